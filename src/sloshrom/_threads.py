"""Work that releases the GIL, in threads of this process: one a usable core.

JAX's compiled runs, numba's kernels and NumPy's large operations release the GIL, so the
members of an ensemble (or the records of a stage) run alone each, side by side, in threads of
the caller's process: nothing to start, send or import, unlike worker processes.

numba's ``parallel=True`` kernels (the virtual rig's, the grey box's column) may run in two
threads at once only with its tbb or omp threading layer: its workqueue layer, the one left
where neither TBB nor the OpenMP runtime loads (e.g. a slim container without ``libgomp``),
terminates the process on a concurrent launch. There the calls run one after the other
(:func:`numba_threadsafe`).
"""

from __future__ import annotations

import contextvars
import functools
import os
from collections.abc import Callable, Sequence
from concurrent.futures import ThreadPoolExecutor
from typing import TypeVar

__all__ = ["map_threads", "numba_threadsafe", "usable_cores"]

T = TypeVar("T")
R = TypeVar("R")


def usable_cores() -> list[int]:
    """The cores this process may run on (all of them where the OS does not say)."""
    if hasattr(os, "sched_getaffinity"):
        return sorted(os.sched_getaffinity(0))
    return list(range(os.cpu_count() or 1))


@functools.cache
def numba_threadsafe() -> bool:
    """Whether numba's ``parallel=True`` kernels may be called from two threads at once: its
    threading layer is tbb or omp, not workqueue. Starts numba's threads if they are not yet
    (as its first parallel kernel would): the layer is then the one the process keeps."""
    import numba
    from numba.np.ufunc import parallel

    parallel._launch_threads()
    return bool(numba.threading_layer() != "workqueue")


def map_threads(fn: Callable[[T], R], items: Sequence[T], workers: int | None = None
                ) -> list[R]:
    """``[fn(x) for x in items]``, the calls in threads of this process, one a usable core.

    For work that releases the GIL (JAX's and numba's compiled runs, NumPy's large
    operations): an ensemble's members, each run alone. Each call is the one the loop would
    make, so the results are the loop's to the bit; the first error (in the items' order) is
    raised once every call has ended. Each call runs in a copy of the caller's context
    (:mod:`contextvars`: e.g. :func:`sloshrom.models.envelope_quiet`). One usable core, one
    item, or numba's workqueue layer (:func:`numba_threadsafe`): the plain loop, here.

    Parameters
    ----------
    fn : callable
        Called once per item; safe to call from several threads at once.
    items : sequence
        The arguments, in the order of the results.
    workers : int, optional
        Threads at most; default: the usable cores (:func:`usable_cores`).
    """
    n = min(len(items), len(usable_cores()) if workers is None else int(workers))
    # each call in a copy of the caller's context (its sloshrom.models.envelope_quiet), in
    # threads or not: what a call sets stays in its copy
    if n < 2 or not numba_threadsafe():
        return [contextvars.copy_context().run(fn, x) for x in items]
    with ThreadPoolExecutor(max_workers=n, thread_name_prefix="sloshrom-map") as ex:
        futures = [ex.submit(contextvars.copy_context().run, fn, x) for x in items]
    return [f.result() for f in futures]
