"""The ``multimode`` study: do ROMs predict the damping of a structure with two active modes?

Runs :func:`sloshrom.studies.multimode.stage_multimode` in ``--out DIR`` with the shipped
configuration (``sloshrom.pipeline.settings.load()``: its ``[multimode]`` table, or ``--set
key=value`` overrides of that table, JSON values), then prints every figure: the structure, the data
design, per mode and level the damping of the rig, the VFA-only ROM, the broadband ROM and frozen
liquid, the ROMs' errors against the rig with OK/MISS against the tolerance, the tank peak
accelerations, the training times and the wall time; the stage's outputs go to
``DIR/multimode_outputs.json``.

Run: ``PYTHONPATH=src .venv/bin/python benchmarks/multimode.py --out /tmp/multimode``
(about 8 min on two idle cores: two NFIR(70, 35) trainings in parallel dominate).
"""

from __future__ import annotations

import argparse
import json
import os
import time
from pathlib import Path
from typing import Any

from sloshrom.config import G
from sloshrom.pipeline.context import Context
from sloshrom.pipeline.settings import load
from sloshrom.studies.multimode.config import CASES
from sloshrom.studies.multimode.stage import stage_multimode


def _pct(v: float | None) -> str:
    return "   n/a" if v is None else f"{100 * v:6.3f}"


def report(outputs: dict[str, Any], wall: float) -> None:
    """Print the study's figures."""
    s, st, te, da, ro = (outputs[k] for k in ("settings", "structure", "test", "data", "roms"))
    tol = s["tolerance"]
    print("\n== structure (wing, two assumed modes; dry / frozen liquid) ==")
    print(f"EI {st['EI_n_m2']:.1f} N m^2, GJ {st['GJ_n_m2_per_rad']:.1f} N m^2/rad, mass "
          f"coupling {st['mass_coupling']:.3f}, wing {st['wing_mass_kg']:.2f} kg, tank structure "
          f"{st['tank_structure_mass_kg']:.3f} kg, liquid {st['liquid_mass_kg']:.4f} kg")
    for k in range(len(st["f_dry_hz"])):
        print(f"mode {k + 1}: f {st['f_dry_hz'][k]:.3f} / {st['f_frozen_hz'][k]:.3f} Hz, zeta "
              f"{100 * st['damping'][k]:.2f} %, m {st['modal_mass_kg'][k]:.4f} kg, psi_T "
              f"{st['psi_tank'][k]:.3f}, Gamma {st['participation_kg'][k]:+.4f} kg, "
              f"m_l psi^2/m {st['liquid_ratio'][k]:.4f}, psi Gamma/m "
              f"{st['tank_participation'][k]:+.3f}")
    print(f"\n== random tests: base {te['rms_g']} g RMS, Gaussian PSD {te['f0_hz']:g} +/- "
          f"{te['sigma_hz']:g} Hz, {te['duration_s']:g} s, seed {te['seed']} ==")
    for lv, rms, modes, run in zip(te["rms_g"], te["frozen_tank_rms_g"],
                                   te["frozen_tank_mode_rms_g"], te["frozen_motion"]["runs"],
                                   strict=True):
        print(f"frozen {lv:g} g: tank peak {run['peak_acceleration_g']:.2f} g, RMS {rms:.2f} g "
              f"(mode 1 {modes[0]:.2f} g, mode 2 {modes[1]:.2f} g), peak velocity "
              f"{run['peak_velocity_m_s']:.2f} m/s")
    print("\n== identification records (virtual rig) ==")
    for name, d in da.items():
        if name == "broadband_design":
            continue
        print(f"{name:21s} {d['duration_s']:6.1f} s  RMS {d['rms_acceleration_g']:5.2f} g  peak "
              f"{d['max_acceleration_g']:5.2f} g  peak velocity {d['max_velocity_m_s']:.2f} m/s  "
              f"| {d['what']}")
    bb = da["broadband_design"]
    print(f"broadband design: band {bb['band_hz'][0]:.2f}-{bb['band_hz'][1]:.2f} Hz, levels "
          + ", ".join(f"{v:.2f}" for v in bb["levels_rms_g"])
          + f" g RMS (top {bb['top_rms_g']:.2f} g = margin {bb['margin']:g} over the frozen "
          f"tests); covers peak acceleration x{bb['covers_peak_acceleration']:.2f}, peak "
          f"velocity x{bb['covers_peak_velocity']:.2f} "
          f"(x{bb['covers_peak_velocity_with_drift']:.2f} with the base drift)")
    print("\n== ROMs ==")
    for name, r in ro.items():
        var = r.get("input", "velocity")
        lo, hi = r["envelope"]["input_min"], r["envelope"]["input_max"]
        span = (f"[{lo:.2f}, {hi:.2f}] m/s" if var == "velocity"
                else f"[{lo / G:.1f}, {hi / G:.1f}] g")
        print(f"{name:17s} {r['name']} on the {var} ({r.get('loss', 'default')}), "
              f"{r['train_seconds_of_data']:.0f} s (+{r['validation_seconds_of_data']:.0f} s "
              f"validation): fit {r['fit_seconds']:.0f} s, {r['epochs']} epochs "
              f"({r['stop_reason']}), validation NRMSE {r['val_nrmse']:.3f}, input range {span}, "
              f"training peak acceleration {r['envelope']['acceleration_max'] / G:.1f} g")
    print("\n== modal damping (%), LSCF on H1, stable-pole cluster median ==")
    zeta = {(r["case"], r["mode"], r["rms_g"]): r for r in outputs["table"]}
    err = {(e["case"], e["mode"], e["rms_g"]): e for e in outputs["errors"]}
    env = {(e["case"], e["rms_g"]): e for e in outputs["envelope"]}
    cases = [c for c in CASES if c in ro or c in ("rig", "frozen")]
    roms = [c for c in cases if c in ro]
    print("tank peak g, then zeta % of: " + ", ".join(cases)
          + "; then error vs rig of: " + ", ".join(roms))
    for k in sorted({r["mode"] for r in outputs["table"]}):
        for lv in te["rms_g"]:
            peaks = " / ".join(f"{env[(c, lv)]['tank_peak_g']:5.2f}" for c in cases)
            z = " ".join(f"{_pct(zeta[(c, k, lv)]['zeta'])}" for c in cases)
            e = "  ".join(
                "   n/a MISS" if err[(c, k, lv)]["error"] is None else
                f"{100 * err[(c, k, lv)]['error']:+6.1f} % "
                f"{'OK' if err[(c, k, lv)]['within'] else 'MISS'}"
                for c in roms)
            print(f"mode {k} {lv:4g} g | {peaks} | {z} | {e}")
    print(f"\ntolerance {100 * tol:g} %: " + ", ".join(
        f"{c} {'within on every mode and level' if ok else 'NOT within everywhere'}"
        for c, ok in outputs["verdict"].items())
        + (f"; the target is judged on {outputs['judged_rom']}" if "judged_rom" in outputs
           else ""))
    print("envelope (peak tank acceleration / the ROM's training peak, fraction outside): "
          + "; ".join(f"{e['case']} {e['rms_g']:g} g {e['acceleration_ratio']:.2f}, "
                      f"{e['outside_fraction']:.3f}"
                      for e in outputs["envelope"] if e["acceleration_ratio"] is not None))
    if outputs.get("open_loop"):
        print("\n== open loop: each ROM fed the rig's own tank motion; power taken from each "
              "mode's band, ROM / rig ==")
        ol = {(o["case"], o["mode"], o["rms_g"]): o for o in outputs["open_loop"]}
        for k in sorted({o["mode"] for o in outputs["open_loop"]}):
            for lv in te["rms_g"]:
                r = {c: ol[(c, k, lv)]["ratio"] for c in roms}
                ratios = "  ".join(f"{c} {'n/a' if v is None else format(v, '.2f')}"
                                   for c, v in r.items())
                p_rig = 1e3 * ol[("vfa_rom", k, lv)]["power_rig_w"]
                print(f"mode {k}  {lv:g} g: rig {p_rig:7.2f} mW | {ratios}")
    print("\n== timings (s) ==")
    print(", ".join(f"{k} {v:.1f}" for k, v in outputs["timings_s"].items())
          + f"; wall {wall:.1f} s; load average at the end {os.getloadavg()[0]:.2f} on "
          f"{os.cpu_count()} CPUs")


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--out", type=Path, help="output directory (runs the stage there)")
    p.add_argument("--summary", type=Path,
                   help="print the figures of a finished `sloshrom reproduce --beyond` run "
                        "(its summary.json) instead")
    p.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                   help="override a key of [multimode] (JSON value), e.g. --set max_epochs=5")
    a = p.parse_args()
    if a.summary is not None:
        s = json.loads(a.summary.read_text())
        if "multimode" not in s["stages"]:
            p.error(f"{a.summary}: no multimode stage (run reproduce with --beyond)")
        report(s["stages"]["multimode"], s["timings_s"].get("multimode", float("nan")))
        return
    if a.out is None:
        p.error("give --out DIR (run the stage) or --summary FILE (read a finished run)")
    settings = {}
    for item in a.set:
        key, _, value = item.partition("=")
        settings[key] = json.loads(value)
    t0 = time.perf_counter()

    def progress(stage: str, done: float, total: float, text: str) -> None:
        print(f"[{time.perf_counter() - t0:7.1f} s] {stage} {done:g}/{total:g}: {text}",
              flush=True)

    print(f"load average at the start {os.getloadavg()[0]:.2f} on {os.cpu_count()} CPUs")
    cfg = load().replace(multimode=settings)
    outputs, files = stage_multimode(Context(a.out, cfg, progress))
    wall = time.perf_counter() - t0
    (a.out / "multimode_outputs.json").write_text(json.dumps(outputs, indent=1, default=float))
    report(outputs, wall)
    print("files: " + ", ".join(files) + f"; outputs: {a.out / 'multimode_outputs.json'}")


if __name__ == "__main__":  # the ROMs train in Dask worker processes, which re-import this file
    main()
