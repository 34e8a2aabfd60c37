"""The bouncing-ball baseline as the pipeline runs it: its declaration, ``STUDY``.

Registered in :data:`sloshrom.pipeline.registry.STUDIES`: with ``[beyond] enabled`` and
``baseline``, its stage runs after the paper's four (it reads their records: the training data, the
ROM, the maps and the beam tests) and its section follows the beam's in the report.
"""

from __future__ import annotations

from collections.abc import Mapping

from sloshrom.pipeline.cache import StageResult
from sloshrom.pipeline.context import Context
from sloshrom.pipeline.settings import ReproduceConfig
from sloshrom.pipeline.study import Identify, StageRecord, Study
from sloshrom.studies.baseline.config import cache_config
from sloshrom.studies.baseline.section import baseline_section
from sloshrom.studies.baseline.stage import stage_baseline
from sloshrom.studies.baseline.table import TABLE

__all__ = ["STUDY"]


def _enabled(cfg: ReproduceConfig) -> bool:
    return cfg.beyond.enabled and cfg.beyond.baseline


def _run(ctx: Context, upstream: Mapping[str, StageResult], identify: Identify) -> StageRecord:
    return stage_baseline(ctx, upstream["data"], upstream["rom"], upstream["maps"],
                          upstream["beam"])


#: The study, as :func:`sloshrom.pipeline.study.registered` gives it to the pipeline.
STUDY = Study(name="baseline", enabled=_enabled, cache_config=cache_config,
              after=("data", "rom", "maps", "beam"), run=_run, section=baseline_section,
              table=TABLE)
