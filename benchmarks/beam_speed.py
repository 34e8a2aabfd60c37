"""Speed of the coupled sloshing-beam simulation with an NFIR(70, 35)-sized ROM.

Target: 10 s of free response in <= 20 ms after compilation; batched random responses
in one ``vmap``. Baseline in the same run: the same discretisation and the same (jitted) network
step driven by a plain Python loop. Run: ``.venv/bin/python benchmarks/beam_speed.py``.
"""

from __future__ import annotations

import time

import jax
import numpy as np

from sloshrom.beam.coupled import CoupledSimulator, upsample_periodic
from sloshrom.beam.structure import ModalModel
from sloshrom.config import G
from sloshrom.signals import random_base_acceleration

FS = 500.0


def make_rom():
    """A real sloshrom NFIR(70, 35) with a couple of LM epochs on a synthetic record."""
    from sloshrom.rom.estimators import NFIR

    t = np.arange(0, 8, 1 / FS)
    u = 0.3 * np.sin(2 * np.pi * (4 + 1.5 * t) * t)
    y = -2.0 * u + 0.5 * np.roll(u, 3) ** 3
    return NFIR(70, 35, max_epochs=2).fit(u, y, fs=FS), "sloshrom.rom.NFIR(70, 35)"


class StandIn:
    """Stand-in with the same shapes: 70-tap delay line, 35 normalized RBF neurons."""

    jax_traceable = True
    dt = 1 / FS

    def __init__(self) -> None:
        rng = np.random.default_rng(0)
        self.w = rng.standard_normal((35, 70)) * 0.1
        self.b = rng.standard_normal(35)
        self.c = rng.standard_normal(35) * 0.1

    def init_state(self):
        return jax.numpy.zeros(70)

    def step(self, state, velocity, acceleration):
        n = self.w @ state + self.b
        a = jax.nn.softmax(-(n**2))
        return jax.numpy.concatenate([velocity[None] * 3.0, state[:-1]]), self.c @ a


class JittedStep:
    """Wrap a model so that a Python loop calls a compiled step (fair baseline)."""

    def __init__(self, model) -> None:
        self.dt = model.dt
        self.init_state = model.init_state
        self._step = jax.jit(model.step)

    def step(self, state, v, a):
        s, f = self._step(state, v, a)
        return s, float(f)


def best(fn, repeat=5):
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return min(times)


def main() -> None:
    try:
        model, label = make_rom()
    except Exception as exc:  # the ROM module may be unavailable: same-shaped stand-in
        model, label = StandIn(), f"stand-in JAX network (70 taps, 35 RBF) [{exc}]"
    modal = ModalModel.from_beam()
    print(f"sloshing model: {label}; modal model: {modal.n_modes} modes; dt = {model.dt} s")

    sim = CoupledSimulator(model, modal, backend="jax")
    n = int(10 / sim.dt)
    a0 = np.zeros(n)
    q0 = modal.static_tip_state(0.0146)
    t0 = time.perf_counter()
    sim.run_raw(a0, q0=q0)
    t_compile = time.perf_counter() - t0
    t_free = best(lambda: sim.run_raw(a0, q0=q0))
    print(f"free response 10 s ({n} steps): first call (compile + run) {t_compile:.2f} s, "
          f"after compilation {1e3 * t_free:.1f} ms (target <= 20 ms)")

    base = CoupledSimulator(JittedStep(model), modal, backend="python")
    base.run_raw(a0[:10], q0=q0)
    t_loop = best(lambda: base.run_raw(a0, q0=q0), repeat=1)
    print(f"baseline (Python loop, jitted network step): {1e3 * t_loop:.0f} ms -> "
          f"lax.scan is {t_loop / t_free:.0f}x faster")

    duration, seeds, levels = 20.0, 34, (0.1, 0.2, 0.4)
    acc = np.stack([random_base_acceleration(FS, duration, np.array(levels) * G, seed=s, fade=1.0)
                    for s in range(seeds)])
    acc = upsample_periodic(acc, int(round(1 / (sim.dt * FS))))
    sim.run_raw(acc[0, 0])  # compile the single-run path at this length
    t_single = best(lambda: sim.run_raw(acc[0, 0]), repeat=3)
    sim.run_raw(acc[:1])  # compile the vmapped path (shape (1, 3, n))
    batch = acc.reshape(-1, acc.shape[-1])
    sim.run_raw(batch)
    t_batch = best(lambda: sim.run_raw(batch), repeat=2)
    nb = batch.shape[0]
    print(f"random responses {duration:g} s: single {1e3 * t_single:.1f} ms; vmapped batch of "
          f"{nb} ({seeds} seeds x {len(levels)} levels) {t_batch:.2f} s = "
          f"{1e3 * t_batch / nb:.1f} ms per response ({t_single * nb / t_batch:.1f}x the "
          "throughput of single runs)")


if __name__ == "__main__":
    main()
