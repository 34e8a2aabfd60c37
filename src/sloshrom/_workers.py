"""Worker processes that end with the process that started them.

A :class:`concurrent.futures.ProcessPoolExecutor`'s workers wait on their call queue, whose pipe
they hold both ends of; when the process that owns the pool is killed (``kill``, a CI's
timeout, the kernel's out-of-memory killer), no end-of-file reaches them and they stay, idle,
reparented to ``init``, until someone kills them. (Dask's workers already watch their parent
through a pipe of their own.) :func:`worker_init`, a pool's ``initializer``, starts a thread in
each worker that ends it once its parent has gone: it polls the parent's id, which changes when
the process is reparented, so that any death of the parent is seen, a ``SIGKILL`` included,
and a parent that starts workers from several threads is fine (Linux's ``PR_SET_PDEATHSIG``
would fire when the starting *thread* ends).
"""

from __future__ import annotations

import importlib
import os
import threading
import time

__all__ = ["ORPHAN_EXIT", "POLL_SECONDS", "exit_with_parent", "worker_init"]

#: Seconds between two looks at the parent's process id.
POLL_SECONDS = 0.5
#: The exit status of a worker that ended because its parent had gone.
ORPHAN_EXIT = 3


def exit_with_parent(parent: int, poll: float = POLL_SECONDS) -> threading.Thread:
    """End this process (``os._exit``) once its parent is no longer ``parent``.

    Parameters
    ----------
    parent : int
        The process id of the process that started this one (passed from it: a parent that
        died before this call would otherwise be taken for ``init``).
    poll : float
        Seconds between two looks (s).

    Returns
    -------
    threading.Thread
        The watching thread (a daemon: it never keeps the process alive).
    """

    def watch() -> None:
        while os.getppid() == parent:
            time.sleep(poll)
        # no cleanup to run: the work belonged to the parent, whose results are lost with it
        os._exit(ORPHAN_EXIT)

    thread = threading.Thread(target=watch, name="sloshrom-exit-with-parent", daemon=True)
    thread.start()
    return thread


def worker_init(parent: int, module: str | None = None) -> None:
    """A pool's ``initializer``: watch the parent (:func:`exit_with_parent`), import ``module``.

    Parameters
    ----------
    parent : int
        ``os.getpid()`` of the process that creates the pool.
    module : str, optional
        A module to import as the worker starts (its first task then finds it loaded).
    """
    exit_with_parent(parent)
    if module is not None:
        importlib.import_module(module)
