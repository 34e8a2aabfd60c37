"""The ``baseline`` stage of `sloshrom reproduce`: the bouncing-ball equivalent mechanical model
(:class:`sloshrom.rom.ball.model.BouncingBall`) through the same Phi_d map, beam tests and Table 2
as the ROM, side by side with it.

The stage takes its inputs from the records of the stages before it
(:meth:`sloshrom.pipeline.cache.StageResult.output`): the training and validation records of
the ``data`` stage, the model of the ``rom`` stage and, when those stages recorded them, the
maps of the ``maps`` stage and the beam results of the ``beam`` stage; what they did not record
is recomputed. :func:`~sloshrom.studies.baseline.section.baseline_section` turns its outputs into
a report section.
"""

from __future__ import annotations

import math
import time
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from sloshrom.beam.compare import AnalysedTest, analysed_test, compare_rows
from sloshrom.beam.damping.columns import table2_dataset, table2_rows
from sloshrom.beam.damping.registry import REFERENCE
from sloshrom.beam.damping.tables import (
    Mode1Decay,
    damping_band_table,
    damping_summary,
    mode1_damping_dataset,
    mode1_decay,
)
from sloshrom.beam.results import to_dataset, write_dataset, write_table
from sloshrom.beam.simulation.cases import envelope_table, simulate_cases
from sloshrom.beam.simulation.structure import coupled_frozen_modes
from sloshrom.energy import DISSIPATIVE_THRESHOLD, map_fidelity, map_maximum
from sloshrom.fileio import OutputBatch
from sloshrom.io import Record, read_record
from sloshrom.models import FrozenLiquid, SloshingModel
from sloshrom.pipeline.beam import EXPERIMENT, beam_structure, beam_tests, coupled_model
from sloshrom.pipeline.cache import StageResult
from sloshrom.pipeline.context import Context
from sloshrom.pipeline.maps import compute_map, write_map
from sloshrom.plotting import savefig
from sloshrom.plotting.beam import free_figures, random_figures, random_window
from sloshrom.rom.ball.model import BouncingBall, lowpass_gain
from sloshrom.rom.loading import load_model
from sloshrom.studies.baseline.config import BALL_MODEL, CASE, FREQUENCY_BANDS, ball_options
from sloshrom.studies.baseline.figures import frequency_band_figure
from sloshrom.studies.baseline.outputs import REFERENCE_KEY, BaselineOutputs

__all__ = ["ball_against_experiment", "comparison_rows", "fit_ball", "frequency_band_errors",
           "lowpassed_nrmse", "stage_baseline"]

#: The ``data`` stage's records the ball is identified on (paths as its record lists them).
TRAIN_RECORD, VALIDATION_RECORD = "data/train.nc", "data/validation.nc"


# -- identification ------------------------------------------------------------------------------
def lowpassed_nrmse(y: np.ndarray, y_hat: np.ndarray, fs: float, cutoff: float) -> float:
    """RMS of ``y_hat - y`` over the RMS of ``y``, both low-passed by the ball's objective
    filter (:func:`sloshrom.rom.ball.model.lowpass_gain`, zero phase, ``cutoff`` in Hz), -."""
    f = np.fft.rfftfreq(y.size, 1.0 / fs)
    gain = lowpass_gain(f, cutoff)

    def lp(x: np.ndarray) -> np.ndarray:
        return np.fft.irfft(np.fft.rfft(x) * gain, y.size)

    ref = lp(y)
    return float(np.sqrt(np.mean((lp(y_hat) - ref) ** 2) / np.mean(ref**2)))


def fit_ball(ctx: Context, train: Record, validation: Record) -> BouncingBall:
    """The bouncing ball identified on the ``train`` record (``validation``: its validation).

    Hyperparameters: the ``[baseline]`` table (:func:`~sloshrom.studies.baseline.config.
    ball_options`). The acceleration is the forward difference of the record's velocity
    (:func:`sloshrom.rom.ball.model.forward_acceleration`), the exact mean acceleration over each
    sample step, as the ROM sees the tank through the same velocity.
    """
    return BouncingBall(tank=ctx.tank, **ball_options(ctx.cfg)).fit(
        train["velocity"], train["dynamic_force"], train.fs,
        validation=(validation["velocity"], validation["dynamic_force"]))


# -- maps ----------------------------------------------------------------------------------------
def _read_map(path: Path | None) -> xr.DataArray | None:
    if path is None or not path.is_file():
        return None
    with xr.open_dataset(path, engine="h5netcdf") as ds:
        return ds["phi_d"].load()


def frequency_band_errors(reference: xr.DataArray, other: xr.DataArray,
                          threshold: float = DISSIPATIVE_THRESHOLD) -> dict[str, dict[str, Any]]:
    """Map errors of ``other`` against ``reference`` in each third of the omega_bar range.

    Parameters
    ----------
    reference, other : xarray.DataArray
        Phi_d maps (-) on the same (omega_bar, a_bar) grid.
    threshold : float
        The dissipative region is where the reference exceeds ``threshold`` times its maximum
        over the *whole* map (-), so the bands share one definition of "dissipative".

    Returns
    -------
    dict
        Band name (:data:`FREQUENCY_BANDS`) -> ``omega_bar`` ([low, high], -), ``frequency_hz``
        ([low, high]), ``full_l2`` and ``dissipative_l2`` (relative L2 errors, -, NaN where the
        band has no such point), ``n_points``, ``n_dissipative``.
    """
    other = other.transpose(*reference.dims)
    r_all = np.asarray(reference.values, dtype=float)
    level = threshold * float(np.nanmax(r_all))
    ob = np.asarray(reference["omega_bar"].values)
    freq = (np.asarray(reference["frequency"].values) if "frequency" in reference.coords
            else np.full(ob.shape, np.nan))
    edges = np.linspace(ob.min(), ob.max(), len(FREQUENCY_BANDS) + 1)
    out: dict[str, dict[str, Any]] = {}
    axis = reference.dims.index("omega_bar")
    for i, name in enumerate(FREQUENCY_BANDS):
        sel = (ob >= edges[i]) & ((ob < edges[i + 1]) if i < len(FREQUENCY_BANDS) - 1
                                  else (ob <= edges[i + 1]))
        r = np.compress(sel, r_all, axis=axis)
        o = np.compress(sel, np.asarray(other.values, dtype=float), axis=axis)
        finite = np.isfinite(r) & np.isfinite(o)
        diss = finite & (r > level)

        def rel(mask: np.ndarray, r: np.ndarray = r, o: np.ndarray = o) -> float:
            n = np.linalg.norm(r[mask])
            return float(np.linalg.norm(o[mask] - r[mask]) / n) if mask.any() and n > 0 \
                else float("nan")

        out[name] = {"omega_bar": [float(ob[sel].min()), float(ob[sel].max())],
                     "frequency_hz": [float(freq[sel].min()), float(freq[sel].max())],
                     "full_l2": rel(finite), "dissipative_l2": rel(diss),
                     "n_points": int(finite.sum()), "n_dissipative": int(diss.sum())}
    return out


# -- beam ----------------------------------------------------------------------------------------
def _result_from_file(path: Path | None) -> dict[str, Any] | None:
    """A beam result (``sloshrom.beam.results.to_dataset`` layout) read back as a result dict."""
    if path is None or not path.is_file():
        return None
    with xr.open_dataset(path, engine="h5netcdf") as ds:
        out: dict[str, Any] = {k: np.asarray(ds[k].values) for k in ds.data_vars}
        out["time"] = np.asarray(ds["time"].values)
        out["fs"] = float(ds.attrs["fs"])
        if "level" in ds.coords:
            out["rms_levels_g"] = np.asarray(ds["level"].values)
    return out


def _table2_by_level(rows: Sequence[Mapping[str, Any]], case: str) -> dict[str, float]:
    # the reference estimator's damping of one case by level (g, as text), from its records
    t2 = table2_dataset([r for r in rows if r["case"] == case])
    return {f"{lv:g}": float(v) for lv, v in zip(t2.level.values,
                                                 t2["value"].sel(estimator=REFERENCE).values,
                                                 strict=True)}


def comparison_rows(outputs: Mapping[str, Any]) -> list[dict[str, Any]]:
    """One row per model (ball, ROM, rig, frozen): map fidelity, Table 2 damping and its
    deviation from the rig, instantaneous damping per band; JSON-able, NaN/None where n/a."""
    t2 = outputs["table2_all"]
    inst = outputs["instantaneous_damping_all"]
    levels = list(_table2_by_level(t2, "rig"))
    rig2 = _table2_by_level(t2, "rig")
    rows = []
    for case, fid_key in ((CASE, "ball_fidelity"), ("rom", "rom_fidelity"), ("rig", None),
                          ("frozen", None)):
        if case not in inst:
            continue
        fid = outputs.get(fid_key) if fid_key else None
        z2 = _table2_by_level(t2, case)
        rows.append({
            "model": case,
            "full_l2": fid["full_l2"] if fid else None,
            "dissipative_l2": fid["dissipative_l2"] if fid else None,
            "n_nonpassive": fid["n_nonpassive"] if fid else None,
            REFERENCE_KEY: z2,
            "table2_vs_rig": {lv: z2[lv] / rig2[lv] - 1 if lv in z2 and rig2[lv] else None
                              for lv in levels},
            "instantaneous_damping": {k: v for k, v in inst[case].items() if k.endswith(" g")},
        })
    return rows


def ball_against_experiment(beam_outputs: Mapping[str, Any], table2: xr.Dataset,
                            bands: list[dict[str, Any]], random: Mapping[str, Any],
                            decay: Mode1Decay, fs: float, f1: float) -> dict[str, Any]:
    """The ball's damping beside the rig playing the laboratory (the ``beam`` stage's
    ``experiment``, read from its record): ``free`` and ``random`` rows of
    ``sloshrom.beam.compare.compare_rows``; ``table2`` is the ball's Table 2 over ``(level,
    estimator)``."""
    exp_random = [r for r in beam_outputs["table2"] if r["case"] == EXPERIMENT]
    exp_free = [r for r in beam_outputs.get("damping_bands", []) if r["case"] == EXPERIMENT]
    out: dict[str, Any] = {}
    if exp_random:
        measured = AnalysedTest(EXPERIMENT, "random", fs, f1, [],
                                levels=[float(r["rms_g"]) for r in exp_random],
                                table2=table2_dataset(exp_random))
        out["random"] = compare_rows(measured, [analysed_test(CASE, "random", random, f1,
                                                              table2)])
    if exp_free:
        measured = AnalysedTest(EXPERIMENT, "free", fs, f1, exp_free)
        out["free"] = compare_rows(measured, [analysed_test(CASE, "free", {"fs": fs}, f1, bands,
                                                            decay)])
    return out


# -- the stage -----------------------------------------------------------------------------------
def stage_baseline(ctx: Context, data: StageResult, rom: StageResult | None = None,
                   maps: StageResult | None = None, beam: StageResult | None = None
                   ) -> tuple[dict[str, Any], list[str]]:
    """Fit the bouncing ball and run it through the Phi_d map and the beam tests.

    Parameters
    ----------
    ctx : Context
        The run.
    data : StageResult
        The ``data`` stage: its recorded training and validation records.
    rom : StageResult, optional
        The ``rom`` stage: its model, for the comparison.
    maps : StageResult, optional
        The ``maps`` stage: the rig's and the ROM's maps it recorded are read, the others
        computed.
    beam : StageResult, optional
        The ``beam`` stage: its ``table2`` and ``instantaneous_damping`` rows of the rig, the ROM
        and frozen liquid are used as they are, its recorded result files for the figures.
        Without it the rows and results are computed by running the tests.

    Returns
    -------
    outputs : dict
        The record of :class:`~sloshrom.studies.baseline.outputs.BaselineOutputs`, JSON-able:
        ``parameters`` (:meth:`BouncingBall.parameters`), ``fit`` (the fit's
        history: objective, NRMSE, validation errors, seconds), ``fit_seconds`` (s),
        ``rig_mass_fraction`` (the rig physics' impacting fraction ``beta``, -),
        ``validation_nrmse_lowpassed`` (ball and ROM on the validation record, both low-passed
        at the ball's cutoff, -), ``map_seconds`` (s), ``ball_maximum``, ``ball_fidelity`` and
        ``rom_fidelity`` (:func:`sloshrom.energy.map_fidelity` against the rig's map),
        ``frequency_bands`` (model -> :func:`frequency_band_errors`), ``f1_frozen_hz``,
        ``instantaneous_damping`` and ``table2`` (the ball's), ``instantaneous_damping_all``
        and ``table2_all`` (every case), ``envelope`` (the ball's runs against its training
        envelope), ``comparison`` (:func:`comparison_rows`).
    files : list of str
        Written files, relative to ``ctx.out``; the map, tables, beam results and figures appear
        together once everything has succeeded (the model file is written first, on its own).

    Raises
    ------
    KeyError
        The ``data`` stage recorded no training or validation record.
    """
    tank = ctx.tank
    cfg = ctx.cfg.beam
    fs = float(ctx.cfg.rig.fs)
    outputs: dict[str, Any] = {}
    steps = 6
    ctx.progress("baseline", 0, steps, "fitting the bouncing ball")
    t0 = time.perf_counter()
    train = read_record(data.output(TRAIN_RECORD))
    val = read_record(data.output(VALIDATION_RECORD))
    ball = fit_ball(ctx, train, val)
    outputs["fit_seconds"] = time.perf_counter() - t0
    outputs["parameters"] = ball.parameters()
    outputs["fit"] = dict(ball.history_)
    outputs["rig_mass_fraction"] = float(ctx.rig_params().beta)
    files = [ctx.rel(ball.save(ctx.path(*BALL_MODEL.split("/"))))]

    rom_model = load_model(rom.output(rom.outputs["model"])) if rom is not None else None
    cutoff = float(ball.history_["lowpass_hz"])
    nrmse = {CASE: lowpassed_nrmse(0.5 * (val["dynamic_force"][1:] + val["dynamic_force"][:-1]),
                                   ball.predict(val["velocity"])[:-1], val.fs, cutoff)
             if math.isfinite(cutoff) else float("nan")}
    if rom_model is not None and math.isfinite(cutoff):
        nrmse["rom"] = lowpassed_nrmse(val["dynamic_force"], rom_model.predict(val["velocity"]),
                                       val.fs, cutoff)
    outputs["validation_nrmse_lowpassed"] = nrmse

    # -- Phi_d maps
    ctx.progress("baseline", 1, steps, "Phi_d map of the bouncing ball")
    t0 = time.perf_counter()
    ball_map = compute_map(ball, ctx.cfg, tank)
    outputs["map_seconds"] = time.perf_counter() - t0
    rig_map = _read_map(maps.optional_output("maps/phi_d_rig.nc") if maps else None)
    if rig_map is None:
        ctx.progress("baseline", 1, steps, "Phi_d map of the rig (maps stage output absent)")
        rig_map = compute_map(ctx.rig(), ctx.cfg, tank)
    rom_map = _read_map(maps.optional_output("maps/phi_d_rom.nc") if maps else None)
    if rom_map is None and rom_model is not None:
        ctx.progress("baseline", 1, steps, "Phi_d map of the ROM (maps stage output absent)")
        rom_map = compute_map(rom_model, ctx.cfg, tank)
    outputs["ball_maximum"] = map_maximum(ball_map)
    outputs["ball_fidelity"] = map_fidelity(rig_map, ball_map)
    bands = {CASE: frequency_band_errors(rig_map, ball_map)}
    if rom_map is not None:
        outputs["rom_fidelity"] = map_fidelity(rig_map, rom_map)
        bands["rom"] = frequency_band_errors(rig_map, rom_map)
    outputs["frequency_bands"] = bands

    # -- beam tests
    ctx.progress("baseline", 2, steps, "beam tests with the bouncing ball")
    _, modal = beam_structure(cfg, tank)
    f1 = float(coupled_frozen_modes(modal, tank.liquid_mass)[0][0])
    outputs["f1_frozen_hz"] = f1
    tests = beam_tests(cfg, modal, tank, fs)
    free = simulate_cases({CASE: ball}, tests["free"], fs)
    rand = simulate_cases({CASE: ball}, tests["random"], fs)
    decays = {CASE: mode1_decay(free[CASE], modal, f1)}
    outputs["instantaneous_damping"] = damping_summary(free, decays)
    table2 = mode1_damping_dataset(rand, cfg.rms_g, f1, max_tank_acceleration=True)
    outputs["table2"] = table2_rows(table2)
    outputs["envelope"] = envelope_table({"free": free, "random": rand})

    # the other cases: the beam stage's results (files), recomputed only where absent
    ctx.progress("baseline", 3, steps, "rig, ROM and frozen beam results")
    others: dict[str, SloshingModel | None] = {"frozen": FrozenLiquid(1.0 / fs), "rig": None,
                                               "rom": rom_model}
    free_all, rand_all = {}, {}
    for case, model in others.items():
        if case == "rom" and rom_model is None:
            continue
        fr = _result_from_file(beam.optional_output(f"beam/free_{case}.nc") if beam else None)
        ra = _result_from_file(beam.optional_output(f"beam/random_{case}.nc") if beam else None)
        if fr is None or ra is None:
            m = model if model is not None else ctx.rig()
            # an ensemble ROM member by member, as the beam stage couples it
            fr = simulate_cases({case: coupled_model(m)}, tests["free"], fs)[case]
            ra = simulate_cases({case: coupled_model(m)}, tests["random"], fs)[case]
        free_all[case], rand_all[case] = fr, ra
    free_all[CASE], rand_all[CASE] = free[CASE], rand[CASE]
    decays_all = {c: decays[c] if c == CASE else mode1_decay(r, modal, f1)
                  for c, r in free_all.items()}
    beam_outputs = beam.outputs if beam is not None else None
    if beam_outputs is not None and "table2" in beam_outputs:
        outputs["table2_all"] = [*beam_outputs["table2"], *outputs["table2"]]
        outputs["instantaneous_damping_all"] = {**beam_outputs["instantaneous_damping"],
                                                **outputs["instantaneous_damping"]}
    else:
        others_free = {c: r for c, r in free_all.items() if c != CASE}
        others_rand = {c: r for c, r in rand_all.items() if c != CASE}
        outputs["table2_all"] = [*table2_rows(mode1_damping_dataset(
            others_rand, cfg.rms_g, f1, max_tank_acceleration=True)), *outputs["table2"]]
        outputs["instantaneous_damping_all"] = {
            **damping_summary(others_free, {c: decays_all[c] for c in others_free}),
            **outputs["instantaneous_damping"]}
    outputs["comparison"] = comparison_rows(outputs)
    if beam_outputs is not None and "experiment" in beam_outputs:
        outputs["experiment"] = ball_against_experiment(
            beam_outputs, table2.sel(case=CASE), damping_band_table(free, decays, f1), rand[CASE],
            decays[CASE], fs, f1)

    # -- files, all together
    ctx.progress("baseline", 4, steps, "figures")
    figs = {}
    fig21 = free_figures(free_all, modal, decays_all)["fig21_instantaneous_damping"]
    fig21.suptitle("First-mode instantaneous damping: bouncing ball beside rig, ROM, frozen")
    figs["baseline_instantaneous_damping"] = fig21
    rfigs = random_figures(rand_all, cfg.rms_g, random_window(cfg.random_duration))
    figs["baseline_tank_acceleration_window"] = rfigs["fig22_tank_acceleration_window"]
    figs["baseline_psd"] = rfigs["fig23_psd"]
    figs["baseline_frequency_bands"] = frequency_band_figure(
        {("bouncing ball" if k == CASE else "ROM"): v for k, v in bands.items()})
    out = ctx.out / "beam"
    with OutputBatch() as batch:
        for kind, res in (("free", free), ("random", rand)):
            write_dataset(to_dataset(res[CASE], CASE, kind, tank, modal, cfg.seed),
                          out / f"{kind}_{CASE}.nc", batch)
        write_table(outputs["table2"], out / "table2_mode1_damping_ball", batch)
        for name, fig in figs.items():
            savefig(fig, ctx.path("figures", f"{name}.png"), batch)
        files += [ctx.rel(p) for p in batch.paths]
    fid = outputs["ball_fidelity"]
    files += [ctx.rel(p) for p in write_map(
        ball_map, ctx.path("maps", "phi_d_bouncing_ball.nc"), "bouncing ball",
        negative_below=fid["passivity_threshold"])]
    diff = (ball_map - rig_map.transpose(*ball_map.dims)).rename("phi_d")
    diff.attrs = {"units": "1", "long_name": "Phi_d(bouncing ball) - Phi_d(rig)"}
    files += [ctx.rel(p) for p in write_map(
        diff, ctx.path("maps", "phi_d_bouncing_ball_difference.nc"), "bouncing ball minus rig",
        kind="difference")]
    ctx.progress("baseline", steps, steps, "done")
    return BaselineOutputs.from_record(outputs).as_record(), files
