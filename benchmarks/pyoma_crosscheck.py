"""Cross-check of the damping uncertainty against pyOMA-2's SSI-cov with ``calc_unc=True``.

On the records of ``benchmarks/damping_estimators.py`` (base-excited SDOF, 10 Hz, zeta 1 %,
Gaussian white base, exact ZOH at 500 Hz; white sensor noise of ``--noise`` times each
channel's RMS) this compares, per record and over the seeds:

* sloshrom's output-only estimate ``lscf_output`` and its std (Au's law times the estimator's
  efficiency, :func:`sloshrom.beam.damping.uncertainty.random_damping`), and the bias-corrected
  ``lscf_h1`` with its bootstrap std;
* pyOMA-2's covariance-driven SSI on the tank and base channels, both as outputs (output-only;
  decimated to 50 Hz), its damping ``Xi`` and the first-order (perturbation) standard deviation
  ``Xi_std`` of the mode near 10 Hz.

Printed: per estimator the bias and scatter of zeta over the seeds, the mean stated std and the
coverage of the true damping by ``zeta +/- 1.96 std``.

pyOMA-2 (PyPI ``pyOMA-2`` 1.4.3) is not a dependency of sloshrom: ``make pyoma`` builds its own
environment (``.venv-pyoma``: ``benchmarks/pyoma-requirements.txt``, hashed pins, then our lock
and sloshrom itself) and runs this script with the defaults (20 seeds, about 30 s)::

    make pyoma
    .venv-pyoma/bin/python benchmarks/pyoma_crosscheck.py --seeds 50

Without pyoma2 the script says so and exits with status 0 (nothing to compare).
"""

from __future__ import annotations

import argparse
import importlib.util
import math
import sys
import time
from pathlib import Path

import numpy as np

from sloshrom.beam.damping.uncertainty import random_damping

FS, F1, ZETA = 500.0, 10.0, 0.01


def _bench():
    spec = importlib.util.spec_from_file_location(
        "damping_estimators", Path(__file__).resolve().parent / "damping_estimators.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def pyoma_ssi_cov(channels: np.ndarray, fs: float, f1: float, br: int, ordmax: int,
                  nb: int) -> tuple[float, float]:
    """Damping ratio and its std of the mode nearest ``f1`` by pyOMA-2's SSI-cov
    (``channels`` shape (n, n_channels), all treated as outputs)."""
    from pyoma2.algorithms import SSI
    from pyoma2.setup import SingleSetup

    setup = SingleSetup(channels, fs=fs)
    alg = SSI(name="SSIcov", method="cov", br=br, ordmax=ordmax, calc_unc=True, nb=nb)
    setup.add_algorithms(alg)
    setup.run_by_name("SSIcov")
    setup.mpe("SSIcov", sel_freq=[f1], order_in="find_min")
    res = alg.result
    return float(np.ravel(res.Xi)[0]), float(np.ravel(res.Xi_std)[0])


def _row(name: str, z: list[float], s: list[float]) -> str:
    z_a, s_a = np.asarray(z, float), np.asarray(s, float)
    ok = np.isfinite(z_a) & np.isfinite(s_a)
    if ok.sum() < 2:
        return f"| {name} | {ok.sum()} | – | – | – | – |"
    e = z_a[ok] / ZETA - 1
    cov = np.mean(np.abs(z_a[ok] - ZETA) <= 1.96 * s_a[ok])
    return (f"| {name} | {ok.sum()} | {100 * e.mean():+.1f} % | {100 * e.std(ddof=1):.1f} % "
            f"| {100 * np.mean(s_a[ok]) / ZETA:.1f} % | {100 * cov:.0f} % |")


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=20)
    ap.add_argument("--duration", type=float, default=90.0, help="s")
    ap.add_argument("--noise", type=float, default=0.05, help="sensor noise / channel RMS")
    ap.add_argument("--decimate", type=int, default=10,
                    help="SSI on the tank channel decimated by this factor (500 -> 50 Hz)")
    ap.add_argument("--br", type=int, default=30, help="SSI block rows")
    ap.add_argument("--ordmax", type=int, default=30, help="SSI largest model order")
    ap.add_argument("--nb", type=int, default=50, help="SSI blocks for the uncertainty")
    args = ap.parse_args()
    try:
        import pyoma2  # noqa: F401
    except ImportError:
        print("pyoma2 is not importable here: nothing to compare. Install pyOMA-2==1.4.3 in a "
              "separate environment (see this script's docstring).")
        return 0
    from scipy import signal

    bench = _bench()
    rows: dict[str, tuple[list[float], list[float]]] = {
        k: ([], []) for k in ("sloshrom lscf_output", "sloshrom lscf_h1", "pyOMA-2 SSI-cov")}
    t0 = time.perf_counter()
    for s in range(args.seeds):
        u, y = bench.noisy_sdof(args.duration, s, args.noise)
        d = random_damping(u, y, FS, F1)
        for k in ("lscf_output", "lscf_h1"):
            rows[f"sloshrom {k}"][0].append(d[k])
            rows[f"sloshrom {k}"][1].append(d[f"{k}_std"])
        # both channels as outputs (output-only SSI): with the tank channel alone pyOMA-2's
        # mode-shape criteria (MPC, MPD) reject every pole and its MPE finds nothing
        yd = signal.decimate(np.stack([y, u], axis=1), args.decimate, ftype="fir",
                             zero_phase=True, axis=0)
        try:
            z, sd = pyoma_ssi_cov(yd, FS / args.decimate, F1, args.br, args.ordmax, args.nb)
        except Exception as exc:  # pyOMA's own failure on one record: reported, not fatal
            print(f"seed {s}: pyOMA-2 failed: {exc}", file=sys.stderr)
            z, sd = math.nan, math.nan
        rows["pyOMA-2 SSI-cov"][0].append(z)
        rows["pyOMA-2 SSI-cov"][1].append(sd)
    print(f"SDOF 10 Hz, zeta 1 %, {args.duration:g} s, noise {100 * args.noise:g} % RMS, "
          f"{args.seeds} seeds; SSI-cov br {args.br}, ordmax {args.ordmax}, nb {args.nb}, "
          f"at {FS / args.decimate:g} Hz\n")
    print("| estimator | n | bias | scatter | mean stated std | coverage of +/-1.96 std |\n"
          "|---|---|---|---|---|---|")
    for k, (z, sd) in rows.items():
        print(_row(k, z, sd))
    print(f"\n({time.perf_counter() - t0:.0f} s)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
