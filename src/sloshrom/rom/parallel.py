"""Run independent training tasks in parallel: the Dask machinery of the sweep and the ensembles.

One function, :func:`run_tasks`, calls ``fn(item, *shared, *args)`` for every item and returns
the results in the order of the items. The large arrays every task reads (the records) go in
``shared``: a Dask cluster receives them once (``scatter``, broadcast to every worker), not once
per task. Schedulers:

``None``
    A new ``dask.distributed.LocalCluster`` of ``n_workers`` single-threaded processes, closed
    afterwards. On Linux, when there are no more workers than cores this process may use,
    each worker process is pinned to a core of its own (:func:`pin_workers`).
``"threads"``
    A thread pool of ``n_workers`` threads in this process (no cluster; tests, small jobs).
``"sequential"``
    One task after the other in this process (debugging, ``workers = 1``).
anything else
    The address of a running Dask scheduler (``tcp://HOST:PORT``).

This module imports no estimator: :mod:`sloshrom.rom.sweep` and :mod:`sloshrom.rom.ensemble`
both use it without importing each other.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Iterable, Sequence
from typing import Any, TypeVar

__all__ = ["pin_workers", "run_tasks", "usable_cores"]

T = TypeVar("T")
R = TypeVar("R")


def usable_cores() -> list[int]:
    """The cores this process may run on (all of them where the OS does not say)."""
    if hasattr(os, "sched_getaffinity"):
        return sorted(os.sched_getaffinity(0))
    return list(range(os.cpu_count() or 1))


def _pin_this_process(cores: list[int], dask_worker: Any = None) -> int:
    """Pin every thread of this Dask worker process to core ``cores[worker index]`` (Dask's
    ``Client.run`` passes the worker as ``dask_worker``)."""
    core = cores[int(dask_worker.name) % len(cores)]
    # every existing thread (the task thread among them); threads made later (XLA's pool,
    # created when a task first uses JAX) inherit the affinity of the thread that makes them
    for tid in os.listdir("/proc/self/task"):
        try:
            os.sched_setaffinity(int(tid), {core})
        except OSError:  # a thread that ended meanwhile
            pass
    return core


def pin_workers(client: Any, n_workers: int) -> dict[str, int] | None:
    """Pin each worker process of a LocalCluster to a core of its own.

    Two training processes that each let XLA run on every core fight for them: on this
    2-core machine two unpinned trainings side by side ran at 1.3x the throughput of one,
    pinned at 1.7x (docs/performance.md). Pinned only on Linux and when there are at least
    as many usable cores as workers; otherwise the OS schedules them.

    Returns
    -------
    dict or None
        The core of each worker (by address), or None when not pinned.
    """
    cores = usable_cores()
    if not (hasattr(os, "sched_setaffinity") and os.path.isdir("/proc/self/task")
            and 1 < n_workers <= len(cores)):
        return None
    return client.run(_pin_this_process, cores)


def run_tasks(
    fn: Callable[..., R],
    items: Iterable[T],
    shared: Sequence[Any] = (),
    args: Sequence[Any] = (),
    *,
    scheduler: str | None = None,
    n_workers: int = 2,
    done: Callable[[int, R], Any] | None = None,
) -> list[R]:
    """Call ``fn(item, *shared, *args)`` for every item, in parallel.

    Parameters
    ----------
    fn : callable
        A module-level function (Dask ships it to worker processes by reference).
    items : iterable
        One task per item.
    shared : sequence
        Large arguments common to every task (scattered once to a Dask cluster).
    args : sequence
        Small arguments common to every task.
    scheduler : str, optional
        ``None`` (a new LocalCluster), ``"threads"``, ``"sequential"`` or a scheduler address
        (module docstring).
    n_workers : int
        Processes of the LocalCluster, threads of ``"threads"``.
    done : callable, optional
        ``done(index, result)`` as each task finishes (in the order they finish).

    Returns
    -------
    list
        The results, in the order of ``items``.

    Raises
    ------
    Exception
        The first exception a task raised (the other tasks are cancelled or left to finish).
    """
    todo = list(items)
    results: list[Any] = [None] * len(todo)

    def finish(i: int, r: Any) -> None:
        results[i] = r
        if done is not None:
            done(i, r)

    if scheduler == "sequential":
        for i, it in enumerate(todo):
            finish(i, fn(it, *shared, *args))
    elif scheduler == "threads":
        from concurrent.futures import ThreadPoolExecutor, as_completed

        with ThreadPoolExecutor(max_workers=n_workers) as ex:
            index = {ex.submit(fn, it, *shared, *args): i for i, it in enumerate(todo)}
            for f in as_completed(index):
                finish(index[f], f.result())
    else:
        import dask
        from dask.distributed import Client, LocalCluster, as_completed

        cluster = None
        if scheduler is None:
            # Dask's nanny sets MALLOC_TRIM_THRESHOLD_=65536 in its workers by default (against
            # fragmentation); glibc then returns and re-faults the large buffers a training
            # allocates at every step: the NFIR's epochs ran 2x slower (as measured). Unset, the
            # workers inherit this process's setting, glibc's adaptive threshold by default.
            with dask.config.set({"distributed.nanny.pre-spawn-environ."
                                  "MALLOC_TRIM_THRESHOLD_": None}):
                cluster = LocalCluster(n_workers=n_workers, threads_per_worker=1,
                                       processes=True, dashboard_address=None)
            client = Client(cluster)
            pin_workers(client, n_workers)
        else:
            client = Client(scheduler, timeout=10)  # an unreachable address fails, not hangs
        try:
            data = client.scatter(list(shared), broadcast=True) if shared else []
            futs = [client.submit(fn, it, *data, *args, pure=False) for it in todo]
            index = {f.key: i for i, f in enumerate(futs)}
            for f in as_completed(futs):
                finish(index[f.key], f.result())
        finally:
            client.close()
            if cluster is not None:
                cluster.close()
    return results
