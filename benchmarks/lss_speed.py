"""Speed of the linear state-space baseline (LSS) against SciPy's own tools, in one run.

On a record the size of a sloshing test (480 s at 500 Hz, 240 000 samples) of a two-mode
system with a cubic distortion, it times:

- the simulation from rest, ``sloshrom.rom.lss.core.lss_simulate`` (real Schur form, one
  ``lfilter`` per eigenvalue or pair) against ``scipy.signal.dlsim`` (the same model, SciPy's
  state-space simulator), and prints the ratio and their largest difference;
- the identification: ``n4sid`` (order 8, 20 block rows) and ``pem_refine`` (20 iterations),
  with the fit each reaches (NRMSE on the training and the validation record);
- the refinement's trust-region iterations: ``pem_refine`` hands ``least_squares`` the R factor
  of ``[J r]`` (``n_p + 1`` rows), against the same ``least_squares`` call on the ``N``
  residuals and the ``N x n_p`` Jacobian (the baseline: SciPy's SVD of the tall Jacobian at
  every iteration); both from the same start, without validation, with their training MSE.

Usage::

    python benchmarks/lss_speed.py [--repeats 5]
"""

from __future__ import annotations

import argparse
import time

import numpy as np
from scipy import signal
from threadpoolctl import threadpool_limits

from sloshrom.rom.lss.core import MAX_SPECTRAL_RADIUS, _to_modal, lss_simulate, n4sid, pem_refine

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


def uncompressed(start: tuple, u: np.ndarray, y: np.ndarray, max_iter: int) -> float:
    """The baseline refinement: ``least_squares`` as ``pem_refine`` calls it, on the ``N``
    residuals and the ``N x n_p`` Jacobian; returns its final training MSE (N^2)."""
    from scipy.optimize import least_squares

    su, sy = np.sqrt(np.mean(u**2)), np.sqrt(np.mean(y**2))
    model, p0 = _to_modal(*start, sy / su, MAX_SPECTRAL_RADIUS)
    us, ys, root_n = u / su, y / sy, np.sqrt(u.size)

    def jac(p: np.ndarray) -> np.ndarray:
        return model.jacobian(p, us, *model.filters(p, us, us.astype(complex))) / root_n

    with threadpool_limits(limits=1, user_api="blas"):  # as pem_refine
        res = least_squares(lambda p: (model.simulate(p, us) - ys) / root_n, p0, jac=jac,
                            bounds=model.bounds(), method="trf", x_scale="jac",
                            tr_solver="exact", max_nfev=max_iter + 1)
    return float(2 * res.cost * sy**2)


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
    runs: dict[str, tuple[float, float]] = {}
    for name in ("ours", "baseline", "ours", "baseline"):  # interleaved: the best of two
        t0 = time.perf_counter()
        mse = (pem_refine(*start, u, y, 20)[4]["final_mse"] if name == "ours"
               else uncompressed(start, u, y, 20))
        t = time.perf_counter() - t0
        runs[name] = (min(t, runs.get(name, (t, 0.0))[0]), mse)
    (t_ours, m_ours), (t_base, m_base) = runs["ours"], runs["baseline"]
    print(f"refinement, 20 iterations, no validation: pem_refine (the R factor of [J r]) "
          f"{t_ours:.2f} s, least_squares on the {N} rows {t_base:.2f} s: "
          f"{t_base / t_ours:.1f}x faster; training MSE {m_ours:.6g} and {m_base:.6g} "
          f"(relative difference {abs(m_ours / m_base - 1):.1e})")
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
