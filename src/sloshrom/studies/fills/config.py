"""Configuration of the fill-level study: the fill keys of ``[beyond]`` and each member's
configuration.

The keys (``fills``, ``unseen_fills``, ``fill_ensemble``, ``beam_fills``) stay in the
``[beyond]`` table, where configuration files have them; their domains, checks and defaults
are the study's own (:mod:`sloshrom.studies.fills.table`). The targets of the judgement are
the study's design, not settings.
"""

from __future__ import annotations

from typing import Any

from sloshrom.pipeline.settings import ReproduceConfig
from sloshrom.studies.fills.table import FILL_KEYS

__all__ = ["FILL_KEYS", "FILL_TARGETS", "cache_config", "label", "member_config"]

#: Targets of the unseen-fill judgement: full-map relative L2 error (-), passivity (points below
#: the passivity threshold), first-mode damping within this fraction of the rig's (-).
FILL_TARGETS = {"full_l2": 0.15, "n_nonpassive": 0, "damping": 0.15}


def label(fill: float) -> str:
    """``0.375`` -> ``"37.5"`` (directory and table labels, per cent)."""
    return f"{100 * fill:g}"


def cache_config(cfg: ReproduceConfig) -> dict[str, Any]:
    """What the stage's cache key depends on: every table a member's identification, the maps
    and the beam tests read, and the study's keys of ``[beyond]``."""
    bey = cfg.tables("beyond")["beyond"]
    return {**cfg.tables("tank", "rig", "data", "rom", "map", "beam"),
            "beyond": {k: bey[k] for k in FILL_KEYS}}


def member_config(cfg: ReproduceConfig, fill: float) -> ReproduceConfig:
    """The configuration of the member identified at ``fill``: the main one with only the fill
    (and the member's ensemble size, ``[beyond] fill_ensemble``) changed, no sweep."""
    return cfg.replace(tank={"fill": float(fill)},
                       rom={"ensemble": int(cfg.beyond.fill_ensemble), "sweep": False,
                            "compare": []})
