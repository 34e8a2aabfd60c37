"""A peer in the same run: deepSI's SUBNET beside our ROM, on the records of one reproduce run.

Trains ``deepSI.SUBNET`` (a neural state-space model with an encoder that estimates the initial
state from past inputs and outputs) on the velocity -> dynamic force of ``DIR/data/train.nc``,
with ``DIR/data/validation.nc`` for its early stopping, within a wall-clock budget, and scores
it as the pipeline scores our ROM:

- validation fit: the whole validation record simulated (the encoder reads its first
  ``max(na, nb)`` samples of input and output, SUBNET's own convention), NRMSE =
  ||y_hat - y|| / ||y - mean(y)|| over the samples after that window, fit = 100 (1 - NRMSE) %;
- the Phi_d map on the grid and shaker envelope of ``DIR/maps/phi_d_rig.nc`` through
  :func:`sloshrom.energy.phi_d_map`, the SUBNET started from the encoder's state for a window
  of rest (zero input and output: the harmonic tests start from rest), and
  :func:`sloshrom.energy.map_fidelity` against the rig's map;
- the training wall time, s (torch limited to ``--threads`` threads, default 2).

It prints one table, SUBNET beside our ROM row(s) from ``DIR/summary.json``, and with
``--out`` writes the figures as JSON.

Usage::

    make peers        # .venv-peers (torch, deepSI, sloshrom), then --run results
    .venv-peers/bin/python benchmarks/peer_subnet.py --run DIR [--minutes 10] [--out f.json]

torch and deepSI are imported only when a SUBNET is trained: the scoring and table helpers
import without them (``tests/test_peer_subnet.py`` checks them in the main ``.venv``).
"""

from __future__ import annotations

import argparse
import json
import math
import os
import re
import sys
import time
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

#: Columns of the table: (key of a row, heading, format of a number).
COLUMNS: tuple[tuple[str, str, str], ...] = (
    ("val_fit", "val fit %", "{:.1f}"),
    ("val_nrmse", "val NRMSE", "{:.3f}"),
    ("full_l2", "map whole %", "{:.1f}"),
    ("dissipative_l2", "map dissip. %", "{:.1f}"),
    ("n_nonpassive", "non-passive", "{}"),
    ("train_seconds", "train s", "{:.0f}"),
)
#: Fraction of the training budget spent on validation simulations (early stopping).
VALIDATION_SHARE = 0.1


# -- pure helpers (no torch) -----------------------------------------------------------------
def nrmse_after_window(y: Any, y_hat: Any, window: int) -> float:
    """``||y_hat - y|| / ||y - mean(y)||`` (-) over the samples from ``window`` on.

    Parameters
    ----------
    y, y_hat : array_like
        Measured and simulated output, same 1-D shape.
    window : int
        Samples left out at the start (SUBNET's encoder window, ``max(na, nb)``).

    Returns
    -------
    float
        NaN when the scored part of ``y`` is constant.

    Raises
    ------
    ValueError
        Shapes differ, are not 1-D, or ``window`` leaves no sample.
    """
    y = np.asarray(y, dtype=np.float64)
    y_hat = np.asarray(y_hat, dtype=np.float64)
    if y.ndim != 1 or y.shape != y_hat.shape:
        raise ValueError(f"y and y_hat must be 1-D of one shape, got {y.shape}, {y_hat.shape}")
    if not 0 <= window < y.size:
        raise ValueError(f"window {window} leaves no sample of {y.size}")
    ys, es = y[window:], y_hat[window:] - y[window:]
    den = float(np.linalg.norm(ys - ys.mean()))
    return float(np.linalg.norm(es)) / den if den > 0 else float("nan")


def fit_percent(nrmse: float) -> float:
    """The MATLAB-style fit ``100 (1 - NRMSE)`` (%)."""
    return 100.0 * (1.0 - float(nrmse))


def _number(value: Any) -> float | None:
    try:
        f = float(value)
    except (TypeError, ValueError):
        return None
    return f if math.isfinite(f) else None


def our_rows(summary: Mapping[str, Any]) -> list[dict[str, Any]]:
    """Our ROM rows of a ``summary.json``: every stage named ``rom*`` that has a ``val_fit``.

    The map figures of stage ``KEY`` are ``stages.maps.KEY_fidelity`` (``rom`` ->
    ``rom_fidelity``); figures a run lacks are None.

    Parameters
    ----------
    summary : mapping
        The parsed ``summary.json``.

    Returns
    -------
    list of dict
        ``model`` (the stage's ``name``), ``source`` and the keys of :data:`COLUMNS` plus
        ``n_points``; map errors are fractions (-), as in the summary.
    """
    stages = summary.get("stages") or {}
    maps = stages.get("maps") or {}
    rows = []
    for key, stage in stages.items():
        if not (key.startswith("rom") and isinstance(stage, Mapping) and "val_fit" in stage):
            continue
        fid = maps.get(f"{key}_fidelity") or {}
        rows.append({
            "model": str(stage.get("name", key)),
            "source": f"summary.json stages.{key}",
            "val_fit": _number(stage.get("val_fit")),
            "val_nrmse": _number(stage.get("val_nrmse")),
            "train_seconds": _number(stage.get("train_seconds")),
            "full_l2": _number(fid.get("full_l2")),
            "dissipative_l2": _number(fid.get("dissipative_l2")),
            "n_nonpassive": fid.get("n_nonpassive"),
            "n_points": fid.get("n_points"),
        })
    return rows


def read_our_rows(path: str | Path) -> list[dict[str, Any]]:
    """:func:`our_rows` of the ``summary.json`` at ``path``."""
    return our_rows(json.loads(Path(path).read_text()))


def _cell(row: Mapping[str, Any], key: str, fmt: str) -> str:
    value = row.get(key)
    if key == "n_nonpassive":
        if value is None:
            return "n/a"
        n = row.get("n_points")
        return f"{int(value)} / {int(n)}" if n is not None else f"{int(value)}"
    f = _number(value)
    if f is None:
        return "n/a"
    if key in ("full_l2", "dissipative_l2"):
        f *= 100.0  # fractions in the summary, percent in the table
    return fmt.format(f)


def format_table(rows: Sequence[Mapping[str, Any]]) -> str:
    """One plain-text table: a row per model, the columns of :data:`COLUMNS`.

    Map errors are given as fractions (as :func:`sloshrom.energy.map_fidelity` returns them)
    and printed in percent; missing figures print as ``n/a``.
    """
    head = ["model"] + [h for _, h, _ in COLUMNS]
    body = [[str(r.get("model", "?"))] + [_cell(r, k, f) for k, _, f in COLUMNS] for r in rows]
    widths = [max(len(line[i]) for line in [head, *body]) for i in range(len(head))]

    def line(cells: list[str]) -> str:
        return "  ".join([cells[0].ljust(widths[0])]
                         + [c.rjust(w) for c, w in zip(cells[1:], widths[1:], strict=True)])

    return "\n".join([line(head), "  ".join("-" * w for w in widths), *map(line, body)])


_ENVELOPE = re.compile(r"([\d.eE+-]+)-([\d.eE+-]+) Hz, Gamma <= ([\d.eE+-]+) g, "
                       r"a_bar <= ([\d.eE+-]+)")


def map_settings(attrs: Mapping[str, Any]) -> dict[str, float | int]:
    """Keyword arguments of :func:`sloshrom.energy.phi_d_map` that reproduce a map's tests.

    Reads the attributes ``phi_d_map`` writes (``envelope``, ``n_cycles``, ``n_ramp``,
    ``settle_time``); those missing keep ``phi_d_map``'s defaults.
    """
    out: dict[str, float | int] = {}
    m = _ENVELOPE.search(str(attrs.get("envelope", "")))
    if m:
        out.update(zip(("f_min", "f_max", "gamma_max", "a_bar_max"), map(float, m.groups()),
                       strict=True))
    for key, kind in (("n_cycles", int), ("n_ramp", int), ("settle_time", float)):
        if key in attrs:
            out[key] = kind(attrs[key])
    return out


# -- SUBNET (torch and deepSI imported here only) ----------------------------------------------
def _import_deepsi(threads: int) -> tuple[Any, Any]:
    # the progress bar would fill a log; fit prints a line at each validation anyway
    os.environ.setdefault("TQDM_DISABLE", "1")
    # OpenMP threads that spin while waiting stall each other on cores busy with other jobs
    # (measured: 2 spinning threads 50-200 times slower than 1 under a load of 2); passive
    # waiting keeps 2 threads as fast as 1 there. Read when torch loads OpenMP: set it first.
    os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")
    import deepSI
    import torch

    # the machine's cores are shared with other runs: the time is that of `threads` cores
    torch.set_num_threads(threads)
    return deepSI, torch


class _OutOfTime(KeyboardInterrupt):
    """Raised inside a training step past the deadline: ``deepSI.fit`` stops on a
    KeyboardInterrupt and keeps the best model it validated."""


class SubnetSloshing:
    """A trained SUBNET as a sloshing model for :func:`sloshrom.energy.phi_d_map`.

    ``simulate(velocity, acceleration)`` on batches ``(n_runs, n)`` starts each run from the
    encoder's state for a window of rest (zero velocity and force) and returns the force (N),
    the model's output ``y_k = h(x_k)`` at the sample times (``force_rule = "trapezoid"``).
    """

    force_rule = "trapezoid"
    input = "velocity"

    def __init__(self, model: Any, fs: float, seed: int = -1) -> None:
        self.model = model
        self.dt = 1.0 / float(fs)
        self.seed = int(seed)

    def simulate(self, velocity: Any, acceleration: Any = None) -> np.ndarray:
        """Dynamic force (N) for the velocity (m/s), shape ``(..., n)``; acceleration unused."""
        import torch

        v = np.asarray(velocity, dtype=np.float64)
        runs = v.reshape(-1, v.shape[-1])
        m = self.model
        with torch.no_grad():
            upast = torch.zeros((runs.shape[0], m.nb), dtype=torch.float32)
            ypast = torch.zeros((runs.shape[0], m.na), dtype=torch.float32)
            y = m(upast, ypast, torch.as_tensor(runs, dtype=torch.float32))
        return y.numpy().astype(np.float64).reshape(v.shape)


def _seconds_per_iteration(dsi: Any, torch: Any, model: Any, data: Any, t: int,
                           batch: int, repeats: int = 3) -> float:
    """Wall time (s) of one training iteration (loss, gradient, Adam step) on a copy."""
    from copy import deepcopy

    probe = deepcopy(model)
    opt = torch.optim.Adam(probe.parameters())
    arrays, idx = probe.create_arrays(data, T=t)
    rng = np.random.default_rng(0)
    times = []
    for _ in range(repeats + 1):  # the first one warms up
        pick = rng.choice(idx, size=batch, replace=False)
        b = [a[pick] for a in arrays]
        t0 = time.perf_counter()
        loss = dsi.fitting.compute_NMSE(probe, *b)
        opt.zero_grad()
        loss.backward()
        opt.step()
        times.append(time.perf_counter() - t0)
    return float(np.median(times[1:]))


def _seconds_per_validation(torch: Any, model: Any, data: Any, part: int = 30,
                            repeats: int = 3) -> float:
    """Wall time (s) of one validation simulation, from 1/``part`` of the record (the median
    of ``repeats``: one timing on a shared machine can be several times too long)."""
    import deepSI as dsi

    n = max(len(data) // part, max(model.na, model.nb) + 10)
    short = dsi.Input_output_data(u=data.u[:n], y=data.y[:n], sampling_time=data.sampling_time)
    arrays, idx = model.create_arrays(short, T="sim")
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        with torch.no_grad():
            model(*[a[idx] for a in arrays])
        times.append(time.perf_counter() - t0)
    return float(np.median(times)) * len(data) / n


def train_subnet(u: np.ndarray, y: np.ndarray, uv: np.ndarray, yv: np.ndarray, fs: float,
                 minutes: float = 10.0, seed: int = 0, nx: int = 8, na: int = 50, nb: int = 50,
                 t: int = 200, batch: int = 256, threads: int = 2
                 ) -> tuple[Any, dict[str, Any]]:
    """Train a ``deepSI.SUBNET`` within ``minutes`` of wall time.

    The number of iterations comes from a measured time per iteration and per validation: the
    validation (a simulation of the whole validation record) runs every ``val_freq``
    iterations, chosen so that it takes about :data:`VALIDATION_SHARE` of the budget; a step
    past the deadline stops the fit all the same. ``deepSI.fit`` keeps the model of the best
    validation.

    Parameters
    ----------
    u, y : ndarray
        Training velocity (m/s) and dynamic force (N).
    uv, yv : ndarray
        Validation record, for early stopping.
    fs : float
        Sample rate, Hz.
    minutes : float
        Wall-clock budget of the training, calibration included.
    seed : int
        torch's seed (initial weights).
    nx, na, nb, t, batch : int
        State size, encoder windows of past outputs and inputs, unroll length of the loss,
        batch size.
    threads : int
        torch threads.

    Returns
    -------
    model : deepSI.SUBNET
    info : dict
        ``train_seconds``, ``torch_threads``, the plan (``seconds_per_iteration``,
        ``seconds_per_validation``, ``val_freq``, ``n_its_planned``), the training steps done
        (``iterations``), ``stopped_by_time``, the validation history ``val_nrms`` (SUBNET's
        NRMS, normalised by the training output's std) at ``val_iterations`` (the last:
        ``last_validation``), ``best_iteration`` and ``samples_per_second``.
    """
    dsi, torch = _import_deepsi(threads)
    t_start = time.perf_counter()
    deadline = t_start + 60.0 * minutes
    torch.manual_seed(seed)
    train = dsi.Input_output_data(u=u, y=y, sampling_time=1.0 / fs)
    val = dsi.Input_output_data(u=uv, y=yv, sampling_time=1.0 / fs)
    nu, ny, norm = dsi.get_nu_ny_and_auto_norm(train)
    model = dsi.SUBNET(nu, ny, norm, nx=nx, nb=nb, na=na)

    t_it = _seconds_per_iteration(dsi, torch, model, train, t, batch)
    t_val = _seconds_per_validation(torch, model, val)
    val_freq = max(10, math.ceil(t_val / (VALIDATION_SHARE * t_it)))
    left = 0.97 * (deadline - time.perf_counter())  # a margin for the last validation
    n_its = max(1, int(left / (t_it + t_val / val_freq)) // val_freq) * val_freq
    print(f"SUBNET: {t_it * 1e3:.0f} ms per iteration, {t_val:.1f} s per validation "
          f"({threads} torch threads): {n_its} iterations, validation every {val_freq}",
          flush=True)

    steps = [0]  # training steps begun (Adam evaluates the loss once per step)

    def loss_fun(*args: Any) -> Any:
        if time.perf_counter() > deadline:
            raise _OutOfTime
        steps[0] += 1
        return dsi.fitting.compute_NMSE(*args)

    res = dsi.fit(model, train, val, n_its=n_its, T=t, batch_size=batch, val_freq=val_freq,
                  loss_fun=loss_fun)
    train_seconds = time.perf_counter() - t_start
    nrms_val = np.asarray(res["NRMS_val"], dtype=np.float64)
    its = np.asarray(res["it_counter"])
    stopped = time.perf_counter() > deadline
    best = int(its[int(np.nanargmin(nrms_val))]) if nrms_val.size else 0
    info = {
        "train_seconds": train_seconds,
        "torch_threads": threads,
        "seconds_per_iteration": t_it,
        "seconds_per_validation": t_val,
        "val_freq": int(val_freq),
        "n_its_planned": int(n_its),
        "iterations": steps[0],
        "last_validation": int(its[-1]) if its.size else 0,
        "stopped_by_time": bool(stopped),
        "val_iterations": [int(i) for i in its],
        "val_nrms": [float(v) for v in nrms_val],
        "best_iteration": best,
        "samples_per_second": _number(res.get("samples/sec")),
    }
    return model, info


def score_validation(model: Any, uv: np.ndarray, yv: np.ndarray, fs: float
                     ) -> dict[str, float | int]:
    """Simulate the whole validation record: NRMSE and fit after the encoder window."""
    import deepSI as dsi

    sim = model.simulate(dsi.Input_output_data(u=uv, y=yv, sampling_time=1.0 / fs))
    window = max(model.na, model.nb)
    nrmse = nrmse_after_window(yv, np.asarray(sim.y), window)
    return {"val_nrmse": nrmse, "val_fit": fit_percent(nrmse), "encoder_window": int(window)}


def score_map(model: Any, run: Path, fs: float, seed: int) -> tuple[dict[str, Any], Any]:
    """Phi_d map of the SUBNET on the rig map's grid, and its fidelity against that map."""
    import xarray as xr

    from sloshrom.config import Tank
    from sloshrom.energy import map_fidelity, phi_d_map
    from sloshrom.io import read_record

    with xr.open_dataset(run / "maps" / "phi_d_rig.nc") as ds:
        rig = ds["phi_d"].load()
    tank = read_record(run / "data" / "train.nc").tank
    if tank is None:  # a record without tank_* attributes: the paper's tank at the map's fill
        tank = Tank(fill=float(rig.attrs.get("tank_fill", 0.5)))
    t0 = time.perf_counter()
    phi = phi_d_map(SubnetSloshing(model, fs, seed), rig.omega_bar.values, rig.a_bar.values,
                    tank=tank, **map_settings(rig.attrs))
    fid = map_fidelity(rig, phi)
    fid["map_seconds"] = time.perf_counter() - t0
    return fid, phi


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--run", type=Path, required=True,
                    help="a `sloshrom reproduce` output directory (data/, maps/, summary.json)")
    ap.add_argument("--minutes", type=float, default=10.0, help="training budget (wall clock)")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--nx", type=int, default=8, help="state size")
    ap.add_argument("--na", type=int, default=50, help="encoder window of past outputs")
    ap.add_argument("--nb", type=int, default=50, help="encoder window of past inputs")
    ap.add_argument("--T", dest="t", type=int, default=200, help="unroll length of the loss")
    ap.add_argument("--batch", type=int, default=256)
    ap.add_argument("--threads", type=int, default=2, help="torch threads")
    ap.add_argument("--out", type=Path, help="write the figures as JSON")
    args = ap.parse_args(argv)

    run = args.run
    needed = [run / "data" / "train.nc", run / "data" / "validation.nc",
              run / "maps" / "phi_d_rig.nc", run / "summary.json"]
    missing = [str(p) for p in needed if not p.is_file()]
    if missing:
        print(f"peer_subnet: {run} is not a finished reproduce run: missing "
              f"{', '.join(missing)} (run `sloshrom reproduce --out {run}`)", file=sys.stderr)
        return 2

    from sloshrom.io import read_record

    tr = read_record(run / "data" / "train.nc")
    va = read_record(run / "data" / "validation.nc")
    if abs(tr.fs - va.fs) > 1e-9 * tr.fs:
        print(f"peer_subnet: train {tr.fs} Hz and validation {va.fs} Hz differ", file=sys.stderr)
        return 2
    u, y = tr["velocity"], tr["dynamic_force"]
    uv, yv = va["velocity"], va["dynamic_force"]

    model, info = train_subnet(u, y, uv, yv, tr.fs, minutes=args.minutes, seed=args.seed,
                               nx=args.nx, na=args.na, nb=args.nb, t=args.t, batch=args.batch,
                               threads=args.threads)
    val = score_validation(model, uv, yv, tr.fs)
    fid, _ = score_map(model, run, tr.fs, args.seed)
    name = f"SUBNET(nx {args.nx}, na=nb {args.na}" if args.na == args.nb else \
        f"SUBNET(nx {args.nx}, na {args.na}, nb {args.nb}"
    row = {"model": f"{name}, T {args.t})", "source": "benchmarks/peer_subnet.py",
           **val, "train_seconds": info["train_seconds"],
           **{k: fid[k] for k in ("full_l2", "dissipative_l2", "n_nonpassive", "n_points")}}
    ours = read_our_rows(run / "summary.json")

    print()
    print(format_table([row, *ours]))
    print(f"\nSUBNET: {info['iterations']} of {info['n_its_planned']} iterations planned "
          f"({'stopped by the wall-time budget' if info['stopped_by_time'] else 'as planned'}),"
          f" best validation at iteration {info['best_iteration']}; validation NRMS every "
          f"{info['val_freq']}: " + ", ".join(f"{v:.3f}" for v in info["val_nrms"]))
    if info["val_nrms"] and info["best_iteration"] == info["val_iterations"][-1]:
        print("SUBNET: the last validation was the best: still improving when the budget ended")
    print(f"SUBNET fit and NRMSE after the encoder window of {val['encoder_window']} samples; "
          f"map min Phi_d {fid['min_phi_d']:.4f} (non-passive below "
          f"{fid['passivity_threshold']:.4f}), {fid['map_seconds']:.0f} s; "
          f"torch threads {args.threads}")
    print("ours: fit = 100 (1 - ||e|| / ||y - mean(y)||) over the whole record, NRMSE = "
          "RMS(e) / RMS(y) (summary.json)")
    if args.out is not None:
        out = {"run": str(run), "subnet": {**row, "map": fid, "training": info,
                                           "settings": vars(args) | {"run": str(run),
                                                                     "out": str(args.out)}},
               "ours": ours}
        args.out.parent.mkdir(parents=True, exist_ok=True)
        args.out.write_text(json.dumps(out, indent=2, default=float) + "\n")
        print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
