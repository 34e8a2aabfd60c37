"""Fidelity of the identified ROM against the virtual rig: every figure of the ROM's targets, for
one or more `reproduce` configurations (one per model class), in the same run.

Runs (or reuses, through the stage cache) ``sloshrom reproduce`` in ``OUT/<name>`` for each
configuration and prints, from the files it writes:

- validation: fit % = 100 (1 - |e| / |y - mean y|) of the free run from rest over the whole
  validation record (target >= 50 %), beside the rig's twin run's (the same record with the
  input's gain changed by ``[rig] twin_gain``: what a laboratory could confirm), and with
  ``rom.compare`` the classes trained in the same run beside it (fit, training time, and the
  ratio of the training times: target <= 2);
- waveform (docs/rom.md, "Waveform fidelity"), each figure beside the twin run's: on the
  validation record (fit: target >= 60 %), at each level of the beam's random tests and over
  the free decay's first 2 s (paper Fig. 20c; fit: target >= 70 %), the force RMS / rig's
  (random tests and free decay: target within 10 %), the power above 60 Hz relative to 5-20 Hz
  against the rig's (random tests: target within a factor of 2), impacts per second (random
  tests: target within 25 %) and the peak-force quantiles (random tests: the 99 % one within
  15 %);
- Phi_d map of the ROM against the rig's: full-map relative L2 error (target <= 6 %),
  dissipative-region error (target <= 5 %), passivity (points below -0.02 max, target 0), and
  for an ensemble the same figures as mean ± std over its members;
- free response: first-mode instantaneous damping per amplitude band for frozen, rig and ROM;
  ROM not more than 5 % below frozen in any band, within 10 % of the rig in bands above 1 g;
- random response (Table 2, LSCF on H1): ROM within 5 % of the rig at each RMS level, with
  the members' spread;
- envelope: each ROM run's peak tank acceleration over the training record's peak (target
  <= 1.05) and the fraction of samples outside the training envelope;
- the wall time of each run (default `reproduce` target <= 10 min).

Configurations: "default" (the grey-box ROM, no override), "nss" (the neural state-space ROM,
the default before it), "rig_b" (the default recipe on the second rig), "nfir" (the paper's
class with the passive recipe), "paper" (the paper's plain-MSE identification).

Usage::

    python benchmarks/fidelity.py --out bench_fidelity                 # every configuration
    python benchmarks/fidelity.py --out bench_fidelity --only default  # one configuration
    python benchmarks/fidelity.py --summary results/summary.json       # figures of a past run

A configuration is a TOML override file (as ``sloshrom reproduce --config``); "default" has
none. Exit status 0 always: the figures are the result, MISS marks a target not met; a figure a
past run's summary does not hold (written before it was recorded) prints as n/a.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
from pathlib import Path
from typing import Any

from sloshrom.pipeline import run
from sloshrom.pipeline import targets as T
from sloshrom.pipeline.settings import load

HERE = Path(__file__).resolve().parent
EXAMPLES = HERE.parent / "docs" / "examples"
CONFIGS = {
    "default": None,
    "nss": EXAMPLES / "nss_rom.toml",
    "rig_b": EXAMPLES / "rig_b.toml",
    "nfir": EXAMPLES / "nfir_rom.toml",
    "paper": EXAMPLES / "paper_rom.toml",
}


def _mark(ok: bool) -> str:
    return "ok  " if ok else "MISS"


def _pct(v: Any) -> str:
    return "  n/a " if v is None or not math.isfinite(v) else f"{100 * v:6.2f}"


def _num(v: Any, fmt: str = "{:.3g}") -> str:
    """A figure, or n/a (absent, None or not finite)."""
    ok = isinstance(v, int | float) and math.isfinite(v)
    return fmt.format(v) if ok else "n/a"


def _quantiles(q: Any) -> str:
    return "/".join(_num(v) for v in q) if isinstance(q, list) and q else "n/a"


def waveform(st: dict[str, Any], levels: list[float]) -> None:
    """The waveform figures of the ROM beside the rig's twin run (n/a: not in the summary)."""
    wr = st["rom"].get("waveform_fidelity") or {}
    wb = st["beam"].get("waveform_fidelity") or {}
    if not wr and not wb:
        print("waveform: n/a (a summary written before the waveform figures were recorded)")
        return
    gain = wr.get("twin_gain", wb.get("twin_gain"))
    print("waveform (docs/rom.md, \"Waveform fidelity\"): ROM [the rig's twin run, input x "
          f"{_num(gain, '{:g}')}]")
    tests = [("validation", wr, "validation")]
    tests += [(f"random {lv:g} g", (wb.get("levels") or {}).get(f"{lv:g}") or {}, "random")
              for lv in levels]
    wf = st["beam"].get("free_fidelity") or {}
    if wf.get("rom"):
        tests.append((f"free {_num(wf.get('seconds'), '{:g}')} s", wf, "free"))
    for test, w, kind in tests:
        ro, tw = w.get("rom") or {}, w.get("twin") or {}
        rms, hf = ro.get("rms_ratio"), ro.get("hf_factor")
        fit, rate, ref_rate = ro.get("fit"), ro.get("impact_rate"), ro.get("impact_rate_reference")
        q, q_ref = ro.get("peak_quantiles") or [], ro.get("peak_quantiles_reference") or []
        marks = {"rms": "", "hf": "", "fit": "", "rate": "", "q99": ""}
        if kind in ("random", "free"):
            rms_ok = rms is not None and abs(rms - 1) <= T.RMS_WITHIN
            marks["rms"] = (f" [{_mark(rms_ok) if rms is not None else 'n/a '} "
                            "within 10 %]")
        if kind == "random":
            hf_ok = hf is not None and 1 / T.HF_FACTOR <= hf <= T.HF_FACTOR
            marks["hf"] = (f" [{_mark(hf_ok) if hf is not None else 'n/a '} "
                           "within x 2]")
            ok = rate is not None and ref_rate and abs(rate / ref_rate - 1) <= T.IMPACTS_WITHIN
            marks["rate"] = f" [{_mark(bool(ok))} within 25 %]"
            ok = (len(q) == 3 and len(q_ref) == 3 and q_ref[2]
                  and abs(q[2] / q_ref[2] - 1) <= T.Q99_WITHIN)
            marks["q99"] = f" [{_mark(bool(ok))} 99 % within 15 %]"
        if kind in ("validation", "free"):
            need = T.FIT_VALIDATION if kind == "validation" else T.FIT_FREE
            marks["fit"] = (f" [{_mark(fit >= need) if fit is not None else 'n/a '} "
                            f">= {need:g} %]")
        def twin(v: Any, fmt: str = "{:.3g}", unit: str = "", has: bool = bool(tw)) -> str:
            # the free decay has no twin run: no bracket rather than an n/a
            return f" [{_num(v, fmt)}{unit}]" if has else ""

        tq = f" [{_quantiles(tw.get('peak_quantiles'))}]" if tw else ""
        print(f"  {test:>12}: force RMS / rig's {_num(rms, '{:.3f}')}"
              f"{twin(tw.get('rms_ratio'), '{:.3f}')}"
              f"{marks['rms']}; power >60 Hz / 5-20 Hz {_num(ro.get('hf_ratio'))}"
              f"{twin(tw.get('hf_ratio'))}, rig {_num(ro.get('hf_ratio_reference'))}: "
              f"x {_num(hf)}{twin(tw.get('hf_factor'))}{marks['hf']}")
        print(f"  {'':>12}  fit {_num(fit, '{:.1f}')} %"
              f"{twin(tw.get('fit'), '{:.1f}', ' %')}{marks['fit']}, NRMSE "
              f"{_num(ro.get('nrmse'), '{:.3f}')}{twin(tw.get('nrmse'), '{:.3f}')}; impacts "
              f"{_num(rate, '{:.2f}')}{twin(tw.get('impact_rate'), '{:.2f}')}"
              f" /s, rig {_num(ref_rate, '{:.2f}')} /s{marks['rate']}; peak force "
              f"1/50/99 % {_quantiles(q)}{tq} N, rig "
              f"{_quantiles(q_ref)} N{marks['q99']}")


def experiment(b: dict[str, Any]) -> None:
    """Table 2 of the ROM against the experiment (the rig as the laboratory): each estimator
    inside the experiment's 95 % interval, or |z| <= 1.96 with both intervals."""
    rows = [x for x in (b.get("experiment") or {}).get("random", []) if x["case"] == "rom"]
    if not rows:
        print("ROM against the experiment: n/a (no comparison in this summary)")
        return
    print("random response, ROM against the experiment (%; inside its 95 % interval or "
          "|z| <= 1.96):")
    for x in rows:
        ok = x["verdict"] == "inside" or (x["z"] is not None and math.isfinite(x["z"])
                                          and abs(x["z"]) <= 1.96)
        why = f" ({x['reason']})" if x.get("reason") else ""
        print(f"  {x['rms_g']:g} g {x['estimator']:>11}: ROM {_pct(x['predicted'])} "
              f"experiment {_pct(x['measured'])} [{_pct(x['measured_low'])}, "
              f"{_pct(x['measured_high'])}] {x['verdict']}, z {_num(x['z'], '{:+.2f}')} "
              f"[{_mark(ok)}]{why}")


def report(name: str, s: dict[str, Any], seconds: float | None) -> None:
    st = s["stages"]
    print(f"\n=== {name} ===")
    if seconds is not None:
        print(f"wall time {seconds:.0f} s ({'reused stages' if seconds < 30 else 'computed'});"
              f" stages: " + ", ".join(f"{k} {v:.0f} s" for k, v in s["timings_s"].items()))
    r = st["rom"]
    print(f"ROM {r['name']}: validation MSE {r['val_mse']:.4f} N^2, train {r['train_seconds']:.0f}"
          f" s")
    fit = r.get("val_fit", math.nan)
    twin_fit = ((r.get("waveform_fidelity") or {}).get("twin") or {}).get("fit")
    print(f"validation fit {fit:6.2f} %  [{_mark(fit >= 50.0)} >= 50 %]; the rig's twin run "
          f"{_num(twin_fit, '{:.2f}')} %")
    for arch, c in (r.get("compare") or {}).items():
        ratio = r["train_seconds"] / c["train_seconds"]
        mark = f" [{_mark(ratio <= 2.0)} <= 2]" if arch == "nfir" else ""
        print(f"compared {c['name']}: fit {c['val_fit']:.2f} %, train {c['train_seconds']:.0f} s;"
              f" training time ratio {ratio:.2f}{mark}")
    f = st["maps"]["rom_fidelity"]
    print(f"map  full-map L2 {_pct(f['full_l2'])} %  "
          f"[{_mark(f['full_l2'] <= T.MAP_FULL)} <= {100 * T.MAP_FULL:g} %]")
    print(f"map  dissipative L2 {_pct(f['dissipative_l2'])} %  "
          f"[{_mark(f['dissipative_l2'] <= T.MAP_DISSIPATIVE)} "
          f"<= {100 * T.MAP_DISSIPATIVE:g} %]")
    print(f"map  non-passive {f['n_nonpassive']}/{f['n_points']} = "
          f"{_pct(f['nonpassive_fraction'])} %  [{_mark(f['n_nonpassive'] == 0)} "
          f"0], min Phi_d {f['min_phi_d']:.4f} (threshold {f['passivity_threshold']:.4f})")
    ms = st["maps"].get("rom_fidelity_members")
    if ms:
        def pm(key: str, scale: float = 100.0) -> str:
            return f"{ms[key]['mean'] * scale:.2f} ± {ms[key]['std'] * scale:.2f}"
        print(f"map  members: full {pm('full_l2')} %, dissipative {pm('dissipative_l2')} %, "
              f"non-passive {pm('nonpassive_fraction')} %, min {pm('min_phi_d', 1.0)}")
    b = st["beam"]
    inst = b["instantaneous_damping"]
    bands = [k for k in inst["frozen"] if k.endswith(" g")]
    print("free response, first-mode instantaneous damping (%):")
    for band in bands:
        fr, rg, ro = (inst[c][band] for c in ("frozen", "rig", "rom"))
        lo = float(band.split("-")[0])
        checks = [f"vs frozen {_mark(ro >= 0.95 * fr)}"]
        if lo >= 1.0:
            checks.append(f"vs rig {100 * (ro / rg - 1):+5.1f} % {_mark(abs(ro / rg - 1) <= 0.10)}")
        print(f"  {band:>7}: frozen {_pct(fr)} rig {_pct(rg)} ROM {_pct(ro)}   "
              + ", ".join(checks))
    rows = {(row["case"], row["rms_g"]): row for row in b["table2"]}
    members = (b.get("rom_members") or {}).get("table2", {})
    print("random response, Table 2 (LSCF on H1, %):")
    for level in s["config"]["beam"]["rms_g"]:
        rg, ro = rows[("rig", level)]["lscf_h1"], rows[("rom", level)]["lscf_h1"]
        fr = rows[("frozen", level)]["lscf_h1"]
        dev = ro / rg - 1 if math.isfinite(ro) and math.isfinite(rg) else math.nan
        sp = members.get(f"{level:g}")
        spt = (f", members {100 * sp['mean']:.2f} ± {100 * sp['std']:.2f}" if sp else "")
        print(f"  {level:g} g: frozen {_pct(fr)} rig {_pct(rg)} ROM {_pct(ro)} "
              f"({100 * dev:+5.1f} %) [{_mark(abs(dev) <= 0.05)} within 5 %]{spt}")
    experiment(b)
    frame = r.get("frame_sensitivity")
    if frame:
        print("frame: the ROM's dissipation on the validation record with the velocity shifted "
              "by " + ", ".join(f"{c:g} m/s: {100 * e:.1f} %" for c, e in
                                zip(frame["offsets_m_s"], frame["energy_change"], strict=False))
              + " (the physics: 0)")
    waveform(st, s["config"]["beam"]["rms_g"])
    env = [e for e in b.get("envelope") or [] if e.get("acceleration_ratio") is not None]
    if env:
        print("envelope (runs of models with a training envelope):")
        for e in env:
            ratio = e["acceleration_ratio"]
            print(f"  {e['run']:>12} {e['case']:>6}: peak {e['peak_tank_acceleration_g']:5.2f} g"
                  f" / training {e['training_peak_acceleration_g']:5.2f} g = {ratio:.3f} "
                  f"[{_mark(ratio <= T.ENVELOPE_RATIO)} <= {T.ENVELOPE_RATIO:g}], "
                  f"outside {_pct(e['outside_fraction'])} % of samples")


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", type=Path, default=Path("bench_fidelity"))
    ap.add_argument("--only", choices=sorted(CONFIGS), action="append")
    ap.add_argument("--quick", action="store_true", help="reproduce --quick sizes")
    ap.add_argument("--summary", type=Path, action="append",
                    help="only print the figures of an existing OUT/summary.json (repeatable)")
    args = ap.parse_args(argv)
    if args.summary:
        for path in args.summary:
            report(str(path), json.loads(path.read_text()), None)
        return 0
    names = args.only or list(CONFIGS)
    for name in names:
        cfg = load(CONFIGS[name], quick=args.quick)
        t0 = time.perf_counter()
        summary = run(args.out / name, cfg)
        report(name, summary, time.perf_counter() - t0)
        json.dumps(summary)  # the summary is plain JSON: what other tools read
    return 0


if __name__ == "__main__":
    sys.exit(main())
