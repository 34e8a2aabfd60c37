"""The SUBNET peer benchmark's scoring and table, without torch or deepSI.

``benchmarks/peer_subnet.py`` imports torch and deepSI only when it trains (they live in
``.venv-peers``, not in the package's environment): its module imports here, and its pure
helpers (NRMSE after the encoder window, the fit, our rows from a ``summary.json``, the map
settings of a rig map, the table) are checked on small arrays and dicts.
"""

from __future__ import annotations

import importlib.util
import json
import math
import sys
from pathlib import Path

import numpy as np
import pytest

SCRIPT = Path(__file__).resolve().parents[1] / "benchmarks" / "peer_subnet.py"


@pytest.fixture(scope="module")
def peer():
    spec = importlib.util.spec_from_file_location("peer_subnet", SCRIPT)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def _summary(**extra_stages):
    return {
        "stages": {
            "data": {"train_seconds": 1.0},
            "rom": {"name": "NFIR(70, 35) x 2", "val_fit": 6.86, "val_nrmse": 0.9314,
                    "train_seconds": 166.1},
            "maps": {"rom_fidelity": {"full_l2": 0.123, "dissipative_l2": 0.105,
                                      "n_nonpassive": 0, "n_points": 543}},
            **extra_stages,
        }
    }


def test_importing_the_script_loads_neither_torch_nor_deepsi(peer):
    assert "deepSI" not in sys.modules
    assert peer.SubnetSloshing.force_rule == "trapezoid"


def test_nrmse_leaves_out_the_encoder_window(peer):
    y = np.array([100.0, -100.0, 1.0, -1.0, 1.0, -1.0])
    y_hat = np.array([0.0, 0.0, 1.5, -1.5, 1.5, -1.5])  # wrong in the window: not counted
    # after the window: ||e|| = sqrt(4 * 0.25) = 1, ||y - mean|| = sqrt(4) = 2
    assert peer.nrmse_after_window(y, y_hat, 2) == pytest.approx(0.5)
    assert peer.fit_percent(0.5) == pytest.approx(50.0)
    assert peer.nrmse_after_window(y[2:], y[2:], 0) == 0.0
    # the mean is taken over the scored part only
    assert peer.nrmse_after_window(y + 7.0, y_hat + 7.0, 2) == pytest.approx(0.5)


def test_nrmse_of_the_mean_is_one_and_fit_zero(peer):
    rng = np.random.default_rng(0)
    y = rng.normal(3.0, 2.0, 1000)
    nrmse = peer.nrmse_after_window(y, np.full_like(y, y[50:].mean()), 50)
    assert nrmse == pytest.approx(1.0)
    assert peer.fit_percent(nrmse) == pytest.approx(0.0, abs=1e-9)


def test_nrmse_rejects_bad_shapes_and_windows(peer):
    with pytest.raises(ValueError, match="one shape"):
        peer.nrmse_after_window(np.zeros(5), np.zeros(4), 0)
    with pytest.raises(ValueError, match="no sample"):
        peer.nrmse_after_window(np.zeros(5), np.zeros(5), 5)
    assert math.isnan(peer.nrmse_after_window(np.ones(5), np.zeros(5), 1))


def test_our_rows_read_the_rom_stage_and_its_map_figures(peer, tmp_path):
    path = tmp_path / "summary.json"
    path.write_text(json.dumps(_summary()))
    (row,) = peer.read_our_rows(path)
    assert row["model"] == "NFIR(70, 35) x 2"
    assert row["val_fit"] == 6.86 and row["val_nrmse"] == 0.9314
    assert row["train_seconds"] == 166.1
    assert (row["full_l2"], row["dissipative_l2"]) == (0.123, 0.105)
    assert (row["n_nonpassive"], row["n_points"]) == (0, 543)


def test_our_rows_list_every_rom_stage_and_tolerate_missing_figures(peer):
    rows = peer.our_rows(_summary(rom_noe={"name": "NOE(20, 10)", "val_fit": 40.0},
                                  beam={"val_fit": 1.0}))
    assert [r["model"] for r in rows] == ["NFIR(70, 35) x 2", "NOE(20, 10)"]
    noe = rows[1]
    assert noe["val_nrmse"] is None and noe["full_l2"] is None and noe["n_nonpassive"] is None
    assert peer.our_rows({}) == []


def test_table_prints_percent_and_na(peer):
    rows = [
        {"model": "SUBNET", "val_fit": 41.234, "val_nrmse": 0.58766, "full_l2": 0.2,
         "dissipative_l2": 0.15, "n_nonpassive": 12, "n_points": 543, "train_seconds": 600.4},
        *peer.our_rows(_summary(rom_noe={"name": "NOE", "val_fit": 40.0})),
    ]
    lines = peer.format_table(rows).splitlines()
    assert len(lines) == 2 + len(rows)
    assert lines[0].split()[0] == "model" and "map whole %" in lines[0]
    sub = lines[2].split()
    assert sub == ["SUBNET", "41.2", "0.588", "20.0", "15.0", "12", "/", "543", "600"]
    assert lines[3].split()[-8:] == ["6.9", "0.931", "12.3", "10.5", "0", "/", "543", "166"]
    assert lines[4].split() == ["NOE", "40.0", "n/a", "n/a", "n/a", "n/a", "n/a"]
    assert len({len(line) for line in lines}) == 1  # aligned columns


def test_map_settings_follow_the_rig_map_attributes(peer):
    attrs = {"envelope": "5.0-25.0 Hz, Gamma <= 6.0 g, a_bar <= 0.45", "n_cycles": np.int64(12),
             "n_ramp": 3, "settle_time": np.float64(0.5), "model": "VirtualRig"}
    assert peer.map_settings(attrs) == {"f_min": 5.0, "f_max": 25.0, "gamma_max": 6.0,
                                        "a_bar_max": 0.45, "n_cycles": 12, "n_ramp": 3,
                                        "settle_time": 0.5}
    assert peer.map_settings({}) == {}
