"""Several tanks on one structure: shapes, backends, mirror symmetry, energy balance."""

import numpy as np
import pytest

from helpers import LinearDamper, NumbaDamper, NumpyDamper
from sloshrom.beam.simulation.coupled import (
    CoupledSimulator,
    StepMismatchError,
    free_response,
    modal_energy,
    random_response,
)
from sloshrom.beam.simulation.structure import ModalDataError, ModalModel, frozen_mass_matrix
from sloshrom.config import Tank
from sloshrom.models import FrozenLiquid
from sloshrom.rig.virtual import VirtualRig

#: mirror of the symmetric structure below: mode 2 is antisymmetric
MIRROR = np.array([1.0, -1.0, 1.0])


def symmetric_structure(damping: float = 0.01) -> ModalModel:
    """A structure symmetric about x = 0 (think of a wing pair): modes 1 and 3 symmetric,
    mode 2 antisymmetric; tanks at x = -1 and +1 m, accelerometers at -1, -0.5, 0.5, 1 m."""
    sym = np.array([[0.2, 0.1, -0.6], [0.6, 0.4, -0.2], [1.0, 0.8, 0.5]])  # x = 0.5, 1 (rows 1-2)
    left = sym[1:] * MIRROR
    return ModalModel(
        frequencies=[8.0, 20.0, 45.0], damping=[damping] * 3, modal_masses=[2.0, 2.5, 1.5],
        psi_tank=[left[1], sym[2]], participation=[1.2, 0.0, 0.3],
        stations=[-1.0, -0.5, 0.5, 1.0], psi_stations=[left[1], left[0], sym[1], sym[2]],
        structure_mass=[0.45, 0.45], station_ids=(1, 2, 3, 4), tank_ids=(101, 102),
    )


def test_one_tank_as_a_row_equals_one_tank():
    modal = ModalModel.from_beam()
    two_d = ModalModel.from_dict({**modal.to_dict(), "psi_tank": [modal.psi_tank.tolist()]})
    assert two_d.n_tanks == 1 and modal.n_tanks == 1
    for model in (FrozenLiquid(0.002), LinearDamper(5.0, 0.002), NumpyDamper(5.0, 0.002)):
        a = free_response(model, modal, duration=1.0)
        b = free_response(model, two_d, duration=1.0)
        assert b["tank_acceleration"].shape == a["tank_acceleration"].shape + (1,)
        for k in ("q", "station_acceleration", "tank_acceleration", "interface_force",
                  "dynamic_force", "tank_velocity"):
            np.testing.assert_array_equal(np.squeeze(b[k]), a[k])


def test_frozen_mass_matrix_sums_the_tanks():
    modal = symmetric_structure()
    m = frozen_mass_matrix(modal, [0.1, 0.3])
    psi = modal.psi_tanks
    expected = np.diag(modal.modal_masses) + 0.1 * np.outer(psi[0], psi[0]) + 0.3 * np.outer(
        psi[1], psi[1])
    np.testing.assert_allclose(m, expected, rtol=1e-15)
    # equal tanks at mirrored points do not couple symmetric and antisymmetric modes
    m = frozen_mass_matrix(modal, 0.2)
    assert m[0, 1] == 0.0 and m[1, 2] == 0.0


def test_multitank_backends_agree_and_shapes():
    modal = symmetric_structure()
    dt = 1 / 1000
    a = np.sin(2 * np.pi * 7 * np.arange(2000) * dt)
    q0 = modal.static_tip_state(0.01, tank=0)
    runs = {}
    for name, models in (("jax", [LinearDamper(20.0, dt), LinearDamper(5.0, dt)]),
                         ("python", [NumpyDamper(20.0, dt), NumpyDamper(5.0, dt)]),
                         ("numba", [NumbaDamper(20.0, dt), NumbaDamper(5.0, dt)])):
        sim = CoupledSimulator(models, modal, tank=[Tank(), Tank(fill=0.3)])
        assert sim.backend == name
        runs[name] = sim.run_raw(a, q0=q0)
        assert runs[name]["tank_acceleration"].shape == (2000, 2)
    for name in ("python", "numba"):
        for k in ("q", "tank_acceleration", "dynamic_force", "interface_force"):
            np.testing.assert_allclose(runs[name][k], runs["jax"][k], rtol=1e-9, atol=1e-12)
    r = runs["jax"]
    # each tank's damper acts on its own velocity; the interface force uses its own masses
    np.testing.assert_allclose(r["dynamic_force"], -np.array([20.0, 5.0]) * r["tank_velocity"])
    m_tot = 0.45 + np.array([Tank().liquid_mass, Tank(fill=0.3).liquid_mass])
    np.testing.assert_allclose(r["interface_force"],
                               -m_tot * r["tank_acceleration"] + r["dynamic_force"])


def test_mirrored_release_gives_mirrored_responses():
    """Two identical rigs at mirrored points: releasing from a load at the right tank gives
    the mirror image of releasing from a load at the left one (the numba path, nonlinear)."""
    modal = symmetric_structure()
    rigs = [VirtualRig(seed=0), VirtualRig(seed=0)]
    left = free_response(rigs, modal, tip_displacement=0.01, duration=1.0, load_tank=0)
    right = free_response(rigs, modal, tip_displacement=0.01, duration=1.0, load_tank=1)
    assert np.max(np.abs(left["tank_acceleration"][:, 0])) > 3 * 9.81  # violent sloshing
    np.testing.assert_allclose(right["q"], left["q"] * MIRROR, rtol=0, atol=1e-12)
    for k in ("tank_acceleration", "dynamic_force", "interface_force"):
        np.testing.assert_allclose(right[k], left[k][:, ::-1], rtol=0,
                                   atol=1e-10 * np.max(np.abs(left[k])))
    np.testing.assert_allclose(right["station_acceleration"],
                               left["station_acceleration"][:, ::-1], rtol=0,
                               atol=1e-10 * np.max(np.abs(left["station_acceleration"])))


def test_symmetric_base_excitation_keeps_the_antisymmetric_mode_at_rest():
    modal = symmetric_structure()
    r = random_response([VirtualRig(seed=0), VirtualRig(seed=0)], modal, (0.3,), duration=3.0,
                        seed=3, f0=8.0, sigma=2.0, output_fs=500.0)
    acc = r["tank_acceleration"][0]
    assert np.max(np.abs(acc)) > 9.81
    np.testing.assert_allclose(acc[:, 1], acc[:, 0], rtol=0, atol=1e-10 * np.abs(acc).max())
    assert np.max(np.abs(r["q"][0][:, 1])) < 1e-12 * np.max(np.abs(r["q"][0][:, 0]))


@pytest.mark.parametrize("kind", ["rig", "damper"])
def test_energy_balance_of_two_tanks(kind):
    """Undamped structure, held force over each step: the structure's energy changes by the
    work of the sloshing forces, sum_j dF_j psi_j . (q_{k+1} - q_k), to round-off."""
    modal = symmetric_structure(damping=0.0)
    if kind == "rig":
        dt = 1e-4
        models = [VirtualRig(seed=0), VirtualRig(tank=Tank(fill=0.35), seed=1)]
        tanks = [Tank(), Tank(fill=0.35)]
    else:
        dt = 1 / 500
        models, tanks = [LinearDamper(3.0, dt), FrozenLiquid(dt)], [Tank(), Tank()]
    sim = CoupledSimulator(models, modal, tank=tanks)
    n, nk = modal.n_modes, 4000
    q0 = modal.static_tip_state(0.01, tank=1)
    raw = sim.run_raw(np.zeros(nk), q0=q0)
    d = sim.disc
    z = np.empty((nk + 1, 2 * n))
    z[0] = np.concatenate([q0, np.zeros(n)])
    u = np.concatenate([raw["dynamic_force"], np.zeros((nk, 1))], axis=1)
    for k in range(nk):  # the states between the outputs, from the same discretisation
        z[k + 1] = d.Phi @ z[k] + d.Gam @ u[k]
    np.testing.assert_allclose(z[:-1, :n], raw["q"], rtol=0, atol=1e-12 * np.abs(q0).max())
    e = modal_energy(d, z[:, :n], z[:, n:])
    work = np.einsum("kj,jn,kn->k", raw["dynamic_force"], d.psi, np.diff(z[:, :n], axis=0))
    assert -np.sum(work) > 0.02 * e[0]  # the liquids take a real part of the energy
    np.testing.assert_allclose(np.diff(e), work, rtol=0, atol=1e-9 * e[0])
    if kind == "damper":  # the frozen tank does no work
        assert np.all(raw["dynamic_force"][:, 1] == 0)


def test_tank_and_model_counts_and_steps_are_checked():
    modal = symmetric_structure()
    with pytest.raises(ValueError, match="3 sloshing model"):
        CoupledSimulator([FrozenLiquid(0.002)] * 3, modal)
    with pytest.raises(ValueError, match="1 tank"):
        CoupledSimulator(FrozenLiquid(0.002), modal, tank=[Tank()])
    with pytest.raises(StepMismatchError, match="different steps"):
        CoupledSimulator([VirtualRig(), LinearDamper(1.0, 0.002)], modal)
    # a frozen tank follows the step of the sloshing one
    sim = CoupledSimulator([VirtualRig(), FrozenLiquid(0.002)], modal, output_fs=500)
    assert sim.dt == 1e-4 and sim.backend == "numba" and sim.active == (0,)
    with pytest.raises(ModalDataError, match="tank index 2"):
        modal.static_tip_state(0.01, tank=2)
    with pytest.raises(ModalDataError, match="one per tank"):
        ModalModel.from_dict({**modal.to_dict(), "structure_mass": [0.4, 0.4, 0.4]})
    with pytest.raises(ModalDataError, match="tank_ids"):
        ModalModel.from_dict({**modal.to_dict(), "tank_ids": [7, 7]})
    with pytest.raises(ModalDataError, match="psi_tank"):
        ModalModel.from_dict({**modal.to_dict(), "psi_tank": [[1.0, 0.5]]})


def test_batched_random_responses_of_two_tanks_equal_single_runs():
    """The JAX path vmaps over levels with one model per tank (a damper and a frozen tank)."""
    modal = symmetric_structure()
    dt = 1 / 500
    models, tanks = [LinearDamper(8.0, dt), FrozenLiquid(dt)], [Tank(), Tank(fill=0.3)]
    both = random_response(models, modal, (0.1, 0.3), duration=6.0, seed=4, f0=8.0,
                           sigma=2.0, tank=tanks)
    assert both["tank_acceleration"].shape == (2, 3000, 2)
    assert both["envelope_outside_fraction"].shape == (2, 2)
    for i, level in enumerate((0.1, 0.3)):
        one = random_response(models, modal, (level,), duration=6.0, seed=4, f0=8.0,
                              sigma=2.0, tank=tanks)
        np.testing.assert_allclose(both["tank_acceleration"][i], one["tank_acceleration"][0],
                                   rtol=1e-10, atol=1e-12)
