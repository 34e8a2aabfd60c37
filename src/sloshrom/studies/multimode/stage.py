"""The ``multimode`` stage: sloshing damping on a structure with two active modes.

The paper's beam is one-mode dominated; its open problem is a sloshing model that interacts with
structural dynamics that are not one-tone-dominant. This stage puts the paper tank on a wing
whose bending (9 Hz) and torsion (17 Hz) modes both move it vertically inside the 5-25 Hz band
where the liquid sloshes violently (:mod:`sloshrom.beam.simulation.wing`), and asks whether a ROM
identified by the paper's recipe predicts the damping of **both** modes. Three ROMs (NFIR, the
paper's architecture), so that the effects of the data and of the input stay apart:

* **VFA-only**: the paper's VFA records (one frequency at a time over the paper's shaker
  domain, 6 g), the tank velocity in, the default recipe;
* **broadband, velocity**: the same VFA records followed by broadband rig records: band-limited
  Gaussian tank acceleration over the band of the two modes (several frequencies at once, as the
  tank of the wing moves), at several levels up to ``margin`` times the tank motion of the
  wing's random tests with frozen liquid (run first: the least-damped case bounds the others);
  same recipe as the VFA-only ROM;
* **broadband, acceleration**: the same records, the tank **acceleration** in (plain MSE: the
  recipe's loss terms are written for a velocity input). The impacts start when the tank's
  acceleration drops below -g, a threshold of the network's input itself rather than of an
  integral of it; this is the ROM the stage judges the two-mode target on.

Judge: random base excitation at several RMS levels with the rig (reference), both ROMs and
frozen liquid; modal filtering of the accelerometers with the frozen-liquid shapes, H1 of base
-> modal acceleration and LSCF stable-pole-cluster damping of each mode
(:func:`sloshrom.beam.damping.multimode.modal_damping_table`); a ROM passes on a mode and level when
its damping is within ``tolerance`` of the rig's. Open loop, each ROM is also fed the rig's own tank
velocity of the coupled tests: the power it takes from each mode's band against the rig's
(:func:`sloshrom.beam.damping.multimode.band_power`) locates a damping error in the ROM itself
rather than in the feedback of the coupled run.

The settings are the ``[multimode]`` table (:mod:`sloshrom.studies.multimode.config`). The
stage needs no other stage's files. Every file of the stage (records, models, table, figures)
is written together at the end.
"""

from __future__ import annotations

import time
import warnings
from collections.abc import Mapping
from typing import Any

import numpy as np

from sloshrom import __version__, signals
from sloshrom.beam.damping.analysis import frf_h1, modal_filter
from sloshrom.beam.damping.multimode import band_power, modal_damping_table, tank_mode_shares
from sloshrom.beam.results import write_table
from sloshrom.beam.simulation.cases import simulate_cases
from sloshrom.beam.simulation.coupled import random_response
from sloshrom.beam.simulation.envelope import tank_motion
from sloshrom.beam.simulation.wing import (
    frozen_station_shapes,
    structure_summary,
    two_mode_wing,
    wing_modal_model,
)
from sloshrom.config import ConfigError, G, Tank
from sloshrom.fileio import OutputBatch
from sloshrom.io import Record, record_from_measurement, velocity_from_acceleration, write_record
from sloshrom.models import FrozenLiquid
from sloshrom.pipeline.context import Context
from sloshrom.pipeline.data import vfa_pieces
from sloshrom.pipeline.rom import error_figures
from sloshrom.plotting import savefig
from sloshrom.rig.virtual import SensorParams, VirtualRig
from sloshrom.rom.errors import EnvelopeWarning
from sloshrom.rom.parallel import run_tasks
from sloshrom.rom.registry import LOSS_TERMS
from sloshrom.rom.tdnn.estimators import NFIR
from sloshrom.signals import broadband_acceleration
from sloshrom.studies.multimode.config import (
    CASES,
    DATA_SETS,
    JUDGED_ROM,
    ROM_INPUTS,
    rom_params,
    wing_design,
)
from sloshrom.studies.multimode.figures import modal_damping_figure, modal_frf_figure
from sloshrom.studies.multimode.outputs import MultimodeOutputs
from sloshrom.studies.multimode.table import MultimodeTable, multimode_table

__all__ = ["stage_multimode"]


def _rig(ctx: Context, seed: int) -> VirtualRig:
    """The configuration's rig physics with its own seed (sensor noise, Faraday seeding)."""
    return VirtualRig(tank=ctx.tank, params=ctx.rig_params(), seed=int(seed),
                      sensors=SensorParams(output_fs=ctx.cfg.rig.fs))


def _fit_rom(item: tuple[str, dict[str, Any], np.ndarray, np.ndarray, np.ndarray, np.ndarray],
             fs: float) -> tuple[NFIR, float]:
    """Train one ROM (a task of :func:`run_tasks`): ``item = (name, NFIR parameters, u, y,
    u_val, y_val)``; returns the fitted NFIR and its training time, s."""
    _, params, u, y, uv, yv = item
    t0 = time.perf_counter()
    model = NFIR(**params).fit(u, y, fs=fs, validation=(uv, yv))
    return model, time.perf_counter() - t0


def _record_outputs(rec: Record) -> dict[str, Any]:
    acc, vel = rec["acceleration"], rec["velocity"]
    return {"duration_s": float(rec.duration), "samples": len(rec),
            "max_acceleration_g": float(np.max(np.abs(acc))) / G,
            "rms_acceleration_g": float(np.sqrt(np.mean(acc**2))) / G,
            "max_velocity_m_s": float(np.max(np.abs(vel))),
            "max_dynamic_force_n": float(np.max(np.abs(rec["dynamic_force"])))}


def _broadband_pieces(s: MultimodeTable, split: str, top_rms: float, band: tuple[float, float],
                      fs: float) -> list[np.ndarray]:
    """One faded piece per level (m/s^2 at ``fs``); validation pieces are half as long."""
    dur = s.broadband_piece_duration * (1.0 if split == "train" else 0.5)
    base = s.broadband_seed + (0 if split == "train" else 100)
    return [broadband_acceleration(fs, dur, lv * top_rms, band[0], band[1], seed=base + k,
                                   fade=s.broadband_fade)
            for k, lv in enumerate(s.broadband_levels)]


def _nan_to_none(v: float) -> float | None:
    return float(v) if np.isfinite(v) else None


def _errors(rows: list[dict[str, Any]], tolerance: float) -> list[dict[str, Any]]:
    """Per ROM case, mode and level: damping / rig damping - 1 and whether it is within."""
    rig = {(r["mode"], r["rms_g"]): r["zeta"] for r in rows if r["case"] == "rig"}
    out = []
    for r in rows:
        if r["case"] == "rig":
            continue
        ref = rig[(r["mode"], r["rms_g"])]
        err = r["zeta"] / ref - 1.0 if np.isfinite(ref) and ref > 0 else float("nan")
        out.append({"case": r["case"], "mode": r["mode"], "rms_g": r["rms_g"],
                    "zeta": _nan_to_none(r["zeta"]), "zeta_rig": _nan_to_none(ref),
                    "error": _nan_to_none(err),
                    "within": bool(np.isfinite(err) and abs(err) <= tolerance)})
    return out


def _open_loop(rig: Mapping[str, Any], roms: Mapping[str, Any], f_modes: np.ndarray,
               levels: list[float], rel_band: float) -> list[dict[str, Any]]:
    """Each ROM fed the rig's own tank motion of the coupled tests (velocity or acceleration,
    the signal it reads): the power it takes from each mode's band against the rig's
    (:func:`~sloshrom.beam.damping.multimode.band_power`)."""
    v, fs = np.asarray(rig["tank_velocity"]), float(rig["fs"])
    a = np.asarray(rig["tank_acceleration"])
    p_rig = band_power(v, rig["dynamic_force"], fs, f_modes, rel_band)
    out = []
    for case, model in roms.items():
        if abs(float(model.fs_) - fs) > 1e-9 * fs:
            raise ConfigError(f"{case} runs at {model.fs_} Hz, the rig's records at {fs} Hz")
        force = np.asarray(model.simulate(v, a))  # (levels, n): one batched free run
        p = band_power(v, force, fs, f_modes, rel_band)
        out += [{"case": case, "rms_g": lv, "mode": k + 1, "power_rig_w": float(p_rig[i, k]),
                 "power_w": float(p[i, k]),
                 "ratio": _nan_to_none(p[i, k] / p_rig[i, k]) if p_rig[i, k] > 0 else None}
                for i, lv in enumerate(levels) for k in range(len(f_modes))]
    return out


# -- the stage ---------------------------------------------------------------------------------
def stage_multimode(ctx: Context) -> tuple[dict[str, Any], list[str]]:
    """Records, three ROMs and the modal damping of a two-mode wing (module docstring).

    Parameters
    ----------
    ctx : Context
        Output directory, configuration (``[tank]``, ``[rig]``: the tank, the rig's physics and
        the record rate ``fs``; ``[multimode]``: the study's settings) and progress.

    Returns
    -------
    outputs : dict
        The record of :class:`~sloshrom.studies.multimode.outputs.MultimodeOutputs`, JSON-able:
        ``settings``; ``structure`` (the wing, EI, GJ, coupling and
        :func:`~sloshrom.beam.simulation.wing.structure_summary`); ``test`` (levels, PSD, the frozen
        runs' tank motion and per-mode tank RMS, g); ``data`` (per record: duration, peaks; the
        broadband design: band, top RMS, levels, coverage of the frozen tank motion);
        ``roms`` (per ROM: the input it reads, its loss, records, train seconds of data, fit
        seconds, epochs, stop reason, validation NRMSE, training envelope); ``table`` (rows of
        :func:`~sloshrom.beam.damping.multimode.modal_damping_table`); ``errors`` (per ROM, mode and
        level: damping / rig damping - 1, ``within`` the tolerance); ``envelope`` (per case and
        level: peak tank acceleration / the ROM's training peak, fraction outside);
        ``open_loop`` (per ROM, level and mode: the power the ROM takes from the mode's band
        when fed the rig's own tank motion of that test, against the rig's power, W, and
        their ratio: the ROM's error without the feedback of the coupled run);
        ``verdict`` (per ROM: every mode and level within; the target is judged on
        :data:`~sloshrom.studies.multimode.config.JUDGED_ROM`); ``timings_s``.
    files : list of str
        ``multimode/data/*.nc``, ``multimode/models/*.npz``,
        ``multimode/table_modal_damping.{csv,md}`` and the two figures, relative to ``ctx.out``.
    """
    s = multimode_table(ctx.cfg)
    with warnings.catch_warnings():
        # a ROM leaving its training envelope (the VFA-only ROM in the wing's tests, the
        # validation records' peaks) is measured and reported (``envelope``, ``roms``), not
        # warned about once per run
        warnings.filterwarnings("ignore", category=EnvelopeWarning)
        warnings.filterwarnings("ignore", message="tank .*training envelope")
        outputs, files = _run(ctx, s)
    return outputs.as_record(), files


def _broadband_design(s: MultimodeTable, frozen: Mapping[str, Any], f_frozen: np.ndarray,
                      fs: float, fine: float) -> dict[str, Any]:
    """Band and top RMS of the broadband records from the frozen random tests (m/s^2, Hz).

    Band ``f1 / broadband_band .. f2 * broadband_band`` (within the shaker's 5-25 Hz). Top RMS:
    ``margin`` times the frozen tests' largest tank RMS acceleration, or more if a flat band
    (relatively richer in high frequencies than the tank's motion, whose velocity the first
    mode dominates) would not cover their RMS velocity too. The velocity is the tank's
    oscillation as a rig record measures it (1 Hz high-pass, as the records' preprocessing):
    without the slow drift of the base velocity, which no shaker record can or need reproduce.
    """
    band = (max(signals.SHAKER_ENVELOPE.f_min, float(f_frozen[0]) / s.broadband_band),
            min(signals.SHAKER_ENVELOPE.f_max, float(f_frozen[-1]) * s.broadband_band))
    acc_rms = np.sqrt(np.mean(frozen["tank_acceleration"] ** 2, axis=-1))
    vel = velocity_from_acceleration(frozen["tank_acceleration"], fs)
    vel_rms = np.sqrt(np.mean(vel**2, axis=-1))
    unit = broadband_acceleration(fine, s.broadband_piece_duration, 1.0, *band,
                                  seed=s.broadband_seed, fade=s.broadband_fade)
    unit_vrms = float(np.sqrt(np.mean(velocity_from_acceleration(unit, fine) ** 2)))
    top = s.margin * max(float(acc_rms.max()), float(vel_rms.max()) / unit_vrms)
    return {"band": band, "top_rms": top, "frozen_acc_rms": acc_rms, "frozen_vel_rms": vel_rms,
            "frozen_vel_peak": float(np.max(np.abs(vel)))}


def _make_records(ctx: Context, s: MultimodeTable, design: Mapping[str, Any],
                  fine: float) -> tuple[dict[str, Record], dict[str, Any]]:
    """The four rig records (VFA and broadband, training and validation) and their summaries."""
    tank = ctx.tank
    band, top = design["band"], design["top_rms"]
    specs = []
    for split, dur, seed in (("train", s.vfa_train_duration, s.vfa_train_seed),
                             ("validation", s.vfa_validation_duration,
                              s.vfa_validation_seed)):
        pieces = vfa_pieces(None, split, dur, seed, signals.SHAKER_DESIGN, None, fine, tank)
        specs.append((f"vfa_{split}", split, int(seed),
                      np.concatenate([p.acceleration for p in pieces]),
                      f"paper VFA {split} (shaker design, {signals.SHAKER_DESIGN.gamma_max:g} g)"))
        del pieces
    for split in ("train", "validation"):
        specs.append((f"broadband_{split}", split, int(s.broadband_seed),
                      np.concatenate(_broadband_pieces(s, split, top, band, fine)),
                      f"broadband {split}: band-limited Gaussian {band[0]:.2f}-{band[1]:.2f} Hz "
                      f"at {len(s.broadband_levels)} levels up to {top / G:.3g} g RMS"))
    records: dict[str, Record] = {}
    out: dict[str, Any] = {}
    for k, (name, split, seed, acc, what) in enumerate(specs):
        rig_seed = int(s.rig_seed) + k  # every record its own sensor noise
        rec = record_from_measurement(
            _rig(ctx, rig_seed).measure(acc), tank, truth=True, split=split, seed=seed,
            rig_seed=rig_seed, provenance=f"sloshrom {__version__} multimode: virtual rig {what}")
        records[name] = rec
        out[name] = {**_record_outputs(rec), "what": what}
    return records, out


def _train_roms(ctx: Context, s: MultimodeTable, records: Mapping[str, Record], fs: float,
                progress: Any) -> tuple[dict[str, NFIR], dict[str, Any]]:
    """The ROMs of :data:`DATA_SETS`, in parallel (``rom_workers``): the models and their
    summaries."""

    def joined(names: tuple[str, ...], var: str) -> np.ndarray:
        return np.concatenate([records[n][var] for n in names])

    items = [(name, rom_params(s, ROM_INPUTS[name]),
              joined(tr, ROM_INPUTS[name]), joined(tr, "dynamic_force"),
              joined(va, ROM_INPUTS[name]), joined(va, "dynamic_force"))
             for name, (tr, va) in DATA_SETS.items()]
    workers = int(s.rom_workers)
    fitted = run_tasks(_fit_rom, items, args=(fs,),
                       scheduler="sequential" if workers == 1 else None,
                       n_workers=min(workers, len(items)),
                       done=lambda i, _: progress(f"{items[i][0]} trained"))
    roms: dict[str, NFIR] = {}
    out: dict[str, Any] = {}
    for (name, params, u, _, uv, yv), (model, secs) in zip(items, fitted, strict=True):
        roms[name] = model
        hist = model.history_
        out[name] = {
            "name": f"NFIR({params['delays']}, {params['neurons']})",
            "input": ROM_INPUTS[name],
            "loss": "plain MSE" if not any(params[k] for k in LOSS_TERMS)
            else "default (amplitude weighting, passivity, cycle energy)",
            "train_records": list(DATA_SETS[name][0]),
            "validation_records": list(DATA_SETS[name][1]),
            "train_seconds_of_data": float(u.size / fs),
            "validation_seconds_of_data": float(uv.size / fs),
            "fit_seconds": float(secs), "epochs": len(hist.get("train_mse", [])),
            "stop_reason": hist.get("stop_reason"),
            "val_nrmse": error_figures(yv, np.asarray(model.predict(uv)))["nrmse"],
            "envelope": {k: (list(v) if isinstance(v, tuple | list) else float(v))
                         for k, v in model.envelope_.items()},
        }
    return roms, out


def _modal_h1(results: Mapping[str, Mapping[str, Any]], shapes: np.ndarray,
              nperseg: int) -> dict[str, tuple[np.ndarray, list[list[np.ndarray]]]]:
    """Per case: frequencies (Hz) and H1 base -> modal acceleration [level][mode] (-)."""
    out = {}
    for case, res in results.items():
        eta = modal_filter(res["station_acceleration"] - res["base_acceleration"][..., None],
                           shapes)
        curves = []
        for i in range(eta.shape[0]):
            row = [frf_h1(res["base_acceleration"][i], eta[i][:, k], float(res["fs"]), nperseg)
                   for k in range(eta.shape[-1])]
            curves.append([h for _, h, _ in row])
        out[case] = (row[0][0], curves)
    return out


def _run(ctx: Context, s: MultimodeTable) -> tuple[MultimodeOutputs, list[str]]:
    """The work of :func:`stage_multimode` with the settings ``s``."""
    timings: dict[str, float] = {}
    t_start = time.perf_counter()
    tank: Tank = ctx.tank
    fs = float(ctx.cfg.rig.fs)  # the records' and the accelerometers' rate
    fine = 1.0 / _rig(ctx, 0).dt  # the rig's integration rate: the records are made at it
    wing = wing_design(s)
    modal = wing_modal_model(wing, tank)
    ms = two_mode_wing(wing, tank)
    f_frozen, st_shapes, tk_shapes = frozen_station_shapes(modal, tank.liquid_mass)
    levels = [float(v) for v in s.rms_g]
    n_steps = 6

    def progress(step: int, text: str) -> None:
        ctx.progress("multimode", step, n_steps, text)

    def test(model: Any, out_fs: float | None) -> dict[str, Any]:
        return random_response(model, modal, levels, s.random_duration, s.random_seed,
                               s.f0, s.sigma, signal_fs=fs, tank=tank, output_fs=out_fs)

    # 1. the random tests with frozen liquid (the least damped case): the broadband design
    progress(0, "random tests with frozen liquid")
    t0 = time.perf_counter()
    frozen = test(FrozenLiquid(1.0 / fs), None)
    motion = tank_motion({"random": frozen})
    eta_frozen = modal_filter(frozen["station_acceleration"]
                              - frozen["base_acceleration"][..., None], st_shapes)
    design = _broadband_design(s, frozen, f_frozen, fs, fine)
    timings["frozen_tests"] = time.perf_counter() - t0

    # 2. records on the rig: the paper's VFA, broadband over the wing's band and motion
    progress(1, "rig records")
    t0 = time.perf_counter()
    records, data_out = _make_records(ctx, s, design, fine)
    bb = records["broadband_train"]
    data_out["broadband_design"] = {
        "band_hz": list(design["band"]), "top_rms_g": design["top_rms"] / G,
        "levels_rms_g": [lv * design["top_rms"] / G for lv in s.broadband_levels],
        "piece_duration_s": s.broadband_piece_duration, "margin": s.margin,
        "frozen_tank_rms_g": (design["frozen_acc_rms"] / G).tolist(),
        "frozen_tank_velocity_rms_m_s": design["frozen_vel_rms"].tolist(),
        "covers_peak_acceleration": float(np.max(np.abs(bb["acceleration"])))
        / motion.peak_acceleration,
        "covers_peak_velocity": float(np.max(np.abs(bb["velocity"]))) / design["frozen_vel_peak"],
        "covers_peak_velocity_with_drift": float(np.max(np.abs(bb["velocity"])))
        / motion.peak_velocity,
    }
    timings["records"] = time.perf_counter() - t0

    # 3. the ROMs: VFA-only, broadband on the velocity and on the acceleration
    progress(2, "training the VFA-only and the two broadband ROMs")
    t0 = time.perf_counter()
    roms, rom_out = _train_roms(ctx, s, records, fs, lambda text: progress(2, text))
    timings["training"] = time.perf_counter() - t0

    # 4. the random tests with rig and ROMs (frozen: step 1, the same signals)
    progress(3, "random tests: rig and ROMs")
    t0 = time.perf_counter()
    results = simulate_cases({"rig": ctx.rig(), **roms}, test, fs,
                             lambda case: progress(3, f"random tests: {case}"))
    results = {c: frozen if c == "frozen" else results[c] for c in CASES}
    timings["random_tests"] = time.perf_counter() - t0

    # 5. modal damping of every case, level and mode
    progress(4, "modal damping")
    t0 = time.perf_counter()
    rows = modal_damping_table(results, modal, tank.liquid_mass, levels, s.rel_band,
                               int(s.nperseg), s.lscf_tol_zeta)
    errors = _errors(rows, s.tolerance)
    envelope = [{"case": c, "rms_g": lv,
                 "tank_peak_g": float(np.max(np.abs(results[c]["tank_acceleration"][i]))) / G,
                 "acceleration_ratio": _nan_to_none(
                     float(np.asarray(results[c]["envelope_acceleration_ratio"])[i])),
                 "outside_fraction": _nan_to_none(
                     float(np.asarray(results[c]["envelope_outside_fraction"])[i]))}
                for c in CASES for i, lv in enumerate(levels)]
    h1 = _modal_h1(results, st_shapes, int(s.nperseg))
    open_loop = _open_loop(results["rig"], roms, f_frozen, levels, s.rel_band)
    timings["analysis"] = time.perf_counter() - t0

    # 6. files, all together
    progress(5, "files and figures")
    out = ctx.out / "multimode"
    figs = {"fig_modal_frf": modal_frf_figure(h1, levels, f_frozen, s.rel_band),
            "fig_modal_damping": modal_damping_figure(rows, levels, modal.n_modes, CASES,
                                                      s.tolerance)}
    with OutputBatch() as batch:
        for name, rec in records.items():
            batch.write(out / "data" / f"{name}.nc", lambda tmp, rec=rec: write_record(rec, tmp))
        for name, model in roms.items():
            stem = f"{NFIR.model_class.name}_{name.removesuffix('_rom')}"  # nfir_<case>
            batch.write(out / "models" / f"{stem}.npz", lambda tmp, model=model: model.save(tmp))
        write_table(rows, out / "table_modal_damping", batch)
        for name, fig in figs.items():
            savefig(fig, out / f"{name}.png", batch)
        files = [ctx.rel(p) for p in batch.paths]
    progress(n_steps, "done")
    timings["total"] = time.perf_counter() - t_start

    outputs = MultimodeOutputs(
        settings=s.model_dump(),
        structure={
            "wing": wing.as_dict(), "EI_n_m2": float(ms.attrs["EI"]),
            "GJ_n_m2_per_rad": float(ms.attrs["GJ"]), "mass_coupling": float(ms.attrs["coupling"]),
            "wing_mass_kg": wing.mass_per_span * wing.span,
            "tank_structure_mass_kg": tank.structure_mass, "liquid_mass_kg": tank.liquid_mass,
            **structure_summary(modal, tank.liquid_mass),
            "tank_shape_frozen": tk_shapes.tolist(),
        },
        test={
            "rms_g": levels, "duration_s": s.random_duration, "f0_hz": s.f0,
            "sigma_hz": s.sigma, "seed": s.random_seed,
            "frozen_motion": motion.as_dict(),
            "frozen_tank_rms_g": (design["frozen_acc_rms"] / G).tolist(),
            "frozen_tank_mode_rms_g": (tank_mode_shares(eta_frozen, tk_shapes) / G).tolist(),
        },
        data=data_out,
        roms=rom_out,
        table=rows,
        errors=errors,
        envelope=envelope,
        open_loop=open_loop,
        verdict={c: all(e["within"] for e in errors if e["case"] == c) for c in ROM_INPUTS},
        judged_rom=JUDGED_ROM,
        timings_s=timings,
    )
    return outputs, files
