"""The version lives in one place (pyproject.toml); the package and the command line read it."""

from __future__ import annotations

import tomllib
from importlib.metadata import version
from pathlib import Path

from typer.testing import CliRunner

import sloshrom
from sloshrom.cli import app

ROOT = Path(__file__).resolve().parents[1]
DECLARED = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["version"]


def test_one_version_everywhere():
    assert version("sloshrom") == DECLARED
    assert sloshrom.__version__ == DECLARED
    for argv in (["--version"], ["version"]):
        result = CliRunner().invoke(app, argv)
        assert result.exit_code == 0, result.output
        assert result.output.strip() == DECLARED


def test_changelog_names_the_version():
    changelog = (ROOT / "CHANGELOG.md").read_text()
    assert changelog.startswith("# Changelog")
    assert f"## [{DECLARED}]" in changelog
