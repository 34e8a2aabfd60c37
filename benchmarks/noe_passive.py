"""The NOE trained by multiple shooting with the passive recipe's loss terms, on a reproduce run.

Trains NOEs with ``trainer="adam"`` (:func:`sloshrom.rom.tdnn.training.adam_noe`) on the run's
training record (``velocity`` -> ``dynamic_force``) with early stopping on its validation record,
each within a time budget, and reports for each:

- the validation fit, % = 100 (1 - |e| / |y - mean y|), the NRMSE (RMS error / RMS of y) and
  the MSE (N^2) of the free run from rest;
- the training time (s), epochs run, best epoch and stop reason;
- the Phi_d map of the NOE on the grid of the run's rig map, against it
  (:func:`sloshrom.energy.map_fidelity`: full-map and dissipative-region relative L2 errors,
  non-passive points) and the map's seconds.

Cases (``--cases``, comma separated):

- ``small``: NOE(delays=2, neurons=10, out_delays=2), passive recipe (amplitude weighting
  0.05 m/s, passivity 1, cycle energy 0.1);
- ``large``: NOE(delays=10, neurons=35, out_delays=10), passive recipe;
- ``plain``: the small NOE with the three terms 0 (the plain simulation error);
- ``lm``: the small NOE trained by Levenberg-Marquardt on the whole record (the paper's).

Usage::

    python benchmarks/noe_passive.py --run results --out noe_passive.json
    python benchmarks/noe_passive.py --run DIR --cases small,plain --max-epochs 60 --budget 600

``DIR`` holds ``data/train.nc``, ``data/validation.nc`` and ``maps/phi_d_rig.nc`` (a finished
``sloshrom reproduce --out DIR``). The JSON is rewritten after every case; ``--save-models``
writes each model file next to it. Exit status 0 always: the figures are the result.
"""

from __future__ import annotations

import argparse
import json
import math
import time
import warnings
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

import sloshrom
from sloshrom.energy import map_fidelity, phi_d_map
from sloshrom.io import read_record
from sloshrom.rom import NOE
from sloshrom.rom.errors import EnvelopeWarning, UnstableModelError

PASSIVE = {"amplitude_weighting": 0.05, "passivity": 1.0, "cycle_energy": 0.1}
PLAIN = {"amplitude_weighting": 0.0, "passivity": 0.0, "cycle_energy": 0.0}
SMALL = {"delays": 2, "neurons": 10, "out_delays": 2}
LARGE = {"delays": 10, "neurons": 35, "out_delays": 10}
CASES: dict[str, dict[str, Any]] = {
    "small": {**SMALL, **PASSIVE, "trainer": "adam"},
    "large": {**LARGE, **PASSIVE, "trainer": "adam"},
    "plain": {**SMALL, **PLAIN, "trainer": "adam"},
    "lm": {**SMALL, "trainer": "lm"},
}


def error_figures(y: np.ndarray, y_hat: np.ndarray) -> dict[str, float]:
    """MSE (N^2), NRMSE (-) and fit (%) of a prediction ``y_hat`` of ``y`` (N)."""
    e = y_hat - y
    mse = float(np.mean(e**2))
    return {"mse": mse, "nrmse": float(math.sqrt(mse) / math.sqrt(np.mean(y**2))),
            "fit": float(100.0 * (1.0 - np.linalg.norm(e) / np.linalg.norm(y - y.mean())))}


def run_case(name: str, hyper: dict[str, Any], data: tuple, rig: xr.DataArray,
             max_epochs: int, budget: float, seed: int, save: Path | None,
             learning_rate: float | None = None) -> dict[str, Any]:
    """Train one case and measure it; the figures as a JSON-ready dict."""
    (u, y, fs), (uv, yv) = data
    if learning_rate is not None and hyper["trainer"] == "adam":
        hyper = {**hyper, "learning_rate": learning_rate}
    model = NOE(max_epochs=max_epochs, seed=seed, **hyper)
    print(f"[{name}] {hyper}", flush=True)

    def cap(epoch: int, info: dict[str, float]) -> bool:
        print(f"  epoch {epoch:3d}  train {info['train_mse']:.4g}  val {info['val_mse']:.4g}  "
              f"objective {info.get('val_objective', math.nan):.4g}  "
              f"{info['seconds']:.0f} s", flush=True)
        return info["seconds"] > budget  # the time budget: stop, keep the best so far

    t0 = time.perf_counter()
    model.fit(u, y, fs, validation=(uv, yv), callback=cap)
    seconds = time.perf_counter() - t0
    h = model.history_
    out: dict[str, Any] = {"hyperparameters": model.get_params(), "n_params": model.n_params,
                           "train_seconds": seconds, "epochs": len(h["val_mse"]) - 1,
                           "best_epoch": h["best_epoch"], "stop_reason": h["stop_reason"]}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", EnvelopeWarning)
        try:
            out["validation"] = error_figures(yv, model.predict(uv))
        except UnstableModelError as exc:
            out["validation"] = {"error": str(exc)}
        t1 = time.perf_counter()
        try:
            m = phi_d_map(model, rig.omega_bar.values, rig.a_bar.values,
                          tank=sloshrom.config.Tank())
            out["map"] = map_fidelity(rig, m)
            out["map"]["min_phi_d"] = float(np.nanmin(m.values))
        except UnstableModelError as exc:
            out["map"] = {"error": str(exc)}
        out["map_seconds"] = time.perf_counter() - t1
    if save is not None:
        out["model_file"] = str(model.save(save / f"noe_{name}.npz"))
    print(f"[{name}] {json.dumps(out, default=float)}", flush=True)
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--run", type=Path, required=True, help="a finished reproduce run directory")
    ap.add_argument("--cases", default="small,large,plain",
                    help=f"comma-separated cases among {', '.join(CASES)}")
    ap.add_argument("--max-epochs", type=int, default=100, help="epochs at most per case")
    ap.add_argument("--budget", type=float, default=600.0,
                    help="training seconds per case (checked after every epoch)")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--learning-rate", type=float, default=None,
                    help="initial Adam step of the adam cases (default: the NOE's, 3e-3)")
    ap.add_argument("--out", type=Path, default=Path("noe_passive.json"))
    ap.add_argument("--save-models", action="store_true", help="write each model file")
    args = ap.parse_args()
    tr = read_record(args.run / "data" / "train.nc")
    va = read_record(args.run / "data" / "validation.nc")
    rig = xr.open_dataarray(args.run / "maps" / "phi_d_rig.nc").load()
    data = ((tr["velocity"], tr["dynamic_force"], tr.fs), (va["velocity"], va["dynamic_force"]))
    results: dict[str, Any] = {"run": str(args.run), "max_epochs": args.max_epochs,
                               "budget": args.budget, "cases": {}}
    for name in args.cases.split(","):
        results["cases"][name] = run_case(name, CASES[name], data, rig, args.max_epochs,
                                          args.budget, args.seed,
                                          args.out.parent if args.save_models else None,
                                          args.learning_rate)
        args.out.write_text(json.dumps(results, indent=1, default=float))
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
