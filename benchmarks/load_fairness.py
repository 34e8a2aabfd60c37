"""Fair under load: the ROM stage's parallel training beside CPU-bound processes, against its
share of the cores.

What the ROM stage of ``make reproduce`` trains: the default NSS ensemble, two members on a new
Dask LocalCluster of two workers (:func:`sloshrom.rom.parallel.run_tasks`), shortened to
``--epochs`` epochs each (the recipe unchanged; the full stage runs 60). Records: those of a
finished ``make reproduce`` (``--run``), else the rig's VFA tests (480 s / 240 s, cached in the
temporary directory; as ``benchmarks/train_speed.py``). Timed in one run, each quiet and then
beside ``--hogs`` CPU-bound processes (``python -c "while True: pass"``), for each behaviour
(``--behaviours``):

``new``
    the default (:func:`~sloshrom.rom.parallel.plan_workers`: cores reserved, idle cores only,
    every worker's thread pools limited to its cores; beside the hogs: not pinned);
``old``
    as before: each worker pinned to one of the first cores whatever the load, no cores
    reserved, no thread limits but Dask's ``OMP/MKL/OPENBLAS_NUM_THREADS=1``;
``pinned``
    the default's thread limits, but pinned whatever the load (to tell the effect of pinning
    from that of the threads).

``--hogs-on CORE`` pins the hogs to one core, as the workers of another run pinned there (a
second ``make reproduce``, the tests) would be. ``--repeat R`` runs R rounds (the behaviours'
order reversed every other round) and compares medians.

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

Run: ``.venv/bin/python benchmarks/load_fairness.py [--epochs 3] [--hogs 2] [--hogs-on CORE]
[--repeat 1] [--behaviours new old pinned]`` (about 4 min per round of the default two
behaviours on a 2-core machine).
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


#: The behaviours timed: name -> (what it is, whether to limit the threads, whether to pin
#: whatever the load).
BEHAVIOURS = {
    "new": ("the default", True, False),
    "old": ("pinned, threads unlimited", False, True),
    "pinned": ("pinned whatever the load, threads limited", True, True),
}


@contextlib.contextmanager
def behaviour(name: str) -> Iterator[None]:
    """run_tasks as the behaviour ``name`` of :data:`BEHAVIOURS`: "new" as it is; "old" as
    before (each worker pinned to one of the first cores whatever the load, no cores reserved,
    no thread limits but Dask's defaults); "pinned" as "new" but pinned whatever the load."""
    _, limited, forced = BEHAVIOURS[name]
    plan, environ = par.plan_workers, par.worker_environ

    def pinned(n_workers, **_):
        cores = tuple(par.usable_cores()[:n_workers])
        return par.Placement(cores, 1, "pinned to the first cores"), None

    if forced:
        par.plan_workers = pinned
    if not limited:
        par.worker_environ = lambda threads, environ=None: {}
    try:
        yield
    finally:
        par.plan_workers, par.worker_environ = plan, environ


@contextlib.contextmanager
def hogs(n: int, core: int | None = None) -> Iterator[None]:
    """``n`` CPU-bound processes for the duration (started 1 s before: the load is there when
    the placement reads the cores), pinned to ``core`` if given."""
    procs = [subprocess.Popen([sys.executable, "-c", "while True: pass"]) for _ in range(n)]
    try:
        for p in procs:
            if core is not None:
                os.sched_setaffinity(p.pid, {core})
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


def case(data, epochs: int, name: str, n_hogs: int, core: int | None = None) -> dict:
    """Train the two members once as behaviour ``name``, beside ``n_hogs`` hogs (pinned to
    ``core`` if given); the times, the CPU, the placement."""
    u, y, uv, yv, fs = data
    label = f"{name}, {f'beside {n_hogs} hogs' if n_hogs else 'quiet'}"
    with hogs(n_hogs, core), behaviour(name):
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
    ap.add_argument("--hogs-on", type=int, default=None, metavar="CORE",
                    help="pin the hogs to this core (as the pinned workers of another run)")
    ap.add_argument("--behaviours", nargs="+", choices=list(BEHAVIOURS), default=["new", "old"],
                    help="the behaviours to time (module docstring)")
    ap.add_argument("--repeat", type=int, default=1, help="rounds of every case (medians)")
    args = ap.parse_args()
    epochs = max(3, args.epochs)
    data, source = records(args.run)
    n_cores, n_workers = len(par.usable_cores()), 2
    print(f"records: {source}; 2 NSS members x {epochs} epochs on {n_workers} workers; "
          f"{n_cores} usable cores; {args.hogs} hogs", flush=True)
    names = args.behaviours
    quiet: dict[str, list[dict]] = {n: [] for n in names}
    loaded: dict[str, list[dict]] = {n: [] for n in names}
    for r in range(args.repeat):
        order = names if r % 2 == 0 else names[::-1]  # no behaviour always first
        for n in order:
            quiet[n].append(case(data, epochs, n, 0))
        for n in order:
            loaded[n].append(case(data, epochs, n, args.hogs, args.hogs_on))
    runnable = n_workers + args.hogs
    fair = max(1.0, runnable / n_cores)
    where = "" if args.hogs_on is None else f" (pinned to core {args.hogs_on})"
    print(f"CPU share beside {args.hogs} hogs{where}: {n_workers} workers + {args.hogs} hogs on "
          f"{n_cores} cores -> {min(1.0, n_cores / runnable):.2f} of a core each, fair "
          f"slow-down {fair:.2f}x; medians of {args.repeat} run(s):")
    for n in names:

        def med(cases: list[dict], key: str) -> float:
            return float(np.median([np.mean(c[key]) for c in cases]))

        q, lo = quiet[n], loaded[n]
        wall, epoch = med(lo, "wall") / med(q, "wall"), med(lo, "epoch") / med(q, "epoch")
        cpu = med(lo, "cpu") / med(q, "cpu")
        verdict = "met" if wall <= 1.5 * fair else "NOT met"
        print(f"{n} ({BEHAVIOURS[n][0]}): quiet {med(q, 'wall'):.1f} s, loaded "
              f"{med(lo, 'wall'):.1f} s: slow-down {wall:.2f}x wall ({epoch:.2f}x per epoch) = "
              f"{wall / fair:.2f}x the fair one (target <= 1.5x: {verdict}); worker CPU under "
              f"load / quiet {cpu:.2f}x")
    quiet_cases = [c for cs in quiet.values() for c in cs]
    if any(q["busiest"] > QUIET_BELOW for q in quiet_cases):
        print(f"NOTE: a core was more than {QUIET_BELOW:.0%} busy before a quiet case: the "
              "machine was not quiet, the slow-downs above understate the hogs' effect")


if __name__ == "__main__":
    main()
