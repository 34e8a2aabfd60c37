"""The ``beam`` stage of `sloshrom reproduce`: sloshing-beam tests with rig, ROM and frozen liquid
(paper Sect. 4–5: Table 1, Figs. 14, 16, 18, 20–23, Table 2)."""

from __future__ import annotations

import html
from pathlib import Path
from typing import Any

import numpy as np

from sloshrom.config import G
from sloshrom.pipeline.chain import Context
from sloshrom.pipeline.html import Figure, Section, Table

BEAM_KEYS = ("length", "width", "thickness", "youngs_modulus", "density")

# tank-acceleration bands (g) in which the instantaneous first-mode damping is averaged
BANDS = ((0.5, 1.0), (1.0, 2.0), (2.0, 3.0), (3.0, 5.0))


def damping_by_band(zeta: np.ndarray, amplitude_g: np.ndarray) -> dict[str, float]:
    """Median instantaneous damping ratio in each tank-acceleration band (NaN if empty)."""
    out = {}
    for lo, hi in BANDS:
        sel = (amplitude_g >= lo) & (amplitude_g < hi)
        out[f"{lo:g}-{hi:g} g"] = float(np.median(zeta[sel])) if sel.sum() > 10 else float("nan")
    return out


def beam_structure(cfg: dict[str, Any], tank: Any) -> tuple[Any, Any]:
    """The dry beam of the ``[beam]`` configuration and its modal model.

    Virtual accelerometers at 1/5, 2/5, ..., 5/5 of the length (the last at the tank).
    """
    from sloshrom.beam.structure import CantileverBeam, ModalModel

    beam = CantileverBeam.with_tank(tank, **{k: cfg[k] for k in BEAM_KEYS})
    stations = tuple(beam.length * k / 5 for k in range(1, 6))
    damping = cfg["damping"][: cfg["n_modes"]]  # one ratio per kept mode (extra ones unused)
    modal = ModalModel.from_beam(beam, tank, n_modes=cfg["n_modes"], damping=damping,
                                 stations=stations)
    return beam, modal


def base_excitation_figure(res: dict[str, Any], cfg: dict[str, Any], fs: float) -> Any:
    """Paper Fig. 17: the imposed base accelerations, time histories and Welch PSDs.

    The dashed curves are the target spectrum of Eq. (8) scaled to each RMS level; the inset
    zooms on the lowest level, as in the paper.
    """
    from sloshrom.beam.analysis import welch_psd
    from sloshrom.pipeline.chain import _plt
    from sloshrom.signals import gaussian_psd

    plt = _plt()
    a = np.asarray(res["base_acceleration"])
    t = np.asarray(res["time"])
    levels = list(cfg["rms_g"])
    fig, (ax_t, ax_f) = plt.subplots(1, 2, figsize=(11, 4.2), constrained_layout=True)
    t0 = min(40.0, 0.5 * t[-1])
    sel = (t >= t0) & (t <= t0 + 2.0)
    for i, lv in enumerate(levels):
        ax_t.plot(t[sel], a[i][sel] / G, lw=0.7, label=f"{lv:g} g RMS")
    ax_t.set_xlabel("time [s]")
    ax_t.set_ylabel("base acceleration [g]")
    ax_t.set_title("(a) imposed base acceleration (2 s window)")
    ax_t.legend(fontsize=8)
    f, p = welch_psd(a / G, fs, nperseg=min(4096, a.shape[-1]))
    fmax = cfg["f0"] + 5 * cfg["sigma"]
    lines = []
    for i, lv in enumerate(levels):
        (ln,) = ax_f.plot(f, p[i], lw=0.8, label=f"{lv:g} g RMS")
        lines.append(ln)
        ax_f.plot(f, gaussian_psd(f, cfg["f0"], cfg["sigma"], lv**2), "k--", lw=0.8)
    ax_f.set_xlim(0, fmax)
    ax_f.set_xlabel("frequency [Hz]")
    ax_f.set_ylabel("PSD [g²/Hz]")
    ax_f.set_title("(b) Welch PSD (Hann, 4096 samples); dashed: Eq. (8)")
    ax_f.legend(fontsize=8, loc="upper left")
    ins = ax_f.inset_axes([0.64, 0.45, 0.34, 0.4])
    ins.plot(f, p[0], lw=0.8, color=lines[0].get_color())
    ins.plot(f, gaussian_psd(f, cfg["f0"], cfg["sigma"], levels[0] ** 2), "k--", lw=0.8)
    ins.set_xlim(0, fmax)
    ins.set_title(f"{levels[0]:g} g RMS", fontsize=7)
    ins.tick_params(labelsize=6)
    return fig


def stage_beam(ctx: Context, rom_path: Path | None) -> tuple[dict[str, Any], list[str]]:
    from sloshrom.beam.analysis import instantaneous_damping, modal_filter, mode1_damping_random
    from sloshrom.beam.coupled import free_response, random_response
    from sloshrom.beam.structure import coupled_frozen_modes, frozen_modal_table
    from sloshrom.cli.beam import (
        _savefig,
        _write_nc,
        _write_table,
        free_figures,
        random_figures,
        to_dataset,
    )
    from sloshrom.fileio import OutputBatch
    from sloshrom.models import FrozenLiquid

    cfg = ctx.cfg["beam"]
    fs = float(ctx.cfg["rig"]["fs"])  # the beam's sensors record at the rig's record rate
    tank = ctx.tank
    out = ctx.out / "beam"
    out.mkdir(parents=True, exist_ok=True)
    beam, modal = beam_structure(cfg, tank)
    models: dict[str, Any] = {"frozen": FrozenLiquid(1.0 / fs), "rig": ctx.rig()}
    if rom_path is not None:
        from sloshrom.rom.estimators import load_model

        models["rom"] = load_model(rom_path)
    outputs: dict[str, Any] = {}
    f1 = float(coupled_frozen_modes(modal, tank.liquid_mass)[0][0])
    outputs["f1_frozen_hz"] = f1

    rows = frozen_modal_table(tank, beam=beam, n_modes=cfg["n_modes"],
                              damping=modal.damping.tolist())
    outputs["table1"] = rows

    steps = 2 * len(models)
    k = 0
    free_res, rand_res = {}, {}
    for case, model in models.items():
        ctx.progress("beam", k, steps, f"free response: {case}")
        out_fs = fs if 1.0 / model.dt > fs else None
        free_res[case] = free_response(model, modal, cfg["tip_displacement"],
                                       cfg["free_duration"], tank, out_fs)
        k += 1
    for case, model in models.items():
        ctx.progress("beam", k, steps, f"random response: {case}")
        out_fs = fs if 1.0 / model.dt > fs else None
        rand_res[case] = random_response(model, modal, cfg["rms_g"], cfg["random_duration"],
                                         cfg["seed"], cfg["f0"], cfg["sigma"], signal_fs=fs,
                                         tank=tank, output_fs=out_fs)
        k += 1
    ctx.progress("beam", steps, steps, "analysis and figures")

    inst: dict[str, Any] = {}
    for case, r in free_res.items():
        x = modal_filter(r["station_acceleration"] - r["base_acceleration"][..., None],
                         modal.psi_stations)[:, 0]
        h = instantaneous_damping(x, r["fs"], f1, reference=r["tank_acceleration"])
        inst[case] = damping_by_band(h["zeta"], h["amplitude"] / G)
        inst[case]["initial_tank_acceleration_g"] = float(np.max(np.abs(r["tank_acceleration"]))
                                                          / G)
    outputs["instantaneous_damping"] = inst

    table2 = []
    for case, r in rand_res.items():
        for i, level in enumerate(cfg["rms_g"]):
            d = mode1_damping_random(r["base_acceleration"][i], r["tank_acceleration"][i],
                                     r["fs"], f1)
            table2.append({"case": case, "rms_g": level,
                           "max_tank_acceleration_g": float(np.max(np.abs(
                               r["tank_acceleration"][i])) / G), **d})
    outputs["table2"] = table2

    figs = {**free_figures(free_res, modal, tank), **random_figures(rand_res, cfg["rms_g"],
            window=(min(40.0, cfg["random_duration"] / 2), min(42.0, cfg["random_duration"] / 2
                                                                + 2)))}
    figs["fig17_base_excitation"] = base_excitation_figure(rand_res["frozen"], cfg, fs)
    # every result file of the stage appears together, once everything above has succeeded
    with OutputBatch() as batch:
        for case in models:
            for kind, res in (("free", free_res), ("random", rand_res)):
                _write_nc(to_dataset(res[case], case, kind, tank, modal, cfg["seed"]),
                          out / f"{kind}_{case}.nc", batch)
        _write_table(rows, out / "table1_frozen_modes", batch)
        _write_table(table2, out / "table2_mode1_damping", batch)
        for name, fig in figs.items():
            _savefig(fig, ctx.path("figures", f"{name}.png"), batch)
        files = [ctx.rel(p) for p in batch.paths]
    return outputs, files


def _pct(v: Any) -> str:
    try:
        return "–" if not np.isfinite(v) else f"{100 * float(v):.2f} %"
    except TypeError:
        return "–"


def report_sections(ctx: Context, b: dict[str, Any]) -> list[Section]:
    figdir = Path(ctx.out) / "figures"

    def fig(name: str, cap: str) -> list[Figure]:
        p = figdir / f"{name}.png"
        return [Figure(p, cap)] if p.is_file() else []

    t1 = Table(["mode", "f dry [Hz]", "f frozen [Hz]", "f coupled [Hz]", "ζ", "modal mass [kg]"],
               [[r["mode"], r["f_dry_Hz"], r["f_frozen_Hz"], r["f_coupled_Hz"],
                 _pct(r["damping"]), r["modal_mass_kg"]] for r in b["table1"]],
               "Table 1 analogue: modes of the beam with frozen liquid (unit maximum "
               "displacement normalisation; damping ratios are estimates).")
    inst = b["instantaneous_damping"]
    cases = list(inst)
    bands = [k for k in next(iter(inst.values())) if k.endswith(" g")]
    t_inst = Table(["tank acceleration"] + cases,
                   [[band] + [_pct(inst[c][band]) for c in cases] for band in bands],
                   "Median first-mode instantaneous damping (Hilbert) in bands of tank "
                   "acceleration amplitude, free response.")
    def spread(r: dict[str, Any], key: str) -> str:
        return f"{_pct(r[key])} ± {_pct(r[key + '_iqr'] / 2)}"

    t2 = Table(["case", "RMS [g]", "max tank acc. [g]", "LSCF on H1", "output-only LSCF",
                "half power"],
               [[r["case"], r["rms_g"], r["max_tank_acceleration_g"], spread(r, "lscf_h1"),
                 spread(r, "lscf_output"), _pct(r["half_power"])] for r in b["table2"]],
               "Table 2 analogue: first-mode damping from the random tests. LSCF columns: "
               "median over the stable poles of model orders 2-40 ± half their interquartile "
               "range; output-only: half-spectrum of the tank acceleration (no base signal "
               "needed), corrected for its exponential window.")
    free_text = (
        f"<p>Free response from a {ctx.cfg['beam']['tip_displacement'] * 100:.2f} cm static tip "
        f"deflection (initial tank acceleration "
        f"{inst.get('frozen', {}).get('initial_tank_acceleration_g', float('nan')):.1f} g). "
        "The rig plays the experiment; the ROM runs in the same coupled model; the frozen case "
        "has Δf = 0. First-mode frequency with frozen liquid: "
        f"{b['f1_frozen_hz']:.2f} Hz.</p>"
    )
    return [
        Section("6. Sloshing beam: modes (paper Table 1)", "", tables=[t1]),
        Section(
            "7. Free response (paper Figs. 14, 16, 20, 21)", free_text,
            fig("fig14_station_accelerations", "Fig. 14 — virtual accelerometers along the beam,"
                " frozen vs sloshing.")
            + fig("fig16_modal_accelerations", "Fig. 16 — modal accelerations from modal "
                  "filtering: sloshing damps mode 1 most.")
            + fig("fig20_tank_interface_dynamic", "Fig. 20 — tank acceleration, interface force"
                  " and dynamic sloshing force.")
            + fig("fig21_instantaneous_damping", "Fig. 21 — first-mode instantaneous damping "
                  "against tank acceleration amplitude (Hilbert envelope, log-decrement dots)."),
            [t_inst],
        ),
        Section(
            "8. Random base excitation (paper Figs. 18, 22, 23, Table 2)",
            "<p>Gaussian-PSD base acceleration (Eq. 8), "
            + html.escape(", ".join(f"{g:g}" for g in ctx.cfg["beam"]["rms_g"]))
            + f" g RMS, {ctx.cfg['beam']['random_duration']:.0f} s, the same phases for every "
            "level and every case.</p>",
            fig("fig17_base_excitation", "Fig. 17 — the base accelerations imposed at the "
                "beam root (the same signal for every case): a 2 s window and their Welch PSDs "
                "against the Gaussian spectrum of Eq. (8) (dashed).")
            + fig("fig18_tank_acceleration", "Fig. 18 — tank acceleration at the three levels "
                  "(sloshing).")
            + fig("fig22_tank_acceleration_window", "Fig. 22 — tank acceleration in a 2 s "
                  "window: rig, ROM and frozen.")
            + fig("fig23_psd", "Fig. 23 — Welch PSDs of the tank acceleration: sloshing lowers "
                  "the resonance peak."),
            [t2],
        ),
    ]
