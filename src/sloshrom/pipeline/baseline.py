"""The ``baseline`` stage of `sloshrom reproduce`: the bouncing-ball equivalent mechanical model
(:class:`sloshrom.rom.bouncing.BouncingBall`) through the same Phi_d map, beam tests and Table 2
as the ROM, side by side with it.

The stage reads the records of the ``data`` stage and, when they exist, the maps of the ``maps``
stage (``maps/phi_d_rig.nc``, ``maps/phi_d_rom.nc``) and the beam results of the ``beam`` stage
(``beam/{free,random}_<case>.nc``); what is missing is recomputed, so the stage also runs on a
partial output directory. :func:`baseline_section` turns its outputs into a report section.
"""

from __future__ import annotations

import math
import time
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr
from matplotlib.figure import Figure

from sloshrom.beam.results import (
    damping_summary,
    envelope_table,
    mode1_damping_table,
    mode1_decay,
    simulate_cases,
    to_dataset,
    write_dataset,
    write_table,
)
from sloshrom.beam.structure import coupled_frozen_modes
from sloshrom.energy import DISSIPATIVE_THRESHOLD, map_fidelity, map_maximum
from sloshrom.fileio import OutputBatch
from sloshrom.io import read_record
from sloshrom.models import FrozenLiquid, SloshingModel
from sloshrom.pipeline.beam import beam_structure, beam_tests
from sloshrom.pipeline.context import Context
from sloshrom.pipeline.html import Figure as ReportFigure
from sloshrom.pipeline.html import Section, Table
from sloshrom.pipeline.maps import compute_map, write_map
from sloshrom.plotting import savefig
from sloshrom.plotting.beam import free_figures, random_figures, random_window
from sloshrom.rom.bouncing import BouncingBall, lowpass_gain
from sloshrom.rom.estimators import load_model

__all__ = [
    "BALL_KEYS", "BALL_MODEL", "CASE", "FREQUENCY_BANDS", "baseline_section", "comparison_rows",
    "fit_ball", "frequency_band_errors", "frequency_band_figure", "lowpassed_nrmse",
    "stage_baseline",
]

#: The ball's model file, relative to the output directory.
BALL_MODEL = "models/bouncing_ball.toml"
#: The ball's case name in the beam results and tables.
CASE = "ball"
#: Names of the thirds of the omega_bar range of the map (low, mid, high frequencies).
FREQUENCY_BANDS = ("low", "mid", "high")


# -- identification ------------------------------------------------------------------------------
def lowpassed_nrmse(y: np.ndarray, y_hat: np.ndarray, fs: float, cutoff: float) -> float:
    """RMS of ``y_hat - y`` over the RMS of ``y``, both low-passed by the ball's objective
    filter (:func:`sloshrom.rom.bouncing.lowpass_gain`, zero phase, ``cutoff`` in Hz), -."""
    f = np.fft.rfftfreq(y.size, 1.0 / fs)
    gain = lowpass_gain(f, cutoff)

    def lp(x: np.ndarray) -> np.ndarray:
        return np.fft.irfft(np.fft.rfft(x) * gain, y.size)

    ref = lp(y)
    return float(np.sqrt(np.mean((lp(y_hat) - ref) ** 2) / np.mean(ref**2)))


#: Keys of an optional ``[baseline]`` configuration table passed to :class:`BouncingBall`.
BALL_KEYS = ("mass_fraction", "restitution", "gap_factor", "seed", "lowpass", "n_substeps",
             "maxiter", "popsize", "tol")


def fit_ball(ctx: Context) -> BouncingBall:
    """The bouncing ball identified on ``data/train.nc`` (validation: ``data/validation.nc``).

    Hyperparameters: :class:`BouncingBall`'s defaults, overridden by the :data:`BALL_KEYS` of a
    ``[baseline]`` table of the configuration if it has one. The acceleration is the forward
    difference of the record's velocity (:func:`sloshrom.rom.bouncing.forward_acceleration`),
    the exact mean acceleration over each sample step, as the ROM sees the tank through the
    same velocity.
    """
    table = ctx.cfg.get("baseline") or {}
    options = {k: table[k] for k in BALL_KEYS if table.get(k) is not None}
    train = read_record(ctx.out / "data" / "train.nc")
    val = read_record(ctx.out / "data" / "validation.nc")
    return BouncingBall(tank=ctx.tank, **options).fit(
        train["velocity"], train["dynamic_force"], train.fs,
        validation=(val["velocity"], val["dynamic_force"]))


# -- maps ----------------------------------------------------------------------------------------
def _read_map(path: Path) -> xr.DataArray | None:
    if not path.is_file():
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


def frequency_band_figure(errors: Mapping[str, Mapping[str, Mapping[str, Any]]]) -> Figure:
    """Bars of the full-map and dissipative-region errors per frequency band, one colour per
    model (``errors``: model -> :func:`frequency_band_errors`)."""
    fig = Figure(figsize=(9, 3.6), layout="constrained")
    axes = fig.subplots(1, 2, sharey=True)
    models = list(errors)
    x = np.arange(len(FREQUENCY_BANDS))
    width = 0.8 / max(len(models), 1)
    for ax, key, title in ((axes[0], "full_l2", "whole map"),
                           (axes[1], "dissipative_l2", "dissipative region")):
        for j, model in enumerate(models):
            vals = [100 * errors[model][b][key] for b in FREQUENCY_BANDS]
            ax.bar(x + (j - (len(models) - 1) / 2) * width, vals, width, label=model)
        some = errors[models[0]] if models else {}
        ax.set_xticks(x, [f"{b}\n{some[b]['frequency_hz'][0]:.1f}-"
                          f"{some[b]['frequency_hz'][1]:.1f} Hz" if b in some else b
                          for b in FREQUENCY_BANDS])
        ax.set_title(f"Phi_d error vs rig: {title}")
    axes[0].set_ylabel("relative L2 error (%)")
    axes[0].legend()
    return fig


# -- beam ----------------------------------------------------------------------------------------
def _result_from_file(path: Path) -> dict[str, Any] | None:
    """A beam result (``sloshrom.beam.results.to_dataset`` layout) read back as a result dict."""
    if not path.is_file():
        return None
    with xr.open_dataset(path, engine="h5netcdf") as ds:
        out: dict[str, Any] = {k: np.asarray(ds[k].values) for k in ds.data_vars}
        out["time"] = np.asarray(ds["time"].values)
        out["fs"] = float(ds.attrs["fs"])
        if "level" in ds.coords:
            out["rms_levels_g"] = np.asarray(ds["level"].values)
    return out


def _table2_by_level(rows: Sequence[Mapping[str, Any]], case: str) -> dict[str, float]:
    return {f"{r['rms_g']:g}": float(r["lscf_h1"]) for r in rows if r["case"] == case}


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
            "table2_lscf_h1": z2,
            "table2_vs_rig": {lv: z2[lv] / rig2[lv] - 1 if lv in z2 and rig2[lv] else None
                              for lv in levels},
            "instantaneous_damping": {k: v for k, v in inst[case].items() if k.endswith(" g")},
        })
    return rows


# -- the stage -----------------------------------------------------------------------------------
def stage_baseline(ctx: Context, rom_path: Path | None,
                   beam_outputs: Mapping[str, Any] | None = None
                   ) -> tuple[dict[str, Any], list[str]]:
    """Fit the bouncing ball and run it through the Phi_d map and the beam tests.

    Parameters
    ----------
    ctx : Context
        The run (``data/train.nc`` and ``data/validation.nc`` must exist).
    rom_path : Path or None
        The ROM's model file, for the comparison (its map is read from ``maps/phi_d_rom.nc``
        when that exists, else computed).
    beam_outputs : mapping, optional
        The outputs of the ``beam`` stage: its ``table2`` and ``instantaneous_damping`` rows of
        the rig, the ROM and frozen liquid are used as they are. Without them the rows are
        computed from the ``beam`` stage's result files, or by running the tests.

    Returns
    -------
    outputs : dict
        JSON-able: ``parameters`` (:meth:`BouncingBall.parameters`), ``fit`` (the fit's
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
    """
    tank = ctx.tank
    cfg = ctx.cfg["beam"]
    fs = float(ctx.cfg["rig"]["fs"])
    outputs: dict[str, Any] = {}
    steps = 6
    ctx.progress("baseline", 0, steps, "fitting the bouncing ball")
    t0 = time.perf_counter()
    ball = fit_ball(ctx)
    outputs["fit_seconds"] = time.perf_counter() - t0
    outputs["parameters"] = ball.parameters()
    outputs["fit"] = dict(ball.history_)
    outputs["rig_mass_fraction"] = float(ctx.rig_params().beta)
    files = [ctx.rel(ball.save(ctx.path(*BALL_MODEL.split("/"))))]

    rom = load_model(rom_path) if rom_path is not None else None
    val = read_record(ctx.out / "data" / "validation.nc")
    cutoff = float(ball.history_["lowpass_hz"])
    nrmse = {CASE: lowpassed_nrmse(0.5 * (val["dynamic_force"][1:] + val["dynamic_force"][:-1]),
                                   ball.predict(val["velocity"])[:-1], val.fs, cutoff)
             if math.isfinite(cutoff) else float("nan")}
    if rom is not None and math.isfinite(cutoff):
        nrmse["rom"] = lowpassed_nrmse(val["dynamic_force"], rom.predict(val["velocity"]),
                                       val.fs, cutoff)
    outputs["validation_nrmse_lowpassed"] = nrmse

    # -- Phi_d maps
    ctx.progress("baseline", 1, steps, "Phi_d map of the bouncing ball")
    t0 = time.perf_counter()
    ball_map = compute_map(ball, ctx.cfg, tank)
    outputs["map_seconds"] = time.perf_counter() - t0
    rig_map = _read_map(ctx.out / "maps" / "phi_d_rig.nc")
    if rig_map is None:
        ctx.progress("baseline", 1, steps, "Phi_d map of the rig (maps stage output absent)")
        rig_map = compute_map(ctx.rig(), ctx.cfg, tank)
    rom_map = _read_map(ctx.out / "maps" / "phi_d_rom.nc")
    if rom_map is None and rom is not None:
        ctx.progress("baseline", 1, steps, "Phi_d map of the ROM (maps stage output absent)")
        rom_map = compute_map(rom, ctx.cfg, tank)
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
    table2 = mode1_damping_table(rand, cfg["rms_g"], f1, max_tank_acceleration=True)
    outputs["table2"] = table2
    outputs["envelope"] = envelope_table({"free": free, "random": rand})

    # the other cases: the beam stage's results (files), recomputed only where absent
    ctx.progress("baseline", 3, steps, "rig, ROM and frozen beam results")
    others: dict[str, SloshingModel | None] = {"frozen": FrozenLiquid(1.0 / fs), "rig": None,
                                               "rom": rom}
    free_all, rand_all = {}, {}
    for case, model in others.items():
        if case == "rom" and rom is None:
            continue
        fr = _result_from_file(ctx.out / "beam" / f"free_{case}.nc")
        ra = _result_from_file(ctx.out / "beam" / f"random_{case}.nc")
        if fr is None or ra is None:
            m = model if model is not None else ctx.rig()
            fr = simulate_cases({case: m}, tests["free"], fs)[case]
            ra = simulate_cases({case: m}, tests["random"], fs)[case]
        free_all[case], rand_all[case] = fr, ra
    free_all[CASE], rand_all[CASE] = free[CASE], rand[CASE]
    decays_all = {c: decays[c] if c == CASE else mode1_decay(r, modal, f1)
                  for c, r in free_all.items()}
    if beam_outputs is not None and "table2" in beam_outputs:
        outputs["table2_all"] = [*beam_outputs["table2"], *table2]
        outputs["instantaneous_damping_all"] = {**beam_outputs["instantaneous_damping"],
                                                **outputs["instantaneous_damping"]}
    else:
        others_free = {c: r for c, r in free_all.items() if c != CASE}
        others_rand = {c: r for c, r in rand_all.items() if c != CASE}
        outputs["table2_all"] = [*mode1_damping_table(others_rand, cfg["rms_g"], f1,
                                                      max_tank_acceleration=True), *table2]
        outputs["instantaneous_damping_all"] = {
            **damping_summary(others_free, {c: decays_all[c] for c in others_free}),
            **outputs["instantaneous_damping"]}
    outputs["comparison"] = comparison_rows(outputs)

    # -- files, all together
    ctx.progress("baseline", 4, steps, "figures")
    figs = {}
    fig21 = free_figures(free_all, modal, decays_all)["fig21_instantaneous_damping"]
    fig21.suptitle("First-mode instantaneous damping: bouncing ball beside rig, ROM, frozen")
    figs["baseline_instantaneous_damping"] = fig21
    rfigs = random_figures(rand_all, cfg["rms_g"], random_window(cfg["random_duration"]))
    figs["baseline_tank_acceleration_window"] = rfigs["fig22_tank_acceleration_window"]
    figs["baseline_psd"] = rfigs["fig23_psd"]
    figs["baseline_frequency_bands"] = frequency_band_figure(
        {("bouncing ball" if k == CASE else "ROM"): v for k, v in bands.items()})
    out = ctx.out / "beam"
    with OutputBatch() as batch:
        for kind, res in (("free", free), ("random", rand)):
            write_dataset(to_dataset(res[CASE], CASE, kind, tank, modal, cfg["seed"]),
                          out / f"{kind}_{CASE}.nc", batch)
        write_table(table2, out / "table2_mode1_damping_ball", batch)
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
    return outputs, files


# -- report --------------------------------------------------------------------------------------
def _pct(v: Any, digits: int = 1) -> str:
    try:
        f = float(v)
    except (TypeError, ValueError):
        return "n/a"
    return "n/a" if not math.isfinite(f) else f"{100 * f:.{digits}f} %"


def _signed(v: Any) -> str:
    try:
        f = float(v)
    except (TypeError, ValueError):
        return "n/a"
    return "n/a" if not math.isfinite(f) else f"{100 * f:+.0f} %"


def _closer(a: Any, b: Any) -> str | None:
    """Which of two absolute errors is smaller: "ball", "ROM" or None (n/a or equal)."""
    try:
        fa, fb = abs(float(a)), abs(float(b))
    except (TypeError, ValueError):
        return None
    if not (math.isfinite(fa) and math.isfinite(fb)) or fa == fb:
        return None
    return "the ball" if fa < fb else "the ROM"


def _honest_paragraph(outputs: Mapping[str, Any]) -> str:
    """What the comparison shows, from the numbers (no claim is written in advance)."""
    rows = {r["model"]: r for r in outputs["comparison"]}
    ball, rom = rows.get(CASE), rows.get("rom")
    p = outputs["parameters"]
    bf = outputs["ball_fidelity"]
    parts = [f"The identified ball carries {p['mass_fraction']:.0%} of the liquid mass with "
             f"restitution {p['restitution']:.2f} in a gap of {1e3 * p['gap_m']:.1f} mm "
             f"({p['gap_factor']:.2f} × the ullage)."]
    beta = outputs.get("rig_mass_fraction")
    if isinstance(beta, float) and beta > 1.5 * p["mass_fraction"]:
        parts.append(
            f"That is far less than the rig's impacting column ({beta:.0%} of the liquid in "
            "its physics): a likely reason is that one lump lands with its whole impulse at "
            "once, where the rig's column is released layer by layer and loses coherence at "
            "large accelerations, so a force fit can only keep the lump small.")
    if rom is None:
        parts.append(f"Its Φ_d map is {_pct(bf['full_l2'])} off the rig's over the whole map "
                     f"and {_pct(bf['dissipative_l2'])} in the dissipative region.")
        return "<p>" + " ".join(parts) + "</p>"
    rf = outputs.get("rom_fidelity", {})
    parts.append(
        f"Against the rig's Φ_d map the ball is {_pct(bf['full_l2'])} off over the whole map "
        f"and {_pct(bf['dissipative_l2'])} in the dissipative region, the ROM "
        f"{_pct(rf.get('full_l2'))} and {_pct(rf.get('dissipative_l2'))}.")
    bands = outputs.get("frequency_bands", {})
    if CASE in bands and "rom" in bands:
        worse = [b for b in FREQUENCY_BANDS
                 if bands[CASE][b]["full_l2"] > bands["rom"][b]["full_l2"]]
        parts.append(
            "Per third of the frequency range the ball's map error is "
            + ", ".join(f"{_pct(bands[CASE][b]['full_l2'], 0)} ({b})" for b in FREQUENCY_BANDS)
            + " against the ROM's "
            + ", ".join(f"{_pct(bands['rom'][b]['full_l2'], 0)}" for b in FREQUENCY_BANDS)
            + (f": the ball is the worse model in {len(worse)} of the "
               f"{len(FREQUENCY_BANDS)} bands." if worse else ": the ball is not worse in any "
               "band."))
    levels = list(ball["table2_vs_rig"])
    dev_b = [ball["table2_vs_rig"][lv] for lv in levels]
    dev_r = [rom["table2_vs_rig"].get(lv) for lv in levels]
    parts.append(
        "In the beam's random tests (Table 2, LSCF on H1) the ball's first-mode damping "
        "deviates from the rig's by " + ", ".join(
            f"{_signed(d)} at {lv} g" for d, lv in zip(dev_b, levels, strict=True))
        + ", the ROM's by " + ", ".join(_signed(d) for d in dev_r) + ".")
    wins = [_closer(a, b) for a, b in zip(dev_b, dev_r, strict=True)]
    n_ball = sum(w == "the ball" for w in wins)
    parts.append(f"The ball is closer to the rig at {n_ball} of {len(levels)} levels.")
    inst = outputs["instantaneous_damping_all"]
    above = [b for b in ball["instantaneous_damping"] if float(b.split("-")[0]) >= 1.0]
    if "rig" in inst and above:
        def dev(case: str, band: str) -> str:
            return _signed(inst[case][band] / inst["rig"][band] - 1)
        parts.append(
            "In the free response the ball's instantaneous damping above 1 g deviates from the "
            "rig's by " + ", ".join(f"{dev(CASE, b)} ({b})" for b in above)
            + ", the ROM's by " + ", ".join(dev("rom", b) for b in above) + ".")
    nr = outputs.get("validation_nrmse_lowpassed", {})
    if "rom" in nr:
        parts.append(
            f"On the validation record the ball's force, low-passed to the band of the tank "
            f"motion, is {_pct(nr[CASE])} off (RMS error over RMS), the ROM's {_pct(nr['rom'])}.")
    parts.append(
        "What the ball cannot hold by construction: one coherent lump (no gradual "
        "Rayleigh-Taylor release, no loss of coherence at large accelerations, no surface "
        "waves), one restitution for every impact, and three parameters fitted on one record. "
        "A map or damping figure it matches is a figure that this much physics explains; "
        "where it misses, the difference is what the ROM learned beyond it.")
    return "<p>" + " ".join(parts) + "</p>"


def baseline_section(ctx: Context, outputs: Mapping[str, Any]) -> Section:
    """A report section: the ball's parameters, its row beside the ROM's (map fidelity, Table 2
    damping against the rig, instantaneous damping bands), its map and what the comparison
    shows (outputs of :func:`stage_baseline`)."""
    p = outputs["parameters"]
    fit = outputs["fit"]
    nr = outputs.get("validation_nrmse_lowpassed", {})
    params = Table(
        ["parameter", "value"],
        [["mass fraction β = m_b / m_l", f"{p['mass_fraction']:.3f}"],
         ["ball mass m_b", f"{1e3 * p['ball_mass_kg']:.1f} g"],
         ["restitution e", f"{p['restitution']:.3f}"],
         ["gap", f"{1e3 * p['gap_m']:.2f} mm ({p['gap_factor']:.2f} × ullage)"],
         ["step", f"1/{p['fs_hz']:g} s"],
         ["fit", f"{fit.get('evaluations', 'n/a')} simulations, "
                 f"{outputs.get('fit_seconds', float('nan')):.1f} s; force low-passed at "
                 f"{fit.get('lowpass_hz', float('nan')):.1f} Hz"],
         ["validation NRMSE (low-passed)", f"ball {_pct(nr.get(CASE))}, ROM "
                                           f"{_pct(nr.get('rom'))}"]],
        "The identified bouncing ball (docs/rom.md, \"The bouncing-ball baseline\").")
    rows = outputs["comparison"]
    levels = list(rows[0]["table2_lscf_h1"]) if rows else []
    bands = list(rows[0]["instantaneous_damping"]) if rows else []
    header = (["model", "full-map L2", "dissipative L2", "non-passive points"]
              + [f"ζ1 {lv} g (vs rig)" for lv in levels]
              + [f"inst. ζ1 {b}" for b in bands])
    body = []
    for r in rows:
        def na(v: Any, fmt: str) -> str:
            return "–" if v is None else fmt.format(v)
        body.append(
            [r["model"], na(r["full_l2"], "{:.1%}"), na(r["dissipative_l2"], "{:.1%}"),
             na(r["n_nonpassive"], "{:d}")]
            + [f"{_pct(r['table2_lscf_h1'].get(lv), 2)} ({_signed(r['table2_vs_rig'].get(lv))})"
               for lv in levels]
            + [_pct(r["instantaneous_damping"].get(b), 2) for b in bands])
    comp = Table(header, body, "Bouncing ball beside the ROM: Φ_d map against the rig's, "
                 "first-mode damping of the random tests (Table 2, LSCF on H1; in brackets the "
                 "deviation from the rig), median instantaneous damping of the free response "
                 "per band of tank acceleration.")
    fb = outputs.get("frequency_bands", {})
    band_rows = [[m, b, f"{v[b]['frequency_hz'][0]:.1f}–{v[b]['frequency_hz'][1]:.1f} Hz",
                  _pct(v[b]["full_l2"]), _pct(v[b]["dissipative_l2"])]
                 for m, v in fb.items() for b in FREQUENCY_BANDS]
    band_table = Table(["model", "band", "frequencies", "full L2", "dissipative L2"], band_rows,
                       "Φ_d map error against the rig per third of the frequency range: does "
                       "the fit carry over to other frequencies?")
    out = Path(ctx.out)

    def fig(rel: str, caption: str) -> list[ReportFigure]:
        path = out / rel
        return [ReportFigure(path, caption)] if path.is_file() else []

    figures = (
        fig("maps/phi_d_bouncing_ball.png", "Φ_d(ω̄, ā) of the bouncing ball (orange: below "
            "the passivity threshold).")
        + fig("maps/phi_d_bouncing_ball_difference.png", "Bouncing ball minus rig.")
        + fig("figures/baseline_frequency_bands.png", "Map error per frequency band, ball and "
              "ROM.")
        + fig("figures/baseline_instantaneous_damping.png", "First-mode instantaneous damping "
              "against tank acceleration amplitude, free response.")
        + fig("figures/baseline_psd.png", "Welch PSDs of the tank acceleration in the random "
              "tests.")
    )
    return Section("The bouncing-ball baseline", _honest_paragraph(outputs), figures,
                   [params, comp, band_table])
