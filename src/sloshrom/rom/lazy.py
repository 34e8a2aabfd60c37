"""Names of a package resolved on first use (PEP 562), so that its light modules load alone.

A class's package (``sloshrom.rom.nss``, ...) holds a light module, its registry entry, which
the command line and the settings import at start-up without JAX; importing that module runs
the package's ``__init__`` first, so the ``__init__`` imports nothing heavy and resolves its
public names (the estimator, the fitted model) from their modules when they are first read.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable, Mapping

__all__ = ["exports"]


def exports(package: str, names: Mapping[str, str]
            ) -> tuple[Callable[[str], object], Callable[[], list[str]]]:
    """``(__getattr__, __dir__)`` of ``package`` whose public ``names`` live in the modules
    ``names[name]`` (relative to the package, e.g. ``"estimator"``)."""

    def getattr_(name: str) -> object:
        module = names.get(name)
        if module is None:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        value: object = getattr(importlib.import_module(f"{package}.{module}"), name)
        return value

    def dir_() -> list[str]:
        return sorted({*importlib.import_module(package).__dict__, *names})

    return getattr_, dir_
