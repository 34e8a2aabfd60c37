"""NumPy's huge-page advice: off for the command line's processes unless the user chose."""

from __future__ import annotations

import os

import numpy as np
import pytest
from typer.testing import CliRunner

from sloshrom._memory import HUGEPAGE_ENV, without_huge_pages


def _toggle():
    core = getattr(np, "_core", None) or np.core
    return core.multiarray._set_madvise_hugepage


@pytest.fixture
def advice():
    """NumPy's advice switched on for the test (as on a Linux host by default), restored after;
    the variable unset."""
    toggle = _toggle()
    before = toggle(True)
    with pytest.MonkeyPatch.context() as mp:
        mp.delenv(HUGEPAGE_ENV, raising=False)
        yield toggle
    toggle(before)


def test_off_in_this_process_and_for_its_children(advice):
    assert without_huge_pages() is True
    assert os.environ[HUGEPAGE_ENV] == "0"  # the Dask workers' NumPy reads it at import
    assert advice(False) is False  # the switch was off already


@pytest.mark.parametrize("choice", ["0", "1"])
def test_the_users_variable_decides(advice, monkeypatch, choice):
    monkeypatch.setenv(HUGEPAGE_ENV, choice)
    assert without_huge_pages() is False
    assert os.environ[HUGEPAGE_ENV] == choice
    assert advice(True) is True  # untouched


def test_the_command_line_turns_it_off(advice):
    from sloshrom.cli import app

    res = CliRunner().invoke(app, ["--version"])
    assert res.exit_code == 0, res.output
    assert os.environ[HUGEPAGE_ENV] == "0"
    assert advice(True) is False
