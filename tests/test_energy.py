"""Energy functions on analytic loops, and the Phi_d map machinery on analytic models."""

from __future__ import annotations

import math

import numpy as np
import pytest

from sloshrom.config import Tank
from sloshrom.energy import (
    JAX_BLOCK,
    EnergyError,
    default_grid,
    dissipated_energy,
    hysteresis_loop,
    map_maximum,
    phi_d,
    phi_d_map,
)
from sloshrom.models import FrozenLiquid, tank_of
from sloshrom.plotting.maps import plot_hysteresis, plot_phi_d_map
from sloshrom.rig import VirtualRig
from sloshrom.signals import harmonic

TANK = Tank()


class LinearDamper:
    """f_S = -c w' (so dF = -c w' + m_l w''): Phi_d = pi c / (m_l Omega) exactly."""

    force_rule = "trapezoid"  # point samples (the model contract)

    def __init__(self, c: float, dt: float = 1e-3, tank: Tank = TANK) -> None:
        self.c = c
        self.dt = dt
        self.tank = tank

    def simulate(self, velocity, acceleration):
        return -self.c * np.asarray(velocity) + self.tank.liquid_mass * np.asarray(acceleration)


def _cycles(n_per_cycle: int, n_cycles: int, a: float, om: float):
    t = np.arange(n_per_cycle * n_cycles + 1) * (2 * np.pi / om) / n_per_cycle
    return t, a * np.cos(om * t), -a * om * np.sin(om * t), -a * om**2 * np.cos(om * t)


@pytest.mark.parametrize("rule", ["trapezoid", "step"])
def test_linear_damper_dissipates_pi_c_omega_a2(rule):
    c, a, om = 3.0, 4e-3, 2 * np.pi * 11.0
    t, w, v, acc = _cycles(2000, 3, a, om)
    if rule == "trapezoid":
        f_s = -c * v  # point samples
    else:
        # step averages over [t_k, t_k+1] (the rig's output convention)
        f_s = -c * np.append(np.diff(w) / np.diff(t), 0.0)
        acc = np.append(np.diff(v) / np.diff(t), 0.0)
    l_d = dissipated_energy(w, f_s, n_cycles=3, rule=rule)
    assert l_d == pytest.approx(np.pi * c * om * a**2, rel=1e-5)
    # dF = f_S + m_l w'' gives the same energy over whole cycles
    df = f_s + TANK.liquid_mass * acc
    assert dissipated_energy(w, df, n_cycles=3, rule=rule) == pytest.approx(l_d, rel=1e-6)


def test_elastic_force_dissipates_nothing():
    _, w, _, _ = _cycles(500, 2, 1e-3, 50.0)
    assert abs(dissipated_energy(w, -1e4 * w, n_cycles=2)) < 1e-9


def test_dissipated_energy_batched_and_errors():
    _, w, v, _ = _cycles(400, 1, 2e-3, 30.0)
    ws = np.stack([w, w])
    fs = np.stack([-1.0 * v, -2.0 * v])
    l_d = dissipated_energy(ws, fs)
    assert l_d.shape == (2,)
    assert l_d[1] == pytest.approx(2 * l_d[0])
    with pytest.raises(ValueError):
        dissipated_energy(w, v[:-1])
    with pytest.raises(ValueError):
        dissipated_energy(w, v, rule="simpson")
    with pytest.raises(ValueError):
        dissipated_energy(w, v, n_cycles=0)


def test_hysteresis_loop_area_is_phi_d():
    c, a, om = 2.0, 3e-3, 70.0
    _, w, v, acc = _cycles(3000, 1, a, om)
    df = -c * v + TANK.liquid_mass * acc
    x, y = hysteresis_loop(w, df, acc, a, om, TANK.liquid_mass)
    area = -np.sum(0.5 * (y[1:] + y[:-1]) * np.diff(x))
    expect = phi_d(np.pi * c * om * a**2, a, om, TANK.liquid_mass)
    assert area == pytest.approx(expect, rel=1e-5)
    assert np.max(np.abs(x)) == pytest.approx(1.0)
    with pytest.raises(ValueError):
        hysteresis_loop(w, df, acc, 0.0, om, TANK.liquid_mass)


def test_phi_d_map_of_linear_damper_is_analytic():
    c = 1.5
    model = LinearDamper(c, dt=2e-4)
    ob, ab = default_grid(6)
    da = phi_d_map(model, ob, ab, TANK, n_cycles=3, settle_time=0.0)
    assert da.dims == ("omega_bar", "a_bar")
    assert da.name == "phi_d" and da.attrs["units"] == "1"
    assert da.attrs["model"] == "LinearDamper"
    om = ob * TANK.reference_frequency
    expect = np.pi * c / (TANK.liquid_mass * om)[:, None] * np.ones((1, ab.size))
    ok = np.isfinite(da.values)
    assert ok.sum() > 10
    np.testing.assert_allclose(da.values[ok], expect[ok], rtol=2e-3)
    # outside the shaker envelope (Gamma > 6 g): NaN
    gamma = ab[None, :] * ob[:, None] ** 2
    assert np.all(np.isnan(da.values[gamma > 6.0 + 1e-9]))
    assert np.all(ok[(gamma <= 5.9) & (ab[None, :] <= 0.45)])
    mx = map_maximum(da)
    assert mx["omega_bar"] == pytest.approx(ob[0])


def test_phi_d_map_frozen_is_zero_and_plots(tmp_path):
    ob, ab = default_grid(4)
    da = phi_d_map(FrozenLiquid(1e-3), ob, ab, TANK, n_cycles=2, settle_time=0.0)
    vals = da.values[np.isfinite(da.values)]
    assert vals.size > 0 and np.all(vals == 0.0)
    da2 = phi_d_map(LinearDamper(1.0), ob, ab, TANK, n_cycles=2, settle_time=0.0)
    ax = plot_phi_d_map(da2)
    ax.figure.savefig(tmp_path / "map.png")
    h = harmonic(1000.0, 10.0, 2e-3)
    x, y = hysteresis_loop(h.displacement, 0 * h.velocity, h.acceleration, 2e-3,
                           2 * math.pi * 10.0, TANK.liquid_mass)
    ax2 = plot_hysteresis(x, y, label="frozen")
    ax2.figure.savefig(tmp_path / "loop.png")
    assert (tmp_path / "map.png").stat().st_size > 0


def test_phi_d_map_rejects_bad_grid():
    with pytest.raises(EnergyError, match="1-D grids of positive numbers"):
        phi_d_map(LinearDamper(1.0), [-1.0, 2.0], [0.1], TANK)


def test_phi_d_map_asks_for_the_tank_of_a_model_without_one():
    # a network (or the frozen liquid) does not know its tank: the paper's is not guessed
    with pytest.raises(EnergyError, match="does not say which tank it simulates: pass tank="):
        phi_d_map(FrozenLiquid(1e-3), [1.0], [0.1])
    rig = VirtualRig(Tank(fill=0.4))
    assert tank_of(rig) is rig.tank and tank_of(FrozenLiquid(1e-3)) is None
    assert tank_of(LinearDamper(1.0)) is TANK


class LaggedDamper(LinearDamper):
    """A causal damper with memory (first-order lag on the damping force), flagged as a JAX
    model: its map runs in blocks of one shape. Records the shapes it is called with."""

    def __init__(self, c: float, jax_traceable: bool, dt: float = 2e-3) -> None:
        super().__init__(c, dt=dt)
        self.jax_traceable = jax_traceable
        self.shapes: list[tuple[int, int]] = []

    def simulate(self, velocity, acceleration):
        from scipy.signal import lfilter

        v = np.asarray(velocity)
        self.shapes.append(v.shape)
        lag = lfilter([0.3], [1.0, -0.7], -self.c * v, axis=-1)
        return lag + self.tank.liquid_mass * np.asarray(acceleration)


def test_map_of_a_jax_model_runs_in_blocks_of_one_shape_with_the_same_values():
    ob, ab = default_grid(12)
    blocks = LaggedDamper(1.5, jax_traceable=True)
    one_by_one = LaggedDamper(1.5, jax_traceable=False)
    calls = []
    a = phi_d_map(blocks, ob, ab, TANK, n_cycles=3, progress=lambda d, n: calls.append(d))
    b = phi_d_map(one_by_one, ob, ab, TANK, n_cycles=3)
    # the padding with rest after each test changes nothing before it (a causal model)
    np.testing.assert_array_equal(np.isnan(a.values), np.isnan(b.values))
    np.testing.assert_allclose(a.values, b.values, rtol=1e-12, equal_nan=True)
    assert np.isfinite(a.values).sum() > 40
    # one shape (one compilation for a JAX model), blocks of JAX_BLOCK tests
    assert len(set(blocks.shapes)) == 1 and blocks.shapes[0][0] == JAX_BLOCK
    assert len(set(one_by_one.shapes)) > 1
    assert calls[-1] == ob.size and calls == sorted(calls)


class _Drag:
    """A stub sloshing model: quadratic drag in the fixed frame (not Galilean invariant) or a
    delayed inertia force on the acceleration (invariant), N."""

    def __init__(self, invariant: bool):
        self.invariant = invariant

    def simulate(self, velocity, acceleration):
        if self.invariant:
            return -0.1 * np.roll(acceleration, 3)
        return -2.0 * velocity * np.abs(velocity)


def test_frame_sensitivity_separates_invariant_models():
    from sloshrom.energy import frame_sensitivity

    fs = 500.0
    t = np.arange(5000) / fs
    v = 0.5 * np.sin(2 * np.pi * 10 * t)
    inv = frame_sensitivity(_Drag(True), v, fs, offsets=(0.1, 0.3))
    assert inv["offsets_m_s"] == [0.1, 0.3]
    assert max(inv["energy_change"] + inv["force_change"]) < 1e-12
    drag = frame_sensitivity(_Drag(False), v, fs, offsets=(0.1, 0.3))
    # quadratic drag: F(v + c) - F(v) = -2 (2 c |v| + c^2 sign) where |v| > c: of order 4 c
    # |v| against 2 v^2 (the force RMS 0.25 N): tens of percent, growing with c
    assert 0.1 < drag["force_change"][0] < drag["force_change"][1]
    assert drag["energy_change"][1] > drag["energy_change"][0] > 0.01
    with pytest.raises(EnergyError, match="dissipates no energy"):
        frame_sensitivity(_Drag(True), np.zeros(100), fs)


def test_frame_change_of_runs_made_elsewhere_is_frame_sensitivity():
    from sloshrom.energy import frame_change, frame_probes, frame_sensitivity

    fs = 500.0
    t = np.arange(3000) / fs
    v = 0.4 * np.sin(2 * np.pi * 8 * t) + 0.1 * np.sin(2 * np.pi * 13 * t)
    probes, acc = frame_probes(v, fs, offsets=(0.05, 0.2, 0.3))
    assert probes.shape == (7, v.size)
    np.testing.assert_array_equal(probes[0], v)
    np.testing.assert_array_equal(probes[5], v + 0.3)
    np.testing.assert_array_equal(probes[6], v - 0.3)
    np.testing.assert_array_equal(acc, np.gradient(v) * fs)
    model = _Drag(False)
    forces = [model.simulate(p, acc) for p in probes]
    assert frame_change(probes, fs, forces, offsets=(0.05, 0.2, 0.3)) == frame_sensitivity(
        model, v, fs, offsets=(0.05, 0.2, 0.3))
    with pytest.raises(EnergyError, match="6 forces for 7 probes of 3 offsets"):
        frame_change(probes, fs, forces[:-1], offsets=(0.05, 0.2, 0.3))
    with pytest.raises(EnergyError, match="dissipates no energy"):
        frame_change(probes, fs, [np.zeros_like(v)] + forces[1:], offsets=(0.05, 0.2, 0.3))
