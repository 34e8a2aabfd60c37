"""NumPy's transparent huge pages, off for the processes the command line owns.

On Linux, NumPy asks the kernel for transparent huge pages (``madvise``) on every array of
4 MB or more. Where the kernel's policy is ``madvise`` (the default of Debian and Ubuntu) and
memory is fragmented (a host whose page cache fills it), each new 2 MB page may wait for the
kernel to compact memory. A process that grows by a few hundred MB at once then waits for
seconds: four 312 MB arrays took 7.0 s against 0.64 s without the advice, and the rig's data
stage of ``sloshrom reproduce`` 27.5 s against 13.0 s, with the same bits (docs/performance.md,
"Huge pages"). NumPy reads ``NUMPY_MADVISE_HUGEPAGE`` once, at its import; a user who sets it
keeps their choice.
"""

from __future__ import annotations

import os

import numpy as np

__all__ = ["HUGEPAGE_ENV", "without_huge_pages"]

#: NumPy's environment variable: ``0`` no huge-page advice, ``1`` always.
HUGEPAGE_ENV = "NUMPY_MADVISE_HUGEPAGE"


def without_huge_pages() -> bool:
    """Turn NumPy's huge-page advice off in this process and in the processes it starts.

    Sets ``NUMPY_MADVISE_HUGEPAGE=0`` for child processes (Dask's workers read it when they
    import NumPy) and switches this process's NumPy, already imported, by its own toggle. A
    variable already set is the user's choice and is left as it is.

    Returns
    -------
    bool
        True if the advice was turned off here; False if the user's variable decides.
    """
    if HUGEPAGE_ENV in os.environ:
        return False
    os.environ[HUGEPAGE_ENV] = "0"
    # NumPy's own switch, the one its import calls with the variable's value (numpy/__init__.py)
    core = getattr(np, "_core", None) or getattr(np, "core", None)
    toggle = getattr(getattr(core, "multiarray", None), "_set_madvise_hugepage", None)
    if toggle is not None:
        toggle(False)
    return True
