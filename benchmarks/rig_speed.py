"""Virtual-rig speed, with a pure-NumPy baseline in the same run.

Targets: 720 s of data in <= 10 s, a 30 x 30 Phi_d map in <= 60 s.

Prints:

* time for 720 s of VFA data (480 s training + 240 s validation path) through
  ``VirtualRig.measure`` at the fine step (target <= 10 s on 2 cores);
* time for a 30 x 30 Phi_d map (target <= 60 s);
* a baseline: the same rig step written in plain Python/NumPy (no numba) on a short slice of
  the VFA input, extrapolated to 720 s, and the speed-up ratio numba / baseline.

Usage::

    .venv/bin/python benchmarks/rig_speed.py
"""

from __future__ import annotations

import time

import numpy as np

from sloshrom.energy import default_grid, map_maximum, phi_d_map
from sloshrom.rig import VirtualRig, rig_step
from sloshrom.signals import harmonic


def _vfa_acceleration(fs: float, split: str) -> np.ndarray:
    try:
        from sloshrom.signals import vfa

        return vfa(fs, split).acceleration
    except ImportError:  # fallback: a chirp with slowly varying amplitude
        dur = 480.0 if split == "train" else 240.0
        t = np.arange(int(dur * fs)) / fs
        f = 5.0 + 20.0 * (0.5 - 0.5 * np.cos(2 * np.pi * t / dur))
        amp = 6 * 9.80665 * np.sin(np.pi * t / dur) ** 2 * (0.5 + 0.5 * np.sin(0.3 * t))
        return amp * np.cos(2 * np.pi * np.cumsum(f) / fs)


def main() -> None:
    rig = VirtualRig()
    fs = 1.0 / rig.dt
    # warm-up (numba compile / cache load) on a short signal
    h = harmonic(fs, 12.0, 5e-3, n_cycles=2)
    rig.measure(h.acceleration)

    accs = {s: _vfa_acceleration(fs, s) for s in ("train", "validation")}
    t0 = time.perf_counter()
    n_out = 0
    for acc in accs.values():
        n_out += rig.measure(acc)["time"].size
    t_measure = time.perf_counter() - t0
    duration = sum(a.size for a in accs.values()) * rig.dt
    print(f"measure: {duration:.0f} s of VFA data ({n_out} output samples) in {t_measure:.2f} s "
          f"(target <= 10 s)")

    # baseline: the same step without numba (rig_step.py_func runs it as plain Python)
    acc = accs["train"]
    vel = np.concatenate([[0.0], np.cumsum(0.5 * (acc[1:] + acc[:-1]) * rig.dt)])
    i0 = int(240.0 / rig.dt)  # a slice in the middle of the path (column active)
    n_base = 20000
    st = rig.init_state()
    params = rig.kernel()[1]
    py_step = rig_step.py_func
    t0 = time.perf_counter()
    for k in range(i0, i0 + n_base):
        py_step(st, params, vel[k], acc[k], rig.dt)
    t_base = (time.perf_counter() - t0) * (duration / rig.dt) / n_base
    t0 = time.perf_counter()
    rig.simulate(vel[i0 : i0 + n_base], acc[i0 : i0 + n_base])
    t_nb_slice = time.perf_counter() - t0
    print(f"baseline (pure Python step, {n_base} steps extrapolated to {duration:.0f} s): "
          f"{t_base:.1f} s; ratio baseline / numba measure = {t_base / t_measure:.0f}x "
          f"(slice: {t_nb_slice * 1e3:.1f} ms numba vs "
          f"{t_base * n_base * rig.dt / duration * 1e3:.0f} ms Python)")

    ob, ab = default_grid(30)
    t0 = time.perf_counter()
    da = phi_d_map(rig, ob, ab)
    t_map = time.perf_counter() - t0
    mx = map_maximum(da)
    n_pts = int(np.isfinite(da.values).sum())
    print(f"Phi_d map 30 x 30 ({n_pts} points inside the envelope): {t_map:.2f} s "
          f"(target <= 60 s); max Phi_d {mx['phi_d']:.3f} at omega_bar {mx['omega_bar']:.2f}, "
          f"a_bar {mx['a_bar']:.3f} (Gamma {mx['gamma']:.2f} g, {mx['frequency']:.1f} Hz)")
    print(f"baseline map estimate (pure Python step): "
          f"{t_base * t_map / t_measure:.0f} s (same step-cost ratio)")


if __name__ == "__main__":
    main()
