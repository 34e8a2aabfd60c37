"""NumPy's transparent huge pages, off for the processes the command line owns.

On Linux, NumPy asks the kernel for transparent huge pages (``madvise``) on every array of
4 MB or more. Where the kernel's policy is ``madvise`` (the default of Debian and Ubuntu) and a
new 2 MB page is slow to come (memory to compact; on our 2-core virtual machine, whose kernel
counts no compaction stall, the host backing the memory), a process that grows by hundreds of
MB at once waits for seconds: the rig's sensors on the default training record took 10.0 s
against 3.9 s without the advice, and the data stage of ``sloshrom reproduce`` 26.8 s against
14.4 s, with the same bits; the column search of the grey box ran as fast either way
(``benchmarks/huge_pages.py``). NumPy reads ``NUMPY_MADVISE_HUGEPAGE`` once, at its import; a
user who sets it keeps their choice.
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
