"""The NSS on a short record: a sweep of its size on the simulated Cascaded Tanks benchmark.

The records are :func:`sloshrom.systems.tanks.cascaded_tanks` (1024 estimation and 1024 test
samples at Ts = 4 s, an overflowing upper tank, the test record far from rest). Each point of
the sweep is an NSS trained on the estimation record's first 80 % (819 samples) with early
stopping on its last 20 % (205 samples), the validation's state encoded from the
``window`` training samples before it (``NSS.fit(..., validation_history=...)`` for the
defaults, the same computation in :func:`fit_here` for the sweep's points, whose recipe
``--set`` changes), and scored on the test record: the state encoded from the test record's
first ``window`` samples, the model simulated from there, the RMSE (V) over the samples from
:data:`SCORED_FROM` on (the same samples for every window).

It prints one row per point (median and range over the seeds, the parameters, samples per
parameter, best epochs, seconds) and the timing. One training process at a time (the machine
is shared); a training takes 10 s (the short recipe) to 4 min (the default recipe, loaded).
The figures and what they say: docs/rom.md, "Short records".

Usage::

    PYTHONPATH=src .venv/bin/python benchmarks/short_record.py --grid sweep   # stage 1
    PYTHONPATH=src .venv/bin/python benchmarks/short_record.py --grid point --point 4,16,10 \
        --set horizon=200 --set batch=128 --set steps_per_epoch=200           # one point
    PYTHONPATH=src .venv/bin/python benchmarks/short_record.py --grid default  # the defaults
    PYTHONPATH=src .venv/bin/python benchmarks/short_record.py --grid lss      # LSS reference
    options: --seeds 0 1 2, --data-seed 1, --out rows.json (appended)
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import math
import sys
import time
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np

from sloshrom.rom import NSS
from sloshrom.rom import shooting as sh
from sloshrom.rom.engine import adam_epochs
from sloshrom.rom.network import MinMaxScaler
from sloshrom.rom.nss import network as ss
from sloshrom.rom.nss import training as sst
from sloshrom.rom.shooting import ShootingOptions
from sloshrom.systems.tanks import cascaded_tanks

#: The test samples scored: from the largest encoder window of the sweep on, so that every
#: point is scored on the same samples whatever its window.
SCORED_FROM = 50
#: The best median test RMSE (V) of the sweep (data seed 0, seeds 0-2: NSS(4, 16, 10) with
#: the default recipe; docs/rom.md, "Short records"): the defaults must come within 20 % of it.
BEST_SWEEP_RMSE = 0.0905
#: The estimation record's share used for training; the rest validates (early stopping).
TRAIN_SHARE = 0.8


def split(u: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, ...]:
    """Training and validation parts of the estimation record (the first 80 %, the rest)."""
    n_tr = int(round(TRAIN_SHARE * u.size))
    return u[:n_tr], y[:n_tr], u[n_tr:], y[n_tr:]


@jax.jit
def _run_from(p: dict[str, Any], x0: jax.Array, u_s: jax.Array, r_u: Any, r_y: Any) -> Any:
    return ss.ss_simulate(p, x0[None, :], u_s[:, None], r_u, r_y)[1][:, 0]


def encoded_run(model: Any, u: np.ndarray, y: np.ndarray, window: int) -> np.ndarray:
    """The model's output over ``u[window:]``, its state encoded from the first ``window``
    samples of ``u`` and ``y`` (physical units)."""
    with jax.enable_x64(True):
        sc = model.scaler
        ru, ry = float(sc.u(0.0)), float(sc.y(0.0))
        p = {k: jnp.asarray(v, jnp.float64) for k, v in model.params.items()}
        x0 = sh.ss_encode(p, jnp.asarray(sc.u(u[:window])), jnp.asarray(sc.y(y[:window])),
                          ru, ry)
        y_s = _run_from(p, x0, jnp.asarray(sc.u(u[window:])), ru, ry)
        return np.asarray(sc.y_inverse(np.asarray(y_s)))


def test_rmse(model: Any, test: Any, window: int) -> float:
    """RMSE (V) of the encoded run of the test record over samples ``SCORED_FROM`` on."""
    u, y = np.asarray(test["u"]), np.asarray(test["y"])
    yh = encoded_run(model, u, y, window)
    e = yh[SCORED_FROM - window:] - y[SCORED_FROM:]
    return float(np.sqrt(np.mean(e**2))) if np.all(np.isfinite(e)) else math.inf


def fit_here(hyper: Mapping[str, Any], u: np.ndarray, y: np.ndarray, fs: float,
             u_val: np.ndarray, y_val: np.ndarray, hist: tuple[np.ndarray, np.ndarray]
             ) -> tuple[Any, dict[str, Any]]:
    """:func:`sloshrom.rom.nss.training.fit_statespace` with an early stopping on the encoded
    run of the validation record (its state from ``hist``, the samples before it): the
    validation of the lead's ``NSS.fit(..., validation_history=window)``, for a package
    without it."""
    spec = ss.StateSpaceSpec(int(hyper["n_states"]), int(hyper["neurons"]),
                             int(hyper["window"]))
    scaler = MinMaxScaler.fit(u, y)
    names = {f.name for f in dataclasses.fields(ShootingOptions)}
    opts = dataclasses.replace(sst.NSS_SHOOTING,
                               **{k: v for k, v in hyper.items() if k in names})
    uh, yh = hist
    uv_all, yv_all = np.concatenate([uh, u_val]), np.concatenate([yh, y_val])
    w = spec.window

    with jax.enable_x64(True):
        problem = sst.shooting_problem(spec, u, y, fs, scaler, None, opts, int(hyper["seed"]))
        ru, ry = float(scaler.u(0.0)), float(scaler.y(0.0))
        uvs = jnp.asarray(scaler.u(uv_all))
        yvs = np.asarray(scaler.y(yv_all))

        def validate(p: Any) -> tuple[float, float]:
            p64 = {k: jnp.asarray(v, jnp.float64) for k, v in p.items()}
            x0 = sh.ss_encode(p64, uvs[:w], jnp.asarray(yvs[:w]), ru, ry)
            yhat = np.asarray(_run_from(p64, x0, uvs[w:], ru, ry))
            if not np.all(np.isfinite(yhat)) or np.max(np.abs(yhat)) > 10.0:
                return math.inf, math.inf
            mse = float(np.mean((yhat - yvs[w:]) ** 2))
            return mse, mse

        problem = dataclasses.replace(problem, validate=validate)
        epochs = int(hyper["max_epochs"])
        res = adam_epochs(problem, max_epochs=epochs, max_fail=6, min_epochs=epochs // 2,
                          rollback=10.0, seed=int(hyper["seed"]),
                          mse_scale=scaler.out_half_range**2)
    params = {k: np.asarray(v, dtype=np.float64) for k, v in res.params.items()}
    model = ss.StateSpaceNetwork(params, scaler, spec, "velocity", fs)
    return model, {"best_epoch": res.best_epoch, "epochs": len(res.history["train_mse"]) - 1,
                   "stop_reason": res.stop_reason}


def run_point(hyper: Mapping[str, Any], seed: int, est: Any, test: Any,
              use_estimator: bool) -> dict[str, Any]:
    """Train one NSS of ``hyper`` (None values: the estimator sizes them) and score it."""
    u, y = np.asarray(est["u"]), np.asarray(est["y"])
    fs = float(est.fs)
    u_tr, y_tr, u_val, y_val = split(u, y)
    t0 = time.perf_counter()
    if use_estimator:
        given = {k: v for k, v in hyper.items() if v is not None}
        m = NSS(**given, seed=seed, units=("V", "V"), names=("u", "y"))
        # the validation's history: the last SCORED_FROM training samples (at least any
        # window); the encoder reads the last `window` of them, as fit_here does
        h = SCORED_FROM
        m.fit(u_tr, y_tr, fs, validation=(np.concatenate([u_tr[-h:], u_val]),
                                          np.concatenate([y_tr[-h:], y_val])),
              validation_history=h)
        model, hist = m.model_, m.history_
        info = {"best_epoch": hist["best_epoch"], "epochs": len(hist["train_mse"]) - 1,
                "stop_reason": hist["stop_reason"], "sizing": m.sizing_}
    else:
        w = int(hyper["window"])
        model, info = fit_here({**hyper, "seed": seed}, u_tr, y_tr, fs, u_val, y_val,
                               (u_tr[-w:], y_tr[-w:]))
    seconds = time.perf_counter() - t0
    spec = model.spec
    return {"n_states": spec.n_states, "neurons": spec.neurons, "window": spec.window,
            "seed": seed, "test_rmse": test_rmse(model, test, spec.window),
            "n_params": spec.n_params, "samples_per_param": u_tr.size / spec.n_params,
            "seconds": seconds, **info}


def run_lss(n_states: int, est: Any, test: Any) -> dict[str, Any]:
    """The best linear model for reference: an LSS of ``n_states`` (N4SID refined on its
    simulation error) trained and validated as the NSS, its test run started from the test
    record's first :data:`SCORED_FROM` samples (``predict(history=...)``)."""
    from sloshrom.rom.lss import LSS

    u, y = np.asarray(est["u"]), np.asarray(est["y"])
    u_tr, y_tr, u_val, y_val = split(u, y)
    h = SCORED_FROM
    t0 = time.perf_counter()
    m = LSS(n_states=n_states, units=("V", "V"), names=("u", "y")).fit(
        u_tr, y_tr, float(est.fs), validation=(np.concatenate([u_tr[-h:], u_val]),
                                               np.concatenate([y_tr[-h:], y_val])),
        validation_history=h)
    seconds = time.perf_counter() - t0
    ut, yt = np.asarray(test["u"]), np.asarray(test["y"])
    yhat = m.predict(ut[h:], history=(ut[:h], yt[:h]))
    rmse = float(np.sqrt(np.mean((yhat - yt[h:]) ** 2)))
    n_params = int(m.n_params)
    return {"n_states": n_states, "neurons": 0, "window": 0, "seed": 0, "test_rmse": rmse,
            "n_params": n_params, "samples_per_param": u_tr.size / n_params,
            "seconds": seconds, "best_epoch": 0, "epochs": 0, "stop_reason": "-"}


#: The sweep's points: (n_states, neurons, window).
SWEEP: tuple[tuple[int, int, int], ...] = (
    (8, 64, 50), (8, 64, 10), (8, 32, 10), (8, 16, 10),
    (4, 64, 10), (4, 32, 10), (4, 16, 10), (4, 8, 10),
    (3, 32, 10), (3, 16, 10), (3, 8, 10), (2, 32, 10), (2, 16, 10),
    (4, 16, 5), (4, 16, 20), (4, 16, 50), (3, 16, 5), (3, 16, 20),
)


def table(rows: Sequence[Mapping[str, Any]]) -> str:
    """One line per point: median and range of the test RMSE over its seeds."""
    by: dict[tuple[Any, ...], list[Mapping[str, Any]]] = {}
    for r in rows:
        by.setdefault((r["label"], r["n_states"], r["neurons"], r["window"]), []).append(r)
    lines = [f"{'point':<22} {'states':>6} {'neur':>5} {'win':>4} {'params':>6} "
             f"{'samp/par':>8} {'seeds':>5} {'RMSE med':>9} {'min':>7} {'max':>7} "
             f"{'epochs':>9} {'s/fit':>6}"]
    for (label, nx, n, w), rs in by.items():
        e = np.array([r["test_rmse"] for r in rs])
        ep = "/".join(str(r["best_epoch"]) for r in rs)
        lines.append(f"{label:<22} {nx:>6} {n:>5} {w:>4} {rs[0]['n_params']:>6} "
                     f"{rs[0]['samples_per_param']:>8.2f} {len(rs):>5} "
                     f"{float(np.median(e)):>9.4f} {e.min():>7.4f} {e.max():>7.4f} "
                     f"{ep:>9} {np.mean([r['seconds'] for r in rs]):>6.1f}")
    return "\n".join(lines)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--grid", choices=("sweep", "default", "point", "lss"), default="sweep")
    ap.add_argument("--point", action="append", default=[],
                    help="n_states,neurons,window (with --grid point; repeatable)")
    ap.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2])
    ap.add_argument("--data-seed", type=int, default=0, help="seed of the records")
    ap.add_argument("--set", action="append", default=[],
                    help="another hyperparameter for every point, NAME=VALUE")
    ap.add_argument("--out", type=Path, help="append the rows to this JSON file")
    a = ap.parse_args()
    est, test = cascaded_tanks(seed=a.data_seed)
    extra: dict[str, Any] = {}
    for s in a.set:
        k, v = s.split("=")
        extra[k] = float(v) if "." in v or "e" in v else int(v)
    rows = []
    t0 = time.perf_counter()
    if a.grid == "lss":
        for nx in (1, 2, 3, 4, 6):
            r = {**run_lss(nx, est, test), "label": f"LSS({nx})", "hyper": {}}
            rows.append(r)
            print(f"LSS({nx}): test RMSE {r['test_rmse']:.4f} V", flush=True)
        points = []
    elif a.grid == "default":
        points: list[tuple[str, dict[str, Any], bool]] = [("default (sized)", {**extra}, True)]
    else:
        pts = ([tuple(int(x) for x in p.split(",")) for p in a.point] if a.grid == "point"
               else list(SWEEP))
        short = {"horizon": 50, "batch": 64, "max_epochs": 60, "steps_per_epoch": 50}
        points = [(f"NSS{p}", {**short, "n_states": p[0], "neurons": p[1], "window": p[2],
                               **extra}, False) for p in pts]
    for label, hyper, via_estimator in points:
        for seed in a.seeds:
            r = run_point(hyper, seed, est, test, via_estimator)
            r["label"] = label
            r["hyper"] = {k: v for k, v in hyper.items()}
            rows.append(r)
            print(f"{label} seed {seed}: test RMSE {r['test_rmse']:.4f} V, "
                  f"{r['n_params']} params, best epoch {r['best_epoch']}/{r['epochs']}, "
                  f"{r['seconds']:.1f} s", flush=True)
    print(table(rows))
    print(f"total {time.perf_counter() - t0:.0f} s")
    if a.out is not None:
        old = json.loads(a.out.read_text()) if a.out.exists() else []
        a.out.write_text(json.dumps(old + rows, indent=1))


if __name__ == "__main__":
    sys.exit(main())
