"""Short records: the simulated Cascaded Tanks benchmark, the NSS's size rule (the defaults on
a long record, exactly; smaller on a short one; the user's values kept; a warning for a user's
size far beyond the record), its weight decay, and (slow) the acceptance on the short record:
the NSS with its defaults within 20 % of the best size of the sweep
(benchmarks/short_record.py, docs/rom.md, "Short records")."""

from __future__ import annotations

import dataclasses
import warnings

import jax.numpy as jnp
import numpy as np
import optax
import pytest

from sloshrom.rom import NSS, ModelSizeWarning, load_model
from sloshrom.rom.nss.entry import NSS_CLASS, NSS_FULL_SIZE_SAMPLES, NSS_SHORT_SIZE, nss_size
from sloshrom.rom.nss.training import NSS_SHOOTING
from sloshrom.rom.shooting import ShootingOptions, adam_optimizer
from sloshrom.systems.tanks import (
    TankParameters,
    cascaded_tanks,
    simulate_tanks,
    steady_levels,
)

TS = 4.0


@pytest.fixture(scope="module")
def tanks():
    return cascaded_tanks(seed=0)


# -- the system ---------------------------------------------------------------------------------
def test_the_levels_settle_where_inflow_equals_outflow():
    p = TankParameters()
    u = 4.0  # below the overflow: h1 = (k4 u / k1)^2 = 4.84 V
    h = simulate_tanks(np.full(600, u), TS, p)  # 40 min, 30 time constants
    h1, h2 = steady_levels(u, p)
    assert h1 == pytest.approx((p.k4 * u / p.k1) ** 2)
    assert h2 == pytest.approx((p.k2 / p.k3) ** 2 * h1)
    np.testing.assert_allclose(h[-1], [h1, h2], rtol=1e-3)
    assert 0.0 < h[100, 1] < h[-1, 1]  # it fills from empty


def test_a_full_upper_tank_overflows_and_part_of_the_spill_reaches_the_lower():
    p = TankParameters()
    u = 6.5  # steady level (k4 u / k1)^2 = 12.8 V, above the top
    h = simulate_tanks(np.full(600, u), TS, p)
    assert h[:, 0].max() == p.h_max and np.all(h <= p.h_max)
    # the lower tank's steady level with the spill k5 (k4 u - k1 sqrt(h_max)) falling in:
    # 9.4 V, where without the spill it would be (k2 / k3)^2 h_max = 8.5 V
    spill = p.k4 * u - p.k1 * np.sqrt(p.h_max)
    h2 = ((p.k2 * np.sqrt(p.h_max) + p.k5 * spill) / p.k3) ** 2
    assert h2 < p.h_max
    assert h[-1, 1] == pytest.approx(h2, rel=1e-3)
    assert h[-1, 1] > (p.k2 / p.k3) ** 2 * p.h_max + 0.5


def test_the_records_are_the_benchmark_s_shape(tanks):
    est, test = tanks
    for r in (est, test):
        assert len(r) == 1024 and r.fs == pytest.approx(0.25)
        assert r.units["u"] == "V" and r.units["y"] == "V"
        assert 0.0 <= r["u"].min() and r["u"].max() <= 10.0
        assert r["y"].max() < 10.5
    assert est.attrs["overflow_fraction"] > 0.01  # the hard nonlinearity is in the data
    assert est.attrs["initial_levels"] == [0.0, 0.0]
    assert min(test.attrs["initial_levels"]) > 1.0  # the test starts far from rest
    assert abs(test["y"][0]) > 1.0


def test_one_seed_one_record():
    a, b = cascaded_tanks(seed=3, n=256, warmup=32)
    c, d = cascaded_tanks(seed=3, n=256, warmup=32)
    e, _ = cascaded_tanks(seed=4, n=256, warmup=32)
    np.testing.assert_array_equal(a["y"], c["y"])
    np.testing.assert_array_equal(b["u"], d["u"])
    assert not np.allclose(a["u"], e["u"])


# -- the size rule ------------------------------------------------------------------------------
def test_the_rule_keeps_the_defaults_on_a_long_record():
    d = NSS_CLASS.defaults()
    sized = {k: d[k] for k in NSS_CLASS.sized_by_record}
    for n in (NSS_FULL_SIZE_SAMPLES, 240_000, 10**7):
        assert nss_size(n, {}) == sized
        assert NSS_CLASS.size(n, {}) == sized
    # and so does the estimator left at its defaults: the sloshing pipeline's NSS
    assert NSS()._sizes(240_000) == sized
    assert NSS()._check_hyperparameters(240_000) == NSS(**sized)._check_hyperparameters()
    assert NSS().effective_params() == {**NSS().get_params(), **sized}


def test_the_rule_sizes_a_short_record_smaller_and_monotonically():
    d = NSS_CLASS.defaults()
    assert nss_size(819, {}) == {**NSS_SHORT_SIZE, "horizon": 200}  # the recipe's horizon
    sizes = [NSS_CLASS.n_params({**d, **nss_size(n, {})})
             for n in (819, 3000, 10_000, 50_000, 240_000)]
    assert sizes == sorted(sizes) and sizes[0] < sizes[-1] / 10
    for n in (819, 5000, 60_000):
        h = nss_size(n, {})
        assert all(h[k] <= d[k] for k in NSS_SHORT_SIZE)
        assert h["window"] + h["horizon"] + 1 <= n  # trainable
    # a record too short for the anchor's horizon: the horizon leaves half of it as starts
    assert nss_size(80, {})["horizon"] == (80 - NSS_SHORT_SIZE["window"]) // 2
    assert nss_size(80, {"window": 30})["horizon"] == 25


def test_the_user_s_values_win():
    h = nss_size(819, {"n_states": 8, "horizon": 150})
    assert "n_states" not in h and "horizon" not in h
    assert h["neurons"] == NSS_SHORT_SIZE["neurons"]
    m = NSS(n_states=6, window=20)
    assert m._sizes(819)["n_states"] == 6 and m._sizes(819)["window"] == 20
    assert m._sizes(819)["neurons"] == NSS_SHORT_SIZE["neurons"]
    assert m._check_hyperparameters(819).n_states == 6


def test_a_user_size_far_beyond_the_record_is_warned_of_with_a_suggestion():
    d = NSS_CLASS.defaults()
    full = {k: d[k] for k in NSS_CLASS.sized_by_record}
    msg = NSS_CLASS.oversize(full, 819)
    assert msg is not None and "8913 parameters for 819 training samples" in msg
    assert "0.092 samples per parameter" in msg and "--n-states 4" in msg
    assert NSS_CLASS.oversize(full, 240_000) is None
    assert NSS_CLASS.oversize(nss_size(819, {}), 819) is None


def _short(n: int = 400, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    est, _ = cascaded_tanks(seed=seed, n=n, warmup=0)
    return np.asarray(est["u"]), np.asarray(est["y"])


def test_fit_sizes_records_and_saves_the_chosen_size(tmp_path):
    u, y = _short()
    with warnings.catch_warnings():
        warnings.simplefilter("error", ModelSizeWarning)  # the rule's size is not warned of
        # no epoch: the size is chosen before the training
        m = NSS(max_epochs=0, units=("V", "V"), names=("u", "y")).fit(u, y, 1 / TS)
    assert m.spec.n_states == 4 and m.spec.neurons == 16 and m.spec.window == 10
    # the horizon shortened to leave half of the 400 samples as starts
    assert m.sized_["horizon"] == 195 and m.n_states is None  # the argument stays "sized"
    assert m.sizing_.startswith("NSS sized for 400 samples: 4 states, 16 neurons, window 10")
    back = load_model(m.save(tmp_path / "m.npz"))
    assert back.get_params() == m.effective_params()
    np.testing.assert_array_equal(back.predict(u), m.predict(u))


def test_fit_warns_of_a_user_size_far_beyond_the_record():
    u, y = _short()
    with pytest.warns(ModelSizeWarning, match="samples per parameter"):
        m = NSS(n_states=8, neurons=64, window=50, max_epochs=0, units=("V", "V"),
                names=("u", "y")).fit(u, y, 1 / TS)
    assert m.sizing_ is not None and "horizon 175" in m.sizing_  # (400 - 50) // 2
    assert m.spec.n_states == 8 and m.effective_params()["horizon"] == 175


# -- weight decay --------------------------------------------------------------------------------
def test_weight_decay_shrinks_the_weights_where_the_gradient_is_zero():
    p = {"W": jnp.array([[1.0, -2.0], [0.5, 4.0]])}
    zero = {"W": jnp.zeros((2, 2))}
    for wd in (0.0, 0.5):
        opt = adam_optimizer(dataclasses.replace(NSS_SHOOTING, learning_rate=1e-2, weight_decay=wd))
        upd, _ = opt.update(zero, opt.init(p), p)
        new = optax.apply_updates(p, upd)
        # AdamW: p - lr wd p (Adam's own step is zero for a zero gradient)
        np.testing.assert_allclose(new["W"], p["W"] * (1 - 1e-2 * wd), rtol=1e-6)


def test_weight_decay_reaches_the_nss_training(monkeypatch):
    import sloshrom.rom.nss.estimator as est

    seen = []

    def capture(spec, u, y, fs, scaler, validation, options, **kw):
        seen.append(options)
        raise KeyboardInterrupt  # the options are all this test needs

    monkeypatch.setattr(est, "fit_statespace", capture)
    u, y = _short()
    for wd in (0.0, 0.25):
        with pytest.raises(KeyboardInterrupt):
            NSS(weight_decay=wd, units=("V", "V"), names=("u", "y")).fit(u, y, 1 / TS)
    assert [o.weight_decay for o in seen] == [0.0, 0.25]
    assert adam_optimizer(seen[1]) is not None
    assert NSS(weight_decay=0.25).effective_params()["weight_decay"] == 0.25


def test_weight_decay_is_a_registry_option_old_files_read_as_zero():
    h = NSS_CLASS.hyper_named("weight_decay")
    assert h.default == 0.0 and h.file_default == 0.0 and h.option == "--weight-decay"
    assert 5 in NSS_CLASS.read_versions and NSS_CLASS.format_version == 6
    assert dataclasses.fields(ShootingOptions)[-1].name == "weight_decay"


# -- acceptance (slow) ----------------------------------------------------------------------------
@pytest.mark.slow
def test_the_defaults_fit_a_short_record():
    """The NSS with every size option left out, on the short record (819 training samples):
    the median test RMSE over 3 seeds within 20 % of the sweep's best median
    (docs/rom.md, "Short records"), and well below the unsized defaults'."""
    import importlib.util
    from pathlib import Path

    path = Path(__file__).resolve().parents[3] / "benchmarks" / "short_record.py"
    spec = importlib.util.spec_from_file_location("short_record", path)
    assert spec is not None and spec.loader is not None
    sr = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(sr)
    est, test = cascaded_tanks(seed=0)
    rmse = [sr.run_point({}, seed, est, test, True)["test_rmse"] for seed in (0, 1, 2)]
    assert float(np.median(rmse)) <= 1.2 * sr.BEST_SWEEP_RMSE, rmse


# -- the command line -----------------------------------------------------------------------------
def test_train_sizes_a_short_record_and_warns_of_a_size_too_big(tmp_path):
    from typer.testing import CliRunner

    from sloshrom.cli import app
    from sloshrom.io import write_record

    est, test = cascaded_tanks(seed=0, n=400, warmup=64)
    data, val = write_record(est, tmp_path / "e.nc"), write_record(test, tmp_path / "t.nc")
    base = ["train", "--data", str(data), "--validation", str(val), "--arch", "nss",
            "--input", "u", "--output", "y", "--max-epochs", "0", "--history", "30"]
    # the size left out: its line; the size given (the window too): the warning
    res = CliRunner().invoke(app, [*base, "--n-states", "8", "--neurons", "64", "--window",
                                   "25", "--weight-decay", "0.1", "--out",
                                   str(tmp_path / "b.npz")])
    assert res.exit_code == 0, res.output
    assert "NSS sized for 400 samples: horizon 187 (" in res.output  # (400 - 25) // 2
    assert "warning: NSS(8 states, 64 neurons) has" in res.output
    assert "samples per parameter" in res.output and "--n-states 4" in res.output
    m = load_model(tmp_path / "b.npz")
    assert (m.n_states, m.window, m.horizon, m.weight_decay) == (8, 25, 187, 0.1)


def test_the_registry_s_records_split_the_estimation_record():
    from sloshrom.systems.tanks import HISTORY, tank_records

    r = tank_records(seed=1, n=300, warmup=40)
    assert list(r)[:3] == ["train", "validation", "test"]
    assert len(r["train"]) == 240 and len(r["validation"]) == 60 + HISTORY
    np.testing.assert_array_equal(r["validation"]["y"][:HISTORY], r["train"]["y"][-HISTORY:])
    np.testing.assert_array_equal(r["validation"]["u"][HISTORY:], r["estimation"]["u"][240:])


def test_a_model_rebuilt_from_its_leaves_keeps_its_size():
    import jax

    u, y = _short()
    m = NSS(max_epochs=0, units=("V", "V"), names=("u", "y")).fit(u, y, 1 / TS)
    leaves, tree = jax.tree_util.tree_flatten(m)
    back = jax.tree_util.tree_unflatten(tree, leaves)
    assert back.effective_params()["n_states"] == 4 == back.spec.n_states
    assert m.set_params(n_states=5).effective_params()["n_states"] == 5  # the user's, now
