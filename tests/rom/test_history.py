"""A start from measured history: ``predict(u, history=...)``, ``fit(validation_history=N)``,
``sloshrom predict --history`` and ``sloshrom train --history``.

The physics: a linear system started away from rest is predicted exactly after its history by
its own linear model; a feed-forward or recurrent network started from its own past outputs
continues its run from rest; a history at rest is rest.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy import signal
from typer.testing import CliRunner

from sloshrom.cli import app
from sloshrom.io import Record, read_record, write_record
from sloshrom.rom import NFIR, NOE, NSS, Ensemble, MinMaxScaler, ROMError
from sloshrom.rom.errors import HistoryError
from sloshrom.rom.lss import LSS
from sloshrom.rom.nss.network import StateSpaceSpec
from sloshrom.rom.nss.training import init_params
from sloshrom.rom.tdnn.network import unpack

FS = 100.0
# a lightly damped oscillator (20 rad/s, 5 % damping) with direct feed-through, sampled at FS
_AC = np.array([[0.0, 1.0], [-400.0, -2.0]])
A, B, C, D, _ = signal.cont2discrete(
    (_AC, np.array([[0.0], [1.0]]), np.array([[100.0, 0.0]]), np.array([[0.1]])), 1 / FS)


def oscillator(n: int, seed: int, x0=(0.0, 0.0)) -> tuple[np.ndarray, np.ndarray]:
    """White-noise input and the oscillator's output from the state ``x0``."""
    u = np.random.default_rng(seed).standard_normal(n)
    x = np.asarray(x0, dtype=float)
    y = np.empty(n)
    for k in range(n):
        y[k] = (C @ x)[0] + D[0, 0] * u[k]
        x = A @ x + B[:, 0] * u[k]
    return u, y


@pytest.fixture(scope="module")
def linear() -> LSS:
    u, y = oscillator(4000, 1)
    return LSS(n_states=2, max_epochs=5).fit(u, y, FS, validation=oscillator(1500, 2))


def test_linear_system_away_from_rest_is_predicted_exactly_after_its_history(linear):
    u, y = oscillator(1000, 3, x0=(3e-3, -0.2))
    h = 50
    scale = np.sqrt(np.mean(y**2))
    from_rest = linear.predict(u) - y
    # the start's transient: far from the 1e-8 below, so the check can fail
    assert np.max(np.abs(from_rest)) > 1e-2 * scale
    err = linear.predict(u[h:], history=(u[:h], y[:h])) - y[h:]
    # measured 4e-15 of the output's RMS (float64 rounding through the least-squares state)
    assert np.max(np.abs(err)) < 1e-8 * scale


def test_linear_history_shorter_than_the_order_is_refused(linear):
    u, y = oscillator(100, 4)
    with pytest.raises(ROMError, match="reads 2 samples"):
        linear.predict(u[1:], history=(u[:1], y[:1]))
    with pytest.raises(ROMError, match="history"):
        linear.predict(u[10:], history=(u[:10], y[:9]))


def test_linear_validation_from_history_scores_the_record_after_it():
    u, y = oscillator(4000, 1)
    uv, yv = oscillator(1500, 5, x0=(3e-3, -0.2))
    from_rest = LSS(n_states=2, max_epochs=5).fit(u, y, FS, validation=(uv, yv))
    from_history = LSS(n_states=2, max_epochs=5).fit(u, y, FS, validation=(uv, yv),
                                                    validation_history=20)
    scale = float(np.mean(yv**2))
    assert from_rest.history_["val_mse"][-1] > 1e-6 * scale  # the transient, scored
    assert from_history.history_["val_mse"][-1] < 1e-16 * scale  # an exact model


def _nfir() -> NFIR:
    theta = np.random.default_rng(0).standard_normal(5 * 10 + 5 + 5 + 1)
    params = {k: np.asarray(v) for k, v in unpack(theta, 10, 5).items()}
    return NFIR.fitted(params, MinMaxScaler(-3.0, 3.0, -1.0, 1.0), FS, delays=10, neurons=5)


def _noe() -> NOE:
    theta = 0.5 * np.random.default_rng(1).standard_normal(5 * 4 + 5 + 5 + 1)
    params = {k: np.asarray(v) for k, v in unpack(theta, 4, 5).items()}
    return NOE.fitted(params, MinMaxScaler(-3.0, 3.0, -1.0, 1.0), FS, delays=2, neurons=5,
                      out_delays=2)


def _nss() -> NSS:
    spec = StateSpaceSpec(2, 8, 10)
    return NSS.fitted(init_params(spec, 0), MinMaxScaler(-3.0, 3.0, -1.0, 1.0), FS,
                      n_states=2, neurons=8, window=10)


@pytest.mark.parametrize("make", [_nfir, _noe, _nss], ids=["nfir", "noe", "nss"])
def test_a_history_at_rest_is_rest(make):
    m = make()
    u = np.random.default_rng(2).uniform(-2.0, 2.0, 300)
    z = np.zeros(m.history_samples)
    np.testing.assert_allclose(m.predict(u, history=(z, z)), m.predict(u), rtol=0,
                               atol=1e-12)


@pytest.mark.parametrize("make", [_nfir, _noe], ids=["nfir", "noe"])
def test_a_network_started_from_its_own_past_continues_its_run(make):
    m = make()
    u = np.random.default_rng(3).uniform(-2.0, 2.0, 400)
    y = m.predict(u)
    h = 30
    np.testing.assert_allclose(m.predict(u[h:], history=(u[:h], y[:h])), y[h:], rtol=0,
                               atol=1e-12)


def test_history_needs_the_samples_the_model_reads():
    m = _nss()
    u = np.zeros(50)
    with pytest.raises(ROMError, match="reads 10 samples"):
        m.predict(u, history=(u[:5], u[:5]))
    with pytest.raises(ROMError, match="history input contains NaN"):
        m.predict(u, history=(np.full(10, np.nan), u[:10]))


@pytest.mark.long
def test_nss_validation_from_history_is_the_prediction_from_history():
    u, y = oscillator(1500, 6)
    uv, yv = oscillator(600, 7, x0=(3e-3, -0.2))
    h = 25
    m = NSS(n_states=2, neurons=8, window=10, horizon=40, max_epochs=2,
            steps_per_epoch=10).fit(u, y, FS, validation=(uv, yv), validation_history=h)
    best = m.history_["val_mse"][m.history_["best_epoch"]]
    e = m.predict(uv[h:], history=(uv[:h], yv[:h])) - yv[h:]
    assert best == pytest.approx(float(np.mean(e**2)), rel=1e-9)


def test_validation_history_is_checked():
    u, y = oscillator(1500, 6)
    m = NSS(n_states=2, neurons=8, window=10, horizon=40, max_epochs=1, steps_per_epoch=2)
    with pytest.raises(ROMError, match="needs a validation record"):
        m.fit(u, y, FS, validation_history=20)
    with pytest.raises(ROMError, match="reads 10 samples"):
        m.fit(u, y, FS, validation=(u[:100], y[:100]), validation_history=5)
    for h in (100, 99):  # a score needs 2 samples (a free run of 1 sample has no slope)
        with pytest.raises(HistoryError, match=rf"validation_history {h}: leaves {100 - h} "
                                               r"sample\(s\) .*at most 98 samples"):
            m.fit(u, y, FS, validation=(u[:100], y[:100]), validation_history=h)


def test_an_ensemble_from_history_is_the_mean_of_its_members():
    members = []
    for seed in (0, 1):
        spec = StateSpaceSpec(2, 8, 10)
        members.append(NSS.fitted(init_params(spec, seed), MinMaxScaler(-3.0, 3.0, -1.0, 1.0),
                                  FS, n_states=2, neurons=8, window=10, seed=seed))
    ens = Ensemble.from_members(members)
    u, y = oscillator(300, 8)
    past = (u[:20], y[:20])
    mean = np.mean([m.predict(u[20:], history=past) for m in members], axis=0)
    np.testing.assert_allclose(ens.predict(u[20:], history=past), mean, rtol=0, atol=1e-14)
    assert ens.history_samples == 10


# -- the command line ------------------------------------------------------------------------


def _write(path, u, y) -> None:
    write_record(Record(np.arange(u.size) / FS, FS, {"force": u, "displacement": y},
                        {"force": "N", "displacement": "m"}), path)


@pytest.fixture(scope="module")
def cli_records(tmp_path_factory):
    d = tmp_path_factory.mktemp("history")
    _write(d / "train.nc", *oscillator(3000, 1))
    _write(d / "validation.nc", *oscillator(800, 2, x0=(3e-3, -0.2)))
    _write(d / "test.nc", *oscillator(600, 3, x0=(-2e-3, 0.3)))
    return d


def test_cli_train_and_predict_from_history(cli_records):
    d = cli_records
    common = ["train", "--data", str(d / "train.nc"), "--validation",
              str(d / "validation.nc"), "--arch", "lss", "--input", "force", "--output",
              "displacement", "--n-states", "2", "--out"]
    r = CliRunner().invoke(app, [*common, str(d / "rest.npz")])
    assert r.exit_code == 0, r.output
    assert "does not start at rest" in r.output and "--history N (N >= 2)" in r.output
    r = CliRunner().invoke(app, [*common, str(d / "lss.npz"), "--history", "20"])
    assert r.exit_code == 0, r.output
    assert "validation MSE (after 20 samples of history)" in r.output
    assert "does not start at rest" not in r.output

    r = CliRunner().invoke(app, ["predict", "-m", str(d / "lss.npz"), "--data",
                                 str(d / "test.nc"), "--out", str(d / "pred.nc"),
                                 "--history", "30"])
    assert r.exit_code == 0, r.output
    assert "570 samples after 30 samples of history" in r.output
    out = read_record(d / "pred.nc")
    assert len(out) == 570 and out.attrs["prediction_history"] == 30
    assert out.time[0] == pytest.approx(30 / FS)
    e = out["displacement_pred"] - out["displacement"]
    assert np.max(np.abs(e)) < 1e-8 * np.sqrt(np.mean(out["displacement"] ** 2))


@pytest.mark.parametrize(("argv", "match"), [
    (["--history", "1"], "reads 2 samples of measured history"),
    (["--history", "600"], "--history"),
])
def test_cli_predict_history_is_checked(cli_records, argv, match):
    d = cli_records
    r = CliRunner().invoke(app, ["train", "--data", str(d / "train.nc"), "--validation",
                                 str(d / "validation.nc"), "--arch", "lss", "--input", "force",
                                 "--output", "displacement", "--n-states", "2", "--out",
                                 str(d / "checked.npz")])
    assert r.exit_code == 0, r.output
    r = CliRunner().invoke(app, ["predict", "-m", str(d / "checked.npz"), "--data",
                                 str(d / "test.nc"), "--out", str(d / "bad.nc"), *argv])
    assert r.exit_code == 2 and match in r.output, r.output
    assert not (d / "bad.nc").exists()
