"""The bouncing-ball baseline's part of the configuration: its table ``[baseline]`` (the ball's
identification, :class:`sloshrom.rom.ball.model.BouncingBall`'s arguments), its switch
``[beyond] baseline``, their defaults (``defaults.toml`` of this package) and checks.

Declared to the settings as :data:`TABLE`; the study reads its table with :func:`baseline_table`.
"""

from __future__ import annotations

import math
from importlib import resources
from typing import TYPE_CHECKING, Annotated, cast

from pydantic import model_validator

from sloshrom.config import ConfigError
from sloshrom.pipeline.schema import Says, Seed, StudyTable, Table, items, number

if TYPE_CHECKING:
    from sloshrom.pipeline.settings import ReproduceConfig

__all__ = ["TABLE", "BaselineSwitch", "BaselineTable", "baseline_table"]

BallFraction = Annotated[float, number(0.0, 1.0, lo_open=True, what="a mass fraction")]
BallRestitution = Annotated[float, number(0.0, 1.0, what="a coefficient of restitution")]
BallGap = Annotated[float, number(0.0, 10.0, lo_open=True, what="a gap / ullage factor")]


class BaselineTable(Table):
    """``[baseline]``: the bouncing ball's identification (``sloshrom.rom.ball.model``)."""

    mass_fraction: Annotated[list[BallFraction], items("mass fractions in (0, 1]", pair=True)]
    restitution: Annotated[list[BallRestitution], items("restitutions in [0, 1]", pair=True)]
    gap_factor: Annotated[list[BallGap], items("gap factors in (0, 10]", pair=True)]
    seed: Seed
    lowpass: Annotated[str | int | float,
                       Says('"input", "none" or a cutoff in Hz (a number > 0)')]
    n_substeps: Annotated[str | int, Says('"auto" or an integer >= 1')]
    maxiter: Annotated[int, number(1, 100_000, integer=True, what="an integer")]
    popsize: Annotated[int, number(2, 10_000, integer=True, what="an integer")]
    tol: Annotated[float, number(0.0, what="a relative tolerance")]

    @model_validator(mode="after")
    def _choices(self) -> BaselineTable:
        for key in ("mass_fraction", "restitution", "gap_factor"):
            lo, hi = getattr(self, key)
            if lo > hi:
                raise ConfigError(f"'baseline.{key}' bounds out of order: low {lo:g} > "
                                  f"high {hi:g}")
        if isinstance(self.lowpass, str) and self.lowpass not in ("input", "none") or (
                not isinstance(self.lowpass, str)
                and not (math.isfinite(self.lowpass) and self.lowpass > 0)):
            raise ConfigError(f"'baseline.lowpass' must be \"input\", \"none\" or a cutoff in "
                              f"Hz (a number > 0), got {self.lowpass!r}")
        if isinstance(self.n_substeps, str) and self.n_substeps != "auto" or (
                not isinstance(self.n_substeps, str) and self.n_substeps < 1):
            raise ConfigError(f"'baseline.n_substeps' must be \"auto\" or an integer >= 1, "
                              f"got {self.n_substeps!r}")
        return self


class BaselineSwitch(Table):
    """The study's key of ``[beyond]``: ``baseline``, its switch."""

    baseline: bool


def baseline_table(cfg: ReproduceConfig) -> BaselineTable:
    """The validated ``[baseline]`` table of ``cfg``."""
    return cast(BaselineTable, cfg.study_table("baseline"))


#: The study's part of the configuration, as the settings assemble it.
TABLE = StudyTable(
    defaults=(resources.files(__package__) / "defaults.toml").read_text(encoding="utf-8"),
    table="baseline", model=BaselineTable, beyond=BaselineSwitch, switch="baseline")
