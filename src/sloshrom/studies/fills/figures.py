"""Figures of the fill-level study: Phi_d maps across fills, damping against fill level.

Object-oriented matplotlib (a :class:`~matplotlib.figure.Figure` made directly, as
:mod:`sloshrom.plotting` does): no backend is selected.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np
import xarray as xr
from matplotlib.figure import Figure

from sloshrom.beam.damping.registry import REFERENCE
from sloshrom.plotting.maps import plot_phi_d_map

__all__ = ["CASE_STYLE", "damping_fill_figure", "fill_maps_figure"]

#: Line styles of the cases of the damping-against-fill figure.
CASE_STYLE = {"rig": dict(color="k", marker="o"), "rom": dict(color="C3", marker="s"),
              "frozen": dict(color="C0", marker="^", linestyle="--")}


def fill_maps_figure(rig: Mapping[float, xr.DataArray], rom: Mapping[float, xr.DataArray],
                     unseen: Sequence[float] = ()) -> Figure:
    """Rig (top row) and ROM (bottom row) Phi_d maps, one column per fill level.

    Both rows of a column share one colour scale (the rig's maximum), so that the eye compares
    levels; columns of fills no member was trained on are titled "unseen".
    """
    fills = sorted(rig)
    fig = Figure(figsize=(3.4 * len(fills), 6.4), layout="constrained")
    axes = fig.subplots(2, len(fills), squeeze=False, sharex=True, sharey=True)
    for j, f in enumerate(fills):
        tag = " (unseen)" if any(abs(f - u) < 1e-9 for u in unseen) else ""
        for i, (name, maps) in enumerate((("rig", rig), ("ROM", rom))):
            ax = axes[i, j]
            plot_phi_d_map(maps[f], ax=ax)
            ax.set_title(f"{name}, fill {f:.1%}{tag}", fontsize=10)
            if j:
                ax.set_ylabel("")
            if i == 0:
                ax.set_xlabel("")
    return fig


def damping_fill_figure(table: xr.Dataset, levels: Sequence[float],
                        unseen: Sequence[float] = ()) -> Figure:
    """First-mode damping (the registry's reference estimator, LSCF on H1) against fill level,
    one panel per RMS level.

    ``table`` is Table 2 over ``(fill, case, level, estimator)`` (fill level -, RMS base level
    g; ``sloshrom.beam.damping.tables.mode1_damping_dataset`` at each fill); fills no member
    saw are shaded.
    """
    fig = Figure(figsize=(4.2 * len(levels), 3.6), layout="constrained")
    axes = fig.subplots(1, len(levels), squeeze=False)[0]
    ref = table["value"].sel(estimator=REFERENCE)
    for ax, level in zip(axes, levels, strict=True):
        for case, style in CASE_STYLE.items():
            pts = sorted((float(f), float(ref.sel(case=case, fill=f).isel(level=k)))
                         for f in table.fill.values if case in table.case
                         for k in range(table.sizes["level"])
                         if abs(float(table.level[k]) - level) < 1e-12)
            if not pts:
                continue
            f, z = np.array(pts).T
            ax.plot(100 * f, 100 * z, label=case, **style)
        for u in unseen:
            ax.axvline(100 * u, color="0.8", linewidth=6, zorder=0)
        ax.set_title(f"{level:g} g RMS base excitation", fontsize=10)
        ax.set_xlabel("fill level d/h [%]")
        ax.grid(alpha=0.3)
    axes[0].set_ylabel("first-mode damping ratio [%]")
    axes[0].legend(fontsize=8)
    return fig
