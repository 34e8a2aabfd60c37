"""The reproduce report: ``OUT/report.html``, one self-contained page in the paper's order."""

from __future__ import annotations

import html
from pathlib import Path
from typing import Any

from sloshrom.config import Tank
from sloshrom.pipeline import html as report
from sloshrom.pipeline import settings
from sloshrom.pipeline.html import Figure, Section, Table


def _fig(ctx: Any, name: str, caption: str) -> list[Figure]:
    p = Path(ctx.out) / "figures" / name
    if not p.is_file():
        p = Path(ctx.out) / name
    return [Figure(p, caption)] if p.is_file() else []


def _num(d: dict[str, Any], *keys: str, fmt: str = "{:.3g}", default: str = "n/a") -> str:
    cur: Any = d
    for k in keys:
        if not isinstance(cur, dict) or k not in cur:
            return default
        cur = cur[k]
    try:
        return fmt.format(cur)
    except (TypeError, ValueError):
        return html.escape(str(cur))


def _setup_section(cfg: dict[str, Any]) -> Section:
    defaults = settings.defaults()

    def source(table: str, *keys: str, paper: str = "paper", other: str = "estimate") -> str:
        # a value the user changed is theirs, whatever the default's source
        if any(cfg[table][k] != defaults[table][k] for k in keys):
            return "configuration"
        return paper if paper else other

    tank = Tank.from_dict(cfg["tank"])
    b = cfg["beam"]
    rows = [
        ["tank inner base l1 × l2", f"{tank.length * 1e3:.1f} × {tank.width * 1e3:.1f} mm",
         source("tank", "length", "width")],
        ["tank height h", f"{tank.height * 1e3:.1f} mm", source("tank", "height")],
        ["fill level α", f"{tank.fill:.2f}", source("tank", "fill", paper="paper (50 %)")],
        ["liquid mass m_l", f"{tank.liquid_mass * 1e3:.1f} g",
         f"derived (ρ = {tank.density:g} kg/m³)"],
        ["structure mass above load cells", f"{tank.structure_mass:.3f} kg",
         source("tank", "structure_mass", paper="")],
        ["record rate (rig sensors and beam accelerometers)", f"{cfg['rig']['fs']:g} Hz",
         source("rig", "fs", paper="")],
        ["VFA train / validation", f"{cfg['data']['train_duration']:.0f} / "
         f"{cfg['data']['validation_duration']:.0f} s",
         source("data", "train_duration", "validation_duration")],
        ["ROM", f"{cfg['rom']['arch'].upper()}({cfg['rom']['delays']}, "
         f"{cfg['rom']['neurons']})",
         source("rom", "arch", "delays", "neurons", paper="paper: NFIR(70, 35)")],
        ["beam length × width × thickness", f"{b['length']:g} × {b['width']:g} × "
         f"{b['thickness']:g} m, clamped", source("beam", "length", "width", "thickness")],
        ["beam E, ρ", f"{b['youngs_modulus'] / 1e9:g} GPa, {b['density']:g} kg/m³",
         source("beam", "youngs_modulus", "density", paper="", other="estimate (aluminium)")],
        ["dry modal damping", ", ".join(f"{z * 100:.2f} %" for z in b["damping"]),
         source("beam", "damping", paper="")],
        ["random PSD centre / σ", f"{b['f0']:g} / {b['sigma']:g} Hz",
         source("beam", "f0", "sigma", paper="")],
        ["random RMS levels", ", ".join(f"{g:g} g" for g in b["rms_g"]), source("beam", "rms_g")],
        ["virtual-rig physics", "impacting column + RT release gate + Faraday modes",
         "model (docs/rig.md): calibrated estimates"],
    ]
    text = (
        "<p class='note'>There is no laboratory behind this report: the <b>virtual rig</b> "
        "(a physics-based tank simulator, docs/rig.md) plays the shaker experiment and the "
        "sloshing-beam experiment. Numbers marked <i>estimate</i> are not given by the paper; "
        "every one of them is a parameter (<code>sloshrom config show</code>).</p>"
    )
    return Section("1. Setup and assumptions", text,
                   tables=[Table(["quantity", "value", "source"], rows)])


def build_sections(ctx: Any, summary: dict[str, Any]) -> list[Section]:
    st = summary["stages"]
    secs = [_setup_section(ctx.cfg)]
    d = st.get("data", {})
    secs.append(Section(
        "2. Identification data (paper Figs. 5–7)",
        f"<p>VFA tests on the virtual rig: train {_num(d, 'train', 'duration_s')} s, validation "
        f"{_num(d, 'validation', 'duration_s')} s at {_num(d, 'train', 'fs_hz')} Hz; peak tank "
        f"acceleration {_num(d, 'train', 'max_acceleration_g')} g (train), peak dynamic force "
        f"{_num(d, 'train', 'max_dynamic_force_n')} N. Input = tank velocity integrated from the "
        "measured acceleration, output = load-cell force minus liquid and structure inertia.</p>",
        _fig(ctx, "fig05_vfa_paths.png", "Fig. 5/7a — the (ω̄, ā) paths of the training and "
             "validation VFA tests over the Γ iso-lines; they cover the same domain by "
             "different paths.")
        + _fig(ctx, "fig06_train_io.png", "Fig. 6 — training input (velocity) and output "
               "(dynamic sloshing force).")
        + _fig(ctx, "fig07_validation_io.png", "Fig. 7b — validation input and output."),
    ))
    r = st.get("rom")
    sw = st.get("sweep")
    if r:
        secs.append(Section(
            "3. Model selection (paper Fig. 8)",
            "<p>" + (html.escape(sw["sweep_text"]) if sw else "The sensitivity sweep was not "
                     "run (use <code>--sweep</code>); the paper's selection is trained "
                     "directly.") + "</p>",
            _fig(ctx, "fig08_sensitivity.png", "Fig. 8 — mean of train and validation MSE "
                 "against neurons for each delay line.") if sw else [],
            [Table(["architecture", "delays", "neurons", "score (MSE, N²)", "stable"],
                   sw["sweep_rows"])] if sw else [],
        ))
        secs.append(Section(
            "4. Validation (paper Fig. 10)",
            f"<p>{html.escape(r.get('name', 'ROM'))}: validation MSE {_num(r, 'val_mse')} N², "
            f"NRMSE {_num(r, 'val_nrmse', fmt='{:.3f}')}, fit {_num(r, 'val_fit', fmt='{:.1f}')} "
            f"%; training took {_num(r, 'train_seconds', fmt='{:.1f}')} s "
            f"({_num(r, 'epochs', fmt='{:.0f}')} epochs, stop: "
            f"{html.escape(str(r.get('stop_reason', 'n/a')))}).</p>",
            _fig(ctx, "fig10_validation.png", "Fig. 10 — ROM free-run prediction against the "
                 "rig's dynamic force on the validation record."),
        ))
    else:
        secs.append(Section("3–4. ROM", "<p class='note'>Not built yet in this version.</p>"))
    m = st.get("maps", {})
    text = (
        f"<p>Rig map maximum Φ_d = {_num(m, 'rig_maximum', 'phi_d')} at ω̄ = "
        f"{_num(m, 'rig_maximum', 'omega_bar')}, ā = {_num(m, 'rig_maximum', 'a_bar')} "
        f"(Γ = {_num(m, 'rig_maximum', 'gamma')} g, {_num(m, 'rig_maximum', 'frequency')} Hz); "
        "the paper's experiment peaks near Γ ≈ 4 g, ā ≈ 0.25.</p>"
    )
    if "rom_relative_l2_error" in m:
        text += (
            f"<p>ROM map maximum Φ_d = {_num(m, 'rom_maximum', 'phi_d')} at ω̄ = "
            f"{_num(m, 'rom_maximum', 'omega_bar')}, ā = {_num(m, 'rom_maximum', 'a_bar')}; "
            f"relative L2 error against the rig where Φ_d > 10 % of its maximum: "
            f"<b>{_num(m, 'rom_relative_l2_error', fmt='{:.1%}')}</b> (aim ≤ 10 %).</p>"
        )
    secs.append(Section(
        "5. Dissipation maps (paper Figs. 3, 4, 11)", text,
        _fig(ctx, "fig03_hysteresis.png", "Fig. 3 — normalised sloshing force and hysteresis "
             "loop at 3 g, 17 Hz; the enclosed area is the dissipated energy per cycle.")
        + _fig(ctx, "maps/phi_d_rig.png", "Fig. 4 — Φ_d(ω̄, ā) of the virtual rig.")
        + _fig(ctx, "maps/phi_d_rom.png", "Fig. 11 — Φ_d(ω̄, ā) predicted by the ROM.")
        + _fig(ctx, "maps/phi_d_difference.png", "ROM minus rig: where the ROM over- (positive)"
               " or under-predicts dissipation."),
    ))
    b = st.get("beam")
    if b:
        from sloshrom.pipeline.beam import report_sections  # noqa: PLC0415

        secs.extend(report_sections(ctx, b))
    else:
        secs.append(Section("6. Sloshing beam", "<p class='note'>Not built yet in this "
                                                 "version.</p>"))
    t = summary.get("timings_s", {})
    secs.append(Section(
        "Run", "<p>" + ", ".join(f"{k}: {v:.1f} s" for k, v in t.items())
        + (" (cached stages reused: "
           + ", ".join(k for k, v in st.items() if v.get("reused")) + ")"
           if any(v.get("reused") for v in st.values()) else "") + "</p>"
        + (f"<p class='note'>Not built in this version: {', '.join(summary['not_built'])}.</p>"
           if summary.get("not_built") else ""),
    ))
    return secs


def write_report(ctx: Any, summary: dict[str, Any]) -> Path:
    intro = (
        "<p>Reproduction of <i>Neural network-based reduced-order model of vertical sloshing "
        "and its experimental validation on a sloshing beam</i> with <b>sloshrom "
        f"{html.escape(summary['sloshrom_version'])}</b> on the built-in virtual rig.</p>"
    )
    return report.write(Path(ctx.out) / "report.html", "sloshrom — reproduction report", intro,
                        build_sections(ctx, summary))
