"""Tests of sloshrom.rom.nss, laid out like its package."""
