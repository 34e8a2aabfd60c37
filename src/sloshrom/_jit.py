"""numba kernels that compile once per machine, wherever the package is installed.

``njit`` is numba's, with its on-disk cache where one can be written: ``NUMBA_CACHE_DIR`` if set,
else beside the module, else the user's cache directory (numba's own order). A read-only
install with no writable home (a container image, a root-owned site-packages run by a service
account) has none; numba then refuses ``cache=True`` at import, so such kernels compile in
memory instead, once per process (a few seconds), and the package still imports. The cache is
keyed by numba on the CPU, so a cache shared between machines is never used on the wrong one.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numba as nb

__all__ = ["njit"]


def njit(fn: Callable | None = None, **options: Any) -> Any:
    """``numba.njit(cache=True, **options)``, or without the cache where none can be written.

    Use as ``@njit`` or ``@njit(parallel=True)``.
    """
    if fn is None:
        return lambda f: njit(f, **options)
    try:
        return nb.njit(cache=True, **options)(fn)
    except RuntimeError as exc:  # "cannot cache function ...: no locator available"
        if "cannot cache" not in str(exc):
            raise
        return nb.njit(cache=False, **options)(fn)
