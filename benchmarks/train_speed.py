"""Time to train the reference NFIR(70, 35) on default-like data, against baselines in one run.

Data: the virtual rig's VFA tests (``sloshrom.signals.vfa`` + ``sloshrom.rig.VirtualRig.measure``,
preprocessed by ``sloshrom.io.record_from_measurement``): 480 s training, 240 s validation at
500 Hz (cached in the temporary directory). Falls back to a synthetic nonlinear system if the rig
is not available.

Trainers compared (same data, same seeded initialisation):

1. ``adam`` (the NFIR default): minibatch Adam with validation early stopping;
2. ``fast``: Levenberg-Marquardt with J^T J on a decimated subset of the rows;
3. ``lm``: MATLAB ``trainlm`` on every row, stopped at the validation MSE the fast trainer
   reached or at ``--lm-cap`` seconds.

(``adam_baseline`` below is a standalone hand-written JAX Adam kept for experiments; the
package's trainer uses ``optax.adam``.)

Run: ``.venv/bin/python benchmarks/train_speed.py`` (about 7 min with the default cap, alone).
Target: <= 2 min on this machine; the paper: ~40 min (MATLAB).
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

import numpy as np


def rig_data(duration: float, split: str, seed: int) -> tuple[np.ndarray, np.ndarray, float]:
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


def synthetic_data(duration: float, seed: int, fs: float = 500.0):
    from scipy.signal import butter, lfilter, sosfiltfilt

    rng = np.random.default_rng(seed)
    n = int(duration * fs)
    u = 0.05 * sosfiltfilt(butter(4, [5, 25], "band", fs=fs, output="sos"), rng.standard_normal(n))
    u *= 1 + np.sin(2 * np.pi * np.arange(n) / n * 3) ** 2
    b, a = butter(2, 15, fs=fs)
    lin = lfilter(b, a, u)
    return u, 100 * np.tanh(20 * lin) * np.abs(lin), fs


def adam_baseline(u, y, uv, yv, fs, model_kw, target, cap, lr=1e-3, batch=4096):
    """Plain minibatch Adam on the NFIR (JAX), from the same initialisation as LM."""
    import jax

    with jax.enable_x64(True):  # float64 as the package's trainers
        return _adam_baseline(u, y, uv, yv, fs, model_kw, target, cap, lr, batch)


def _adam_baseline(u, y, uv, yv, fs, model_kw, target, cap, lr, batch):
    import jax
    import jax.numpy as jnp

    from sloshrom.rom import network, training
    from sloshrom.rom.estimators import NFIR

    spec = NFIR(**model_kw).spec
    sc = network.MinMaxScaler.fit(u, y)
    us, ys, uvs = sc.u(u), sc.y(y), sc.u(uv)
    rest = float(sc.u(0.0))
    d, h, hidden = spec.delays, spec.neurons, spec.hidden
    n = us.size
    stride = -(-n // training.FAST_MAX_ROWS)
    rows0 = np.arange(stride // 2, n, stride)
    theta = jnp.asarray(training.init_theta(training._regressors(us, ys, rows0, d, 0, rest, 0.0),
                                            ys[rows0], h, hidden, model_kw.get("seed", 0)))
    up = jnp.asarray(np.concatenate([np.full(max(d), rest), us]))
    ysj = jnp.asarray(ys)

    def loss(th, rows):
        e = network.nfir_rows(th, up, rows, d, h, hidden) - ysj[rows]
        return jnp.mean(e**2)

    @jax.jit
    def step(th, mom, vel, t, rows):
        g = jax.grad(loss)(th, rows)
        mom = 0.9 * mom + 0.1 * g
        vel = 0.999 * vel + 0.001 * g**2
        mh, vh = mom / (1 - 0.9**t), vel / (1 - 0.999**t)
        return th - lr * mh / (jnp.sqrt(vh) + 1e-8), mom, vel

    def val_mse(th):
        yh = network.nfir_free_run(th, jnp.asarray(uvs), rest, d, h, hidden)
        return float(np.mean((np.asarray(sc.y_inverse(yh)) - yv) ** 2))

    rng = np.random.default_rng(0)
    mom, vel = jnp.zeros_like(theta), jnp.zeros_like(theta)
    t0, it, best = time.perf_counter(), 0, val_mse(theta)
    while time.perf_counter() - t0 < cap:
        for _ in range(200):
            it += 1
            theta, mom, vel = step(theta, mom, vel, it, jnp.asarray(rng.integers(0, n, batch)))
        best = min(best, val_mse(theta))
        if best <= target:
            break
    return time.perf_counter() - t0, best, it


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--train-duration", type=float, default=480.0)
    ap.add_argument("--val-duration", type=float, default=240.0)
    ap.add_argument("--lm-cap", type=float, default=300.0, help="s; trainlm-exact time cap")
    ap.add_argument("--max-epochs", type=int, default=1000)
    ap.add_argument("--skip-baselines", action="store_true")
    ap.add_argument("--synthetic", action="store_true", help="synthetic system instead of rig")
    args = ap.parse_args()

    from sloshrom.rom.estimators import NFIR

    t0 = time.perf_counter()
    source = "synthetic"
    if not args.synthetic:
        try:
            u, y, fs = rig_data(args.train_duration, "train", 1)
            uv, yv, _ = rig_data(args.val_duration, "validation", 2)
            source = "virtual rig VFA"
        except ImportError:
            pass
    if source == "synthetic":
        u, y, fs = synthetic_data(args.train_duration, 1)
        uv, yv, _ = synthetic_data(args.val_duration, 2)
    print(f"data: {source}, {u.size} + {uv.size} samples at {fs:g} Hz "
          f"({time.perf_counter() - t0:.1f} s to make/load); var(y_val) = {np.var(yv):.4g} N^2")

    kw = {"delays": 70, "neurons": 35, "max_epochs": args.max_epochs, "seed": 0}
    res = {}
    for trainer in ("adam", "fast"):
        t0 = time.perf_counter()
        m = NFIR(trainer=trainer, **kw).fit(u, y, fs=fs, validation=(uv, yv))
        t = time.perf_counter() - t0
        h = m.history_
        v = h["val_mse"][h["best_epoch"]]
        res[trainer] = (t, v)
        print(f"{trainer:6s}: {t:7.1f} s  {len(h['train_mse']) - 1:4d} epochs "
              f"({h['stop_reason']}), best val MSE {v:.4g} N^2 (NRMSE "
              f"{np.sqrt(v / np.mean(yv**2)):.3f}), train MSE {h['train_mse'][h['best_epoch']]:.4g}"
              f" N^2, {m.n_params} parameters")
    t_fast, v_fast = res["fast"]
    t_def, v_def = res["adam"]
    print(f"ratio fast-LM/adam (default): time {t_fast / t_def:.1f}x, val MSE "
          f"{v_fast / v_def:.2f}")
    if args.skip_baselines:
        return

    t0 = time.perf_counter()
    lm = NFIR(trainer="lm", **kw).fit(
        u, y, fs=fs, validation=(uv, yv),
        callback=lambda e, info: info["val_mse"] <= v_fast or info["seconds"] > args.lm_cap,
    )
    t_lm = time.perf_counter() - t0
    hl = lm.history_
    v_lm = min(hl["val_mse"])
    print(f"lm    : {t_lm:7.1f} s  {len(hl['train_mse']) - 1:4d} epochs ({hl['stop_reason']}), "
          f"best val MSE {v_lm:.4g} N^2, {np.mean(np.diff(hl['seconds'])):.1f} s/epoch")
    for name, t, v in (("lm", t_lm, v_lm),):
        tag = "reached" if v <= v_fast else "did NOT reach (time cap): a lower bound;"
        print(f"ratio {name}/fast: {t / t_fast:5.1f}x  ({tag} the fast val MSE; val MSE ratio "
              f"{v / v_fast:.2f}); lm/adam {t / t_def:.1f}x, val MSE ratio {v / v_def:.2f}")
    print("paper (MATLAB trainlm, parallel CPU): ~40 min; target: <= 120 s")


if __name__ == "__main__":
    main()
