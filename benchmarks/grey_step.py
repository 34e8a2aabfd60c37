"""The grey box's training step against the hardware: the pure-JAX step (``lax.scan`` over the
network's products, the reference) against the C kernel's (``sloshrom.rom.grey.kernel``: the
shooting window and its reverse pass as XLA FFI calls), in the same run, on one core.

For the default recipe (GreyBox(8 states, 32 neurons), window 50, horizon 200, batch 128 + the
passivity probes, the passive loss terms) on the default records (``results/data`` of
``make reproduce``, else the rig's VFA tests) and a physics fixed at a plausible column (the
step does not depend on it), prints per Adam step, for float64 (the grey box's default) and
float32:

- the kernel's loss and gradient against the pure-JAX step's (relative difference);
- the time of an epoch of ``--steps`` Adam steps (the median of ``--repeats`` epochs after the
  first, which compiles), both paths interleaved;
- the step's FLOPs counted from the architecture (forward products of the state map, the output
  map and the encoder, times 3 for forward and backward; tanh not counted) and their rate;
- the float32 peak of one core (a 2048^2 product, timed in the same run) and each step's
  distance from it (the issue's target: within 2.5x);
- the same step with the shooting window replaced by a stand-in of the same inputs and outputs
  that does almost nothing (``--no-outside`` skips it): what the step costs outside the
  kernel (the encoder, the windows' gathers, the loss terms, Adam), and so the kernel's own
  time and its distance from the peak.

Run on one core, as a pinned ensemble worker trains: ``taskset -c 0 .venv/bin/python
benchmarks/grey_step.py`` (about 2 min).
"""

from __future__ import annotations

import argparse
import contextlib
import os
import sys
import time
from collections.abc import Iterator, Mapping
from pathlib import Path

import jax
import jax.numpy as jnp
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from sloshrom.rom import GreyBox  # noqa: E402
from sloshrom.rom.engine import epoch_program  # noqa: E402
from sloshrom.rom.grey import training as gt  # noqa: E402
from sloshrom.rom.grey.kernel import kernel_available  # noqa: E402
from sloshrom.rom.grey.network import N_FEATURES, GreySpec  # noqa: E402
from sloshrom.rom.grey.physics import physical_parameters  # noqa: E402
from sloshrom.rom.network import MinMaxScaler  # noqa: E402
from sloshrom.rom.shooting import ShootingOptions  # noqa: E402
from sloshrom.signals import power_band  # noqa: E402
from train_speed import peak_rate, records, step_report  # noqa: E402


def step_flops(spec: GreySpec, batch: int, probes: int, horizon: int) -> float:
    """FLOPs of one Adam step: 2 per multiply-add of the forward products, x3 for the reverse
    pass; the encoder runs on the batch, the window on the batch and the probes."""
    nx, n = spec.n_states, spec.neurons
    nz, no = nx + 1 + N_FEATURES, nx + N_FEATURES
    per_sample = nz * (nx + n) + n * nx + no * (n + 1) + n
    encoder = 2 * spec.window * n + n * nx
    return 3.0 * 2.0 * ((batch + probes) * horizon * per_sample + batch * encoder)


#: The step with the stand-in window (``--no-outside`` skips it).
_OUTSIDE = "outside kernel"


def _stand_in(p: Mapping[str, jax.Array], x0: jax.Array, seq: jax.Array, r_u: float | jax.Array,
              r_y: float | jax.Array) -> jax.Array:
    """The window's inputs to outputs (B, T) at almost no cost, with a gradient for every
    weight and the states: what the step costs without the kernel."""
    del r_u  # (the kernel's input offset: nothing to offset here)
    touch = sum(jnp.ravel(p[k])[0] for k in ("A", "W1", "b1", "W2", "C", "V1", "d1", "V2"))
    nx = x0.shape[1]
    return (seq[..., 0] * p["C"][0] + (x0 @ p["A"][:nx]).sum(-1)[:, None] + touch * 0.0
            + jnp.asarray(r_y, seq.dtype))


@contextlib.contextmanager
def _window_replaced() -> Iterator[None]:
    """``grey_window`` as the shooting problem reads it, replaced by :func:`_stand_in`."""
    real = gt.grey_window
    gt.grey_window = _stand_in
    try:
        yield
    finally:
        gt.grey_window = real


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--run", type=Path, default=Path("results"))
    ap.add_argument("--steps", type=int, default=40, help="Adam steps per timed epoch")
    ap.add_argument("--repeats", type=int, default=5, help="timed epochs of each (>= 2)")
    ap.add_argument("--no-outside", action="store_true",
                    help="skip the step with a stand-in window (the cost outside the kernel)")
    a = ap.parse_args()
    if not kernel_available():
        sys.exit("the grey box's C kernel is not built (or SLOSHROM_GREY_KERNEL=jax)")
    (u, y, _, _, fs), source = records(a.run)
    est = GreyBox(velocity_offset=0.5)
    h = est.effective_params()
    spec = GreySpec(h["n_states"], h["neurons"], h["window"], h["n_balls"], h["n_substeps"],
                    h["n_past"])
    band = power_band(u, fs, 0.001, 0.999)
    opts = ShootingOptions(horizon=h["horizon"], batch=est.batch, max_epochs=1,
                           steps_per_epoch=a.steps, learning_rate=est.learning_rate,
                           passivity=1.0, cycle_energy=0.1, frequency_band=(band[0], band[1]),
                           velocity_offset=0.5, weight_decay=0.0)
    scaler = MinMaxScaler.fit(u, y)
    physics = physical_parameters(0.6, 0.2, 130.0, 1.0, 2.5, 0.009, 8.0,
                                  liquid_mass=0.124, ullage=0.0136)
    taps = np.zeros(spec.n_taps)
    taps[-spec.n_substeps:] = 1.0 / spec.n_substeps
    params0 = gt.init_params(spec, 0, physics, taps)
    print(f"records: {source}; cores usable: {len(os.sched_getaffinity(0))}", flush=True)
    flops = step_flops(spec, est.batch, opts.probes_per_step, opts.horizon)
    peak = peak_rate(np.float32)
    print(f"one Adam step: {flops / 1e9:.3f} GFLOP; float32 peak here {peak / 1e9:.0f} GFLOP/s "
          f"(a 2048^2 product); the step at the peak: {flops / peak * 1e3:.2f} ms", flush=True)
    with jax.enable_x64(True):
        for dtype in (jnp.float64, jnp.float32):
            progs, checks = {}, {}
            paths = [("JAX (lax.scan)", False), ("C kernel (FFI)", True)]
            if not a.no_outside:
                paths.append((_OUTSIDE, True))
            for name, kernel in paths:
                # the stand-in is read when the epoch is traced: its first call below
                with _window_replaced() if name == _OUTSIDE else contextlib.nullcontext():
                    pr = gt.shooting_problem(spec, u, y, fs, scaler, params0, None, opts,
                                             dtype=dtype, kernel=kernel)
                    ep = epoch_program(pr.loss, pr.optimizer)
                    draws = tuple(jnp.asarray(x) for x in pr.draw(np.random.default_rng(99)))
                    jax.block_until_ready(ep(pr.params0, pr.optimizer.init(pr.params0),
                                             draws, pr.data)[2])
                    # the gradient away from the start (whose output layer is zero), where
                    # the runs stay bounded: with 0.05 the residual state map's windows blew
                    # up (a loss of 1e15, where float32's saturated tanh leaves a gradient
                    # of V1 to its round-off in both paths)
                    p1 = jax.tree_util.tree_map(
                        lambda v: v + 0.01 * jnp.asarray(
                            np.random.default_rng(v.size).standard_normal(v.shape), v.dtype),
                        pr.params0)
                    (value, _), grad = jax.jit(jax.value_and_grad(pr.loss, has_aux=True))(
                        p1, pr.data, *(x[0] for x in draws))
                progs[name], checks[name] = (pr, ep), (float(value), grad)
            (v0, g0), (v1, g1) = checks["JAX (lax.scan)"], checks["C kernel (FFI)"]
            worst = max(float(jnp.max(jnp.abs(g1[k] - g0[k])) / jnp.max(jnp.abs(g0[k])))
                        for k in g0)
            print(f"{jnp.dtype(dtype).name}: at a loss of {v0:.4g}, the kernel's loss / JAX's - 1: "
                  f"{v1 / v0 - 1:.1e}; largest relative difference of a parameter's gradient: "
                  f"{worst:.1e}", flush=True)
            times: dict[str, list[float]] = {k: [] for k in progs}
            for rep in range(a.repeats):
                for name, (pr, ep) in progs.items():  # interleaved: drift hits both
                    d = tuple(jnp.asarray(x) for x in pr.draw(np.random.default_rng(rep)))
                    c0 = time.process_time()
                    t0 = time.perf_counter()
                    jax.block_until_ready(ep(pr.params0, pr.optimizer.init(pr.params0), d,
                                             pr.data)[2])
                    wall = time.perf_counter() - t0
                    times[name].append(min(wall, time.process_time() - c0) / a.steps)
            outside = times.pop(_OUTSIDE, None)
            step_report(times, flops, peak, "JAX (lax.scan)", "C kernel (FFI)")
            if outside is not None:
                # per interleaved run: the kernel's step less the stand-in's, timed after it
                own = np.asarray(times["C kernel (FFI)"]) - np.asarray(outside)
                t = float(np.median(own))
                print(f"  outside the kernel (the step with a stand-in window): "
                      f"{np.median(outside) * 1e3:.2f} ms/step "
                      f"[{', '.join(f'{x * 1e3:.2f}' for x in outside)}]; the kernel alone "
                      f"{t * 1e3:.2f} ms/step, {t / (flops / peak):.1f}x the float32 peak's "
                      "time", flush=True)


if __name__ == "__main__":
    main()
