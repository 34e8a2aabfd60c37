"""Figures of the bouncing-ball baseline: map errors per frequency band.

Object-oriented matplotlib (a :class:`~matplotlib.figure.Figure` made directly, as
:mod:`sloshrom.plotting` does): no backend is selected. The ball's beam figures are those of
:mod:`sloshrom.plotting.beam`.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np
from matplotlib.figure import Figure

from sloshrom.studies.baseline.config import FREQUENCY_BANDS

__all__ = ["frequency_band_figure"]


def frequency_band_figure(errors: Mapping[str, Mapping[str, Mapping[str, Any]]]) -> Figure:
    """Bars of the full-map and dissipative-region errors per frequency band, one colour per
    model (``errors``: model ->
    :func:`~sloshrom.studies.baseline.stage.frequency_band_errors`)."""
    fig = Figure(figsize=(9, 3.6), layout="constrained")
    axes = fig.subplots(1, 2, sharey=True)
    models = list(errors)
    x = np.arange(len(FREQUENCY_BANDS))
    width = 0.8 / max(len(models), 1)
    for ax, key, title in ((axes[0], "full_l2", "whole map"),
                           (axes[1], "dissipative_l2", "dissipative region")):
        for j, model in enumerate(models):
            vals = [100 * errors[model][b][key] for b in FREQUENCY_BANDS]
            ax.bar(x + (j - (len(models) - 1) / 2) * width, vals, width, label=model)
        some = errors[models[0]] if models else {}
        ax.set_xticks(x, [f"{b}\n{some[b]['frequency_hz'][0]:.1f}-"
                          f"{some[b]['frequency_hz'][1]:.1f} Hz" if b in some else b
                          for b in FREQUENCY_BANDS])
        ax.set_title(f"Phi_d error vs rig: {title}")
    axes[0].set_ylabel("relative L2 error [%]")
    axes[0].legend()
    return fig
