"""Figures of the force the structure feels: the free decay's dynamic force in its first
seconds (paper Fig. 20c) and the random tests' force statistics, each ROM curve beside the
rig's and the rig's twin run's (its input's gain changed by 0.1 %: the scale of what a
laboratory could confirm).

Each function returns ``{file stem: Figure}``; the stems are the result files' names.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np
from matplotlib.figure import Figure

from sloshrom.beam.damping.analysis import welch_psd
from sloshrom.config import G
from sloshrom.fidelity import impact_peaks, impact_threshold

__all__ = ["FORCE_FIGURES", "force_figures", "free_force_figure", "random_force_figure"]

FORCE_FIGURES = ("fig20c_dynamic_force_start", "force_statistics_random")
#: Highest frequency of the spectra, Hz.
F_MAX = 250.0
#: Welch segment of the force spectra, samples (0.5 Hz lines at 500 Hz: the impacts' broad
#: spectrum needs averages more than resolution).
NPERSEG = 1024


def free_force_figure(time: np.ndarray, forces: Mapping[str, np.ndarray], fs: float,
                      seconds: float = 2.0,
                      figures: Mapping[str, Mapping[str, float]] | None = None
                      ) -> dict[str, Figure]:
    """The free decay's dynamic force over its first ``seconds`` (paper Fig. 20c).

    Parameters
    ----------
    time : ndarray, shape (n,)
        s.
    forces : mapping
        Case ("rig", "rom", ...) -> dynamic force, N, shape (n,).
    fs : float
        Sample rate, Hz.
    seconds : float
        The window shown, s.
    figures : mapping, optional
        Case -> ``{"rms_ratio": ..., "fit": ...}`` against the rig over the window, said in the
        legend.
    """
    n = min(int(round(seconds * fs)) + 1, time.size)
    fig = Figure(figsize=(8, 3.4), layout="constrained")
    ax = fig.subplots()
    styles = {"rig": ("k", 0.9), "rom": ("tab:red", 0.9)}
    for case, f in forces.items():
        color, lw = styles.get(case, (None, 0.7))
        lab = case
        if figures and case in figures:
            fg = figures[case]
            lab = f"{case} (RMS {fg['rms_ratio']:.2f} of the rig's, fit {fg['fit']:.0f} %)"
        ax.plot(time[:n], np.asarray(f)[:n], color=color, lw=lw, label=lab)
    ax.set_xlabel("time [s]")
    ax.set_ylabel("dynamic force [N]")
    ax.set_title(f"Free decay: dynamic sloshing force, first {seconds:g} s (paper Fig. 20c)")
    ax.legend(fontsize=8, loc="lower right")
    return {"fig20c_dynamic_force_start": fig}


def random_force_figure(levels: Sequence[float], fs: float,
                        force: Mapping[str, np.ndarray],
                        tank_acceleration: Mapping[str, np.ndarray]) -> dict[str, Figure]:
    """The random tests' force statistics per level: Welch spectra of the dynamic force and of
    the tank acceleration up to 250 Hz, and the distribution of the force's impact peaks.

    Parameters
    ----------
    levels : sequence of float
        Base RMS of each test, g.
    fs : float
        Sample rate, Hz.
    force, tank_acceleration : mapping
        Case ("rig", "twin", "rom") -> signals, shape (levels, n): the dynamic force (N) and
        the tank acceleration (m/s^2).
    """
    n_lv = len(levels)
    fig = Figure(figsize=(11, 2.9 * n_lv), layout="constrained")
    axes = fig.subplots(n_lv, 3, squeeze=False)
    colors = {"rig": "k", "twin": "tab:gray", "rom": "tab:red"}
    for i, lv in enumerate(levels):
        ref = np.asarray(force["rig"])[i]
        thr = impact_threshold(ref)
        for case, f in force.items():
            x = np.asarray(f)[i]
            fr, p = welch_psd(x, fs, nperseg=min(NPERSEG, x.size))
            keep = (fr > 0) & (fr <= F_MAX)
            axes[i, 0].semilogy(fr[keep], p[keep], color=colors.get(case), lw=0.8, label=case)
            pk = np.sort(impact_peaks(x, fs, thr)[1])
            if pk.size:
                axes[i, 2].plot(pk, 1.0 - np.arange(pk.size) / pk.size, color=colors.get(case),
                                lw=0.9, drawstyle="steps-post",
                                label=f"{case}: {pk.size / (x.size / fs):.1f} impacts/s")
        for case, a in tank_acceleration.items():
            x = np.asarray(a)[i] / G
            fr, p = welch_psd(x, fs, nperseg=min(NPERSEG, x.size))
            keep = (fr > 0) & (fr <= F_MAX)
            axes[i, 1].semilogy(fr[keep], p[keep], color=colors.get(case), lw=0.8, label=case)
        axes[i, 0].set_ylabel(f"{lv:g} g: force PSD [N²/Hz]")
        axes[i, 1].set_ylabel("tank acc. PSD [g²/Hz]")
        axes[i, 2].set_ylabel("fraction of impacts ≥ peak")
        axes[i, 2].set_yscale("log")
        for ax in axes[i]:
            ax.legend(fontsize=7)
    for ax, lab in zip(axes[-1], ("frequency [Hz]", "frequency [Hz]",
                                  "impact peak, downward [N]"), strict=True):
        ax.set_xlabel(lab)
    fig.suptitle("Random tests: the force the structure feels (ROM beside the rig and its "
                 "twin run, input × 1.001)")
    return {"force_statistics_random": fig}


def force_figures(free: Mapping[str, Mapping[str, np.ndarray]] | None,
                  random: Mapping[str, Mapping[str, np.ndarray]] | None, levels: Sequence[float],
                  fs: float, free_figures: Mapping[str, Mapping[str, float]] | None = None
                  ) -> dict[str, Figure]:
    """Both figures from the beam stage's results (case -> result of ``beam.coupled``), those
    whose cases have forces."""
    out: dict[str, Figure] = {}
    if free and all("dynamic_force" in r for r in free.values()):
        t = np.asarray(next(iter(free.values()))["time"])
        out.update(free_force_figure(t, {c: r["dynamic_force"] for c, r in free.items()},
                                     fs, figures=free_figures))
    if random and "rig" in random and all("dynamic_force" in r for r in random.values()):
        out.update(random_force_figure(
            levels, fs, {c: np.atleast_2d(r["dynamic_force"]) for c, r in random.items()},
            {c: np.atleast_2d(r["tank_acceleration"]) for c, r in random.items()}))
    return out
