"""The state-space ROM's training step against the hardware: the compiled loops that run it
(``sloshrom.rom.fused``) against XLA's small products, in the same run, on one core.

For the default recipe (NSS(8, 64), strictly proper, batch 128 + 24 passivity probes, horizon
200, the passive loss terms, the Galilean augmentation) on the default records
(``results/data`` of ``make reproduce``, else the rig's VFA tests), prints per Adam step:

- the time of an epoch of ``--steps`` Adam steps (the median of ``--repeats`` epochs after the
  first, which compiles), with the simulation run by the compiled loops (the trainer's) and by
  XLA (``jax.lax.scan`` over the model's products: the trainer before);
- the step's FLOPs counted from the architecture (as ``benchmarks/train_speed.py``: forward and
  backward products, 3x the forward; tanh not counted) and their rate;
- the float32 peak of one core (a 2048^2 product, timed in the same run) and the step's
  distance from it (the target: within 4x).

Run on one core, as a pinned ensemble worker trains: ``taskset -c 0 .venv/bin/python
benchmarks/nss_step.py`` (about 1 min).
"""

from __future__ import annotations

import argparse
import os
import sys
import time
import types
from pathlib import Path

import jax
import jax.numpy as jnp
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from sloshrom.rom import NSS, fused  # noqa: E402
from sloshrom.rom import statespace as ss  # noqa: E402
from sloshrom.rom.engine import epoch_program  # noqa: E402
from sloshrom.rom.network import MinMaxScaler  # noqa: E402
from sloshrom.rom.shooting import ShootingOptions  # noqa: E402
from sloshrom.signals import power_band  # noqa: E402
from train_speed import nss_flops, peak_rate, records  # noqa: E402


def xla_simulate(weights, f0, c0, x0, u):
    """The same simulation as XLA's scan of small products (the trainer's before)."""
    p = dict(zip(fused.WEIGHT_NAMES, weights, strict=True))

    def body(x, uk):
        z = jnp.concatenate([x, uk[:, None]], axis=-1)
        return (x + z @ p["A"] + jnp.tanh(z @ p["W1"] + p["b1"]) @ p["W2"] - f0,
                z @ p["C"] + jnp.tanh(z @ p["V1"] + p["d1"]) @ p["V2"] + c0)

    return jax.lax.scan(body, x0, u.T)[1].T


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--run", type=Path, default=Path("results"))
    ap.add_argument("--steps", type=int, default=50, help="Adam steps per timed epoch")
    ap.add_argument("--repeats", type=int, default=4, help="timed epochs of each (>= 2)")
    a = ap.parse_args()
    (u, y, _, _, fs), source = records(a.run)
    # the recipe of `reproduce` ([rom.nss] and the registry's passive recipe)
    est = NSS(feedthrough="no", velocity_offset=0.5, passivity=1.0, cycle_energy=0.1)
    spec = ss.StateSpaceSpec(est.n_states, est.neurons, est.window, proper=True)
    band = power_band(u, fs, 0.001, 0.999)  # the probes' band, as NSS.fit takes it
    opts = ShootingOptions(horizon=est.horizon, batch=est.batch, steps_per_epoch=a.steps,
                           passivity=est.passivity, cycle_energy=est.cycle_energy,
                           amplitude_weighting=est.amplitude_weighting,
                           frequency_band=(band[0], band[1]), velocity_offset=0.5)
    scaler = MinMaxScaler.fit(u, y)
    print(f"records: {source}; cores usable: {len(os.sched_getaffinity(0))}", flush=True)
    progs = {}
    with jax.enable_x64(True):
        for name, sim in (("compiled loops", fused.simulate), ("XLA", xla_simulate)):
            # the problem traces the module's `fused.simulate` when first run: swap, compile
            ss.fused = types.SimpleNamespace(WEIGHT_NAMES=fused.WEIGHT_NAMES, simulate=sim)
            pr = ss.shooting_problem(spec, u, y, fs, scaler, None, opts, 0)
            ep = epoch_program(pr.loss, pr.optimizer)
            jax.block_until_ready(ep(pr.params0, pr.optimizer.init(pr.params0),
                                     pr.draw(np.random.default_rng(99)))[2])
            progs[name] = (pr, ep)
        ss.fused = fused
        times: dict[str, list[float]] = {k: [] for k in progs}
        for rep in range(a.repeats):
            for name, (pr, ep) in progs.items():  # interleaved: the machine's drift hits both
                d = pr.draw(np.random.default_rng(rep))
                t0 = time.perf_counter()
                jax.block_until_ready(ep(pr.params0, pr.optimizer.init(pr.params0), d)[2])
                times[name].append((time.perf_counter() - t0) / a.steps)
    flops = nss_flops(est)[0] / est.steps_per_epoch
    peak = peak_rate(np.float32)
    print(f"one Adam step: {flops / 1e9:.3f} GFLOP; float32 peak here {peak / 1e9:.0f} GFLOP/s "
          f"(a 2048^2 product on the cores this process may use)")
    med = {k: float(np.median(v)) for k, v in times.items()}
    for name, t in med.items():
        print(f"  {name:15s} {t * 1e3:7.2f} ms/step  {flops / t / 1e9:6.1f} GFLOP/s  "
              f"{t / (flops / peak):5.1f}x the peak's time  "
              f"[{', '.join(f'{x * 1e3:.1f}' for x in times[name])}]")
    ratios = np.asarray(times["XLA"]) / np.asarray(times["compiled loops"])
    print(f"speed-up of the compiled loops (XLA / loops, per interleaved pair): median "
          f"{np.median(ratios):.2f} [{', '.join(f'{r:.2f}' for r in ratios)}]")


if __name__ == "__main__":
    main()
