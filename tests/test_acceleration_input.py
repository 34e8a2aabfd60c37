"""Networks on the tank acceleration: the step contract in the coupled beam, the envelope, the
energy maps, the ensemble, the model file, ONNX and the command line."""

from __future__ import annotations

import warnings

import jax
import numpy as np
import pytest
from typer.testing import CliRunner

from sloshrom.beam.simulation.coupled import CoupledSimulator
from sloshrom.cli import app
from sloshrom.config import Tank
from sloshrom.energy import default_grid, phi_d_map
from sloshrom.io import Record, write_record
from sloshrom.models import model_input
from sloshrom.rom import load_model
from sloshrom.rom.ensemble import Ensemble
from sloshrom.rom.errors import ROMError
from sloshrom.rom.family import FillBlend
from sloshrom.rom.network import MinMaxScaler
from sloshrom.rom.onnx import check_exportable
from sloshrom.rom.tdnn.estimators import NFIR, NOE

ACC = {"units": ("m/s^2", "N"), "names": ("acceleration", "dynamic_force")}
FS = 500.0


def _random(seed: int = 0, **kw) -> NFIR:
    """A 'fitted' acceleration network with random weights (input range +-80 m/s^2)."""
    rng = np.random.default_rng(seed)
    params = {"W": rng.standard_normal((4, 5)), "b": rng.standard_normal(4),
              "c": 0.3 * rng.standard_normal(4), "c0": np.float64(0.0)}
    envelope = {"input_min": -80.0, "input_max": 80.0, "output_min": -2.0,
                "output_max": 2.0, "frequency_band": [5.0, 25.0], "acceleration_max": 80.0}
    return NFIR.fitted(params, MinMaxScaler(-80.0, 80.0, -2.0, 2.0), FS, envelope,
                       delays=5, neurons=4, seed=seed, **{**ACC, **kw})


def _acc(n: int = 3000, seed: int = 0, rms: float = 8.0) -> np.ndarray:
    rng = np.random.default_rng(seed)
    a = np.convolve(rng.standard_normal(n), np.hanning(9), "same")
    a *= np.sin(np.pi * np.arange(n) / (n - 1)) ** 2  # from rest to rest
    return a * rms / np.sqrt(np.mean(a**2))


def _force(a: np.ndarray) -> np.ndarray:
    """A causal nonlinear force of the past accelerations (N)."""
    lin = np.convolve(a, 0.02 * np.exp(-np.arange(20) / 4.0))[: a.size]
    return np.r_[0.0, np.tanh(lin[:-1])]


@pytest.fixture(scope="module")
def modal(builtin_modal):
    return builtin_modal


def test_step_fed_the_previous_acceleration_reproduces_predict():
    m = _random()
    a = _acc(400)
    with jax.enable_x64(True):
        state, out = m.init_state(), []
        for a_prev in np.r_[0.0, a[:-1]]:  # what the coupled beam passes at step k: a_{k-1}
            state, f = m.step(state, 123.0, a_prev)  # the velocity is not read
            out.append(float(f))
    np.testing.assert_allclose(out, m.predict(a), rtol=1e-12, atol=1e-13)
    # simulate reads the acceleration and needs it
    np.testing.assert_array_equal(m.simulate(np.full(a.size, 5.0), a), m.predict(a))
    with pytest.raises(ValueError, match="reads the tank acceleration"):
        m.simulate(a, None)
    assert m.input == "acceleration" and NFIR().input == "velocity"
    assert model_input(NFIR(), "v", "a") == "v" and model_input(m, "v", "a") == "a"


@pytest.mark.parametrize("backend, n", [
    ("jax", 1500), ("python", 300),
    # the Python loop calls the step once a sample: 1500 of them in the slow tier
    pytest.param("python", 1500, marks=pytest.mark.slow)])
def test_coupled_beam_feeds_the_network_its_own_signal(modal, backend, n):
    """Replayed open loop on the closed loop's own tank acceleration, the network gives the
    closed loop's force sample by sample: the loop feeds the right signal with the right lag."""
    m = _random(seed=3)
    base = 0.3 * 9.80665 * _acc(n, seed=1, rms=1.0)
    out = CoupledSimulator(m, modal, backend=backend).run(base)
    assert np.max(np.abs(out["dynamic_force"])) > 0.05  # the network is not idle
    np.testing.assert_allclose(out["dynamic_force"], m.predict(out["tank_acceleration"]),
                               rtol=1e-9, atol=1e-10)
    # a velocity network on the same run reads the velocity instead
    v = NFIR.fitted(m.params_, MinMaxScaler(-2.0, 2.0, -2.0, 2.0), FS,
                    {**m.envelope_, "input_min": -2.0, "input_max": 2.0}, delays=5, neurons=4)
    out_v = CoupledSimulator(v, modal, backend=backend).run(base)
    np.testing.assert_allclose(out_v["dynamic_force"], v.predict(out_v["tank_velocity"]),
                               rtol=1e-9, atol=1e-10)


def test_envelope_is_an_acceleration_range(modal):
    a = _acc(2000)
    y = _force(a)
    m = NFIR(delays=8, neurons=3, max_epochs=3, **ACC).fit(a, y, FS, validation=(a, y))
    assert m.envelope_["input_min"] == pytest.approx(a.min())
    assert m.envelope_["input_max"] == pytest.approx(a.max())
    assert m.envelope_["acceleration_max"] == pytest.approx(np.max(np.abs(a)))
    peak = np.max(np.abs(a))
    with warnings.catch_warnings(record=True) as w:
        warnings.simplefilter("always")
        # a base signal that drives the tank well beyond the training accelerations
        out = CoupledSimulator(m, modal).run(3.0 * peak * np.sin(
            2 * np.pi * 6.0 * np.arange(1000) / FS) * np.hanning(1000))
    msgs = [str(x.message) for x in w]
    assert any(s.startswith("tank acceleration outside the training envelope") and "m/s^2"
               in s for s in msgs), msgs
    ratio = np.max(np.abs(out["tank_acceleration"])) / peak
    assert float(out["envelope_acceleration_ratio"]) == pytest.approx(ratio)
    outside = np.mean((out["tank_acceleration"] < a.min()) | (out["tank_acceleration"] > a.max())
                      | (np.abs(out["tank_acceleration"]) > peak))
    assert float(out["envelope_outside_fraction"]) == pytest.approx(outside)


def test_loss_terms_units_and_noe_are_refused_for_an_acceleration_input():
    a = _acc(1000)
    y = _force(a)
    for name in ("amplitude_weighting", "passivity", "cycle_energy"):
        with pytest.raises(ROMError, match=f"{name} > 0 needs a velocity input"):
            NFIR(delays=4, neurons=3, max_epochs=1, **ACC, **{name: 0.1}).fit(a, y, FS)
    with pytest.raises(ROMError, match=r"'acceleration' is in m/s\^2, got units 'm/s'"):
        NFIR(delays=4, neurons=3, names=ACC["names"], units=("m/s", "N")).fit(a, y, FS)
    with pytest.raises(ROMError, match="an NOE takes the tank velocity"):
        NOE(trainer="lm", max_epochs=1, **ACC).fit(a, y, FS)
    NFIR(delays=4, neurons=3, max_epochs=1, names=ACC["names"], units=("m/s2", "N")).fit(a, y, FS)


def test_model_file_ensemble_and_onnx(tmp_path):
    m = _random(seed=5)
    a = _acc(600)
    back = load_model(m.save(tmp_path / "acc.npz"))
    assert back.input == "acceleration" and tuple(back.units) == ("m/s^2", "N")
    np.testing.assert_array_equal(back.simulate(np.zeros_like(a), a), m.predict(a))
    ens = Ensemble.from_members([_random(seed=5), _random(seed=6)])
    assert ens.input == "acceleration"
    np.testing.assert_allclose(ens.simulate(np.zeros_like(a), a),
                               0.5 * (_random(seed=5).predict(a) + _random(seed=6).predict(a)),
                               rtol=1e-12, atol=1e-14)
    with pytest.raises(ROMError, match="cannot be exported to ONNX"):
        check_exportable(m)
    # a fill blend's members must read the same signal
    v = NFIR.fitted(m.params_, m.scaler_, FS, delays=5, neurons=4, seed=1)
    with pytest.raises(ROMError, match=r"members read different inputs \['acceleration', "
                                       r"'velocity'\]"):
        FillBlend([m, v], [0.5, 0.5], 0.5, (0.25, 0.75))
    assert FillBlend([m, _random(seed=6)], [0.5, 0.5], 0.5, (0.25, 0.75)).input == \
        "acceleration"


def test_energy_map_drives_the_network_with_the_acceleration():
    """Phi_d of a network on the acceleration is the map of the same network wrapped to read
    the acceleration through a velocity-contract adapter: the map feeds each its own signal."""
    m = _random(seed=2)

    class ThroughVelocitySlot:
        dt, force_rule = m.dt, m.force_rule

        def simulate(self, velocity, acceleration):
            return m.predict(acceleration)

    ob, ab = default_grid(4)
    ours = np.asarray(phi_d_map(m, ob, ab, Tank(), n_cycles=3, n_ramp=1))
    ref = np.asarray(phi_d_map(ThroughVelocitySlot(), ob, ab, Tank(), n_cycles=3, n_ramp=1))
    assert np.isfinite(ours).sum() >= 4
    np.testing.assert_allclose(ours, ref, rtol=1e-12, equal_nan=True)
    assert np.nanmax(np.abs(ours)) > 0


@pytest.mark.long
def test_cli_trains_a_network_on_the_acceleration(tmp_path):
    paths = []
    for name, seed, n in (("train", 1, 2000), ("validation", 2, 600)):
        a = _acc(n, seed)
        rec = Record(np.arange(n) / FS, FS, {"acceleration": a, "dynamic_force": _force(a)},
                     {"acceleration": "m/s^2", "dynamic_force": "N"}, {})
        paths.append(write_record(rec, tmp_path / f"{name}.nc"))
    common = ["train", "--data", str(paths[0]), "--validation", str(paths[1]),
              "--input", "acceleration", "--delays", "4", "--neurons", "3", "--max-epochs", "2"]
    out = tmp_path / "acc.npz"
    res = CliRunner().invoke(app, [*common, "--out", str(out)])
    assert res.exit_code == 0, res.output
    m = load_model(out)
    assert m.input == "acceleration"
    assert (m.amplitude_weighting, m.passivity, m.cycle_energy) == (0.0, 0.0, 0.0)
    # the beam and the map take it (they feed it the tank acceleration in m/s^2)
    res = CliRunner().invoke(app, ["beam", "free", "--sloshing", str(out),
                                   "--out", str(tmp_path / "res")])
    assert res.exit_code == 0, res.output
    res = CliRunner().invoke(app, ["map", "--model", str(out), "--n-omega", "2", "--n-a", "2",
                                   "--out", str(tmp_path / "map.nc")])
    assert res.exit_code == 0, res.output
    bad = tmp_path / "bad.npz"
    res = CliRunner().invoke(app, [*common, "--out", str(bad), "--passivity", "1"])
    assert res.exit_code == 2 and "--passivity > 0 needs a velocity input" in res.output, \
        res.output
    res = CliRunner().invoke(app, [*common, "--out", str(bad), "--arch", "noe"])
    assert res.exit_code == 2 and ("--input acceleration: an NOE takes the tank velocity; the "
                                   "acceleration needs --arch nfir") in res.output, res.output
    assert not bad.exists()
