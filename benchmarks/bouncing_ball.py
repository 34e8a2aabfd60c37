"""The bouncing-ball baseline against the ROM and the virtual rig: every figure of the comparison.

Runs (or reuses, through the stage cache) ``sloshrom reproduce`` in ``DIR``, then the bouncing-ball
stage (:func:`sloshrom.studies.baseline.stage_baseline`, which writes its model, map, beam
results and figures into ``DIR``) and prints:

- the fit: seconds, simulations, identified parameters, training and validation NRMSE of the
  low-passed force, the ROM's validation NRMSE on the same measure;
- the Phi_d map of the ball and of the ROM against the rig's: full-map and dissipative-region
  relative L2 errors, passivity, and the same errors per third of the frequency range;
- the beam: Table 2 (LSCF on H1) first-mode damping of ball, ROM, rig and frozen liquid at each
  RMS level and the deviation from the rig; the median instantaneous damping of the free
  response per band of tank acceleration;
- model speed: a 10 s free response of the beam with the ball (at its step and at the record
  rate), the ROM and the rig, after compilation;
- two checks of the ball's design: the fit with the plain MSE (``lowpass=None``) and the ball's
  map at the record rate (``n_substeps=1``) instead of the rig's step.

Usage::

    python benchmarks/bouncing_ball.py --run DIR                # reproduce (cached) + the ball
    python benchmarks/bouncing_ball.py --run DIR --no-pipeline  # DIR is finished: ball only

The configuration is the one DIR's ``summary.json`` records (so the cache reuses every stage; tables
it lacks, e.g. ``[baseline]`` in a run made before that table existed, take their defaults), else
the defaults (``sloshrom.pipeline.settings.load()``), else ``--config``. The stage writes into DIR:
copy a run you want to keep unchanged. Exit status 0 always: the figures are the result.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
from pathlib import Path
from typing import Any

import xarray as xr

from sloshrom.beam.simulation.coupled import free_response
from sloshrom.energy import map_fidelity
from sloshrom.io import read_record
from sloshrom.pipeline import Context, run
from sloshrom.pipeline.beam import beam_structure
from sloshrom.pipeline.cache import StageCache
from sloshrom.pipeline.maps import compute_map
from sloshrom.pipeline.settings import ReproduceConfig, defaults, load, merge, validate
from sloshrom.rom.ball.model import BouncingBall
from sloshrom.rom.loading import load_model
from sloshrom.studies.baseline.config import CASE, FREQUENCY_BANDS
from sloshrom.studies.baseline.stage import frequency_band_errors, lowpassed_nrmse, stage_baseline


def _pct(v: Any, digits: int = 1) -> str:
    try:
        f = float(v)
    except (TypeError, ValueError):
        return "n/a"
    return "n/a" if not math.isfinite(f) else f"{100 * f:.{digits}f} %"


def _progress(stage: str, done: float, total: float, text: str) -> None:
    print(f"  [{stage}] {done:g}/{total:g} {text}", file=sys.stderr, flush=True)


def config_for(out: Path, path: Path | None) -> ReproduceConfig:
    if path is not None:
        return load(path)
    summary = out / "summary.json"
    if summary.is_file():
        return recorded_config(summary)
    return load()


def recorded_config(summary: Path) -> ReproduceConfig:
    """The configuration a run's ``summary.json`` records; tables it lacks take their
    defaults."""
    return validate(merge(defaults(), json.loads(summary.read_text())["config"]))


def print_fit(o: dict[str, Any]) -> None:
    p, h = o["parameters"], o["fit"]
    print(f"fit: {o['fit_seconds']:.1f} s, {h['evaluations']} simulations of "
          f"{h['n_samples']} samples, {h['generations']} generations "
          f"(converged: {h['converged']}); force low-passed at {h['lowpass_hz']:.1f} Hz")
    print(f"  mass fraction {p['mass_fraction']:.4f} (m_b = {1e3 * p['ball_mass_kg']:.2f} g), "
          f"restitution {p['restitution']:.4f}, gap {1e3 * p['gap_m']:.3f} mm "
          f"({p['gap_factor']:.3f} x ullage), model step {1e6 * p['dt_s']:.0f} us "
          f"({p['n_substeps']} per record sample)")
    nr = o["validation_nrmse_lowpassed"]
    print(f"  NRMSE of the low-passed force: train {_pct(h['nrmse'])}, validation "
          f"{_pct(h['validation_nrmse'])} (unfiltered {_pct(h['validation_nrmse_unfiltered'])});"
          f" ROM validation on the same measure {_pct(nr.get('rom'))}")


def print_maps(o: dict[str, Any]) -> None:
    print("Phi_d map against the rig's (whole map | dissipative region | non-passive points, "
          "min Phi_d):")
    for name, key in (("ball", "ball_fidelity"), ("ROM", "rom_fidelity")):
        f = o.get(key)
        if f:
            print(f"  {name:>4}: {_pct(f['full_l2']):>8} | {_pct(f['dissipative_l2']):>8} | "
                  f"{f['n_nonpassive']}/{f['n_points']}, min {f['min_phi_d']:.4f} "
                  f"(threshold {f['passivity_threshold']:.4f})")
    m = o["ball_maximum"]
    print(f"  ball maximum Phi_d {m['phi_d']:.3f} at omega_bar {m['omega_bar']:.2f}, a_bar "
          f"{m['a_bar']:.3f} ({m['gamma']:.2f} g, {m['frequency']:.1f} Hz)")
    print("per frequency band (whole map | dissipative region):")
    for band in FREQUENCY_BANDS:
        row = []
        for model, errs in o["frequency_bands"].items():
            b = errs[band]
            row.append(f"{'ball' if model == CASE else model}: {_pct(b['full_l2']):>8} | "
                       f"{_pct(b['dissipative_l2']):>8}")
        lo, hi = o["frequency_bands"][CASE][band]["frequency_hz"]
        print(f"  {band:>4} {lo:5.1f}-{hi:4.1f} Hz  " + "   ".join(row))


def print_beam(o: dict[str, Any]) -> None:
    rows = {(r["case"], r["rms_g"]): r["lscf_h1"] for r in o["table2_all"]}
    levels = sorted({lv for _, lv in rows})
    cases = [c for c in (CASE, "rom", "rig", "frozen") if (c, levels[0]) in rows]
    print("Table 2, first-mode damping (LSCF on H1) and deviation from the rig:")
    for lv in levels:
        rig = rows[("rig", lv)]
        print(f"  {lv:g} g: " + ", ".join(
            f"{c} {_pct(rows[(c, lv)], 3)}" + ("" if c == "rig" else
                                              f" ({100 * (rows[(c, lv)] / rig - 1):+.1f} %)")
            for c in cases))
    inst = o["instantaneous_damping_all"]
    bands = [k for k in inst[CASE] if k.endswith(" g")]
    print("free response, median instantaneous first-mode damping per band of tank "
          "acceleration (deviation from the rig):")
    for band in bands:
        rig = inst["rig"][band]
        print(f"  {band:>7}: " + ", ".join(
            f"{c} {_pct(inst[c][band], 3)}" + ("" if c == "rig" else
                                              f" ({100 * (inst[c][band] / rig - 1):+.1f} %)")
            for c in cases))


def print_speed(ctx: Context, rom_path: Path | None) -> None:
    _, modal = beam_structure(ctx.cfg.beam, ctx.tank)
    fs = float(ctx.cfg.rig.fs)
    ball = BouncingBall.load(ctx.out / "models" / "bouncing_ball.toml")
    models = {"ball": ball,
              "ball at the record rate": BouncingBall.from_parameters(
                  ball.mass_fraction_, ball.restitution_, ball.gap_, ball.fs_, tank=ctx.tank,
                  n_substeps=1),
              "rig": ctx.rig()}
    if rom_path is not None:
        models["ROM"] = load_model(rom_path)
    print("speed, 10 s free response of the beam (after a warm-up call that compiles; best of "
          "2):")
    for name, model in models.items():
        free_response(model, modal, duration=10.0, tank=ctx.tank, output_fs=fs)
        times = []
        for _ in range(2):
            t0 = time.perf_counter()
            free_response(model, modal, duration=10.0, tank=ctx.tank, output_fs=fs)
            times.append(time.perf_counter() - t0)
        print(f"  {name:>23}: {1e3 * min(times):7.1f} ms  (model step {1e6 * model.dt:.0f} us)")


def print_design_checks(ctx: Context, o: dict[str, Any]) -> None:
    """The ball's two design choices against the alternatives, on the same data."""
    train = read_record(ctx.out / "data" / "train.nc")
    val = read_record(ctx.out / "data" / "validation.nc")
    cutoff = o["fit"]["lowpass_hz"]
    t0 = time.perf_counter()
    plain = BouncingBall(tank=ctx.tank, lowpass=None).fit(
        train["velocity"], train["dynamic_force"], train.fs,
        validation=(val["velocity"], val["dynamic_force"]))
    y = val["dynamic_force"]
    nr = lowpassed_nrmse(0.5 * (y[1:] + y[:-1]), plain.predict(val["velocity"])[:-1], val.fs,
                         cutoff)
    print(f"check: plain-MSE fit ({time.perf_counter() - t0:.1f} s): mass fraction "
          f"{plain.mass_fraction_:.4f}, restitution {plain.restitution_:.4f}, gap factor "
          f"{plain.gap_factor_:.3f}; validation NRMSE unfiltered "
          f"{_pct(plain.history_['validation_nrmse'])}, low-passed at {cutoff:.1f} Hz "
          f"{_pct(nr)}")
    ball = BouncingBall.load(ctx.out / "models" / "bouncing_ball.toml")
    coarse = BouncingBall.from_parameters(ball.mass_fraction_, ball.restitution_, ball.gap_,
                                          ball.fs_, tank=ctx.tank, n_substeps=1)
    with xr.open_dataset(ctx.out / "maps" / "phi_d_rig.nc", engine="h5netcdf") as ds:
        rig = ds["phi_d"].load()
    cmap = compute_map(coarse, ctx.cfg, ctx.tank)
    f = map_fidelity(rig, cmap)
    bands = frequency_band_errors(rig, cmap)
    print(f"check: the same ball's map at the record rate ({1e3 * coarse.dt:.0f} ms step): "
          f"whole map {_pct(f['full_l2'])}, dissipative {_pct(f['dissipative_l2'])}, "
          f"non-passive {f['n_nonpassive']}/{f['n_points']} (min {f['min_phi_d']:.4f}); per "
          "band " + ", ".join(f"{b} {_pct(bands[b]['full_l2'])}" for b in FREQUENCY_BANDS))


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--run", type=Path, default=Path("bench_ball"),
                    help="a sloshrom reproduce output directory (made if needed)")
    ap.add_argument("--config", type=Path, help="a reproduce configuration file")
    ap.add_argument("--no-pipeline", action="store_true",
                    help="DIR is a finished run: do not run (or check) the reproduce stages")
    ap.add_argument("--no-checks", action="store_true", help="skip the design checks")
    args = ap.parse_args(argv)
    out = args.run
    cfg = config_for(out, args.config)
    t0 = time.perf_counter()
    if args.no_pipeline:
        cfg = recorded_config(out / "summary.json")
    else:
        run(out, cfg, _progress)
    print(f"reproduce: {time.perf_counter() - t0:.0f} s "
          f"({'read' if args.no_pipeline else 'run, cached stages reused'})")
    # the stages' results as their records hold them: the baseline finds its inputs there
    cache = StageCache(out)
    data, rom, maps, beam = (cache.recorded(n) for n in ("data", "rom", "maps", "beam"))
    if data is None:
        raise SystemExit(f"{out}: no intact data stage recorded (run without --no-pipeline)")
    rom_path = rom.output(rom.outputs["model"]) if rom is not None else None
    ctx = Context(out, cfg, _progress)
    t0 = time.perf_counter()
    o, files = stage_baseline(ctx, data, rom, maps, beam)
    print(f"bouncing-ball stage: {time.perf_counter() - t0:.1f} s, {len(files)} files")
    print_fit(o)
    print_maps(o)
    print_beam(o)
    print_speed(ctx, rom_path)
    if not args.no_checks:
        print_design_checks(ctx, o)
    json.dumps(o)  # the outputs are plain JSON, as the stage cache stores them
    return 0


if __name__ == "__main__":
    sys.exit(main())
