"""The grey box's free run of a few rows: the C kernel row by row against ``lax.scan``.

A validation run (one row, every epoch) or a prediction of a few records goes by
``sloshrom.rom.grey.kernel.free_run_rows``: one row at a time, the neurons as the vector axis.
``lax.scan`` (``sloshrom.rom.grey.network.grey_run``, the reference) runs the rows side by side
as the batch axis of its products. This script times both on the same network (the default
architecture: 8 states, 32 neurons; stable random weights) for ``--rows`` rows of ``--samples``
samples each, alternated, and prints the medians, their ratio and the largest difference
relative to the output's range.

Usage: ``taskset -c 0 .venv/bin/python benchmarks/grey_free_run.py`` (one core, as a
validation run has; about 20 s). The package's ``FREE_RUN_ROWS`` threshold is lifted here so
that every row count runs both paths.
"""

from __future__ import annotations

import argparse
import sys
import time

import jax
import jax.numpy as jnp
import numpy as np

from sloshrom.rom.grey import kernel as gk
from sloshrom.rom.grey.network import N_FEATURES, grey_run


def network(nx: int, n: int, seed: int) -> dict[str, np.ndarray]:
    """Random weights of a contracting network (``A``'s state rows near ``-I / 10``)."""
    rng = np.random.default_rng(seed)
    nz, no = nx + 1 + N_FEATURES, nx + N_FEATURES
    p = {"A": 0.02 * rng.standard_normal((nz, nx)), "W1": 0.3 * rng.standard_normal((nz, n)),
         "b1": 0.1 * rng.standard_normal(n), "W2": 0.03 * rng.standard_normal((n, nx)),
         "C": 0.3 * rng.standard_normal(no), "V1": 0.3 * rng.standard_normal((no, n)),
         "d1": 0.1 * rng.standard_normal(n), "V2": 0.3 * rng.standard_normal(n)}
    p["A"][:nx] -= 0.1 * np.eye(nx)
    return p


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rows", type=int, nargs="+", default=[1, 4, 32, 64])
    ap.add_argument("--samples", type=int, default=20_000)
    ap.add_argument("--repeats", type=int, default=5)
    a = ap.parse_args()
    if not gk.kernel_available():
        sys.exit("the grey box's C kernel is not built (or SLOSHROM_GREY_KERNEL=jax)")
    default = gk.FREE_RUN_ROWS
    gk.FREE_RUN_ROWS = max(a.rows)
    p = network(8, 32, 1)
    rng = np.random.default_rng(2)
    print(f"rows of {a.samples} samples; 8 states, 32 neurons; the package takes the C path "
          f"up to {default} rows")
    with jax.enable_x64(True):
        pj = {k: jnp.asarray(v) for k, v in p.items()}
        for b in a.rows:
            u = rng.standard_normal((a.samples, b))
            phi = 0.3 * rng.standard_normal((a.samples, b, N_FEATURES))
            x0 = np.zeros((b, 8))
            args = (jnp.asarray(u), jnp.asarray(phi), jnp.asarray(x0), 0.3, -0.2)
            ref = np.asarray(grey_run(pj, *args))  # compiles
            got = gk.free_run_rows(p, u, phi, x0, 0.3, -0.2)
            scan, rows = [], []
            for _ in range(a.repeats):  # alternated: drift hits both
                t0 = time.perf_counter()
                np.asarray(grey_run(pj, *args))
                t1 = time.perf_counter()
                gk.free_run_rows(p, u, phi, x0, 0.3, -0.2)
                t2 = time.perf_counter()
                scan.append(t1 - t0)
                rows.append(t2 - t1)
            diff = float(np.max(np.abs(got - ref)) / np.ptp(ref))
            ts, tr = float(np.median(scan)), float(np.median(rows))
            print(f"{b:4d} rows: lax.scan {1e3 * ts:8.1f} ms   C row by row {1e3 * tr:8.1f} ms"
                  f"   ratio {ts / tr:5.2f}   largest difference / range {diff:.1e}",
                  flush=True)


if __name__ == "__main__":
    main()
