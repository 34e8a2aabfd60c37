"""Sensitivity analysis: grid, results table, resume, unstable flag, Fig. 8 plot."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from sloshrom import rom
from sloshrom.plotting.rom import plot_sweep
from sloshrom.rom import sweep


def _data(n, seed):
    from scipy.signal import butter, filtfilt

    b, a = butter(4, 0.08)
    u = filtfilt(b, a, np.random.default_rng(seed).standard_normal(n))
    lin = np.convolve(np.concatenate([[0.0], u[:-1]]), np.exp(-np.arange(8) / 3.0))[:n]
    return u, np.tanh(lin)


def test_sweep_grid_is_the_paper_grid():
    g = sweep.sweep_grid()
    nfir = [p for p in g if p[0] == "nfir"]
    noe = [p for p in g if p[0] == "noe"]
    assert {p[1] for p in nfir} == {50, 60, 70}
    assert sorted({p[2] for p in nfir}) == [5, 10, 15, 20, 25, 30, 35, 40]
    assert len(nfir) == 24
    assert noe == [("noe", 2, 10), ("noe", 2, 15), ("noe", 2, 20)]
    with pytest.raises(rom.ROMError, match="arch"):
        sweep.sweep_grid("narx")


@pytest.mark.filterwarnings("ignore::sloshrom.rom.EnvelopeWarning")
@pytest.mark.long
def test_sweep_scores_table_resume_and_plot(tmp_path, monkeypatch):
    tr, va = _data(1200, 1), _data(600, 2)
    pts = [("nfir", 3, 2), ("nfir", 5, 3), ("noe", 2, 2)]
    rows = sweep.run_sweep(tr, va, 100.0, tmp_path, pts, scheduler="sequential",
                           options={"max_epochs": 3})
    assert [r["score"] for r in rows] == sorted(r["score"] for r in rows)
    for r in rows:
        m = rom.load_model(tmp_path / r["model"])
        tr_mse = np.mean((m.predict(tr[0]) - tr[1]) ** 2)
        va_mse = np.mean((m.predict(va[0]) - va[1]) ** 2)
        np.testing.assert_allclose(r["score"], 0.5 * (tr_mse + va_mse), rtol=1e-12)
    table = json.loads((tmp_path / "sweep.json").read_text())
    assert {t["name"] for t in table} == {"nfir_d3_n2", "nfir_d5_n3", "noe_d2_n2"}
    assert (tmp_path / "sweep.csv").read_text().startswith("name,arch,delays,neurons")

    # resume: finished points are read back, not retrained
    def boom(*a, **k):
        raise AssertionError("retrained a finished point")

    monkeypatch.setattr(rom.NFIR, "fit", boom)
    monkeypatch.setattr(rom.NOE, "fit", boom)
    again = sweep.run_sweep(tr, va, 100.0, tmp_path, pts, scheduler="threads",
                            options={"max_epochs": 3})
    assert [r["name"] for r in again] == [r["name"] for r in rows]
    assert plot_sweep(again, tmp_path / "fig8.png").stat().st_size > 1000


def test_unstable_noe_is_flagged_not_dropped(tmp_path, monkeypatch):
    def unstable_fit(self, *a, **k):
        raise rom.UnstableModelError("NOE unstable at its initial parameters")

    monkeypatch.setattr(rom.NOE, "fit", unstable_fit)
    tr, va = _data(500, 3), _data(300, 4)
    rows = sweep.run_sweep(tr, va, 100.0, tmp_path, [("noe", 2, 2)], scheduler="sequential")
    assert rows[0]["unstable"] is True and math.isinf(rows[0]["score"])
    assert json.loads((tmp_path / "sweep.json").read_text())[0]["score"] is None
    plot_sweep(rows, tmp_path / "f.png")


@pytest.mark.slow
@pytest.mark.filterwarnings("ignore::sloshrom.rom.EnvelopeWarning")
def test_sweep_through_dask_local_cluster(tmp_path):
    tr, va = _data(800, 5), _data(400, 6)
    pts = [("nfir", 3, 2), ("nfir", 4, 2)]
    rows = sweep.run_sweep(tr, va, 100.0, tmp_path, pts, n_workers=2, options={"max_epochs": 2})
    assert len(rows) == 2 and all(math.isfinite(r["score"]) for r in rows)
    assert (tmp_path / "nfir_d3_n2.npz").is_file()


def test_sweep_starts_the_longest_trainings_first(tmp_path, monkeypatch):
    # the workers finish together when the long points (the NOE's LM, then the largest NFIRs)
    # are not left for the end
    seen = []

    def record(fn, items, **kwargs):
        seen.extend(items)
        return []

    monkeypatch.setattr(sweep, "run_tasks", record)
    pts = [("nfir", 50, 5), ("nfir", 70, 40), ("noe", 2, 10), ("nfir", 60, 20), ("noe", 2, 20)]
    sweep.run_sweep(_data(300, 1), _data(300, 2), 100.0, tmp_path, pts)
    assert seen == [("noe", 2, 20), ("noe", 2, 10), ("nfir", 70, 40), ("nfir", 60, 20),
                    ("nfir", 50, 5)]


def test_an_option_of_one_class_reaches_that_class_alone(tmp_path, monkeypatch):
    # [rom.nfir]'s precision trains the sweep's NFIRs; the NOE, which has none, is built
    # without it (a TypeError before)
    seen = {}

    class Stop(Exception):
        pass

    def fit(self, *a, **k):
        seen[type(self).__name__] = self.get_params()
        raise Stop

    for cls in (rom.NFIR, rom.NOE):
        monkeypatch.setattr(cls, "fit", fit)
    tr, va = _data(600, 1), _data(300, 2)
    for point in (("nfir", 3, 2), ("noe", 2, 2)):
        with pytest.raises(Stop):
            sweep.fit_point(point, tr, va, 100.0, str(tmp_path),
                            {"max_epochs": 3, "precision": "float32"})
    assert seen["NFIR"]["precision"] == "float32" and seen["NFIR"]["max_epochs"] == 3
    assert "precision" not in seen["NOE"] and seen["NOE"]["max_epochs"] == 3
    with pytest.raises(TypeError):  # any other option stays every class's
        sweep.fit_point(("noe", 2, 2), tr, va, 100.0, str(tmp_path), {"delay_s": 1})
