"""Figures of the excitation signals: VFA paths (paper Figs. 5, 7a), identification records
(Figs. 6, 7b) and the sloshing beam's random base excitation (Fig. 17)."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
from matplotlib.axes import Axes
from matplotlib.figure import Figure

from sloshrom.beam.damping.analysis import welch_psd
from sloshrom.config import G
from sloshrom.io import Record
from sloshrom.signals import VFA, gaussian_psd

__all__ = ["base_excitation_figure", "plot_vfa_paths", "record_io_figure", "vfa_paths_figure"]


def plot_vfa_paths(paths: VFA | Sequence[VFA], ax: Axes | None = None,
                   gammas: Sequence[float] = (1, 2, 3, 4, 5, 6),
                   max_points: int = 20000) -> Axes:
    """Plot VFA paths in the (omega_bar, a_bar) plane over the Gamma iso-lines (paper Fig. 5/7a).

    Parameters
    ----------
    paths : VFA or sequence of VFA
        The paths (``sloshrom.signals.vfa``).
    ax : matplotlib Axes, optional
        Where to draw; default: the axes of a new 6.4 x 4.4 in figure.
    gammas : sequence of float
        Iso-lines ``a_bar = Gamma / omega_bar^2`` to draw (Gamma in g).
    max_points : int
        Each path is decimated to at most this many points for drawing.

    Returns
    -------
    matplotlib.axes.Axes
    """
    if isinstance(paths, VFA):
        paths = [paths]
    if ax is None:
        ax = Figure(figsize=(6.4, 4.4), layout="constrained").subplots()
    wmax = max(float(np.max(p.omega_bar)) for p in paths) * 1.05
    amax = max(float(np.max(p.a_bar)) for p in paths) * 1.1
    ob = np.linspace(0.3, wmax, 400)
    last = -np.inf
    for gm in sorted(gammas):
        ax.plot(ob, gm / ob**2, color="0.6", lw=0.7, ls="--")
        ob_lab = np.sqrt(gm / (0.85 * amax))
        # a label only where it clears the last one: close iso-lines share a label
        if ob_lab < wmax and ob_lab - last > 0.06 * wmax:
            ax.text(ob_lab, 0.85 * amax, f" {gm:g} g", color="0.4", fontsize=8)
            last = ob_lab
    colors = {"train": "tab:blue", "validation": "tab:orange"}
    # one legend entry per record, with the lengths of its paths
    lengths: dict[str, list[str]] = {}
    for p in paths:
        lengths.setdefault(p.split, []).append(f"{p.time[-1]:.0f}")
    for p in paths:
        step = max(1, len(p.time) // max_points)
        first = p is next(q for q in paths if q.split == p.split)
        ax.plot(
            p.omega_bar[::step],
            p.a_bar[::step],
            lw=0.6,
            color=colors.get(p.split),
            label=f"{p.split} ({' + '.join(lengths[p.split])} s)" if first else None,
        )
    ax.set_xlim(0, wmax)
    ax.set_ylim(0, amax)
    ax.set_xlabel(r"$\bar\omega = \Omega/\sqrt{g/h}$")
    ax.set_ylabel(r"$\bar a = a/h$")
    ax.legend(loc="best", fontsize=8)
    return ax


def vfa_paths_figure(paths: Sequence[VFA]) -> Figure:
    """Paper Fig. 5/7a: the training and validation paths on one figure."""
    fig = Figure(figsize=(6.4, 4.4), layout="constrained")
    plot_vfa_paths(paths, ax=fig.subplots())
    return fig


def record_io_figure(rec: Record, split: str) -> Figure:
    """Paper Figs. 6, 7b: input (tank velocity, m/s) and output (dynamic force, N) of a record."""
    fig = Figure(figsize=(8, 5), layout="constrained")
    axs = fig.subplots(2, 1, sharex=True)
    axs[0].plot(rec.time, rec["velocity"], lw=0.4)
    axs[0].set_ylabel("velocity [m/s]")
    axs[1].plot(rec.time, rec["dynamic_force"], lw=0.4, color="C3")
    axs[1].set_ylabel(r"$\Delta f$ [N]")
    axs[1].set_xlabel("time [s]")
    axs[0].set_title(f"{split} record: input (tank velocity) and output (dynamic force)")
    return fig


def base_excitation_figure(res: dict[str, Any], levels: Sequence[float], f0: float,
                           sigma: float, fs: float) -> Figure:
    """Paper Fig. 17: the imposed base accelerations, time histories and Welch PSDs.

    Parameters
    ----------
    res : dict
        A random response (``sloshrom.beam.simulation.coupled.random_response``): ``time`` (s) and
        ``base_acceleration`` (m/s^2, one row per level).
    levels : sequence of float
        The RMS levels, g.
    f0, sigma : float
        Centre and standard deviation of the target Gaussian PSD (paper Eq. 8), Hz.
    fs : float
        Sampling rate of ``res``, Hz.

    Notes
    -----
    The dashed curves are the target spectrum of Eq. (8) scaled to each RMS level. The PSD axis
    is logarithmic, so that the lowest level reads as well as the others (the paper zooms on it
    in an inset).
    """
    a = np.asarray(res["base_acceleration"])
    t = np.asarray(res["time"])
    levels = list(levels)
    fig = Figure(figsize=(11, 4.2), layout="constrained")
    ax_t, ax_f = fig.subplots(1, 2)
    t0 = min(40.0, 0.5 * t[-1])
    sel = (t >= t0) & (t <= t0 + 2.0)
    for i, lv in enumerate(levels):
        ax_t.plot(t[sel], a[i][sel] / G, lw=0.7, label=f"{lv:g} g RMS")
    ax_t.set_xlabel("time [s]")
    ax_t.set_ylabel("base acceleration [g]")
    ax_t.set_title("(a) imposed base acceleration (2 s window)")
    ax_t.legend(fontsize=8)
    f, p = welch_psd(a / G, fs, nperseg=min(4096, a.shape[-1]))
    fmax = f0 + 5 * sigma
    for i, lv in enumerate(levels):
        ax_f.plot(f, p[i], lw=0.8, label=f"{lv:g} g RMS")
        ax_f.plot(f, gaussian_psd(f, f0, sigma, lv**2), "k--", lw=0.8)
    ax_f.set_xlim(0, fmax)
    ax_f.set_xlabel("frequency [Hz]")
    ax_f.set_ylabel("PSD [g²/Hz]")
    ax_f.set_title("(b) Welch PSD (Hann, 4096 samples); dashed: Eq. (8)")
    ax_f.legend(fontsize=8, loc="upper left")
    # on a log scale every level reads as well as the largest (the paper zooms on the lowest
    # in an inset, too small to read here)
    ax_f.set_yscale("log")
    top = float(np.max(p[:, f <= fmax]))
    ax_f.set_ylim(top * 1e-4, top * 3)
    return fig
