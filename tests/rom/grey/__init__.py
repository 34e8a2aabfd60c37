"""Tests of sloshrom.rom.grey, laid out like its package."""
