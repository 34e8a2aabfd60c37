"""Speed of the linear state-space baseline (LSS) against SciPy's own tools, in one run.

On a record the size of a sloshing test (480 s at 500 Hz, 240 000 samples) of a two-mode
system with a cubic distortion, it times:

- the simulation from rest, ``sloshrom.rom.lss.core.lss_simulate`` (real Schur form, one
  ``lfilter`` per eigenvalue or pair) against ``scipy.signal.dlsim`` (the same model, SciPy's
  state-space simulator), and prints the ratio and their largest difference;
- the identification: ``n4sid`` (order 8, 20 block rows) and ``pem_refine`` (20 iterations),
  with the fit each reaches (NRMSE on the training and the validation record).

Usage::

    python benchmarks/lss_speed.py [--repeats 5]
"""

from __future__ import annotations

import argparse
import time

import numpy as np
from scipy import signal

from sloshrom.rom.lss.core import lss_simulate, n4sid, pem_refine

FS = 500.0
N = 240_000


def records(seed: int) -> tuple[np.ndarray, np.ndarray]:
    """Band-limited velocity-like input; two lightly damped modes plus a cubic term."""
    rng = np.random.default_rng(seed)
    u = signal.sosfilt(signal.butter(4, [0.5, 15.0], btype="band", fs=FS, output="sos"),
                       rng.standard_normal(N))
    u *= 0.1 / np.std(u)
    y = np.zeros(N)
    for f, z in ((3.0, 0.02), (7.5, 0.05)):
        w = 2 * np.pi * f / FS
        r = np.exp(-z * w)
        y += signal.lfilter([0.0, w], [1.0, -2 * r * np.cos(w), r * r], u)
    return u, y + 0.3 * y**3 / np.var(y)


def best(fn, repeats: int) -> float:
    """The fastest of ``repeats`` calls, s (the least disturbed by other load)."""
    out = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        out.append(time.perf_counter() - t0)
    return min(out)


def nrmse(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.sqrt(np.mean((a - b) ** 2) / np.mean(b**2)))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=5)
    args = ap.parse_args()
    (u, y), (uv, yv) = records(1), records(2)
    t0 = time.perf_counter()
    start = n4sid(u, y, 8, 20)
    t_n4sid = time.perf_counter() - t0
    t0 = time.perf_counter()
    A, B, C, D, info = pem_refine(*start, u, y, 20, validation=(uv, yv))
    t_pem = time.perf_counter() - t0
    print(f"n4sid (order 8, 20 block rows), {N} samples: {t_n4sid:.2f} s; NRMSE train "
          f"{nrmse(lss_simulate(*start, u), y):.3f}, validation "
          f"{nrmse(lss_simulate(*start, uv), yv):.3f}")
    print(f"pem_refine (20 iterations): {t_pem:.2f} s ({info['stop_reason']}); NRMSE train "
          f"{nrmse(lss_simulate(A, B, C, D, u), y):.3f}, validation "
          f"{nrmse(lss_simulate(A, B, C, D, uv), yv):.3f}")
    ours = best(lambda: lss_simulate(A, B, C, D, u), args.repeats)
    sys = (A, B, C, D, 1.0 / FS)
    scipy_s = best(lambda: signal.dlsim(sys, u), max(1, args.repeats // 2))
    _, ref, _ = signal.dlsim(sys, u)
    diff = float(np.max(np.abs(lss_simulate(A, B, C, D, u) - ref[:, 0])))
    print(f"simulation of {N} samples: lss_simulate {ours * 1e3:.1f} ms, scipy.signal.dlsim "
          f"{scipy_s * 1e3:.1f} ms: {scipy_s / ours:.1f}x faster; largest difference "
          f"{diff:.2e} (output peak {np.abs(ref).max():.3g})")


if __name__ == "__main__":
    main()
