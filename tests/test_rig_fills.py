"""The virtual rig at other fill levels (25 and 75 %): the physics checks of the 50 % rig hold,
and what changes with the fill goes the way the physics says."""

from __future__ import annotations

import math

import numpy as np
import pytest

from sloshrom.config import G, Tank
from sloshrom.energy import default_grid, dissipated_energy, map_maximum, phi_d_map
from sloshrom.rig import VirtualRig, energy_audit
from sloshrom.signals import harmonic

FILLS = (0.25, 0.75)


def _harm(dt: float, f: float, gamma: float, **kw):
    return harmonic(1.0 / dt, f, gamma * G / (2 * math.pi * f) ** 2, **kw)


def _phi(rig: VirtualRig, f: float, gamma: float) -> float:
    h = _harm(rig.dt, f, gamma, n_cycles=8, n_settle=int(0.5 * f) + 2)
    df = rig.simulate(h.velocity, h.acceleration)
    seg = slice(h.steady.start, h.steady.stop + 1)
    l_d = dissipated_energy(h.displacement[seg], df[seg], n_cycles=8, rule=rig.force_rule)
    return float(l_d / (rig.tank.liquid_mass * h.amplitude**2 * (2 * math.pi * f) ** 2))


@pytest.mark.parametrize("fill", FILLS)
@pytest.mark.parametrize("f", [6.0, 24.0])
def test_no_force_below_one_g(fill, f):
    rig = VirtualRig(tank=Tank(fill=fill))
    h = _harm(rig.dt, f, 0.7, n_cycles=10)
    df = rig.simulate(h.velocity, h.acceleration)
    assert np.max(np.abs(df)) < 1e-4  # only the seeded micrometre surface noise
    assert abs(dissipated_energy(h.displacement, df)) < 1e-8


@pytest.mark.parametrize("fill", FILLS)
@pytest.mark.parametrize(("f", "gamma"), [(12.0, 4.0), (20.0, 3.0), (8.0, 2.0)])
def test_energy_balance(fill, f, gamma):
    rig = VirtualRig(tank=Tank(fill=fill))
    au = energy_audit(rig, *(lambda h: (h.velocity, h.acceleration))(
        _harm(rig.dt, f, gamma, n_cycles=8)))
    assert au["released_at_end"] == 0.0
    assert au["work"] > 0 and au["contact_loss"] > 0
    assert abs(au["relative_residual"]) < 0.01


@pytest.mark.parametrize("fill", FILLS)
def test_phi_d_converges_when_dt_halves(fill):
    tank = Tank(fill=fill)
    base, fine = VirtualRig(tank=tank, dt=1e-4), VirtualRig(tank=tank, dt=5e-5)
    for f, gamma in [(12.0, 4.0), (20.0, 3.0)]:
        a, b = _phi(base, f, gamma), _phi(fine, f, gamma)
        assert abs(a - b) / abs(b) < 0.02, (fill, f, gamma, a, b)


@pytest.mark.parametrize("n", [12, pytest.param(30, marks=pytest.mark.slow)])
def test_what_changes_with_the_fill(n):
    """Liquid mass and depth grow with the fill, the ullage gap shrinks. A smaller gap shortens
    the flight of the liquid between floor and ceiling, so the map's dissipation peak moves to
    higher frequency; Phi_d is per kg of liquid, and the energy dissipated per kg falls as the
    liquid fills the tank (less room to fly)."""
    ob, ab = default_grid(n)  # the paper's 30 x 30 grid in the slow tier
    peaks = {}
    for fill in (0.25, 0.5, 0.75):
        tank = Tank(fill=fill)
        peaks[fill] = map_maximum(phi_d_map(VirtualRig(tank=tank), ob, ab, tank=tank))
    lo, mid, hi = (peaks[f] for f in (0.25, 0.5, 0.75))
    assert lo["omega_bar"] < mid["omega_bar"] < hi["omega_bar"]
    assert lo["phi_d"] > mid["phi_d"] > hi["phi_d"] > 0.05
    assert all(1.0 < p["gamma"] <= 6.0 + 1e-9 for p in peaks.values())
    t25, t75 = Tank(fill=0.25), Tank(fill=0.75)
    assert t75.liquid_mass == pytest.approx(3 * t25.liquid_mass)
    assert t75.ullage == pytest.approx(t25.ullage / 3)
