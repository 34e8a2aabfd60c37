"""Report tables of a measurement beside its predictions: each estimate with its interval and the
verdict of ``sloshrom.beam.compare.compare_rows`` (used by the beam section and the studies)."""

from __future__ import annotations

from typing import Any

import numpy as np

from sloshrom.beam.damping.registry import label
from sloshrom.pipeline.html import Table

__all__ = ["cell_text", "experiment_tables", "interval_text", "percent"]


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


def cell_text(v: float, lo: float, hi: float, reason: str = "", note: str = "") -> str:
    """A table cell of a damping estimate: :func:`interval_text`, or ``— (reason)`` when the
    value is missing (never a silent gap); a value without an interval, or one a fallback or
    part of an ensemble's members gave, followed by its reason or note in parentheses."""
    text = interval_text(v, lo, hi)
    if text == "–":
        return f"— ({reason})" if reason else "–"
    extra = "; ".join(x for x in (reason, note) if x)
    return f"{text} ({extra})" if extra else text


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
        # an n/a verdict says why (the estimates' reasons), as every other missing cell
        cells = {r["case"]: f"{percent(r['predicted'])} ({r['verdict']}"
                 + (f": {r['reason']})" if r.get("reason") else ")") for r in sel}
        why_m = "; ".join(x.removeprefix("measured: ") for x in
                          str(m.get("reason", "")).split("; ") if x.startswith("measured: "))
        body.append([k[0], label(k[1]),
                     cell_text(m["measured"], m["measured_low"], m["measured_high"], why_m)]
                    + [cells.get(c, "–") for c in cases])
    return [Table(head + ["experiment (95 % interval)"] + cases, body,
                  f"The rig as the laboratory, {what} damping: its beam runs written as a test "
                  "lab's UFF 58 files (station and base accelerometers with sensor noise) and "
                  "analysed as a measurement, its estimates with their 95 % intervals; beside "
                  "them each prediction and whether it lies inside that interval "
                  "(the command sloshrom compare does the same with real files).")]
