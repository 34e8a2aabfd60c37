"""`sloshrom reproduce`: the paper's whole workflow on the virtual rig, as resumable stages.

Stages (each cached in ``OUT/.stages``; a rerun reuses a finished stage whose configuration and
upstream stages did not change):

``data``    VFA training/validation records from the virtual rig (paper Figs. 5–7)
``sweep``   sensitivity analysis over delays x neurons (Fig. 8), on request (``[rom] sweep``)
``rom``     NFIR/NOE identification (Fig. 10 validation)
``maps``    Phi_d maps of rig and ROM and their difference (Figs. 4, 11)
``beam``    sloshing-beam free and random tests with rig, ROM and frozen liquid (Figs. 14–23)
``report``  ``OUT/report.html`` and ``OUT/summary.json``

This module is the only one that knows all the others; it does I/O and plotting, the numerical
work stays in the modules it calls.
"""

from __future__ import annotations

import importlib.util
import json
import math
import time
from collections.abc import Callable
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from sloshrom import __version__
from sloshrom.config import G, Tank
from sloshrom.fileio import atomic_write, atomic_write_text
from sloshrom.pipeline.cache import StageCache, StageResult

# Called as ``report(stage, done, total, text)``; the CLI turns it into progress bars.
Progress = Callable[[str, float, float, str], None]


def _quiet(stage: str, done: float, total: float, text: str) -> None:
    pass


def available(module: str) -> bool:
    return importlib.util.find_spec(module) is not None


@dataclass
class Context:
    out: Path
    cfg: dict[str, Any]
    progress: Progress = _quiet
    timings: dict[str, float] = field(default_factory=dict)

    @property
    def tank(self) -> Tank:
        return Tank.from_dict(self.cfg["tank"])

    def rig(self) -> Any:
        """The virtual rig of the configuration; its sensors record at ``[rig] fs``."""
        from sloshrom.rig.virtual import SensorParams, VirtualRig

        return VirtualRig(tank=self.tank, seed=self.cfg["rig"]["seed"],
                          sensors=SensorParams(output_rate=self.cfg["rig"]["fs"]))

    def path(self, *parts: str) -> Path:
        p = self.out.joinpath(*parts)
        p.parent.mkdir(parents=True, exist_ok=True)
        return p

    def rel(self, p: Path) -> str:
        return str(Path(p).relative_to(self.out))


@contextmanager
def _timer(ctx: Context, name: str):
    t0 = time.perf_counter()
    yield
    ctx.timings[name] = time.perf_counter() - t0


def _savefig(fig: Any, path: Path) -> Path:
    import matplotlib.pyplot as plt

    # suffix ".png": savefig takes the format from the (temporary) name, always PNG here
    atomic_write(path, lambda tmp: fig.savefig(tmp, dpi=110), suffix=".png")
    plt.close(fig)
    return path


def _plt():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


# ----------------------------------------------------------------------------------------------
# data
# ----------------------------------------------------------------------------------------------
def stage_data(ctx: Context) -> tuple[dict[str, Any], list[str]]:
    from sloshrom import signals
    from sloshrom.io.record import record_from_measurement, write_record

    plt = _plt()
    cfg, tank = ctx.cfg, ctx.tank
    rig = ctx.rig()
    files, outputs, paths, records = [], {}, [], {}
    splits = [
        ("train", cfg["data"]["train_duration"], cfg["data"]["train_seed"]),
        ("validation", cfg["data"]["validation_duration"], cfg["data"]["validation_seed"]),
    ]
    for k, (split, duration, seed) in enumerate(splits):
        ctx.progress("data", k, len(splits), f"rig VFA {split} ({duration:.0f} s)")
        sig = signals.vfa(1.0 / rig.dt, split=split, duration=duration, tank=tank, seed=seed)
        meas = rig.measure(sig.acceleration)
        rec = record_from_measurement(
            meas, tank, truth=True, split=split, seed=int(seed),
            rig_seed=int(cfg["rig"]["seed"]),
            provenance=f"sloshrom {__version__} reproduce: virtual rig VFA {split}",
        )
        p = ctx.path("data", f"{split}.nc")
        write_record(rec, p)
        files.append(ctx.rel(p))
        paths.append(sig)
        records[split] = rec
        outputs[split] = {
            "duration_s": float(rec.duration),
            "fs_hz": float(rec.fs),
            "samples": len(rec),
            "max_acceleration_g": float(np.max(np.abs(rec["acceleration"])) / G),
            "max_dynamic_force_n": float(np.max(np.abs(rec["dynamic_force"]))),
        }
        del sig, meas
    ctx.progress("data", len(splits), len(splits), "figures")
    fig, ax = plt.subplots(figsize=(6.4, 4.4), constrained_layout=True)
    signals.plot_vfa_paths(paths, ax=ax)
    files.append(ctx.rel(_savefig(fig, ctx.path("figures", "fig05_vfa_paths.png"))))
    for split, name in (("train", "fig06_train_io.png"), ("validation", "fig07_validation_io.png")):
        rec = records[split]
        fig, axs = plt.subplots(2, 1, figsize=(8, 5), sharex=True, constrained_layout=True)
        axs[0].plot(rec.time, rec["velocity"], lw=0.4)
        axs[0].set_ylabel("velocity [m/s]")
        axs[1].plot(rec.time, rec["dynamic_force"], lw=0.4, color="C3")
        axs[1].set_ylabel(r"$\Delta f$ [N]")
        axs[1].set_xlabel("time [s]")
        axs[0].set_title(f"{split} record: input (tank velocity) and output (dynamic force)")
        files.append(ctx.rel(_savefig(fig, ctx.path("figures", name))))
    return outputs, files


# ----------------------------------------------------------------------------------------------
# maps
# ----------------------------------------------------------------------------------------------
def map_grid(cfg: dict[str, Any], tank: Tank) -> tuple[np.ndarray, np.ndarray]:
    m = cfg["map"]
    w0 = tank.reference_frequency
    ob = np.linspace(2 * math.pi * m["f_min"] / w0, 2 * math.pi * m["f_max"] / w0, m["n_omega"])
    ab = np.linspace(m["a_bar_min"], m["a_bar_max"], m["n_a"])
    return ob, ab


def compute_map(model: Any, cfg: dict[str, Any], tank: Tank, progress: Callable | None = None):
    from sloshrom.energy import phi_d_map

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


def write_map(da: Any, path: Path, title: str) -> list[Path]:
    """NetCDF + PNG beside it, both or neither (one :class:`~sloshrom.fileio.OutputBatch`)."""
    from sloshrom.energy import plot_phi_d_map
    from sloshrom.fileio import OutputBatch

    plt = _plt()
    fig, ax = plt.subplots(figsize=(6.4, 4.6), constrained_layout=True)
    try:
        plot_phi_d_map(da, ax=ax)
        ax.set_title(title)
        with OutputBatch() as batch:
            batch.write(path, lambda tmp: da.to_dataset().to_netcdf(tmp, engine="h5netcdf"))
            png = batch.write(path.with_suffix(".png"), lambda tmp: fig.savefig(tmp, dpi=110),
                              suffix=".png")
    finally:
        plt.close(fig)
    return [path, png]


def hysteresis_figure(rig: Any, rom: Any, tank: Tank, path: Path,
                      gamma: float = 3.0, frequency: float = 17.0) -> Path:
    """Paper Fig. 3: normalised force history and hysteresis loop at (3 g, 17 Hz)."""
    from sloshrom.energy import hysteresis_loop
    from sloshrom.signals import harmonic

    plt = _plt()
    om = 2 * math.pi * frequency
    a = gamma * G / om**2
    fig, axs = plt.subplots(1, 2, figsize=(10, 4), constrained_layout=True)
    for model, label, style in ((rig, "rig", "-"), (rom, "ROM", "--")):
        if model is None:
            continue
        h = harmonic(1.0 / model.dt, frequency, a, n_cycles=4, n_ramp=3, n_settle=6)
        df = np.asarray(model.simulate(h.velocity, h.acceleration))
        sl = h.steady
        x, y = hysteresis_loop(h.displacement[sl], df[sl], h.acceleration[sl], a, om,
                               tank.liquid_mass)
        axs[0].plot(h.time[sl] - h.time[sl][0], y, style, lw=1, label=label)
        axs[1].plot(x, y, style, lw=1, label=label)
    axs[0].set_xlabel("time [s]")
    axs[0].set_ylabel(r"$f_S / (m_l a \Omega^2)$")
    axs[1].set_xlabel("w / a")
    axs[1].set_ylabel(r"$f_S / (m_l a \Omega^2)$")
    axs[1].legend()
    fig.suptitle(f"sloshing force at {gamma:g} g, {frequency:g} Hz (paper Fig. 3)")
    return _savefig(fig, path)


def stage_maps(ctx: Context, rom_path: Path | None) -> tuple[dict[str, Any], list[str]]:
    from sloshrom.energy import map_maximum

    tank = ctx.tank
    files: list[str] = []
    outputs: dict[str, Any] = {}

    def prog(label):
        return lambda done, total: ctx.progress("maps", done, total, label)

    rig = ctx.rig()
    rom = None
    if rom_path is not None:
        from sloshrom.rom.estimators import load_model

        rom = load_model(rom_path)
    files.append(ctx.rel(hysteresis_figure(rig, rom, tank, ctx.path("figures",
                                                                    "fig03_hysteresis.png"))))
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


# ----------------------------------------------------------------------------------------------
# orchestration
# ----------------------------------------------------------------------------------------------
def run(out: str | Path, cfg: dict[str, Any], progress: Progress = _quiet) -> dict[str, Any]:
    """Run every stage that is built, reuse cached ones, write the summary; return it.

    The configuration is validated first (:func:`sloshrom.pipeline.settings.validate`): a bad value
    costs one ``ConfigError`` naming the key, before any work.
    """
    from sloshrom.pipeline.settings import validate

    validate(cfg)
    ctx = Context(Path(out), cfg, progress)
    ctx.out.mkdir(parents=True, exist_ok=True)
    cache = StageCache(ctx.out)
    results: dict[str, StageResult] = {}
    not_built: list[str] = []

    with _timer(ctx, "data"):
        results["data"] = cache.run(
            "data", {k: cfg[k] for k in ("tank", "rig", "data")}, [],
            lambda: stage_data(ctx), __version__,
        )
    rom_path = None
    if available("sloshrom.pipeline.rom"):
        from sloshrom.pipeline.rom import SWEEP_KEYS, stage_rom, stage_sweep  # noqa: PLC0415

        if cfg["rom"]["sweep"]:
            with _timer(ctx, "sweep"):
                results["sweep"] = cache.run(
                    "sweep", {k: cfg["rom"][k] for k in SWEEP_KEYS}, [results["data"]],
                    lambda: stage_sweep(ctx), __version__,
                )
        rom_keys = {k: v for k, v in cfg["rom"].items() if not k.startswith("sweep")}
        with _timer(ctx, "rom"):
            results["rom"] = cache.run(
                "rom", rom_keys, [results["data"]], lambda: stage_rom(ctx), __version__
            )
        rom_path = ctx.out / results["rom"].outputs["model"]
    else:
        not_built.append("rom (ROM identification)")
    with _timer(ctx, "maps"):
        deps = [results[k] for k in ("data", "rom") if k in results]
        results["maps"] = cache.run(
            "maps", {k: cfg[k] for k in ("tank", "rig", "map")}, deps,
            lambda: stage_maps(ctx, rom_path), __version__,
        )
    if available("sloshrom.pipeline.beam"):
        from sloshrom.pipeline.beam import stage_beam  # noqa: PLC0415

        with _timer(ctx, "beam"):
            deps = [results[k] for k in ("data", "rom") if k in results]
            results["beam"] = cache.run(
                "beam", {k: cfg[k] for k in ("tank", "rig", "beam")}, deps,
                lambda: stage_beam(ctx, rom_path), __version__,
            )
    else:
        not_built.append("beam (sloshing-beam simulations)")

    summary = {
        "sloshrom_version": __version__,
        "config": cfg,
        "stages": {k: {"reused": r.reused, **r.outputs} for k, r in results.items()},
        "timings_s": ctx.timings,
        "not_built": not_built,
    }
    from sloshrom.pipeline.report import write_report  # noqa: PLC0415

    write_report(ctx, summary)
    atomic_write_text(ctx.out / "summary.json", json.dumps(summary, indent=1, default=float))
    return summary
