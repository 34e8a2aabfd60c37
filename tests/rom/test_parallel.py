"""The placement of a LocalCluster's workers (sloshrom.rom.parallel): which cores, reserved how,
with how many threads; the decision is pure and tested on given readings, the reservation on lock
files in a temporary directory, the workers' environment on one real cluster."""

from __future__ import annotations

import os
import subprocess
import sys
import warnings

import pytest

from sloshrom._threads import map_threads, numba_threadsafe
from sloshrom.rom import parallel
from sloshrom.rom.parallel import (
    XLA_ONE_THREAD,
    BusyCoresNote,
    busy_fractions,
    held_cores,
    place_workers,
    plan_workers,
    reserve_cores,
    run_tasks,
    stat_times,
    usable_cores,
    worker_environ,
)

QUIET = {0: 0.02, 1: 0.05}


# --- the decision ---------------------------------------------------------------------------


def test_a_quiet_machine_pins_a_worker_per_core_with_one_thread():
    p = place_workers(2, [0, 1], busy=QUIET)
    assert p.cores == (0, 1) and p.threads == 1 and not p.crowded
    assert "pinned to cores 0, 1" in p.reason


def test_busy_cores_are_not_pinned_and_the_reason_names_them():
    p = place_workers(2, [0, 1], busy={0: 0.97, 1: 1.0})
    assert p.cores is None and p.crowded and p.threads == 1
    assert p.reason == ("0 of 2 usable cores free for 2 Dask workers (core 0 97% busy, core 1 "
                        "100% busy): workers not pinned, 1 thread each")
    # one free core is not enough for two workers either
    p = place_workers(2, [0, 1], busy={0: 0.1, 1: 0.8})
    assert p.cores is None and p.crowded and "1 of 2 usable cores free" in p.reason
    # the threshold: at most BUSY_ABOVE is free
    assert place_workers(2, [0, 1], busy={0: 0.5, 1: 0.5}).cores == (0, 1)


def test_cores_held_by_another_run_are_not_free():
    p = place_workers(2, [0, 1], held={0}, busy=QUIET)
    assert p.cores is None and p.crowded
    assert "core 0 held by another sloshrom run" in p.reason


def test_a_16_core_workstation_where_another_run_holds_0_and_1():
    cores = list(range(16))
    assert place_workers(2, cores, held={0, 1}).cores == (2, 3)
    # the least busy free cores first (to 0.1), then the lowest numbers
    busy = {2: 0.9, 3: 0.3, 4: 0.0, 5: 0.04}
    assert place_workers(2, cores, held={0, 1}, busy=busy).cores == (4, 5)
    assert place_workers(3, cores, held={0, 1}, busy=busy).cores == (4, 5, 6)
    # held cores outside the usable ones do not count
    assert place_workers(2, [8, 9], held={0, 1}).cores == (8, 9)
    # crowded on 16 cores: the free ones are shared, at least one thread each
    p = place_workers(4, cores, held=range(13), busy={13: 1.0})
    assert p.cores is None and p.crowded and p.threads == 1
    assert "2 of 16 usable cores free" in p.reason and "cores 0, 1, 2" in p.reason


def test_one_worker_or_more_workers_than_cores_are_not_pinned_nor_crowded():
    p = place_workers(1, [0, 1], busy=QUIET)
    assert p.cores is None and not p.crowded and p.threads == 2
    assert place_workers(1, [0, 1], busy={0: 1.0, 1: 1.0}).threads == 1
    p = place_workers(3, [0, 1], busy=QUIET)
    assert p.cores is None and not p.crowded and p.threads == 1


# --- the readings ----------------------------------------------------------------------------


STAT0 = """cpu  300 0 100 1600 0 0 0 0 0 0
cpu0 100 0 50 800 0 0 0 0 0 0
cpu1 200 0 50 800 0 0 0 0 0 0
intr 12345 0 0
"""
# in between: core 0 idle for 24 of 25 ticks, core 1 busy for 25 of 25 (20 user, 5 stolen)
STAT1 = """cpu  320 0 101 1624 0 0 0 5 0 0
cpu0 100 0 51 823 1 0 0 0 0 0
cpu1 220 0 50 800 0 0 0 5 0 0
intr 12399 0 0
"""


def test_busy_fractions_from_two_readings_of_proc_stat():
    t0, t1 = stat_times(STAT0), stat_times(STAT1)
    assert t0 == {0: (800, 950), 1: (800, 1050)}
    busy = busy_fractions(t0, t1)
    assert busy[0] == pytest.approx(1 / 25) and busy[1] == 1.0
    assert busy_fractions(t0, t0) == {0: 0.0, 1: 0.0}  # no tick: idle


@pytest.mark.skipif(not os.path.isfile("/proc/stat"), reason="Linux only")
def test_measure_busy_reads_every_usable_core():
    busy = parallel.measure_busy(0.05)
    assert set(usable_cores()) <= set(busy) and all(0 <= b <= 1 for b in busy.values())


# --- the reservation -------------------------------------------------------------------------


def test_two_reservations_get_different_cores_until_released(tmp_path):
    with reserve_cores([0, 1, 2, 3], 2, tmp_path) as a:
        b = reserve_cores([0, 1, 2, 3], 2, tmp_path)
        assert a.cores == (0, 1) and b.cores == (2, 3)
        assert held_cores(range(5), tmp_path) == {0, 1, 2, 3}
        assert reserve_cores([0, 1, 2, 3], 2, tmp_path).cores == ()  # none left
        b.release()
        b.release()  # idempotent
        assert held_cores(range(5), tmp_path) == {0, 1}
    assert held_cores(range(5), tmp_path) == set()


def test_a_lock_is_held_by_another_process_and_freed_when_it_dies(tmp_path):
    code = ("import sys; from pathlib import Path; from sloshrom.rom.parallel import "
            "reserve_cores; r = reserve_cores([0], 1, Path(sys.argv[1])); print(r.cores, "
            "flush=True); sys.stdin.read()")
    proc = subprocess.Popen([sys.executable, "-c", code, str(tmp_path)], text=True,
                            stdin=subprocess.PIPE, stdout=subprocess.PIPE)
    try:
        assert proc.stdout.readline().strip() == "(0,)"
        assert held_cores([0, 1], tmp_path) == {0}
    finally:
        proc.kill()  # no release: the OS drops the lock with the process
        proc.wait()
    assert held_cores([0, 1], tmp_path) == set()


@pytest.mark.skipif(not parallel.can_pin() or len(usable_cores()) < 2,
                    reason="pinning needs Linux and two cores")
def test_plan_workers_reserves_the_cores_it_pins_to(tmp_path):
    cores = usable_cores()
    quiet = dict.fromkeys(cores, 0.0)
    placement, reservation = plan_workers(2, busy=quiet, directory=tmp_path)
    assert placement.cores == tuple(cores[:2]) and reservation.cores == placement.cores
    # a second run meanwhile: the next cores, or none free on two cores
    second, r2 = plan_workers(2, busy=quiet, directory=tmp_path)
    if len(cores) >= 4:
        assert second.cores == tuple(cores[2:4])
        r2.release()
    else:
        assert second.cores is None and second.crowded and r2 is None
        assert "held by another sloshrom run" in second.reason
    reservation.release()
    busy = dict.fromkeys(cores, 1.0)
    placement, reservation = plan_workers(2, busy=busy, directory=tmp_path)
    assert placement.cores is None and reservation is None and placement.crowded
    # no lock directory to use: not pinned (blind pinning could collide with another run)
    (tmp_path / "file").write_text("")
    placement, reservation = plan_workers(2, busy=quiet, directory=tmp_path / "file")
    assert placement.cores is None and reservation is None and placement.crowded
    assert placement.reason.startswith("cannot reserve cores (")


def test_the_lock_directory_is_this_users_own(monkeypatch, tmp_path):
    monkeypatch.setenv("XDG_RUNTIME_DIR", str(tmp_path))
    path = parallel.runtime_dir()
    assert path == tmp_path / "sloshrom" and (path.stat().st_mode & 0o777) == 0o700
    assert parallel.runtime_dir() == path  # made once, then found
    path.rmdir()
    (tmp_path / "elsewhere").mkdir()
    path.symlink_to(tmp_path / "elsewhere")  # a link planted in its place: refused
    with pytest.raises(OSError, match="not a directory of this user"):
        parallel.runtime_dir()


# --- the workers' environment ----------------------------------------------------------------


def test_worker_environ_limits_every_pool_and_keeps_the_users_settings():
    env = worker_environ(1, {})
    assert env == {"OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1", "MKL_NUM_THREADS": "1",
                   "NUMBA_NUM_THREADS": "1", "NPROC": "1", "XLA_FLAGS": XLA_ONE_THREAD}
    user = {"XLA_FLAGS": "--xla_cpu_enable_fast_math=false", "OMP_NUM_THREADS": "8",
            "OPENBLAS_NUM_THREADS": "1"}
    env = worker_environ(2, user)
    assert env["OMP_NUM_THREADS"] == "2" and env["OPENBLAS_NUM_THREADS"] == "1"
    assert "XLA_FLAGS" not in env  # two threads: XLA's Eigen may use them
    env = worker_environ(1, user)
    assert env["XLA_FLAGS"] == f"--xla_cpu_enable_fast_math=false {XLA_ONE_THREAD}"
    # the user's own choice of the flag, or a file of flags: left as they are
    assert "XLA_FLAGS" not in worker_environ(1, {"XLA_FLAGS": "--xla_cpu_multi_thread_eigen"})
    assert "XLA_FLAGS" not in worker_environ(1, {"XLA_FLAGS": "/etc/xla.flags"})


def _worker_state(_: object) -> dict[str, object]:
    """What a task sees in its worker: the variables, the cores of its threads, XLA's pool."""
    import jax
    import jax.numpy as jnp

    jax.jit(lambda a: jnp.tanh(a @ a))(jnp.ones((64, 64))).block_until_ready()
    names, cores = [], set()
    for tid in os.listdir("/proc/self/task"):
        try:
            with open(f"/proc/self/task/{tid}/comm") as f:
                names.append(f.read().strip())
            cores |= os.sched_getaffinity(int(tid))
        except OSError:  # a thread that ended meanwhile
            pass
    keys = (*parallel.THREAD_VARIABLES, "XLA_FLAGS", "MALLOC_TRIM_THRESHOLD_")
    from dask.distributed import get_worker

    return {"env": {k: os.environ.get(k) for k in keys}, "cores": sorted(cores),
            "xla_pool": sum(n.endswith("XLAEigen") for n in names),
            "profiler": "profile" in get_worker().periodic_callbacks}


@pytest.mark.skipif(not parallel.can_pin() or len(usable_cores()) < 2,
                    reason="pinning needs Linux and two cores")
@pytest.mark.long
def test_local_cluster_workers_are_pinned_with_one_thread_each(monkeypatch, tmp_path):
    """One real cluster, on a machine said to be quiet: every thread of each worker on a core of
    its own, every pool of one thread, the user's XLA flags kept, no sampling profiler; this
    process unchanged."""
    monkeypatch.setenv("XDG_RUNTIME_DIR", str(tmp_path))  # apart from the real runs' locks
    monkeypatch.setattr(parallel, "measure_busy", lambda: {})
    monkeypatch.setenv("XLA_FLAGS", "--xla_cpu_enable_fast_math=false")
    before = dict(os.environ)
    with warnings.catch_warnings():
        warnings.simplefilter("error", BusyCoresNote)
        seen = run_tasks(_worker_state, [0, 1], n_workers=2)
    assert sorted(s["cores"] for s in seen) == [[c] for c in usable_cores()[:2]]
    for s in seen:
        assert s["xla_pool"] == 1
        assert not s["profiler"]  # Dask's sampling profiler off: it takes the task's GIL
        assert s["env"] == {**dict.fromkeys(parallel.THREAD_VARIABLES, "1"),
                            "XLA_FLAGS": f"--xla_cpu_enable_fast_math=false {XLA_ONE_THREAD}",
                            # glibc's allocator as this process has it, not Dask's 65536
                            "MALLOC_TRIM_THRESHOLD_": before.get("MALLOC_TRIM_THRESHOLD_")}
    # the variables were set here only while the workers started (Dask's own ones too)
    changed = {k for k in set(before) | set(os.environ) if before.get(k) != os.environ.get(k)}
    assert changed <= {"__DASK_PARENT_PID"}, changed
    assert held_cores(usable_cores(), tmp_path / "sloshrom") == set()  # released


def test_a_busy_machine_says_so_and_does_not_pin(monkeypatch, tmp_path):
    monkeypatch.setenv("XDG_RUNTIME_DIR", str(tmp_path))
    monkeypatch.setattr(parallel, "measure_busy", lambda: dict.fromkeys(usable_cores(), 1.0))
    if not parallel.can_pin() or len(usable_cores()) < 2:
        pytest.skip("pinning needs Linux and two cores")
    with pytest.warns(BusyCoresNote, match=r"0 of \d+ usable cores free for 2 Dask workers "
                                           r"\(core \d+ 100% busy.*\): workers not pinned, 1 "
                                           r"thread each; 1-minute load average") as rec:
        seen = run_tasks(os.sched_getaffinity, [0], n_workers=2)
    assert rec[0].filename == __file__  # the caller of run_tasks
    assert seen == [set(usable_cores())]


# -- map_threads ------------------------------------------------------------------------------
def test_map_threads_gives_the_loops_results_in_order_from_threads():
    import threading

    seen = []

    def fn(x):
        seen.append(threading.current_thread().name)
        return x * x

    items = list(range(7))
    assert map_threads(fn, items, workers=2) == [x * x for x in items]
    if numba_threadsafe():
        assert all(name.startswith("sloshrom-map") for name in seen)
    else:  # numba's workqueue layer: the loop
        assert set(seen) == {threading.current_thread().name}
    seen.clear()
    # one thread or one item: the plain loop, in the caller's thread
    assert map_threads(fn, items, workers=1) == [x * x for x in items]
    assert map_threads(fn, [3], workers=2) == [9]
    assert set(seen) == {threading.current_thread().name}
    assert map_threads(fn, [], workers=2) == []


def test_map_threads_raises_the_first_error_once_every_call_has_ended():
    ran = []

    def fn(x):
        ran.append(x)
        if x in (1, 3):
            raise ValueError(f"item {x}")
        return x

    with pytest.raises(ValueError, match="item 1"):
        map_threads(fn, [0, 1, 2, 3, 4], workers=2)
    # in threads every call has ended; the loop (numba's workqueue layer) stops at the error
    assert sorted(ran) == ([0, 1, 2, 3, 4] if numba_threadsafe() else [0, 1])


def test_map_threads_runs_each_call_in_the_callers_context():
    import contextvars

    var = contextvars.ContextVar("var", default="unset")
    token = var.set("caller's")
    try:
        assert map_threads(lambda _: var.get(), range(4), workers=2) == ["caller's"] * 4
    finally:
        var.reset(token)
    # a call's own change stays in its copy
    def change(_):
        var.set("changed")
        return var.get()

    assert map_threads(change, range(3), workers=2) == ["changed"] * 3
    assert var.get() == "unset"


@pytest.mark.long
def test_map_threads_runs_numbas_parallel_kernels_in_turn_on_its_workqueue_layer():
    """numba's workqueue layer ends the process when two threads launch a parallel kernel at
    once: there the calls run one after the other (with tbb or omp, in threads)."""
    code = (
        "import numpy as np, threading\n"
        "from sloshrom._threads import map_threads, numba_threadsafe\n"
        "from sloshrom.rom.grey.physics import causal_intervals\n"
        "phys = np.array([[0.01, 1e6, 100.0, 0.01, 10.0, 0.01, 7.0]])\n"
        "u = np.sin(np.linspace(0, 60, 4000))[None].repeat(2, 0)\n"
        "seen = set()\n"
        "def run(i):\n"
        "    seen.add(threading.current_thread().name)\n"
        "    return causal_intervals(phys, u * (1 + i), 500.0, 10, 8)\n"
        "out = map_threads(run, range(4), workers=2)\n"
        "ref = [run(i) for i in range(4)]\n"
        "same = all(np.array_equal(a, b) for x, y in zip(out, ref) for a, b in zip(x, y))\n"
        "print(numba_threadsafe(), sorted(seen) == ['MainThread'], same)\n")
    for layer, expected in (("workqueue", "False True True"), ("omp", "True False True")):
        env = {**os.environ, "NUMBA_THREADING_LAYER": layer}
        res = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                             env=env, timeout=300)
        if layer == "omp" and "could not be loaded" in res.stderr + res.stdout:
            continue  # no OpenMP runtime on this machine: the workqueue case is the one
        assert res.returncode == 0, res.stderr[-2000:]
        assert res.stdout.split("\n")[-2] == expected, (layer, res.stdout, res.stderr[-500:])
