"""The grey box's column with the windows as the vector axis, against window by window.

The column's search simulates every candidate on its 32 windows. ``causal_intervals`` runs
them as the lanes of one block (``_causal_lanes``) from ``LANES_FROM`` windows on, window by
window (``_causal_batch``) below. This script times, on one core, in the same run, alternated:

- ``kernel``: both kernels on the default search's 32 windows, 40 random candidates of the
  search's bounds, and checks that the two give the same bits;
- ``search``: the column's differential evolution, ``--generations`` generations of the
  default recipe, one thread, with the lanes and with them turned off (``LANES_FROM`` above
  the windows' count); the objectives must be equal to the bit;
- ``score``: where a candidate's score spends its time after the kernel (the search's
  ``score``, piece by piece, on the same 40 candidates): the filter's normal equations, their
  solution, the filter's output, the error and the short-time spectra.

Usage: ``taskset -c 1 .venv/bin/python benchmarks/grey_lanes.py --run results`` (a
``make reproduce`` folder; about 1 min).
"""

from __future__ import annotations

import argparse
import sys
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
import numba  # noqa: E402
from threadpoolctl import threadpool_limits  # noqa: E402

from grey_threads import _search  # noqa: E402
from sloshrom.config import Tank  # noqa: E402
from sloshrom.rom import GreyBox  # noqa: E402
from sloshrom.rom.grey import physics as ph  # noqa: E402
from sloshrom.rom.grey.training import (  # noqa: E402
    PHYSICS_BOUNDS,
    WARM_S,
    WINDOW_S,
    _solve_normal,
    _spectra,
    _windows,
)
from train_speed import records  # noqa: E402


def _kernels(run: Path, repeats: int = 2) -> None:
    (u, y, _, _, fs), _ = records(run)
    u = np.asarray(u, dtype=np.float64)
    length, warm = int(round((WINDOW_S + WARM_S) * fs)), int(round(WARM_S * fs))
    idx = _windows(u.size, fs, 32, 0)[:, None] + np.arange(length)
    uw = np.ascontiguousarray(u[idx])
    tank = Tank(fill=0.5)
    rng = np.random.default_rng(0)
    lo, hi = np.array(list(PHYSICS_BOUNDS.values())).T
    phys = [ph.physical_parameters(*(lo + (hi - lo) * rng.random(lo.size)),
                                   liquid_mass=tank.liquid_mass, ullage=tank.ullage)[None]
            for _ in range(40)]
    one, lanes = np.empty((2, 1, 32, length, 3, 8))
    args = (fs, 10, 8, False, warm - 1)
    ph._causal_batch(phys[0], uw, *args, one)  # compiled or loaded before the clock

    def by_lanes(*x: object) -> None:
        ph._causal_lanes(*x, ph.LANES)

    by_lanes(phys[0], uw, *args, lanes)
    times: dict[str, list[float]] = {"window by window": [], "lanes": []}
    for _ in range(repeats):
        for name, kernel, out in (("window by window", ph._causal_batch, one),
                                  ("lanes", by_lanes, lanes),
                                  ("lanes", by_lanes, lanes),
                                  ("window by window", ph._causal_batch, one)):
            t0 = time.perf_counter()
            for p in phys:
                kernel(p, uw, *args, out)
            times[name].append((time.perf_counter() - t0) / len(phys) * 1e3)
    same = 0
    for p in phys:
        ph._causal_batch(p, uw, *args, one)
        by_lanes(p, uw, *args, lanes)
        same += np.array_equal(one.view(np.int64), lanes.view(np.int64))
    a, b = np.median(times["window by window"]), np.median(times["lanes"])
    print(f"kernel, 32 windows of {length} samples, a candidate: window by window "
          f"{a:.2f} ms, lanes {b:.2f} ms: {a / b:.2f}x; the same bits for {same} of "
          f"{len(phys)} candidates")
    _score_parts(phys, np.asarray(y, dtype=np.float64)[idx][:, warm:], fs, warm,
                 lambda p: by_lanes(p, uw, *args, lanes), lanes[0], repeats)


def _score_parts(phys: list[np.ndarray], yw: np.ndarray, fs: float, warm: int,
                 column: Callable[[np.ndarray], None], out: np.ndarray, repeats: int) -> None:
    """A candidate's score piece by piece, as ``fit_physics``'s ``score`` computes it:
    ``column(p)`` simulates candidate ``p`` into ``out`` (its windows' column)."""
    n_past = int(GreyBox().effective_params()["n_past"])  # the default recipe's
    target, target_spectra = yw.reshape(-1), _spectra(yw, fs)
    names = ("kernel", "normal equations", "their solution", "filter output",
             "error and spectra")
    t = np.zeros((repeats, len(names)))
    for r in range(repeats):
        for p in phys:
            t0 = time.perf_counter()
            column(p)
            t1 = time.perf_counter()
            ne = ph.filter_normal_equations(out, yw, n_past, warm)
            t2 = time.perf_counter()
            taps = _solve_normal(*ne)
            t3 = time.perf_counter()
            fit = ph.filter_output(out, taps, n_past, warm)
            t4 = time.perf_counter()
            score = float(np.mean((fit.reshape(-1) - target) ** 2))
            score += sum(float(np.mean((m - s) ** 2))
                         for m, s in zip(_spectra(fit, fs), target_spectra, strict=True))
            t5 = time.perf_counter()
            t[r] += np.diff([t0, t1, t2, t3, t4, t5])
    ms = np.median(t, axis=0) / len(phys) * 1e3
    print(f"a candidate's score, {ms.sum():.2f} ms: "
          + ", ".join(f"{n} {v:.2f} ms ({v / ms.sum():.0%})" for n, v in zip(names, ms,
                                                                               strict=True)))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--run", type=Path, default=Path("results"))
    ap.add_argument("--generations", type=int, default=6)
    a = ap.parse_args()
    # one thread: the window-by-window kernel would otherwise share its windows among numba's
    # threads on the one core
    numba.set_num_threads(1)
    _kernels(a.run)
    default = ph.LANES_FROM
    res: dict[str, list[dict[str, float]]] = {"window by window": [], "lanes": []}
    with threadpool_limits(1):
        for name in ("window by window", "lanes", "lanes", "window by window"):
            ph.LANES_FROM = 10**9 if name == "window by window" else default
            res[name].append(_search(a.run, a.generations))
    for name, runs in res.items():
        print(f"search, {a.generations} generations, one thread, {name}: "
              + ", ".join(f"{r['search s']:.2f} s" for r in runs)
              + f"; objective {runs[0]['objective']!r}")
    objectives = {r["objective"] for runs in res.values() for r in runs}
    print("the same objective in all four: " + ("yes" if len(objectives) == 1 else "NO"))


if __name__ == "__main__":
    main()
