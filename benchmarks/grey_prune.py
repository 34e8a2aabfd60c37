"""The column's search with trials scored in part, against every trial scored in full.

Differential evolution discards a trial that scores more than its target; ``fit_physics``
returns such a trial the error its filter's normal equations give, without its output and
spectra (``prune``, its Notes). This script runs the default recipe's search on the default
records both ways, alternated (full, in part, in part, full), on the threads the process
may use, and checks that the four give the same parameters, taps and objective to the bit.

Usage: ``taskset -c 1 .venv/bin/python benchmarks/grey_prune.py --run results`` (a
``make reproduce`` folder; about 1.5 min on one core); ``--seed 1`` for the second member.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
from grey_threads import search_arguments  # noqa: E402
from sloshrom.rom.grey import training as gt  # noqa: E402


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--run", type=Path, default=Path("results"))
    ap.add_argument("--seed", type=int, default=0, help="the member's seed (0, 1, ...)")
    a = ap.parse_args()
    args, kw = search_arguments(a.run, a.seed)
    gt.fit_physics(*args, **{**kw, "generations": 1})  # numba's kernel loaded
    seconds: dict[bool, list[float]] = {False: [], True: []}
    found = []
    pruned = 0.0
    for prune in (False, True, True, False):
        t0 = time.perf_counter()
        physics, taps, hist = gt.fit_physics(*args, **kw, prune=prune)
        seconds[prune].append(time.perf_counter() - t0)
        found.append((physics, taps, hist["objective"]))
        pruned = max(pruned, hist["pruned"])
        evaluations = hist["evaluations"]
    full, part = np.median(seconds[False]), np.median(seconds[True])
    print(f"search, seed {a.seed}, {evaluations:.0f} trials: in full "
          + ", ".join(f"{s:.2f}" for s in seconds[False]) + " s; in part "
          + ", ".join(f"{s:.2f}" for s in seconds[True])
          + f" s ({pruned:.0f} trials cut short); {full / part:.2f}x")
    same = all(np.array_equal(f[0], found[0][0]) and np.array_equal(f[1], found[0][1])
               and f[2] == found[0][2] for f in found)
    print(f"the same parameters, taps and objective in all four: {'yes' if same else 'NO'} "
          f"(objective {found[0][2]!r})")


if __name__ == "__main__":
    main()
