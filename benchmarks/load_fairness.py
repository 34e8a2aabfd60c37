"""Fair under load: the ROM stage's parallel training beside CPU-bound processes, against its
share of the cores.

What the ROM stage of ``make reproduce`` trains: the default NSS ensemble, two members on a new
Dask LocalCluster of two workers (:func:`sloshrom.rom.parallel.run_tasks`), shortened to
``--epochs`` epochs each (the recipe unchanged; the full stage runs 60). Records: those of a
finished ``make reproduce`` (``--run``), else the rig's VFA tests (480 s / 240 s, cached in the
temporary directory; as ``benchmarks/train_speed.py``). Timed in one run, in this order:

1. the default placement (:func:`~sloshrom.rom.parallel.plan_workers`: cores reserved, idle
   cores only, every worker's thread pools limited to its cores), quiet;
2. the old behaviour (each worker pinned to one of the first cores, whatever the load; no
   thread limits but Dask's ``OMP/MKL/OPENBLAS_NUM_THREADS=1``), quiet;
3. the default beside ``--hogs`` CPU-bound processes (``python -c "while True: pass"``);
4. the old behaviour beside them.

Each line: the placement taken, the wall time of the training (the cluster's start and the
compilation included: what the stage waits for), the steady epoch of Adam steps (the slower
member's median of epochs 2..E) and each worker's CPU time. Then the slow-down of each
behaviour under load (loaded / quiet, same behaviour) against its fair one: with W workers and
H hogs on C cores each runnable process gets C / (W + H) of a core when C < W + H, so the fair
slow-down is (W + H) / C (2 workers + 2 hogs on 2 cores: 2x). Target: slow-down <= 1.5x the
fair one. Threads fighting on a pinned core show as a worker's CPU time rising under load
above its quiet CPU time (the same work).

The machine's own load (other users) is printed before each case (the 1-minute load average and
each core's busy fraction over 0.25 s); a "quiet" case on a busy machine is not quiet, and the
ratios drift with it: run it when the machine is otherwise idle.

Run: ``.venv/bin/python benchmarks/load_fairness.py [--epochs 3] [--hogs 2] [--skip-old]``
(about 3 min with the defaults on a 2-core machine).
"""

from __future__ import annotations

import argparse
import contextlib
import os
import resource
import subprocess
import sys
import time
import warnings
from collections.abc import Iterator
from pathlib import Path

import numpy as np

import sloshrom.rom.parallel as par
from train_speed import records, steady

#: Busy fraction of the busiest core above which a "quiet" case was not quiet.
QUIET_BELOW = 0.2


def _fit_member(seed: int, u, y, uv, yv, fs: float, epochs: int):
    """One NSS member of the default recipe (a task of run_tasks): the model, its worker's
    CPU seconds so far (user + system, this process) and its core(s)."""
    from sloshrom.rom import NSS
    from sloshrom.rom.registry import CLASSES

    m = NSS(max_epochs=epochs, seed=seed, **CLASSES["nss"].recipe).fit(
        u, y, fs=fs, validation=(uv, yv))
    ru = resource.getrusage(resource.RUSAGE_SELF)
    return m, ru.ru_utime + ru.ru_stime, sorted(os.sched_getaffinity(0))


@contextlib.contextmanager
def old_behaviour() -> Iterator[None]:
    """run_tasks as before: the workers pinned to the first cores whatever the load, no cores
    reserved, no thread limits but Dask's defaults."""
    plan, environ = par.plan_workers, par.worker_environ

    def pinned(n_workers, **_):
        cores = tuple(par.usable_cores()[:n_workers])
        return par.Placement(cores, 1, f"pinned to cores {', '.join(map(str, cores))} (old)"), None

    par.plan_workers = pinned
    par.worker_environ = lambda threads, environ=None: {}
    try:
        yield
    finally:
        par.plan_workers, par.worker_environ = plan, environ


@contextlib.contextmanager
def hogs(n: int) -> Iterator[None]:
    """``n`` CPU-bound processes for the duration (started 1 s before: the load is there when
    the placement reads the cores)."""
    procs = [subprocess.Popen([sys.executable, "-c", "while True: pass"]) for _ in range(n)]
    try:
        time.sleep(1.0 if n else 0.0)
        yield
    finally:
        for p in procs:
            p.kill()
        for p in procs:
            p.wait()


def machine() -> tuple[str, float]:
    """The 1-minute load average and each core's busy fraction now; the busiest core's."""
    busy = par.measure_busy()
    cores = ", ".join(f"{c}: {b:.0%}" for c, b in sorted(busy.items()))
    return f"load {os.getloadavg()[0]:.1f}, busy {cores}", max(busy.values(), default=0.0)


def case(data, epochs: int, old: bool, n_hogs: int) -> dict:
    """Train the two members once; the times, the CPU and the placement."""
    u, y, uv, yv, fs = data
    label = f"{'old' if old else 'new'}, {f'beside {n_hogs} hogs' if n_hogs else 'quiet'}"
    with hogs(n_hogs), old_behaviour() if old else contextlib.nullcontext():
        before, busiest = machine()
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always", par.BusyCoresNote)
            t0 = time.perf_counter()
            out = par.run_tasks(_fit_member, [0, 1], shared=(u, y, uv, yv), args=(fs, epochs),
                                n_workers=2)
            wall = time.perf_counter() - t0
    notes = [str(w.message) for w in caught if issubclass(w.category, par.BusyCoresNote)]
    cores = [c for _, _, c in out]
    placed = ("not pinned: " + notes[0].split(" for ")[0] if notes else
              "pinned to cores " + ", ".join(str(c[0]) for c in sorted(cores))
              if all(len(c) == 1 for c in cores) else "not pinned")
    epoch = max(steady(m.history_, "step_seconds") for m, _, _ in out)
    cpu = [c for _, c, _ in out]
    print(f"{label:22s} | {placed:48s} | wall {wall:6.1f} s | epoch {epoch:6.2f} s | worker CPU "
          f"{' / '.join(f'{c:.0f}' for c in cpu)} s | before: {before}", flush=True)
    return {"wall": wall, "epoch": epoch, "cpu": cpu, "notes": notes, "busiest": busiest}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--run", type=Path, default=Path("results"),
                    help="a finished `make reproduce` run: its records")
    ap.add_argument("--epochs", type=int, default=3, help="epochs of each member (>= 3)")
    ap.add_argument("--hogs", type=int, default=2, help="CPU-bound processes beside it")
    ap.add_argument("--skip-old", action="store_true", help="do not time the old behaviour")
    args = ap.parse_args()
    epochs = max(3, args.epochs)
    data, source = records(args.run)
    n_cores, n_workers = len(par.usable_cores()), 2
    print(f"records: {source}; 2 NSS members x {epochs} epochs on {n_workers} workers; "
          f"{n_cores} usable cores; {args.hogs} hogs", flush=True)
    behaviours = [False] if args.skip_old else [False, True]
    quiet = {old: case(data, epochs, old, 0) for old in behaviours}
    loaded = {old: case(data, epochs, old, args.hogs) for old in behaviours}
    runnable = n_workers + args.hogs
    fair = max(1.0, runnable / n_cores)
    print(f"CPU share beside {args.hogs} hogs: {n_workers} workers + {args.hogs} hogs on "
          f"{n_cores} cores -> {min(1.0, n_cores / runnable):.2f} of a core each, fair "
          f"slow-down {fair:.2f}x")
    for old in behaviours:
        q, lo = quiet[old], loaded[old]
        wall, epoch = lo["wall"] / q["wall"], lo["epoch"] / q["epoch"]
        cpu = np.mean(lo["cpu"]) / np.mean(q["cpu"])
        verdict = "met" if wall <= 1.5 * fair else "NOT met"
        name = "old (pinned, threads unlimited)" if old else "new (the default)"
        print(f"{name}: slow-down {wall:.2f}x wall ({epoch:.2f}x per epoch) = "
              f"{wall / fair:.2f}x the fair one (target <= 1.5x: {verdict}); worker CPU "
              f"under load / quiet {cpu:.2f}x")
    if any(q["busiest"] > QUIET_BELOW for q in quiet.values()):
        print(f"NOTE: a core was more than {QUIET_BELOW:.0%} busy before a quiet case: the "
              "machine was not quiet, the slow-downs above understate the hogs' effect")


if __name__ == "__main__":
    main()
