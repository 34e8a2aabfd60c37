"""Modal beam model: frequency equation, finite-element cross-check, modal data validation."""

import numpy as np
import pytest
from scipy.linalg import eigh

from sloshrom.beam.simulation.structure import (
    CantileverBeam,
    ModalDataError,
    ModalModel,
    coupled_frozen_modes,
    frozen_modal_table,
)
from sloshrom.config import ConfigError, Tank


def test_bare_cantilever_roots():
    np.testing.assert_allclose(CantileverBeam().beta_l(3), [1.8751, 4.6941, 7.8548], atol=1e-4)


def test_a_beams_roots_are_solved_once_and_handed_out_as_copies():
    from sloshrom.beam.simulation.structure import _beta_l

    beam = CantileverBeam(length=0.6173, tip_mass=0.25)  # no other test solves this beam
    before = _beta_l.cache_info()
    roots = beam.beta_l(3)
    ModalModel.from_beam(beam)  # frequencies, shapes, integrals: all from the same roots
    after = _beta_l.cache_info()
    assert after.misses == before.misses + 1 and after.hits > before.hits
    roots[:] = 0.0  # the caller's copy
    np.testing.assert_array_equal(CantileverBeam(length=0.6173, tip_mass=0.25).beta_l(3),
                                  _beta_l(beam, 3))
    assert np.all(beam.beta_l(3) > 1.0)
    assert not np.allclose(CantileverBeam(length=0.6173, tip_mass=0.3).beta_l(3),
                           beam.beta_l(3))


def _fe_frequencies(beam: CantileverBeam, n_el: int = 60, n_modes: int = 3) -> np.ndarray:
    """Hermite cubic beam elements, clamped at x = 0, lumped tip mass + rotary inertia."""
    le = beam.length / n_el
    ei, mu = beam.EI, beam.mu
    k = ei / le**3 * np.array(
        [[12, 6 * le, -12, 6 * le], [6 * le, 4 * le**2, -6 * le, 2 * le**2],
         [-12, -6 * le, 12, -6 * le], [6 * le, 2 * le**2, -6 * le, 4 * le**2]])
    m = mu * le / 420 * np.array(
        [[156, 22 * le, 54, -13 * le], [22 * le, 4 * le**2, 13 * le, -3 * le**2],
         [54, 13 * le, 156, -22 * le], [-13 * le, -3 * le**2, -22 * le, 4 * le**2]])
    nd = 2 * (n_el + 1)
    kg, mg = np.zeros((nd, nd)), np.zeros((nd, nd))
    for e in range(n_el):
        s = slice(2 * e, 2 * e + 4)
        kg[s, s] += k
        mg[s, s] += m
    mg[-2, -2] += beam.tip_mass
    mg[-1, -1] += beam.tip_inertia
    w2 = eigh(kg[2:, 2:], mg[2:, 2:], eigvals_only=True)[:n_modes]
    return np.sqrt(w2) / (2 * np.pi)


@pytest.mark.parametrize("tip_mass, tip_inertia", [(0.0, 0.0), (0.574, 0.0), (0.574, 1e-3)])
def test_frequencies_match_finite_elements(tip_mass, tip_inertia):
    beam = CantileverBeam(tip_mass=tip_mass, tip_inertia=tip_inertia)
    np.testing.assert_allclose(beam.frequencies(3), _fe_frequencies(beam), rtol=2e-4)


def test_modal_properties_consistent():
    beam = CantileverBeam.with_tank(Tank())
    p = beam.modal_properties(3)
    # Rayleigh quotient of the exact mode = omega^2 (checks masses, inertia and BC signs)
    np.testing.assert_allclose(p["modal_stiffness"] / p["modal_mass"],
                               (2 * np.pi * p["frequency"]) ** 2, rtol=1e-6)
    x = np.linspace(0, beam.length, 3001)
    psi = beam.mode_shapes(x, 3)
    np.testing.assert_allclose(np.abs(psi).max(axis=0), 1.0, rtol=1e-6)  # unit max displacement
    assert np.all(p["psi_tip"] > 0)
    # mass orthogonality, including tip mass and rotary inertia
    from scipy.integrate import simpson

    rot = beam.mode_shapes([beam.length], 3, deriv=1)[0]
    m12 = (beam.mu * simpson(psi[:, 0] * psi[:, 1], x=x) + beam.tip_mass * psi[-1, 0] * psi[-1, 1]
           + beam.tip_inertia * rot[0] * rot[1])
    assert abs(m12) < 1e-6 * p["modal_mass"][0]


def test_static_tip_state_matches_projection():
    tank = Tank()
    beam = CantileverBeam.with_tank(tank)
    modal = ModalModel.from_beam(beam, tank, n_modes=3)
    q = modal.static_tip_state(0.0146)
    assert modal.psi_tank @ q == pytest.approx(0.0146, rel=1e-12)
    # mass-weighted projection of the exact static shape on the modes
    from scipy.integrate import simpson

    x = np.linspace(0, beam.length, 4001)
    w = beam.static_tip_shape(x, 0.0146)
    wp = 0.0146 * 3 / (2 * beam.length)  # slope at the tip
    psi = beam.mode_shapes(x, 3)
    rot = beam.mode_shapes([beam.length], 3, deriv=1)[0]
    proj = (beam.mu * simpson(psi * w[:, None], x=x, axis=0) + beam.tip_mass * psi[-1] * w[-1]
            + beam.tip_inertia * rot * wp) / modal.modal_masses
    np.testing.assert_allclose(q, proj, rtol=0.02, atol=1e-3 * abs(q[0]))


def test_frozen_table_against_independent_models():
    tank = Tank()
    rows = frozen_modal_table(tank, n_modes=3)
    assert [r["mode"] for r in rows] == [1, 2, 3]
    # f_frozen (frequency equation, liquid added to the tip mass) against finite elements
    dry = CantileverBeam.with_tank(tank)
    frozen = CantileverBeam(tip_mass=dry.tip_mass + tank.liquid_mass, tip_inertia=dry.tip_inertia)
    f_fe = _fe_frequencies(frozen)
    np.testing.assert_allclose([r["f_frozen_Hz"] for r in rows], f_fe, rtol=2e-4)
    assert all(r["f_frozen_Hz"] < r["f_dry_Hz"] for r in rows)  # added mass lowers every mode
    # f_coupled (the truncated model M + m_l psi psi^T on the dry modes) is a Rayleigh-Ritz
    # estimate: an upper bound of the exact frozen frequency that falls toward it as modes are
    # added
    f3 = coupled_frozen_modes(ModalModel.from_beam(n_modes=3), tank.liquid_mass)[0]
    f8 = coupled_frozen_modes(ModalModel.from_beam(n_modes=8), tank.liquid_mass)[0][:3]
    assert np.all(f3 >= f8 - 1e-9) and np.all(f8 >= f_fe * (1 - 2e-4))
    np.testing.assert_allclose(f8, f_fe, rtol=1e-3)
    np.testing.assert_allclose([r["f_coupled_Hz"] for r in rows], f3, rtol=1e-12)


def _good() -> dict:
    return ModalModel.from_beam().to_dict()


@pytest.mark.parametrize(
    "key, value, match",
    [
        ("modal_masses", [1.0, 0.0, 1.0], "modal masses must be positive"),
        ("frequencies", [10.0, -1.0, 200.0], "frequencies must be positive"),
        ("stations", [0.1, 0.2, 0.3, 0.5, 0.9], "off the beam"),
        ("damping", [0.01, 0.01], "one value per mode"),
    ],
)
def test_bad_modal_data(key, value, match):
    d = _good()
    d[key] = value
    with pytest.raises(ModalDataError, match=match):
        ModalModel.from_dict(d)


def test_modal_data_from_toml(tmp_path):
    import tomli_w

    d = _good()
    p = tmp_path / "modal.toml"
    p.write_bytes(tomli_w.dumps({"modal": d}).encode())
    m = ModalModel.from_toml(p)
    np.testing.assert_allclose(m.frequencies, d["frequencies"])
    # without participation factors the structure loads for free responses only
    d.pop("participation")
    p.write_bytes(tomli_w.dumps({"modal": d}).encode())
    m = ModalModel.from_toml(p)
    assert not m.has_participation and "participation" not in m.to_dict()
    from sloshrom.beam.simulation.coupled import CoupledSimulator
    from sloshrom.models import FrozenLiquid

    sim = CoupledSimulator(FrozenLiquid(0.002), m)
    assert np.all(np.isfinite(sim.run(np.zeros(50), q0=np.full(m.n_modes, 1e-3))["q"]))
    with pytest.raises(ModalDataError, match="participation"):
        sim.run(np.ones(50))
    with pytest.raises(ConfigError, match="not found"):
        ModalModel.from_toml(tmp_path / "missing.toml")


def test_stations_off_beam_from_beam():
    with pytest.raises(ModalDataError, match="off the beam"):
        ModalModel.from_beam(stations=(0.1, 0.8))
    with pytest.raises(ConfigError):
        CantileverBeam(thickness=0.0)


def test_frozen_mass_matrix_and_no_coupled_import():
    import subprocess
    import sys

    from sloshrom.beam.simulation import structure

    modal = ModalModel.from_beam()
    ml = Tank().liquid_mass
    mf = structure.frozen_mass_matrix(modal, ml)
    expected = np.diag(modal.modal_masses) + ml * np.outer(modal.psi_tank, modal.psi_tank)
    np.testing.assert_array_equal(mf, expected)
    w2, _ = eigh(np.diag(modal.stiffness), mf)
    np.testing.assert_allclose(coupled_frozen_modes(modal, ml)[0], np.sqrt(w2) / (2 * np.pi))
    # the structure does not know the coupled simulation (no import circle, no re-export)
    assert not hasattr(structure, "CoupledSimulator")
    code = ("import sys, sloshrom.beam.simulation.structure; "
            "assert 'sloshrom.beam.simulation.coupled' not in sys.modules")
    assert subprocess.run([sys.executable, "-c", code]).returncode == 0
