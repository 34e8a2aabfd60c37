"""Coverage of the random-test damping intervals on a laboratory beam, every mode, two bands.

The truth: :class:`sloshrom.beam.lab.synthetic.LabBeam` (a uniform cantilever without tank, modes
10.3 / 64.1 / 180 Hz at 1.37 / 0.62 / 0.48 % damping), random base tests
(:func:`~sloshrom.beam.lab.synthetic.random_test`: coloured, -3 dB/octave, 4th-order Butterworth
band, 0.5 % sensor noise on every channel) at 0.1 / 0.2 / 0.4 g RMS, ``--duration`` s at
500 Hz, the tip accelerometer as the response. Two shaker bands: the wide default 3-220 Hz
(every mode excited) and 3-40 Hz (a laboratory's shaker: mode 2 on the roll-off, mode 3 not
excited). The beam is linear and the noise proportional to each channel's RMS, so the levels
differ only by their seeds (level i: seeds ``1000 i + first_seed ...``): they are replicates,
pooled in the rows ``all``. Each mode k is analysed by
:func:`sloshrom.beam.damping.uncertainty.estimate_random` with ``f1 = f_k`` and the band between its
neighbours (:func:`mode_band`), Welch segments of 16384 samples, seed = the record's seed.

Printed per band, mode, level and estimator: the number of records with a value (``n``), of
NaN (each with its reason, the most common one shown), the coverage of the true damping by the
95 % intervals with its binomial standard error ``sqrt(p (1 - p) / n)`` (``p`` at least
0.95 in it: a cell covering every record still has that uncertainty), the bias and scatter of
the values and the mean stated standard deviation (relative to the true damping), and
``scatter / mean std`` (1 for an honest stated std).

Usage::

    .venv/bin/python benchmarks/lab_coverage.py --seeds 30 --jobs 2 --out lab.jsonl
    .venv/bin/python benchmarks/lab_coverage.py --table lab.jsonl      # re-tabulate only
"""

from __future__ import annotations

import argparse
import json
import math
import time
import warnings
from collections import Counter
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path
from typing import Any

import numpy as np

from sloshrom.beam.damping.uncertainty import estimate_random
from sloshrom.beam.lab.synthetic import DEFAULT_BAND, LabBeam, random_test

FS = 500.0
LEVELS = (0.1, 0.2, 0.4)
BANDS = {"3-220 Hz": DEFAULT_BAND, "3-40 Hz": (3.0, 40.0)}


def mode_band(beam: LabBeam, k: int, fs: float = FS) -> tuple[float, float]:
    """Fitting band of mode ``k`` (0-based), Hz: ``f_k (1 -/+ 0.5)`` cut at the geometric
    means with the neighbouring modes and at the Nyquist frequency."""
    f = beam.frequencies
    lo = max(0.5 * f[k], math.sqrt(f[k - 1] * f[k]) if k > 0 else 0.0)
    hi = min(1.5 * f[k], math.sqrt(f[k] * f[k + 1]) if k + 1 < len(f) else fs / 2, fs / 2)
    return (lo, hi)


def one_record(args: tuple[str, float, int, float],
               modes: tuple[int, ...] = (1, 2, 3)) -> list[dict[str, Any]]:
    """The estimates of ``modes`` (1-based) in one record: rows of (band, level, seed, mode,
    estimator)."""
    band_name, level, seed, duration = args
    beam = LabBeam()
    r = random_test(beam, level, duration, FS, band=BANDS[band_name], seed=seed)
    rows = []
    for k, (fk, zk) in enumerate(zip(beam.frequencies, beam.damping, strict=True)):
        if k + 1 not in modes:
            continue
        t0 = time.perf_counter()
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            e = estimate_random(r["base"], r["stations"][:, -1], FS, fk, seed=seed,
                                band=mode_band(beam, k))
        dt = time.perf_counter() - t0
        for name, x in e.estimates.items():
            rows.append({"band": band_name, "level": level, "seed": seed, "mode": k + 1,
                         "truth": zk, "estimator": name, "value": x.value, "std": x.std,
                         "low": x.low, "high": x.high, "uncorrected": x.uncorrected,
                         "frequency": x.frequency, "duration": duration,
                         "reason": x.reason, "seconds": dt})
    return rows


def _row(band: str, mode: int, level: str, est: str, sel: list[dict[str, Any]]) -> str:
    ok = [r for r in sel if np.isfinite(r["value"]) and np.isfinite(r["low"])]
    why = Counter(r["reason"].split(":")[0] for r in sel if r not in ok)
    nan_s = f"{len(sel) - len(ok)}" + (f" ({why.most_common(1)[0][0][:40]})" if why else "")
    head = f"| {band} | {mode} | {level} | {est} | {len(ok)} | {nan_s} |"
    if len(ok) < 2:
        return head + " – | – | – | – | – |"
    truth = sel[0]["truth"]
    v = np.array([r["value"] for r in ok]) / truth
    s = np.array([r["std"] for r in ok]) / truth
    cov = float(np.mean([r["low"] <= truth <= r["high"] for r in ok]))
    se = math.sqrt(max(cov * (1 - cov), 0.05 * 0.95) / len(ok))  # at p = 1, that of p = 0.95
    sc = float(np.std(v, ddof=1))
    return (head + f" {100 * cov:.0f} ± {100 * se:.0f} % | {100 * (v.mean() - 1):+.1f} % | "
            f"{100 * sc:.1f} % | {100 * s.mean():.1f} % | {sc / s.mean():.2f} |")


def table(rows: list[dict[str, Any]]) -> str:
    """The markdown coverage table of ``rows``: per band, mode, level and estimator, then the
    levels pooled (``all``)."""
    out = ["| band | mode | level (g) | estimator | n | NaN | coverage ± 1 s.e. | bias | "
           "scatter | mean std | scatter / std |", "|" + "---|" * 11]
    groups = sorted({(r["band"], r["mode"], r["estimator"]) for r in rows},
                    key=lambda k: (list(BANDS).index(k[0]), k[1], k[2]))
    for band, mode, est in groups:
        sel = [r for r in rows if (r["band"], r["mode"], r["estimator"]) == (band, mode, est)]
        levels = sorted({r["level"] for r in sel})
        for lv in levels:
            out.append(_row(band, mode, f"{lv:g}", est, [r for r in sel if r["level"] == lv]))
        if len(levels) > 1:
            out.append(_row(band, mode, "all", est, sel))
    return "\n".join(out)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=30, help="records per band and level")
    ap.add_argument("--first-seed", type=int, default=0)
    ap.add_argument("--duration", type=float, default=120.0, help="record length, s")
    ap.add_argument("--bands", default=",".join(BANDS), help="comma separated: " +
                    ", ".join(BANDS))
    ap.add_argument("--levels", default=",".join(f"{x:g}" for x in LEVELS))
    ap.add_argument("--jobs", type=int, default=1, help="worker processes")
    ap.add_argument("--out", type=Path, help="append the rows to this JSON-lines file (the "
                    "records it holds are not run again)")
    ap.add_argument("--table", type=Path, help="only tabulate this JSON-lines file")
    a = ap.parse_args()
    if a.table is not None:
        rows = [json.loads(x) for x in a.table.read_text().splitlines() if x.strip()]
        print(table(rows))
        return
    # the beam is linear and the noise proportional to each channel's RMS: a level with the
    # seed of another is that record scaled. Each level gets seeds of its own (1000 apart)
    # seeds outermost: a run stopped early has about as many records in every cell
    tasks = [(b, float(lv), 1000 * i + s, a.duration)
             for s in range(a.first_seed, a.first_seed + a.seeds)
             for b in a.bands.split(",") for i, lv in enumerate(a.levels.split(","))]
    if a.out is not None and a.out.exists():  # resume: the records already in the file
        done = {(r["band"], r["level"], r["seed"]) for r in
                (json.loads(x) for x in a.out.read_text().splitlines() if x.strip())}
        tasks = [t for t in tasks if t[:3] not in done]
    rows: list[dict[str, Any]] = []
    t0 = time.perf_counter()
    with ProcessPoolExecutor(a.jobs) as pool:
        for rr in pool.map(one_record, tasks):
            rows += rr
            if a.out is not None:
                with a.out.open("a") as fh:
                    fh.writelines(json.dumps(r) + "\n" for r in rr)
    print(f"{len(tasks)} records of {a.duration:g} s, {time.perf_counter() - t0:.0f} s\n")
    print(table(rows))


if __name__ == "__main__":
    main()
