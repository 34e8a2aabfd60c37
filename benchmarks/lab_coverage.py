"""Coverage of the damping intervals on laboratory beams of known modes: every estimator, mode
and level, random tests and free decays.

The truth: :class:`sloshrom.beam.lab.synthetic.LabBeam` campaigns (``CAMPAIGNS``), each a
cantilever without tank of known modes and damping, tested as a laboratory would:

* ``3-220 Hz`` - the default three-mode beam (10.3 / 64.1 / 180 Hz, 1.37 / 0.62 / 0.48 %),
  base coloured -3 dB/octave, 4th-order Butterworth band 3-220 Hz, 0.5 % sensor noise on every
  channel (proportional: the levels are replicates);
* ``3-40 Hz`` - the same beam on a laboratory's shaker band 3-40 Hz (mode 2 on the roll-off,
  mode 3 not excited);
* ``four`` - four modes (8.1 / 50.8 / 143.1 / 205.6 Hz), a strongly coloured base
  (-6 dB/octave over 3-240 Hz) and a sensor floor of 0.5 mg RMS on every channel besides 0.2 %
  proportional noise: the signal-to-noise ratio grows with the level, as in a laboratory;
* ``close`` - closely spaced modes (10.3 / 11.9 / 64.1 Hz), -3 dB/octave, the same sensor
  floor.

Random tests (default): ``--duration`` s at 500 Hz, the tip accelerometer as the response,
levels 0.1 / 0.2 / 0.4 g RMS (level i: seeds ``1000 i + first_seed ...``). Each mode k is
analysed by :func:`sloshrom.beam.damping.uncertainty.estimate_random` with ``f1 = f_k``, the
band between its neighbours (:func:`sloshrom.beam.damping.peaks.mode_bands`) and the other
modes as its neighbours (as ``sloshrom analyse`` passes the modes it found), Welch segments of
16384 samples, the base given (output-only LSCF divides by its spectrum), seed = the record's
seed.

Free decays (``--decay``): :func:`~sloshrom.beam.lab.synthetic.free_decay` from ``--peak-g``
at the tip, ``--decay-duration`` s, 2 mg sensor noise, analysed as ``sloshrom analyse free``
analyses a measured decay (:func:`sloshrom.beam.lab.every_mode.free_mode_rows`: every mode,
its own amplitude bands, Hilbert and log decrement with their bootstrap intervals). The
"level" column is then the amplitude band.

Printed per campaign, mode, level and estimator: the number of records with a value (``n``),
of NaN (each with its reason, the most common one shown), the coverage of the true damping by
the 95 % intervals with its binomial standard error ``sqrt(p (1 - p) / n)`` (``p`` at least
0.95 in it: a cell covering every record still has that uncertainty), the bias and scatter of
the values and the mean stated standard deviation (relative to the true damping), and
``scatter / mean std`` (1 for an honest stated std).

Usage::

    .venv/bin/python benchmarks/lab_coverage.py --seeds 30 --jobs 2 --out lab.jsonl
    .venv/bin/python benchmarks/lab_coverage.py --campaigns four,close --seeds 20 --jobs 2 \
        --out lab.jsonl
    .venv/bin/python benchmarks/lab_coverage.py --decay --seeds 30 --jobs 2 --out decay.jsonl
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

from sloshrom.beam.damping.peaks import given_modes, mode_bands
from sloshrom.beam.damping.uncertainty import estimate_random
from sloshrom.beam.lab.every_mode import TestModes, free_mode_decays, free_mode_rows
from sloshrom.beam.lab.synthetic import DEFAULT_BAND, LabBeam, free_decay, random_test

FS = 500.0
LEVELS = (0.1, 0.2, 0.4)
#: The campaigns: the beam and its random tests' options (random_test's keywords).
CAMPAIGNS: dict[str, dict[str, Any]] = {
    "3-220 Hz": {"beam": LabBeam(), "band": DEFAULT_BAND},
    "3-40 Hz": {"beam": LabBeam(), "band": (3.0, 40.0)},
    "four": {"beam": LabBeam(frequencies=(8.1, 50.8, 143.1, 205.6),
                             damping=(0.011, 0.0072, 0.0051, 0.0043)),
             "band": (3.0, 240.0), "tilt": -6.0, "noise": 0.002, "noise_g": 0.0005},
    "close": {"beam": LabBeam(frequencies=(10.3, 11.9, 64.1), damping=(0.0137, 0.011, 0.0062)),
              "band": DEFAULT_BAND, "noise": 0.002, "noise_g": 0.0005},
}
#: The default selection (the first two: the table of docs/beam.md before the others).
DEFAULT_CAMPAIGNS = ("3-220 Hz", "3-40 Hz", "four", "close")


def mode_band(beam: LabBeam, k: int, fs: float = FS) -> tuple[float, float]:
    """Fitting band of mode ``k`` (0-based), Hz: the analyses' own
    (:func:`sloshrom.beam.damping.peaks.mode_bands`)."""
    return mode_bands(beam.frequencies, fs)[k]


def one_record(args: tuple[str, float, int, float],
               modes: tuple[int, ...] | None = None) -> list[dict[str, Any]]:
    """The estimates of every mode (or of ``modes``, numbered from 1) in one record: rows of
    (campaign, level, seed, mode, estimator)."""
    name, level, seed, duration = args
    spec = dict(CAMPAIGNS[name])
    beam = spec.pop("beam")
    r = random_test(beam, level, duration, FS, seed=seed, **spec)
    rows = []
    for k, (fk, zk) in enumerate(zip(beam.frequencies, beam.damping, strict=True)):
        if modes is not None and k + 1 not in modes:
            continue
        t0 = time.perf_counter()
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            e = estimate_random(r["base"], r["stations"][:, -1], FS, fk, seed=seed,
                                band=mode_band(beam, k), neighbours=beam.frequencies)
        dt = time.perf_counter() - t0
        for est, x in e.estimates.items():
            rows.append({"band": name, "level": level, "seed": seed, "mode": k + 1,
                         "truth": zk, "estimator": est, "value": x.value, "std": x.std,
                         "low": x.low, "high": x.high, "uncorrected": x.uncorrected,
                         "frequency": x.frequency, "duration": duration,
                         "reason": x.reason, "seconds": dt})
    return rows


def one_decay(args: tuple[str, float, int, float]) -> list[dict[str, Any]]:
    """The band rows of every mode of one free decay from ``peak_g`` at the tip (the
    ``level`` of a row is its amplitude band)."""
    name, peak_g, seed, duration = args
    beam = CAMPAIGNS[name]["beam"]
    d = free_decay(beam, peak_g, duration, FS, noise_g=0.002, seed=seed)
    n = d["time"].size
    res: Any = {"fs": FS, "time": d["time"], "station_acceleration": d["stations"],
                "tank_acceleration": d["stations"][:, -1], "base_acceleration": np.zeros(n)}
    modes = TestModes(given_modes(beam.frequencies), mode_bands(beam.frequencies, FS), "given")
    t0 = time.perf_counter()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        out = free_mode_rows(res, name, modes, free_mode_decays(res, modes), seed=seed)
    dt = time.perf_counter() - t0
    return [{"band": name, "level": r["band"], "seed": seed, "mode": r["mode"],
             "truth": beam.damping[r["mode"] - 1], "estimator": r["method"],
             "value": r["zeta"], "std": r["std"], "low": r["low"], "high": r["high"],
             "n_cycles": r["n_cycles"], "duration": duration, "reason": r["reason"],
             "seconds": dt} for r in out]


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


def _level_key(lv: float | str) -> float:
    # a random test's level (g), or a decay's amplitude band ("0.5-1 g") by its lower edge
    return float(lv) if not isinstance(lv, str) else float(lv.split("-")[0])


def _level_text(lv: float | str) -> str:
    return lv if isinstance(lv, str) else f"{lv:g}"


def table(rows: list[dict[str, Any]]) -> str:
    """The markdown coverage table of ``rows``: per band, mode, level and estimator, then the
    levels pooled (``all``)."""
    out = ["| campaign | mode | level (g) | estimator | n | NaN | coverage ± 1 s.e. | bias | "
           "scatter | mean std | scatter / std |", "|" + "---|" * 11]
    order = list(CAMPAIGNS)
    groups = sorted({(r["band"], r["mode"], r["estimator"]) for r in rows},
                    key=lambda k: (order.index(k[0]) if k[0] in order else len(order), k[1],
                                   k[2]))
    for band, mode, est in groups:
        sel = [r for r in rows if (r["band"], r["mode"], r["estimator"]) == (band, mode, est)]
        levels = sorted({r["level"] for r in sel}, key=_level_key)
        for lv in levels:
            out.append(_row(band, mode, _level_text(lv), est,
                            [r for r in sel if r["level"] == lv]))
        if len(levels) > 1:
            out.append(_row(band, mode, "all", est, sel))
    return "\n".join(out)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=30, help="records per band and level")
    ap.add_argument("--first-seed", type=int, default=0)
    ap.add_argument("--duration", type=float, default=120.0, help="record length, s")
    ap.add_argument("--campaigns", default=",".join(DEFAULT_CAMPAIGNS),
                    help="comma separated: " + ", ".join(CAMPAIGNS))
    ap.add_argument("--levels", default=",".join(f"{x:g}" for x in LEVELS))
    ap.add_argument("--decay", action="store_true", help="free decays instead of random tests")
    ap.add_argument("--peak-g", type=float, default=8.5, help="decays: tip peak, g")
    ap.add_argument("--decay-duration", type=float, default=20.0, help="decays: length, s")
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
    names = a.campaigns.split(",")
    unknown = [c for c in names if c not in CAMPAIGNS]
    if unknown:
        ap.error(f"unknown campaign(s) {unknown}; known: {', '.join(CAMPAIGNS)}")
    if a.decay:
        tasks = [(b, a.peak_g, s, a.decay_duration)
                 for s in range(a.first_seed, a.first_seed + a.seeds) for b in names]
    else:
        tasks = [(b, float(lv), 1000 * i + s, a.duration)
                 for s in range(a.first_seed, a.first_seed + a.seeds)
                 for b in names for i, lv in enumerate(a.levels.split(","))]
    work = one_decay if a.decay else one_record
    if a.out is not None and a.out.exists():  # resume: the records already in the file
        done = {(r["band"], r["seed"]) for r in
                (json.loads(x) for x in a.out.read_text().splitlines() if x.strip())}
        tasks = [t for t in tasks if (t[0], t[2]) not in done]
    rows: list[dict[str, Any]] = []
    t0 = time.perf_counter()
    with ProcessPoolExecutor(a.jobs) as pool:
        for rr in pool.map(work, tasks):
            rows += rr
            if a.out is not None:
                with a.out.open("a") as fh:
                    fh.writelines(json.dumps(r) + "\n" for r in rr)
    length = a.decay_duration if a.decay else a.duration
    print(f"{len(tasks)} records of {length:g} s, {time.perf_counter() - t0:.0f} s\n")
    print(table(rows))


if __name__ == "__main__":
    main()
