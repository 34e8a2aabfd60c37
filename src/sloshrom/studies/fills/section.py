"""The report section of the fill-level study: "Beyond the paper: one ROM for every fill level".

:func:`fills_section` writes the family, its map against the rig's at every fill and the beam's
first-mode damping against fill level, from the stage's outputs
(:class:`~sloshrom.studies.fills.outputs.FillsOutputs`).
"""

from __future__ import annotations

import html
from collections.abc import Mapping
from typing import Any

import numpy as np

from sloshrom.pipeline.context import Context
from sloshrom.pipeline.html import Figure, Section, Table
from sloshrom.rom.ensemble import spread_text
from sloshrom.studies.fills.config import label as _pct
from sloshrom.studies.fills.outputs import FillsOutputs

__all__ = ["fills_section"]


def _fmt(v: Any, scale: float = 100.0, fmt: str = "{:.2f}") -> str:
    try:
        x = float(v)
    except (TypeError, ValueError):
        return "n/a"
    return fmt.format(scale * x) if np.isfinite(x) else "n/a"


def _member_text(v: Mapping[str, object]) -> str:
    """How the family's member at one fill was identified: the main ROM, or its training time
    and, for an ensemble, its networks' validation MSE (spread, N²)."""
    if v["main_rom"]:
        return "the main ROM"
    text = f"trained in {_fmt(v['train_seconds'], scale=1.0, fmt='{:.0f}')} s"
    spread = v.get("val_mse_members")
    if isinstance(spread, dict) and len(spread.get("values", [])) > 1:
        text += (f"; validation MSE of its {len(spread['values'])} networks "
                 f"{spread_text(spread['values'], 'N²')}")
    return text


def fills_section(ctx: Context, outputs: FillsOutputs | Mapping[str, Any]) -> Section:
    """The report section of the fill-level study (``outputs``: the stage's outputs, or their
    record in ``summary.json``)."""
    o = outputs if isinstance(outputs, FillsOutputs) else FillsOutputs.from_record(outputs)
    t = o.targets
    map_rows = [[f"{_pct(r['fill'])} %" + (" (unseen)" if r["unseen"] else ""),
                 _fmt(r["full_l2"]), _fmt(r["dissipative_l2"]),
                 f"{r['n_nonpassive']} ({_fmt(r['nonpassive_fraction'], fmt='{:.1f}')} %)",
                 "ok" if (r["full_l2"] <= t["full_l2"] and r["n_nonpassive"] == 0)
                 else "MISS" if r["unseen"] else ""]
                for r in o.maps]
    beam_rows = [[f"{_pct(r['fill'])} %" + (" (unseen)" if r["unseen"] else ""),
                  f"{r['rms_g']:g}", _fmt(r["rig"]), _fmt(r["rom"]), _fmt(r["frozen"]),
                  _fmt(r["rom_vs_rig"], fmt="{:+.1f}"),
                  ("ok" if abs(r["rom_vs_rig"]) <= t["damping"] else "MISS")
                  if r["unseen"] and np.isfinite(r["rom_vs_rig"]) else ""]
                 for r in o.beam_errors]
    members = ", ".join(f"{k} % ({_member_text(v)})" for k, v in o.members.items())
    s = o.seconds
    text = (
        "The paper ends with \"include different filling levels in the training process\". "
        f"A fill family: one ROM identified at each of the fills {members}, by the same "
        "recipe and the same data design at its own fill; at a fill between two members the "
        "family predicts the convex blend of their dynamic forces, linear in the fill "
        "(docs/rom.md, \"Fill levels\"). A model refuses a fill outside the range it was "
        "identified on. Judged at fills no member saw: the map against the rig's at that fill "
        f"(target full-map error <= {t['full_l2']:.0%} and passive) and the first-mode damping "
        f"of the sloshing beam (LSCF on H1, target within {t['damping']:.0%} of the rig). "
        "At a trained fill the family is its member, so those rows are the members' own "
        f"accuracy. Time: members {s['members']:.0f} s, maps {s['maps']:.0f} s, beam "
        f"{s['beam']:.0f} s.")
    return Section(
        "Beyond the paper: one ROM for every fill level", f"<p>{html.escape(text)}</p>",
        figures=[Figure(ctx.out / "figures" / "fills_phi_d_maps.png",
                        "Phi_d maps of the rig (top) and of the fill family (bottom) at the "
                        "training fills and at an unseen fill."),
                 Figure(ctx.out / "figures" / "fills_damping.png",
                        "First-mode damping ratio (LSCF on H1) of the sloshing beam against "
                        "fill level: rig, fill family, frozen liquid; shaded: unseen fills.")],
        tables=[Table(["fill", "full-map error [%]", "dissipative-region error [%]",
                       "non-passive points", "target"], map_rows,
                      "Phi_d map of the fill family against the rig's at each fill."),
                Table(["fill", "RMS [g]", "rig [%]", "family [%]", "frozen [%]",
                       "family vs rig [%]", "target"], beam_rows,
                      "First-mode damping ratio of the sloshing beam, LSCF on H1.")])
