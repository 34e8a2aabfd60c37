"""The two-mode wing study: do ROMs predict the damping of a structure with two active modes?

``config`` (the ``[multimode]`` table and the study's cases), ``stage`` (the records, the three
ROMs, the random tests and their modal damping: :func:`~sloshrom.studies.multimode.stage.
stage_multimode`), ``outputs`` (:class:`~sloshrom.studies.multimode.outputs.MultimodeOutputs`),
``section`` (the report section), ``figures``, ``study`` (its declaration to the pipeline,
``STUDY``). The wing and its damping analysis are domain physics, in
:mod:`sloshrom.beam.simulation.wing` and :mod:`sloshrom.beam.damping.multimode`; the broadband
records' signal is
:func:`sloshrom.signals.broadband_acceleration`.
"""

from __future__ import annotations

from sloshrom.studies.multimode.config import CASES, JUDGED_ROM, ROM_INPUTS
from sloshrom.studies.multimode.outputs import MultimodeOutputs
from sloshrom.studies.multimode.section import multimode_section
from sloshrom.studies.multimode.stage import stage_multimode

__all__ = ["CASES", "JUDGED_ROM", "ROM_INPUTS", "MultimodeOutputs", "multimode_section",
           "stage_multimode"]
