"""The ``data`` stage of `sloshrom reproduce`: VFA training and validation records from the
virtual rig (paper Figs. 5-7)."""

from __future__ import annotations

from typing import Any

import numpy as np

from sloshrom import __version__, signals
from sloshrom.config import G
from sloshrom.io import record_from_measurement, write_record
from sloshrom.pipeline.context import Context
from sloshrom.plotting import savefig
from sloshrom.plotting.signals import record_io_figure, vfa_paths_figure

__all__ = ["stage_data"]


def stage_data(ctx: Context) -> tuple[dict[str, Any], list[str]]:
    """Record the training and validation VFA tests on the rig; write records and figures.

    Returns
    -------
    outputs : dict
        Per split: ``duration_s`` (s), ``fs_hz`` (Hz), ``samples``, ``max_acceleration_g`` (g),
        ``max_dynamic_force_n`` (N).
    files : list of str
        ``data/train.nc``, ``data/validation.nc`` and the figures, relative to ``ctx.out``.
    """
    cfg, tank = ctx.cfg, ctx.tank
    rig = ctx.rig()
    files, outputs, paths, records = [], {}, [], {}
    splits = [
        ("train", cfg["data"]["train_duration"], cfg["data"]["train_seed"]),
        ("validation", cfg["data"]["validation_duration"], cfg["data"]["validation_seed"]),
    ]
    for k, (split, duration, seed) in enumerate(splits):
        ctx.progress("data", k, len(splits), f"rig VFA {split} ({duration:.0f} s)")
        sig = signals.vfa(1.0 / rig.dt, split=split, duration=duration, tank=tank, seed=seed)
        meas = rig.measure(sig.acceleration)
        rec = record_from_measurement(
            meas, tank, truth=True, split=split, seed=int(seed),
            rig_seed=int(cfg["rig"]["seed"]),
            provenance=f"sloshrom {__version__} reproduce: virtual rig VFA {split}",
        )
        p = ctx.path("data", f"{split}.nc")
        write_record(rec, p)
        files.append(ctx.rel(p))
        paths.append(sig)
        records[split] = rec
        outputs[split] = {
            "duration_s": float(rec.duration),
            "fs_hz": float(rec.fs),
            "samples": len(rec),
            "max_acceleration_g": float(np.max(np.abs(rec["acceleration"])) / G),
            "max_dynamic_force_n": float(np.max(np.abs(rec["dynamic_force"]))),
        }
        del sig, meas
    ctx.progress("data", len(splits), len(splits), "figures")
    p = savefig(vfa_paths_figure(paths), ctx.path("figures", "fig05_vfa_paths.png"))
    files.append(ctx.rel(p))
    for split, name in (("train", "fig06_train_io.png"), ("validation", "fig07_validation_io.png")):
        p = savefig(record_io_figure(records[split], split), ctx.path("figures", name))
        files.append(ctx.rel(p))
    return outputs, files
