"""Fixtures shared by the test modules, built once per session.

Shared objects are read-only: their arrays are frozen (``writeable = False``), so a test that
would change one for the others fails where it writes; a test that needs its own copy makes it
(``ModalModel.from_dict(builtin_modal.to_dict())``).
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from helpers import TINY_REPRODUCE, make_model_files, reproduce_interrupted_then_resumed


def _frozen_arrays(obj):
    for f in dataclasses.fields(obj):
        value = getattr(obj, f.name)
        if isinstance(value, np.ndarray):
            value.flags.writeable = False
    return obj


@pytest.fixture(scope="session")
def builtin_modal():
    """The built-in sloshing beam's modal model (paper tank at 50 %, 3 modes)."""
    from sloshrom.beam.structure import ModalModel

    return _frozen_arrays(ModalModel.from_beam())


@pytest.fixture(scope="session")
def model_files(tmp_path_factory):
    """good.npz (a tiny NFIR, 500 Hz, m/s -> N), newer.npz, tampered.npz and text.npz."""
    return make_model_files(tmp_path_factory.mktemp("models"))


@pytest.fixture(scope="session")
def tiny_reproduce(tmp_path_factory) -> dict:
    """`sloshrom reproduce` of ``TINY_REPRODUCE``: interrupted before its maps, resumed with the
    sweep, then rerun without it (everything reused).

    ``out`` (results folder), ``config`` (its TOML file), ``cfg`` (validated), ``resumed`` and
    ``rerun`` (the two summaries), ``html`` (the resumed run's report), ``resumed_log`` and
    ``rerun_log`` (the two commands' output: CliRunner is not a terminal). Read only: copy
    ``out`` to run more stages in it.
    """
    import json

    from typer.testing import CliRunner

    from sloshrom.cli import app
    from sloshrom.pipeline import settings

    d = tmp_path_factory.mktemp("tiny")
    config = d / "tiny.toml"
    config.write_text(TINY_REPRODUCE)
    cfg = settings.load(config)
    out = d / "results"
    logs: list[str] = []
    resumed = reproduce_interrupted_then_resumed(out, cfg, ["--config", str(config), "--sweep"],
                                                 logs)
    html = (out / "report.html").read_text()
    res = CliRunner().invoke(app, ["reproduce", "--config", str(config), "--out", str(out)])
    assert res.exit_code == 0, res.output
    rerun = json.loads((out / "summary.json").read_text())
    return {"out": out, "config": config, "cfg": cfg, "resumed": resumed, "rerun": rerun,
            "html": html, "resumed_log": logs[0], "rerun_log": res.output}
