"""The fill-level study: one ROM for every fill level, judged at fills no member saw.

``config`` (the fill keys of ``[beyond]``, a member's configuration, the targets), ``stage``
(:func:`~sloshrom.studies.fills.stage.stage_fills`), ``outputs``
(:class:`~sloshrom.studies.fills.outputs.FillsOutputs`), ``section`` (the report section),
``figures``, ``study`` (its declaration to the pipeline, ``STUDY``). The family itself, a
model combinator, is :mod:`sloshrom.rom.family`.
"""

from __future__ import annotations

from sloshrom.studies.fills.config import FILL_TARGETS, member_config
from sloshrom.studies.fills.outputs import FillsOutputs
from sloshrom.studies.fills.section import fills_section
from sloshrom.studies.fills.stage import stage_fills

__all__ = ["FILL_TARGETS", "FillsOutputs", "fills_section", "member_config", "stage_fills"]
