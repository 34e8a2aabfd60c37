"""The ``maps`` stage of `sloshrom reproduce`: Phi_d maps of the rig and the ROM and their
difference (paper Figs. 4, 11), and the hysteresis loops of Fig. 3.

:func:`compute_map`, :func:`write_map`, :func:`relative_map_error` and
:func:`fidelity_lines` also serve ``sloshrom map``.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from sloshrom._threads import map_threads
from sloshrom.config import G, Tank
from sloshrom.energy import (
    DISSIPATIVE_THRESHOLD,
    hysteresis_loop,
    map_fidelity,
    map_maximum,
    phi_d_map,
)
from sloshrom.fileio import OutputBatch, netcdf_writer
from sloshrom.models import SloshingModel
from sloshrom.pipeline.context import Context, StageRecord
from sloshrom.pipeline.settings import ReproduceConfig
from sloshrom.plotting import savefig
from sloshrom.plotting.maps import Loop, hysteresis_figure, phi_d_map_figure
from sloshrom.rom.ensemble import is_ensemble, spread
from sloshrom.rom.loading import load_model
from sloshrom.signals import harmonic

__all__ = [
    "HYSTERESIS_FREQUENCY", "HYSTERESIS_GAMMA", "compute_map", "fidelity_lines",
    "hysteresis_loops", "map_grid", "relative_map_error", "stage_maps", "write_map",
]

#: The harmonic test of paper Fig. 3: acceleration amplitude (g) and frequency (Hz).
HYSTERESIS_GAMMA = 3.0
HYSTERESIS_FREQUENCY = 17.0


#: Fidelity figures given as mean ± std over the members of an ensemble ROM.
MEMBER_FIGURES = ("full_l2", "dissipative_l2", "n_nonpassive", "nonpassive_fraction",
                  "min_phi_d")


def map_grid(cfg: ReproduceConfig, tank: Tank) -> tuple[np.ndarray, np.ndarray]:
    """The (omega_bar, a_bar) grid (both -) of the ``[map]`` configuration for ``tank``."""
    m = cfg.map
    w0 = tank.reference_frequency
    ob = np.linspace(2 * math.pi * m.f_min / w0, 2 * math.pi * m.f_max / w0, m.n_omega)
    ab = np.linspace(m.a_bar_min, m.a_bar_max, m.n_a)
    return ob, ab


def compute_map(model: SloshingModel, cfg: ReproduceConfig, tank: Tank,
                progress: Callable[[int, int], None] | None = None) -> xr.DataArray:
    """Phi_d map of ``model`` on the grid and shaker envelope of the ``[map]`` configuration.

    ``progress(done, total)`` is called as frequencies finish.
    """
    m = cfg.map
    ob, ab = map_grid(cfg, tank)
    return phi_d_map(
        model, ob, ab, tank=tank, f_min=m.f_min, f_max=m.f_max,
        gamma_max=m.gamma_max, a_bar_max=m.a_bar_max, progress=progress,
    )


def relative_map_error(reference: Any, other: Any,
                       threshold: float = DISSIPATIVE_THRESHOLD) -> float:
    """Relative L2 error (-) of ``other`` against ``reference`` in the dissipative region only.

    The region is where the reference exceeds ``threshold`` times its maximum. This is one
    figure of :func:`sloshrom.energy.map_fidelity` (``dissipative_l2``), kept for callers that
    want only it; reports should give the whole-map error and the passivity too.
    """
    return float(map_fidelity(reference, other, dissipative_threshold=threshold)
                 ["dissipative_l2"])


def fidelity_lines(fid: dict[str, Any], against: str = "the reference") -> list[str]:
    """Plain-text lines of a :func:`sloshrom.energy.map_fidelity` result, whole map first."""
    where = ""
    if math.isfinite(fid["min_omega_bar"]) and math.isfinite(fid["min_a_bar"]):
        where = f" at omega_bar = {fid['min_omega_bar']:.2f}, a_bar = {fid['min_a_bar']:.3f}"
    return [
        f"against {against}, on the {fid['n_points']} points both maps cover:",
        f"  full map:            relative L2 error {fid['full_l2']:.1%}",
        f"  dissipative region:  relative L2 error {fid['dissipative_l2']:.1%} "
        f"({fid['n_dissipative']} points where the reference Phi_d > "
        f"{fid['dissipative_threshold']:.0%} of its maximum)",
        f"  passivity:           {fid['n_nonpassive']} points ({fid['nonpassive_fraction']:.1%})"
        f" below Phi_d = {fid['passivity_threshold']:.3g} "
        f"(-{fid['passivity_tolerance']:.0%} of the reference maximum); "
        f"min Phi_d = {fid['min_phi_d']:.3g}{where}",
    ]


def write_map(da: xr.DataArray, path: Path, title: str, kind: str = "map",
              negative_below: float | None = None, top: float | None = None) -> list[Path]:
    """NetCDF + PNG beside it, both or neither (one :class:`~sloshrom.fileio.OutputBatch`).

    ``kind``, ``negative_below`` and ``top`` go to
    :func:`sloshrom.plotting.maps.phi_d_map_figure`: ``"map"`` (Phi_d, non-passive values
    below ``negative_below`` marked, colours up to ``top``) or ``"difference"`` (diverging
    colours centred on zero).
    """
    fig = phi_d_map_figure(da, title, kind=kind, negative_below=negative_below, top=top)
    with OutputBatch() as batch:
        batch.write(path, netcdf_writer(da.to_dataset()))
        png = savefig(fig, path.with_suffix(".png"), batch)
    return [path, png]


def hysteresis_loops(models: dict[str, SloshingModel], tank: Tank,
                     gamma: float = HYSTERESIS_GAMMA,
                     frequency: float = HYSTERESIS_FREQUENCY) -> list[Loop]:
    """Normalised steady response of each model (label -> model) to one harmonic test.

    The test has acceleration amplitude ``gamma`` (g) at ``frequency`` (Hz): 3 ramp cycles,
    6 settling cycles and 4 steady cycles, sampled at each model's own step.
    """
    om = 2 * math.pi * frequency
    a = gamma * G / om**2
    loops = []
    for label, model in models.items():
        h = harmonic(1.0 / model.dt, frequency, a, n_cycles=4, n_ramp=3, n_settle=6)
        df = np.asarray(model.simulate(h.velocity, h.acceleration))
        sl = h.steady
        x, y = hysteresis_loop(h.displacement[sl], df[sl], h.acceleration[sl], a, om,
                               tank.liquid_mass)
        loops.append(Loop(label, h.time[sl] - h.time[sl][0], x, y))
    return loops


def stage_maps(ctx: Context, rom_path: Path | None) -> StageRecord:
    """Fig. 3 and the Phi_d maps of the rig, the ROM (if ``rom_path``) and their difference.

    Returns
    -------
    outputs : dict
        ``rig_seconds`` (s), ``rig_maximum`` (``sloshrom.energy.map_maximum``) and, with a ROM,
        ``rom_seconds``, ``rom_fidelity`` (:func:`sloshrom.energy.map_fidelity` of the ROM map
        against the rig's: whole map, dissipative region, passivity), ``rom_maximum`` and
        ``rom_relative_l2_error`` (-, the same as ``rom_fidelity["dissipative_l2"]``, kept for
        readers of older summaries).
    files : list of str
        Written files, relative to ``ctx.out``.
    """
    tank = ctx.tank
    files: list[str] = []
    outputs: dict[str, Any] = {}

    def prog(label: str) -> Callable[[int, int], None]:
        return lambda done, total: ctx.progress("maps", done, total, label)

    rig = ctx.rig()
    models: dict[str, SloshingModel] = {"rig": rig}
    rom = None
    if rom_path is not None:
        rom = models["ROM"] = load_model(rom_path)
    fig = hysteresis_figure(hysteresis_loops(models, tank), HYSTERESIS_GAMMA,
                            HYSTERESIS_FREQUENCY)
    files.append(ctx.rel(savefig(fig, ctx.path("figures", "fig03_hysteresis.png"))))
    t0 = time.perf_counter()
    rig_map = compute_map(rig, ctx.cfg, tank, prog("Phi_d map of the rig"))
    outputs["rig_seconds"] = time.perf_counter() - t0
    outputs["rig_maximum"] = map_maximum(rig_map)
    files += [ctx.rel(p) for p in write_map(rig_map, ctx.path("maps", "phi_d_rig.nc"),
                                             "virtual rig (paper Fig. 4)")]
    if rom is not None:
        t0 = time.perf_counter()
        rom_map = compute_map(rom, ctx.cfg, tank, prog("Phi_d map of the ROM"))
        outputs["rom_seconds"] = time.perf_counter() - t0
        outputs["rom_maximum"] = map_maximum(rom_map)
        fid = map_fidelity(rig_map, rom_map)
        outputs["rom_fidelity"] = fid
        outputs["rom_relative_l2_error"] = fid["dissipative_l2"]
        if is_ensemble(rom):
            # one map per member: the spread a single network's map carries
            n = len(rom.members_)
            ctx.progress("maps", 0, n, f"Phi_d maps of the {n} members")
            # each member's map alone, a core each
            fids = map_threads(lambda m: map_fidelity(rig_map, compute_map(m, ctx.cfg, tank)),
                               rom.members_)
            outputs["rom_fidelity_members"] = {
                key: spread(f[key] for f in fids) for key in MEMBER_FIGURES}
        # the ROM figure marks exactly the points counted as non-passive
        files += [ctx.rel(p) for p in write_map(
            rom_map, ctx.path("maps", "phi_d_rom.nc"), "ROM (paper Fig. 11)",
            negative_below=fid["passivity_threshold"],
            # on the rig's colour scale (Fig. 4's): one colour, one Phi_d in both figures
            top=float(rig_map.max()))]
        diff = (rom_map - rig_map).rename("phi_d")
        diff.attrs = {"units": "1", "long_name": "Phi_d(ROM) - Phi_d(rig)"}
        files += [ctx.rel(p) for p in write_map(diff, ctx.path("maps", "phi_d_difference.nc"),
                                                 "ROM minus rig", kind="difference")]
    return outputs, files
