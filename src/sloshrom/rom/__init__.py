"""Reduced-order models: NFIR and NOE time-delay networks with normalized radial-basis hidden
layers, the neural state-space ROM (NSS) and the linear state-space baseline (LSS).

The names below are resolved on first use (PEP 562), so that importing a JAX-free module of
this package (``sloshrom.rom.registry``, ``sloshrom.rom.modelfile``) does not load JAX.
"""

from __future__ import annotations

import importlib
from typing import Any

__all__ = [
    "FORMAT_VERSION", "LSS", "NFIR", "NOE", "NSS", "BouncingBall", "Ensemble",
    "EnvelopeWarning", "FillFamily", "FillRangeError", "MinMaxScaler", "ModelFileError",
    "Network", "NotFittedError", "ROMError", "UnstableModelError", "hidden_activations",
    "load_model", "n_params", "noe_simulate", "pack", "rbf_apply", "unpack",
]

_WHERE = {"LSS": "sloshrom.rom.lss"}


def __getattr__(name: str) -> Any:
    if name in __all__:
        return getattr(importlib.import_module(_WHERE.get(name, "sloshrom.rom.estimators")),
                       name)
    raise AttributeError(f"module 'sloshrom.rom' has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted({*globals(), *__all__})
