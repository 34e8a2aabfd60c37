"""Figures of the dissipated energy: Phi_d maps (paper Figs. 4, 11) and hysteresis loops
(Fig. 3)."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import xarray as xr
from matplotlib.axes import Axes
from matplotlib.figure import Figure

__all__ = ["Loop", "hysteresis_figure", "phi_d_map_figure", "plot_hysteresis", "plot_phi_d_map"]


def plot_phi_d_map(da: xr.DataArray, ax: Axes | None = None, levels: int = 15) -> Axes:
    """Contour map of Phi_d(omega_bar, a_bar) with the Gamma = 1 and Gamma = 4 iso-lines.

    Parameters
    ----------
    da : xarray.DataArray
        A map of ``sloshrom.energy.phi_d_map`` (dimensionless, dims ``omega_bar``, ``a_bar``).
    ax : matplotlib Axes, optional
        Where to draw; default: the axes of a new 6 x 4.5 in figure.
    levels : int
        Number of contour levels.

    Returns
    -------
    matplotlib.axes.Axes
    """
    if ax is None:
        ax = Figure(figsize=(6, 4.5)).subplots()
    ob = np.asarray(da.omega_bar)
    ab = np.asarray(da.a_bar)
    z = np.asarray(da.values).T
    cs = ax.contourf(ob, ab, np.ma.masked_invalid(z), levels=levels, cmap="Blues")
    ax.figure.colorbar(cs, ax=ax, label=r"$\Phi_d$")
    obf = np.linspace(ob.min(), ob.max(), 200)
    for gam, style in ((1.0, "--"), (4.0, "-")):
        ax.plot(obf, gam / obf**2, "k" + style, lw=1, label=rf"$\Gamma$ = {gam:g} g")
    ax.set_ylim(ab.min(), ab.max())
    ax.set_xlabel(r"$\bar\omega = \Omega/\sqrt{g/h}$")
    ax.set_ylabel(r"$\bar a = a/h$")
    ax.legend(loc="upper right", fontsize=8)
    return ax


def phi_d_map_figure(da: xr.DataArray, title: str) -> Figure:
    """A Phi_d map (:func:`plot_phi_d_map`) with a title, on its own 6.4 x 4.6 in figure."""
    fig = Figure(figsize=(6.4, 4.6), layout="constrained")
    ax = plot_phi_d_map(da, ax=fig.subplots())
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
