"""Speed of the coupled sloshing-beam simulation with the ROM in the loop.

Target: 10 s of free response in <= 5 ms after compilation with an NFIR(70, 35)-sized ROM; also
timed with the default ROM class of ``sloshrom reproduce``, an ensemble of two NSS (8 states, 64
neurons; ``--nss FILE`` times a model file instead, e.g. ``results/models/nss.npz``); batched
random responses in one ``vmap``. In the same run, for each ROM: the scan with ``unroll=8``
(:class:`~sloshrom.beam.simulation.coupled.CoupledSimulator`'s option for many runs), the default
``unroll=1`` (one step per loop trip, as before the option; it compiles fastest) and the
baseline, the same discretisation and the same (jitted) ROM step driven by a plain Python loop;
first calls (compile + run), then the best of several runs, with the ratios. Run:
``.venv/bin/python benchmarks/beam_speed.py [--nss FILE]``.
"""

from __future__ import annotations

import argparse
import time

import jax
import numpy as np

from sloshrom.beam.simulation.coupled import CoupledSimulator, upsample_periodic
from sloshrom.beam.simulation.structure import ModalModel
from sloshrom.config import G
from sloshrom.signals import random_base_acceleration

FS = 500.0
#: The target: 10 s of coupled free response after compilation, s.
TARGET_S = 5e-3


def make_rom():
    """A real sloshrom NFIR(70, 35) with a couple of LM epochs on a synthetic record."""
    from sloshrom.rom.tdnn.estimators import NFIR

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


def make_nss(path: str | None):
    """The default ROM class of ``sloshrom reproduce``: a model file, or an ensemble of two NSS
    of the default size (8 states, 64 neurons) after a few Adam steps on a synthetic record."""
    from sloshrom.rom import NSS, load_model
    from sloshrom.rom.ensemble import Ensemble

    if path:
        return load_model(path), f"{path}"
    t = np.arange(0, 8, 1 / FS)
    u = 0.3 * np.sin(2 * np.pi * (4 + 1.5 * t) * t)
    y = -2.0 * u + 0.5 * np.roll(u, 3) ** 3
    model = Ensemble(NSS(max_epochs=1, steps_per_epoch=2), n_members=2).fit(
        u, y, fs=FS, validation=(u, y), scheduler="sequential")
    return model, "ensemble of 2 x sloshrom.rom.NSS(8 states, 64 neurons)"


def free_response_times(model, modal) -> dict[str, float]:
    """Seconds for 10 s of coupled free response: per unroll (8, 1) the first call
    (``compile_u``) and the best of 7 after it (``scan_u``); ``python``, the Python-loop
    baseline (best of 2); ``identical``: the two scans give the same arrays, bit for bit."""
    out: dict[str, float] = {}
    res = {}
    n = int(round(10 / model.dt))
    a0 = np.zeros(n)
    q0 = modal.static_tip_state(0.0146)
    for unroll in (8, 1):
        sim = CoupledSimulator(model, modal, backend="jax", unroll=unroll)
        t0 = time.perf_counter()
        res[unroll] = sim.run_raw(a0, q0=q0)
        out[f"compile_{unroll}"] = time.perf_counter() - t0
        out[f"scan_{unroll}"] = best(lambda sim=sim: sim.run_raw(a0, q0=q0), repeat=7)
    out["steps"] = n
    out["identical"] = all(np.array_equal(res[8][k], res[1][k]) for k in res[1])
    base = CoupledSimulator(JittedStep(model), modal, backend="python")
    base.run_raw(a0[:10], q0=q0)
    out["python"] = best(lambda: base.run_raw(a0, q0=q0), repeat=2)
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--nss", help="an NSS (or NSS ensemble) model file to time")
    args = parser.parse_args()
    try:
        model, label = make_rom()
    except Exception as exc:  # the ROM module may be unavailable: same-shaped stand-in
        model, label = StandIn(), f"stand-in JAX network (70 taps, 35 RBF) [{exc}]"
    nss, nss_label = make_nss(args.nss)
    modal = ModalModel.from_beam()
    print(f"modal model: {modal.n_modes} modes; dt = {model.dt} s")
    verdicts = []
    for name, m, lab in (("NFIR", model, label), ("NSS", nss, nss_label)):
        t = free_response_times(m, modal)
        ok = t["scan_8"] <= TARGET_S
        verdicts.append(ok)
        print(f"{name} ({lab}), free response 10 s ({t['steps']} steps), after compilation:")
        print(f"  unroll=8 {1e3 * t['scan_8']:.2f} ms (first call {t['compile_8']:.2f} s); "
              f"unroll=1 {1e3 * t['scan_1']:.2f} ms (first call {t['compile_1']:.2f} s): "
              f"{t['scan_1'] / t['scan_8']:.2f}x; bit-identical: {t['identical']}")
        print(f"  baseline Python loop with jitted ROM step {1e3 * t['python']:.0f} ms: "
              f"{t['python'] / t['scan_8']:.0f}x unroll=8, {t['python'] / t['scan_1']:.0f}x "
              f"unroll=1; target <= {1e3 * TARGET_S:g} ms: {'met' if ok else 'NOT met'} "
              f"(unroll=8), {'met' if t['scan_1'] <= TARGET_S else 'NOT met'} (unroll=1)")

    sim = CoupledSimulator(model, modal, backend="jax")
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
    print(f"NFIR random responses {duration:g} s: single {1e3 * t_single:.1f} ms; vmapped batch "
          f"of {nb} ({seeds} seeds x {len(levels)} levels) {t_batch:.2f} s = "
          f"{1e3 * t_batch / nb:.1f} ms per response ({t_single * nb / t_batch:.1f}x the "
          "throughput of single runs)")
    print(f"target (NFIR, 10 s free response <= {1e3 * TARGET_S:g} ms): "
          f"{'met' if verdicts[0] else 'NOT met'}; NSS ensemble: "
          f"{'met' if verdicts[1] else 'NOT met'}")


if __name__ == "__main__":
    main()
