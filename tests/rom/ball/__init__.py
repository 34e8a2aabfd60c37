"""Tests of sloshrom.rom.ball, laid out like its package."""
