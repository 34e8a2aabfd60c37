"""Tests of sloshrom.rom.tdnn, laid out like its package."""
