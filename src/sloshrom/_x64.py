"""Double precision for our JAX computations without changing the user's JAX configuration.

The ROMs and the coupled simulation are identified and compared in float64 (LM normal
equations, parity with ONNX to ~1e-15). Rather than flipping ``jax_enable_x64`` for the whole
process at import, every public entry point runs inside ``jax.enable_x64(True)``: the user's
own JAX code keeps its precision, and ours is float64 wherever it is called from. Functions
jitted inside the context are compiled and cached for it (the flag is part of JAX's cache key).
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from typing import Any, TypeVar

import jax

__all__ = ["float64"]

F = TypeVar("F", bound=Callable[..., Any])


def float64(fn: F) -> F:
    """Decorator: run ``fn`` with JAX in double precision (``jax.enable_x64(True)``).

    A fresh context per call, so that decorated functions calling each other nest correctly.
    """

    @functools.wraps(fn)
    def wrapper(*args: Any, **kwargs: Any) -> Any:
        with jax.enable_x64(True):
            return fn(*args, **kwargs)

    return wrapper  # type: ignore[return-value]
