"""Sensitivity analysis over delays x neurons (paper section 3, Fig. 8).

The grid is each class's of the registry that declares one (:attr:`~sloshrom.rom.registry.
ModelClass.sweep`: the paper's NFIR and NOE). Every grid point trains one network; its score is
the mean of the training and validation MSE
(free-run simulation, N^2). Each finished point writes its model (``<name>.npz``) and its result
(``<name>.json``) to the output directory, so an interrupted sweep resumes where it stopped.
Unstable NOE networks are kept in the table with ``unstable = True`` and an infinite score.

Grid points run in parallel through Dask (:func:`sloshrom.rom.parallel.run_tasks`, also used by
the ensembles): a ``dask.distributed.LocalCluster`` by default, an existing cluster given by its
scheduler address, or ``"threads"``/``"sequential"`` (tests).
"""

from __future__ import annotations

import csv
import io
import json
import math
import os
import time
import warnings
from collections.abc import Callable, Iterable
from pathlib import Path
from typing import Any

import numpy as np

from sloshrom.fileio import atomic_write_text
from sloshrom.rom.errors import ROMError, TrainingWarning, UnstableModelError
from sloshrom.rom.parallel import quiet_worker, run_tasks
from sloshrom.rom.registry import model_class, swept

__all__ = ["BOTH", "SWEEP_FIGURE", "SWEEP_TABLES", "fit_point", "point_name", "run_sweep",
           "sweep_grid", "write_table"]

#: The result tables :func:`run_sweep` writes in its directory (and the figure ``sloshrom
#: sweep`` adds), besides ``<point>.npz`` and ``<point>.json`` per grid point.
SWEEP_TABLES = ("sweep.csv", "sweep.json")
SWEEP_FIGURE = "fig8_sweep.png"

COLUMNS = ("name", "arch", "delays", "neurons", "train_mse", "val_mse", "score", "unstable",
           "epochs", "stop_reason", "seconds", "model")


#: ``arch`` of :func:`sweep_grid` for every class of the sweep.
BOTH = "both"


def sweep_grid(arch: str = BOTH) -> list[tuple[str, int, int]]:
    """The paper's grid as ``(arch, delays, neurons)``: each swept class's delays x neurons
    (:attr:`~sloshrom.rom.registry.ModelClass.sweep`; NFIR {50,60,70} x {5..40}, NOE 2 x
    {10,15,20}); ``arch``: one class's name or ``"both"``, every class's.

    Raises
    ------
    ROMError
        Another ``arch``.
    """
    classes = [mc for mc in swept() if arch in (mc.name, BOTH)]
    if not classes:
        names = ", ".join(repr(mc.name) for mc in swept())
        raise ROMError(f"arch must be {names} or {BOTH!r}, got {arch!r}")
    return [(mc.name, d, n) for mc in classes for d in mc.sweep[0] for n in mc.sweep[1]]


def point_name(arch: str, delays: int, neurons: int) -> str:
    """The name of one sweep point, e.g. ``nfir_d70_n35``."""
    return f"{arch}_d{delays}_n{neurons}"


#: Options of :func:`run_sweep` that only some classes have: given to those alone.
_ONE_CLASS_OPTIONS = frozenset({"precision"})


def fit_point(
    point: tuple[str, int, int],
    train: tuple[np.ndarray, np.ndarray],
    validation: tuple[np.ndarray, np.ndarray],
    fs: float,
    out_dir: str,
    options: dict[str, Any],
    parent: int | None = None,
) -> dict[str, Any]:
    """Train (or resume from disk) one grid point; returns its result row.

    ``parent``: the process id of :func:`run_sweep`'s caller (a :class:`TrainingWarning` is
    not shown in a worker process: the row's ``stop_reason`` says it)."""
    quiet_worker(parent, TrainingWarning)
    arch, delays, neurons = point
    name = point_name(arch, delays, neurons)
    out = Path(out_dir)
    res_path = out / f"{name}.json"
    if res_path.is_file():  # finished before: resume
        return json.loads(res_path.read_text(encoding="utf-8"))
    mc = model_class(arch)
    # an option of one class only (the NFIR's precision) is not the other's to refuse
    names = {h.name for h in mc.hyper}
    model = mc.estimator_class()(delays=delays, neurons=neurons,
                                 **{k: v for k, v in options.items()
                                    if k not in _ONE_CLASS_OPTIONS or k in names})
    row: dict[str, Any] = {"name": name, "arch": arch, "delays": delays, "neurons": neurons}
    t0 = time.perf_counter()
    try:
        model.fit(*train, fs=fs, validation=validation)
        tr = float(np.mean((model.predict(train[0]) - train[1]) ** 2))
        va = float(np.mean((model.predict(validation[0]) - validation[1]) ** 2))
        row.update(train_mse=tr, val_mse=va, score=0.5 * (tr + va), unstable=False,
                   epochs=len(model.history_["train_mse"]) - 1,
                   stop_reason=model.history_["stop_reason"])
        row["model"] = model.save(out / f"{name}.npz").name
    except UnstableModelError as exc:
        row.update(train_mse=math.inf, val_mse=math.inf, score=math.inf, unstable=True,
                   epochs=0, stop_reason=f"unstable: {exc}", model="")
    row["seconds"] = time.perf_counter() - t0
    atomic_write_text(res_path, json.dumps(row))
    return row


def run_sweep(
    train: tuple[Any, Any],
    validation: tuple[Any, Any],
    fs: float,
    out_dir: str | Path,
    points: Iterable[tuple[str, int, int]] | None = None,
    scheduler: str | None = None,
    n_workers: int = 2,
    options: dict[str, Any] | None = None,
    progress: Callable[[dict[str, Any]], Any] | None = None,
) -> list[dict[str, Any]]:
    """Run the sensitivity analysis.

    Parameters
    ----------
    train, validation : (u, y)
        Input (m/s) and output (N) records sampled at ``fs``.
    fs : float
        Sample rate, Hz.
    out_dir : path
        Models, per-point results, ``sweep.csv``/``sweep.json`` go here.
    points : iterable of (arch, delays, neurons), optional
        Default :func:`sweep_grid`.
    scheduler : str, optional
        None: a new ``LocalCluster(n_workers)``; ``"threads"`` or ``"sequential"``: no cluster;
        anything else: the address of an existing Dask scheduler.
    options : dict, optional
        Extra estimator arguments (``max_epochs``, ``hidden``, ``seed``, ``trainer``; and
        ``precision``, given to the classes that have it: the NFIR's).
    progress : callable, optional
        Called with each finished row.

    Returns
    -------
    list of dict
        One row per point (columns ``COLUMNS``), sorted by score.
    """
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    pts = list(points) if points is not None else sweep_grid()
    opts = dict(options or {})
    train = (np.asarray(train[0], float), np.asarray(train[1], float))
    validation = (np.asarray(validation[0], float), np.asarray(validation[1], float))
    # the longest trainings first (the NOE's Levenberg-Marquardt, then the largest NFIRs): the
    # workers then finish together instead of one waiting on the last long point
    pts.sort(key=lambda p: (not model_class(p[0]).sweep_first, -p[1] * p[2]))
    with warnings.catch_warnings():
        # a grid point at mu_max is a row of the table (its stop_reason), not a warning per
        # point; set in this thread, which the "threads" scheduler's workers read
        warnings.simplefilter("ignore", TrainingWarning)
        rows = run_tasks(fit_point, pts, shared=(train, validation),
                         args=(float(fs), str(out), opts, os.getpid()), scheduler=scheduler,
                         n_workers=n_workers,
                         done=None if progress is None else lambda _i, row: progress(row))
    rows.sort(key=lambda r: (r["score"], r["name"]))
    write_table(rows, out)
    return rows


def write_table(rows: list[dict[str, Any]], out_dir: Path) -> tuple[Path, Path]:
    """Write ``sweep.csv`` and ``sweep.json`` (atomically)."""
    buf = io.StringIO()
    w = csv.DictWriter(buf, fieldnames=COLUMNS, extrasaction="ignore")
    w.writeheader()
    w.writerows(rows)
    csv_path, json_path = (out_dir / name for name in SWEEP_TABLES)
    atomic_write_text(csv_path, buf.getvalue())
    safe = [{k: (None if isinstance(v, float) and not math.isfinite(v) else v)
             for k, v in r.items()} for r in rows]
    atomic_write_text(json_path, json.dumps(safe, indent=1))
    return csv_path, json_path
