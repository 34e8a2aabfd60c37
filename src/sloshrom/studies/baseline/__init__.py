"""The bouncing-ball baseline: an equivalent mechanical model beside the ROM.

``config`` (the ``[baseline]`` table, the study's names), ``stage`` (the fit, the map, the beam
tests and the comparison: :func:`~sloshrom.studies.baseline.stage.stage_baseline`), ``outputs``
(:class:`~sloshrom.studies.baseline.outputs.BaselineOutputs`), ``section`` (the report
section), ``figures``, ``study`` (its declaration to the pipeline, ``STUDY``). The model
itself is :class:`sloshrom.rom.ball.model.BouncingBall`.
"""

from __future__ import annotations

from sloshrom.studies.baseline.config import CASE, FREQUENCY_BANDS
from sloshrom.studies.baseline.outputs import BaselineOutputs
from sloshrom.studies.baseline.section import baseline_section
from sloshrom.studies.baseline.stage import comparison_rows, frequency_band_errors, stage_baseline

__all__ = ["CASE", "FREQUENCY_BANDS", "BaselineOutputs", "baseline_section", "comparison_rows",
           "frequency_band_errors", "stage_baseline"]
