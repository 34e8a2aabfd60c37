"""Fixtures shared by the test modules, built once per session.

Shared objects are read-only: their arrays are frozen (``writeable = False``), so a test that
would change one for the others fails where it writes; a test that needs its own copy makes it
(``ModalModel.from_dict(builtin_modal.to_dict())``).
"""

from __future__ import annotations

import dataclasses
import functools
import os
import shutil
import tempfile

#: XLA's persistent compilation cache, one temporary folder a run (outside the tree, removed at
#: the end): a computation compiled once is loaded by the other xdist worker, by the same
#: worker's next identical computation under a new ``jax.jit`` (each ``fit`` traces its own), and
#: by the ``sloshrom`` subprocesses the tests start (they inherit the environment). JAX keys an
#: entry on the computation itself (its canonical IR), jaxlib's version, the backend, the XLA
#: flags (``XLA_FLAGS``) and the compile options, so an entry is never used for another
#: computation; and the folder is new each run, so nothing of an earlier run (another checkout,
#: package version or machine) is read.
#: Set before JAX is imported (``helpers`` imports it); the xdist workers inherit it.
JAX_CACHE = "JAX_COMPILATION_CACHE_DIR"
_OWN_JAX_CACHE = JAX_CACHE not in os.environ and "PYTEST_XDIST_WORKER" not in os.environ
if _OWN_JAX_CACHE:
    os.environ[JAX_CACHE] = tempfile.mkdtemp(prefix="sloshrom-tests-jax-")
    os.environ["JAX_PERSISTENT_CACHE_MIN_COMPILE_TIME_SECS"] = "0"
    os.environ["JAX_PERSISTENT_CACHE_MIN_ENTRY_SIZE_BYTES"] = "0"

import numpy as np  # noqa: E402
import pytest  # noqa: E402
import typer.testing  # noqa: E402

from helpers import (  # noqa: E402
    TINY_REPRODUCE,
    figure_axes,
    make_model_files,
    reproduce_interrupted_then_resumed,
)

# typer builds the app's Click command again at every ``CliRunner.invoke`` (5-10 ms a call;
# tests/test_hostile_cli.py alone makes 473): once a process instead, for every runner of the
# tests. The command keeps nothing of a run: each invocation makes its own context.
if hasattr(typer.testing, "_get_command"):
    typer.testing._get_command = functools.cache(typer.testing._get_command)

#: session fixtures too costly to build once per pytest-xdist worker
SHARED_ON_ONE_WORKER = ("tiny_reproduce",)
#: fixtures whose build alone takes tens of seconds: every test that needs one is a ``long``
#: test (`make test-long`), so that the fast tier never builds them
LONG_FIXTURES = ("tiny_reproduce",)


@pytest.hookimpl(tryfirst=True)  # before ``-m`` selects by the marks
def pytest_collection_modifyitems(config, items):
    """Mark ``long`` every test that needs one of ``LONG_FIXTURES`` (directly or through
    another fixture)."""
    for item in items:
        if any(name in getattr(item, "fixturenames", ()) for name in LONG_FIXTURES):
            item.add_marker(pytest.mark.long)


@pytest.hookimpl(optionalhook=True)  # a pytest-xdist hook: without xdist it is never called
def pytest_xdist_make_scheduler(config, log):
    """``--dist loadfile`` (`make test`), where the test files that use one of
    ``SHARED_ON_ONE_WORKER`` are one unit: that fixture is built on one worker, not on each.

    Every test file is one unit of work, as with xdist's own loadfile, so that a module-scoped
    fixture is built once too. (Grouping by the ``xdist_group`` mark, ``--dist loadgroup``, does
    nothing with pytest 9.2: pytest-xdist issue 1386.)
    """
    if config.getvalue("dist") != "loadfile":
        return None
    from xdist.scheduler import LoadFileScheduling

    root = config.rootpath
    # every test module, at any depth (tests/beam/...: laid out like the package)
    shared = {name: {p.relative_to(root).as_posix() for p in (root / "tests").rglob("test_*.py")
                     if name in p.read_text(encoding="utf-8")}
              for name in SHARED_ON_ONE_WORKER}

    class SharedFixtureScheduling(LoadFileScheduling):
        def _split_scope(self, nodeid):
            path = super()._split_scope(nodeid)
            return next((name for name, files in shared.items() if path in files), path)

        def _assign_work_unit(self, node):
            # the shared units are the largest: first, then xdist's order (most tests first)
            for name in reversed(SHARED_ON_ONE_WORKER):
                if name in self.workqueue:
                    self.workqueue.move_to_end(name, last=False)
            super()._assign_work_unit(node)

    return SharedFixtureScheduling(config, log)


def pytest_configure(config):
    """typer's ``CliRunner.invoke`` builds the whole command tree anew on every call, and
    reads the signature of each of the ~40 commands again (``eval`` of every annotation: about
    60 ms a call, half the time of the bad-input suites). Read each function's signature once:
    the commands are still built and run as the ``sloshrom`` script builds them.
    """
    import functools

    import typer.main

    read = getattr(typer.main, "get_params_from_function", None)
    if read is None or hasattr(read, "cache_info"):
        return
    once = functools.lru_cache(maxsize=None)(read)
    typer.main.get_params_from_function = lambda func: dict(once(func))


def _frozen_arrays(obj):
    for f in dataclasses.fields(obj):
        value = getattr(obj, f.name)
        if isinstance(value, np.ndarray):
            value.flags.writeable = False
    return obj


@pytest.fixture(scope="session")
def builtin_modal():
    """The built-in sloshing beam's modal model (paper tank at 50 %, 3 modes)."""
    from sloshrom.beam.simulation.structure import ModalModel

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
    ``rerun_log`` (the two commands' output: CliRunner is not a terminal), ``figures`` (each
    figure the runs wrote, as :func:`helpers.figure_axes` reads it). Read only: copy ``out`` to
    run more stages in it.
    """
    import json

    from matplotlib.figure import Figure
    from typer.testing import CliRunner

    from sloshrom.cli import app
    from sloshrom.pipeline import settings

    d = tmp_path_factory.mktemp("tiny")
    config = d / "tiny.toml"
    config.write_text(TINY_REPRODUCE)
    cfg = settings.load(config)
    out = d / "results"
    logs: list[str] = []
    figures: list[dict] = []
    save = Figure.savefig

    def recorded(fig, *args, **kwargs):  # what each written figure shows on its axes
        figures.append(figure_axes(fig))
        return save(fig, *args, **kwargs)

    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(Figure, "savefig", recorded)
        resumed = reproduce_interrupted_then_resumed(
            out, cfg, ["--config", str(config), "--sweep"], logs)
    html = (out / "report.html").read_text()
    res = CliRunner().invoke(app, ["reproduce", "--config", str(config), "--out", str(out)])
    assert res.exit_code == 0, res.output
    rerun = json.loads((out / "summary.json").read_text())
    return {"out": out, "config": config, "cfg": cfg, "resumed": resumed, "rerun": rerun,
            "html": html, "resumed_log": logs[0], "rerun_log": res.output, "figures": figures}


def pytest_unconfigure(config):
    if _OWN_JAX_CACHE:
        shutil.rmtree(os.environ.pop(JAX_CACHE), ignore_errors=True)
