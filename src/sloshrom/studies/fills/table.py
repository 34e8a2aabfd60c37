"""The fill-level study's part of the configuration: its keys of ``[beyond]`` (``fills``,
``unseen_fills``, ``fill_ensemble``, ``beam_fills``: no table of its own; it runs whenever
``[beyond] enabled``), their defaults (``defaults.toml`` of this package) and checks: the fills
in order, the family's ensemble in a model file, and the fills the virtual rig runs at.

Declared to the settings as :data:`TABLE`.
"""

from __future__ import annotations

from importlib import resources
from typing import TYPE_CHECKING, Annotated

from pydantic import model_validator

from sloshrom.config import FILL_TOLERANCE, ConfigError
from sloshrom.pipeline.schema import StudyTable, Table, items, number

if TYPE_CHECKING:
    from sloshrom.pipeline.settings import ReproduceConfig

__all__ = ["FILL_KEYS", "TABLE", "FillKeys"]

Fill = Annotated[float, number(0.0, 1.0, lo_open=True, hi_open=True, what="a fill level d/h")]
Fills = Annotated[list[Fill], items("fill levels d/h in (0, 1)", distinct=True)]


class FillKeys(Table):
    """The study's keys of ``[beyond]``: the fills of the family's members, those no member
    saw, the networks per member, the fills of the beam tests."""

    fills: Fills
    unseen_fills: Fills
    fill_ensemble: Annotated[int, number(1, 20, integer=True, what="a number of networks")]
    beam_fills: Fills

    @model_validator(mode="after")
    def _inside(self) -> FillKeys:
        if len(self.fills) < 2:
            raise ConfigError(f"'beyond.fills' needs two fill levels at least (a family "
                              f"interpolates between them), got {self.fills}")
        lo, hi = min(self.fills), max(self.fills)
        seen = [u for u in self.unseen_fills
                if any(abs(u - f) <= FILL_TOLERANCE for f in self.fills)]
        if seen:
            raise ConfigError(
                f"'beyond.unseen_fills' {seen} {'is' if len(seen) == 1 else 'are'} also in "
                f"'beyond.fills' (within {FILL_TOLERANCE:g}): a member is identified there, so "
                "the report would call a trained fill unseen; give fills no member has")
        for key in ("unseen_fills", "beam_fills"):
            out = [f for f in getattr(self, key) if not lo <= f <= hi]
            if out:
                raise ConfigError(f"'beyond.{key}' {out} lie outside the trained fills "
                                  f"[{lo:g}, {hi:g}] ('beyond.fills'): the fill family does "
                                  "not extrapolate")
        return self


#: The keys of ``[beyond]`` that configure the study.
FILL_KEYS = tuple(FillKeys.model_fields)


def _check(cfg: ReproduceConfig) -> None:
    # a member of the family is an ensemble of the ROM: it must fit a model file as the ROM's
    if cfg.beyond.enabled:
        cfg.check_members("'beyond.fill_ensemble'", cfg.beyond.fill_ensemble)


def _rig_fills(cfg: ReproduceConfig) -> list[tuple[str, float]]:
    # the rig runs at every fill of the family, seen or not, and of the beam tests
    if not cfg.beyond.enabled:
        return []
    return [(f"beyond.{key}", float(f)) for key in ("fills", "unseen_fills", "beam_fills")
            for f in getattr(cfg.beyond, key)]


#: The study's part of the configuration, as the settings assemble it.
TABLE = StudyTable(
    defaults=(resources.files(__package__) / "defaults.toml").read_text(encoding="utf-8"),
    beyond=FillKeys, check=_check, rig_fills=_rig_fills)
