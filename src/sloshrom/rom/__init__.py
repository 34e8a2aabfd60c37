"""Reduced-order models: every class of the registry (:mod:`sloshrom.rom.registry`, one package
each: the paper's NFIR and NOE time-delay networks in :mod:`sloshrom.rom.tdnn`, the neural
state-space ROM NSS in :mod:`sloshrom.rom.nss`, the linear state-space baseline LSS in
:mod:`sloshrom.rom.lss`), ensembles, fill families, the bouncing ball (:mod:`sloshrom.rom.ball`)
and :func:`load_model`.

The names below are resolved on first use (PEP 562), so that importing a JAX-free module of
this package (``sloshrom.rom.registry``, ``sloshrom.rom.modelfile``, a class's ``entry``) does
not load JAX: each registered class's estimator by its class name, and the public names of the
classes' packages (``sloshrom.rom.BouncingBall``, ``sloshrom.rom.pack``, ...).
"""

from __future__ import annotations

import importlib
from typing import Any

from sloshrom.rom.registry import CLASSES, packages

#: Each name of the ROMs' shared modules and the module that defines it.
_NAMES = {
    "FORMAT_VERSION": "modelfile", "ModelFileError": "modelfile",
    "Ensemble": "ensemble", "FillFamily": "family",
    "EnvelopeWarning": "errors", "FillRangeError": "errors", "ModelSizeWarning": "errors",
    "NotFittedError": "errors", "ROMError": "errors", "UnstableModelError": "errors",
    "MinMaxScaler": "network", "load_model": "loading",
}


def _package_names() -> dict[str, str]:
    """The public names of the classes' packages (their ``__all__``) and each package."""
    out: dict[str, str] = {}
    for pkg in packages():
        for name in importlib.import_module(pkg).__all__:
            out.setdefault(name, pkg)
    return out


def __getattr__(name: str) -> Any:
    if name == "__all__":  # the classes' names too, once the registry is read
        return sorted({*_NAMES, *_package_names(),
                       *(mc.class_name for mc in CLASSES.values())})
    module = _NAMES.get(name)
    if module is not None:
        return getattr(importlib.import_module(f"{__name__}.{module}"), name)
    for mc in CLASSES.values():
        if name == mc.class_name:
            return mc.estimator_class()
    pkg = _package_names().get(name)
    if pkg is not None:
        return getattr(importlib.import_module(pkg), name)
    raise AttributeError(f"module 'sloshrom.rom' has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted({*globals(), *_NAMES, *_package_names(),
                   *(mc.class_name for mc in CLASSES.values())})
