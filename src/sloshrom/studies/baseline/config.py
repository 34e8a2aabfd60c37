"""Configuration of the bouncing-ball baseline: the ``[baseline]`` table and the study's names.

The table's keys, defaults and checks (those of :class:`sloshrom.rom.ball.model.BouncingBall`)
are the study's own (:mod:`sloshrom.studies.baseline.table`, ``defaults.toml`` of this
package); :func:`ball_options` turns them into the
estimator's arguments (TOML has no ``None``: ``lowpass = "none"`` and ``n_substeps = "auto"``
stand for it, as in the ball's model file).
"""

from __future__ import annotations

from typing import Any

from sloshrom.pipeline.settings import ReproduceConfig
from sloshrom.studies.baseline.table import baseline_table

__all__ = ["BALL_KEYS", "BALL_MODEL", "CASE", "FREQUENCY_BANDS", "ball_options", "cache_config"]

#: The keys of ``[baseline]``: the arguments of :class:`~sloshrom.rom.ball.model.BouncingBall`.
BALL_KEYS = ("mass_fraction", "restitution", "gap_factor", "seed", "lowpass", "n_substeps",
             "maxiter", "popsize", "tol")
#: The ball's model file, relative to the output directory.
BALL_MODEL = "models/bouncing_ball.toml"
#: The ball's case name in the beam results and tables.
CASE = "ball"
#: Names of the thirds of the omega_bar range of the map (low, mid, high frequencies).
FREQUENCY_BANDS = ("low", "mid", "high")


def ball_options(cfg: ReproduceConfig) -> dict[str, Any]:
    """The arguments of :class:`~sloshrom.rom.ball.model.BouncingBall` from ``[baseline]``:
    search bounds as pairs, ``"none"`` and ``"auto"`` as ``None``."""
    t = baseline_table(cfg)
    out: dict[str, Any] = {k: getattr(t, k) for k in BALL_KEYS}
    for key in ("mass_fraction", "restitution", "gap_factor"):
        out[key] = tuple(out[key])
    out["lowpass"] = None if out["lowpass"] == "none" else out["lowpass"]
    out["n_substeps"] = None if out["n_substeps"] == "auto" else out["n_substeps"]
    return out


def cache_config(cfg: ReproduceConfig) -> dict[str, Any]:
    """What the stage's cache key depends on: the tables its fit, map and beam tests read."""
    return cfg.tables("tank", "rig", "map", "beam", "baseline")
