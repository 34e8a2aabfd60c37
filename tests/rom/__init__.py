"""Tests of sloshrom.rom, laid out like its package."""
