"""Figures of the sloshing-beam tests: free response (paper Figs. 14, 16, 20, 21) and random
response (Figs. 18, 22, 23); a measurement against predictions (Figs. 21, 23 and Table 2 with
their intervals).

Each function returns ``{file stem: Figure}``; the stems are the result files' names.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
import xarray as xr
from matplotlib.axes import Axes
from matplotlib.figure import Figure
from numpy.typing import ArrayLike

from sloshrom.beam.compare import AnalysedTest, match_levels
from sloshrom.beam.damping.analysis import welch_psd
from sloshrom.beam.damping.registry import label
from sloshrom.beam.damping.tables import Mode1Decay, decay_floor
from sloshrom.beam.damping.uncertainty import FLOOR_FACTOR
from sloshrom.beam.simulation.structure import ModalModel
from sloshrom.config import G

__all__ = ["COMPARE_FIGURES", "FREE_FIGURES", "RANDOM_FIGURES", "comparison_figures",
           "damping_ylim", "free_figures", "mode_damping_figure", "mode_decay_figure",
           "random_figures", "random_window"]

FREE_FIGURES = ("fig14_station_accelerations", "fig16_modal_accelerations",
                "fig20_tank_interface_dynamic", "fig21_instantaneous_damping")
RANDOM_FIGURES = ("fig18_tank_acceleration", "fig22_tank_acceleration_window", "fig23_psd")



def _psd_axes(ax: Axes, title: str, f_max: float = 40.0) -> None:
    """A tank-acceleration PSD panel: 0-``f_max`` Hz, the y range from the lowest curve's
    floor inside it to above the peak (no curve clipped), labelled."""
    inside = []
    for ln in ax.get_lines():
        x, y = np.asarray(ln.get_xdata(), float), np.asarray(ln.get_ydata(), float)
        inside.append(y[(x > 0) & (x <= f_max)])
    top = max(float(np.max(y)) for y in inside if y.size)
    floor = min(float(np.min(y[y > 0])) for y in inside if np.any(y > 0))
    ax.set_ylim(max(floor / 2, top * 1e-9), top * 3)
    ax.set_xlim(0, f_max)
    ax.set_title(title)
    ax.set_xlabel("frequency [Hz]")
    ax.set_ylabel("PSD tank acc. [g²/Hz]")


def free_figures(res: Mapping[str, Mapping[str, Any]], modal: ModalModel | None,
                 decays: Mapping[str, Mode1Decay],
                 labels: Sequence[str] | None = None) -> dict[str, Figure]:
    """Figures of a free-response comparison between cases.

    Parameters
    ----------
    res : mapping
        Case -> free response (``sloshrom.beam.simulation.coupled.free_response``).
    modal : ModalModel or None
        The beam's modal model (station positions, number of modes); ``None`` for a structure
        known by its measured modes alone (no Fig. 16: no modal filtering).
    decays : mapping
        Case -> its first-mode analysis (``sloshrom.beam.damping.tables.mode1_decay``).
    labels : sequence of str, optional
        The stations' names in Fig. 14 (default their positions on ``modal``).

    Returns
    -------
    dict
        :data:`FREE_FIGURES` stem -> Figure (without Fig. 20, the forces, when a case has
        none: a measured test; without Fig. 16 when ``modal`` is ``None``).
    """
    figs = {}
    cases = list(res)
    # one panel per station, the cases overlaid: the difference sloshing makes is then seen
    # (a panel per case showed the same picture three times)
    n_st = min(res[c]["station_acceleration"].shape[-1] for c in cases)
    names = (list(labels) if labels is not None else
             [f"x = {x:.3f} m" for x in modal.stations] if modal is not None else
             [f"station {j + 1}" for j in range(n_st)])
    fig = Figure(figsize=(8, 1.7 * n_st + 0.8), layout="constrained")
    axes = fig.subplots(n_st, 1, sharex=True, squeeze=False)
    for j in range(n_st):
        ax = axes[j, 0]
        for k, case in enumerate(cases):
            r = res[case]
            ax.plot(r["time"], r["station_acceleration"][:, j] / G, lw=1.0 if k == 0 else 0.7,
                    alpha=0.9, ls=("-", "--", ":", "-.")[k % 4], label=case)
        ax.set_ylabel(f"{names[j]}\n[g]")
    axes[0, 0].legend(fontsize=7, ncol=len(cases), loc="upper right")
    axes[-1, 0].set_xlabel("time [s]")
    fig.suptitle("Station accelerations of the free response, the cases overlaid")
    figs["fig14_station_accelerations"] = fig

    if modal is not None:
        # fewer stations than modes: no modal filtering, one band-passed record per case
        n_q = min(modal.n_modes, *(decays[c].modal.shape[-1] for c in cases))
        fig = Figure(figsize=(8, 2.2 * n_q), layout="constrained")
        axes = fig.subplots(n_q, 1, sharex=True, squeeze=False)
        for n in range(n_q):
            # drawn so that none hides another: the rig solid and wide, the others thinner
            # and dashed on top
            for k, case in enumerate(cases):
                axes[n, 0].plot(res[case]["time"], decays[case].modal[:, n],
                                lw=1.4 if k == 0 else 0.8, alpha=0.9,
                                ls=("-", "--", ":", "-.")[k % 4], label=case)
            axes[n, 0].set_ylabel(rf"$\ddot q_{{{n + 1}}}$ [m/s²]")
        axes[0, 0].legend(fontsize=8)
        axes[-1, 0].set_xlabel("time [s]")
        fig.suptitle("Modal accelerations (modal filtering of the station accelerations)")
        figs["fig16_modal_accelerations"] = fig

    if all("interface_force" in res[c] for c in cases):  # a measured test has no forces
        fig = Figure(figsize=(8, 7), layout="constrained")
        axes = fig.subplots(3, 1, sharex=True)
        for case in cases:
            r = res[case]
            axes[0].plot(r["time"], r["tank_acceleration"] / G, lw=0.6, label=case)
            axes[1].plot(r["time"], r["interface_force"], lw=0.6, label=case)
            axes[2].plot(r["time"], r["dynamic_force"], lw=0.6, label=case)
        for ax, lab in zip(axes, ("tank acc. [g]", "interface force [N]", "dynamic force [N]"),
                           strict=True):
            ax.set_ylabel(lab)
        axes[0].legend(fontsize=8)
        axes[-1].set_xlabel("time [s]")
        figs["fig20_tank_interface_dynamic"] = fig

    fig = Figure(figsize=(7, 4.5), layout="constrained")
    ax = fig.subplots()
    zs, amps, floors, n_faint = [], [], [], 0
    for case in cases:
        h, ld = decays[case].hilbert, decays[case].log_decrement
        f = float(np.median(h["frequency"])) if len(h["frequency"]) else float("nan")
        floor = decay_floor(res[case], f) / G if np.isfinite(f) else float("nan")
        least = FLOOR_FACTOR * floor if np.isfinite(floor) else -np.inf
        ah, al = h["amplitude"] / G, ld["amplitude"] / G
        zh, zl = 100 * np.where(ah >= least, h["zeta"], np.nan), 100 * ld["zeta"]
        line, = ax.plot(ah, zh, lw=1.0, label=f"{case} (Hilbert)")
        ax.plot(al[al >= least], zl[al >= least], "o", ms=3, color=line.get_color(),
                label=f"{case} (log decrement)")
        # below the noise floor: drawn faintly, no part of the scale
        ax.plot(al[al < least], zl[al < least], "o", ms=2, color=line.get_color(), alpha=0.25)
        n_faint += int(np.count_nonzero(al < least))
        zs += [zh, np.where(al >= least, zl, np.nan)]
        amps += [ah, al]
        if np.isfinite(floor):
            ax.axvline(least, color=line.get_color(), lw=0.6, ls=":")
            floors.append(least)
    lim = damping_ylim(zs, amps, None)
    if lim is not None:
        ax.set_ylim(*lim)
    ax.set_xlabel("tank acceleration amplitude [g]")
    ax.set_ylabel("first-mode damping ratio [%]")
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3)
    # the title names only what the axes show
    lo, hi = ax.get_xlim()
    shown = [f"dotted: {FLOOR_FACTOR:g} × the noise floor"] if any(
        lo <= x <= hi for x in floors) else []
    if n_faint and shown:
        shown.append("faint points below it do not set the scale")
    ax.set_title("; ".join(shown) or "first-mode instantaneous damping", fontsize=8)
    figs["fig21_instantaneous_damping"] = fig
    return figs


def damping_ylim(zeta: Sequence[ArrayLike], amplitude: Sequence[ArrayLike],
                 floor: float | None = None) -> tuple[float, float] | None:
    """Damping-axis limits of Fig. 21 (unit of ``zeta``) from the points that carry
    information.

    The points (arrays of damping ratios and their amplitudes, one pair per series) whose
    amplitude is at least ``FLOOR_FACTOR * floor`` (``floor`` in the amplitudes' unit; all
    points without one), their 2nd to 98th percentiles weighted by the squared amplitude (the
    noise scatters a damping estimate as 1 / amplitude), padded by 15 % of the range: the
    scatter at the end of a decay, in the noise, does not set the scale, even where the floor
    is not known. ``None`` without any finite point.
    """
    least = FLOOR_FACTOR * floor if floor is not None and np.isfinite(floor) else -np.inf
    z = np.concatenate([np.ravel(np.asarray(v, float)) for v in zeta] or [np.zeros(0)])
    a = np.concatenate([np.ravel(np.asarray(v, float)) for v in amplitude] or [np.zeros(0)])
    ok = np.isfinite(z) & np.isfinite(a) & (a >= least)
    z, w = z[ok], a[ok] ** 2
    if z.size == 0 or not w.sum() > 0:
        return None
    order = np.argsort(z)
    cw = np.cumsum(w[order]) / w.sum()
    lo, hi = np.interp([0.01, 0.99], cw, z[order])
    pad = 0.25 * max(hi - lo, 0.05 * abs(hi), 1e-12)
    return float(lo - pad), float(hi + pad)


def random_window(duration: float) -> tuple[float, float]:
    """The 2 s window (s) of Fig. 22: from 40 s, or from the middle of a shorter record."""
    return min(40.0, duration / 2), min(42.0, duration / 2 + 2)


def random_figures(res: Mapping[str, Mapping[str, Any]], levels: Sequence[float],
                   window: tuple[float, float] = (40, 42)) -> dict[str, Figure]:
    """Figures of a random-response comparison between cases.

    Parameters
    ----------
    res : mapping
        Case -> random response (``sloshrom.beam.simulation.coupled.random_response``), one row per
        level.
    levels : sequence of float
        The RMS base-acceleration levels, g.
    window : (float, float)
        Time window of Fig. 22, s (:func:`random_window`).

    Returns
    -------
    dict
        :data:`RANDOM_FIGURES` stem -> Figure. Fig. 18 shows the first sloshing case (not
        ``frozen``), Fig. 23 the Welch PSDs (8192 samples) on six decades below each peak.
    """
    figs = {}
    cases = list(res)
    slosh = [c for c in cases if c != "frozen"] or cases
    fig = Figure(figsize=(8, 2.3 * len(levels)), layout="constrained")
    axes = fig.subplots(len(levels), 1, sharex=True, squeeze=False)
    r = res[slosh[0]]
    for i, lv in enumerate(levels):
        axes[i, 0].plot(r["time"], r["tank_acceleration"][i] / G, lw=0.4)
        axes[i, 0].set_ylabel(f"{lv:g} g RMS\ntank acc. [g]")
    axes[-1, 0].set_xlabel("time [s]")
    fig.suptitle(f"Tank acceleration, {slosh[0]}")
    figs["fig18_tank_acceleration"] = fig

    fig = Figure(figsize=(8, 2.3 * len(levels)), layout="constrained")
    axes = fig.subplots(len(levels), 1, sharex=True, squeeze=False)
    for case in cases:
        r = res[case]
        sel = (r["time"] >= window[0]) & (r["time"] <= window[1])
        for i in range(len(levels)):
            axes[i, 0].plot(r["time"][sel], r["tank_acceleration"][i][sel] / G, lw=0.8,
                            label=case)
    for i, lv in enumerate(levels):
        axes[i, 0].set_ylabel(f"{lv:g} g RMS [g]")
    axes[0, 0].legend(fontsize=8)
    axes[-1, 0].set_xlabel("time [s]")
    figs["fig22_tank_acceleration_window"] = fig

    fig = Figure(figsize=(4 * len(levels), 3.8), layout="constrained")
    axes = fig.subplots(1, len(levels), squeeze=False)
    for case in cases:
        r = res[case]
        # in g, as every time plot of the tank acceleration
        f, p = welch_psd(r["tank_acceleration"] / G, r["fs"], nperseg=8192)
        for i in range(len(levels)):
            axes[0, i].semilogy(f, p[i], lw=0.8, label=case)
    for i, lv in enumerate(levels):
        _psd_axes(axes[0, i], f"{lv:g} g RMS")
    axes[0, 0].legend(fontsize=8)
    figs["fig23_psd"] = fig
    return figs


def mode_decay_figure(case: str, frequencies: Sequence[float],
                      decays: Sequence[Mode1Decay]) -> Figure:
    """Fig. 21 at every mode of a free decay: each mode's instantaneous damping (Hilbert, line;
    log decrement, dots) against its own amplitude at the tank, one panel per mode."""
    n = len(decays)
    fig = Figure(figsize=(7, 3.2 * n), layout="constrained")
    axes = fig.subplots(n, 1, squeeze=False)[:, 0]
    for k, (ax, f, d) in enumerate(zip(axes, frequencies, decays, strict=True)):
        h, ld = d.hilbert, d.log_decrement
        ax.plot(h["amplitude"] / G, 100 * h["zeta"], lw=1.0, color="C0", label="Hilbert")
        ax.plot(ld["amplitude"] / G, 100 * ld["zeta"], "o", ms=3, color="C0", alpha=0.6,
                label="log decrement")
        lim = damping_ylim([100 * h["zeta"], 100 * ld["zeta"]],
                           [h["amplitude"], ld["amplitude"]])
        if lim is not None:  # Fig. 21's scale: scattered points in the noise do not set it
            ax.set_ylim(*lim)
        ax.set_ylabel(f"mode {k + 1} damping [%]")
        ax.set_title(f"{case}: mode {k + 1}, {f:.4g} Hz", fontsize=9)
        ax.grid(alpha=0.3)
    axes[0].legend(fontsize=8)
    axes[-1].set_xlabel("the mode's amplitude at the tank [g]")
    return fig


def mode_damping_figure(damping: xr.Dataset) -> Figure:
    """Table 2 at every mode: damping ratio against RMS base level, one panel per mode, each
    estimator with its 95 % interval.

    ``damping`` is Table 2 over ``(mode, level, estimator)`` with the coordinate
    ``mode_frequency_Hz`` (Hz) along ``mode`` (``sloshrom.beam.lab.every_mode.
    random_mode_dataset``; levels in g).
    """
    modes = [int(m) for m in damping.mode.values]
    estimators = [str(e) for e in damping.estimator.values]
    fig = Figure(figsize=(7, 3.0 * len(modes)), layout="constrained")
    axes = fig.subplots(len(modes), 1, squeeze=False)[:, 0]
    g = np.array([float(x) for x in damping.level.values])
    for k, (ax, m) in enumerate(zip(axes, modes, strict=True)):
        d = damping.isel(mode=k)
        for j, est in enumerate(estimators):
            v, lo, hi = (np.asarray(d[var].sel(estimator=est).values, dtype=float)
                         for var in ("value", "low", "high"))
            x = g * (1 + 0.03 * (j - (len(estimators) - 1) / 2))
            err = np.where(np.isfinite(lo) & np.isfinite(hi),
                           np.stack([v - lo, hi - v]), 0.0)
            ax.errorbar(x, 100 * v, yerr=100 * err, fmt="o", ms=4, capsize=3,
                        label=label(est))
        ax.set_xscale("log")
        ax.set_xticks(g, [f"{x:g}" for x in g])
        ax.set_ylabel(f"mode {m} damping [%]")
        ax.set_title(f"mode {m}, {float(d['mode_frequency_Hz']):.4g} Hz", fontsize=9)
        ax.grid(alpha=0.3)
    axes[0].legend(fontsize=8)
    axes[-1].set_xlabel("RMS base acceleration [g]")
    return fig


#: Figures of ``sloshrom compare``: free decays / random tests.
COMPARE_FIGURES = {"free": ("fig21_comparison",),
                   "random": ("fig23_comparison", "table2_comparison")}


def comparison_figures(measured: AnalysedTest, predicted: Sequence[AnalysedTest]
                       ) -> dict[str, Figure]:
    """The measurement and the predictions in the paper's figures, with the intervals.

    Free decays (Fig. 21): first-mode instantaneous damping against tank acceleration amplitude,
    the measurement in black with its per-band 95 % intervals (Hilbert: boxes spanning the band;
    log decrement: error bars), each prediction's curve and band medians in colour. Random tests:
    the Welch PSDs of the tank acceleration per level (Fig. 23) and Table 2 as error bars
    (one panel per estimator of the measurement's Table 2 - by default LSCF on H1, output-only
    LSCF, half power -; the measurement first, each case beside it).

    Parameters
    ----------
    measured, predicted : AnalysedTest
        From :func:`sloshrom.beam.compare.analyse_test`.

    Returns
    -------
    dict
        :data:`COMPARE_FIGURES` stem -> Figure.
    """
    tests = [measured, *predicted]
    if measured.kind == "free":
        fig = Figure(figsize=(7.5, 4.8), layout="constrained")
        ax = fig.subplots()
        bands = {r["band"]: r for r in measured.rows if r["method"] == "hilbert"}
        for k, t in enumerate(tests):
            colour = "k" if k == 0 else f"C{k - 1}"
            assert t.decay is not None
            h = t.decay.hilbert
            # the measurement wide and on top, dashed predictions under it: a prediction that
            # agrees does not hide it
            ax.plot(h["amplitude"] / G, 100 * h["zeta"], lw=2.2 if k == 0 else 1.0,
                    ls="-" if k == 0 else "--", color=colour, alpha=0.6 if k == 0 else 1.0,
                    zorder=3 if k == 0 else 2, label=f"{t.case} (Hilbert)")
            for r in t.rows:
                lo_g, hi_g = (float(x) for x in r["band"].removesuffix(" g").split("-"))
                mid = 0.5 * (lo_g + hi_g) * (1 + 0.03 * (k - len(tests) / 2))
                if r["method"] == "log_decrement":
                    ax.errorbar(mid, 100 * r["zeta"],
                                yerr=[[100 * (r["zeta"] - r["low"])],
                                      [100 * (r["high"] - r["zeta"])]],
                                fmt="o", ms=3, color=colour, capsize=2)
        for band, r in bands.items():
            lo_g, hi_g = (float(x) for x in band.removesuffix(" g").split("-"))
            if np.isfinite(r["low"]) and np.isfinite(r["high"]):
                ax.fill_between([lo_g, hi_g], 100 * r["low"], 100 * r["high"], color="k",
                                alpha=0.12, lw=0)
        lim = damping_ylim([100 * t.decay.hilbert["zeta"] for t in tests if t.decay]
                           + [100 * t.decay.log_decrement["zeta"] for t in tests if t.decay],
                           [t.decay.hilbert["amplitude"] for t in tests if t.decay]
                           + [t.decay.log_decrement["amplitude"] for t in tests if t.decay])
        if lim is not None:
            ax.set_ylim(*lim)
        ax.set_xlabel("tank acceleration amplitude [g]")
        ax.set_ylabel("first-mode damping ratio [%]")
        ax.set_title(f"{measured.case}: grey boxes = 95 % intervals per band (Hilbert); "
                     "dots = log decrement", fontsize=9)
        ax.legend(fontsize=8)
        ax.grid(alpha=0.3)
        return {"fig21_comparison": fig}

    levels = measured.levels
    fig = Figure(figsize=(4 * len(levels), 3.8), layout="constrained")
    axes = fig.subplots(1, len(levels), squeeze=False)
    for k, t in enumerate(tests):
        assert t.psd is not None
        f, p = t.psd
        for i, lv in enumerate(levels):
            j = match_levels([lv], t.levels)[0]
            if j is not None:
                axes[0, i].semilogy(f, p[j] / G**2, lw=1.2 if k == 0 else 0.8,
                                    color="k" if k == 0 else f"C{k - 1}", label=t.case)
    for i, lv in enumerate(levels):
        _psd_axes(axes[0, i], f"{lv:.3g} g RMS")
    axes[0, 0].legend(fontsize=8)
    figs = {"fig23_comparison": fig}

    damping = [t.damping for t in tests]  # (level, estimator) datasets
    names = list(damping[0].estimator.values)
    fig = Figure(figsize=(4 * len(names), 3.8), layout="constrained")
    axes = fig.subplots(1, len(names), squeeze=False, sharey=True)
    width = 0.6 / max(len(tests), 1)
    for col, est in enumerate(names):
        ax = axes[0, col]
        for k, t in enumerate(tests):
            if est not in damping[k].estimator:
                continue
            d = damping[k].sel(estimator=est)
            for i, lv in enumerate(levels):
                j = match_levels([lv], t.levels)[0]
                if j is None:
                    continue
                z, lo, hi = (float(d[v][j]) for v in ("value", "low", "high"))
                err = ([[100 * (z - lo)], [100 * (hi - z)]]
                       if np.isfinite(lo) and np.isfinite(hi) else None)
                ax.errorbar(i + (k - (len(tests) - 1) / 2) * width, 100 * z, yerr=err,
                            fmt="s" if k == 0 else "o", ms=4, capsize=3,
                            color="k" if k == 0 else f"C{k - 1}",
                            label=t.case if i == 0 else None)
        ax.set_xticks(range(len(levels)), [f"{lv:.3g} g" for lv in levels])
        ax.set_title(str(damping[0].label.sel(estimator=est).values))
        ax.set_xlabel("RMS base acceleration [g]")
        ax.set_ylabel("first-mode damping [%]")
        ax.grid(alpha=0.3)
    fig.suptitle("First-mode damping with 95 % intervals")
    axes[0, 0].legend(fontsize=8)
    figs["table2_comparison"] = fig
    return figs
