"""`sloshrom reproduce`: the paper's whole workflow on the virtual rig, as resumable stages.

Stages (each cached in ``OUT/.stages``; a rerun reuses a finished stage whose configuration and
upstream stages did not change), one module each:

==========  ===========================================================================
``data``    VFA training/validation records from the virtual rig (paper Figs. 5–7), designed
            from the ``[beam]`` tests (``[data] design = "structure"``)
``sweep``   sensitivity analysis over delays x neurons (Fig. 8), on request (``[rom] sweep``)
``rom``     ROM identification (Fig. 10 validation)
``maps``    Phi_d maps of rig and ROM and their difference (Figs. 3, 4, 11)
``beam``    sloshing-beam free and random tests with rig, ROM and frozen liquid (Figs. 14–23)
==========  ===========================================================================

then each study beyond the paper that the configuration enables (``[beyond]``), in the order of
the registry (:func:`sloshrom.pipeline.study.registered`; today the bouncing-ball ``baseline``, the
``fills`` family and the two-mode ``multimode`` wing), each a stage as its
:class:`~sloshrom.pipeline.study.Study` declares it, and

``report``  ``OUT/report.html`` and ``OUT/summary.json``

This module only orders the stages and caches them; the stages do the I/O and the figures, the
numerical work stays in the library modules they call. A stage gets the results of the stages
before it (:class:`~sloshrom.pipeline.cache.StageResult`) and finds their files in their records.
It imports no study: it runs what the registry declares.
"""

from __future__ import annotations

import functools
import json
import time
import warnings
from collections.abc import Callable
from pathlib import Path
from typing import Any

from sloshrom import __version__
from sloshrom.errors import Note
from sloshrom.fileio import atomic_write_text, complete_commits, folder_lock
from sloshrom.pipeline import study as registry
from sloshrom.pipeline.beam import stage_beam
from sloshrom.pipeline.cache import StageCache, StageResult
from sloshrom.pipeline.context import (
    Context,
    Progress,
    StageEvents,
    check_rig_tanks,
    no_events,
    quiet,
)
from sloshrom.pipeline.data import stage_data
from sloshrom.pipeline.maps import stage_maps
from sloshrom.pipeline.report import write_report
from sloshrom.pipeline.rom import stage_rom, stage_sweep, sweep_keys
from sloshrom.pipeline.settings import ReproduceConfig, validate
from sloshrom.pipeline.study import StageRecord, Study
from sloshrom.rom.registry import CLASSES

__all__ = ["RESULT_ENTRIES", "identify", "run"]

#: What :func:`run` writes in its output directory: two files, the lock held while it runs
#: and the directories whose whole tree the stages own (a trailing ``/``). The command line
#: refuses an input (``--config``) that is one of them or lies inside one, before any work.
RESULT_ENTRIES = ("report.html", "summary.json", ".sloshrom.lock", ".stages/", "data/", "sweep/",
                  "models/", "maps/", "beam/", "figures/",
                  *(d for study in registry.registered() for d in study.directories))


def _stage(ctx: Context, cache: StageCache, name: str, config: object,
           depends: list[StageResult], func: Callable[[], StageRecord]) -> StageResult:
    """``cache.run`` of stage ``name``, timed in ``ctx.timings``; ``ctx.on_stage`` is told when
    it starts (only if it runs) and when it is done or reused."""

    def started() -> StageRecord:
        ctx.on_stage(name, "start", 0.0)
        return func()

    t0 = time.perf_counter()
    result = cache.run(name, config, depends, started, __version__)
    ctx.timings[name] = time.perf_counter() - t0
    ctx.on_stage(name, "reused" if result.reused else "done", ctx.timings[name])
    return result


def rom_stage_keys(rom: dict[str, Any]) -> dict[str, Any]:
    """The ``[rom]`` keys the rom stage's result depends on (its cache key): not the sweep's,
    and of the class tables only those of the ROM's class and of the compared ones."""
    used = {rom["arch"], *rom["compare"]}  # (the ROM's own class in compare is not trained)
    return {k: v for k, v in rom.items()
            if not k.startswith("sweep") and (k not in CLASSES or k in used)}


def identify(ctx: Context, cache: StageCache | None = None) -> dict[str, StageResult]:
    """The ``data`` (and ``sweep``, if asked) and ``rom`` stages in ``ctx.out``, cached.

    The identification part of :func:`run`, also used to identify ROMs at other fill levels
    (``beyond``). Returns the stage results by name.
    """
    cfg = ctx.cfg
    cache = cache if cache is not None else StageCache(ctx.out)
    results: dict[str, StageResult] = {}
    # a structure-designed training depends on the beam tests it is designed from
    data_tables = ("tank", "rig", "data") + (("beam",) if cfg.data.design != "shaker"
                                             else ())
    results["data"] = _stage(ctx, cache, "data", cfg.tables(*data_tables), [],
                             lambda: stage_data(ctx))
    rom = cfg.tables("rom")["rom"]
    if cfg.rom.sweep:
        results["sweep"] = _stage(ctx, cache, "sweep", sweep_keys(rom), [results["data"]],
                                  lambda: stage_sweep(ctx, results["data"]))
    results["rom"] = _stage(ctx, cache, "rom", rom_stage_keys(rom), [results["data"]],
                            lambda: stage_rom(ctx, results["data"]))
    return results


def run(out: str | Path, cfg: ReproduceConfig | dict[str, Any],
        progress: Progress = quiet, on_stage: StageEvents = no_events) -> dict[str, Any]:
    """Run every stage, reuse cached ones, write the report and the summary; return it.

    Parameters
    ----------
    out : str or Path
        Output directory (created).
    cfg : ReproduceConfig or dict
        The configuration (``sloshrom.pipeline.settings.load``), or a dict of tables built in
        code (validated here).
    progress : callable
        ``progress(stage, done, total, text)``, called as the stages advance.
    on_stage : callable
        ``on_stage(stage, event, seconds)`` as each stage starts, ends or is reused
        (:data:`~sloshrom.pipeline.context.StageEvents`), the report (``"report"``) too.

    Returns
    -------
    dict
        The summary written to ``OUT/summary.json``: ``sloshrom_version``, ``config`` (the
        dict form, :meth:`~sloshrom.pipeline.settings.ReproduceConfig.as_dict`),
        ``stages`` (per stage: ``reused`` and its outputs) and ``timings_s`` (s).

    Raises
    ------
    ConfigError
        The configuration is invalid (:func:`sloshrom.pipeline.settings.validate`) or names a
        tank the virtual rig cannot model (:func:`~sloshrom.pipeline.context.check_rig_tanks`)
        or that an enabled study's own check refuses (:attr:`~sloshrom.pipeline.study.Study.
        check`, e.g. a wing the two-mode study cannot build): one error naming the key, before
        any work and before anything is written.
    FolderBusyError
        Another live run holds ``OUT/.sloshrom.lock`` (:func:`sloshrom.fileio.folder_lock`):
        the message names its process id; nothing is written.
    """
    cfg = validate(cfg)
    check_rig_tanks(cfg)  # the tanks the rig runs at, before any stage or file
    studies = [s for s in registry.registered() if s.enabled(cfg)]
    for study in studies:  # the studies' own checks, before any stage
        study.check(cfg)
    ctx = Context(Path(out), cfg, progress, on_stage=on_stage)
    ctx.out.mkdir(parents=True, exist_ok=True)
    # one run per folder: a second one at once is refused with the first's process id
    with folder_lock(ctx.out / ".sloshrom.lock", what=f"--out {ctx.out}") as note:
        if note is not None:
            warnings.warn(note, Note, stacklevel=2)
        return _run_stages(ctx, cfg, studies)


def _run_stages(ctx: Context, cfg: ReproduceConfig, studies: list[Study]) -> dict[str, object]:
    """Every stage, then the report and the summary (the caller holds the folder's lock)."""
    # a batch whose commit a killed run left part-way: finished before anything is read
    complete_commits(ctx.out)
    cache = StageCache(ctx.out)
    results = identify(ctx, cache)
    rom = results["rom"]
    rom_path = rom.output(rom.outputs["model"])  # the model file, as the rom stage recorded it
    deps = [results["data"], results["rom"]]
    results["maps"] = _stage(ctx, cache, "maps", cfg.tables("tank", "rig", "map"), deps,
                             lambda: stage_maps(ctx, rom_path))
    results["beam"] = _stage(ctx, cache, "beam", cfg.tables("tank", "rig", "beam"), deps,
                             lambda: stage_beam(ctx, rom_path))

    for study in studies:
        # the upstream results in the order the study declares: the order of its cache key
        upstream = {name: results[name] for name in study.after}
        results[study.name] = _stage(ctx, cache, study.name, study.cache_config(cfg),
                                     list(upstream.values()),
                                     functools.partial(study.run, ctx, upstream, identify))

    summary: dict[str, object] = {
        "sloshrom_version": __version__,
        "config": cfg.as_dict(),
        "stages": {k: {"reused": r.reused, **r.outputs} for k, r in results.items()},
        "timings_s": ctx.timings,
    }
    # not a cached stage, and not in the timings the summary already holds: told, not timed
    ctx.on_stage("report", "start", 0.0)
    t0 = time.perf_counter()
    write_report(ctx, summary)
    atomic_write_text(ctx.out / "summary.json", json.dumps(summary, indent=1, default=float))
    ctx.on_stage("report", "done", time.perf_counter() - t0)
    return summary
