"""One grey-box member's identification, phase by phase, in CPU seconds: the column's search
(differential evolution, numba), the network's training (compilation, Adam epochs, validation)
and its validation error, by the pure-JAX path or the C kernel, with or without the stop on a
validation plateau. Two runs side by side (one a core) compare the paths under the same load:

    taskset -c 0 .venv/bin/python benchmarks/grey_train.py --path jax --no-plateau &
    taskset -c 1 .venv/bin/python benchmarks/grey_train.py --path kernel

(the default records of ``make reproduce``, ``--run results``; about 3 min each on a quiet core).
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from sloshrom.rom import GreyBox  # noqa: E402
from sloshrom.rom.grey import kernel as gk  # noqa: E402
from sloshrom.rom.grey import training as gt  # noqa: E402
from sloshrom.rom.grey.entry import GREY_CLASS  # noqa: E402
from train_speed import records  # noqa: E402


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--run", type=Path, default=Path("results"))
    ap.add_argument("--path", choices=("jax", "kernel"), default="kernel")
    ap.add_argument("--no-plateau", action="store_true", help="train all max_epochs")
    ap.add_argument("--seed", type=int, default=0)
    a = ap.parse_args()
    if a.path == "jax":
        os.environ[gk.KERNEL_ENV] = "jax"
    elif not gk.kernel_available():
        sys.exit("the grey box's C kernel is not built")
    if a.no_plateau:
        gt.PLATEAU = None
    (u, y, uv, yv, fs), source = records(a.run)
    cpu = {"search": 0.0}
    search = gt.fit_physics

    def timed_search(*args, **kw):
        c0 = time.process_time()
        out = search(*args, **kw)
        cpu["search"] = time.process_time() - c0
        return out

    # the recipe of `reproduce` ([rom.grey] and the class's passive recipe)
    est = GreyBox(seed=a.seed, velocity_offset=0.5, **GREY_CLASS.recipe)
    sys.modules["sloshrom.rom.grey.estimator"].fit_physics = timed_search
    c0, t0 = time.process_time(), time.perf_counter()
    est.fit(u, y, fs, validation=(uv, yv), fill=0.5)
    total_cpu, wall = time.process_time() - c0, time.perf_counter() - t0
    h = est.history_
    steps = np.asarray(h["step_seconds"][1:])
    val = np.asarray(h["validation_seconds"])
    print(f"records: {source}; path {a.path}, plateau {'off' if a.no_plateau else gt.PLATEAU}")
    print(f"epochs {len(steps)} (best {h['best_epoch']}, {h['stop_reason']}); validation MSE "
          f"{h['val_mse'][h['best_epoch']]:.5f} N^2")
    print(f"CPU s: total {total_cpu:.1f} (wall {wall:.1f}); search {cpu['search']:.1f}; "
          f"network {total_cpu - cpu['search']:.1f}")
    print(f"wall s of the network: first epoch (compiles) {steps[0]:.1f}, the others "
          f"{steps[1:].sum():.1f} ({np.median(steps[1:]):.2f} an epoch), validation "
          f"{val.sum():.1f} (first {val[0]:.1f})")


if __name__ == "__main__":
    main()
