"""How well can a causal model fit the rig's force point by point? The rig's own physics, driven
by the validation record's 500 Hz velocity, scored against the record (docs/rom.md, "The force
the structure feels").

The record's force passed the sensors' zero-phase anti-alias filters: an impact recorded at
``t_k`` is spread on both sides of its instant. A model that may not read the future (every ROM
coupled to a structure) cannot put force before an impact unless it predicts it. This script
runs the virtual rig itself at 10 kHz on the record's velocity (resampled) and scores its force
rendered four ways:

- zero-phase: the same filter as the sensors (the ceiling of any model: the rig's twin level);
- centred average: the mean force over ``[t_k - dt/2, t_k + dt/2]`` (half a sample of look-ahead);
- causal average: the mean over ``[t_{k-1}, t_k]`` (what a model without look-ahead outputs);
- with the input held over each 2 ms sample (zero-order hold, as a ROM sees it), zero-phase;

and, with the input held, the rig with stiffer contacts (its impacts shorter), to show what the
contact model costs.

Usage::

    python benchmarks/force_ceiling.py --run results     # after `make reproduce`

Prints one line per rendering: the fit (%) and the force RMS over the record's.
"""

from __future__ import annotations

import argparse
import dataclasses
import time
from pathlib import Path

import numpy as np
from scipy import signal as sps

from sloshrom.config import Tank
from sloshrom.io import read_record
from sloshrom.rig import RigParams, VirtualRig

UP = 20  # 10 kHz from the record's 500 Hz


def fit(ref: np.ndarray, model: np.ndarray) -> float:
    """The point-wise fit, %."""
    return 100.0 * (1.0 - np.linalg.norm(ref - model) / np.linalg.norm(ref - ref.mean()))


def main(argv: list[str] | None = None) -> int:
    """Run the renderings and print their figures."""
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--run", type=Path, default=Path("results"),
                    help="a `sloshrom reproduce` output folder (its data/validation.nc)")
    ap.add_argument("--seconds", type=float, default=120.0,
                    help="the record's first seconds scored (all: 0)")
    args = ap.parse_args(argv)
    rec = read_record(args.run / "data" / "validation.nc")
    fs = float(rec.fs)
    n = rec["velocity"].size if args.seconds <= 0 else min(rec["velocity"].size,
                                                             int(args.seconds * fs))
    v = np.asarray(rec["velocity"][:n], dtype=float)
    acc = np.asarray(rec["acceleration"][:n], dtype=float)
    y = np.asarray(rec["dynamic_force"][:n], dtype=float)
    tank = Tank(fill=float(rec.attrs.get("fill", 0.5)))
    fine = fs * UP
    sos = sps.butter(8, 200.0, fs=fine, output="sos")
    t0 = time.perf_counter()
    rig = VirtualRig(tank)
    df = rig.simulate(sps.resample_poly(v, UP, 1), sps.resample_poly(acc, UP, 1))
    rows = [("zero-phase (the sensors' filter)", sps.sosfiltfilt(sos, df)[::UP])]
    centred = np.array([df[max(0, k * UP - UP // 2): k * UP + UP // 2].mean() for k in range(n)])
    rows.append(("centred average, half a sample ahead", centred))
    causal = np.concatenate([[0.0], df[: (n - 1) * UP].reshape(-1, UP).mean(axis=1)])
    rows.append(("causal average of the last sample", causal))
    # the input held over each sample, as a ROM's step sees it
    t = np.arange(n) / fs
    t_fine = np.arange((n - 1) * UP + 1) / fine
    v_lin = np.interp(t_fine, t, v)
    a_zoh = np.concatenate([np.repeat(np.diff(v) * fs, UP), [0.0]])
    df = rig.simulate(v_lin, a_zoh)
    rows.append(("input held over each sample, zero-phase", sps.sosfiltfilt(sos, df)[::UP]))
    for hz, sub in ((1000.0, 5),):
        stiff = VirtualRig(tank, params=dataclasses.replace(RigParams.default(),
                                                            contact_frequency=hz),
                           dt=1.0 / (fine * sub))
        t2 = np.arange((n - 1) * UP * sub + 1) / (fine * sub)
        d2 = stiff.simulate(np.interp(t2, t, v),
                            np.concatenate([np.repeat(np.diff(v) * fs, UP * sub), [0.0]]))
        sos2 = sps.butter(8, 200.0, fs=fine * sub, output="sos")
        rows.append((f"input held, contacts at {hz:g} Hz (rig: "
                     f"{RigParams.default().contact_frequency:g}), zero-phase",
                     sps.sosfiltfilt(sos2, d2)[:: UP * sub]))
    print(f"the rig's force from the validation record's velocity ({n / fs:g} s), "
          f"{time.perf_counter() - t0:.0f} s:")
    for name, model in rows:
        print(f"  {name:62s} fit {fit(y, model):5.1f} %, RMS {model.std() / y.std():.2f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
