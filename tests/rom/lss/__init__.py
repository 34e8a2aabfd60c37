"""Tests of sloshrom.rom.lss, laid out like its package."""
