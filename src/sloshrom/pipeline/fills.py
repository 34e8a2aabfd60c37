"""The ``fills`` stage of `sloshrom reproduce --beyond`: one ROM for every fill level.

The paper's closing open problem, "include different filling levels in the training process":
ROMs identified at the ``[beyond] fills`` (the main ROM at the ``[tank]`` fill, the others by
the same ``data`` and ``rom`` stages with only the fill changed) form a
:class:`sloshrom.rom.family.FillFamily`, judged at fills none of them saw: its Phi_d map against
the rig's at that fill, and the first-mode damping of the sloshing beam (LSCF on H1) against
fill level for rig, family and frozen liquid.
"""

from __future__ import annotations

import copy
import html
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from sloshrom.beam.results import mode1_damping_table, simulate_cases, write_table
from sloshrom.beam.structure import coupled_frozen_modes
from sloshrom.config import FILL_TOLERANCE
from sloshrom.energy import map_fidelity
from sloshrom.fileio import OutputBatch
from sloshrom.models import FrozenLiquid
from sloshrom.pipeline.beam import beam_structure, beam_tests
from sloshrom.pipeline.cache import StageResult
from sloshrom.pipeline.context import Context
from sloshrom.pipeline.html import Figure, Section, Table
from sloshrom.pipeline.maps import compute_map
from sloshrom.plotting import savefig
from sloshrom.plotting.fills import damping_fill_figure, fill_maps_figure
from sloshrom.rom.estimators import load_model
from sloshrom.rom.family import write_family

__all__ = ["FILL_TARGETS", "fills_section", "stage_fills"]

#: Targets of the unseen-fill judgement: full-map relative L2 error (-), passivity (points below
#: the passivity threshold), first-mode damping within this fraction of the rig's (-).
FILL_TARGETS = {"full_l2": 0.15, "n_nonpassive": 0, "damping": 0.15}

Identify = Callable[[Context], dict[str, StageResult]]


def _pct(fill: float) -> str:
    """``0.375`` -> ``"37.5"`` (directory and table labels)."""
    return f"{100 * fill:g}"


def member_config(cfg: dict[str, Any], fill: float) -> dict[str, Any]:
    """The configuration of the member identified at ``fill``: the main one with only the fill
    (and the member's ensemble size, ``[beyond] fill_ensemble``) changed, no sweep."""
    sub = copy.deepcopy(cfg)
    sub["tank"]["fill"] = float(fill)
    sub["rom"]["ensemble"] = int(cfg["beyond"]["fill_ensemble"])
    sub["rom"]["sweep"] = False
    return sub


def stage_fills(ctx: Context, rom_path: Path, identify: Identify
                ) -> tuple[dict[str, Any], list[str]]:
    """Identify the family, map it at trained and unseen fills, run the beam across fills.

    Parameters
    ----------
    ctx : Context
    rom_path : Path
        The main ROM (identified at the ``[tank]`` fill).
    identify : callable
        ``identify(ctx) -> stage results`` (:func:`sloshrom.pipeline.chain.identify`): runs the
        cached ``data`` and ``rom`` stages of a member in its own directory
        ``fills/fill_<pct>/``.

    Returns
    -------
    outputs : dict
        ``family`` (the manifest), ``members`` (fill -> model file, training seconds, whether
        reused), ``maps`` (one row per fill: ``fill``, ``unseen``, the
        :func:`sloshrom.energy.map_fidelity` figures of the family's map against the rig's at
        that fill), ``damping`` (rows of case, fill, RMS level and the Table 2 estimators),
        ``beam_errors`` (per unseen beam fill and level: the family's first-mode damping
        relative to the rig's), ``targets`` and the wall times (s) of each part.
    files : list of str
        Relative to ``ctx.out``.
    """
    cfg, bey = ctx.cfg, ctx.cfg["beyond"]
    tank0 = ctx.tank
    fills = sorted(float(f) for f in bey["fills"])
    unseen = sorted(float(f) for f in bey["unseen_fills"])
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
        res = identify(sub)
        rom = res["rom"]
        members[f] = sub.out / rom.outputs["model"]
        info[_pct(f)] = {"model": ctx.rel(members[f]), "main_rom": False,
                         "reused": rom.reused, "train_seconds": rom.outputs["train_seconds"],
                         "val_fit": rom.outputs["val_fit"]}
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
    bcfg = cfg["beam"]
    fs = float(cfg["rig"]["fs"])
    levels = list(bcfg["rms_g"])
    damping: list[dict[str, Any]] = []
    beam_fills = sorted(float(f) for f in bey["beam_fills"])
    for k, f in enumerate(beam_fills):
        ctx.progress("fills", k, len(beam_fills), f"beam random tests at fill {_pct(f)} %")
        tank = tank0.replace(fill=f)
        _, modal = beam_structure(bcfg, tank)
        f1 = float(coupled_frozen_modes(modal, tank.liquid_mass)[0][0])
        models = {"frozen": FrozenLiquid(1.0 / fs), "rig": ctx.rig(tank), "rom": family.at(f)}
        res = simulate_cases(models, beam_tests(bcfg, modal, tank, fs)["random"], fs)
        for row in mode1_damping_table(res, levels, f1, max_tank_acceleration=True):
            damping.append({"fill": f, "f1_frozen_hz": f1, **row})
    timings["beam"] = time.perf_counter() - t0
    out["damping"] = damping
    out["beam_errors"] = _beam_errors(damping, unseen)
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
        "fills_damping": damping_fill_figure(damping, levels, unseen),
    }
    with OutputBatch() as batch:
        batch.write(ctx.path("fills", "phi_d_maps.nc"),
                    lambda tmp: maps_ds.to_netcdf(tmp, engine="h5netcdf"))
        write_table(damping, ctx.out / "fills" / "damping_against_fill", batch)
        for name, fig in figs.items():
            savefig(fig, ctx.path("figures", f"{name}.png"), batch)
        files = [ctx.rel(manifest), *(ctx.rel(p) for p in batch.paths)]
    return out, files


def _relay(ctx: Context, fill: float):
    """A member's progress, shown on the ``fills`` bar (not on the main run's data/rom bars)."""
    def progress(stage: str, done: float, total: float, text: str) -> None:
        ctx.progress("fills", done, total, f"fill {_pct(fill)} %, {stage}: {text}")
    return progress


def _beam_errors(rows: list[dict[str, Any]], unseen: list[float]) -> list[dict[str, Any]]:
    """Per fill (unseen fills flagged) and level: family and frozen damping relative to rig."""
    out = []
    by = {(r["case"], r["fill"], r["rms_g"]): r["lscf_h1"] for r in rows}
    for (_, f, level), rig in sorted(kv for kv in by.items() if kv[0][0] == "rig"):
        rom, frozen = by.get(("rom", f, level)), by.get(("frozen", f, level))
        rel = (rom / rig - 1.0) if rom is not None and np.isfinite(rom) and rig else float("nan")
        out.append({"fill": f, "unseen": any(abs(f - u) < 1e-9 for u in unseen),
                    "rms_g": level, "rig": rig, "rom": rom, "frozen": frozen,
                    "rom_vs_rig": rel})
    return out


def _fmt(v: Any, scale: float = 100.0, fmt: str = "{:.2f}") -> str:
    try:
        x = float(v)
    except (TypeError, ValueError):
        return "n/a"
    return fmt.format(scale * x) if np.isfinite(x) else "n/a"


def fills_section(ctx: Context, o: dict[str, Any]) -> Section:
    """The report section of the fill-level study."""
    t = o["targets"]
    map_rows = [[f"{_pct(r['fill'])} %" + (" (unseen)" if r["unseen"] else ""),
                 _fmt(r["full_l2"]), _fmt(r["dissipative_l2"]),
                 f"{r['n_nonpassive']} ({_fmt(r['nonpassive_fraction'], fmt='{:.1f}')} %)",
                 "ok" if (r["full_l2"] <= t["full_l2"] and r["n_nonpassive"] == 0)
                 else "MISS" if r["unseen"] else ""]
                for r in o["maps"]]
    beam_rows = [[f"{_pct(r['fill'])} %" + (" (unseen)" if r["unseen"] else ""),
                  f"{r['rms_g']:g}", _fmt(r["rig"]), _fmt(r["rom"]), _fmt(r["frozen"]),
                  _fmt(r["rom_vs_rig"], fmt="{:+.1f}"),
                  ("ok" if abs(r["rom_vs_rig"]) <= t["damping"] else "MISS")
                  if r["unseen"] and np.isfinite(r["rom_vs_rig"]) else ""]
                 for r in o["beam_errors"]]
    members = ", ".join(
        f"{k} % (" + ("the main ROM" if v["main_rom"] else
                      "trained in {:.0f} s".format(v["train_seconds"])) + ")"
        for k, v in o["members"].items())
    s = o["seconds"]
    text = (
        "The paper ends with \"include different filling levels in the training process\". "
        f"A fill family: one ROM identified at each of the fills {members}, by the same "
        "recipe and the same data design at its own fill; at a fill between two members the "
        "family predicts the convex blend of their dynamic forces, linear in the fill "
        "(docs/rom.md, \"Fill levels\"). A model refuses a fill outside the range it was "
        "identified on. Judged at fills no member saw: the map against the rig's at that fill "
        f"(target full-map error <= {t['full_l2']:.0%} and passive) and the first-mode damping "
        f"of the sloshing beam (LSCF on H1, target within {t['damping']:.0%} of the rig). "
        "At a trained fill the family is its member, so those rows are the members' own "
        f"accuracy. Time: members {s['members']:.0f} s, maps {s['maps']:.0f} s, beam "
        f"{s['beam']:.0f} s.")
    return Section(
        "Beyond the paper: one ROM for every fill level", f"<p>{html.escape(text)}</p>",
        figures=[Figure(ctx.out / "figures" / "fills_phi_d_maps.png",
                        "Phi_d maps of the rig (top) and of the fill family (bottom) at the "
                        "training fills and at an unseen fill."),
                 Figure(ctx.out / "figures" / "fills_damping.png",
                        "First-mode damping ratio (LSCF on H1) of the sloshing beam against "
                        "fill level: rig, fill family, frozen liquid; shaded: unseen fills.")],
        tables=[Table(["fill", "full-map error (%)", "dissipative-region error (%)",
                       "non-passive points", "target"], map_rows,
                      "Phi_d map of the fill family against the rig's at each fill."),
                Table(["fill", "RMS (g)", "rig (%)", "family (%)", "frozen (%)",
                       "family vs rig (%)", "target"], beam_rows,
                      "First-mode damping ratio of the sloshing beam, LSCF on H1.")])
