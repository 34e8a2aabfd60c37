"""NFIR/NOE models: equations, contract, save/load, envelope, bad input."""

from __future__ import annotations

import json
import warnings

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from sloshrom import rom
from sloshrom.rom import modelfile
from sloshrom.rom.errors import UnstableModelError
from sloshrom.rom.modelfile import ModelFileError
from sloshrom.rom.network import MinMaxScaler
from sloshrom.rom.tdnn.estimators import NFIR, NOE


def _random_model(cls, seed=0, **kw):
    """A 'fitted' model with random parameters (no training needed for structural tests)."""
    m = cls(**kw)
    rng = np.random.default_rng(seed)
    h, d = m.neurons, m.n_inputs
    params = {
        "W": rng.standard_normal((h, d)),
        "b": rng.standard_normal(h),
        "c": rng.standard_normal(h),
        "c0": np.float64(rng.standard_normal()),
    }
    envelope = {"input_min": -0.5, "input_max": 0.7, "output_min": -3.0, "output_max": 2.0,
                "frequency_band": [5.0, 25.0]}
    history = {"train_mse": [1.0], "val_mse": [1.0], "stop_reason": "test"}
    return cls.fitted(params, MinMaxScaler(-0.5, 0.7, -3.0, 2.0), 500.0, envelope, history,
                      **m.get_params())


def test_nfir_70_35_has_2521_parameters():
    assert NFIR(delays=70, neurons=35).n_params == 2521
    assert NFIR().n_params == 2521
    m = _random_model(NFIR, delays=70, neurons=35)
    assert rom.pack(m.params_).size == 2521
    assert NOE(delays=2, neurons=10).n_params == 10 * 4 + 21


@jax.enable_x64(True)  # the pure network functions follow the caller's precision
def test_radbasn_equation_matlab_and_distance():
    rng = np.random.default_rng(1)
    W, b, c, c0 = rng.standard_normal((4, 3)), rng.standard_normal(4), rng.standard_normal(4), 0.3
    x = rng.standard_normal(3)
    n = W @ x + b
    a = np.exp(-(n**2)) / np.sum(np.exp(-(n**2)))
    p = {"W": W, "b": b, "c": c, "c0": c0}
    np.testing.assert_allclose(rom.rbf_apply(p, x, "matlab"), a @ c + c0, rtol=1e-13)
    n = b * np.linalg.norm(x - W, axis=1)
    a = np.exp(-(n**2)) / np.sum(np.exp(-(n**2)))
    np.testing.assert_allclose(rom.rbf_apply(p, x, "distance"), a @ c + c0, rtol=1e-12)
    # log-sum-exp stable: huge n does not give NaN
    big = {"W": 1e6 * W, "b": b, "c": c, "c0": c0}
    assert np.isfinite(rom.rbf_apply(big, x, "matlab"))


@jax.enable_x64(True)  # rbf_apply and step are JAX functions in the caller's precision
def test_nfir_predict_matches_regressor_formula_and_step_contract():
    m = _random_model(NFIR, delays=[1, 3, 4], neurons=5)
    u = np.random.default_rng(2).uniform(-0.4, 0.6, 50)
    y = m.predict(u)
    us = m.scaler_.u(u)
    rest = m.scaler_.u(0.0)
    up = np.concatenate([np.full(4, rest), us])
    for k in (0, 1, 7, 49):
        x = np.array([up[4 + k - d] for d in (1, 3, 4)])
        ys = rom.rbf_apply(m.params_, x, "matlab")
        np.testing.assert_allclose(y[k], m.scaler_.y_inverse(ys), rtol=1e-12)
    # the contract: jax-traceable step inside lax.scan gives the same
    state, ys = jax.lax.scan(lambda s, v: m.step(s, v, 0.0), m.init_state(), jnp.asarray(u))
    np.testing.assert_allclose(np.asarray(ys), y, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(m.simulate(u, np.zeros_like(u)), y)
    assert m.dt == 1 / 500.0


def test_noe_simulation_matches_hand_rolled_loop():
    m = _random_model(NOE, seed=3, delays=[1, 2, 3], neurons=4, out_delays=2)
    u = np.random.default_rng(4).uniform(-0.5, 0.7, 60)
    y = m.predict(u)
    sc = m.scaler_
    ub = [sc.u(0.0)] * 3  # most recent first
    yb = [sc.y(0.0)] * 2
    out = []
    for uk in u:
        x = np.array(ub + yb)
        n = m.params_["W"] @ x + m.params_["b"]
        a = np.exp(-(n**2)) / np.exp(-(n**2)).sum()
        yk = a @ m.params_["c"] + m.params_["c0"]
        out.append(sc.y_inverse(yk))
        ub = [sc.u(uk)] + ub[:-1]
        yb = [yk] + yb[:-1]
    np.testing.assert_allclose(y, out, rtol=1e-12)
    with jax.enable_x64(True):
        state, ys = jax.lax.scan(lambda s, v: m.step(s, v, 0.0), m.init_state(),
                                 jnp.asarray(u))
    np.testing.assert_allclose(np.asarray(ys), out, rtol=1e-12)


def test_batched_predict_equals_rows():
    for cls in (NFIR, NOE):
        m = _random_model(cls, delays=3, neurons=4)
        u = np.random.default_rng(5).uniform(-0.5, 0.7, (3, 40))
        yb = m.predict(u)
        assert yb.shape == (3, 40)
        for i in range(3):
            np.testing.assert_allclose(yb[i], m.predict(u[i]), rtol=1e-13)


def test_unstable_noe_detected():
    m = _random_model(NOE, delays=2, neurons=4)
    m.params_["c"] = m.params_["c"] * 1e3  # output far beyond the training range
    with pytest.raises(UnstableModelError, match="unstable"):
        m.predict(np.linspace(-0.4, 0.6, 30))
    m.params_["c"][0] = np.nan
    with pytest.raises(UnstableModelError):
        m.predict(np.linspace(-0.4, 0.6, 30))


@pytest.mark.parametrize("cls", [NFIR, NOE])
def test_save_load_roundtrip_identical_predictions(tmp_path, cls):
    m = _random_model(cls, delays=4, neurons=3, hidden="distance")
    p = m.save(tmp_path / "model.npz")
    assert p.exists() and not list(tmp_path.glob(".*"))  # no temporary left behind
    m2 = rom.load_model(p)
    assert type(m2) is cls and m2.get_params() == m.get_params()
    u = np.random.default_rng(6).uniform(-0.5, 0.7, 100)
    np.testing.assert_array_equal(m.predict(u), m2.predict(u))
    assert m2.fs_ == 500.0 and m2.envelope_ == m.envelope_ and m2.history_ == m.history_
    from sloshrom import __version__

    with np.load(p, allow_pickle=False) as z:
        meta = json.loads(str(z["metadata"]))
    assert meta["sloshrom_version"] == __version__ and meta["format_version"] == 1
    assert meta["units"] == {"input": "m/s", "output": "N"}


def _rewrite(path, meta=None, **arrays):
    with np.load(path, allow_pickle=False) as z:
        files = dict(z.items())
    if meta is not None:
        files["metadata"] = np.array(json.dumps(meta))
    files.update(arrays)
    np.savez(path, **files)


def test_load_errors(tmp_path):
    m = _random_model(NFIR, delays=4, neurons=3)
    p = m.save(tmp_path / "m.npz")
    meta = json.loads(str(np.load(p)["metadata"]))
    with pytest.raises(ModelFileError, match="no such"):
        rom.load_model(tmp_path / "missing.npz")
    bad = tmp_path / "bad.npz"
    bad.write_text("hello")
    with pytest.raises(ModelFileError, match="not a sloshrom model"):
        rom.load_model(bad)
    np.savez(tmp_path / "other.npz", x=np.ones(3))
    with pytest.raises(ModelFileError, match="not a sloshrom model"):
        rom.load_model(tmp_path / "other.npz")
    _rewrite(p, {**meta, "format_version": modelfile.NEWEST_FORMAT_VERSION + 1})
    with pytest.raises(ModelFileError, match="newer"):
        rom.load_model(p)
    _rewrite(p, {**meta, "format_version": 0})
    with pytest.raises(ModelFileError, match="unsupported format version"):
        rom.load_model(p)
    _rewrite(p, meta, W=np.ones((3, 5)))
    with pytest.raises(ModelFileError, match="tampered"):
        rom.load_model(p)
    # same shapes, changed values: caught by the checksum
    good = m.save(tmp_path / "good.npz")
    with np.load(good) as z:
        arrays = {k: z[k] for k in modelfile.PARAM_NAMES}
    arrays["W"] = arrays["W"] + 1e-9
    _rewrite(good, meta, **arrays)
    with pytest.raises(ModelFileError, match="checksum mismatch"):
        rom.load_model(good)
    # object arrays would need pickle: refused, with a message that does not advise pickle
    np.savez(tmp_path / "obj.npz", metadata=np.array([{"a": 1}], dtype=object))
    with pytest.raises(ModelFileError, match="never loads") as err:
        rom.load_model(tmp_path / "obj.npz")
    assert "allow_pickle" not in str(err.value)


def test_checksum_detects_changed_metadata(tmp_path):
    m = _random_model(NFIR, delays=4, neurons=3)
    p = m.save(tmp_path / "m.npz")
    with np.load(p) as z:
        meta = json.loads(str(z["metadata"]))
        arrays = {k: z[k] for k in modelfile.PARAM_NAMES}
    assert meta["checksum"].startswith("sha256:")
    assert rom.load_model(p).fs_ == m.fs_
    _rewrite(p, {**meta, "fs": meta["fs"] * 2}, **arrays)
    with pytest.raises(ModelFileError, match="checksum mismatch"):
        rom.load_model(p)


def test_envelope_warning_with_amount_and_predict_leaves_the_model_unchanged():
    m = _random_model(NFIR, delays=3, neurons=3)
    before = dict(vars(m))
    with pytest.warns(rom.EnvelopeWarning, match=r"by 0\.3 m/s"):
        m.predict(np.array([0.0, 1.0, 0.2, 0.0]))
    # no once-flag on the model: every call warns, the warnings filters decide what is shown
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        m.predict(np.array([0.0, 1.0, 0.2, 0.0]))
        m.predict(np.array([0.0, 1.0, 0.2, 0.0]))
    assert [w.category for w in caught] == [rom.EnvelopeWarning] * 2
    assert caught[0].filename == __file__  # points at the caller of predict
    assert vars(m).keys() == before.keys()
    assert all(vars(m)[k] is v for k, v in before.items())


@pytest.mark.parametrize("cls", [NFIR, NOE])
def test_get_params_complete_and_set_params(cls):
    import inspect

    m = cls()
    names = [p for p in inspect.signature(cls.__init__).parameters if p != "self"]
    assert list(m.get_params()) == names
    assert m.set_params(neurons=4, delays=np.int64(3)) is m
    p = m.get_params(deep=True)
    assert p["neurons"] == 4 and type(p["delays"]) is int and p["delays"] == 3
    assert cls(**p).get_params() == p
    with pytest.raises(rom.ROMError, match="no parameter 'bogus'"):
        m.set_params(bogus=1)
    if cls is NFIR:
        assert "out_delays" not in p and "unstable_bound" not in p


def test_constructor_stores_validation_in_fit():
    u = _sig(500, 0)
    m = NFIR(delays=0, neurons=3, max_epochs=2)  # stored as given, no check yet
    assert m.delays == 0
    with pytest.raises(rom.ROMError, match="delays"):
        m.fit(u, u**2, fs=500.0)
    m.set_params(delays=3)
    assert m.fit(u, u**2, fs=500.0) is m


def test_numpy_hyperparameters_save(tmp_path):
    # NumPy integers as hyperparameters (from a grid, a config array) are saved as plain ints
    m = _random_model(NFIR, delays=np.array([1, 2, 4]), neurons=np.int64(3))
    m2 = rom.load_model(m.save(tmp_path / "np.npz"))
    assert m2.get_params()["delays"] == [1, 2, 4] and m2.get_params()["neurons"] == 3


def _sig(n, seed):
    return np.sin(np.linspace(0, 20, n)) + 0.1 * np.random.default_rng(seed).standard_normal(n)


def test_bad_input():
    u = _sig(500, 0)
    y = u**2
    with pytest.raises(rom.ROMError, match="too few"):
        NFIR(delays=70, neurons=3).fit(u[:60], y[:60], fs=500.0)
    with pytest.raises(rom.ROMError, match="constant"):
        NFIR(delays=3, neurons=3).fit(np.ones(500), y, fs=500.0)
    with pytest.raises(rom.ROMError, match="constant"):
        NFIR(delays=3, neurons=3).fit(u, np.ones(500), fs=500.0)
    bad = u.copy()
    bad[10] = np.nan
    with pytest.raises(rom.ROMError, match="NaN"):
        NFIR(delays=3, neurons=3).fit(bad, y, fs=500.0)
    with pytest.raises(rom.ROMError, match="same length"):
        NFIR(delays=3, neurons=3).fit(u, y[:-1], fs=500.0)
    with pytest.raises(rom.ROMError, match="fs"):
        NFIR(delays=3, neurons=3).fit(u, y, fs=0.0)
    with pytest.raises(rom.ROMError, match="delays"):
        NFIR(delays=0).fit(u, y, fs=500.0)
    with pytest.raises(rom.ROMError, match="delays"):
        NFIR(delays=[1, 1]).fit(u, y, fs=500.0)
    with pytest.raises(rom.ROMError, match="hidden"):
        NFIR(hidden="gauss").fit(u, y, fs=500.0)
    with pytest.raises(rom.ROMError, match="neurons"):
        NFIR(neurons=2.5).fit(u, y, fs=500.0)
    with pytest.raises(rom.NotFittedError, match="not fitted"):
        NFIR().predict(u)
    m = _random_model(NFIR, delays=3, neurons=3)
    with pytest.raises(rom.ROMError, match="NaN"):
        m.predict(bad)
    with pytest.raises(rom.ROMError, match="shape"):
        m.predict(np.zeros((2, 2, 2)))


# -- command line ------------------------------------------------------------------------------


def _record(n, seed, fs=100.0):
    from scipy.signal import butter, filtfilt

    from sloshrom.io import Record

    b, a = butter(4, 0.08)
    u = filtfilt(b, a, np.random.default_rng(seed).standard_normal(n))
    y = np.tanh(np.convolve(np.concatenate([[0.0], u[:-1]]), np.exp(-np.arange(8) / 3.0))[:n])
    return Record(np.arange(n) / fs, fs, {"velocity": u, "dynamic_force": y},
                  {"velocity": "m/s", "dynamic_force": "N"}, {})


@pytest.mark.filterwarnings("ignore::sloshrom.rom.EnvelopeWarning")
@pytest.mark.long
def test_cli_train_predict(tmp_path):
    from typer.testing import CliRunner

    import sloshrom.cli.rom  # noqa: F401  (registers the commands)
    from sloshrom.cli._app import app
    from sloshrom.io import read_record, write_record

    write_record(_record(1500, 1), tmp_path / "tr.nc")
    write_record(_record(800, 2), tmp_path / "va.nc")
    write_record(_record(800, 3, fs=200.0), tmp_path / "other_rate.nc")
    r = CliRunner()
    res = r.invoke(app, ["train", "--data", str(tmp_path / "tr.nc"), "--validation",
                         str(tmp_path / "va.nc"), "--delays", "6", "--neurons", "3",
                         "--max-epochs", "3", "--out", str(tmp_path / "m.npz")])
    assert res.exit_code == 0, res.output
    assert "wrote" in res.output
    res = r.invoke(app, ["predict", "--model", str(tmp_path / "m.npz"), "--data",
                         str(tmp_path / "va.nc"), "--out", str(tmp_path / "p.nc")])
    assert res.exit_code == 0, res.output
    rec = read_record(tmp_path / "p.nc")
    m = rom.load_model(tmp_path / "m.npz")
    np.testing.assert_allclose(rec["dynamic_force_pred"], m.predict(rec["velocity"]), rtol=1e-12)
    assert rec.units["dynamic_force_pred"] == "N" and "velocity" in rec
    # sample-rate mismatch: model vs data, and train vs validation
    res = r.invoke(app, ["predict", "--model", str(tmp_path / "m.npz"), "--data",
                         str(tmp_path / "other_rate.nc"), "--out", str(tmp_path / "q.nc")])
    assert res.exit_code == 2 and "sample-rate mismatch" in res.output
    assert not (tmp_path / "q.nc").exists()
    res = r.invoke(app, ["train", "--data", str(tmp_path / "tr.nc"), "--validation",
                         str(tmp_path / "other_rate.nc"), "--out", str(tmp_path / "x.npz")])
    assert res.exit_code == 2 and "sample-rate mismatch" in res.output
    res = r.invoke(app, ["train", "--data", str(tmp_path / "tr.nc"), "--validation",
                         str(tmp_path / "va.nc"), "--output", "force",
                         "--out", str(tmp_path / "x.npz")])
    assert res.exit_code == 2 and "no variable force" in res.output
