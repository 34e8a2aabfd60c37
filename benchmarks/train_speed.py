"""Identification against the limit of the hardware: every trainer's epoch against the time of a
dense product of the same FLOPs, in the same run.

For each model class and trainer of the default run (the NSS's multiple shooting, the passive
NFIR's minibatch Adam, the NOE's multiple shooting; each with its loss recipe and plain), on the
default records (``results/data`` of ``make reproduce``, else the rig's VFA tests):

- ``epoch``: the steady time of one epoch's compiled Adam steps (median of epochs 2..E of a real
  ``fit``; epoch 1 compiles), and of the validation after it;
- ``GFLOP``: the epoch's floating-point operations, counted from the architecture (the products
  of each layer: forward, and the two products of its backward pass -- weights and, in a
  recurrence, its input -- so 3x forward for the state-space and NOE recurrences, 2x for the
  NFIR whose regressors are data; element-wise work such as tanh and exp is not counted);
- ``bound``: in the same run, the time of a dense matrix product with those FLOPs, in the
  trainer's precision, of the shape class of the model's widest layer (rows x its inputs by its
  inputs x its outputs); ``ratio`` = epoch / bound: how far from the arithmetic the epoch runs.
  Ratios hold across machines better than seconds. A skinny product streams its operands from
  memory, so a trainer whose small products stay in cache can beat this bound (ratio < 1); the
  time of the same FLOPs at the rate of a large square product (the machine's arithmetic peak
  for us) is printed beside it;
- the ensemble's scaling: one NSS member alone, two members on two pinned Dask workers (the
  default), the same unpinned, and two members ``vmap``-ed in one process: throughput relative
  to one member;
- the ROM's Phi_d map (30 x 30) from a cold start (compilation included), beside the rig's map;
- ``--sweep``: the paper's sensitivity analysis (27 networks) on two workers.

Targets (this 2-core machine): passive NFIR epoch <= 2x its bound; an ensemble of 2 on 2 cores
>= 1.7x one member's throughput; ROM map <= 3 s; sweep <= 5 min.

Run: ``.venv/bin/python benchmarks/train_speed.py`` (about 3 min; ``--sweep`` adds ~5 min;
``--lm`` adds the comparison of Adam with the paper's Levenberg-Marquardt, ~7 min).
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import os
import tempfile
import time
from pathlib import Path

import jax
import jax.numpy as jnp
import numpy as np

BLOCK = 65536  # rows of the dense product timed for the bound


def rig_data(duration: float, split: str, seed: int) -> tuple[np.ndarray, np.ndarray, float]:
    """The rig's VFA test (cached in the temporary directory): velocity, force, fs."""
    cache = Path(tempfile.gettempdir()) / f"sloshrom_bench_{split}_{duration:g}_{seed}.npz"
    if cache.is_file():
        z = np.load(cache, allow_pickle=False)
        return z["u"], z["y"], float(z["fs"])
    from sloshrom.io import record_from_measurement
    from sloshrom.rig.virtual import VirtualRig
    from sloshrom.signals import vfa

    rig = VirtualRig(seed=seed)
    path = vfa(1.0 / rig.dt, split, duration=duration, seed=seed)
    rec = record_from_measurement(rig.measure(path.acceleration), truth=False)
    u, y, fs = rec["velocity"], rec["dynamic_force"], rec.fs
    np.savez(cache, u=u, y=y, fs=fs)
    return u, y, fs


def records(run: Path) -> tuple[tuple[np.ndarray, ...], str]:
    """(u, y, uv, yv, fs) of a finished ``make reproduce`` run, else of the rig's VFA tests."""
    if (run / "data" / "train.nc").is_file():
        from sloshrom.io import read_record

        tr = read_record(run / "data" / "train.nc")
        va = read_record(run / "data" / "validation.nc")
        return ((tr["velocity"], tr["dynamic_force"], va["velocity"], va["dynamic_force"],
                 tr.fs), f"{run}/data (the default records)")
    u, y, fs = rig_data(480.0, "train", 1)
    uv, yv, _ = rig_data(240.0, "validation", 2)
    return (u, y, uv, yv, fs), "the rig's VFA tests, 480 s / 240 s (no results/data)"


def product_seconds(flops: float, k: int, n: int, dtype: np.dtype, repeat: int = 5) -> float:
    """Time of dense products (rows x k) @ (k x n) in ``dtype`` totalling ``flops``: the median
    of ``repeat`` timings of a loop of products long enough (>= 50 ms) for the clock."""
    rng = np.random.default_rng(0)
    a = jnp.asarray(rng.standard_normal((BLOCK, k)), dtype)
    b = jnp.asarray(rng.standard_normal((k, n)), dtype)
    f = jax.jit(jnp.dot)
    f(a, b).block_until_ready()
    t0 = time.perf_counter()
    f(a, b).block_until_ready()
    loops = max(1, int(0.05 / max(time.perf_counter() - t0, 1e-6)))
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        for _ in range(loops):
            r = f(a, b)
        r.block_until_ready()
        times.append((time.perf_counter() - t0) / loops)
    return float(np.median(times)) * flops / (2.0 * BLOCK * k * n)


def peak_rate(dtype: np.dtype, size: int = 2048, repeat: int = 3) -> float:
    """FLOP/s of a large square product in ``dtype``: the machine's arithmetic peak for us."""
    rng = np.random.default_rng(0)
    a = jnp.asarray(rng.standard_normal((size, size)), dtype)
    f = jax.jit(jnp.dot)
    f(a, a).block_until_ready()
    best = math.inf
    for _ in range(repeat):
        t0 = time.perf_counter()
        f(a, a).block_until_ready()
        best = min(best, time.perf_counter() - t0)
    return 2.0 * size**3 / best


def step_report(times: dict[str, list[float]], flops: float, peak: float, reference: str,
                candidate: str, indent: str = "  ") -> None:
    """Print each path's median time a step (from ``times``, s a step per interleaved run), its
    GFLOP/s and its time over the ``flops``' time at the float32 ``peak`` (FLOP/s); then the
    speed-up of ``candidate`` over ``reference``, per interleaved pair."""
    for name, v in times.items():
        t = float(np.median(v))
        print(f"{indent}{name:15s} {t * 1e3:7.2f} ms/step  {flops / t / 1e9:6.1f} GFLOP/s  "
              f"{t / (flops / peak):5.1f}x the float32 peak's time  "
              f"[{', '.join(f'{x * 1e3:.1f}' for x in v)}]")
    ratios = np.asarray(times[reference]) / np.asarray(times[candidate])
    print(f"{indent}speed-up of {candidate} ({reference} / it, per interleaved pair): median "
          f"{np.median(ratios):.2f} [{', '.join(f'{r:.2f}' for r in ratios)}]", flush=True)


def steady(h: dict, key: str) -> float:
    """Median of an epoch timing over epochs 2.. (epoch 1 compiles)."""
    v = np.asarray(h[key][2:], dtype=float)
    return float(np.median(v)) if v.size else math.nan


# ---------------------------------------------------------------------------------------------
# FLOPs of one epoch, counted from the architecture
# ---------------------------------------------------------------------------------------------


def nss_flops(m) -> tuple[float, int, int]:
    """FLOPs of one NSS epoch, and the (k, n) of its widest layer."""
    # the size it has (the estimator's sized arguments are None until a fit chooses them)
    p = m.effective_params()
    nx, h, w = p["n_states"], p["neurons"], p["window"]
    n_probe = 24 if m.passivity > 0 else 0
    seqs = m.batch + n_probe
    per_step = (nx + 1) * (nx + 2 * h + 1) + h * (nx + 1)  # A, W1, V1, C; W2, V2 (MACs)
    encoder = 2 * w * h + h * nx
    fwd = 2.0 * (seqs * p["horizon"] * per_step + m.batch * encoder)
    return m.steps_per_epoch * 3.0 * fwd, nx + 1, 2 * h


def nfir_rows(m, u: np.ndarray, fs: float) -> int:
    """Rows of NFIR regressors one Adam step evaluates (data, probes, cycles)."""
    from sloshrom.rom.network import MinMaxScaler
    from sloshrom.rom.tdnn.training import energy_cycles, harmonic_probes
    from sloshrom.signals import power_band

    rows = 4096
    band = tuple(power_band(u, fs, 0.001, 0.999))
    sc = MinMaxScaler.fit(u, u)
    if m.passivity > 0:
        rows += 24 * harmonic_probes(u, fs, sc, m.spec.delays, band).weight.shape[1]
    if m.cycle_energy > 0:
        rows += 32 * int(energy_cycles(u, fs, band).rows.shape[1])
    return rows


def nfir_flops(m, u: np.ndarray, fs: float) -> tuple[float, int, int]:
    d, h = len(m.spec.delays), m.neurons
    # forward W x and the weight gradient: two products per row (the regressors are data)
    return 200 * nfir_rows(m, u, fs) * 2.0 * 2.0 * d * h, d, h


def noe_flops(m) -> tuple[float, int, int]:
    d = len(m.spec.delays) + m.out_delays
    n_probe = 24 if m.passivity > 0 else 0
    fwd = 2.0 * (m.batch + n_probe) * m.horizon * (d * m.neurons + m.neurons)
    return m.steps_per_epoch * 3.0 * fwd, d, m.neurons


# ---------------------------------------------------------------------------------------------


def epoch_table(data, epochs: int) -> list[dict]:
    from sloshrom.rom import NFIR, NOE, NSS
    from sloshrom.rom.registry import CLASSES

    NSS_RECIPE, RECIPE = dict(CLASSES["nss"].recipe), dict(CLASSES["nfir"].recipe)

    u, y, uv, yv, fs = data
    plain = {"amplitude_weighting": 0.0, "passivity": 0.0, "cycle_energy": 0.0}
    cases = [
        ("NSS(8, 64, 50), recipe", NSS(max_epochs=epochs, **NSS_RECIPE), nss_flops, np.float32),
        ("NSS(8, 64, 50), plain", NSS(max_epochs=epochs, **plain), nss_flops, np.float32),
        ("NFIR(70, 35) Adam, passive recipe",
         NFIR(70, 35, trainer="adam", max_epochs=epochs, **RECIPE), nfir_flops, np.float64),
        ("NFIR(70, 35) Adam, plain", NFIR(70, 35, trainer="adam", max_epochs=epochs),
         nfir_flops, np.float64),
        ("NOE(2, 10, 2) shooting, recipe",
         NOE(2, 10, out_delays=2, trainer="adam", max_epochs=epochs, **RECIPE), noe_flops,
         np.float32),
    ]
    rows = []
    for name, m, count, dtype in cases:
        t0 = time.perf_counter()
        m.fit(u, y, fs=fs, validation=(uv, yv))
        wall = time.perf_counter() - t0
        h = m.history_
        flops, k, n = count(m, u, fs) if count is nfir_flops else count(m)
        bound = product_seconds(flops, k, n, dtype)
        peak = flops / peak_rate(dtype)
        ep, val = steady(h, "step_seconds"), steady(h, "validation_seconds")
        rows.append({"name": name, "epoch": ep, "validation": val, "gflop": flops / 1e9,
                     "gflops": flops / 1e9 / ep, "bound": bound, "ratio": ep / bound,
                     "peak": peak, "peak_ratio": ep / peak,
                     "dtype": np.dtype(dtype).name, "shape": f"rows x {k} @ {k} x {n}",
                     "compile": h["step_seconds"][1] - ep, "wall": wall})
        r = rows[-1]
        print(f"{name:36s} epoch {ep:6.3f} s + validation {val:5.3f} s | {r['gflop']:7.2f} "
              f"GFLOP, {r['gflops']:6.1f} GFLOP/s | bound {bound:6.3f} s ({r['dtype']}, "
              f"{r['shape']}) | ratio {r['ratio']:5.1f}x | at the square product's rate "
              f"{peak:6.3f} s, ratio {r['peak_ratio']:5.1f}x", flush=True)
    return rows


def _fit_nss_member(seed: int, u, y, uv, yv, fs, epochs):
    from sloshrom.rom import NSS
    from sloshrom.rom.registry import CLASSES

    return NSS(max_epochs=epochs, seed=seed, **CLASSES["nss"].recipe).fit(
        u, y, fs=fs, validation=(uv, yv))


def ensemble_scaling(data, epochs: int) -> dict:
    """Throughput of 2 NSS members against one: pinned workers, unpinned, vmap."""
    import sloshrom.rom.parallel as par
    from sloshrom.rom.parallel import run_tasks

    u, y, uv, yv, fs = data
    out = {}
    one = _fit_nss_member(0, u, y, uv, yv, fs, epochs)
    t1 = steady(one.history_, "step_seconds")
    out["one"] = t1
    print(f"one NSS member alone: {t1:.3f} s per epoch of steps", flush=True)
    pin = par.pin_workers
    for label, pinned in (("2 members, 2 pinned workers", True),
                          ("2 members, 2 unpinned workers", False)):
        if not pinned:
            par.pin_workers = lambda client, n: None
        try:
            t0 = time.perf_counter()
            ms = run_tasks(_fit_nss_member, [0, 1], shared=(u, y, uv, yv),
                           args=(fs, epochs), n_workers=2)
            wall = time.perf_counter() - t0
        finally:
            par.pin_workers = pin
        per = max(steady(m.history_, "step_seconds") for m in ms)
        out[label] = 2 * t1 / per
        print(f"{label}: {per:.3f} s per epoch of steps each -> throughput x{2 * t1 / per:.2f} "
              f"one member's (wall {wall:.1f} s with the cluster's start)", flush=True)
    out["vmap"] = vmap_scaling(data, t1)
    return out


def vmap_scaling(data, t1: float) -> float:
    """Two NSS members as one vmap-ed program in this process."""
    import optax

    from sloshrom.rom import NSS
    from sloshrom.rom.network import MinMaxScaler
    from sloshrom.rom.nss.training import NSS_SHOOTING, shooting_problem
    from sloshrom.rom.registry import CLASSES
    from sloshrom.signals import power_band

    u, y, uv, yv, fs = data
    m = NSS(**CLASSES["nss"].recipe)
    with jax.enable_x64(True):
        band = tuple(power_band(u, fs, 0.001, 0.999))
        options = dataclasses.replace(NSS_SHOOTING, frequency_band=band,
                                      passivity=m.passivity, cycle_energy=m.cycle_energy)
        probs = [shooting_problem(m._check_hyperparameters(), u, y, fs, MinMaxScaler.fit(u, y),
                                  None, options, seed=s) for s in (0, 1)]
        opt = probs[0].optimizer

        def step(p, s, *xs):
            (_, mse), g = jax.value_and_grad(probs[0].loss, has_aux=True)(p, *xs)
            upd, s = opt.update(g, s, p)
            return optax.apply_updates(p, upd), s, mse

        vstep = jax.vmap(step)

        @jax.jit
        def epoch(P, S, draws):
            def body(c, xs):
                p, s, mse = vstep(*c, *xs)
                return (p, s), mse

            (P, S), mse = jax.lax.scan(body, (P, S), draws)
            return P, S, mse.mean()

        P = jax.tree.map(lambda *a: jnp.stack(a), *[p.params0 for p in probs])
        S = jax.vmap(opt.init)(P)
        rngs = [np.random.default_rng(s) for s in (0, 1)]
        ds = [p.draw(r) for p, r in zip(probs, rngs, strict=True)]
        draws = tuple(jnp.stack([jnp.asarray(a) for a in col], axis=1) for col in zip(*ds,
                                                                                    strict=True))
        jax.block_until_ready(epoch(P, S, draws))
        best = math.inf
        for _ in range(3):
            t0 = time.perf_counter()
            jax.block_until_ready(epoch(P, S, draws))
            best = min(best, time.perf_counter() - t0)
    print(f"2 members vmap-ed in one process: {best:.3f} s per epoch of steps -> throughput "
          f"x{2 * t1 / best:.2f} one member's", flush=True)
    return 2 * t1 / best


def map_times(run: Path) -> dict:
    from sloshrom import Tank
    from sloshrom.energy import default_grid, phi_d_map
    from sloshrom.rig.virtual import VirtualRig
    from sloshrom.rom import load_model

    ob, ab = default_grid(30)
    out = {}
    for name in ("nss", "nfir"):
        path = run / "models" / f"{name}.npz"
        if not path.is_file():
            continue
        m = load_model(path)
        t0 = time.perf_counter()
        phi_d_map(m, ob, ab, tank=Tank())
        out[name] = time.perf_counter() - t0
    t0 = time.perf_counter()
    phi_d_map(VirtualRig(seed=0), ob, ab)
    out["rig"] = time.perf_counter() - t0
    print("Phi_d map 30 x 30 from a cold start: " + ", ".join(
        f"{k} {v:.2f} s" for k, v in out.items()) + " (target: the ROM's <= 3 s)", flush=True)
    return out


def sweep_time(data) -> float:
    from sloshrom.pipeline.rom import sweep_options, sweep_points
    from sloshrom.pipeline.settings import load
    from sloshrom.rom.sweep import run_sweep

    u, y, uv, yv, fs = data
    cfg = load().rom
    pts = sweep_points(cfg)
    with tempfile.TemporaryDirectory() as tmp:
        t0 = time.perf_counter()
        # as the sweep stage: every point trains with [rom.nfir]'s table
        run_sweep((u, y), (uv, yv), fs, tmp, pts, n_workers=2, options=sweep_options(cfg))
        t = time.perf_counter() - t0
    print(f"sweep of {len(pts)} networks on 2 workers: {t:.0f} s (target <= 300 s)", flush=True)
    return t


def lm_comparison(data, max_epochs: int, cap: float) -> None:
    """Adam against the paper's Levenberg-Marquardt on the NFIR(70, 35) (plain MSE)."""
    from sloshrom.rom import NFIR

    u, y, uv, yv, fs = data
    kw = {"delays": 70, "neurons": 35, "max_epochs": max_epochs, "seed": 0}
    res = {}
    for trainer in ("adam", "fast"):
        t0 = time.perf_counter()
        m = NFIR(trainer=trainer, **kw).fit(u, y, fs=fs, validation=(uv, yv))
        h = m.history_
        res[trainer] = (time.perf_counter() - t0, h["val_mse"][h["best_epoch"]])
        print(f"{trainer:5s}: {res[trainer][0]:7.1f} s, {len(h['train_mse']) - 1} epochs "
              f"({h['stop_reason']}), best validation MSE {res[trainer][1]:.4g} N^2", flush=True)
    t0 = time.perf_counter()
    v_fast = res["fast"][1]
    lm = NFIR(trainer="lm", **kw).fit(
        u, y, fs=fs, validation=(uv, yv),
        callback=lambda e, info: info["val_mse"] <= v_fast or info["seconds"] > cap)
    t_lm = time.perf_counter() - t0
    v_lm = min(lm.history_["val_mse"])
    tag = "reached" if v_lm <= v_fast else "did NOT reach within the cap (a lower bound)"
    print(f"lm   : {t_lm:7.1f} s, {tag} the fast LM's validation MSE; lm/fast "
          f"{t_lm / res['fast'][0]:.1f}x, lm/adam {t_lm / res['adam'][0]:.1f}x", flush=True)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--run", type=Path, default=Path("results"),
                    help="a finished `make reproduce` run: its records and models")
    ap.add_argument("--epochs", type=int, default=4, help="epochs of each timed fit (>= 3)")
    ap.add_argument("--sweep", action="store_true", help="also time the 27-network sweep")
    ap.add_argument("--lm", action="store_true", help="also compare Adam with the paper's LM")
    ap.add_argument("--lm-cap", type=float, default=300.0)
    ap.add_argument("--lm-epochs", type=int, default=1000)
    ap.add_argument("--skip-ensemble", action="store_true")
    args = ap.parse_args()
    epochs = max(3, args.epochs)
    data, source = records(args.run)
    print(f"records: {source}; {data[0].size} + {data[2].size} samples at {data[4]:g} Hz; "
          f"{os.cpu_count()} cores", flush=True)
    rows = epoch_table(data, epochs)
    passive = next(r for r in rows if r["name"].startswith("NFIR") and "passive" in r["name"])
    verdict = "met" if passive["ratio"] <= 2.0 else "NOT met"
    print(f"target passive NFIR epoch <= 2x its bound: {passive['ratio']:.1f}x, {verdict}")
    pairs = [("NSS", "recipe"), ("NFIR", "passive recipe")]
    for cls, rec in pairs:
        r1 = next(r for r in rows if r["name"].startswith(cls) and rec in r["name"])
        r0 = next(r for r in rows if r["name"].startswith(cls) and "plain" in r["name"])
        print(f"{cls}: the loss terms cost {r1['epoch'] / r0['epoch'] - 1:+.0%} of the plain "
              f"epoch; validation {r1['validation'] / r1['epoch']:.0%} of an epoch")
    if not args.skip_ensemble:
        sc = ensemble_scaling(data, epochs)
        best = sc["2 members, 2 pinned workers"]
        print(f"target ensemble of 2 on 2 cores >= 1.7x one member: x{best:.2f}, "
              f"{'met' if best >= 1.7 else 'NOT met'}")
    map_times(args.run)
    if args.sweep:
        sweep_time(data)
    if args.lm:
        lm_comparison(data, args.lm_epochs, args.lm_cap)


if __name__ == "__main__":
    main()
