"""The report section of the bouncing-ball baseline: "The bouncing-ball baseline".

:func:`baseline_section` writes the ball's parameters, its row beside the ROM's, its map and a
paragraph on what the comparison shows, all from the stage's outputs
(:class:`~sloshrom.studies.baseline.outputs.BaselineOutputs`): no claim is written in advance.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from sloshrom.beam.damping.registry import REFERENCE, label
from sloshrom.pipeline.context import Context
from sloshrom.pipeline.experiment import experiment_tables
from sloshrom.pipeline.html import Figure as ReportFigure
from sloshrom.pipeline.html import Section, Table
from sloshrom.studies.baseline.config import CASE, FREQUENCY_BANDS
from sloshrom.studies.baseline.outputs import REFERENCE_KEY, BaselineOutputs

__all__ = ["baseline_section"]


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


def _honest_paragraph(o: BaselineOutputs) -> str:
    """What the comparison shows, from the numbers (no claim is written in advance)."""
    rows = {r["model"]: r for r in o.comparison}
    ball, rom = rows.get(CASE), rows.get("rom")
    p = o.parameters
    bf = o.ball_fidelity
    parts = [f"The identified ball carries {p['mass_fraction']:.0%} of the liquid mass with "
             f"restitution {p['restitution']:.2f} in a gap of {1e3 * p['gap_m']:.1f} mm "
             f"({p['gap_factor']:.2f} × the ullage)."]
    beta = o.rig_mass_fraction
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
    rf = o.rom_fidelity if o.rom_fidelity is not None else {}
    parts.append(
        f"Against the rig's Φ_d map the ball is {_pct(bf['full_l2'])} off over the whole map "
        f"and {_pct(bf['dissipative_l2'])} in the dissipative region, the ROM "
        f"{_pct(rf.get('full_l2'))} and {_pct(rf.get('dissipative_l2'))}.")
    bands = o.frequency_bands if o.frequency_bands is not None else {}
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
        f"In the beam's random tests (Table 2, {label(REFERENCE)}) the ball's first-mode damping "
        "deviates from the rig's by " + ", ".join(
            f"{_signed(d)} at {lv} g" for d, lv in zip(dev_b, levels, strict=True))
        + ", the ROM's by " + ", ".join(_signed(d) for d in dev_r) + ".")
    wins = [_closer(a, b) for a, b in zip(dev_b, dev_r, strict=True)]
    n_ball = sum(w == "the ball" for w in wins)
    parts.append(f"The ball is closer to the rig at {n_ball} of {len(levels)} levels.")
    inst = o.instantaneous_damping_all
    above = [b for b in ball["instantaneous_damping"] if float(b.split("-")[0]) >= 1.0]
    if "rig" in inst and above:
        def dev(case: str, band: str) -> str:
            return _signed(inst[case][band] / inst["rig"][band] - 1)
        parts.append(
            "In the free response the ball's instantaneous damping above 1 g deviates from the "
            "rig's by " + ", ".join(f"{dev(CASE, b)} ({b})" for b in above)
            + ", the ROM's by " + ", ".join(dev("rom", b) for b in above) + ".")
    nr = o.validation_nrmse_lowpassed if o.validation_nrmse_lowpassed is not None else {}
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


def baseline_section(ctx: Context, outputs: BaselineOutputs | Mapping[str, Any]) -> Section:
    """A report section: the ball's parameters, its row beside the ROM's (map fidelity, Table 2
    damping against the rig, instantaneous damping bands), its map and what the comparison
    shows (outputs of :func:`~sloshrom.studies.baseline.stage.stage_baseline`, or their record
    in ``summary.json``)."""
    o = outputs if isinstance(outputs, BaselineOutputs) else BaselineOutputs.from_record(outputs)
    p = o.parameters
    fit = o.fit
    nr = o.validation_nrmse_lowpassed if o.validation_nrmse_lowpassed is not None else {}
    params = Table(
        ["parameter", "value"],
        [["mass fraction β = m_b / m_l", f"{p['mass_fraction']:.3f}"],
         ["ball mass m_b", f"{1e3 * p['ball_mass_kg']:.1f} g"],
         ["restitution e", f"{p['restitution']:.3f}"],
         ["gap", f"{1e3 * p['gap_m']:.2f} mm ({p['gap_factor']:.2f} × ullage)"],
         ["step", f"1/{p['fs_hz']:g} s"],
         ["fit", f"{fit.get('evaluations', 'n/a')} simulations, "
                 f"{o.fit_seconds if o.fit_seconds is not None else float('nan'):.1f} s; "
                 "force low-passed at "
                 f"{fit.get('lowpass_hz', float('nan')):.1f} Hz"],
         ["validation NRMSE (low-passed)", f"ball {_pct(nr.get(CASE))}, ROM "
                                           f"{_pct(nr.get('rom'))}"]],
        "The identified bouncing ball (docs/rom.md, \"The bouncing-ball baseline\").")
    rows = o.comparison
    levels = list(rows[0][REFERENCE_KEY]) if rows else []
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
            + [f"{_pct(r[REFERENCE_KEY].get(lv), 2)} ({_signed(r['table2_vs_rig'].get(lv))})"
               for lv in levels]
            + [_pct(r["instantaneous_damping"].get(b), 2) for b in bands])
    comp = Table(header, body, "Bouncing ball beside the ROM: Φ_d map against the rig's, "
                 "first-mode damping of the random tests (Table 2, "
                 f"{label(REFERENCE)}; in brackets the deviation from the rig), median "
                 "instantaneous damping of the free response per band of tank acceleration.")
    fb = o.frequency_bands if o.frequency_bands is not None else {}
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
    return Section("The bouncing-ball baseline", _honest_paragraph(o), figures,
                   [params, comp, band_table,
                    *experiment_tables(o.experiment, "random"),
                    *experiment_tables(o.experiment, "free")])
