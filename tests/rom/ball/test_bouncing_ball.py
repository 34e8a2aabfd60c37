"""The bouncing-ball equivalent mechanical model (sloshrom.rom.ball): exact flight and impacts,
exact energy and momentum bookkeeping, identification, the sloshing-model contract, model files."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
import xarray as xr

from sloshrom.beam.simulation.coupled import CoupledSimulator, free_response
from sloshrom.beam.simulation.structure import ModalModel
from sloshrom.config import G, Tank
from sloshrom.models import FrozenLiquid, SloshingModel, has_kernel
from sloshrom.pipeline.context import Context
from sloshrom.pipeline.html import render_table
from sloshrom.pipeline.settings import load
from sloshrom.rom.ball.model import (
    STATE_NAMES,
    Ball,
    BouncingBall,
    ball_kernel_step,
    forward_acceleration,
    is_ball_file,
)
from sloshrom.rom.errors import NotFittedError, ROMError
from sloshrom.rom.modelfile import ModelFileError
from sloshrom.studies.baseline.config import FREQUENCY_BANDS
from sloshrom.studies.baseline.section import baseline_section
from sloshrom.studies.baseline.stage import comparison_rows, frequency_band_errors

TANK = Tank()
M_L = TANK.liquid_mass
Z, ZD, CONTACT, LOSS, IMPACTS, WORK = (STATE_NAMES.index(n) for n in STATE_NAMES)
FLIGHT, FLOOR, CEILING = 0.0, 1.0, 2.0


def ball(beta: float = 0.5, e: float = 0.5, gap: float = 0.012, fs: float = 1000.0,
         n_substeps: int = 1) -> BouncingBall:
    return BouncingBall.from_parameters(beta, e, gap, fs, n_substeps=n_substeps)


def run_kernel(model: BouncingBall, acc: np.ndarray,
               state: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """States (n + 1, 6) and forces (n,) of the numba kernel, one step per sample of ``acc``."""
    fn, params, st = model.kernel()
    if state is not None:
        st = np.array(state, dtype=float)
    states, forces = [st.copy()], []
    for a in acc:
        forces.append(fn(st, params, 0.0, float(a)))
        states.append(st.copy())
    return np.array(states), np.array(forces)


def ramped_harmonic(fs: float, freq: float, gamma_g: float, n_cycles: int = 12,
                    rest: float = 0.4) -> np.ndarray:
    """Tank acceleration (m/s^2): a harmonic of ``gamma_g`` g ramped over 3 cycles at each end,
    then ``rest`` s of rest (the ball lands and stops)."""
    t = np.arange(int(round(n_cycles * fs / freq))) / fs
    ramp = np.clip(np.minimum(t, t[-1] - t) * freq / 3.0, 0.0, 1.0)
    a = gamma_g * G * ramp * np.sin(2 * np.pi * freq * t)
    return np.concatenate([a, np.zeros(int(rest * fs))])


# -- exact physics ---------------------------------------------------------------------------------
def test_flight_is_the_exact_parabola_and_an_impact_reverses_with_restitution():
    e, gap, fs, beta = 0.4, 0.012, 1000.0, 0.5
    m_b = beta * M_L
    states, forces = run_kernel(ball(beta, e, gap, fs), np.full(250, -2 * G))
    # g + w'' = -g: relative to the tank the ball falls "up" with g from the floor
    t = np.arange(states.shape[0]) / fs
    t_hit = math.sqrt(2 * gap / G)
    v_hit = G * t_hit
    before = t < t_hit
    np.testing.assert_allclose(states[before, Z], 0.5 * G * t[before] ** 2, rtol=1e-12,
                               atol=1e-18)
    np.testing.assert_allclose(states[before, ZD], G * t[before], rtol=1e-12)
    k = int(t_hit * fs)  # the step of the impact
    np.testing.assert_allclose(forces[:k], -m_b * G, rtol=1e-12)  # in flight dF = m_b (g + w'')
    t_back = t_hit + 2 * e * v_hit / G  # back at the ceiling after the first rebound
    after = (t > t_hit) & (t < t_back)
    assert after.sum() > 10
    s = t[after] - t_hit
    np.testing.assert_allclose(states[after, Z], gap - e * v_hit * s + 0.5 * G * s**2,
                               rtol=1e-12)
    np.testing.assert_allclose(states[after, ZD], -e * v_hit + G * s, rtol=1e-10, atol=1e-15)
    # the impact step's force is the step's momentum change, impulse included
    v_next = -e * v_hit + G * (t[k + 1] - t_hit)
    assert forces[k] == pytest.approx(-m_b * (v_next - G * t[k]) * fs, rel=1e-12)
    assert states[k + 1, LOSS] == pytest.approx(0.5 * m_b * (1 - e * e) * v_hit**2, rel=1e-12)
    # the bounces die out (no Zeno chatter): at rest against the ceiling, no force; the whole
    # potential energy m_b g Gap of the relative motion has been dissipated
    assert states[-1, CONTACT] == CEILING and np.all(forces[-20:] == 0.0)
    assert states[-1, LOSS] == pytest.approx(m_b * G * gap, rel=1e-12)


def test_weightless_flight_is_uniform_and_e1_reflects():
    gap, fs, v0 = 0.012, 1000.0, 0.3
    model = ball(0.5, 1.0, gap, fs)
    st = np.array([0.5 * gap, v0, FLIGHT, 0.0, 0.0, 0.0])
    states, forces = run_kernel(model, np.full(400, -G), st)  # g + w'' = 0
    t = np.arange(states.shape[0]) / fs
    # unfolded straight line, folded back into [0, gap] (a triangle wave)
    x = np.mod(0.5 * gap + v0 * t, 2 * gap)
    z = np.where(x <= gap, x, 2 * gap - x)
    np.testing.assert_allclose(states[:, Z], z, atol=1e-14)
    np.testing.assert_allclose(np.abs(states[:, ZD]), v0, rtol=1e-12)
    n_hits = int((t[-1] - 0.5 * gap / v0) // (gap / v0)) + 1  # first after gap/2, then every gap
    assert states[-1, LOSS] == 0.0 and states[-1, IMPACTS] == n_hits == 10
    # force only in the steps of an impact: 2 m_b v0 / dt in magnitude
    hits = np.flatnonzero(forces != 0.0)
    assert hits.size == n_hits
    np.testing.assert_allclose(np.abs(forces[hits]), 2 * 0.5 * M_L * v0 * fs, rtol=1e-12)


@pytest.mark.parametrize("freq", [3.0, 12.0, 25.0])
def test_at_rest_under_steady_motion_below_one_g_no_force(freq):
    model = ball(0.8, 0.3, 0.012, 2000.0)
    t = np.arange(4000) / 2000.0
    acc = 0.95 * G * np.sin(2 * np.pi * freq * t)
    states, forces = run_kernel(model, acc)
    assert np.all(forces == 0.0)
    np.testing.assert_array_equal(states[-1], model.init_state())
    assert np.all(model.simulate(np.zeros_like(acc), acc) == 0.0)


@pytest.mark.parametrize("e", [0.0, 0.3, 0.9, 1.0])
def test_energy_balance_is_exact(e):
    """Work of the tank = change of the ball's energy + the impact losses, to round-off.

    With the acceleration a_k held over step k the pseudo-force -m_b w'' does the work
    W_k = -m_b a_k (z_k+1 - z_k) on the relative motion (energy m_b zdot^2/2 + m_b g z). The
    tank's absolute work on the liquid, integral of -dF w' over the step with
    w'(t) = w'_k + a_k (t - t_k), is W_k + m_b (zdot w')|_k^k+1, where zdot comes from the force
    output (zdot_k+1 = zdot_k - dF_k dt / m_b): over a record from rest to rest it equals the
    impact losses.
    """
    fs, beta, gap = 2000.0, 0.6, 0.012
    m_b = beta * M_L
    acc = ramped_harmonic(fs, 14.0, 3.5, rest=0.0 if e == 1.0 else 0.5)
    states, forces = run_kernel(ball(beta, e, gap, fs), acc)
    z, zd, loss = states[:, Z], states[:, ZD], states[:, LOSS]
    assert states[-1, IMPACTS] > 10
    work = -m_b * np.cumsum(acc * np.diff(z))
    np.testing.assert_allclose(states[1:, WORK], work, rtol=1e-12, atol=1e-15)
    energy = 0.5 * m_b * zd**2 + m_b * G * z
    scale = np.sum(np.abs(acc * np.diff(z))) * m_b  # the size of the terms summed
    np.testing.assert_allclose(work, energy[1:] - energy[0] + loss[1:], rtol=0, atol=1e-13 * scale)
    if e == 1.0:
        assert loss[-1] < 1e-9 * scale  # nothing lost (only a rest capture could)
        return
    assert loss[-1] > 0.01 * scale
    assert states[-1, CONTACT] == FLOOR and zd[-1] == 0.0  # at rest at the end
    # absolute work of the tank, from the force output and the exact ZOH tank velocity
    zd_out = np.concatenate([[0.0], -np.cumsum(forces) / fs / m_b])
    np.testing.assert_allclose(zd_out, zd, rtol=0, atol=1e-12 * np.max(np.abs(zd)))
    wd = np.concatenate([[0.0], np.cumsum(acc) / fs])
    w_abs = np.sum(-m_b * acc * np.diff(z)) + m_b * (zd_out[-1] * wd[-1] - zd_out[0] * wd[0])
    assert w_abs == pytest.approx(loss[-1], rel=1e-12)


def test_force_rule_the_averaged_impulse_is_the_momentum_change():
    fs, beta = 1000.0, 0.7
    m_b = beta * M_L
    acc = ramped_harmonic(fs, 9.0, 4.5)
    states, forces = run_kernel(ball(beta, 0.2, 0.01, fs), acc)
    np.testing.assert_allclose(forces / fs, -m_b * np.diff(states[:, ZD]), rtol=1e-12,
                               atol=1e-18)
    assert np.sum(forces) / fs == pytest.approx(-m_b * (states[-1, ZD] - states[0, ZD]),
                                                abs=1e-15)
    # the in-flight steps give m_b (g + a) exactly
    flight = (states[:-1, CONTACT] == FLIGHT) & (states[1:, IMPACTS] == states[:-1, IMPACTS]) \
        & (states[1:, CONTACT] == FLIGHT)
    assert flight.sum() > 100
    np.testing.assert_allclose(forces[flight], m_b * (G + acc[flight]), rtol=1e-9)


# -- the sloshing-model contract -------------------------------------------------------------------
def test_step_simulate_and_kernel_agree_and_step_is_pure():
    model = ball(0.5, 0.3, 0.012, 1000.0)
    acc = np.stack([ramped_harmonic(1000.0, 11.0, 3.0), ramped_harmonic(1000.0, 11.0, 5.0)])
    batch = model.simulate(np.zeros_like(acc), acc)
    assert batch.shape == acc.shape
    for row, out in zip(acc, batch, strict=True):
        _, f_kernel = run_kernel(model, row)
        st, f_step = model.init_state(), []
        for a in row:
            before = st.copy()
            new, f = model.step(st, 0.0, a)
            np.testing.assert_array_equal(st, before)  # not modified
            st = new
            f_step.append(f)
        np.testing.assert_array_equal(out, f_kernel)
        np.testing.assert_array_equal(out, np.array(f_step))
    # leading axes are independent runs, broadcast with the velocity
    three = model.simulate(np.zeros((3, 1, acc.shape[1])), acc[0])
    assert three.shape == (3, 1, acc.shape[1])
    np.testing.assert_array_equal(three[2, 0], batch[0])


def test_predict_at_the_record_rate_is_the_substepped_model_averaged():
    fs, n = 500.0, 4
    model = ball(0.5, 0.3, 0.012, fs, n_substeps=n)
    assert model.dt == pytest.approx(1 / (fs * n))
    # a short record: the ball is chaotic, so round-off (the sum of n sub-step flights is the
    # one flight only to ~1e-16) grows over long records; the physics is the same
    t = np.arange(600) / fs
    u = 0.4 * np.sin(2 * np.pi * 9.0 * t) * np.clip(t, 0, 1)
    a = forward_acceleration(u, fs)
    np.testing.assert_allclose(np.cumsum(a[:-1]) / fs, u[1:] - u[0], atol=1e-12)
    coarse = model.predict(u)
    fine = model.simulate(np.zeros(a.size * n), np.repeat(a, n)).reshape(-1, n).mean(axis=1)
    np.testing.assert_allclose(coarse, fine, rtol=0, atol=1e-9 * np.max(np.abs(coarse)))
    np.testing.assert_array_equal(model.predict(u, acceleration=a), coarse)


def test_protocols_params_and_not_fitted():
    est = BouncingBall()
    assert not isinstance(est, SloshingModel)  # no dt before fit
    with pytest.raises(NotFittedError):
        est.predict(np.zeros(10))
    with pytest.raises(NotFittedError):
        est.kernel()
    params = est.get_params()
    assert params["mass_fraction"] == (0.05, 1.0) and params["restitution"] == (0.0, 0.95)
    assert params["gap_factor"] == (0.2, 2.0) and params["seed"] == 0
    assert est.set_params(seed=3, maxiter=5) is est and est.seed == 3
    with pytest.raises(ROMError, match="no parameter 'beta'"):
        est.set_params(beta=0.3)
    model = ball()
    assert isinstance(model, SloshingModel) and has_kernel(model)
    assert isinstance(model.envelope_, dict) and model.force_rule == "step"
    fn, params, state = model.kernel()
    assert fn is ball_kernel_step and params.shape == (5,) and state.shape == (6,)


# -- identification --------------------------------------------------------------------------------
TRUE = {"beta": 0.4, "e": 0.3, "gamma": 0.8}


def vfa_record(fs: float = 500.0) -> tuple[np.ndarray, np.ndarray]:
    """Tank velocity (m/s) of a short stepped-sine test: 2 s at each of 7, 10, 13, 16 Hz with
    2-5 g, ramped, from rest to rest."""
    parts = []
    for f, gam in ((7.0, 2.5), (10.0, 4.0), (13.0, 3.0), (16.0, 5.0)):
        t = np.arange(int(2 * fs)) / fs
        ramp = np.clip(np.minimum(t, t[-1] - t) / 0.5, 0, 1)
        parts.append(-gam * G / (2 * np.pi * f) * ramp * np.cos(2 * np.pi * f * t) * ramp)
    return np.concatenate(parts), np.arange(0)


@pytest.fixture(scope="module")
def fitted() -> tuple[BouncingBall, np.ndarray, np.ndarray]:
    fs = 500.0
    u, _ = vfa_record(fs)
    truth = BouncingBall.from_parameters(TRUE["beta"], TRUE["e"], TRUE["gamma"] * TANK.ullage,
                                         fs)
    y = truth.predict(u)
    est = BouncingBall(maxiter=25, popsize=8, seed=1)
    assert est.fit(u, y, fs, validation=(u[::-1].copy(), y[::-1].copy())) is est
    return est, u, y


def test_identification_recovers_the_parameters_of_a_ball(fitted):
    est, u, y = fitted
    assert est.mass_fraction_ == pytest.approx(TRUE["beta"], rel=0.03)
    assert est.gap_ / TANK.ullage == pytest.approx(TRUE["gamma"], rel=0.03)
    assert est.restitution_ == pytest.approx(TRUE["e"], abs=0.05)
    h = est.history_
    # the target is the trapezoid average of the record's samples, the data here step averages:
    # half a sample apart (0.1 rad at 16 Hz), an error of this size even at the true parameters
    assert h["nrmse"] < 0.2 and h["evaluations"] > 100 and h["seconds"] > 0
    assert set(est.envelope_) == {"input_min", "input_max", "output_min", "output_max",
                                  "frequency_band", "acceleration_max"}
    # the ball reads the acceleration: its envelope is an acceleration range
    assert est.input == "acceleration"
    assert est.envelope_["input_max"] == pytest.approx(np.max(forward_acceleration(u, 500.0)))
    assert est.envelope_["acceleration_max"] >= est.envelope_["input_max"]
    assert est.dt == pytest.approx(1e-4)  # default sub-steps: the rig's step
    assert "validation_nrmse" in h


def test_the_fitted_ball_is_an_immutable_model_the_estimator_delegates_to(fitted):
    est, u, _ = fitted
    m = est.model_
    assert isinstance(m, Ball) and isinstance(m, SloshingModel) and has_kernel(m)
    assert (m.mass_fraction, m.restitution, m.gap, m.dt) == \
        (est.mass_fraction_, est.restitution_, est.gap_, est.dt)
    assert m.input == est.input == "acceleration" and m.fill_range == est.fill_range
    with pytest.raises(dataclasses.FrozenInstanceError):
        m.gap = 0.0
    a = forward_acceleration(u[:400], 1.0 / est.dt)
    np.testing.assert_array_equal(m.simulate(None, a), est.simulate(None, a))
    state, forces = m.init_state(), []
    for ak in a[:50]:
        state, f = m.step(state, 0.0, ak)
        forces.append(f)
    np.testing.assert_allclose(forces, m.simulate(None, a[:50]), rtol=1e-12, atol=1e-12)


def test_fit_is_deterministic(fitted):
    est, u, y = fitted
    again = BouncingBall(**est.get_params()).fit(u, y, 500.0)
    assert (again.mass_fraction_, again.restitution_, again.gap_) == \
        (est.mass_fraction_, est.restitution_, est.gap_)


# -- the coupled beam ------------------------------------------------------------------------------
def test_the_coupled_beam_runs_the_ball_in_numba_and_it_damps():
    modal = ModalModel.from_beam(n_modes=2)
    model = ball(0.6, 0.2, TANK.ullage, 500.0, n_substeps=4)
    assert CoupledSimulator(model, modal).backend == "numba"
    res = free_response(model, modal, duration=3.0, output_fs=500.0)
    # frozen liquid through the plain loop (no JAX compilation in the fast tests)
    frozen = CoupledSimulator(FrozenLiquid(model.dt), modal, output_fs=500.0,
                              backend="python").run(np.zeros(res["q"].shape[0] * 4),
                                                     q0=res["q0"])
    assert np.all(np.isfinite(res["tank_acceleration"]))
    assert np.max(np.abs(res["tank_acceleration"])) > 3 * G  # the ball lifts off
    late = res["time"] > 2.0
    assert np.max(np.abs(res["tank_acceleration"][late])) < \
        0.9 * np.max(np.abs(frozen["tank_acceleration"][late]))
    assert np.any(res["dynamic_force"] != 0.0)


# -- model files -----------------------------------------------------------------------------------
def test_save_load_round_trip_is_exact(fitted, tmp_path):
    est, u, _ = fitted
    path = est.save(tmp_path / "ball.toml")
    assert is_ball_file(path)
    back = BouncingBall.load(path)
    assert (back.mass_fraction_, back.restitution_, back.gap_, back.fs_, back.n_substeps_) == \
        (est.mass_fraction_, est.restitution_, est.gap_, est.fs_, est.n_substeps_)
    assert back.envelope_ == est.envelope_
    assert back.history_ == est.history_
    assert back.get_params() == {**est.get_params(), "tank": TANK}
    np.testing.assert_array_equal(back.predict(u), est.predict(u))
    text = path.read_text()
    assert "[bouncing_ball]" in text and "gap_m" in text


def test_a_version_1_file_reads_its_velocity_range_as_the_peak_acceleration(fitted, tmp_path):
    # version 1 stored the velocity's range as the input range; the ball reads the acceleration
    est, _, _ = fitted
    text = est.save(tmp_path / "ball.toml").read_text()
    assert "format_version = 2" in text
    old = tmp_path / "v1.toml"
    old.write_text(text.replace("format_version = 2", "format_version = 1"))
    env = BouncingBall.load(old).envelope_
    peak = est.envelope_["acceleration_max"]
    assert (env["input_min"], env["input_max"]) == (-peak, peak)
    assert BouncingBall.load(tmp_path / "ball.toml").envelope_ == est.envelope_


def _good_text(tmp_path) -> str:
    return ball().save(tmp_path / "good.toml").read_text()


@pytest.mark.parametrize("edit, match", [
    (lambda s: s.replace("bouncing_ball", "ball"), "no \\[bouncing_ball\\] table"),
    (lambda s: s.replace("restitution = 0.5\n", ""), "no key 'restitution'"),
    (lambda s: s.replace("restitution = 0.5\n", "restitution = \"0.5\"\n"), "wrong type"),
    (lambda s: s.replace("restitution = 0.5\n", "restitution = 1.5\n"), "restitution 1.5"),
    (lambda s: s.replace("mass_fraction = 0.5\n", "mass_fraction = 0.0\n"), "mass_fraction"),
    (lambda s: s.replace("gap_m = 0.012\n", "gap_m = -0.012\n"), "gap"),
    (lambda s: s.replace("gap_m = 0.012\n", "gap_m = 0.011\n"), "contradicts"),
    (lambda s: s.replace("fs_hz = 1000.0\n", "fs_hz = nan\n"), "finite"),
    (lambda s: s.replace("format_version = 2", "format_version = 3"), "version 3"),
    (lambda s: s.replace("sloshrom-bouncing-ball", "other"), "format 'other'"),
    (lambda s: s.replace("fill = 0.5", "fill = 1.5"), "fill"),
    (lambda s: s + "\n[[oops", "not a valid TOML"),
])
def test_bad_model_files_give_clear_errors(tmp_path, edit, match):
    bad = tmp_path / "bad.toml"
    bad.write_text(edit(_good_text(tmp_path)))
    with pytest.raises(ModelFileError, match=match):
        BouncingBall.load(bad)


def test_missing_and_foreign_files(tmp_path):
    with pytest.raises(ModelFileError, match="no such model file"):
        BouncingBall.load(tmp_path / "none.toml")
    other = tmp_path / "other.toml"
    other.write_text("[tank]\nfill = 0.5\n")
    assert not is_ball_file(other) and not is_ball_file(tmp_path / "none.toml")
    with pytest.raises(ROMError, match="ends in .toml"):
        ball().save(tmp_path / "ball.npz")


# -- bad input -------------------------------------------------------------------------------------
def _record(n: int = 1500, fs: float = 500.0) -> tuple[np.ndarray, np.ndarray]:
    t = np.arange(n) / fs
    u = -3 * G / (2 * np.pi * 10) * np.cos(2 * np.pi * 10 * t) * np.clip(t, 0, 1)
    return u, ball(fs=fs).predict(u)


@pytest.mark.parametrize("change, match", [
    (dict(u=np.full(1500, np.nan)), "u contains NaN"),
    (dict(y=np.zeros(1400)), "same length"),
    (dict(fs=0.0), "fs must be a finite positive"),
    (dict(fs=-500.0), "fs must be a finite positive"),
    (dict(u=np.zeros(50), y=np.ones(50)), "too short"),
    (dict(y=np.zeros(1500)), "constant"),
    (dict(u=np.zeros((2, 1500))), "shape"),
    (dict(acceleration=np.zeros(1500)), "never falls below -g"),
    (dict(acceleration=np.zeros(10)), "length"),
    (dict(validation=(np.zeros(1500),)), "validation must be"),
])
def test_bad_records_give_clear_errors(change, match):
    u, y = _record()
    kw = {"u": u, "y": y, "fs": 500.0, **change}
    with pytest.raises(ROMError, match=match):
        BouncingBall(maxiter=1, popsize=2).fit(**kw)


@pytest.mark.parametrize("params, match", [
    (dict(restitution=(0.9, 0.1)), "out of order"),
    (dict(restitution=(0.0, 1.5)), "outside the physical range"),
    (dict(mass_fraction=(0.0, 0.5)), "outside the physical range"),
    (dict(gap_factor=(0.5, 20.0)), "outside the physical range"),
    (dict(gap_factor=(0.5,)), "pair"),
    (dict(mass_fraction=(0.1, float("nan"))), "finite"),
    (dict(seed=-1), "seed"),
    (dict(maxiter=0), "maxiter"),
    (dict(n_substeps=0), "n_substeps"),
    (dict(lowpass=-3.0), "lowpass"),
    (dict(lowpass=400.0), "Nyquist"),
    (dict(tank="paper"), "Tank"),
])
def test_bad_hyperparameters_give_clear_errors(params, match):
    u, y = _record()
    with pytest.raises(ROMError, match=match):
        BouncingBall(**{"maxiter": 1, "popsize": 2, **params}).fit(u, y, 500.0)


def test_fixed_parameters_are_not_searched():
    u, y = _record()
    est = BouncingBall(mass_fraction=(0.5, 0.5), restitution=(0.5, 0.5), gap_factor=(0.2, 2.0),
                       maxiter=5, popsize=5).fit(u, y, 500.0)
    assert est.mass_fraction_ == 0.5 and est.restitution_ == 0.5


# -- the pipeline's comparison ---------------------------------------------------------------------
def test_frequency_band_errors_and_the_report_section(tmp_path):
    ob, ab = np.linspace(1.0, 7.0, 6), np.linspace(0.01, 0.4, 4)
    ref = xr.DataArray(np.ones((6, 4)), dims=("omega_bar", "a_bar"),
                       coords={"omega_bar": ob, "a_bar": ab, "frequency": ("omega_bar", 3 * ob)})
    other = ref.copy(data=np.ones((6, 4)) * np.array([1.1, 1.1, 1.0, 1.0, 0.5, 0.5])[:, None])
    errs = frequency_band_errors(ref, other.transpose("a_bar", "omega_bar"))
    assert [errs[b]["full_l2"] for b in FREQUENCY_BANDS] == pytest.approx([0.1, 0.0, 0.5])
    assert errs["high"]["frequency_hz"] == pytest.approx([17.4, 21.0])
    assert errs["low"]["n_points"] == 8
    fid = {"full_l2": 0.3, "dissipative_l2": 0.35, "n_nonpassive": 0}
    inst = {c: {"1-2 g": z, "initial_tank_acceleration_g": 8.0}
            for c, z in (("ball", 0.011), ("rom", 0.012), ("rig", 0.0115), ("frozen", 0.01))}
    outputs = {
        "parameters": ball().parameters(), "fit": {"evaluations": 10, "lowpass_hz": 25.0},
        "fit_seconds": 1.0, "ball_fidelity": fid, "rom_fidelity": {**fid, "full_l2": 0.1},
        "validation_nrmse_lowpassed": {"ball": 0.6, "rom": 0.3},
        "frequency_bands": {"ball": errs, "rom": {b: {**v, "full_l2": 0.05} for b, v in
                                                   errs.items()}},
        "instantaneous_damping_all": inst,
        "table2_all": [{"case": c, "rms_g": 0.1, "lscf_h1": z} for c, z in
                       (("ball", 0.013), ("rom", 0.016), ("rig", 0.0131), ("frozen", 0.0104))],
        "rig_mass_fraction": 0.8,
    }
    outputs["comparison"] = comparison_rows(outputs)
    assert [r["model"] for r in outputs["comparison"]] == ["ball", "rom", "rig", "frozen"]
    assert outputs["comparison"][0]["table2_vs_rig"]["0.1"] == pytest.approx(0.013 / 0.0131 - 1)
    sec = baseline_section(Context(tmp_path, load()), outputs)
    assert "closer to the rig at 1 of 1 levels" in sec.text
    assert "worse model in 2 of the 3 bands" in sec.text
    html = render_table(sec.tables[1])
    assert "ball" in html and "-1 %" in html


def test_a_ball_is_refused_at_another_fill_like_a_rom():
    """The ball's mass and gap belong to its tank's fill: another fill is refused, as a ROM's."""
    from sloshrom.rom.errors import FillRangeError
    from sloshrom.rom.family import at_fill, training_fills

    model = BouncingBall.from_parameters(0.5, 0.3, 0.01, 500.0, tank=Tank(fill=0.25))
    assert model.fill_range == (0.25, 0.25) and training_fills(model) == (0.25, 0.25)
    assert at_fill(model, 0.252, "ball.toml") is model  # within the gauge tolerance
    with pytest.raises(FillRangeError, match=r"ball\.toml was identified at fill 25\.0%; fill "
                                             r"50\.0% is outside"):
        at_fill(model, 0.5, "ball.toml")
