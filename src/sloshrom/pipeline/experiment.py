"""Report tables of a measurement beside its predictions: each estimate with its interval and the
verdict of ``sloshrom.beam.compare.compare_rows`` (used by the beam section and the studies)."""

from __future__ import annotations

from typing import Any

import numpy as np

from sloshrom.beam.registry import label
from sloshrom.pipeline.html import Table

__all__ = ["experiment_tables", "interval_text", "percent"]


def percent(v: Any) -> str:
    """A damping ratio in percent (``1.23 %``), ``–`` when missing."""
    try:
        return "–" if not np.isfinite(v) else f"{100 * float(v):.2f} %"
    except TypeError:
        return "–"


def interval_text(v: Any, lo: Any, hi: Any) -> str:
    """A damping ratio and its interval in percent: ``1.23 % [1.10, 1.36]``."""
    try:
        if not np.isfinite(v):
            return "–"
        if not (np.isfinite(lo) and np.isfinite(hi)):
            return percent(v)
        return f"{100 * float(v):.2f} % [{100 * float(lo):.2f}, {100 * float(hi):.2f}]"
    except TypeError:
        return "–"


def experiment_tables(exp: Any, kind: str) -> list[Table]:
    """The rig as the laboratory against the predictions: one row per band (free decay, Hilbert
    and log decrement) or per level and estimator (random tests), a column per predicted case:
    its estimate and whether it lies inside the experiment's 95 % interval."""
    if not isinstance(exp, dict) or not exp.get(kind):
        return []
    rows = exp[kind]
    cases = list(dict.fromkeys(r["case"] for r in rows))
    if kind == "free":
        keys = list(dict.fromkeys((r["band"], r["method"]) for r in rows))
        head, what = ["tank acceleration", "method"], "free decay: instantaneous first-mode"
    else:
        keys = list(dict.fromkeys((r["rms_g"], r["estimator"]) for r in rows))
        head, what = ["RMS [g]", "estimator"], "random tests: first-mode"
    body = []
    for k in keys:
        sel = [r for r in rows if (r.get("band", r.get("rms_g")),
                                   r.get("method", r.get("estimator"))) == k]
        m = sel[0]
        cells = {r["case"]: f"{percent(r['predicted'])} ({r['verdict']})" for r in sel}
        body.append([k[0], label(k[1]),
                     interval_text(m["measured"], m["measured_low"], m["measured_high"])]
                    + [cells.get(c, "–") for c in cases])
    return [Table(head + ["experiment (95 % interval)"] + cases, body,
                  f"The rig as the laboratory, {what} damping: its beam runs written as a test "
                  "lab's UFF 58 files (station and base accelerometers with sensor noise) and "
                  "analysed as a measurement, its estimates with their 95 % intervals; beside "
                  "them each prediction and whether it lies inside that interval "
                  "(`sloshrom compare`).")]
