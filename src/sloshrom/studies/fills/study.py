"""The fill-level study as the pipeline runs it: its declaration, ``STUDY``.

Registered in :data:`sloshrom.pipeline.registry.STUDIES`: with ``[beyond] enabled``, its stage runs
after the paper's ``data`` and ``rom`` (the main ROM is the member at the ``[tank]`` fill),
identifies the other members with the chain's ``identify`` in ``fills/`` and its section follows the
baseline's in the report.
"""

from __future__ import annotations

from collections.abc import Mapping

from sloshrom.pipeline.cache import StageResult
from sloshrom.pipeline.context import Context
from sloshrom.pipeline.settings import ReproduceConfig
from sloshrom.pipeline.study import Identify, StageRecord, Study
from sloshrom.studies.fills.config import cache_config
from sloshrom.studies.fills.section import fills_section
from sloshrom.studies.fills.stage import stage_fills
from sloshrom.studies.fills.table import TABLE

__all__ = ["STUDY"]


def _enabled(cfg: ReproduceConfig) -> bool:
    return cfg.beyond.enabled


def _run(ctx: Context, upstream: Mapping[str, StageResult], identify: Identify) -> StageRecord:
    return stage_fills(ctx, upstream["rom"], identify)


#: The study, as :func:`sloshrom.pipeline.study.registered` gives it to the pipeline.
STUDY = Study(name="fills", enabled=_enabled, cache_config=cache_config, after=("data", "rom"),
              run=_run, section=fills_section, directories=("fills/",), table=TABLE)
