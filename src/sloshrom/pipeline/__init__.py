"""The reproduce chain: configuration, cached stages, report.

``run`` and ``Context`` load on first use: the CLI imports ``sloshrom.pipeline.settings`` at
start-up and must not pay for every stage's dependencies (JAX, xarray, matplotlib) then.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from sloshrom.pipeline.chain import run
    from sloshrom.pipeline.context import Context

__all__ = ["Context", "run"]

_LAZY = {"Context": "sloshrom.pipeline.context", "run": "sloshrom.pipeline.chain"}


def __getattr__(name: str) -> Any:
    if name in _LAZY:
        return getattr(importlib.import_module(_LAZY[name]), name)
    raise AttributeError(f"module 'sloshrom.pipeline' has no attribute {name!r}")
