"""Physics in the NFIR loss: amplitude weighting, harmonic passivity probes, and a small
identification on the virtual rig whose ROM must not create energy."""

from __future__ import annotations

import math

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from sloshrom import signals
from sloshrom.config import Tank
from sloshrom.energy import dissipated_energy, map_fidelity, phi_d_map
from sloshrom.io import record_from_measurement
from sloshrom.rig.virtual import SensorParams, VirtualRig
from sloshrom.rom.errors import ROMError
from sloshrom.rom.losses import pack_cycles
from sloshrom.rom.tdnn import training
from sloshrom.rom.tdnn.estimators import NFIR
from sloshrom.rom.tdnn.network import nfir_free_run, pack

FS = 500.0


def test_amplitude_weights_follow_one_over_amplitude_squared():
    t = np.arange(int(40 * FS)) / FS
    amp = np.where(t < 20.0, 1.0, 0.1)
    u = amp * np.sin(2 * np.pi * 10.0 * t)
    eps = 0.05
    w = training.amplitude_weights(u, FS, eps)
    assert w.mean() == pytest.approx(1.0)
    big, small = w[int(5 * FS):int(15 * FS)], w[int(25 * FS):int(35 * FS)]
    # away from the step the 1 s RMS x sqrt(2) is the amplitude: ratio (1 + eps^2)/(0.01 + eps^2)
    assert np.ptp(big) / big.mean() < 1e-3
    assert small.mean() / big.mean() == pytest.approx((1 + eps**2) / (0.01 + eps**2), rel=1e-3)


@pytest.fixture(scope="module")
def rig_records():
    """A short VFA on the virtual rig (training) and another path (validation), 500 Hz."""
    tank = Tank()
    rig = VirtualRig(tank=tank, seed=0, sensors=SensorParams(output_fs=FS))
    out = []
    for split, seed in (("train", 1), ("validation", 2)):
        sig = signals.vfa(1.0 / rig.dt, split=split, duration=60.0, tank=tank, seed=seed)
        rec = record_from_measurement(rig.measure(sig.acceleration), tank, truth=True)
        out.append((np.asarray(rec["velocity"]), np.asarray(rec["dynamic_force"])))
    return tank, rig, out[0], out[1]


def _small(**kw) -> NFIR:
    return NFIR(delays=20, neurons=10, max_epochs=12, seed=1, **kw)


@pytest.mark.long
def test_probe_dissipation_equals_the_energy_of_a_simulated_harmonic_test(rig_records):
    # the probe's one-period sum must be the dissipated energy of the steady response, computed
    # independently by free-running the model on a long sine and integrating -dF dw
    tank, _, (u, y), _ = rig_records
    m = NFIR(delays=20, neurons=10, max_epochs=2, seed=3).fit(u, y, fs=FS)
    sc = m.scaler_
    with jax.enable_x64(True):  # as inside the trainer
        probes = training.harmonic_probes(u, FS, sc, m.spec.delays, (5.0, 25.0), n_freq=3,
                                          n_amp=3)
        phi = np.asarray(training.probe_dissipation(
            pack(m.params_), probes, jnp.arange(probes.n), m.spec.delays, 10, "matlab"))
    assert probes.n == 9  # periods 20, 45, 100 samples x 3 amplitudes
    m_ref = sc.out_half_range / (float(np.max(np.abs(np.gradient(u)))) * FS)
    checked = 0
    for i, P in ((1, 20), (4, 45), (8, 100)):
        win = sc.in_min + (np.asarray(probes.windows[i]) + 1) * 0.5 * (sc.in_max - sc.in_min)
        sine = np.sin(2 * np.pi * (np.arange(win.size) - 20) / P)  # the window starts at -20
        V = float(win @ sine / (sine @ sine))
        k = np.arange(40 * P + 1)
        v = V * np.sin(2 * np.pi * k / P)
        w = -V * P / (2 * np.pi * FS) * np.cos(2 * np.pi * k / P)  # its displacement
        f = m.predict(v)
        sl = slice(20 * P, 40 * P + 1)  # 20 steady cycles, after the 20-sample memory
        # the probe's rule: rectangle sum of -F v over whole periods (exact on its own terms)
        rect = -np.sum(f[20 * P:40 * P] * v[20 * P:40 * P]) / FS / 20
        assert phi[i] == pytest.approx(rect / (m_ref * V * V), rel=1e-9, abs=1e-12)
        # the maps' rule (trapezoid on -dF dw) differs by O((Omega dt)^2): 2.5 % at P = 20
        ld = dissipated_energy(w[sl], f[sl], n_cycles=20)
        assert phi[i] == pytest.approx(ld / (m_ref * V * V), rel=0.03, abs=1e-5)
        checked += 1
    assert checked == 3


def test_loss_options_are_checked():
    u = np.sin(np.arange(3000) / 10.0)
    with pytest.raises(ROMError, match="passivity"):
        _small(passivity=-1.0).fit(u, u**2, fs=FS)
    with pytest.raises(ROMError, match="needs trainer 'adam'"):
        _small(amplitude_weighting=0.05, trainer="lm").fit(u, u**2, fs=FS)
    with pytest.raises(ROMError, match="amplitude_weighting"):
        _small(amplitude_weighting=float("nan")).fit(u, u**2, fs=FS)
    with pytest.raises(ROMError, match="cycle_energy"):
        _small(cycle_energy=-1.0).fit(u, u**2, fs=FS)
    with pytest.raises(ROMError, match="needs trainer 'adam'"):
        _small(cycle_energy=1.0, trainer="fast").fit(u, u**2, fs=FS)


@pytest.fixture(scope="module")
def passive_and_plain(rig_records):
    tank, rig, (u, y), (uv, yv) = rig_records
    plain = _small().fit(u, y, fs=FS, validation=(uv, yv))
    passive = _small(amplitude_weighting=0.05, passivity=1.0).fit(u, y, fs=FS,
                                                                 validation=(uv, yv))
    ob = np.linspace(2 * math.pi * 5 / tank.reference_frequency,
                     2 * math.pi * 25 / tank.reference_frequency, 8)
    ab = np.linspace(0.01, 0.45, 8)
    ref = phi_d_map(rig, ob, ab, tank=tank)
    return ref, {name: phi_d_map(m, ob, ab, tank=tank)
                 for name, m in (("plain", plain), ("passive", passive))}


@pytest.mark.slow  # the recipe's code paths run in the fast tier (history test, tiny reproduce)
def test_passive_recipe_gives_a_passive_map_on_a_small_case(passive_and_plain):
    ref, maps = passive_and_plain
    fid = map_fidelity(ref, maps["passive"])
    assert fid["n_points"] > 30
    assert fid["nonpassive_fraction"] <= 0.01, fid
    # the control: without the physics in the loss the same network creates energy here
    assert map_fidelity(ref, maps["plain"])["n_nonpassive"] > 0


def test_passive_recipe_history_reports_the_objective(rig_records):
    _, _, (u, y), (uv, yv) = rig_records
    m = NFIR(delays=5, neurons=4, max_epochs=2, amplitude_weighting=0.05,
             passivity=1.0, cycle_energy=0.1).fit(u, y, fs=FS, validation=(uv, yv))
    h = m.history_
    assert len(h["val_objective"]) == len(h["val_mse"]) >= 2
    assert m.envelope_["acceleration_max"] == pytest.approx(
        float(np.max(np.abs(np.gradient(u)))) * FS)


def test_energy_cycles_cut_whole_cycles_with_the_probe_normalisation():
    # 10 Hz at 1 m/s, then 8 Hz at 0.5 m/s, then 0.001 m/s (below max/100: noise, dropped)
    t = np.arange(int(3 * FS)) / FS
    u = np.where(t < 1.0, np.sin(2 * np.pi * 10 * t),
                 np.where(t < 2.0, 0.5 * np.sin(2 * np.pi * 8 * t),
                          1e-3 * np.sin(2 * np.pi * 10 * t)))
    cyc = training.energy_cycles(u, FS, (5.0, 25.0))
    rows, w = np.asarray(cyc.rows), np.asarray(cyc.weight)
    lengths = (w != 0).sum(axis=1)
    # 9 whole 10 Hz cycles between upward crossings, 7 whole 8 Hz ones (and the join)
    assert set(lengths) <= {50, 62, 63, 56, 57} and 15 <= cyc.n <= 17
    assert np.all(np.diff(rows, axis=1)[w[:, 1:] != 0] == 1)  # contiguous samples
    a_max = float(np.max(np.abs(np.gradient(u)))) * FS
    for r, ww, n in zip(rows, w, lengths, strict=True):
        v = u[r[:n]]
        assert v[0] >= 0 > u[r[0] - 1]  # starts at an upward zero crossing
        # sum(F v)/fs over m_ref V^2 for a unit damper F = v: (V^2 n / 2 / fs) / (m_ref V^2)
        peak = np.abs(v).max()
        assert np.sum(v * ww[:n]) == pytest.approx(np.sum(v**2) * a_max / (FS * peak**2))
        assert np.sum(v**2) / peak**2 == pytest.approx(n / 2, rel=0.03)
    with pytest.raises(ROMError, match="no input cycle"):
        training.energy_cycles(np.linspace(0.0, 1.0, 1000), FS, (5.0, 25.0))


def _cycle_error(m: NFIR, u: np.ndarray, y: np.ndarray) -> float:
    """RMS error of the normalised energy of the record's cycles, model against data."""
    cyc = training.energy_cycles(u, FS, (5.0, 25.0))
    rows, w = np.asarray(cyc.rows), np.asarray(cyc.weight)
    e = (m.predict(u) - y) / m.scaler_.out_half_range
    return float(np.sqrt(np.mean(np.sum(e[rows] * w, axis=1) ** 2)))


@pytest.mark.slow  # two trainings of 12 epochs; the term's code path: the history test below
def test_cycle_energy_term_fits_the_energy_of_unseen_cycles(rig_records):
    # the term is there to get the exchanged energy right: on the validation record the
    # cycle-energy error must fall against the same recipe without it
    _, _, (u, y), (uv, yv) = rig_records
    kw = dict(amplitude_weighting=0.05, passivity=1.0)
    without = _small(**kw).fit(u, y, fs=FS, validation=(uv, yv))
    with_term = _small(cycle_energy=1.0, **kw).fit(u, y, fs=FS, validation=(uv, yv))
    assert with_term.get_params()["cycle_energy"] == 1.0
    e0, e1 = _cycle_error(without, uv, yv), _cycle_error(with_term, uv, yv)
    assert e1 < 0.8 * e0, (e0, e1)


@pytest.mark.parametrize("hidden", ["matlab", "distance"])
@pytest.mark.long
def test_cycle_error_of_a_run_is_the_networks_on_the_cycles(hidden):
    """The validation's cycle-energy term read from the NFIR's run over the record equals the
    network evaluated again on the cycles (``cycle_energy_error`` on their packed samples,
    chunk by chunk, the last chunk wrapped around), to round-off (float64, as the trainer
    validates)."""
    with jax.enable_x64(True):
        _check_cycle_error_of_a_run(hidden)


def _check_cycle_error_of_a_run(hidden: str) -> None:
    rng = np.random.default_rng(5)
    t = np.arange(int(6 * FS)) / FS
    u_s = np.sin(2 * np.pi * (6 + 2 * t) * t) * (0.3 + 0.1 * t)  # 6-30 Hz, growing
    y_s = 0.5 * np.roll(u_s, 3) + 0.05 * rng.standard_normal(u_s.size)
    delays, neurons, rest = (1, 2, 3, 4, 5, 6), 4, 0.0
    theta = pack({"W": rng.standard_normal((neurons, len(delays))),
                  "b": rng.standard_normal(neurons), "c": rng.standard_normal(neurons),
                  "c0": np.array(0.1)})
    cyc = training.energy_cycles(u_s, FS, (5.0, 40.0))
    chunk = 8
    assert cyc.n % chunk  # the last chunk wraps around
    run = nfir_free_run(theta, jnp.asarray(u_s), rest, delays, neurons, hidden)
    got = training.run_cycle_error(np.asarray(run) - y_s, cyc, chunk=chunk)
    up = jnp.asarray(np.concatenate([np.full(max(delays), rest), u_s]))
    idx = np.arange(-(-cyc.n // chunk) * chunk) % cyc.n
    packed = [pack_cycles(cyc, idx[None, k:k + chunk], 0) for k in range(0, idx.size, chunk)]
    want = np.mean([float(training.cycle_energy_error(
        theta, up, jnp.asarray(y_s), c.rows[0], c.weight[0], c.segment[0], chunk, delays,
        neurons, hidden)) for c in packed])
    assert got > 0 and got == pytest.approx(want, rel=1e-12, abs=0)
    # another error is another value: the comparison is not vacuous
    assert training.run_cycle_error(np.asarray(run) - 1.01 * y_s, cyc, chunk=chunk) != \
        pytest.approx(want, rel=1e-6)
    bad = np.asarray(run) - y_s
    bad[np.asarray(cyc.rows)[0, 1]] = np.nan
    assert training.run_cycle_error(bad, cyc, chunk=chunk) == math.inf
