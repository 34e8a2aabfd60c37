"""The time-delay networks' inner loops against their plain-JAX baselines, in the same run.

- **NFIR Adam epoch** (200 steps of 4,096 rows, float32, plain MSE): the baseline gathers the
  regressors element by element (``up[row_index(rows, delays)]``) and differentiates
  ``rbf_apply`` (JAX's softmax); ours reads them as windows (``regressors``) and computes the
  layer for reverse mode (``rbf_rows``). Both epochs interleaved, the median of ``--repeats``;
  the gradients' relative difference at the same parameters.
- **NFIR cycle-energy term** (the passive recipe's: 32 cycles a step, 200 steps, float32):
  each cycle padded to the record's longest (the baseline) against the cycles' samples packed
  one after the other (``sloshrom.rom.losses.pack_cycles``); the term and its gradient, the
  draws of one epoch packed on the host included; their relative differences.
- **NOE normal equations** (Levenberg-Marquardt, float64, the whole training record): every
  chunk simulated (the baseline) against the chunks fed the trial step's free run, as
  ``noe_problem`` does at an accepted step; both must give the same bits.

On the default records (``results/data`` of ``make reproduce``, else the rig's VFA tests).
Run on one core: ``taskset -c 0 .venv/bin/python benchmarks/tdnn_step.py`` (about 2 min).
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from pathlib import Path

import jax
import jax.numpy as jnp
import numpy as np
import optax

sys.path.insert(0, str(Path(__file__).resolve().parent))
from sloshrom.rom.engine import epoch_program  # noqa: E402
from sloshrom.rom.losses import cycle_slots, energy_cycles, pack_cycles  # noqa: E402
from sloshrom.rom.tdnn import training  # noqa: E402
from sloshrom.rom.tdnn.network import (  # noqa: E402
    n_params,
    rbf_apply,
    row_index,
    unpack,
)
from sloshrom.signals import power_band  # noqa: E402
from train_speed import records  # noqa: E402


def _timed(f, *args) -> float:
    t0 = time.perf_counter()
    jax.block_until_ready(f(*args))
    return time.perf_counter() - t0


def _nfir_data(u: np.ndarray, y: np.ndarray, delays: int, neurons: int,
               rng: np.random.Generator) -> tuple:
    """The delays, the rest-padded scaled input, the scaled output and random parameters of
    an NFIR(delays, neurons), float32."""
    scale = max(float(np.max(np.abs(u))), 1e-12)
    up = jnp.asarray(np.concatenate([np.zeros(delays), u / scale]), jnp.float32)
    ys = jnp.asarray(y / max(float(np.max(np.abs(y))), 1e-12), jnp.float32)
    theta = jnp.asarray(0.1 * rng.standard_normal(n_params(delays, neurons)), jnp.float32)
    return tuple(range(1, delays + 1)), up, ys, theta


def nfir_epochs(u: np.ndarray, y: np.ndarray, delays: int, neurons: int,
                repeats: int) -> None:
    rng = np.random.default_rng(0)
    d, up, ys, theta = _nfir_data(u, y, delays, neurons, rng)
    rows = jnp.asarray(rng.integers(0, u.size, (200, 4096)))

    def baseline(th, _, r):
        e = rbf_apply(unpack(th, delays, neurons), up[row_index(r, d)], "matlab") - ys[r]
        return jnp.mean(e**2), jnp.mean(e**2)

    def ours(th, _, r):
        e = training._loss_rows(th, up, r, d, neurons, "matlab") - ys[r]
        return jnp.mean(e**2), jnp.mean(e**2)

    opt = optax.adam(1e-3)
    epochs = {"baseline": epoch_program(baseline, opt), "ours": epoch_program(ours, opt)}
    state = opt.init(theta)
    times: dict[str, list[float]] = {k: [] for k in epochs}
    for f in epochs.values():
        _timed(f, theta, state, (rows,), ())  # compiles
    for _ in range(repeats):
        for k, f in epochs.items():
            times[k].append(_timed(f, theta, state, (rows,), ()))
    g0, g1 = (jax.jit(jax.grad(lambda t, f=f: f(t, (), rows[0])[0]))(theta)
              for f in (baseline, ours))
    rel = float(jnp.max(jnp.abs(g1 - g0)) / jnp.max(jnp.abs(g0)))
    t0, t1 = statistics.median(times["baseline"]), statistics.median(times["ours"])
    print(f"NFIR({delays}, {neurons}) Adam epoch (200 x 4096 rows, float32): baseline "
          f"{t0:.3f} s, ours {t1:.3f} s, ratio {t0 / t1:.2f}x; gradient relative difference "
          f"{rel:.1e}", flush=True)


def cycle_energy_epochs(u: np.ndarray, y: np.ndarray, fs: float, delays: int, neurons: int,
                        repeats: int) -> None:
    rng = np.random.default_rng(1)
    d, up, ys, theta = _nfir_data(u, y, delays, neurons, rng)
    cyc = energy_cycles(u, fs, power_band(u, fs))
    rows, weight = cyc.rows, jnp.asarray(cyc.weight, jnp.float32)
    slots = cycle_slots(cyc, 32)

    def baseline(th, _, idx):
        r = rows[idx]
        e = training._loss_rows(th, up, r.reshape(-1), d, neurons, "matlab").reshape(r.shape)
        v = jnp.mean(jnp.sum((e - ys[r]) * weight[idx], axis=-1) ** 2)
        return v, v

    def ours(th, _, r, w, seg):
        v = training.cycle_energy_error(th, up, ys, r, w, seg, 32, d, neurons, "matlab")
        return v, v

    opt = optax.adam(1e-3)
    state = opt.init(theta)
    programs = {"baseline": epoch_program(baseline, opt), "ours": epoch_program(ours, opt)}
    idx = rng.integers(0, cyc.n, (200, 32))

    def draws(name):
        if name == "baseline":
            return (jnp.asarray(idx),)
        p = pack_cycles(cyc, idx, slots, np.float32)
        return tuple(jnp.asarray(a) for a in (p.rows, p.weight, p.segment))

    def run(name):
        t0 = time.perf_counter()
        jax.block_until_ready(programs[name](theta, state, draws(name), ()))
        return time.perf_counter() - t0

    for k in programs:
        run(k)  # compiles
    times: dict[str, list[float]] = {k: [] for k in programs}
    for _ in range(repeats):
        for k in programs:
            times[k].append(run(k))
    p0 = pack_cycles(cyc, idx[:1], slots, np.float32)
    v0, g0 = jax.jit(jax.value_and_grad(lambda t: baseline(t, (), idx[0])[0]))(theta)
    v1, g1 = jax.jit(jax.value_and_grad(
        lambda t: ours(t, (), p0.rows[0], p0.weight[0], p0.segment[0])[0]))(theta)
    rel_v = abs(float(v1) / float(v0) - 1.0)
    rel_g = float(jnp.max(jnp.abs(g1 - g0)) / jnp.max(jnp.abs(g0)))
    t0, t1 = statistics.median(times["baseline"]), statistics.median(times["ours"])
    print(f"NFIR({delays}, {neurons}) cycle-energy term, an epoch of 200 steps x 32 of "
          f"{cyc.n} cycles (float32): padded to {rows.shape[1]} samples each {t0:.3f} s, "
          f"packed in {slots} places {t1:.3f} s, ratio {t0 / t1:.2f}x; value relative "
          f"difference {rel_v:.1e}, gradient {rel_g:.1e}", flush=True)


def noe_normal_equations(u: np.ndarray, y: np.ndarray, neurons: int, repeats: int) -> None:
    with jax.enable_x64(True):
        us = 2.0 * (u - u.min()) / (u.max() - u.min()) - 1.0
        ysc = 2.0 * (y - y.min()) / (y.max() - y.min()) - 1.0
        delays, m = (1, 2), 2
        theta = 0.3 * np.random.default_rng(neurons).standard_normal(n_params(4, neurons))
        prob = training.noe_problem(us, ysc, delays, m, neurons, "matlab", 0.0, 0.0, 1e6)
        other = theta + 1e-3

        def simulated():
            prob.sse(other)  # the last run is another step's: every chunk simulates
            t0 = time.perf_counter()
            out = prob.normal_eq(theta)
            return time.perf_counter() - t0, out

        def from_run():
            prob.sse(theta)
            t0 = time.perf_counter()
            out = prob.normal_eq(theta)
            return time.perf_counter() - t0, out

        simulated(), from_run()  # compile both paths
        times: dict[str, list[float]] = {"simulated": [], "from the run": []}
        outs = {}
        for _ in range(repeats):
            for k, f in (("simulated", simulated), ("from the run", from_run)):
                t, outs[k] = f()
                times[k].append(t)
        same = all(np.array_equal(a, b) for a, b in zip(outs["simulated"],
                                                         outs["from the run"], strict=True))
        t0, t1 = (statistics.median(v) for v in times.values())
        print(f"NOE(2, {neurons}, 2) normal equations on {u.size} samples (float64): every chunk "
              f"simulated {t0:.3f} s, from the trial's run {t1:.3f} s, ratio {t0 / t1:.2f}x; "
              f"the same bits: {same}", flush=True)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--run", type=Path, default=Path("results"))
    ap.add_argument("--repeats", type=int, default=5)
    a = ap.parse_args()
    (u, y, _, _, fs), source = records(a.run)
    print(f"records: {source}", flush=True)
    nfir_epochs(np.asarray(u), np.asarray(y), 70, 40, a.repeats)
    cycle_energy_epochs(np.asarray(u), np.asarray(y), float(fs), 70, 35, a.repeats)
    noe_normal_equations(np.asarray(u), np.asarray(y), 15, a.repeats)


if __name__ == "__main__":
    main()
