"""The ROM's targets and a run's verdict on each: pure functions of a run's ``summary.json``.

One place for the thresholds that the report's "At a glance" section and
``benchmarks/fidelity.py`` judge a run by. A target is *met* or *missed* with the figure that
decides it, or *not measured* when the run did not compute that figure (a stage not run, a
summary written before the figure existed); a target is never left out because it is missed.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass

from sloshrom.beam.damping.registry import label

__all__ = ["ENVELOPE_RATIO", "FIT_FREE", "FIT_VALIDATION", "FROZEN_MARGIN", "HF_FACTOR",
           "IMPACTS_WITHIN", "MAP_DISSIPATIVE", "MAP_FULL", "Q99_WITHIN", "RMS_WITHIN",
           "ROM_STAGE_SECONDS", "Row", "Verdict", "verdicts"]

#: Fit (%) of the ROM's free run over the whole validation record.
FIT_VALIDATION = 60.0
#: Fit (%) of the ROM's dynamic force over the free decay's first seconds (paper Fig. 20c).
FIT_FREE = 70.0
#: Force RMS / the rig's: within this fraction of 1 (random tests and free decay).
RMS_WITHIN = 0.10
#: Power above 60 Hz relative to 5-20 Hz, over the rig's: within this factor.
HF_FACTOR = 2.0
#: Impacts per second / the rig's: within this fraction of 1.
IMPACTS_WITHIN = 0.25
#: The 99 % quantile of the force's peaks / the rig's: within this fraction of 1.
Q99_WITHIN = 0.15
#: Relative L2 error of the ROM's Phi_d map over every point.
MAP_FULL = 0.06
#: Relative L2 error of the ROM's Phi_d map over the dissipative region.
MAP_DISSIPATIVE = 0.05
#: Peak tank acceleration of a ROM run over the training record's peak.
ENVELOPE_RATIO = 1.05
#: The ROM's first-mode damping may lie at most this fraction below the frozen liquid's.
FROZEN_MARGIN = 0.05
#: Wall time of the ``rom`` stage, s (2 cores).
ROM_STAGE_SECONDS = 60.0


@dataclass(frozen=True)
class Verdict:
    """A target and a run's figure on it.

    Attributes
    ----------
    what : str
        What is measured, in words.
    goal : str
        The target, with its unit.
    figure : str
        The run's figure(s), with their unit; ``"n/a"`` when not measured.
    met : bool or None
        True met, False missed, None not measured in this run.
    section : str
        The report's section that shows it.
    """

    what: str
    goal: str
    figure: str
    met: bool | None
    section: str

    @property
    def word(self) -> str:
        """``"met"``, ``"missed"`` or ``"not measured"``."""
        return {True: "met", False: "missed", None: "not measured"}[self.met]


def _pct(x: float, digits: int = 0) -> str:
    return f"{100 * x:.{digits}f} %"


def _finite(v: object) -> float | None:
    return float(v) if isinstance(v, int | float) and math.isfinite(v) else None


#: A table of a run's summary (JSON: values of any kind, narrowed where read).
Row = Mapping[str, object]


def _map(v: object) -> Row:
    """``v`` if it is a table, else an empty one."""
    return v if isinstance(v, Mapping) else {}


def _get(d: object, *keys: str) -> object:
    for k in keys:
        if not isinstance(d, Mapping):
            return None
        d = d.get(k)
    return d


def _levels(beam: Row) -> list[tuple[str, Row]]:
    """(level, the ROM's waveform figures) of each random test, in the run's order."""
    lv = _get(beam, "waveform_fidelity", "levels")
    if not isinstance(lv, Mapping):
        return []
    return [(str(k), _map(v.get("rom"))) for k, v in lv.items()
            if isinstance(v, Mapping) and isinstance(v.get("rom"), Mapping)]


def _per_level(what: str, goal: str, section: str, levels: Sequence[tuple[str, Row]],
               value: Callable[[Row], float | None], ok: Callable[[float], bool],
               fmt: str) -> Verdict:
    """One verdict over every level: met when met at each; the figures level by level."""
    vals = [(k, value(r)) for k, r in levels]
    got = [(k, v) for k, v in vals if v is not None]
    if not vals or len(got) < len(vals):
        return Verdict(what, goal, "n/a", None, section)
    figure = ", ".join(f"{fmt.format(v)} at {k} g" for k, v in got)
    return Verdict(what, goal, figure, all(ok(v) for _, v in got), section)


def _ratio(r: Row, key: str, ref: str) -> float | None:
    a, b = _finite(r.get(key)), _finite(r.get(ref))
    return a / b if a is not None and b else None


def _q99(r: Row) -> float | None:
    q, q_ref = r.get("peak_quantiles"), r.get("peak_quantiles_reference")
    if not (isinstance(q, list) and isinstance(q_ref, list) and len(q) == len(q_ref) == 3):
        return None
    return _ratio({"a": q[2], "b": q_ref[2]}, "a", "b")


def _consistent(rows: object, what: str, goal: str, section: str) -> Verdict:
    """The ROM's rows of an experiment table: met when each is consistent with the
    experiment (inside its interval, or the two intervals agree)."""
    rom = [_map(r) for r in rows if _map(r).get("case") == "rom"] if isinstance(rows, list) \
        else []
    judged = [r for r in rom if r.get("consistent") in ("yes", "no")]
    if not judged:
        return Verdict(what, goal, "n/a", None, section)
    ok = sum(r["consistent"] == "yes" for r in judged)
    miss = [f"{r.get('band', '')}{r.get('rms_g', '')}{' g' if 'rms_g' in r else ''} "
            f"{_method(r)}".strip()
            for r in judged if r["consistent"] != "yes"]
    figure = f"{ok} of {len(judged)} cells" + (f" (not: {'; '.join(miss)})" if miss else "")
    return Verdict(what, goal, figure, ok == len(judged), section)


def _method(r: Row) -> str:
    """An experiment row's method or estimator, in the report's words ("LSCF on H1")."""
    return label(str(r.get("method") or r.get("estimator") or ""))


def verdicts(summary: Row) -> list[Verdict]:
    """Every target of the ROM and the run's verdict on it, in the report's order.

    Parameters
    ----------
    summary : mapping
        A run's ``summary.json`` (``stages``, ``timings_s``).

    Returns
    -------
    list of Verdict
        Waveform (validation, random tests, free decay), energy (Phi_d map, passivity),
        damping against the experiment, envelope and cost.
    """
    st = _map(summary.get("stages"))
    rom, maps, beam = _map(st.get("rom")), _map(st.get("maps")), _map(st.get("beam"))
    out = []
    fit = _finite(_get(rom, "waveform_fidelity", "rom", "fit"))
    if fit is None:
        fit = _finite(rom.get("val_fit"))
    out.append(Verdict("fit of the free run on the validation record",
                       f"≥ {FIT_VALIDATION:g} %", "n/a" if fit is None else f"{fit:.1f} %",
                       None if fit is None else fit >= FIT_VALIDATION, "4"))
    f = _map(maps.get("rom_fidelity"))
    full, diss = _finite(f.get("full_l2")), _finite(f.get("dissipative_l2"))
    npas = _finite(f.get("n_nonpassive"))
    out += [
        Verdict("Φ_d map error, every point", f"≤ {_pct(MAP_FULL)}",
                "n/a" if full is None else f"{_pct(full, 1)}",
                None if full is None else full <= MAP_FULL, "5"),
        Verdict("Φ_d map error, dissipative region", f"≤ {_pct(MAP_DISSIPATIVE)}",
                "n/a" if diss is None else f"{_pct(diss, 1)}",
                None if diss is None else diss <= MAP_DISSIPATIVE, "5"),
        Verdict("passivity: map points where the ROM gives energy back", "0",
                "n/a" if npas is None else f"{npas:.0f} of {f.get('n_points', '?')}",
                None if npas is None else npas == 0, "5"),
    ]
    lv = _levels(beam)
    out += [
        _per_level("random tests: force RMS / the rig's", f"1 ± {_pct(RMS_WITHIN)}", "8", lv,
                   lambda r: _finite(r.get("rms_ratio")),
                   lambda v: abs(v - 1) <= RMS_WITHIN, "{:.2f}"),
        _per_level("random tests: power above 60 Hz (impacts' share) / the rig's",
                   f"within × {HF_FACTOR:g}", "8", lv, lambda r: _finite(r.get("hf_factor")),
                   lambda v: 1 / HF_FACTOR <= v <= HF_FACTOR, "{:.2f}"),
        _per_level("random tests: impacts per second / the rig's", f"1 ± {_pct(IMPACTS_WITHIN)}",
                   "8", lv, lambda r: _ratio(r, "impact_rate", "impact_rate_reference"),
                   lambda v: abs(v - 1) <= IMPACTS_WITHIN, "{:.2f}"),
        _per_level("random tests: 99 % force peak / the rig's", f"1 ± {_pct(Q99_WITHIN)}", "8",
                   lv, _q99, lambda v: abs(v - 1) <= Q99_WITHIN, "{:.2f}"),
    ]
    ff = _map(beam.get("free_fidelity"))
    fr = _map(ff.get("rom"))
    secs = _finite(ff.get("seconds"))
    head = f"free decay, first {secs:g} s" if secs is not None else "free decay"
    rms, ffit = _finite(fr.get("rms_ratio")), _finite(fr.get("fit"))
    out += [
        Verdict(f"{head}: force RMS / the rig's", f"1 ± {_pct(RMS_WITHIN)}",
                "n/a" if rms is None else f"{rms:.2f}",
                None if rms is None else abs(rms - 1) <= RMS_WITHIN, "7"),
        Verdict(f"{head}: fit of the dynamic force (Fig. 20c)", f"≥ {FIT_FREE:g} %",
                "n/a" if ffit is None else f"{ffit:.1f} %",
                None if ffit is None else ffit >= FIT_FREE, "7"),
    ]
    exp = _map(beam.get("experiment"))
    out += [
        _consistent(exp.get("random"), "first-mode damping of the random tests (Table 2) "
                    "against the experiment", "every cell consistent", "8"),
        _consistent(exp.get("free"), "first-mode damping of the free decay per amplitude band "
                    "against the experiment", "every cell consistent", "7"),
    ]
    out.append(_above_frozen(beam.get("instantaneous_damping")))
    out.append(_envelope(beam.get("envelope")))
    t = _finite(_map(summary.get("timings_s")).get("rom"))
    reused = bool(rom.get("reused"))
    out.append(Verdict("time of the ROM stage (2 cores)", f"≤ {ROM_STAGE_SECONDS:g} s",
                       "n/a (reused from the cache)" if reused or t is None else f"{t:.0f} s",
                       None if reused or t is None else t <= ROM_STAGE_SECONDS, "Run"))
    return out


def _above_frozen(inst: object) -> Verdict:
    what = "free decay: the ROM's damping never below the frozen liquid's"
    goal = f"at most {_pct(FROZEN_MARGIN)} below, in every band"
    if not isinstance(inst, Mapping) or "rom" not in inst or "frozen" not in inst:
        return Verdict(what, goal, "n/a", None, "7")
    rom, frozen = _map(inst["rom"]), _map(inst["frozen"])
    rel: dict[str, float] = {}
    for b, v in rom.items():
        z, z0 = _finite(v), _finite(frozen.get(b))
        if str(b).endswith(" g") and z is not None and z0:
            rel[str(b)] = z / z0 - 1
    if not rel:
        return Verdict(what, goal, "n/a", None, "7")
    worst = min(rel, key=lambda b: rel[b])
    return Verdict(what, goal, f"lowest {100 * rel[worst]:+.1f} % (band {worst})",
                   rel[worst] >= -FROZEN_MARGIN, "7")


def _envelope(rows: object) -> Verdict:
    what = "the beam's runs inside the ROM's training envelope (peak tank acceleration)"
    goal = f"≤ {ENVELOPE_RATIO:g} × the training record's"
    rom = [_map(r) for r in rows if _map(r).get("case") == "rom"] if isinstance(rows, list) \
        else []
    ratios = [(str(r.get("run", "")), v) for r in rom
              if (v := _finite(r.get("acceleration_ratio"))) is not None]
    if not ratios:
        return Verdict(what, goal, "n/a", None, "8")
    run, worst = max(ratios, key=lambda kv: kv[1])
    return Verdict(what, goal, f"largest {worst:.2f} × ({run})", worst <= ENVELOPE_RATIO, "8")
