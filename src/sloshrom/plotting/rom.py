"""Figures of the ROM identification: sensitivity sweep (paper Fig. 8) and validation
(Fig. 10)."""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.figure import Figure

from sloshrom.plotting import savefig
from sloshrom.rom.registry import swept

__all__ = ["plot_sweep", "sweep_figure", "validation_figure"]

_STYLES = ("o-", "s--", "^:", "d-.")


def sweep_figure(rows: list[dict[str, Any]]) -> Figure:
    """Paper Fig. 8: score (mean of train and validation MSE, N^2) against neurons.

    ``rows`` as returned by ``sloshrom.rom.sweep.run_sweep``; unstable networks (infinite
    score) are marked with red crosses at the top of their line.
    """
    fig = Figure(figsize=(6.5, 4), layout="constrained")
    ax = fig.subplots()
    # one line style per class of the sweep, in the registry's order (the NFIR's solid)
    order = [mc.name for mc in swept()]
    groups: dict[tuple[str, int], list[dict[str, Any]]] = {}
    for r in rows:
        groups.setdefault((r["arch"], r["delays"]), []).append(r)
    for (arch, d), rs in sorted(groups.items()):
        rs = sorted(rs, key=lambda r: r["neurons"])
        x = [r["neurons"] for r in rs if math.isfinite(r["score"])]
        y = [r["score"] for r in rs if math.isfinite(r["score"])]
        style = _STYLES[order.index(arch) % len(_STYLES)] if arch in order else _STYLES[-1]
        ax.plot(x, y, style, label=f"{arch.upper()}, {d} delays")
        bad = [r["neurons"] for r in rs if not math.isfinite(r["score"])]
        if bad and y:
            ax.plot(bad, [max(y)] * len(bad), "rx", label=f"{arch.upper()} {d}: unstable")
    ax.set_yscale("log")
    ax.set_xlabel("hidden neurons")
    ax.set_ylabel(r"mean(train, validation) MSE [N$^2$]")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    return fig


def plot_sweep(rows: list[dict[str, Any]], path: str | Path) -> Path:
    """Write paper Fig. 8 (:func:`sweep_figure`) to the PNG file ``path``; return ``path``."""
    return savefig(sweep_figure(rows), path)


def validation_figure(time: np.ndarray, y: np.ndarray, y_hat: np.ndarray, name: str,
                      fs: float, fit: float, nrmse: float,
                      compare: Sequence[tuple[np.ndarray, str, float]] = ()) -> Figure:
    """Paper Fig. 10: free-run prediction against the measured dynamic force (N).

    Top: the whole validation record as the force's RMS over 1 s windows; bottom: the
    waveform over one second around its largest force.
    ``fit`` (%) and ``nrmse`` (-) go into the title; ``fs`` (Hz) is the record's rate.
    ``compare``: other models' predictions (N), each with its name and its fit (%), drawn as
    thin traces labelled with their fits (the paper's NFIR and the best linear model beside a
    state-space ROM).
    """
    fig = Figure(figsize=(9, 6), layout="constrained")
    axs = fig.subplots(2, 1, height_ratios=(1, 1.3))
    labels = [f"{other_name} (fit {other_fit:.1f} %)" for _, other_name, other_fit in compare]
    # the whole record as the force's RMS over 1 s windows: the raw traces of 500 s are a
    # solid blob at this width; the bottom panel shows the waveform
    n = max(1, int(round(fs)))
    t_rms = time[: len(time) // n * n].reshape(-1, n).mean(axis=1)

    def rms(x: np.ndarray) -> np.ndarray:
        return np.sqrt((x[: len(x) // n * n].reshape(-1, n) ** 2).mean(axis=1))

    axs[0].plot(t_rms, rms(y), "k", lw=1.2, label="rig (validation)")
    axs[0].plot(t_rms, rms(y_hat), "r--", lw=1.0, label=name)
    for k, ((other, _, _), label) in enumerate(zip(compare, labels, strict=True)):
        axs[0].plot(t_rms, rms(other), color=f"C{k}", lw=0.8, label=label)
    axs[0].set_xlabel("time [s]")
    axs[0].set_ylabel(r"$\Delta f$ RMS over 1 s [N]")
    # beside other models, the title says whose fit it gives
    axs[0].set_title(f"validation{f' of {name}' if compare else ''}: fit {fit:.1f} %, "
                     f"NRMSE {nrmse:.3f}")
    fig.legend(*axs[0].get_legend_handles_labels(), loc="outside lower center",
               ncol=min(4, 2 + len(compare)), fontsize=8)
    i0 = int(np.argmax(np.abs(y)))
    sl = slice(max(0, i0 - int(0.5 * fs)), i0 + int(0.5 * fs))
    axs[1].plot(time[sl], y[sl], "k", lw=1, label="rig")
    axs[1].plot(time[sl], y_hat[sl], "r--", lw=1, label=name)
    for k, ((other, _, _), label) in enumerate(zip(compare, labels, strict=True)):
        axs[1].plot(time[sl], other[sl], color=f"C{k}", lw=0.6, label=label)
    axs[1].set_xlabel("time [s]")
    axs[1].set_ylabel(r"$\Delta f$ [N]")
    return fig
