"""The virtual shaker rig: a physics-based tank simulator that plays the shaker experiment.

Modules: :mod:`~sloshrom.rig.params` (parameters, TOML), :mod:`~sloshrom.rig.physics` (tank modes,
numba kernel), :mod:`~sloshrom.rig.virtual` (:class:`VirtualRig`, sensors),
:mod:`~sloshrom.rig.audit` (energy balance) and :mod:`~sloshrom.rig.errors` (:class:`RigError`).
"""

from sloshrom.rig.audit import energy_audit
from sloshrom.rig.errors import RigError
from sloshrom.rig.params import RigParams, SensorParams
from sloshrom.rig.physics import faraday_modes, rig_kernel_step, rig_step
from sloshrom.rig.virtual import VirtualRig

__all__ = [
    "RigError",
    "RigParams",
    "SensorParams",
    "VirtualRig",
    "energy_audit",
    "faraday_modes",
    "rig_kernel_step",
    "rig_step",
]
