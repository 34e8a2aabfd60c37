"""What a study beyond the paper declares to the pipeline: one :class:`Study`.

A study is a package under ``sloshrom.studies`` whose module ``study`` holds ``STUDY``, a
:class:`Study`, whose module ``table`` holds ``TABLE``, its part of the configuration (a
:class:`~sloshrom.pipeline.schema.StudyTable`, the same object as ``STUDY.table``), and whose
package is listed in :data:`sloshrom.pipeline.registry.STUDIES` (the registry);
:func:`registered` returns the declarations in that order. The settings assemble the
configuration from the tables, the chain runs each enabled study as a cached stage after the
paper's stages, the report adds its section after the beam's, and ``reproduce`` protects its
directories: the pipeline reads these declarations and imports no study by name.

This module is infrastructure both sides share: it names no study.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from functools import cache
from typing import Any

from sloshrom.pipeline.cache import StageResult
from sloshrom.pipeline.context import Context, StageRecord
from sloshrom.pipeline.html import Section
from sloshrom.pipeline.registry import STUDIES, study_tables
from sloshrom.pipeline.schema import StudyTable
from sloshrom.pipeline.settings import ReproduceConfig

__all__ = ["PAPER_STAGES", "Identify", "StageRecord", "Study", "no_check", "registered"]

#: The paper's stages a study may take the results of (:attr:`Study.after`), in the chain's
#: order; ``sweep`` runs only on request and is not offered.
PAPER_STAGES = ("data", "rom", "maps", "beam")

#: ``identify(ctx) -> stage results by name``: the cached ``data`` and ``rom`` stages of a run in
#: ``ctx.out`` (:func:`sloshrom.pipeline.chain.identify`), for a study that identifies ROMs of
#: its own (at other fill levels).
Identify = Callable[[Context], dict[str, StageResult]]

def no_check(cfg: ReproduceConfig) -> None:
    """A study without checks of its own beyond the settings' validation."""


@dataclass(frozen=True)
class Study:
    """A study beyond the paper, as the pipeline runs and reports it.

    Attributes
    ----------
    name : str
        Its stage's name: the cache record ``OUT/.stages/<name>``, its key in ``summary.json``
        (``stages``, ``timings_s``) and in the outputs :attr:`section` receives. Not one of the
        paper's stages' names.
    enabled : callable
        ``enabled(cfg) -> bool``: whether the run includes it (its switches of ``[beyond]``).
    cache_config : callable
        ``cache_config(cfg) -> JSON-able``: the part of the configuration its cache key hashes
        (with :attr:`after`'s keys and the package version). A change here redoes the stage of
        every earlier run.
    after : tuple of str
        The paper's stages (:data:`PAPER_STAGES`) whose results its stage takes, in the order
        their keys enter its cache key; empty for a study that reads no other stage's files.
    run : callable
        ``run(ctx, upstream, identify) -> (outputs, files)`` (:data:`StageRecord`): the stage.
        ``upstream`` maps each name of :attr:`after` to its
        :class:`~sloshrom.pipeline.cache.StageResult`; ``identify`` is :data:`Identify`.
    section : callable
        ``section(ctx, outputs) -> Section``: its section of the report, from its stage's
        outputs as ``summary.json`` holds them.
    check : callable
        ``check(cfg)``, run before any stage when the study is enabled: the checks the settings'
        validation cannot make (raises :class:`~sloshrom.config.ConfigError`).
    directories : tuple of str
        The directories of the output directory whose whole tree its stage owns, each with a
        trailing ``/`` (``reproduce`` refuses an input inside one).
    table : StudyTable or None
        Its part of the configuration (its module ``table``'s ``TABLE``: the settings read that
        one, this says it is the study's); ``None`` for a study without settings of its own.
    """

    name: str
    enabled: Callable[[ReproduceConfig], bool]
    cache_config: Callable[[ReproduceConfig], Any]
    after: tuple[str, ...]
    run: Callable[[Context, Mapping[str, StageResult], Identify], StageRecord]
    section: Callable[[Context, Mapping[str, Any]], Section]
    check: Callable[[ReproduceConfig], None] = no_check
    directories: tuple[str, ...] = ()
    table: StudyTable | None = None

    def __post_init__(self) -> None:
        # a declaration error is a programming error of the study, found at registration
        if self.name in PAPER_STAGES or self.name in ("sweep", "report"):
            raise TypeError(f"study {self.name!r}: the name of a paper's stage")
        unknown = [s for s in self.after if s not in PAPER_STAGES]
        if unknown:
            raise TypeError(f"study {self.name!r}: after {unknown}, not among {PAPER_STAGES}")
        bad = [d for d in self.directories if not d.endswith("/")]
        if bad:
            raise TypeError(f"study {self.name!r}: directories {bad} need a trailing '/'")


@cache
def registered() -> tuple[Study, ...]:
    """The registered studies (:data:`sloshrom.pipeline.registry.STUDIES`), in their order.

    Each study's modules are imported here, on the first call (they load what their stages
    need: JAX, xarray, matplotlib).

    Returns
    -------
    tuple of Study

    Raises
    ------
    TypeError
        A registered package without a ``STUDY``, one whose ``STUDY.table`` is not its
        ``TABLE``, or two studies of one name (a programming error of the registry).
    """
    out: list[Study] = []
    for package, table in zip(STUDIES, study_tables(), strict=True):
        study = getattr(importlib.import_module(f"{package}.study"), "STUDY", None)
        if not isinstance(study, Study):
            raise TypeError(f"{package}.study declares no STUDY (a sloshrom.pipeline.study.Study)")
        if study.table is not table:
            raise TypeError(f"{package}: STUDY.table is not the TABLE of {package}.table")
        if any(s.name == study.name for s in out):
            raise TypeError(f"{package}: a second study named {study.name!r}")
        out.append(study)
    return tuple(out)
