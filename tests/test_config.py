import math

import numpy as np
import pytest

from sloshrom import ConfigError, FrozenLiquid, SloshingModel, Tank
from sloshrom.config import G


def test_default_tank_matches_paper():
    t = Tank()
    assert t.height == pytest.approx(0.0272)
    assert t.depth == pytest.approx(0.0136)
    assert t.ullage == pytest.approx(0.0136)
    # m_l = rho * l1 * l2 * d
    assert t.liquid_mass == pytest.approx(1000 * 0.1172 * 0.078 * 0.0136)
    assert t.liquid_mass == pytest.approx(0.124, abs=1e-3)
    assert t.reference_frequency == pytest.approx(math.sqrt(G / 0.0272))


@pytest.mark.parametrize("fill", [0.0, 1.0, -0.1, 1.5, float("nan"), "half"])
def test_fill_outside_open_interval_is_rejected(fill):
    with pytest.raises(ConfigError, match="fill"):
        Tank(fill=fill)


@pytest.mark.parametrize("name", ["height", "length", "density", "structure_mass"])
def test_non_positive_parameters_are_rejected(name):
    with pytest.raises(ConfigError, match=name):
        Tank(**{name: 0.0})


def test_millimetres_are_caught():
    with pytest.raises(ConfigError, match="millimetres"):
        Tank(height=27.2)


def test_toml_round_trip(tmp_path):
    p = tmp_path / "tank.toml"
    p.write_text("[tank]\nfill = 0.25\nheight = 0.03\n")
    t = Tank.from_toml(p)
    assert t.fill == 0.25 and t.height == 0.03 and t.length == Tank().length
    assert Tank.from_dict(t.to_dict()) == t


def test_toml_errors(tmp_path):
    with pytest.raises(ConfigError, match="not found"):
        Tank.from_toml(tmp_path / "missing.toml")
    bad = tmp_path / "bad.toml"
    bad.write_text("[tank\nfill=")
    with pytest.raises(ConfigError, match="not valid TOML"):
        Tank.from_toml(bad)
    unknown = tmp_path / "unknown.toml"
    unknown.write_text("[tank]\nvolume = 3\n")
    with pytest.raises(ConfigError, match="unknown tank parameter"):
        Tank.from_toml(unknown)


def test_frozen_liquid_contract():
    m = FrozenLiquid(dt=0.002)
    assert isinstance(m, SloshingModel)
    s = m.init_state()
    s2, f = m.step(s, 0.3, -2.0)
    assert f == 0.0
    out = m.simulate(np.ones((3, 10)), np.ones(10))
    assert out.shape == (3, 10) and not out.any()
    with pytest.raises(ValueError, match="dt"):
        FrozenLiquid(dt=0.0)
