"""Bias and scatter of the first-mode damping estimators over many seeds (docs/beam.md numbers).

Cases (true damping ratio 1 % in all):

* ``sdof``: base-excited single-mode oscillator, ``H(s) = (2 zeta w s + w^2) / (s^2 + 2 zeta w s
  + w^2)`` (base -> absolute acceleration), f = 10 Hz, Gaussian white base acceleration held
  over each sample and the exact zero-order-hold discretisation at 500 Hz (so the sampled
  system has exactly the continuous poles), start-up transient discarded; 90 s and 600 s.
* ``beam``: the coupled beam with frozen liquid (first mode 10.19 Hz, zeta_1 = 1 % exactly),
  the paper's random base excitation (Gaussian PSD, random phases, 1 s fades), 0.1 g, 90 s:
  the configuration of Table 2.
* ``decay``: free decay ``exp(-zeta w t) cos(w_d t)`` (10 Hz, 15 s) plus white measurement
  noise of 0.1 % and 1 % of the initial amplitude: Hilbert (median of the instantaneous
  damping) and log decrement (median).

Random-response estimators, as :func:`sloshrom.beam.damping.uncertainty.mode1_damping_random` (Welch
Hann, nperseg 16384, 50 % overlap; band f1 -/+ 50 %):

* ``lscf_h1``      LSCF on H1, median of the stable-pole cluster;
* ``lscf_output``  output-only LSCF on the window-corrected half-spectrum, cluster median;
* ``lscf_psd_old`` the earlier estimate: single-pole LSCF (sdypy ``select_closest_poles``) on the
  Welch PSD, the baseline;
* ``half_power``   half-power bandwidth of |H1|.

Printed per estimator: the relative error ``zeta_hat / zeta - 1`` over the seeds as mean (the
bias), median, standard deviation, min, max, the number of NaN (no stable cluster) and the mean
cluster size; for the output-only estimator also the Cramer-Rao-type bound
``std / zeta >= 1 / sqrt(zeta w_n T)`` of an output-only damping estimate from T seconds
(Gaussian white excitation; not applicable to the random-phase excitation of ``beam``, whose
amplitude spectrum is deterministic).

Coverage (``--coverage``): the intervals of :mod:`sloshrom.beam.damping.uncertainty` on records of
known damping with white sensor noise (``--noise``, standard deviation as a fraction of each
channel's RMS): ``random`` - the ``sdof`` records (``--duration``, ``--nperseg``) through
``random_damping``; ``decay`` - free decays ``8 exp(-zeta w t) cos(w_d t)`` ("g"; 10 Hz,
1.37 %, 12 s and 64 Hz, 0.62 %, 8 s, 500 Hz) plus white noise of ``--decay-noise`` g
(each level) through ``band_damping`` (bands 0.5-1, 1-2, 2-3, 3-5 g), its intervals from the
noise-added bootstrap of the record (``--closed-forms``: also those without the record). Printed
per estimator:
coverage of the true damping by the 95 % intervals, their mean width, the bias and scatter of
the estimate, the mean stated standard deviation (relative to zeta) and the mean width over
the scatter (3.9 for calibrated normal intervals).

Usage::

    .venv/bin/python benchmarks/damping_estimators.py              # 50 seeds, all cases (~1 min)
    .venv/bin/python benchmarks/damping_estimators.py --seeds 20 --cases sdof
    .venv/bin/python benchmarks/damping_estimators.py --coverage --seeds 100 --cases random,decay
    .venv/bin/python benchmarks/damping_estimators.py --coverage --seeds 100 --cases decay \
        --closed-forms                                             # decay: ~12 min
    .venv/bin/python benchmarks/damping_estimators.py --coverage --cases random --noise 0 \
        --duration 600 --nperseg 32768 --seeds 20
"""

from __future__ import annotations

import argparse
import math
import time

import numpy as np
from scipy import signal

from sloshrom.beam.damping.analysis import (
    instantaneous_damping,
    log_decrement,
    lscf_damping,
    welch_psd,
)
from sloshrom.beam.damping.uncertainty import band_damping, mode1_damping_random, random_damping

FS, F1, ZETA = 500.0, 10.0, 0.01
NPERSEG = 16384


def sdof_base_response(
    duration: float, seed: int, zeta: float = ZETA, f1: float = F1, fs: float = FS
) -> tuple[np.ndarray, np.ndarray]:
    """Base acceleration (white, unit variance) and absolute acceleration of a base-excited SDOF.

    Exact zero-order-hold discretisation; 20 time constants of start-up are simulated and
    discarded so that the record is stationary.
    """
    wn = 2 * np.pi * f1
    b, a, _ = signal.cont2discrete(([2 * zeta * wn, wn**2], [1, 2 * zeta * wn, wn**2]),
                                   1 / fs, method="zoh")
    n0 = int(20 / (zeta * wn) * fs)
    u = np.random.default_rng(seed).standard_normal(int(round(duration * fs)) + n0)
    y = signal.lfilter(np.ravel(b), a, u)
    return u[n0:], y[n0:]


def random_estimates(base: np.ndarray, tank: np.ndarray, fs: float, f1: float) -> dict:
    """The Table 2 estimators plus the old single-pole LSCF on the PSD."""
    d = mode1_damping_random(base, tank, fs, f1, nperseg=NPERSEG)
    fp, p = welch_psd(tank, fs, NPERSEG)
    d["lscf_psd_old"] = lscf_damping(fp, p, f1, (0.5 * f1, 1.5 * f1))["zeta"]
    return d


def decay_estimates(noise: float, seed: int) -> dict:
    t = np.arange(0, 15.0, 1 / FS)
    wd = 2 * np.pi * F1 * math.sqrt(1 - ZETA**2)
    x = np.exp(-ZETA * 2 * np.pi * F1 * t) * np.cos(wd * t)
    x = x + noise * np.random.default_rng(seed).standard_normal(t.size)
    return {"hilbert": float(np.median(instantaneous_damping(x, FS, F1)["zeta"])),
            "log_decrement": float(np.median(log_decrement(x, FS, F1)["zeta"]))}


def _stats(values: list[float], zeta: float) -> dict:
    e = np.asarray(values, dtype=float) / zeta - 1
    ok = e[np.isfinite(e)]
    if ok.size == 0:
        return {"mean": math.nan, "median": math.nan, "std": math.nan, "min": math.nan,
                "max": math.nan, "nan": int(e.size)}
    return {"mean": ok.mean(), "median": float(np.median(ok)), "std": ok.std(ddof=1),
            "min": ok.min(), "max": ok.max(), "nan": int(e.size - ok.size)}


def _print_rows(case: str, duration: float, rows: dict[str, list[float]], zeta: float,
                sizes: dict[str, list[float]] | None = None, digits: int = 2) -> None:
    for name, values in rows.items():
        s = _stats(values, zeta)
        n = (f"{np.mean(sizes[name]):.1f} ({np.min(sizes[name]):.0f})" if sizes and name in sizes
             else "–")
        p = {k: f"{100 * v:+.{digits}f} %" for k, v in s.items() if k != "nan"}
        print(f"| {case} | {duration:g} | {name} | {p['mean']} | {p['median']} "
              f"| {p['std'].lstrip('+')} | {p['min']} | {p['max']} | {s['nan']} | {n} |")


HEADER = ("| case | T (s) | estimator | bias (mean) | median | std | min | max | NaN "
          "| cluster size: mean (min) |\n|---|---|---|---|---|---|---|---|---|---|")
KEYS = ("lscf_h1", "lscf_output", "lscf_psd_old", "half_power")


def run_random(case: str, duration: float, seeds: list[int]) -> None:
    rows: dict[str, list[float]] = {k: [] for k in KEYS}
    sizes: dict[str, list[float]] = {"lscf_h1": [], "lscf_output": []}
    freqs: dict[str, list[float]] = {"frequency_h1": [], "frequency_output": []}

    def collect(d: dict) -> None:
        for k in KEYS:
            rows[k].append(d[k])
        for k in freqs:
            freqs[k].append(d[k])
        sizes["lscf_h1"].append(d["lscf_h1_n"])
        sizes["lscf_output"].append(d["lscf_output_n"])

    if case == "sdof":
        f1, zeta = F1, ZETA
        for s in seeds:
            u, y = sdof_base_response(duration, s)
            collect(random_estimates(u, y, FS, f1))
    else:
        from sloshrom.beam.simulation.coupled import random_response
        from sloshrom.beam.simulation.structure import ModalModel, coupled_frozen_modes
        from sloshrom.config import Tank
        from sloshrom.models import FrozenLiquid

        modal = ModalModel.from_beam()
        f1, zeta = float(coupled_frozen_modes(modal, Tank().liquid_mass)[0][0]), modal.damping[0]
        for chunk in range(0, len(seeds), 10):  # 10 records at a time: bounded memory
            out = random_response(FrozenLiquid(1 / FS), modal, rms_levels_g=(0.1,),
                                  duration=duration, seed=seeds[chunk:chunk + 10])
            for i in range(out["tank_acceleration"].shape[0]):
                collect(random_estimates(out["base_acceleration"][i, 0],
                                         out["tank_acceleration"][i, 0], FS, f1))
    _print_rows(case, duration, rows, zeta, sizes)
    _print_rows(case, duration, freqs, f1, digits=3)  # relative errors of the natural frequency
    if case == "sdof":
        crlb = 1 / math.sqrt(zeta * 2 * np.pi * f1 * duration)
        print(f"|  |  | (bound for output-only: std >= {100 * crlb:.1f} %) |  |  |  |  |  |  |  |")


def run_decay(noise: float, seeds: list[int]) -> None:
    rows: dict[str, list[float]] = {"hilbert": [], "log_decrement": []}
    for s in seeds:
        d = decay_estimates(noise, s)
        for k in rows:
            rows[k].append(d[k])
    _print_rows(f"decay, noise {100 * noise:g} %", 15.0, rows, ZETA)


def noisy_sdof(duration: float, seed: int, noise: float) -> tuple[np.ndarray, np.ndarray]:
    """:func:`sdof_base_response` plus white sensor noise of ``noise`` times each channel's RMS
    (its own seed)."""
    u, y = sdof_base_response(duration, seed)
    rng = np.random.default_rng(10_000 + seed)
    return (u + noise * u.std() * rng.standard_normal(u.size),
            y + noise * y.std() * rng.standard_normal(y.size))


#: The decay coverage cases: (frequency Hz, damping ratio, record length s).
DECAY_MODES = ((10.0, 0.0137, 12.0), (64.0, 0.0062, 8.0))


def noisy_decay(noise_g: float, seed: int, amplitude_g: float = 8.0, duration: float = 8.0,
                f: float = F1, zeta: float = ZETA) -> np.ndarray:
    """Free decay ``amplitude exp(-zeta w t) cos(w_d t)`` (g) plus white noise (g)."""
    t = np.arange(0, duration, 1 / FS)
    wd = 2 * np.pi * f * math.sqrt(1 - zeta**2)
    x = amplitude_g * np.exp(-zeta * 2 * np.pi * f * t) * np.cos(wd * t)
    return x + noise_g * np.random.default_rng(seed).standard_normal(t.size)


def coverage_random(duration: float, seeds: list[int], noise: float, nperseg: int = NPERSEG,
                    n_resamples: int | None = None) -> dict[str, dict[str, float]]:
    """Coverage, width, bias and scatter of ``random_damping``'s intervals (relative to zeta)."""
    kw = {} if n_resamples is None else {"n_resamples": n_resamples}
    rows = [random_damping(*noisy_sdof(duration, s, noise), FS, F1, nperseg=nperseg, **kw)
            for s in seeds]
    out = {k: _coverage([r[k] for r in rows], [r[f"{k}_std"] for r in rows],
                        [r[f"{k}_low"] for r in rows], [r[f"{k}_high"] for r in rows])
           for k in ("lscf_h1", "lscf_output", "half_power")}
    for k in ("lscf_h1_uncorrected", "half_power_uncorrected"):
        out[k] = _coverage([r[k] for r in rows])
    return out


def coverage_decay(noise_g: float, seeds: list[int], f: float = F1, zeta: float = ZETA,
                   duration: float = 8.0, bootstrap: bool = True
                   ) -> dict[str, dict[str, float]]:
    """Coverage, width, bias and scatter of ``band_damping``'s intervals, per band and method:
    with the record (noise-added bootstrap, the default) or without (the closed forms)."""
    acc: dict[str, list[dict]] = {}
    for s in seeds:
        x = noisy_decay(noise_g, s, f=f, zeta=zeta, duration=duration)
        kw = {"record": x, "fs": FS, "seed": 1_000 + s} if bootstrap else {}
        for r in band_damping(instantaneous_damping(x, FS, f), log_decrement(x, FS, f), f,
                              amplitude_scale=1.0, **kw):
            acc.setdefault(f"{r['method']} {r['band']}", []).append(r)
    return {k: _coverage([r["zeta"] for r in v], [r["std"] for r in v], [r["low"] for r in v],
                         [r["high"] for r in v], truth=zeta) for k, v in acc.items()}


def _coverage(zeta, std=None, low=None, high=None, truth: float = ZETA) -> dict[str, float]:
    z = np.asarray(zeta, dtype=float)
    ok = np.isfinite(z)
    e = z[ok] / truth - 1
    out = {"n": int(ok.sum()), "bias": float(e.mean()) if e.size else math.nan,
           "scatter": float(e.std(ddof=1)) if e.size > 1 else math.nan}
    if low is not None:
        lo, hi = np.asarray(low, float)[ok], np.asarray(high, float)[ok]
        out.update(coverage=float(np.mean((lo <= truth) & (truth <= hi))),
                   width=float(np.mean(hi - lo) / truth),
                   ratio=float(np.mean(hi - lo) / np.std(z[ok], ddof=1)) if e.size > 1
                   else math.nan,
                   stated_std=float(np.mean(np.asarray(std, float)[ok]) / truth))
    return out


def print_coverage(title: str, table: dict[str, dict[str, float]]) -> None:
    print(f"\n{title}\n\n| estimator | n | coverage of 95 % intervals | mean width | bias "
          "| scatter | mean stated std | width / scatter |\n|---|---|---|---|---|---|---|---|")
    for k, c in table.items():
        cov = f"{100 * c['coverage']:.0f} %" if "coverage" in c else "–"
        wid = f"{100 * c['width']:.1f} %" if "width" in c else "–"
        sd = f"{100 * c['stated_std']:.1f} %" if "stated_std" in c else "–"
        rat = f"{c['ratio']:.1f}" if "ratio" in c else "–"
        print(f"| {k} | {c['n']} | {cov} | {wid} | {100 * c['bias']:+.1f} % "
              f"| {100 * c['scatter']:.1f} % | {sd} | {rat} |")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=50, help="number of seeds per case")
    ap.add_argument("--cases", default="sdof,beam,decay", help="comma-separated subset")
    ap.add_argument("--first-seed", type=int, default=0, help="seeds first .. first + n - 1")
    ap.add_argument("--coverage", action="store_true",
                    help="coverage of the intervals instead (cases random, decay)")
    ap.add_argument("--noise", type=float, default=0.05,
                    help="coverage, random: sensor noise / channel RMS")
    ap.add_argument("--decay-noise", default="0.005,0.05",
                    help="coverage, decay: white sensor noise, g (comma-separated levels)")
    ap.add_argument("--closed-forms", action="store_true",
                    help="coverage, decay: also the intervals without the record")
    ap.add_argument("--duration", type=float, default=90.0, help="coverage, random: s")
    ap.add_argument("--nperseg", type=int, default=NPERSEG, help="coverage, random: Welch")
    args = ap.parse_args()
    seeds = list(range(args.first_seed, args.first_seed + args.seeds))
    cases = {c.strip() for c in args.cases.split(",")}
    if args.coverage:
        t0 = time.perf_counter()
        if "random" in cases:
            print_coverage(f"random_damping: SDOF 10 Hz, zeta 1 %, {args.duration:g} s, "
                           f"nperseg {args.nperseg}, sensor noise {100 * args.noise:g} % RMS, "
                           f"{args.seeds} seeds",
                           coverage_random(args.duration, seeds, args.noise, args.nperseg))
            print(f"({(time.perf_counter() - t0) / len(seeds):.2f} s per record)")
        if "decay" in cases:
            noises = [float(v) for v in args.decay_noise.split(",")]
            for f, zeta, duration in DECAY_MODES:
                for noise in noises:
                    for boot in ((True, False) if args.closed_forms else (True,)):
                        how = "bootstrap" if boot else "closed forms"
                        print_coverage(
                            f"band_damping ({how}): decay from 8 g, {f:g} Hz, zeta "
                            f"{100 * zeta:g} %, {duration:g} s, white noise {noise:g} g, "
                            f"{args.seeds} seeds",
                            coverage_decay(noise, seeds, f, zeta, duration, boot))
        print(f"\n({time.perf_counter() - t0:.0f} s)")
        return
    t0 = time.perf_counter()
    print(f"true zeta = 1 %, {args.seeds} seeds; relative errors zeta_hat / zeta - 1\n")
    print(HEADER)
    if "sdof" in cases:
        for duration in (90.0, 600.0):
            run_random("sdof", duration, seeds)
    if "beam" in cases:
        run_random("beam", 90.0, seeds)
    if "decay" in cases:
        for noise in (1e-3, 1e-2):
            run_decay(noise, seeds)
    print(f"\n({time.perf_counter() - t0:.0f} s)")


if __name__ == "__main__":
    main()
