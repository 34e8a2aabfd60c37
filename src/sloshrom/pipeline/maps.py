"""The ``maps`` stage of `sloshrom reproduce`: Phi_d maps of the rig and the ROM and their
difference (paper Figs. 4, 11), and the hysteresis loops of Fig. 3.

:func:`compute_map`, :func:`write_map` and :func:`relative_map_error` also serve
``sloshrom map``.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from sloshrom.config import G, Tank
from sloshrom.energy import hysteresis_loop, map_maximum, phi_d_map
from sloshrom.fileio import OutputBatch
from sloshrom.models import SloshingModel
from sloshrom.pipeline.context import Context
from sloshrom.plotting import savefig
from sloshrom.plotting.maps import Loop, hysteresis_figure, phi_d_map_figure
from sloshrom.rom.estimators import load_model
from sloshrom.signals import harmonic

__all__ = [
    "HYSTERESIS_FREQUENCY", "HYSTERESIS_GAMMA", "compute_map", "hysteresis_loops", "map_grid",
    "relative_map_error", "stage_maps", "write_map",
]

#: The harmonic test of paper Fig. 3: acceleration amplitude (g) and frequency (Hz).
HYSTERESIS_GAMMA = 3.0
HYSTERESIS_FREQUENCY = 17.0


def map_grid(cfg: dict[str, Any], tank: Tank) -> tuple[np.ndarray, np.ndarray]:
    """The (omega_bar, a_bar) grid (both -) of the ``[map]`` configuration for ``tank``."""
    m = cfg["map"]
    w0 = tank.reference_frequency
    ob = np.linspace(2 * math.pi * m["f_min"] / w0, 2 * math.pi * m["f_max"] / w0, m["n_omega"])
    ab = np.linspace(m["a_bar_min"], m["a_bar_max"], m["n_a"])
    return ob, ab


def compute_map(model: SloshingModel, cfg: dict[str, Any], tank: Tank,
                progress: Callable[[int, int], None] | None = None) -> xr.DataArray:
    """Phi_d map of ``model`` on the grid and shaker envelope of the ``[map]`` configuration.

    ``progress(done, total)`` is called as frequencies finish.
    """
    ob, ab = map_grid(cfg, tank)
    m = cfg["map"]
    return phi_d_map(
        model, ob, ab, tank=tank, f_min=m["f_min"], f_max=m["f_max"],
        gamma_max=m["gamma_max"], a_bar_max=m["a_bar_max"], progress=progress,
    )


def relative_map_error(reference: Any, other: Any, threshold: float = 0.1) -> float:
    """Relative L2 error of ``other`` against ``reference`` where the reference matters.

    "Matters" = points where the reference exceeds ``threshold`` times its maximum (the
    dissipative region); elsewhere both are ~0 and a relative error is meaningless.
    """
    r = np.asarray(reference, dtype=np.float64)
    o = np.asarray(other, dtype=np.float64)
    ok = np.isfinite(r) & np.isfinite(o)
    ok &= r > threshold * np.nanmax(r)
    if not ok.any():
        return float("nan")
    return float(np.linalg.norm(o[ok] - r[ok]) / np.linalg.norm(r[ok]))


def write_map(da: xr.DataArray, path: Path, title: str) -> list[Path]:
    """NetCDF + PNG beside it, both or neither (one :class:`~sloshrom.fileio.OutputBatch`)."""
    fig = phi_d_map_figure(da, title)
    with OutputBatch() as batch:
        batch.write(path, lambda tmp: da.to_dataset().to_netcdf(tmp, engine="h5netcdf"))
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


def stage_maps(ctx: Context, rom_path: Path | None) -> tuple[dict[str, Any], list[str]]:
    """Fig. 3 and the Phi_d maps of the rig, the ROM (if ``rom_path``) and their difference.

    Returns
    -------
    outputs : dict
        ``rig_seconds`` (s), ``rig_maximum`` (``sloshrom.energy.map_maximum``) and, with a ROM,
        ``rom_seconds``, ``rom_maximum`` and ``rom_relative_l2_error`` (-,
        :func:`relative_map_error`).
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
        outputs["rom_relative_l2_error"] = relative_map_error(rig_map.values, rom_map.values)
        files += [ctx.rel(p) for p in write_map(rom_map, ctx.path("maps", "phi_d_rom.nc"),
                                                 "ROM (paper Fig. 11)")]
        diff = (rom_map - rig_map).rename("phi_d")
        diff.attrs = {"units": "1", "long_name": "Phi_d(ROM) - Phi_d(rig)"}
        files += [ctx.rel(p) for p in write_map(diff, ctx.path("maps", "phi_d_difference.nc"),
                                                 "ROM minus rig")]
    return outputs, files
