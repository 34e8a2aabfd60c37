"""Figures of the dissipated energy: Phi_d maps (paper Figs. 4, 11) and hysteresis loops
(Fig. 3)."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import xarray as xr
from matplotlib import colormaps
from matplotlib.axes import Axes
from matplotlib.colors import TwoSlopeNorm
from matplotlib.figure import Figure
from matplotlib.patches import Patch

from sloshrom.config import ConfigError
from sloshrom.energy import PASSIVITY_TOLERANCE

__all__ = [
    "MAP_KINDS", "NEGATIVE_COLOR", "Loop", "hysteresis_figure", "phi_d_map_figure",
    "plot_hysteresis", "plot_phi_d_map",
]


#: Fill colour of non-passive Phi_d on a map (energy given back to the tank).
NEGATIVE_COLOR = "#ff7f0e"
MAP_KINDS = ("map", "difference")


def plot_phi_d_map(da: xr.DataArray, ax: Axes | None = None, levels: int = 15,
                   kind: str = "map", negative_below: float | None = None,
                   top: float | None = None) -> Axes:
    """Contour map of Phi_d(omega_bar, a_bar) with the Gamma = 1 and Gamma = 4 iso-lines.

    Parameters
    ----------
    da : xarray.DataArray
        A map of ``sloshrom.energy.phi_d_map`` (dimensionless, dims ``omega_bar``, ``a_bar``),
        or the difference of two maps.
    ax : matplotlib Axes, optional
        Where to draw; default: the axes of a new 6 x 4.5 in figure.
    levels : int
        Number of contour levels.
    kind : {"map", "difference"}
        ``"map"``: sequential colours from Phi_d = 0 up; values below ``negative_below``
        (non-passive: the model gives energy back to the tank) are filled in
        :data:`NEGATIVE_COLOR`, outlined by a contour at that level and named in the legend.
        ``"difference"``: diverging colours (``RdBu_r``) with a norm centred on zero and
        symmetric limits: red where ``da`` > 0, blue where ``da`` < 0, white at 0.
    negative_below : float, optional
        Phi_d level (-, <= 0) under which a ``"map"`` point counts as non-passive. Default:
        ``-sloshrom.energy.PASSIVITY_TOLERANCE`` times the map's maximum, so that round-off
        around Phi_d = 0 (the rig's non-dissipative region) is not painted; pass
        ``map_fidelity(...)["passivity_threshold"]`` to match a comparison's count, or 0.
    top : float, optional
        Top of a ``"map"``'s colour scale (-): give two maps the same one to compare them by
        colour (the ROM's on the rig's). Default: the map's own maximum.

    Returns
    -------
    matplotlib.axes.Axes
    """
    if kind not in MAP_KINDS:
        raise ConfigError(f"kind must be one of {MAP_KINDS}, got {kind!r}")
    if negative_below is not None and not negative_below <= 0:
        raise ConfigError(f"negative_below must be <= 0, got {negative_below}")
    if ax is None:
        ax = Figure(figsize=(6, 4.5)).subplots()
    ob = np.asarray(da.omega_bar)
    ab = np.asarray(da.a_bar)
    z = np.ma.masked_invalid(np.asarray(da.values, dtype=np.float64).T)
    zmin = float(z.min()) if z.count() else 0.0
    zmax = float(z.max()) if z.count() else 0.0
    handles: list[Patch] = []
    if kind == "difference":
        # symmetric limits and a norm centred on 0: the colour tells over (red) from under (blue)
        m = max(abs(zmin), abs(zmax)) or 1.0
        norm = TwoSlopeNorm(vcenter=0.0, vmin=-m, vmax=m)
        # an odd number of bands: the middle one straddles 0 and takes the colour map's white
        n_bands = levels if levels % 2 else levels + 1
        cs = ax.contourf(ob, ab, z, levels=np.linspace(-m, m, n_bands + 1), cmap="RdBu_r",
                         norm=norm)
        ax.figure.colorbar(cs, ax=ax, label=r"$\Delta\Phi_d$ (red: more, blue: less)")
    else:
        floor = (-PASSIVITY_TOLERANCE * max(zmax, 0.0) if negative_below is None
                 else float(negative_below))
        if top is None or not top > 0:
            top = zmax if zmax > 0 else 1.0
        # the lowest band reaches down to the floor (round-off around 0 stays the colour of
        # 0); anything below is "under", a colour no band uses
        bounds = np.linspace(0.0, top, levels)
        bounds[0] = floor
        cmap = colormaps["Blues"].with_extremes(under=NEGATIVE_COLOR)
        cs = ax.contourf(ob, ab, z, levels=bounds, cmap=cmap,
                         extend="both" if zmax > top else "min")
        ax.figure.colorbar(cs, ax=ax, label=r"$\Phi_d$")
        if zmin < floor:  # outline the non-passive patches, which may be single cells
            ax.contour(ob, ab, z, levels=[floor], colors=NEGATIVE_COLOR, linewidths=1.0)
        # named even when absent: the reader learns that none is hidden
        handles = [Patch(facecolor=NEGATIVE_COLOR,
                         label=rf"$\Phi_d$ < {floor:.2g} (not passive)")]
    obf = np.linspace(ob.min(), ob.max(), 200)
    for gam, style in ((1.0, "--"), (4.0, "-")):
        ax.plot(obf, gam / obf**2, "k" + style, lw=1, label=rf"$\Gamma$ = {gam:g} g")
    ax.set_ylim(ab.min(), ab.max())
    ax.set_xlabel(r"$\bar\omega = \Omega/\sqrt{g/h}$")
    ax.set_ylabel(r"$\bar a = a/h$")
    lines, _ = ax.get_legend_handles_labels()
    ax.legend(handles=lines + handles, loc="upper right", fontsize=8)
    return ax


def phi_d_map_figure(da: xr.DataArray, title: str, kind: str = "map",
                     negative_below: float | None = None, top: float | None = None) -> Figure:
    """A Phi_d map or difference (:func:`plot_phi_d_map`: ``kind``, ``negative_below``,
    ``top``) with a title, on its own 6.4 x 4.6 in figure."""
    fig = Figure(figsize=(6.4, 4.6), layout="constrained")
    ax = plot_phi_d_map(da, ax=fig.subplots(), kind=kind, negative_below=negative_below,
                        top=top)
    ax.set_title(title)
    return fig


def plot_hysteresis(x: np.ndarray, y: np.ndarray, ax: Axes | None = None,
                    label: str | None = None) -> Axes:
    """Plot a normalised hysteresis loop (``w/a`` against ``f_S/(m_l a Omega^2)``, both -).

    Returns the matplotlib Axes (default: those of a new 5 x 4 in figure).
    """
    if ax is None:
        ax = Figure(figsize=(5, 4)).subplots()
    ax.plot(x, y, lw=0.8, label=label)
    ax.set_xlabel(r"$w/a$")
    ax.set_ylabel(r"$f_S/(m_l a \Omega^2)$")
    if label:
        ax.legend()
    return ax


@dataclass
class Loop:
    """One model's steady harmonic response, normalised (``sloshrom.energy.hysteresis_loop``).

    ``time`` (s, from the start of the steady part), ``x`` = w/a (-) and
    ``y`` = f_S/(m_l a Omega^2) (-); ``label`` names the model in the legend.
    """

    label: str
    time: np.ndarray
    x: np.ndarray
    y: np.ndarray


def hysteresis_figure(loops: Sequence[Loop], gamma: float, frequency: float) -> Figure:
    """Paper Fig. 3: normalised force history and hysteresis loop at ``gamma`` (g),
    ``frequency`` (Hz); solid line for the first loop, dashed for the others."""
    fig = Figure(figsize=(10, 4), layout="constrained")
    axs = fig.subplots(1, 2)
    for k, loop in enumerate(loops):
        style = "-" if k == 0 else "--"
        axs[0].plot(loop.time, loop.y, style, lw=1, label=loop.label)
        axs[1].plot(loop.x, loop.y, style, lw=1, label=loop.label)
    axs[0].set_xlabel("time [s]")
    axs[0].set_ylabel(r"$f_S / (m_l a \Omega^2)$")
    axs[1].set_xlabel("w / a")
    axs[1].set_ylabel(r"$f_S / (m_l a \Omega^2)$")
    axs[1].legend()
    fig.suptitle(f"sloshing force at {gamma:g} g, {frequency:g} Hz (paper Fig. 3)")
    return fig
