"""Small deterministic runs of every room, stored once as ``tests/data/behaviour.npz``.

The fixture is written by the code base *before* a refactoring
(``python tools/write_behaviour_fixture.py``); ``test_behaviour.py`` reruns the same cases and
compares each array with a tolerance derived from its measured sensitivity, never bit for bit
(another CPU rounds differently in the last bits): ``cases(eps, draw)`` perturbs every input of
every stage by a random relative amount of at most ``eps``, and the largest relative change of
an array over ``DRAWS`` draws is its tolerance (``tools/write_behaviour_fixture.py
--tolerances`` writes them to ``tests/data/behaviour_tolerance.json``).
"""

from __future__ import annotations

import warnings

import numpy as np

from helpers import FLOOR, relative_change
from sloshrom import FrozenLiquid, Tank
from sloshrom.beam.simulation.coupled import free_response, random_response
from sloshrom.beam.simulation.structure import CantileverBeam, ModalModel
from sloshrom.energy import phi_d_map
from sloshrom.rig.virtual import SensorParams, VirtualRig
from sloshrom.rom.tdnn.estimators import NFIR, NOE
from sloshrom.signals import SHAKER_ENVELOPE as SHAKER
from sloshrom.signals import harmonic, vfa

#: relative size of the perturbation whose effect is a case's tolerance: above the largest
#: relative difference that another instruction set makes in any input of these cases (the VFA
#: acceleration: 8.1e-14 with NumPy's AVX-512 paths on or off) and ~900 float64 roundings
EPS = 1e-13
#: draws of the perturbation (the tolerance is the largest change over them)
DRAWS = 5


def _beam(tank: Tank, damping) -> ModalModel:
    beam = CantileverBeam.with_tank(tank)
    stations = tuple(beam.length * k / 5 for k in range(1, 6))
    return ModalModel.from_beam(beam, tank, n_modes=3, damping=tuple(damping),
                                stations=stations)


def cases(eps: float = 0.0, draw: int = 0) -> dict[str, np.ndarray]:
    """Every stored array, by name.

    ``eps > 0`` multiplies every input of every stage (tank dimensions and density, the VFA
    band, shaker signals, training and prediction records, modal damping, RMS levels, map
    grid) by
    ``1 + eps r``, ``r`` uniform in [-1, 1] and independent for every sample, as rounding
    differences are; ``draw`` seeds ``r``.
    """
    rng = np.random.default_rng(1000 + draw)

    def p(x):
        """x times (1 + eps r); x itself when eps is 0."""
        x = np.asarray(x, dtype=float)
        return x * (1.0 + eps * rng.uniform(-1.0, 1.0, x.shape)) if eps else x

    out: dict[str, np.ndarray] = {}
    ref = Tank()
    tank = Tank(length=float(p(ref.length)), width=float(p(ref.width)),
                height=float(p(ref.height)), density=float(p(ref.density)))
    rig = VirtualRig(tank, seed=3, sensors=SensorParams(output_fs=1000.0))
    path = vfa(1.0 / rig.dt, duration=20.0, tank=tank, seed=3, f_min=float(p(SHAKER.f_min)),
               f_max=float(p(SHAKER.f_max)))
    out["vfa_acceleration"] = np.asarray(path.acceleration)
    m = rig.measure(p(path.acceleration))
    for k in ("time", "acceleration", "force", "true_velocity", "true_dynamic_force"):
        out[f"rig_{k}"] = np.asarray(m[k])
    # not the frequency: 12 Hz puts a sample exactly on the end of the ramp, where the commanded
    # acceleration jumps (exact arithmetic on every CPU; a perturbed frequency moves the sample)
    h = harmonic(1.0 / rig.dt, 12.0, 0.25 * tank.height, n_cycles=6)
    out["rig_harmonic_force"] = rig.simulate(p(h.velocity), p(h.acceleration))

    # the ROMs learn the true force from the true velocity of the 20 s record
    u, y, fs = p(m["true_velocity"]), p(m["true_dynamic_force"]), m["fs"]
    n = u.size * 3 // 4
    val = (u[n:], y[n:])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        roms = {
            "nfir_lm": NFIR(8, 5, trainer="lm", max_epochs=6, seed=1),
            "nfir_fast": NFIR(8, 5, trainer="fast", max_epochs=6, seed=2),
            "nfir_adam": NFIR(8, 5, trainer="adam", max_epochs=6, seed=3),
            "noe_lm": NOE(2, 4, trainer="lm", max_epochs=4, seed=4),
        }
        for name, model in roms.items():
            model.fit(u[:n], y[:n], fs, validation=val)
            for k, v in model.params_.items():
                out[f"{name}_param_{k}"] = np.asarray(v)
            out[f"{name}_predict"] = model.predict(p(m["true_velocity"]))

        modal = _beam(tank, p([0.01, 0.01, 0.01]))
        for name, model in (("frozen", FrozenLiquid(1e-3)), ("nfir", roms["nfir_lm"]),
                            ("rig", VirtualRig(tank, seed=5))):
            res = free_response(model, modal, duration=1.5, tank=tank, output_fs=1000.0)
            out[f"free_{name}_tank_acceleration"] = np.asarray(res["tank_acceleration"])
        res = random_response(roms["nfir_lm"], modal, rms_levels_g=tuple(p([0.1, 0.3])),
                              duration=4.0, tank=tank, output_fs=1000.0, seed=2)
        out["random_nfir_tank_acceleration"] = np.asarray(res["tank_acceleration"])
        wbar, abar = p([3.0, 4.5]), p([0.1, 0.3])
        out["map_rig"] = phi_d_map(VirtualRig(tank, seed=1), wbar, abar, tank=tank,
                                   n_cycles=6).values
        out["map_nfir"] = phi_d_map(roms["nfir_lm"], wbar, abar, tank=tank, n_cycles=6).values
    return out


def tolerances(eps: float = EPS, draws: int = DRAWS) -> dict[str, float]:
    """Each case's largest relative change over ``draws`` perturbed runs, at least FLOOR."""
    base = cases()
    out = dict.fromkeys(base, FLOOR)
    for draw in range(draws):
        moved = cases(eps, draw)
        for k in base:
            out[k] = max(out[k], relative_change(moved[k], base[k]))
    return out
