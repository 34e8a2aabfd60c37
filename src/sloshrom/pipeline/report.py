"""The reproduce report: ``OUT/report.html``, one self-contained page in the paper's order.

Built from the configuration and the stages' outputs (``summary.json``): no size, duration or
level is written into the text here.
"""

from __future__ import annotations

import html
from pathlib import Path
from typing import Any

import numpy as np

from sloshrom import fidelity
from sloshrom.beam.damping.columns import table2_dataset
from sloshrom.beam.damping.registry import REFERENCE, TABLE2, label
from sloshrom.pipeline import html as report
from sloshrom.pipeline import settings
from sloshrom.pipeline import study as registry
from sloshrom.pipeline.context import Context
from sloshrom.pipeline.experiment import cell_text, experiment_tables, percent
from sloshrom.pipeline.glance import glance_section, glossary_section, link_terms
from sloshrom.pipeline.html import Figure, Section, Table
from sloshrom.pipeline.maps import HYSTERESIS_FREQUENCY, HYSTERESIS_GAMMA
from sloshrom.rom.ensemble import spread_text
from sloshrom.rom.registry import CLASSES, paper_class

__all__ = ["build_sections", "waveform_table", "write_report"]


def _fig(ctx: Context, name: str, caption: str) -> list[Figure]:
    p = Path(ctx.out) / "figures" / name
    if not p.is_file():
        p = Path(ctx.out) / name
    return [Figure(p, caption)] if p.is_file() else []


def _listed(v: Any) -> str:
    """A value or a list of them (one per ensemble member), as text."""
    if isinstance(v, list | tuple):
        return ", ".join(str(x) for x in v) if v else "n/a"
    return "n/a" if v is None else str(v)


def _pm(s: Any, fmt: str = "{:.3g}", scale: float = 1.0) -> str:
    """``mean ± std`` of a spread dict (``sloshrom.rom.ensemble.spread``)."""
    if not isinstance(s, dict) or s.get("mean") is None:
        return "n/a"
    return f"{fmt.format(s['mean'] * scale)} ± {fmt.format(s['std'] * scale)}"


def _members_mse(s: object) -> str:
    """The members' validation MSE (a :func:`~sloshrom.rom.ensemble.spread` record) in words:
    mean ± std, min, max and their ratio (N²)."""
    if not isinstance(s, dict) or not isinstance(s.get("values"), list):
        return "n/a"
    return html.escape(spread_text(s["values"], "N²") + " (mean ± std)")


def _stop_text(messages: object) -> str:
    """Why a training of the ROM (or of a member) stopped where its result is probably poor
    (Levenberg-Marquardt at mu_max), one paragraph each; empty for any other stop."""
    if not isinstance(messages, list):
        return ""
    many = len(messages) > 1
    return "".join(f"<p>{'Member ' + str(k) + ': ' if many else ''}{html.escape(str(m))}</p>"
                   for k, m in enumerate(messages) if m)


def _frame_text(fr: object) -> str:
    """The ROM's frame sensitivity (``stages.rom.frame_sensitivity``) as a paragraph."""
    if not isinstance(fr, dict) or not fr.get("offsets_m_s"):
        return ""
    parts = ", ".join(f"{100 * e:.1f} % for {c:g} m/s" for c, e in
                      zip(fr["offsets_m_s"], fr.get("energy_change", []), strict=False))
    return ("<p>Frame: the sloshing force does not depend on the tank's uniform velocity; "
            "the ROM's energy dissipated over the validation record changes by "
            f"{html.escape(parts)} added to its velocity (0 for the physics; a beam under "
            "random base excitation drifts by tenths of a m/s; docs/rom.md, \"The damping the "
            "structure sees\").</p>")


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


def _mm(metres: object) -> str:
    """A displacement in m as mm, the one unit of displacements on the page ("n/a" if none)."""
    return f"{1e3 * metres:.3g}" if isinstance(metres, int | float) else "n/a"


def _setup_section(cfg: settings.ReproduceConfig) -> Section:
    defaults = settings.load()

    def source(table: str, *keys: str, paper: str = "paper", other: str = "estimate") -> str:
        # a value the user changed is theirs, whatever the default's source
        mine, default = getattr(cfg, table), getattr(defaults, table)
        if any(getattr(mine, k) != getattr(default, k) for k in keys):
            return "configuration"
        return paper if paper else other

    tank = cfg.tank.tank()
    b = cfg.beam
    paper_rom, paper = defaults.rom, paper_class().name
    rows = [
        ["tank inner base l1 × l2", f"{tank.length * 1e3:.1f} × {tank.width * 1e3:.1f} mm",
         source("tank", "length", "width")],
        ["tank height h", f"{tank.height * 1e3:.1f} mm", source("tank", "height")],
        ["fill level α", f"{tank.fill:.2f}",
         source("tank", "fill", paper=f"paper ({defaults.tank.fill * 100:g} %)")],
        ["liquid mass m_l", f"{tank.liquid_mass * 1e3:.1f} g",
         f"derived (ρ = {tank.density:g} kg/m³)"],
        ["structure mass above load cells", f"{tank.structure_mass:.3f} kg",
         source("tank", "structure_mass", paper="")],
        ["record rate (rig sensors and beam accelerometers)", f"{cfg.rig.fs:g} Hz",
         source("rig", "fs", paper="")],
        ["VFA train / validation (the records' first segment; section 2 lists the rest)",
         f"{cfg.data.train_duration:.0f} / {cfg.data.validation_duration:.0f} s",
         source("data", "train_duration", "validation_duration")],
        ["ROM", cfg.rom.name(),
         "configuration" if (cfg.rom.arch, cfg.rom.hyper()) != (paper_rom.arch,
                                                                paper_rom.hyper())
         # a class other than the paper's is never the paper's, even as the default
         else f"paper: {paper_rom.name(paper)}" if CLASSES[cfg.rom.arch].paper
         else f"default, not the paper's {paper_rom.name(paper)}"],
        ["beam length × width × thickness", f"{b.length:g} × {b.width:g} × "
         f"{b.thickness:g} m, clamped", source("beam", "length", "width", "thickness")],
        ["beam E, ρ", f"{b.youngs_modulus / 1e9:g} GPa, {b.density:g} kg/m³",
         source("beam", "youngs_modulus", "density", paper="", other="estimate (aluminium)")],
        ["dry modal damping", ", ".join(f"{z * 100:.2f} %" for z in b.damping),
         source("beam", "damping", paper="")],
        ["random PSD centre / σ", f"{b.f0:g} / {b.sigma:g} Hz",
         source("beam", "f0", "sigma", paper="")],
        ["random RMS levels", ", ".join(f"{g:g} g" for g in b.rms_g), source("beam", "rms_g")],
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


def _programme_text(d: dict[str, object]) -> str:
    """What each record holds, segment kind by kind (the VFA durations of the set-up table
    are the first segment's): ``", each ..."``, or "" for a record without a programme."""
    prog = (d.get("design") or {}).get("programme") or {}
    parts = []
    for rec in ("train", "validation"):
        segs = (prog.get(rec) or {}).get("segments") or []
        if not segs:
            continue
        groups: dict[str, list[float]] = {}
        for sg in segs:
            name = str(sg.get("name", ""))
            kind = "VFA extension" if name == "vfa extension" else {
                "vfa": "VFA", "random": "random", "decay": "decay"}.get(str(sg.get("kind")),
                                                                     name)
            groups.setdefault(kind, []).append(float(sg.get("duration_s", 0.0)))
        words = [f"{kind} {ds[0]:.0f} s" if len(ds) == 1 else
                 f"{len(ds)} {kind} segments of {ds[0]:.3g} s"
                 for kind, ds in groups.items()]
        parts.append(f"{rec} = " + " + ".join(words))
    return " (" + "; ".join(parts) + ")" if parts else ""


def _compare_text(compared: dict[str, Any] | None) -> str:
    """The classes identified beside the ROM (``stages.rom.compare``, by class), as a
    paragraph; "" without."""
    rows = []
    for arch, c in (compared or {}).items():
        mc = CLASSES.get(arch)
        what = "the paper's class" if mc is not None and mc.paper else "the class"
        rows.append(f"{what} {html.escape(c.get('name', arch))}: validation MSE "
                    f"{_num(c, 'val_mse')} N², NRMSE {_num(c, 'val_nrmse', fmt='{:.3f}')}, fit "
                    f"{_num(c, 'val_fit', fmt='{:.1f}')} %, trained in "
                    f"{_num(c, 'train_seconds', fmt='{:.1f}')} s")
    if not rows:
        return ""
    return ("<p>Beside it, on the same records, each with its own configuration: "
            + "; ".join(rows) + ". The maps and beam sections use the ROM above, not these "
            "models.</p>")


def build_sections(ctx: Context, summary: dict[str, Any]) -> list[Section]:
    """The report's sections, from the run's stage summaries."""
    st = summary["stages"]
    secs = [glance_section(summary, _rom_sentence(st["rom"])), _setup_section(ctx.cfg)]
    d = st.get("data", {})
    secs.append(Section(
        "2. Identification data (paper Figs. 5–7)",
        f"<p>Records of the virtual rig: train {_num(d, 'train', 'duration_s', fmt='{:.0f}')} "
        f"s, validation {_num(d, 'validation', 'duration_s', fmt='{:.0f}')} s at "
        f"{_num(d, 'train', 'fs_hz')} Hz{_programme_text(d)}; peak tank "
        f"acceleration {_num(d, 'train', 'max_acceleration_g')} g, peak tank velocity "
        f"{_num(d, 'train', 'max_velocity_m_s')} m/s (train), peak dynamic force "
        f"{_num(d, 'train', 'max_dynamic_force_n')} N. Input = tank velocity integrated from the "
        "measured acceleration, output = load-cell force minus liquid and structure inertia.</p>"
        + _design_text(d),
        _fig(ctx, "fig05_vfa_paths.png", "Fig. 5/7a — the (ω̄, ā) paths of the training and "
             "validation VFA tests over the Γ iso-lines; they cover the same domain by "
             "different paths.")
        + _fig(ctx, "fig06_train_io.png", "Fig. 6 — training input (velocity) and output "
               "(dynamic sloshing force).")
        + _fig(ctx, "fig07_validation_io.png", "Fig. 7b — validation input and output."),
        _design_tables(d),
    ))
    r = st["rom"]
    sw = st.get("sweep")
    secs.append(Section(
        "3. Model selection (paper Fig. 8)",
        "<p>" + (html.escape(sw["sweep_text"]) if sw else "The sensitivity sweep was not "
                 "run (use <code>--sweep</code>); the configured ROM is trained "
                 "directly.") + "</p>",
        _fig(ctx, "fig08_sensitivity.png", "Fig. 8 — mean of train and validation MSE "
             "against neurons for each delay line.") if sw else [],
        [Table(["architecture", "delays", "neurons", "score (MSE, N²)", "stable"],
               sw["sweep_rows"])] if sw else [],
    ))
    secs.append(Section(
        "4. Validation (paper Fig. 10)",
        (f"<p>{html.escape(r['model_class_text'])}</p>" if r.get("model_class_text") else "")
        + f"<p>{html.escape(r.get('name', 'ROM'))}: validation MSE {_num(r, 'val_mse')} N², "
        f"NRMSE {_num(r, 'val_nrmse', fmt='{:.3f}')}, fit {_num(r, 'val_fit', fmt='{:.1f}')} "
        f"%; training took {_num(r, 'train_seconds', fmt='{:.1f}')} s "
        f"({_listed(r.get('epochs'))} epochs, stop: "
        f"{html.escape(_listed(r.get('stop_reason')))}).</p>"
        + (f"<p>Ensemble of {r['n_members']} networks (seeds {_listed(r.get('seeds'))}), the "
           "ROM's force is their mean. Validation MSE of the members (each one's free run over "
           f"the whole validation record): {_members_mse(r.get('val_mse_members'))}; of their "
           f"mean: {_num(r, 'val_mse')} N².</p>" if r.get("n_members", 1) > 1 else "")
        + _stop_text(r.get("stop_message"))
        + _compare_text(r.get("compare"))
        + (f"<p>{html.escape(r['recipe_text'])}</p>" if r.get("recipe_text") else "")
        + _frame_text(r.get("frame_sensitivity")),
        _fig(ctx, "fig10_validation.png", "Fig. 10 — ROM free-run prediction against the "
             "rig's dynamic force on the validation record"
             + (", and the classes compared with it (thin lines)." if r.get("compare")
                else ".")),
    ))
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
            f"{_num(m, 'rom_maximum', 'omega_bar')}, ā = {_num(m, 'rom_maximum', 'a_bar')}.</p>"
            + _fidelity_text(m)
        )
    secs.append(Section(
        "5. Dissipation maps (paper Figs. 3, 4, 11)", text,
        _fig(ctx, "fig03_hysteresis.png", "Fig. 3 — normalised sloshing force and hysteresis "
             f"loop at {HYSTERESIS_GAMMA:g} g, {HYSTERESIS_FREQUENCY:g} Hz (<a href='#g-w'>w</a>: "
             "the tank's displacement, a its amplitude); the enclosed area is the dissipated "
             "energy per cycle.")
        + _fig(ctx, "maps/phi_d_rig.png", "Fig. 4 — Φ_d(ω̄, ā) of the virtual rig.")
        + _fig(ctx, "maps/phi_d_rom.png", "Fig. 11 — Φ_d(ω̄, ā) predicted by the ROM, on the "
               "colour scale of Fig. 4; orange (outlined) where it is below the passivity "
               "threshold, i.e. where the ROM gives energy back to the tank.")
        + _fig(ctx, "maps/phi_d_difference.png", "ROM minus rig, on colours centred on zero: "
               "red where the ROM over-predicts dissipation, blue where it under-predicts, "
               "white where they agree to within one colour band."),
    ))
    secs.extend(_beam_sections(ctx, st["beam"], r))
    # the studies that ran, in the registry's order, after the beam's sections
    secs.extend(study.section(ctx, st[study.name]) for study in registry.registered()
                if study.name in st)
    t = summary.get("timings_s", {})
    secs.append(Section(
        "Run", "<p>" + ", ".join(f"{k}: {v:.1f} s" for k, v in t.items())
        + (" (cached stages reused: "
           + ", ".join(k for k, v in st.items() if v.get("reused")) + ")"
           if any(v.get("reused") for v in st.values()) else "") + "</p>",
    ))
    secs.append(glossary_section())
    return link_terms(secs)


def _rom_sentence(r: dict[str, object]) -> str:
    """What the ROM is, in one sentence (HTML): its name, its class in words, its ensemble and
    its training time."""
    mc = CLASSES.get(str(r.get("arch", "")))
    what = f" ({html.escape(mc.summary)})" if mc is not None else ""
    n = r.get("n_members", 1)
    ens = (f", an ensemble of {n} networks that differ by their seed (the ROM's force is "
           "their mean)") if isinstance(n, int) and n > 1 else ""
    return (f"The ROM is <b>{html.escape(str(r.get('name', 'ROM')))}</b>{what}{ens}, "
            f"trained on the virtual rig's VFA records in {_num(r, 'train_seconds', fmt='{:.0f}')}"
            " s.")


def _fidelity_text(m: dict[str, Any]) -> str:
    """The ROM map against the rig's (``rom_fidelity`` of the ``maps`` stage): the whole map
    first, then the dissipative region, then the passivity."""
    f = m.get("rom_fidelity")
    if not isinstance(f, dict):  # a maps stage cached before the fidelity was recorded
        return (
            "<p>Relative L2 error against the rig where Φ_d > 10 % of its maximum: "
            f"<b>{_num(m, 'rom_relative_l2_error', fmt='{:.1%}')}</b>. The whole-map error and "
            "the passivity were not recorded by this (cached) maps stage: rerun it.</p>"
        )
    where = ""
    if np.isfinite(f.get("min_omega_bar", np.nan)):
        where = (f" at ω̄ = {_num(f, 'min_omega_bar', fmt='{:.2f}')}, "
                 f"ā = {_num(f, 'min_a_bar', fmt='{:.3f}')}")
    return (
        f"<p>ROM against the rig, on the {_num(f, 'n_points', fmt='{:d}')} grid points both "
        "maps cover, whole map first:</p><ul>"
        f"<li>full map: relative L2 error <b>{_num(f, 'full_l2', fmt='{:.1%}')}</b> "
        "(‖Φ_d,ROM − Φ_d,rig‖ / ‖Φ_d,rig‖ over every point; target ≤ 6 %);</li>"
        f"<li>dissipative region (rig Φ_d > {_num(f, 'dissipative_threshold', fmt='{:.0%}')} "
        f"of its maximum, {_num(f, 'n_dissipative', fmt='{:d}')} points): relative L2 error "
        f"<b>{_num(f, 'dissipative_l2', fmt='{:.1%}')}</b> (target ≤ 5 %);</li>"
        f"<li>passivity: <b>{_num(f, 'n_nonpassive', fmt='{:d}')}</b> points "
        f"(<b>{_num(f, 'nonpassive_fraction', fmt='{:.1%}')}</b>) have a ROM Φ_d below the "
        f"threshold {_num(f, 'passivity_threshold')} "
        f"(−{_num(f, 'passivity_tolerance', fmt='{:.0%}')} of the rig maximum); the ROM map's "
        f"minimum is Φ_d = <b>{_num(f, 'min_phi_d')}</b>{where}. A negative Φ_d "
        "means the model returns energy to the tank over a cycle, which the liquid cannot "
        "do.</li></ul>" + _member_text(m.get("rom_fidelity_members"))
    )


def _member_text(ms: Any) -> str:
    """The same figures for each member of an ensemble ROM, as mean ± std."""
    if not isinstance(ms, dict):
        return ""
    n = ms.get("full_l2", {}).get("n", "?")
    return (
        f"<p>Each of the {n} members alone (mean ± std over members): full-map error "
        f"{_pm(ms.get('full_l2'), '{:.1f}', 100)} %, dissipative-region error "
        f"{_pm(ms.get('dissipative_l2'), '{:.1f}', 100)} %, non-passive points "
        f"{_pm(ms.get('nonpassive_fraction'), '{:.1f}', 100)} %, minimum Φ_d "
        f"{_pm(ms.get('min_phi_d'))}. The ensemble's map is the mean of the members' maps "
        "(Φ_d is linear in the force).</p>"
    )


def _design_text(d: dict[str, Any]) -> str:
    """How the VFA amplitudes were chosen (outputs ``d`` of the ``data`` stage)."""
    des = d.get("design")
    if not isinstance(des, dict):
        return ""
    rig = d.get("rig") or {}
    rig_text = ("calibrated virtual-rig physics" if not rig else "virtual-rig physics with "
                + ", ".join(f"{html.escape(str(k))} = {v:g}" for k, v in rig.items())
                + " (configuration overrides)")
    env = (f"Γ ≤ {_num(des, 'gamma_max_g')} g, velocity ≤ {_num(des, 'max_velocity_m_s')} m/s, "
           f"displacement ≤ {_mm(des.get('max_displacement_m'))} mm "
           f"(ā ≤ {_num(des, 'a_bar_max')})")
    if des.get("rule") != "structure":
        return (f"<p>Training designed for the paper's shaker: {env}; {rig_text}.</p>")
    fz = des.get("frozen_beam_tests") or {}
    text = (
        f"<p>Training designed from the structure: the beam tests of sections 7 and 8 were run "
        f"first with frozen liquid (linear, the least-damped case: sloshing only adds damping, "
        f"so the rig and ROM runs stay below it). Their tank motion peaks at "
        f"{_num(fz, 'peak_acceleration_g')} g, {_num(fz, 'peak_velocity_m_s')} m/s "
        f"(displacement {_mm(fz.get('peak_displacement_m'))} mm, "
        f"{_num(fz, 'frequency_hz')} Hz); the VFA covers {_num(des, 'margin')} × that: {env}. "
        f"The training record reaches {_num(d, 'train', 'covers_acceleration')} × the frozen "
        f"peak acceleration and {_num(d, 'train', 'covers_velocity')} × its velocity; "
        f"{rig_text}.</p>"
    )
    over = des.get("exceeds_shaker") or []
    if over:
        text += ("<p class='note'>This envelope exceeds the paper's shaker (6 g, 1 m/s, 12.5 mm"
                 f") in {html.escape(', '.join(over))}: the virtual rig has no shaker limits, a "
                 "laboratory would need a bigger shaker.</p>")
    return text


def _design_tables(d: dict[str, Any]) -> list[Table]:
    """The frozen beam tests' tank motion, one row per run (structure design only)."""
    fz = (d.get("design") or {}).get("frozen_beam_tests")
    if not isinstance(fz, dict):
        return []
    return [Table(["frozen run", "peak tank acc. [g]", "peak velocity [m/s]",
                   "displacement [mm]", "frequency [Hz]"],
                  [[r["run"], r["peak_acceleration_g"], r["peak_velocity_m_s"],
                    1e3 * r["peak_displacement_m"], r["frequency_hz"]] for r in fz["runs"]],
                  "Tank motion of the beam tests with frozen liquid: what the training covers.")]


def _waveform_rows(test: str, wf: object, twin: bool = True) -> list[list[str]]:
    """Rows rig / ROM / twin of one test's waveform figures (``waveform_fidelity`` of a stage:
    ``rom`` and ``twin``, each :func:`sloshrom.fidelity.waveform_fidelity`; ``twin`` False:
    a test without a twin run, whose ``twin`` entry holds the rig's own figures only)."""
    if not isinstance(wf, dict) or not isinstance(wf.get("twin"), dict):
        return []
    ref = wf["twin"]

    def num(v: object, fmt: str) -> str:
        ok = isinstance(v, int | float) and np.isfinite(v)
        return fmt.format(v) if ok else "n/a"

    def peaks(q: object) -> str:
        return " / ".join(num(v, "{:.3g}") for v in q) if isinstance(q, list) and q else "n/a"

    rows = [[test, "rig", "", "1", num(ref["hf_ratio_reference"], "{:.3g}"),
             num(ref["impact_rate_reference"], "{:.2f}"),
             peaks(ref["peak_quantiles_reference"])]]
    gain = wf.get("twin_gain")
    runs = [("ROM", wf.get("rom"))]
    if twin:
        runs.append((f"rig, input × {gain:g} (twin)" if isinstance(gain, int | float)
                     else "rig twin", wf["twin"]))
    for run, f in runs:
        if isinstance(f, dict):
            rows.append([test, run, num(f["fit"], "{:.1f}"), num(f["rms_ratio"], "{:.3f}"),
                         num(f["hf_ratio"], "{:.3g}"), num(f["impact_rate"], "{:.2f}"),
                         peaks(f["peak_quantiles"])])
    return rows


def waveform_table(rom: object, beam: object) -> list[Table]:
    """The "waveform fidelity" table: the ROM's force beside the rig's and the rig's twin run's,
    on the validation record (``rom`` stage outputs) and the beam's random tests (``beam``);
    empty for stages cached before the figures were recorded."""
    rows = _waveform_rows("validation record",
                          rom.get("waveform_fidelity") if isinstance(rom, dict) else None)
    ff = beam.get("free_fidelity") if isinstance(beam, dict) else None
    if isinstance(ff, dict) and isinstance(ff.get("rom"), dict):
        rows += _waveform_rows(f"beam free decay, first {ff['seconds']:g} s",
                               {"rom": ff["rom"], "twin": {
                                   k: ff["rom"][k] for k in ("hf_ratio_reference",
                                                             "impact_rate_reference",
                                                             "peak_quantiles_reference")}},
                               twin=False)
    wf = beam.get("waveform_fidelity") if isinstance(beam, dict) else None
    if isinstance(wf, dict):
        for level, per in wf.get("levels", {}).items():
            rows += _waveform_rows(f"beam random, {level} g",
                                   {**per, "twin_gain": wf.get("twin_gain")})
    if not rows:
        return []
    hi, lo = fidelity.HIGH_BAND, fidelity.LOW_BAND
    high = f"> {hi[0]:g} Hz" if hi[1] is None else f"{hi[0]:g}–{hi[1]:g} Hz"
    quantiles = " / ".join(f"{100 * q:g}" for q in fidelity.QUANTILES)
    return [Table(
        ["test", "run", "fit [%]", "force RMS / rig's", f"power {high} / {lo[0]:g}–{lo[1]:g} Hz",
         "impacts [1/s]", f"peak force {quantiles} % [N]"],
        rows,
        "Waveform fidelity (docs/rom.md, \"Waveform fidelity\"): the dynamic force of the ROM "
        "against the rig's, beside the rig's own twin run, the same test with the input's gain "
        "changed slightly, which no laboratory could tell from the nominal one. Force RMS about "
        "the mean; band powers from Welch PSDs; an impact is a downward peak beyond "
        f"{fidelity.IMPACT_THRESHOLD:g} times the rig's RMS, {1e3 * fidelity.MIN_SEPARATION:g} ms "
        "at least after the previous one; peak-force quantiles of every downward peak, from the "
        "mean.")]


def _envelope_table(rows: Any) -> list[Table]:
    """Peak tank acceleration of each beam run against the model's training envelope."""
    if not rows:
        return []

    def na(v: Any, fmt: str) -> str:
        return "n/a" if v is None else fmt.format(v)

    return [Table(["run", "case", "peak tank acc. [g]", "training peak [g]", "ratio",
                   "fraction outside"],
                  [[r["run"], r["case"], f"{r['peak_tank_acceleration_g']:.3g}",
                    na(r["training_peak_acceleration_g"], "{:.3g}"),
                    na(r["acceleration_ratio"], "{:.2f}"), na(r["outside_fraction"], "{:.2%}")]
                   for r in rows],
                  "Beam runs against the training envelope of each model (velocity outside "
                  "the training range or acceleration above the training peak); n/a: the model "
                  "has no training envelope (rig, frozen) or it does not record its peak "
                  "acceleration.")]


def _beam_sections(ctx: Context, b: dict[str, Any],
                   rom: object = None) -> list[Section]:
    """Sections 6-8: the sloshing beam (outputs ``b`` of the ``beam`` stage; ``rom``, those of
    the ``rom`` stage, for the waveform table's validation rows)."""
    figdir = Path(ctx.out) / "figures"

    def fig(name: str, cap: str) -> list[Figure]:
        p = figdir / f"{name}.png"
        return [Figure(p, cap)] if p.is_file() else []

    t1 = Table(["mode", "f dry [Hz]", "f frozen [Hz]", "f coupled [Hz]", "ζ", "modal mass [kg]"],
               [[r["mode"], r["f_dry_Hz"], r["f_frozen_Hz"], r["f_coupled_Hz"],
                 percent(r["damping"]), r["modal_mass_kg"]] for r in b["table1"]],
               "Table 1 analogue: modes of the beam with frozen liquid (unit maximum "
               "displacement normalisation; damping ratios are estimates).")
    inst = b["instantaneous_damping"]
    cases = list(inst)
    bands = [k for k in next(iter(inst.values())) if k.endswith(" g")]
    t_inst = Table(["tank acceleration"] + cases,
                   [[band] + [percent(inst[c][band]) for c in cases] for band in bands],
                   "Median first-mode instantaneous damping (Hilbert) in bands of tank "
                   "acceleration amplitude, free response.")

    # Table 2 row by row (the stage's records), its estimates from the (level, estimator)
    # dataset of the row's case
    t2_rows = b["table2"]
    damping = {c: table2_dataset([r for r in t2_rows if r["case"] == c])
               for c in dict.fromkeys(r["case"] for r in t2_rows)}
    level_of: dict[str, int] = {}
    body = []
    for r in t2_rows:
        j = level_of[r["case"]] = level_of.get(r["case"], -1) + 1
        d = damping[r["case"]].isel(level=j)
        # every cell a value or the reason it has none (and a fallback's or members' note)
        body.append([r["case"], r["rms_g"], r["max_tank_acceleration_g"],
                     *(cell_text(float(d["value"].sel(estimator=n)),
                                 float(d["low"].sel(estimator=n)),
                                 float(d["high"].sel(estimator=n)),
                                 str(d["reason"].sel(estimator=n).values),
                                 str(d["note"].sel(estimator=n).values))
                       for n in d.estimator.values)])
    names = [str(x) for x in next(iter(damping.values())).label.values] if damping else \
        [label(n) for n in TABLE2]
    t2 = Table(["case", "RMS [g]", "max tank acc. [g]", *names], body,
               "Table 2 analogue: first-mode damping from the random tests, each with its 95 % "
               "interval (docs/beam.md, \"Uncertainty of the damping estimates\"). LSCF "
               "columns: median over the stable poles of model orders 2-40; output-only: "
               "half-spectrum of the tank acceleration (no base signal needed), corrected for "
               "its exponential window. A cell without a value says why (—, the reason); an "
               "ensemble ROM's row is the mean of its members' estimates, each member coupled "
               "to the beam alone, its interval holding their spread (docs/beam.md).")
    tables2 = [t2]
    rm = b.get("rom_members")
    if isinstance(rm, dict):
        levels = list(rm.get("table2", {}))
        tables2.append(Table(
            ["RMS [g]", f"{label(REFERENCE)}, members (mean ± std)"],
            [[lv, f"{_pm(rm['table2'][lv], '{:.2f}', 100)} %"] for lv in levels],
            "The random tests with each member of the ensemble ROM coupled alone: the spread "
            "of the first-mode damping that one trained network carries; their mean is the "
            "ROM's value in Table 2 (members without a value left out)."))
        for band in bands:
            pm = f"{_pm(rm['instantaneous_damping'].get(band), '{:.2f}', 100)} %"
            t_inst.rows.append([f"{band}, ROM members (mean ± std)"]
                               + [pm if c == "rom" else "" for c in cases])
    free_text = (
        f"<p>Free response from a {ctx.cfg.beam.tip_displacement * 1e3:.1f} mm static tip "
        f"deflection (initial tank acceleration "
        f"{inst.get('frozen', {}).get('initial_tank_acceleration_g', float('nan')):.1f} g). "
        "The rig plays the experiment; the ROM runs in the same coupled model; the frozen case "
        "has Δf = 0. First-mode frequency with frozen liquid: "
        f"{b['f1_frozen_hz']:.2f} Hz. The tables' <a href='#g-experiment'>experiment</a> "
        "column is the rig replayed through a laboratory's files, with sensor noise, and "
        "analysed as measured data.</p>"
    )
    return [
        Section("6. Sloshing beam: modes (paper Table 1)", "", tables=[t1]),
        Section(
            "7. Free response (paper Figs. 14, 16, 20, 21)", free_text,
            fig("fig14_station_accelerations", "Fig. 14 — virtual accelerometers along the beam, "
                "one panel per station, frozen and sloshing overlaid.")
            + fig("fig16_modal_accelerations", "Fig. 16 — modal accelerations from modal "
                  "filtering: sloshing damps mode 1 most.")
            + fig("fig20_tank_interface_dynamic", "Fig. 20 — tank acceleration, interface force"
                  " and dynamic sloshing force.")
            + fig("fig20c_dynamic_force_start", "Fig. 20c — the dynamic sloshing force in the "
                  "first 2 s after the release, ROM against the rig (the violent impacts; the "
                  "paper: \"in good agreement\").")
            + fig("fig21_instantaneous_damping", "Fig. 21 — first-mode instantaneous damping "
                  "against tank acceleration amplitude (Hilbert envelope, log-decrement dots).")
            + fig("fig21_comparison", "Fig. 21, as the paper sets it: the rig as the "
                  "laboratory (black, its 95 % intervals per amplitude band as grey boxes) "
                  "against the predictions."),
            [t_inst, *experiment_tables(b.get("experiment"), "free")],
        ),
        Section(
            "8. Random base excitation (paper Figs. 18, 22, 23, Table 2)",
            "<p>Gaussian-PSD base acceleration (Eq. 8), "
            + html.escape(", ".join(f"{g:g}" for g in ctx.cfg.beam.rms_g))
            + f" g RMS, {ctx.cfg.beam.random_duration:.0f} s, the same phases for every "
            "level and every case.</p>",
            fig("fig17_base_excitation", "Fig. 17 — the base accelerations imposed at the "
                "beam root (the same signal for every case): a 2 s window and their Welch PSDs "
                "against the Gaussian spectrum of Eq. (8) (dashed).")
            + fig("fig18_tank_acceleration", "Fig. 18 — tank acceleration at each RMS level "
                  "(sloshing).")
            + fig("fig22_tank_acceleration_window", "Fig. 22 — tank acceleration in a 2 s "
                  "window: rig, ROM and frozen.")
            + fig("fig23_psd", "Fig. 23 — Welch PSDs of the tank acceleration: sloshing lowers "
                  "the resonance peak.")
            + fig("force_statistics_random", "The force the structure feels, per level: Welch "
                  "spectra of the dynamic force and of the tank acceleration up to 250 Hz, and "
                  "the distribution of the impacts' peaks (downward peaks beyond 3 times the "
                  "rig's RMS), the ROM beside the rig and the rig's twin run.")
            + fig("table2_comparison", "Table 2 as intervals: the rig as the laboratory "
                  "(squares) and the predictions, each estimate with its 95 % interval."),
            [*tables2, *experiment_tables(b.get("experiment"), "random"),
             *_envelope_table(b.get("envelope")), *waveform_table(rom, b)],
        ),
    ]


def write_report(ctx: Context, summary: dict[str, Any]) -> Path:
    """Write ``report.html`` in the run's output folder; its path."""
    intro = (
        "<p>Reproduction of <i>Neural network-based reduced-order model of vertical sloshing "
        "and its experimental validation on a sloshing beam</i> with <b>sloshrom "
        f"{html.escape(summary['sloshrom_version'])}</b> on the built-in virtual rig.</p>"
    )
    return report.write(Path(ctx.out) / "report.html", "sloshrom — reproduction report", intro,
                        build_sections(ctx, summary))
