"""Fill levels: the rig at 20-80 % fill and the fill family judged at fills it never saw.

Prints every figure of the fill-level study:

- ``--rig-only``: the rig's Phi_d map maximum at 20, 25, 37.5, 50, 62.5, 75 and 80 % fill, and
  how well other fills' maps predict the unseen 37.5 and 62.5 % ones (nearest trained fill,
  linear blend of the energies, linear blend of Phi_d): the floor of any family built on 25 /
  50 / 75 %. About 25 s.
- default: runs (or reuses, through the stage cache) ``sloshrom reproduce --beyond`` in
  ``--out`` and prints the fill family's map error and passivity at every fill (target at the
  unseen fills: full-map error <= 15 %, no non-passive point), the sloshing beam's first-mode
  damping (LSCF on H1) against fill for rig, family and frozen liquid (target at the unseen
  fills: within 15 % of the rig) and the wall times.
- ``--summary OUT/summary.json``: the same figures from a finished run.

Usage::

    python benchmarks/fill_levels.py --rig-only
    python benchmarks/fill_levels.py --out bench_beyond
    python benchmarks/fill_levels.py --summary bench_beyond/summary.json

Exit status 0 always: the figures are the result, MISS marks a target not met.
"""

from __future__ import annotations

import argparse
import json
import math
import time
from pathlib import Path
from typing import Any

from sloshrom.config import Tank
from sloshrom.energy import map_fidelity, map_maximum
from sloshrom.pipeline import run
from sloshrom.pipeline.maps import compute_map
from sloshrom.pipeline.settings import load
from sloshrom.rig import VirtualRig


def _pct(v: Any, fmt: str = "{:6.2f}") -> str:
    return "   n/a" if v is None or not math.isfinite(v) else fmt.format(100 * v)


def rig_only() -> None:
    cfg = load()
    maps = {}
    t0 = time.perf_counter()
    print("fill   max Phi_d  omega_bar  a_bar  Gamma(g)  f(Hz)  Phi_d*fill")
    for f in (0.2, 0.25, 0.375, 0.5, 0.625, 0.75, 0.8):
        tank = Tank(fill=f)
        maps[f] = compute_map(VirtualRig(tank=tank), cfg, tank)
        m = map_maximum(maps[f])
        print(f"{100 * f:5.1f}  {m['phi_d']:9.3f}  {m['omega_bar']:9.2f}  {m['a_bar']:5.3f}  "
              f"{m['gamma']:8.2f}  {m['frequency']:5.1f}  {m['phi_d'] * f:10.3f}")
    print(f"({time.perf_counter() - t0:.1f} s for the 7 rig maps)")
    print("\nfull-map relative L2 error (%) of a prediction of the rig's map at an unseen fill:")
    for mid, lo, hi in ((0.375, 0.25, 0.5), (0.625, 0.5, 0.75)):
        w = (mid - lo) / (hi - lo)
        preds = {
            f"nearest ({100 * lo:g} %)": maps[lo],
            f"nearest ({100 * hi:g} %)": maps[hi],
            "blend of energies (family)": ((1 - w) * lo * maps[lo] + w * hi * maps[hi]) / mid,
            "blend of Phi_d": (1 - w) * maps[lo] + w * maps[hi],
        }
        for name, p in preds.items():
            err = map_fidelity(maps[mid], p)["full_l2"]
            print(f"  {100 * mid:5.1f} % from {name:28s} {_pct(err)}")


def report(s: dict[str, Any], seconds: float | None) -> None:
    f = s["stages"].get("fills")
    if f is None:
        print("no fills stage in this run: run with [beyond] enabled = true (--beyond)")
        return
    t = f["targets"]
    print("members:")
    for k, v in f["members"].items():
        print(f"  {k:>5} %  {v['model']}" + ("  (the main ROM)" if v["main_rom"] else
              f"  trained in {v['train_seconds']:.0f} s, validation fit {v['val_fit']:.1f} %"))
    print("\nPhi_d map of the family against the rig's at each fill:")
    print("  fill      full(%)  dissip.(%)  non-passive  min Phi_d")
    for r in f["maps"]:
        ok = r["full_l2"] <= t["full_l2"] and r["n_nonpassive"] <= t["n_nonpassive"]
        mark = ("ok  " if ok else "MISS") if r["unseen"] else "    "
        print(f"  {100 * r['fill']:5.1f}{'*' if r['unseen'] else ' '}  {_pct(r['full_l2'])}  "
              f"{_pct(r['dissipative_l2'])}     {r['n_nonpassive']:6d}   {r['min_phi_d']:9.4f}"
              f"  {mark}")
    print(f"  (* unseen; target full <= {t['full_l2']:.0%} and no non-passive point)")
    print("\nsloshing beam, first-mode damping (LSCF on H1, %):")
    print("  fill    RMS(g)    rig   family  frozen  family vs rig")
    for r in f["beam_errors"]:
        mark = (("ok  " if abs(r["rom_vs_rig"]) <= t["damping"] else "MISS")
                if r["unseen"] and math.isfinite(r["rom_vs_rig"]) else "    ")
        print(f"  {100 * r['fill']:5.1f}{'*' if r['unseen'] else ' '}  {r['rms_g']:5.2f}  "
              f"{_pct(r['rig'])} {_pct(r['rom'])} {_pct(r['frozen'])}  "
              f"{_pct(r['rom_vs_rig'], '{:+7.1f}')} %  {mark}")
    sec = f["seconds"]
    print(f"\nfills stage: members {sec['members']:.0f} s, maps {sec['maps']:.0f} s, beam "
          f"{sec['beam']:.0f} s; whole run timings {s.get('timings_s')}")
    if seconds is not None:
        print(f"wall time of this run: {seconds:.0f} s")


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", type=Path, default=Path("bench_beyond"))
    ap.add_argument("--summary", type=Path)
    ap.add_argument("--rig-only", action="store_true")
    a = ap.parse_args(argv)
    if a.rig_only:
        rig_only()
        return 0
    if a.summary is not None:
        report(json.loads(a.summary.read_text()), None)
        return 0
    cfg = load().replace(beyond={"enabled": True})
    t0 = time.perf_counter()
    s = run(a.out, cfg)
    report(s, time.perf_counter() - t0)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
