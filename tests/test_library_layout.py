"""The library's shape: no CLI in the library, no backend selection, one way to save figures,
beam results and analysis errors shared by the CLI and the pipeline."""

from __future__ import annotations

import ast
import functools
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from matplotlib.figure import Figure

from sloshrom.beam.damping.analysis import AnalysisError, half_power_damping, modal_filter
from sloshrom.beam.damping.tables import damping_by_band, mode1_damping_table
from sloshrom.beam.errors import BeamError
from sloshrom.beam.results import write_table
from sloshrom.beam.simulation.cases import case_output_fs
from sloshrom.config import ConfigError
from sloshrom.fileio import OutputBatch
from sloshrom.models import FrozenLiquid
from sloshrom.pipeline import settings
from sloshrom.plotting import render_png, savefig

SRC = Path(__file__).parents[1] / "src" / "sloshrom"


@functools.cache
def _modules() -> tuple[tuple[str, ast.Module], ...]:
    """Every module of the package and its syntax tree, parsed once (seconds) for the tests
    below, which only walk them."""
    return tuple((str(p.relative_to(SRC)), ast.parse(p.read_text(encoding="utf-8")))
                 for p in sorted(SRC.rglob("*.py")))


def _imports(tree: ast.Module) -> list[tuple[str, list[str]]]:
    out = []
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom) and node.module:
            out.append((node.module, [a.name for a in node.names]))
        elif isinstance(node, ast.Import):
            out += [(a.name, []) for a in node.names]
    return out


def test_only_the_cli_imports_the_cli():
    bad = [(name, mod) for name, tree in _modules() if not name.startswith("cli/")
           for mod, _ in _imports(tree) if mod.startswith("sloshrom.cli")]
    assert not bad, bad


def test_no_backend_selection_and_no_pyplot_in_the_library():
    for name, tree in _modules():
        mods = [m for m, _ in _imports(tree)]
        assert "matplotlib.pyplot" not in mods, name
        for node in ast.walk(tree):
            if isinstance(node, ast.Attribute) and node.attr == "use":
                assert not (isinstance(node.value, ast.Name) and node.value.id == "matplotlib"), \
                    name


@pytest.mark.parametrize("room", ["pipeline/", "plotting/", "beam/", "cli/"])
def test_no_private_name_is_imported_across_modules(room):
    bad = [(name, mod, n) for name, tree in _modules() if name.startswith(room)
           for mod, names in _imports(tree) if mod.startswith("sloshrom")
           for n in names if n.startswith("_") and not n.startswith("__")]
    assert not bad, bad


def test_cli_start_up_loads_no_heavy_library():
    code = ("import sys, sloshrom.cli; "
            "print(sorted(m for m in ('jax', 'matplotlib', 'xarray', 'numba') "
            "if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True)
    assert out.stdout.strip() == "[]", out.stdout


def test_savefig_is_atomic_and_joins_a_batch(tmp_path):
    fig = Figure(figsize=(2, 2))
    fig.subplots().plot([0, 1], [1, 0])
    p = savefig(fig, tmp_path / "sub" / "a.png")
    assert p.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    with pytest.raises(OSError), OutputBatch() as batch:
        savefig(fig, tmp_path / "b.png", batch)
        assert not (tmp_path / "b.png").exists()  # not before the batch commits
        raise OSError("disk full")
    assert sorted(f.name for f in tmp_path.rglob("*") if f.is_file()) == ["a.png"]
    # drawn now, written later (in a batch or not): the same file
    png = render_png(fig)
    assert savefig(png, tmp_path / "c.png").read_bytes() == png == p.read_bytes()
    with OutputBatch() as batch:
        savefig(png, tmp_path / "d.png", batch)
    assert (tmp_path / "d.png").read_bytes() == png


def test_analysis_errors_are_package_errors():
    psi = np.array([[1.0, 2.0], [2.0, 4.0], [3.0, 6.0]])  # two identical mode shapes
    with pytest.raises(AnalysisError, match="independent"):
        modal_filter(np.zeros((10, 3)), psi)
    with pytest.raises(AnalysisError, match="too few"):
        half_power_damping(np.arange(3.0), np.ones(3), (0.0, 2.0))
    # a malformed argument is the room's BeamError (a ValueError), not an AnalysisError
    with pytest.raises(BeamError, match="n_stations") as info:
        modal_filter(np.zeros((10, 2)), psi)
    assert not isinstance(info.value, AnalysisError)


@pytest.mark.long  # 2.7-3.1 s in the fast tier (2026-12-07)
def test_table2_columns_and_banded_damping(tmp_path):
    fs, f1, zeta = 500.0, 10.0, 0.02
    rng = np.random.default_rng(0)
    base = rng.standard_normal(2 * 16384)
    # the tank: a single 10 Hz mode driven by the base (discretised by the impulse invariance)
    from scipy import signal

    wn = 2 * np.pi * f1
    sys_d = signal.cont2discrete(([wn**2], [1, 2 * zeta * wn, wn**2]), 1 / fs, method="impulse")
    tank = signal.lfilter(np.ravel(sys_d[0]), sys_d[1], base)
    res = {"rig": {"base_acceleration": base[None], "tank_acceleration": tank[None], "fs": fs}}
    plain = mode1_damping_table(res, [0.1], f1)
    full = mode1_damping_table(res, [0.1], f1, max_tank_acceleration=True)
    assert list(plain[0])[:2] == ["case", "rms_g"]
    assert list(full[0])[:3] == ["case", "rms_g", "max_tank_acceleration_g"]
    assert full[0]["lscf_h1"] == pytest.approx(zeta, rel=0.3)
    csv, md = write_table(full, tmp_path / "t2")
    assert csv.read_text().splitlines()[0] == ",".join(full[0])
    assert md.suffix == ".md"
    bands = damping_by_band(np.full(100, 0.01), np.linspace(0.5, 0.99, 100))
    assert bands["0.5-1 g"] == pytest.approx(0.01) and np.isnan(bands["1-2 g"])


def test_case_output_fs():
    assert case_output_fs(FrozenLiquid(1e-4), 500.0) == 500.0  # the rig's step: decimated
    assert case_output_fs(FrozenLiquid(1 / 500.0), 500.0) is None  # already at the rate


def test_run_validates_before_writing_anything(tmp_path):
    from sloshrom.pipeline import run

    cfg = settings.defaults()
    cfg["beam"]["rms_g"] = []
    with pytest.raises(ConfigError, match=r"beam\.rms_g"):
        run(tmp_path / "out", cfg)
    assert not (tmp_path / "out").exists()


def test_beam_cli_analysis_error_is_one_line(tmp_path, monkeypatch):
    from typer.testing import CliRunner

    import sloshrom.beam.damping.tables
    from sloshrom.cli import app

    def bad(*args, **kwargs):
        raise AnalysisError("mode shapes at the stations are not independent")

    monkeypatch.setattr(sloshrom.beam.damping.tables, "mode1_decay", bad)
    out = tmp_path / "res"
    res = CliRunner().invoke(app, ["beam", "free", "--sloshing", "frozen", "--duration", "2",
                                   "--out", str(out)])
    assert res.exit_code == 2, res.output
    assert "error: damping analysis of mode 1: mode shapes" in res.output
    assert res.exception is None or isinstance(res.exception, SystemExit)
    assert not [p for p in tmp_path.rglob("*") if p.is_file()]
