"""The virtual shaker rig: a physics-based tank simulator that plays the shaker experiment.

Modules: :mod:`~sloshrom.rig.params` (parameters, TOML), :mod:`~sloshrom.rig.physics` (tank modes,
numba kernel), :mod:`~sloshrom.rig.virtual` (:class:`VirtualRig`, sensors),
:mod:`~sloshrom.rig.audit` (energy balance), :mod:`~sloshrom.rig.limits` (its integration rate
and the longest and shortest runs) and :mod:`~sloshrom.rig.errors` (:class:`RigError`).

The names below are resolved on first use (PEP 562), so that importing a light module of this
package (``sloshrom.rig.limits``, which the command line reads when it starts) does not load
numba.
"""

from __future__ import annotations

import importlib

#: Each name of the package and the module that defines it.
_HOMES = {
    "RigError": "errors", "RigParams": "params", "SensorParams": "params",
    "VirtualRig": "virtual", "energy_audit": "audit", "faraday_modes": "physics",
    "rig_kernel_step": "physics", "rig_step": "physics",
}
__all__ = sorted(_HOMES)


def __getattr__(name: str) -> object:
    if name in _HOMES:
        return getattr(importlib.import_module(f"sloshrom.rig.{_HOMES[name]}"), name)
    raise AttributeError(f"module 'sloshrom.rig' has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted({*globals(), *__all__})
