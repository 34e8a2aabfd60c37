"""The report's first and last sections: "At a glance" (what the ROM is, its targets met and
missed with the figures, what it gets right and where it falls short) and the glossary, with
each glossary term linked at its first use on the page."""

from __future__ import annotations

import html
import re
from collections.abc import Sequence

from sloshrom.pipeline.html import Markup, Section, Table
from sloshrom.pipeline.targets import Row, Verdict, verdicts
from sloshrom.rom.registry import CLASSES

__all__ = ["GLOSSARY", "NOT_LINKED", "glance_section", "glossary", "glossary_section",
           "link_terms"]

#: Term -> (anchor, definition in HTML). The terms are matched case-sensitively, as written.
GLOSSARY: dict[str, tuple[str, str]] = {
    "ROM": ("rom", "Reduced-order model: here a model that gives the sloshing force from the "
            "tank's motion, fast enough to run inside a structural simulation."),
    "VFA": ("vfa", "Variable-frequency-and-amplitude test: the shaker's identification input, a "
            "sine whose frequency and amplitude sweep the (ω̄, ā) plane (paper §3)."),
    "fit": ("fit", "Fit = 100 (1 − ‖e‖ / ‖y − mean y‖) %, e the model's error on the output y "
            "(MATLAB's <code>compare</code>): 100 % is exact, 0 % no better than the mean."),
    "NRMSE": ("nrmse", "Normalised RMS error ‖e‖ / ‖y − mean y‖ = 1 − fit / 100."),
    "Φ_d": ("phi-d", "Dissipated energy per cycle of a harmonic test, normalised by the "
            "liquid's mass and the tank's peak velocity squared "
            "(Φ_d = E_d / (m_l v_max²)), mapped over ω̄ (the frequency over the "
            "liquid's natural frequency) and ā (the amplitude over the tank's height)."),
    "ω̄": ("omega-bar", "Non-dimensional frequency: the excitation's frequency over the "
          "liquid's first natural frequency."),
    "ā": ("a-bar", "Non-dimensional amplitude: the tank's displacement amplitude over its "
          "height."),
    "Γ": ("gamma", "Peak tank acceleration of a harmonic test, in g."),
    "RT release gate": ("rt-gate", "Rayleigh–Taylor release gate: the liquid leaves the "
                        "tank's floor only when the tank accelerates downward faster than "
                        "gravity (the interface is then unstable)."),
    "strictly proper": ("strictly-proper", "The output at a sample does not depend on the "
                        "input at that sample (no feed-through): a co-simulation master may "
                        "read the output before it sets the input."),
    "ensemble": ("ensemble", "Networks that differ only by their initialisation's seed; the "
                 "ROM's force is their mean, their spread the uncertainty one network "
                 "carries. \"× 2\" after a ROM's name: an ensemble of 2."),
    "twin run": ("twin", "The rig run again with its input's gain changed by 0.1 %: what a "
                 "laboratory could reproduce; the ceiling of a waveform comparison."),
    "experiment": ("experiment", "The \"experiment\" rows: the rig replayed through "
                   "laboratory files (UFF 58, with sensor noise) and analysed as measured "
                   "data, as the paper's laboratory tests are."),
    "LSCF": ("lscf", "Least-squares complex-frequency estimator of modal parameters (a "
             "rational fit of a frequency response, over model orders 2–40, stable poles)."),
    "H1": ("h1", "The frequency response estimate H1 = S_xy / S_xx (cross spectrum of the "
           "base and the response over the base's auto spectrum)."),
    "half power": ("half-power", "Damping from the width of a resonance peak at half its "
                   "power: ζ = (f₂ − f₁) / (2 f_n)."),
    "Hilbert": ("hilbert", "Instantaneous damping from the envelope of the modally filtered "
                "decay (Hilbert transform), per band of tank acceleration amplitude."),
    "log decrement": ("log-decrement", "Damping from the ratio of successive peaks of a "
                      "decay: ζ ≈ ln(x_k / x_{k+1}) / (2π)."),
    "envelope": ("envelope", "The range of motion a ROM was trained on (peak tank acceleration "
                 "and velocity); outside it the ROM extrapolates."),
    "passivity": ("passivity", "A sloshing load can only take energy out of the structure on "
                  "average: Φ_d ≥ 0 everywhere."),
    "w": ("w", "In Fig. 3, w is the tank's vertical displacement and a its amplitude: the "
          "hysteresis loop's abscissa is w / a, its ordinate the force over m_l a Ω²."),
}


def glossary() -> dict[str, tuple[str, str]]:
    """:data:`GLOSSARY` and one entry per ROM class of the registry (its class name, its
    summary), so that a class added to the registry is defined on the page too."""
    classes = {mc.class_name: (f"class-{mc.name}", html.escape(mc.summary[:1].upper()
                                                               + mc.summary[1:]) + ".")
               for mc in CLASSES.values()}
    return {**GLOSSARY, **classes}


def _verdict_rows(vs: Sequence[Verdict]) -> list[list[str]]:
    def word(v: Verdict) -> str:
        return Markup(f"<b class='miss'>{v.word}</b>") if v.met is False else v.word

    return [[v.what, v.goal, v.figure, word(v),
             v.section if v.section == "Run" else f"§ {v.section}"] for v in vs]


def glance_section(summary: Row, rom_text: str) -> Section:
    """The report's first section.

    Parameters
    ----------
    summary : mapping
        The run's summary (``stages``, ``timings_s``).
    rom_text : str
        One sentence (HTML) saying what the ROM is.
    """
    vs = verdicts(summary)
    met = [v for v in vs if v.met is True]
    missed = [v for v in vs if v.met is False]
    unknown = [v for v in vs if v.met is None]
    counts = (f"It meets <b>{len(met)}</b> of the {len(vs)} targets and misses "
              f"<b>{len(missed)}</b>" + (f"; {len(unknown)} were not measured in this run"
                                         if unknown else "") + ".")
    right = ("<p><b>What it gets right:</b></p><ul>" + "".join(
        f"<li>{html.escape(v.what)}: {html.escape(v.figure)}</li>" for v in met) + "</ul>"
             if met else "<p><b>What it gets right:</b> none of the targets.</p>")
    short = ("<p><b>Where it falls short:</b></p><ul>" + "".join(
        f"<li>{html.escape(v.what)}: <b>{html.escape(v.figure)}</b> against "
        f"{html.escape(v.goal)}</li>" for v in missed) + "</ul>" if missed else
             "<p><b>Where it falls short:</b> no target is missed.</p>")
    text = f"<p>{rom_text} {counts}</p>" + right + short
    table = Table(["target", "goal", "this run", "verdict", "see"], _verdict_rows(vs),
                  "Every target of the ROM, in the order of the sections that show it "
                  "(\"not measured\": this run did not compute the figure).")
    return Section("At a glance", text, tables=[table])


def glossary_section() -> Section:
    """The glossary, one anchored entry per term."""
    items = "".join(f"<dt id='g-{a}'>{html.escape(t)}</dt><dd>{d}</dd>"
                    for t, (a, d) in sorted(glossary().items(), key=lambda kv: kv[0].lower()))
    return Section("Glossary", f"<dl>{items}</dl>")


_TAG = re.compile(r"(<[^>]*>)")
#: Glossary terms not linked automatically: "w" (a letter of Fig. 3's caption) and
#: "experiment" (also the paper's experiment).
NOT_LINKED = frozenset({"w", "experiment"})


def _pattern(term: str) -> re.Pattern[str]:
    # a word on its own: not inside another word, nor a part of a formula (Φ_d,ROM stays)
    return re.compile(rf"(?<![\w/]){re.escape(term)}(?![\w])")


def _link_first(text: str, term: str, anchor: str) -> tuple[str, bool]:
    """``text`` with the first use of ``term`` outside tags, links and code linked."""
    parts = _TAG.split(text)
    skip = 0  # depth inside <a>, <code> or a heading
    for i, part in enumerate(parts):
        if i % 2:
            m = re.match(r"<(/?)(a|code|h\d)\b", part)
            if m:
                skip += -1 if m.group(1) else 1
            continue
        if skip:
            continue
        new, n = _pattern(term).subn(lambda mm: f"<a href='#g-{anchor}'>{mm.group(0)}</a>",
                                     part, count=1)
        if n:
            parts[i] = new
            return "".join(parts), True
    return text, False


def link_terms(sections: Sequence[Section]) -> list[Section]:
    """The sections with the first use of each glossary term in their text linked to its
    entry (outside tags, links and code; the glossary itself untouched). Terms that are also
    everyday words in this report (:data:`NOT_LINKED`) are linked where they are introduced,
    not here."""
    todo = {t: a for t, (a, _) in glossary().items() if t not in NOT_LINKED}
    out = []
    for s in sections:
        text = s.text
        if s.title != "Glossary":
            for term in list(todo):
                text, done = _link_first(text, term, todo[term])
                if done:
                    del todo[term]
        out.append(Section(s.title, text, s.figures, s.tables))
    return out
