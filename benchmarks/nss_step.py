"""The state-space ROM's training step against the hardware: the trainer's (XLA's small products)
against the compiled loops of ``benchmarks/nss_kernel.py`` (a lever measured and not adopted),
in the same run, on one core.

For the default recipe (NSS(8, 64), strictly proper, batch 128 + 24 passivity probes, horizon
200, the passive loss terms, the Galilean augmentation) on the default records
(``results/data`` of ``make reproduce``, else the rig's VFA tests), prints per Adam step:

- that the compiled loops' loss and gradient are the trainer's (relative difference, float32);
- the time of an epoch of ``--steps`` Adam steps (the median of ``--repeats`` epochs after the
  first, which compiles), with the simulation run by XLA (``jax.lax.scan`` over the model's
  products: the trainer's) and by the compiled loops;
- the step's FLOPs counted from the architecture (as ``benchmarks/train_speed.py``: forward and
  backward products, 3x the forward; tanh not counted) and their rate;
- the float32 peak of one core (a 2048^2 product, timed in the same run) and the step's
  distance from it (the target: within 4x).

Run on one core, as a pinned ensemble worker trains: ``taskset -c 0 .venv/bin/python
benchmarks/nss_step.py`` (about 1 min).
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import sys
import time
from pathlib import Path

import jax
import jax.numpy as jnp
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import nss_kernel  # noqa: E402
from sloshrom.rom import NSS  # noqa: E402
from sloshrom.rom.engine import epoch_program  # noqa: E402
from sloshrom.rom.network import MinMaxScaler  # noqa: E402
from sloshrom.rom.nss import network as ss  # noqa: E402
from sloshrom.rom.nss import training as sst  # noqa: E402
from sloshrom.signals import power_band  # noqa: E402
from train_speed import nss_flops, peak_rate, records, step_report  # noqa: E402


def loops_simulate(p, x0, u_s, r_u, r_y, unroll=1):
    """``statespace.ss_simulate``'s signature (the outputs only), run by the compiled loops."""
    f0, h0 = ss._rest_terms(p, r_u, p["A"].shape[1])
    y = nss_kernel.simulate([p[k] for k in nss_kernel.WEIGHT_NAMES], f0, r_y - h0, x0, u_s.T)
    return None, y.T


def problem(sim, spec, u, y, fs, scaler, opts):
    """The trainer's multiple-shooting problem, its simulation run by ``sim``."""
    xla = ss.ss_simulate
    ss.ss_simulate = sim  # read when the loss is traced: swapped back after the first epoch
    try:
        pr = sst.shooting_problem(spec, u, y, fs, scaler, None, opts, 0)
        ep = epoch_program(pr.loss, pr.optimizer)
        draws = tuple(jnp.asarray(a) for a in pr.draw(np.random.default_rng(99)))
        jax.block_until_ready(ep(pr.params0, pr.optimizer.init(pr.params0), draws,
                                 pr.data)[2])
        (value, _), grad = jax.value_and_grad(pr.loss, has_aux=True)(
            pr.params0, pr.data, *(a[0] for a in draws))
    finally:
        ss.ss_simulate = xla
    return pr, ep, float(value), grad


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--run", type=Path, default=Path("results"))
    ap.add_argument("--steps", type=int, default=50, help="Adam steps per timed epoch")
    ap.add_argument("--repeats", type=int, default=4, help="timed epochs of each (>= 2)")
    a = ap.parse_args()
    (u, y, _, _, fs), source = records(a.run)
    # the recipe of `reproduce` ([rom.nss] and the registry's passive recipe)
    est = NSS(feedthrough="no", velocity_offset=0.5, passivity=1.0, cycle_energy=0.1)
    # the size of a long record (the defaults; the estimator's sized arguments are None)
    h = est.effective_params()
    spec = ss.StateSpaceSpec(h["n_states"], h["neurons"], h["window"], proper=True)
    band = power_band(u, fs, 0.001, 0.999)  # the probes' band, as NSS.fit takes it
    opts = dataclasses.replace(sst.NSS_SHOOTING,
                               horizon=h["horizon"], batch=est.batch, steps_per_epoch=a.steps,
                           passivity=est.passivity, cycle_energy=est.cycle_energy,
                           amplitude_weighting=est.amplitude_weighting,
                           frequency_band=(band[0], band[1]), velocity_offset=0.5)
    scaler = MinMaxScaler.fit(u, y)
    print(f"records: {source}; cores usable: {len(os.sched_getaffinity(0))}", flush=True)
    progs, checks = {}, {}
    with jax.enable_x64(True):
        for name, sim in (("XLA (trainer)", ss.ss_simulate), ("compiled loops", loops_simulate)):
            pr, ep, value, grad = problem(sim, spec, u, y, fs, scaler, opts)
            progs[name], checks[name] = (pr, ep), (value, grad)
        (v0, g0), (v1, g1) = checks.values()
        worst = max(float(np.max(np.abs(g1[k] - g0[k])) / np.max(np.abs(g0[k]))) for k in g0)
        print(f"the loops' loss / the trainer's - 1: {v1 / v0 - 1:.1e}; largest relative "
              f"difference of a parameter's gradient: {worst:.1e} (float32)", flush=True)
        times: dict[str, list[float]] = {k: [] for k in progs}
        for rep in range(a.repeats):
            for name, (pr, ep) in progs.items():  # interleaved: the machine's drift hits both
                d = pr.draw(np.random.default_rng(rep))
                t0 = time.perf_counter()
                jax.block_until_ready(ep(pr.params0, pr.optimizer.init(pr.params0), d,
                                         pr.data)[2])
                times[name].append((time.perf_counter() - t0) / a.steps)
    flops = nss_flops(est)[0] / est.steps_per_epoch
    peak = peak_rate(np.float32)
    print(f"one Adam step: {flops / 1e9:.3f} GFLOP; float32 peak here {peak / 1e9:.0f} GFLOP/s "
          f"(a 2048^2 product on the cores this process may use)")
    step_report(times, flops, peak, "XLA (trainer)", "compiled loops")


if __name__ == "__main__":
    main()
