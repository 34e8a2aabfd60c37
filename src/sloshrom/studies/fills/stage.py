"""The ``fills`` stage of `sloshrom reproduce --beyond`: one ROM for every fill level.

The paper's closing open problem, "include different filling levels in the training process":
ROMs identified at the ``[beyond] fills`` (the main ROM at the ``[tank]`` fill, the others by
the same ``data`` and ``rom`` stages with only the fill changed) form a
:class:`sloshrom.rom.family.FillFamily`, judged at fills none of them saw: its Phi_d map against
the rig's at that fill, and the first-mode damping of the sloshing beam (LSCF on H1) against
fill level for rig, family and frozen liquid. The members' model files are taken from the
records of their ``rom`` stages (:meth:`sloshrom.pipeline.cache.StageResult.output`).
"""

from __future__ import annotations

import time
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from sloshrom.beam.damping.columns import table2_rows
from sloshrom.beam.damping.registry import REFERENCE
from sloshrom.beam.damping.tables import mode1_damping_dataset
from sloshrom.beam.results import write_table
from sloshrom.beam.simulation.cases import simulate_cases
from sloshrom.beam.simulation.structure import coupled_frozen_modes
from sloshrom.config import FILL_TOLERANCE
from sloshrom.energy import map_fidelity
from sloshrom.fileio import OutputBatch, netcdf_writer
from sloshrom.models import FrozenLiquid
from sloshrom.pipeline.beam import beam_structure, beam_tests, coupled_models
from sloshrom.pipeline.cache import StageResult
from sloshrom.pipeline.context import Context
from sloshrom.pipeline.maps import compute_map
from sloshrom.pipeline.study import Identify
from sloshrom.plotting import savefig
from sloshrom.rom.family import write_family
from sloshrom.rom.loading import load_model
from sloshrom.studies.fills.config import FILL_TARGETS, member_config
from sloshrom.studies.fills.config import label as _pct
from sloshrom.studies.fills.figures import damping_fill_figure, fill_maps_figure
from sloshrom.studies.fills.outputs import FillsOutputs

__all__ = ["Identify", "model_file", "stage_fills"]

def model_file(rom: StageResult) -> Path:
    """The model file of a ``rom`` stage, as its record lists it."""
    return rom.output(rom.outputs["model"])


def stage_fills(ctx: Context, rom: StageResult, identify: Identify
                ) -> tuple[dict[str, Any], list[str]]:
    """Identify the family, map it at trained and unseen fills, run the beam across fills.

    Parameters
    ----------
    ctx : Context
    rom : StageResult
        The ``rom`` stage of the main ROM (identified at the ``[tank]`` fill).
    identify : callable
        ``identify(ctx) -> stage results`` (:func:`sloshrom.pipeline.chain.identify`): runs the
        cached ``data`` and ``rom`` stages of a member in its own directory
        ``fills/fill_<pct>/``.

    Returns
    -------
    outputs : dict
        The record of :class:`~sloshrom.studies.fills.outputs.FillsOutputs`: ``family`` (the
        manifest), ``members`` (fill -> model file, training seconds, whether reused,
        validation fit and, for an ensemble, its members' validation MSE), ``maps`` (one row
        per fill: ``fill``, ``unseen``, the :func:`sloshrom.energy.map_fidelity` figures of
        the family's map against the rig's at that fill), ``damping`` (rows of case, fill,
        RMS level and the Table 2 estimators), ``beam_errors`` (per unseen beam fill and
        level: the family's first-mode damping relative to the rig's), ``targets`` and the
        wall times (s) of each part.
    files : list of str
        Relative to ``ctx.out``.
    """
    cfg, bey = ctx.cfg, ctx.cfg.beyond
    tank0 = ctx.tank
    fills = sorted(float(f) for f in bey.fills)
    unseen = sorted(float(f) for f in bey.unseen_fills)
    rom_path = model_file(rom)
    out: dict[str, Any] = {"fills": fills, "unseen_fills": unseen, "targets": FILL_TARGETS}
    timings: dict[str, float] = {}

    # -- the members -------------------------------------------------------------------------
    t0 = time.perf_counter()
    members: dict[float, Path] = {}
    info: dict[str, Any] = {}
    for k, f in enumerate(fills):
        if abs(f - tank0.fill) <= FILL_TOLERANCE:
            members[f] = rom_path
            info[_pct(f)] = {"model": ctx.rel(rom_path), "main_rom": True}
            continue
        ctx.progress("fills", k, len(fills), f"identifying the member at fill {_pct(f)} %")
        sub = Context(ctx.out / "fills" / f"fill_{_pct(f)}", member_config(cfg, f),
                      _relay(ctx, f))
        member = identify(sub)["rom"]
        members[f] = model_file(member)
        info[_pct(f)] = {"model": ctx.rel(members[f]), "main_rom": False,
                         "reused": member.reused,
                         "train_seconds": member.outputs["train_seconds"],
                         "val_fit": member.outputs["val_fit"],
                         # an ensemble at this fill ([beyond] fill_ensemble > 1): its members'
                         # validation MSE, as the main ROM's (N^2, spread), else None
                         "val_mse_members": member.outputs.get("val_mse_members")}
    timings["members"] = time.perf_counter() - t0
    out["members"] = info
    manifest = write_family(ctx.path("fills", "family.toml"), members)
    family = load_model(manifest)
    out["family"] = ctx.rel(manifest)

    # -- maps: trained and unseen fills ------------------------------------------------------
    t0 = time.perf_counter()
    map_fills = sorted(set(fills) | set(unseen))
    rig_maps, rom_maps, rows = {}, {}, []
    for k, f in enumerate(map_fills):
        ctx.progress("fills", k, len(map_fills), f"Phi_d maps at fill {_pct(f)} %")
        tank = tank0.replace(fill=f)
        rig_maps[f] = compute_map(ctx.rig(tank), cfg, tank)
        rom_maps[f] = compute_map(family.at(f), cfg, tank)
        fid = map_fidelity(rig_maps[f], rom_maps[f])
        rows.append({"fill": f, "unseen": f in unseen, **fid})
    timings["maps"] = time.perf_counter() - t0
    out["maps"] = rows

    # -- the beam across fills ---------------------------------------------------------------
    t0 = time.perf_counter()
    bcfg = cfg.beam
    fs = float(cfg.rig.fs)
    levels = list(bcfg.rms_g)
    tables: list[xr.Dataset] = []
    beam_fills = sorted(float(f) for f in bey.beam_fills)
    for k, f in enumerate(beam_fills):
        ctx.progress("fills", k, len(beam_fills), f"beam random tests at fill {_pct(f)} %")
        tank = tank0.replace(fill=f)
        _, modal = beam_structure(bcfg, tank)
        f1 = float(coupled_frozen_modes(modal, tank.liquid_mass)[0][0])
        models = {"frozen": FrozenLiquid(1.0 / fs), "rig": ctx.rig(tank), "rom": family.at(f)}
        # an ensemble member of the family member by member, as the beam stage couples it
        res = simulate_cases(coupled_models(models), beam_tests(bcfg, modal, tank, fs)["random"],
                             fs)
        t2 = mode1_damping_dataset(res, levels, f1, max_tank_acceleration=True)
        tables.append(t2.expand_dims(fill=[f]).assign_coords(f1_frozen_hz=("fill", [f1])))
    timings["beam"] = time.perf_counter() - t0
    # Table 2 over (fill, case, level, estimator); its rows (fill, f1_frozen_hz, case, rms_g,
    # ...) for the record and the file
    table = xr.concat(tables, dim="fill")
    damping = table2_rows(table)
    out["damping"] = damping
    out["beam_errors"] = _beam_errors(table, unseen)
    out["seconds"] = timings

    # -- files -------------------------------------------------------------------------------
    maps_ds = xr.Dataset({
        "phi_d_rig": xr.concat([rig_maps[f] for f in map_fills], dim="fill"),
        "phi_d_rom": xr.concat([rom_maps[f] for f in map_fills], dim="fill"),
    }).assign_coords(fill=("fill", map_fills))
    maps_ds["fill"].attrs = {"units": "1", "long_name": "fill level d/h"}
    shown = [*fills, *unseen[:1]]
    figs = {
        "fills_phi_d_maps": fill_maps_figure({f: rig_maps[f] for f in shown},
                                             {f: rom_maps[f] for f in shown}, unseen),
        "fills_damping": damping_fill_figure(table, levels, unseen),
    }
    with OutputBatch() as batch:
        batch.write(ctx.path("fills", "phi_d_maps.nc"), netcdf_writer(maps_ds))
        write_table(damping, ctx.out / "fills" / "damping_against_fill", batch)
        for name, fig in figs.items():
            savefig(fig, ctx.path("figures", f"{name}.png"), batch)
        files = [ctx.rel(manifest), *(ctx.rel(p) for p in batch.paths)]
    return FillsOutputs(**out).as_record(), files


def _relay(ctx: Context, fill: float):
    """A member's progress, shown on the ``fills`` bar (not on the main run's data/rom bars)."""
    def progress(stage: str, done: float, total: float, text: str) -> None:
        ctx.progress("fills", done, total, f"fill {_pct(fill)} %, {stage}: {text}")
    return progress


def _beam_errors(table: xr.Dataset, unseen: list[float]) -> list[dict[str, Any]]:
    """Per fill (unseen fills flagged) and level: family and frozen damping relative to rig
    (the reference estimator's, from Table 2 over ``(fill, case, level, estimator)``)."""
    out = []
    z = table["value"].sel(estimator=REFERENCE).transpose("fill", "case", "level")
    by = {(str(c), float(f), float(lv)): float(z.values[i, j, k])
          for i, f in enumerate(table.fill.values) for j, c in enumerate(table.case.values)
          for k, lv in enumerate(table.level.values)}
    for (_, f, level), rig in sorted(kv for kv in by.items() if kv[0][0] == "rig"):
        rom, frozen = by.get(("rom", f, level)), by.get(("frozen", f, level))
        rel = (rom / rig - 1.0) if rom is not None and np.isfinite(rom) and rig else float("nan")
        out.append({"fill": f, "unseen": any(abs(f - u) < 1e-9 for u in unseen),
                    "rms_g": level, "rig": rig, "rom": rom, "frozen": frozen,
                    "rom_vs_rig": rel})
    return out
