"""Reduced-order models: every class of the registry (:mod:`sloshrom.rom.registry`: the
paper's NFIR and NOE time-delay networks with normalized radial-basis hidden layers, the neural
state-space ROM NSS, the linear state-space baseline LSS), ensembles, fill families and the
bouncing ball, and :func:`load_model`.

The names below are resolved on first use (PEP 562), so that importing a JAX-free module of
this package (``sloshrom.rom.registry``, ``sloshrom.rom.modelfile``) does not load JAX; each
registered class's estimator is importable from here by its class name.
"""

from __future__ import annotations

import importlib
from typing import Any

from sloshrom.rom.registry import CLASSES

_ESTIMATORS = [
    "FORMAT_VERSION", "BouncingBall", "Ensemble", "EnvelopeWarning", "FillFamily",
    "FillRangeError", "MinMaxScaler", "ModelFileError", "ModelSizeWarning", "Network",
    "NotFittedError",
    "ROMError", "UnstableModelError", "hidden_activations", "load_model", "n_params",
    "noe_simulate", "pack", "rbf_apply", "unpack",
]
__all__ = sorted([*_ESTIMATORS, *(mc.class_name for mc in CLASSES.values())])


def __getattr__(name: str) -> Any:
    for mc in CLASSES.values():
        if name == mc.class_name:
            return mc.estimator_class()
    if name in _ESTIMATORS:
        return getattr(importlib.import_module("sloshrom.rom.estimators"), name)
    raise AttributeError(f"module 'sloshrom.rom' has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted({*globals(), *__all__})
