"""Reduced-order models: every class of the registry (:mod:`sloshrom.rom.registry`, one package
each: the paper's NFIR and NOE time-delay networks in :mod:`sloshrom.rom.tdnn`, the neural
state-space ROM NSS in :mod:`sloshrom.rom.nss`, the linear state-space baseline LSS in
:mod:`sloshrom.rom.lss`), ensembles, fill families, the bouncing ball (:mod:`sloshrom.rom.ball`)
and :func:`load_model`.

The names below are resolved on first use (PEP 562), so that importing a JAX-free module of
this package (``sloshrom.rom.registry``, ``sloshrom.rom.modelfile``, a class's ``entry``) does
not load JAX; each registered class's estimator is importable from here by its class name.
"""

from __future__ import annotations

import importlib
from typing import Any

from sloshrom.rom.registry import CLASSES

#: Each name and the module that defines it.
_NAMES = {
    "FORMAT_VERSION": "modelfile", "ModelFileError": "modelfile",
    "BouncingBall": "ball.model", "Ensemble": "ensemble", "FillFamily": "family",
    "EnvelopeWarning": "errors", "FillRangeError": "errors", "ModelSizeWarning": "errors",
    "NotFittedError": "errors", "ROMError": "errors", "UnstableModelError": "errors",
    "MinMaxScaler": "network", "load_model": "loading",
    **dict.fromkeys(("Network", "hidden_activations", "n_params", "noe_simulate", "pack",
                     "rbf_apply", "unpack"), "tdnn.network"),
}


def __getattr__(name: str) -> Any:
    if name == "__all__":  # the classes' names too, once the registry is read
        return sorted({*_NAMES, *(mc.class_name for mc in CLASSES.values())})
    module = _NAMES.get(name)
    if module is not None:
        return getattr(importlib.import_module(f"{__name__}.{module}"), name)
    for mc in CLASSES.values():
        if name == mc.class_name:
            return mc.estimator_class()
    raise AttributeError(f"module 'sloshrom.rom' has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted({*globals(), *_NAMES, *(mc.class_name for mc in CLASSES.values())})
