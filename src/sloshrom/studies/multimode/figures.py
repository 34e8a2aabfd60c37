"""Figures of the two-mode structure study: |H1| per mode and damping against base level.

Object-oriented matplotlib (a :class:`~matplotlib.figure.Figure` made directly, as
:mod:`sloshrom.plotting` does): no backend is selected; the stage saves them with
:func:`sloshrom.plotting.savefig`.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
from matplotlib.figure import Figure

__all__ = ["CASE_LABELS", "modal_damping_figure", "modal_frf_figure"]

#: legend (and report) label of each case of the study
CASE_LABELS = {"rig": "rig (reference)", "vfa_rom": "VFA-only ROM",
               "broadband_rom": "broadband ROM (velocity)",
               "broadband_acc_rom": "broadband ROM (acceleration)", "frozen": "frozen liquid"}
_COLOURS = {"rig": "k", "vfa_rom": "tab:orange", "broadband_rom": "tab:blue",
            "broadband_acc_rom": "tab:green", "frozen": "tab:gray"}


def modal_frf_figure(h1: Mapping[str, Any], levels: list[float], f_modes: np.ndarray,
                     rel_band: float) -> Figure:
    """|H1| base -> modal acceleration, rows = levels, columns = modes, one curve per case."""
    n_l, n_m = len(levels), len(f_modes)
    fig = Figure(figsize=(4.2 * n_m, 2.4 * n_l + 0.6))
    axes = fig.subplots(n_l, n_m, squeeze=False)
    for i, level in enumerate(levels):
        for k, fk in enumerate(f_modes):
            ax = axes[i, k]
            for case, (f, hs) in h1.items():
                sel = (f >= fk * (1 - rel_band)) & (f <= fk * (1 + rel_band))
                ax.semilogy(f[sel], np.abs(hs[i][k][sel]), color=_COLOURS[case], lw=1.0,
                            label=CASE_LABELS[case])
            ax.set_title(f"mode {k + 1} ({fk:.2f} Hz frozen), base {level:g} g RMS", fontsize=9)
            ax.set_ylabel("|H1| [-]")
    for ax in axes[-1]:
        ax.set_xlabel("frequency [Hz]")
    axes[0, 0].legend(fontsize=7)
    fig.tight_layout()
    return fig


def modal_damping_figure(rows: list[dict[str, Any]], levels: list[float], n_modes: int,
                         cases: Sequence[str], tolerance: float) -> Figure:
    """Damping ratio against base level, one panel per mode; the rig's +/- tolerance shaded."""
    fig = Figure(figsize=(4.2 * n_modes, 3.6))
    axes = fig.subplots(1, n_modes, squeeze=False)[0]
    for k, ax in enumerate(axes):
        for case in cases:
            z = [next(r["zeta"] for r in rows if r["case"] == case and r["mode"] == k + 1
                      and r["rms_g"] == lv) for lv in levels]
            ax.plot(levels, 100 * np.asarray(z), "o-", color=_COLOURS[case],
                    label=CASE_LABELS[case])
            if case == "rig":
                zr = 100 * np.asarray(z)
                ax.fill_between(levels, zr * (1 - tolerance), zr * (1 + tolerance), color="k",
                                alpha=0.1, label=f"rig ± {100 * tolerance:g} %")
        ax.set_title(f"mode {k + 1}")
        ax.set_xlabel("base acceleration [g RMS]")
        ax.set_ylabel("damping ratio [%]")
    axes[0].legend(fontsize=7)
    fig.tight_layout()
    return fig
