"""One definition of the shaker envelope (signals.SHAKER_ENVELOPE) and of the shaker limits."""

from __future__ import annotations

import inspect
import math
import tomllib
from pathlib import Path

import numpy as np
import pytest

from sloshrom import energy, signals
from sloshrom.config import G, Tank
from sloshrom.signals import SHAKER_ENVELOPE, SHAKER_LIMITS, ShakerEnvelope, ShakerLimits

DEFAULTS_TOML = Path(signals.__file__).parent / "pipeline" / "defaults.toml"


def test_the_paper_envelope():
    assert (SHAKER_ENVELOPE.f_min, SHAKER_ENVELOPE.f_max) == (5.0, 25.0)
    assert SHAKER_ENVELOPE.gamma_max == 6.0
    assert SHAKER_ENVELOPE.a_bar_max == 0.45
    assert ShakerEnvelope() == SHAKER_ENVELOPE


@pytest.mark.parametrize(
    "func",
    [signals.vfa, signals.vfa_gamma_limit, energy.shaker_envelope, energy.phi_d_map],
)
def test_defaults_come_from_the_one_envelope(func):
    params = inspect.signature(func).parameters
    names = [n for n in ("f_min", "f_max", "gamma_max", "a_bar_max") if n in params]
    assert names
    for name in names:
        assert params[name].default == getattr(SHAKER_ENVELOPE, name), name


def test_default_grid_spans_the_envelope():
    tank = Tank()
    ob, ab = energy.default_grid(5, tank)
    f = ob * tank.reference_frequency / (2 * math.pi)
    assert f[0] == pytest.approx(SHAKER_ENVELOPE.f_min)
    assert f[-1] == pytest.approx(SHAKER_ENVELOPE.f_max)
    assert (ab[0], ab[-1]) == (signals.DEFAULT_A_BAR_MIN, SHAKER_ENVELOPE.a_bar_max)


def test_pipeline_defaults_agree_with_the_envelope():
    # defaults.toml cannot import the constant: this test keeps the two equal
    with DEFAULTS_TOML.open("rb") as fh:
        m = tomllib.load(fh)["map"]
    assert m["f_min"] == SHAKER_ENVELOPE.f_min
    assert m["f_max"] == SHAKER_ENVELOPE.f_max
    assert m["gamma_max"] == SHAKER_ENVELOPE.gamma_max
    assert m["a_bar_max"] == SHAKER_ENVELOPE.a_bar_max
    assert m["a_bar_min"] == signals.DEFAULT_A_BAR_MIN


def test_limits_share_the_acceleration_limit():
    assert ShakerLimits() == SHAKER_LIMITS
    assert SHAKER_LIMITS.max_acceleration == SHAKER_ENVELOPE.gamma_max * G


def test_paper_tank_envelope_is_inside_the_shaker_limits():
    # the map's envelope (a_bar, Gamma) and the shaker's (stroke, velocity) describe one domain
    # for the paper tank: every point the map plays, the shaker can play
    tank = Tank()
    f = np.linspace(SHAKER_ENVELOPE.f_min, SHAKER_ENVELOPE.f_max, 2001)
    om = 2 * np.pi * f
    a = np.minimum(SHAKER_ENVELOPE.a_bar_max * tank.height, SHAKER_ENVELOPE.gamma_max * G / om**2)
    assert a.max() <= SHAKER_LIMITS.max_displacement
    assert (a * om).max() <= SHAKER_LIMITS.max_velocity
    assert (a * om**2).max() <= SHAKER_LIMITS.max_acceleration * (1 + 1e-12)


@pytest.mark.parametrize(
    "kw",
    [{"f_min": 0.0}, {"f_max": float("inf")}, {"f_min": 30.0}, {"gamma_max": -1.0},
     {"a_bar_max": float("nan")}],
)
def test_envelope_validation(kw):
    with pytest.raises(ValueError, match="ShakerEnvelope"):
        ShakerEnvelope(**kw)
