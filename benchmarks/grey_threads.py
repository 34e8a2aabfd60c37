"""One grey-box model in one process: one core against all of them, in the same run.

A single model trained in one process (``sloshrom train`` without ``--ensemble``, the Python
API) spreads its two phases over the process's cores: the column's search scores a
generation's candidates side by side, one a thread, and the network's C kernel shares its
batch's blocks of rows among XLA's intra-op threads. An ensemble's member in a Dask worker
owns one core and runs both on one thread. This script times each phase in a child process
limited to one thread (the environment of such a worker: ``NPROC=1``, ``NUMBA_NUM_THREADS=1``,
BLAS on one thread, XLA's Eigen on one thread, pinned to one core) and in one with every core,
the two alternated (one, all, all, one), and prints the times and their ratio:

- ``kernel``: the shooting window forward and reverse (``jax.grad`` of a sum over
  ``grey_window``), float64 and float32, 160 rows x 200 samples, the median of 40 calls;
- ``search``: the column's differential evolution, ``--generations`` generations of the
  default recipe on the default records (``--run``: a ``make reproduce`` folder).

Usage: ``.venv/bin/python benchmarks/grey_threads.py --run results`` (about 1 min). The
objective each search reaches is printed: the two children must agree to the bit.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent


def _kernel() -> dict[str, float]:
    import jax
    import jax.numpy as jnp

    from sloshrom.rom.grey.kernel import grey_window, kernel_available

    if not kernel_available():
        sys.exit("the grey box's C kernel is not built")
    rng = np.random.default_rng(0)
    nx, n, b, t = 8, 32, 160, 200
    shapes = {"A": (nx + 5, nx), "W1": (nx + 5, n), "b1": (n,), "W2": (n, nx), "C": (nx + 4,),
              "V1": (nx + 4, n), "d1": (n,), "V2": (n,)}
    out = {}
    with jax.enable_x64(True):
        for dt in (jnp.float64, jnp.float32):
            p = {k: jnp.asarray(0.1 * rng.standard_normal(s), dt) for k, s in shapes.items()}
            x0 = jnp.asarray(0.1 * rng.standard_normal((b, nx)), dt)
            seq = jnp.asarray(0.1 * rng.standard_normal((b, t, 5)), dt)

            def loss(p, x0, seq=seq):
                return jnp.sum(grey_window(p, x0, seq, 0.0, 0.0) ** 2)

            f = jax.jit(jax.grad(loss, argnums=(0, 1)))
            jax.block_until_ready(f(p, x0))
            ts = []
            for _ in range(40):
                t0 = time.perf_counter()
                jax.block_until_ready(f(p, x0))
                ts.append(time.perf_counter() - t0)
            out[f"kernel {np.dtype(dt).name} ms"] = 1e3 * float(np.median(ts))
    return out


def search_arguments(run: Path, seed: int = 0) -> tuple[tuple[object, ...], dict[str, object]]:
    """``fit_physics``'s arguments as the default recipe's estimator makes them for member
    ``seed`` on the records of ``run`` (the fit stops there)."""
    import sloshrom.rom.grey.estimator as ge
    from sloshrom.rom import GreyBox
    from sloshrom.rom.grey.entry import GREY_CLASS

    sys.path.insert(0, str(HERE))
    from train_speed import records

    (u, y, uv, yv, fs), _ = records(run)
    caught: list[tuple[tuple[object, ...], dict[str, object]]] = []

    class Stop(Exception):
        pass

    def stop(*args: object, **kw: object) -> None:
        caught.append((args, kw))
        raise Stop

    real = ge.fit_physics
    ge.fit_physics = stop
    try:
        GreyBox(seed=seed, velocity_offset=0.5, **GREY_CLASS.recipe).fit(
            u, y, fs, validation=(uv, yv), fill=0.5)
    except Stop:
        pass
    finally:
        ge.fit_physics = real
    return caught[0]


def _search(run: Path, generations: int) -> dict[str, float]:
    from sloshrom.rom.grey import training as gt

    args, kw = search_arguments(run)
    gt.fit_physics(*args, **{**kw, "generations": 1})  # numba's kernel loaded
    t0 = time.perf_counter()
    _, _, hist = gt.fit_physics(*args, **{**kw, "generations": generations})
    return {"search s": time.perf_counter() - t0, "objective": hist["objective"]}


def _child(kind: str, run: Path, generations: int) -> dict[str, float]:
    if kind == "kernel":
        return _kernel()
    return _search(run, generations)


def _one_thread_env() -> dict[str, str]:
    env = dict(os.environ)
    env.update(NPROC="1", NUMBA_NUM_THREADS="1", OMP_NUM_THREADS="1",
               OPENBLAS_NUM_THREADS="1", MKL_NUM_THREADS="1",
               XLA_FLAGS=(env.get("XLA_FLAGS", "") + " --xla_cpu_multi_thread_eigen=false").strip())
    return env


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--run", type=Path, default=Path("results"))
    ap.add_argument("--generations", type=int, default=6)
    ap.add_argument("--child", choices=("kernel", "search"), help=argparse.SUPPRESS)
    a = ap.parse_args()
    if a.child:
        if os.environ.get("NPROC") == "1" and hasattr(os, "sched_setaffinity"):
            os.sched_setaffinity(0, {min(os.sched_getaffinity(0))})
        print(json.dumps(_child(a.child, a.run, a.generations)))
        return
    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    print(f"{cores} usable cores; children alternated one thread, all, all, one")
    results: dict[str, dict[str, list[float]]] = {"one": {}, "all": {}}
    for kind in ("kernel", "search"):
        for who in ("one", "all", "all", "one"):
            env = _one_thread_env() if who == "one" else dict(os.environ)
            cmd = [sys.executable, __file__, "--child", kind, "--run", str(a.run),
                   "--generations", str(a.generations)]
            out = subprocess.run(cmd, env=env, check=True, capture_output=True, text=True)
            for k, v in json.loads(out.stdout.strip().splitlines()[-1]).items():
                results[who].setdefault(k, []).append(v)
    for k in results["one"]:
        one, every = results["one"][k], results["all"][k]
        if k == "objective":
            same = "the same in every child" if len(set(one + every)) == 1 else (
                f"DIFFERS: {one + every!r}")
            print(f"search objective: {one[0]!r} ({same})")
            continue
        ratio = np.mean(one) / np.mean(every)
        print(f"{k:>22}: one thread {', '.join(f'{x:.2f}' for x in one)}; all cores "
              f"{', '.join(f'{x:.2f}' for x in every)}; ratio {ratio:.2f}x")


if __name__ == "__main__":
    main()
