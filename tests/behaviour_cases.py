"""Small deterministic runs of every room, stored once as ``tests/data/behaviour.npz``.

The fixture was written by the code base *before* the package was reorganised
(``python tools/write_behaviour_fixture.py``); ``test_behaviour.py`` reruns the same cases and
compares: records bit for bit, trained models and simulations to round-off.
"""

from __future__ import annotations

import warnings

import numpy as np

from sloshrom import FrozenLiquid, Tank
from sloshrom.beam.coupled import free_response, random_response
from sloshrom.beam.structure import CantileverBeam, ModalModel
from sloshrom.energy import phi_d_map
from sloshrom.rig.virtual import SensorParams, VirtualRig
from sloshrom.rom.estimators import NFIR, NOE
from sloshrom.signals import harmonic, vfa

#: cases whose arrays must match bit for bit (the rest: to round-off)
EXACT = ("vfa_", "rig_")


def _beam(tank: Tank) -> ModalModel:
    beam = CantileverBeam.with_tank(tank)
    stations = tuple(beam.length * k / 5 for k in range(1, 6))
    return ModalModel.from_beam(beam, tank, n_modes=3, damping=(0.01, 0.01, 0.01),
                                stations=stations)


def cases() -> dict[str, np.ndarray]:
    """Every stored array, by name."""
    out: dict[str, np.ndarray] = {}
    tank = Tank()
    rig = VirtualRig(tank, seed=3, sensors=SensorParams(output_rate=1000.0))
    path = vfa(1.0 / rig.dt, duration=20.0, tank=tank, seed=3)
    out["vfa_acceleration"] = np.asarray(path.acceleration)
    m = rig.measure(path.acceleration)
    for k in ("time", "acceleration", "force", "true_velocity", "true_dynamic_force"):
        out[f"rig_{k}"] = np.asarray(m[k])
    h = harmonic(1.0 / rig.dt, 12.0, 0.25 * tank.height, n_cycles=6)
    out["rig_harmonic_force"] = rig.simulate(h.velocity, h.acceleration)

    # the ROMs learn the true force from the true velocity of the 20 s record
    u, y, fs = m["true_velocity"], m["true_dynamic_force"], m["fs"]
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
            out[f"{name}_predict"] = model.predict(u)

        modal = _beam(tank)
        for name, model in (("frozen", FrozenLiquid(1e-3)), ("nfir", roms["nfir_lm"]),
                            ("rig", VirtualRig(tank, seed=5))):
            res = free_response(model, modal, duration=1.5, tank=tank, output_fs=1000.0)
            out[f"free_{name}_tank_acceleration"] = np.asarray(res["tank_acceleration"])
        res = random_response(roms["nfir_lm"], modal, rms_levels=(0.1, 0.3), duration=4.0,
                              tank=tank, output_fs=1000.0, seed=2)
        out["random_nfir_tank_acceleration"] = np.asarray(res["tank_acceleration"])
        wbar, abar = np.array([3.0, 4.5]), np.array([0.1, 0.3])
        out["map_rig"] = phi_d_map(VirtualRig(tank, seed=1), wbar, abar, tank=tank,
                                   n_cycles=6).values
        out["map_nfir"] = phi_d_map(roms["nfir_lm"], wbar, abar, tank=tank, n_cycles=6).values
    return out
