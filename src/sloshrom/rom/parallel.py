"""Run independent training tasks in parallel: the Dask machinery of the sweep and the ensembles.

One function, :func:`run_tasks`, calls ``fn(item, *shared, *args)`` for every item and returns
the results in the order of the items. The large arrays every task reads (the records) go in
``shared``: a Dask cluster receives them once (``scatter``, broadcast to every worker), not once
per task. Schedulers:

``None``
    A new ``dask.distributed.LocalCluster`` of ``n_workers`` single-threaded processes, closed
    afterwards, placed on the cores by :func:`plan_workers` (below).
``"threads"``
    A thread pool of ``n_workers`` threads in this process (no cluster; tests, small jobs).
``"sequential"``
    One task after the other in this process (debugging, ``workers = 1``).
anything else
    The address of a running Dask scheduler (``tcp://HOST:PORT``).

Placement of a LocalCluster's workers
-------------------------------------
Two trainings that each let XLA spread over every core fight for them; each on a core of its
own runs at close to its full speed (docs/performance.md, "Ensembles: two members on two
cores"). So, on Linux, with at least two workers:

- **Cores no other run holds.** Each pinned worker's core is reserved by a lock file
  (``core-N.lock``, ``fcntl.flock``) in a per-user directory (:func:`runtime_dir`), held while
  the cluster lives and released when it closes, or by the OS when the process dies. A second
  sloshrom run on the same machine pins to other cores, not to the first run's.
- **Cores that are idle.** Each core's busy fraction is measured from ``/proc/stat`` over
  :data:`BUSY_INTERVAL` s just before the cluster starts (:func:`measure_busy`); a core busy
  above :data:`BUSY_ABOVE` is not free. When fewer cores are free than workers, the workers are
  not pinned (a pinned worker cannot move away from the processes that load its core; unpinned,
  the OS balances them with the others) and a :class:`BusyCoresNote` says so in one line.
  Beside two processes pinned to core 0, the ROM stage's two members took 1.8x their quiet
  time so, against 2.9x pinned to cores 0 and 1 (fair: 2x; ``benchmarks/load_fairness.py``).
  The decision itself is the pure function :func:`place_workers`.
- **As many threads as cores.** Every worker's thread pools are limited to the cores it owns
  (one when pinned), through the environment it is started with, before it loads NumPy, numba
  or JAX (:func:`worker_environ`): OpenBLAS, MKL and OpenMP, numba, XLA's CPU thread pools
  (``NPROC``) and XLA's multi-threaded Eigen products (``XLA_FLAGS``, appended to the user's).
  Extra threads pinned to the core of the one doing the work only take turns with it.

The variables are set in this process's environment only while the workers start; Dask's own
defaults for its workers (``OMP_NUM_THREADS=1``, ...) are taken back from it as well.

This module imports no estimator: :mod:`sloshrom.rom.sweep` and :mod:`sloshrom.rom.ensemble`
both use it without importing each other.
"""

from __future__ import annotations

import contextlib
import contextvars
import fcntl
import os
import stat
import tempfile
import time
import warnings
from collections.abc import Callable, Iterable, Iterator, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any, TypeVar

from sloshrom._threads import usable_cores
from sloshrom.errors import Note

if TYPE_CHECKING:
    from dask.distributed import Client

__all__ = ["BUSY_ABOVE", "BUSY_INTERVAL", "BusyCoresNote", "CoreReservation", "Placement",
           "THREAD_VARIABLES", "busy_fractions", "can_pin", "held_cores", "measure_busy",
           "pin_workers", "place_workers", "plan_workers", "quiet_worker", "reserve_cores",
           "run_tasks",
           "runtime_dir", "stat_times", "usable_cores", "WORKER_QUIET", "worker_environ"]

T = TypeVar("T")
R = TypeVar("R")

#: A core whose busy fraction (time not idle, over the measuring interval) is above this is
#: not free for a pinned worker: it would share its core with that load and could not move.
BUSY_ABOVE = 0.5
#: Seconds over which the busy fraction of each core is measured before a cluster starts:
#: long enough for a few scheduler ticks (4 ms each), short beside a cluster's start (~3 s).
BUSY_INTERVAL = 0.25
#: The variables that size a worker's thread pools: OpenMP, OpenBLAS, MKL, numba, and XLA's
#: CPU client (``NPROC``: the size of its thread pools, measured with jaxlib 0.10).
THREAD_VARIABLES = ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS",
                    "NUMBA_NUM_THREADS", "NPROC")
#: XLA's products on its multi-threaded Eigen device; off for a worker of one thread.
XLA_ONE_THREAD = "--xla_cpu_multi_thread_eigen=false"
#: Dask settings of a LocalCluster's workers: no sampling profiler.
WORKER_QUIET: dict[str, object] = {"distributed.worker.profile.enabled": False}


class BusyCoresNote(Note):
    """A LocalCluster's workers are not pinned: too few cores are free (busy or reserved by
    another sloshrom run). Changes no result, only how the workers share the cores."""


def can_pin() -> bool:
    """Whether this platform can pin a process's threads (Linux: affinity and ``/proc``)."""
    return hasattr(os, "sched_setaffinity") and os.path.isdir("/proc/self/task")


# ---------------------------------------------------------------------------------------------
# The decision (pure)
# ---------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Placement:
    """Where the workers of a LocalCluster run and how many threads each may use.

    Attributes
    ----------
    cores : tuple of int or None
        The core of worker ``i`` is ``cores[i]``; None: not pinned (the OS schedules them).
    threads : int
        Threads of each worker's pools (BLAS, numba, XLA): the cores it owns.
    reason : str
        One line: what was decided and why.
    crowded : bool
        Not pinned because fewer cores are free than workers (busy or held by another run):
        the case to tell the user about.
    """

    cores: tuple[int, ...] | None
    threads: int
    reason: str
    crowded: bool = False


def _core_list(cores: Iterable[int]) -> str:
    """``"0, 1"``, or ``"none"``."""
    return ", ".join(str(c) for c in cores) or "none"


def place_workers(
    n_workers: int,
    cores: Sequence[int],
    held: Iterable[int] = (),
    busy: Mapping[int, float] | None = None,
    *,
    busy_above: float = BUSY_ABOVE,
) -> Placement:
    """Decide which core each worker is pinned to, if any, and its threads.

    A core is free when no other sloshrom run holds it and it is busy at most ``busy_above``.
    With at least two workers and as many free cores, each worker gets one, the least busy
    first (busy fractions compared to 0.1, then the lowest number), and one thread. Otherwise
    the workers are not pinned and share the free cores, at least one thread each.

    Parameters
    ----------
    n_workers : int
        Worker processes of the cluster.
    cores : sequence of int
        The cores this process may use (:func:`usable_cores`).
    held : iterable of int
        Cores reserved by another sloshrom run (:func:`held_cores`).
    busy : mapping of int to float, optional
        Busy fraction of each core over a short interval, 0 (idle) to 1 (:func:`measure_busy`);
        a core it does not name counts as idle.
    busy_above : float
        The busy fraction above which a core is not free.

    Returns
    -------
    Placement
        The cores (or None), the threads per worker and the reason.
    """
    busy = dict(busy or {})
    held_set = set(held) & set(cores)
    free = [c for c in cores if c not in held_set and busy.get(c, 0.0) <= busy_above]
    free.sort(key=lambda c: (round(busy.get(c, 0.0), 1), c))
    if n_workers < 2:
        return Placement(None, max(1, len(free)),
                         f"one worker: not pinned, {max(1, len(free))} thread(s)")
    if n_workers > len(cores):
        return Placement(None, 1, f"{n_workers} workers on {len(cores)} usable cores: not "
                                  "pinned, 1 thread each")
    if len(free) >= n_workers:
        chosen = tuple(free[:n_workers])
        return Placement(chosen, 1, f"{n_workers} workers pinned to cores {_core_list(chosen)}, "
                                    "1 thread each")
    taken = sorted(c for c in cores if busy.get(c, 0.0) > busy_above and c not in held_set)
    why = [f"core {c} {busy[c]:.0%} busy" for c in taken]
    if held_set:
        why.append(f"core{'s' * (len(held_set) > 1)} {_core_list(sorted(held_set))} held by "
                   "another sloshrom run")
    threads = max(1, len(free) // n_workers)
    return Placement(None, threads,
                     f"{len(free)} of {len(cores)} usable cores free for {n_workers} Dask "
                     f"workers ({', '.join(why)}): workers not pinned, {threads} thread"
                     f"{'s' * (threads > 1)} each", crowded=True)


# ---------------------------------------------------------------------------------------------
# Busy cores: /proc/stat
# ---------------------------------------------------------------------------------------------


def stat_times(text: str) -> dict[int, tuple[int, int]]:
    """Idle and total time of each core (clock ticks since boot) from ``/proc/stat``'s text.

    ``cpuN user nice system idle iowait irq softirq steal ...``: idle is ``idle + iowait``, total
    the sum of the first eight fields (guest time is already in user). Time stolen by the
    hypervisor counts as busy: another guest had the core.
    """
    out: dict[int, tuple[int, int]] = {}
    for line in text.splitlines():
        name, *fields = line.split()
        if not (name.startswith("cpu") and name[3:].isdigit()) or len(fields) < 4:
            continue
        ticks = [int(f) for f in fields[:8]]
        out[int(name[3:])] = (ticks[3] + (ticks[4] if len(ticks) > 4 else 0), sum(ticks))
    return out


def busy_fractions(before: Mapping[int, tuple[int, int]],
                   after: Mapping[int, tuple[int, int]]) -> dict[int, float]:
    """Busy fraction (0..1) of each core between two readings of :func:`stat_times`.

    A core with no tick in between (a too short interval) counts as idle.
    """
    out: dict[int, float] = {}
    for core, (idle1, total1) in after.items():
        if core not in before:
            continue
        idle0, total0 = before[core]
        d_total = total1 - total0
        out[core] = min(1.0, max(0.0, 1.0 - (idle1 - idle0) / d_total)) if d_total > 0 else 0.0
    return out


def measure_busy(interval: float = BUSY_INTERVAL) -> dict[int, float]:
    """The busy fraction of each core over the next ``interval`` seconds, from ``/proc/stat``.

    Per core and now, unlike the load average (one number for the machine, an average over the
    last minute that lags a load that starts or stops). Empty where ``/proc/stat`` is missing.
    """
    try:
        before = stat_times(Path("/proc/stat").read_text())
        time.sleep(interval)
        after = stat_times(Path("/proc/stat").read_text())
    except OSError:
        return {}
    return busy_fractions(before, after)


# ---------------------------------------------------------------------------------------------
# Cores reserved by lock files
# ---------------------------------------------------------------------------------------------


def runtime_dir() -> Path:
    """The per-user directory of the core lock files, created (mode 700) if missing.

    ``$XDG_RUNTIME_DIR/sloshrom`` where the session has one, else ``<tmp>/sloshrom-<uid>``.

    Raises
    ------
    OSError
        The directory cannot be made, or is not this user's own directory (a symbolic link, or
        another user's, in a shared temporary directory).
    """
    xdg = os.environ.get("XDG_RUNTIME_DIR", "")
    if xdg and os.path.isdir(xdg):
        path = Path(xdg) / "sloshrom"
    else:
        path = Path(tempfile.gettempdir()) / f"sloshrom-{os.getuid()}"
    with contextlib.suppress(FileExistsError):
        path.mkdir(mode=0o700)
    info = path.lstat()
    if not stat.S_ISDIR(info.st_mode) or info.st_uid != os.getuid():
        raise OSError(f"{path} is not a directory of this user")
    return path


def _lock(directory: Path, core: int) -> int | None:
    """An open descriptor holding the lock of ``core``, or None when another holds it."""
    fd = os.open(directory / f"core-{core}.lock", os.O_RDWR | os.O_CREAT, 0o600)
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except BlockingIOError:
        os.close(fd)
        return None
    except BaseException:
        os.close(fd)
        raise
    return fd


class CoreReservation:
    """Cores reserved by this process: a lock held on each until :meth:`release`.

    The locks are ``flock`` locks of open files: they are this object's, not the process's
    (two reservations in one process exclude each other too), and the OS releases them when
    the process ends, however it ends. Use as a context manager, or call :meth:`release`.

    Attributes
    ----------
    cores : tuple of int
        The reserved cores, in the order they were asked for.
    """

    def __init__(self, locks: Mapping[int, int]) -> None:
        self._fds = dict(locks)
        self.cores = tuple(self._fds)

    def release(self) -> None:
        """Release every lock (idempotent)."""
        fds, self._fds = self._fds, {}
        for fd in fds.values():
            os.close(fd)  # closing the file releases its flock

    def __enter__(self) -> CoreReservation:
        return self

    def __exit__(self, *exc: object) -> None:
        self.release()

    def __del__(self) -> None:
        if getattr(self, "_fds", None):  # dropped unreleased: do not keep the cores
            self.release()


def reserve_cores(cores: Iterable[int], n: int, directory: Path | None = None) -> CoreReservation:
    """Reserve up to ``n`` of ``cores``, in their order, skipping those another run holds.

    Parameters
    ----------
    cores : iterable of int
        The candidates, preferred first.
    n : int
        How many to reserve.
    directory : Path, optional
        The directory of the lock files; default :func:`runtime_dir`.

    Returns
    -------
    CoreReservation
        The cores reserved: ``n`` of them, or fewer when fewer were free.

    Raises
    ------
    OSError
        The lock directory or a lock file cannot be used.
    """
    directory = runtime_dir() if directory is None else directory
    locks: dict[int, int] = {}
    try:
        for core in cores:
            if len(locks) >= n:
                break
            fd = _lock(directory, core)
            if fd is not None:
                locks[core] = fd
    except BaseException:
        for fd in locks.values():
            os.close(fd)
        raise
    return CoreReservation(locks)


def held_cores(cores: Iterable[int], directory: Path | None = None) -> set[int]:
    """The cores of ``cores`` whose lock another reservation holds now (each lock is taken and
    released at once when free)."""
    directory = runtime_dir() if directory is None else directory
    held = set()
    for core in cores:
        fd = _lock(directory, core)
        if fd is None:
            held.add(core)
        else:
            os.close(fd)
    return held


def plan_workers(
    n_workers: int,
    *,
    busy: Mapping[int, float] | None = None,
    directory: Path | None = None,
) -> tuple[Placement, CoreReservation | None]:
    """The placement of a new LocalCluster's workers, with its cores reserved.

    Reads this machine: :func:`usable_cores`, the cores other runs hold (:func:`held_cores`),
    the busy fractions (:func:`measure_busy`, unless ``busy`` is given); decides with
    :func:`place_workers`; reserves the chosen cores. When another run reserves one of them
    between the reading and the reservation, it reads and decides again (three times at most,
    then does not pin).

    Parameters
    ----------
    n_workers : int
        Worker processes of the cluster.
    busy : mapping of int to float, optional
        Busy fractions to use instead of measuring them (tests).
    directory : Path, optional
        The directory of the lock files; default :func:`runtime_dir`.

    Returns
    -------
    Placement
        The decision (:attr:`Placement.reason` says it in one line).
    CoreReservation or None
        The reserved cores, to release when the cluster closes; None when not pinned.
    """
    cores = usable_cores()
    if n_workers < 2 or n_workers > len(cores):  # nothing to pin: the decision needs no reading
        return place_workers(n_workers, cores), None
    if not can_pin():
        threads = max(1, len(cores) // n_workers)
        return (Placement(None, threads, f"cannot pin on this platform: {n_workers} workers "
                                         f"not pinned, {threads} thread(s) each"), None)
    if busy is None:
        busy = measure_busy()
    try:
        directory = runtime_dir() if directory is None else directory
        for _ in range(3):
            placement = place_workers(n_workers, cores, held_cores(cores, directory), busy)
            if placement.cores is None:
                return placement, None
            reservation = reserve_cores(placement.cores, n_workers, directory)
            if reservation.cores == placement.cores:
                return placement, reservation
            reservation.release()  # another run took one of them meanwhile: read again
    except OSError as e:  # no lock directory of our own: pinning blind could collide
        return (Placement(None, 1, f"cannot reserve cores ({e}): {n_workers} workers not "
                                   "pinned, 1 thread each", crowded=True), None)
    return (Placement(None, 1, f"cores taken by other sloshrom runs while reserving: "
                               f"{n_workers} workers not pinned, 1 thread each", crowded=True),
            None)


# ---------------------------------------------------------------------------------------------
# The workers' environment and pinning
# ---------------------------------------------------------------------------------------------


def worker_environ(threads: int, environ: Mapping[str, str] | None = None) -> dict[str, str]:
    """The environment variables that limit a worker's thread pools to ``threads``.

    A thread count the user set lower (in ``environ``) is kept; the user's ``XLA_FLAGS`` are
    kept and, for one thread, :data:`XLA_ONE_THREAD` appended unless they set that flag
    themselves (or name a file of flags, which XLA reads instead).

    Parameters
    ----------
    threads : int
        Threads of each pool: the cores the worker owns.
    environ : mapping, optional
        The environment the workers inherit; default ``os.environ``.

    Returns
    -------
    dict
        Variable -> value, to set before the worker process starts.
    """
    environ = os.environ if environ is None else environ
    env: dict[str, str] = {}
    for var in THREAD_VARIABLES:
        mine = environ.get(var, "").strip()
        env[var] = mine if mine.isdigit() and 0 < int(mine) < threads else str(threads)
    flags = environ.get("XLA_FLAGS", "").strip()
    if threads == 1 and "xla_cpu_multi_thread_eigen" not in flags:
        if not flags:
            env["XLA_FLAGS"] = XLA_ONE_THREAD
        elif flags.startswith("--"):
            env["XLA_FLAGS"] = f"{flags} {XLA_ONE_THREAD}"
    return env


@contextlib.contextmanager
def _environ(values: Mapping[str, str], restore: Iterable[str]) -> Iterator[None]:
    """Set ``values`` in this process's environment; on exit, put back ``values``' variables
    and those of ``restore`` (which Dask sets in the process that starts its workers) as they
    were."""
    keys = set(values) | set(restore)
    saved = {k: os.environ.get(k) for k in keys}
    os.environ.update(values)
    try:
        yield
    finally:
        for k, v in saved.items():
            if v is None:
                os.environ.pop(k, None)
            else:
                os.environ[k] = v


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


def pin_workers(client: Any, cores: Sequence[int]) -> dict[str, int]:
    """Pin worker ``i`` of a LocalCluster (every thread of it) to ``cores[i]``.

    Parameters
    ----------
    client : dask.distributed.Client
        A client of the cluster, whose workers are named 0, 1, ... (a LocalCluster's).
    cores : sequence of int
        A core per worker (:attr:`Placement.cores`).

    Returns
    -------
    dict
        The core of each worker (by address).
    """
    return client.run(_pin_this_process, list(cores))


def quiet_worker(parent: int | None, *categories: type[Warning]) -> None:
    """In a process other than ``parent``, ignore warnings of ``categories`` for good.

    For a task of :func:`run_tasks` whose warnings its caller says once, from the results, in
    its own process (``parent``: that process's id, passed in the task's arguments). A Dask
    worker process would otherwise print each one raw; in the caller's process (``"threads"``,
    ``"sequential"``) nothing is changed: the caller filters there, in its own thread, since a
    filter set and restored in each task would race between threads.

    Parameters
    ----------
    parent : int or None
        Process id of the caller of :func:`run_tasks`; None: change nothing.
    *categories : type of Warning
        The warnings to ignore in this process.
    """
    if parent is not None and os.getpid() != parent:
        for category in categories:
            warnings.filterwarnings("ignore", category=category)


def run_tasks(
    fn: Callable[..., R],
    items: Iterable[T],
    shared: Sequence[Any] = (),
    args: Sequence[Any] = (),
    *,
    scheduler: str | None = None,
    n_workers: int = 2,
    done: Callable[[int, R], Any] | None = None,
    started: Callable[[], object] | None = None,
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
    started : callable, optional
        ``started()`` once, as the tasks are submitted: after a new LocalCluster's workers
        are placed on their cores (work the caller starts beside them from then on does not
        make the cores look busy to the placement).

    Returns
    -------
    list
        The results, in the order of ``items``.

    Raises
    ------
    Exception
        The first exception a task raised (the other tasks are cancelled or left to finish).

    Warns
    -----
    BusyCoresNote
        A new LocalCluster's workers are not pinned because too few cores are free.
    """
    todo = list(items)
    results: list[Any] = [None] * len(todo)

    def finish(i: int, r: Any) -> None:
        results[i] = r
        if done is not None:
            done(i, r)

    def start() -> None:
        if started is not None:
            started()

    if scheduler == "sequential":
        start()
        for i, it in enumerate(todo):
            finish(i, fn(it, *shared, *args))
    elif scheduler == "threads":
        from concurrent.futures import ThreadPoolExecutor, as_completed

        with ThreadPoolExecutor(max_workers=n_workers) as ex:
            # each task in a copy of the caller's context (its context variables)
            index = {ex.submit(contextvars.copy_context().run, fn, it, *shared, *args): i
                     for i, it in enumerate(todo)}
            start()
            for f in as_completed(index):
                finish(index[f], f.result())
    else:
        from dask.distributed import as_completed

        with contextlib.ExitStack() as stack:
            client = stack.enter_context(_client(scheduler, n_workers))
            data = client.scatter(list(shared), broadcast=True) if shared else []
            futs = [client.submit(fn, it, *data, *args, pure=False) for it in todo]
            start()
            index = {f.key: i for i, f in enumerate(futs)}
            for f in as_completed(futs):
                finish(index[f.key], f.result())
    return results


@contextlib.contextmanager
def _client(scheduler: str | None, n_workers: int) -> Iterator[Client]:
    """A Dask client of the scheduler at ``scheduler``, or of a new LocalCluster (None) placed
    by :func:`plan_workers`; closed on exit, with the cluster and its cores' reservation."""
    import dask
    from dask.distributed import Client, LocalCluster

    if scheduler is not None:
        client = Client(scheduler, timeout=10)  # an unreachable address fails, not hangs
        try:
            yield client
        finally:
            client.close()
        return
    placement, reservation = plan_workers(n_workers)
    if placement.crowded:
        load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
        # stacklevel: the caller of run_tasks (through run_tasks and this generator)
        warnings.warn(BusyCoresNote(f"{placement.reason}; 1-minute load average {load:.1f}"),
                      stacklevel=5)
    env = worker_environ(placement.threads)
    # Dask's nanny sets MALLOC_TRIM_THRESHOLD_=65536 in its workers by default (against
    # fragmentation); glibc then returns and re-faults the large buffers a training
    # allocates at every step: the NFIR's epochs ran 2x slower (as measured). Unset, the
    # workers inherit this process's setting, glibc's adaptive threshold by default.
    # Ours are "pre-spawn" variables: set before the worker process starts, so before it loads
    # OpenBLAS or numba; Dask's nanny also sets them in this process (restored by _environ).
    spawn = "distributed.nanny.pre-spawn-environ"
    dask_defaults = set(dask.config.get(spawn)) | {"PYTHONHASHSEED"}
    settings: dict[str, object] = {f"{spawn}.{k}": v for k, v in env.items()}
    settings[f"{spawn}.MALLOC_TRIM_THRESHOLD_"] = None
    # Dask's sampling profiler takes the GIL from a task's thread every 10 ms to look at its
    # stack, for a dashboard that is not there: without it the grey box's column search in a
    # worker ran 6 % faster (as measured)
    settings.update(WORKER_QUIET)
    with contextlib.ExitStack() as stack:
        if reservation is not None:
            stack.callback(reservation.release)
        # on exit too: a worker the nanny restarts sets them again in this process
        stack.enter_context(_environ({}, [*env, *dask_defaults]))
        with dask.config.set(settings), _environ(env, dask_defaults):
            cluster = stack.enter_context(LocalCluster(
                n_workers=n_workers, threads_per_worker=1, processes=True,
                dashboard_address=None))
        client = stack.enter_context(Client(cluster))
        if placement.cores is not None:
            pin_workers(client, placement.cores)
        yield client
