"""The two-mode wing study as the pipeline runs it: its declaration, ``STUDY``.

Registered in :data:`sloshrom.pipeline.registry.STUDIES`: with ``[beyond] enabled`` and
``multimode``, the wing's own checks run before any stage; its stage has its own wing, records and
ROMs (no other stage's files) in ``multimode/``, and its section closes the studies in the report.
"""

from __future__ import annotations

from collections.abc import Mapping

from sloshrom.pipeline.cache import StageResult
from sloshrom.pipeline.context import Context
from sloshrom.pipeline.settings import ReproduceConfig
from sloshrom.pipeline.study import Identify, StageRecord, Study
from sloshrom.studies.multimode.config import cache_config, wing_design
from sloshrom.studies.multimode.section import multimode_section
from sloshrom.studies.multimode.stage import stage_multimode
from sloshrom.studies.multimode.table import TABLE, multimode_table

__all__ = ["STUDY"]


def _enabled(cfg: ReproduceConfig) -> bool:
    return cfg.beyond.enabled and cfg.beyond.multimode


def _check(cfg: ReproduceConfig) -> None:
    wing_design(multimode_table(cfg))  # a wing the study cannot build: ConfigError before any stage


def _run(ctx: Context, upstream: Mapping[str, StageResult], identify: Identify) -> StageRecord:
    return stage_multimode(ctx)


#: The study, as :func:`sloshrom.pipeline.study.registered` gives it to the pipeline.
STUDY = Study(name="multimode", enabled=_enabled, cache_config=cache_config, after=(),
              run=_run, section=multimode_section, check=_check, directories=("multimode/",),
              table=TABLE)
