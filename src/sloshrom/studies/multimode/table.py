"""The two-mode wing study's part of the configuration: its table ``[multimode]`` (the wing, the
random tests that judge the ROMs, the identification records, the ROM recipe), its switch
``[beyond] multimode``, their defaults (``defaults.toml`` of this package) and checks.

Declared to the settings as :data:`TABLE`; the study reads its table with
:func:`multimode_table`. The wing's own checks (those of
:class:`~sloshrom.beam.simulation.wing.WingDesign`) run before any stage
(``sloshrom.studies.multimode.config.wing_design``, the study's ``check``).
"""

from __future__ import annotations

from importlib import resources
from typing import TYPE_CHECKING, Annotated, cast

from pydantic import model_validator

from sloshrom.config import ConfigError
from sloshrom.limits import MAX_EPOCHS, Hidden
from sloshrom.pipeline.schema import Delays, Neurons, Seed, StudyTable, Table, items, number

if TYPE_CHECKING:
    from sloshrom.pipeline.settings import ReproduceConfig

__all__ = ["TABLE", "MultimodeSwitch", "MultimodeTable", "multimode_table"]

Positive = Annotated[float, number(0.0, lo_open=True, what="a positive number")]
PositiveInt = Annotated[int, number(1, integer=True, what="a positive integer")]
RmsLevels = Annotated[list[Positive], items("positive numbers")]


class MultimodeTable(Table):
    """``[multimode]``: the two-mode wing study (``sloshrom.studies.multimode``).

    The wing's own checks (``sloshrom.beam.simulation.wing.WingDesign``) run before any stage,
    in ``sloshrom.studies.multimode.config.wing_design``.
    """

    # the wing (sloshrom.beam.simulation.wing.WingDesign)
    span: float
    chord: float
    ea_chord_fraction: float
    mass_per_span: float
    cg_offset: float
    gyration_radius: float
    tank_offset: float
    f_bending: float
    f_torsion: float
    damping: list[float]
    stations: list[float]
    # random base excitation (the judge)
    rms_g: RmsLevels
    random_duration: Positive
    f0: Positive
    sigma: Positive
    random_seed: Seed
    rel_band: Annotated[float, number(0.0, 0.5, lo_open=True, hi_open=True,
                                      what="a relative band")]
    nperseg: PositiveInt
    lscf_tol_zeta: Annotated[float, number(0.0, 1.0, lo_open=True, hi_open=True,
                                           what="a damping tolerance")]
    tolerance: Positive
    # identification records (virtual rig)
    vfa_train_duration: Positive
    vfa_validation_duration: Positive
    vfa_train_seed: Seed
    vfa_validation_seed: Seed
    broadband_levels: RmsLevels
    broadband_piece_duration: Positive
    broadband_band: Annotated[float, number(1.0, lo_open=True, what="a frequency factor")]
    broadband_fade: Positive
    broadband_seed: Seed
    margin: Annotated[float, number(1.0, what="a factor over the frozen tests' tank motion")]
    rig_seed: Seed
    # the ROM recipe
    delays: Delays
    neurons: Neurons
    hidden: Hidden
    amplitude_weighting: Annotated[float, number(0.0, 100.0,
                                                 what="an amplitude floor in m/s (0 = off)")]
    passivity: Annotated[float, number(0.0, 1e6, what="a penalty weight (0 = off)")]
    cycle_energy: Annotated[float, number(0.0, 1e6, what="a loss weight (0 = off)")]
    max_epochs: Annotated[int, number(1, MAX_EPOCHS, integer=True, what="an integer")]
    rom_seed: Seed
    rom_workers: Annotated[int, number(1, 64, integer=True,
                                       what="a number of parallel trainings")]

    @model_validator(mode="after")
    def _pieces(self) -> MultimodeTable:
        if self.broadband_piece_duration <= 4 * self.broadband_fade:
            raise ConfigError("'multimode.broadband_piece_duration' must exceed four "
                              "'multimode.broadband_fade' (the validation pieces are half as "
                              "long)")
        return self


class MultimodeSwitch(Table):
    """The study's key of ``[beyond]``: ``multimode``, its switch."""

    multimode: bool


def multimode_table(cfg: ReproduceConfig) -> MultimodeTable:
    """The validated ``[multimode]`` table of ``cfg``."""
    return cast(MultimodeTable, cfg.study_table("multimode"))


#: The study's part of the configuration, as the settings assemble it.
TABLE = StudyTable(
    defaults=(resources.files(__package__) / "defaults.toml").read_text(encoding="utf-8"),
    table="multimode", model=MultimodeTable, beyond=MultimodeSwitch, switch="multimode")
