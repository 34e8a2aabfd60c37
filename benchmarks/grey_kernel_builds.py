"""Two or more builds of the grey box's C kernel (``window.cc``) side by side in one process.

Each build's shared object is loaded as a module of its own and its XLA FFI handlers are
registered under a prefix, so one process runs them all on the same inputs (the default
architecture, 8 states, 32 neurons and 5 features, with the weights of
``grey_free_run.network``; 200 samples; 160 rows, the batch and the passivity probes of a
step), alternated round by round. For each build it prints whether its gradients equal the
first build's to the bit (else their largest relative difference), and the median and least
time of the window's forward pass and of forward and reverse together, each inside one
compiled loop of 20 calls (no buffer allocated between calls).

Why one process: how fast the kernel runs depends on where its working memory falls. Before
the working memory was aligned to cache lines, the same build's reverse pass took 2.2 ms in
one process and 3.0 ms in another, which no pair of separate runs can tell from a change in
the code.

Usage (one core, so the kernel runs its blocks on one thread)::

    g++ -O3 -std=c++17 -fPIC -shared variant.cc -o /tmp/variant.so \\
        -I$(.venv/bin/python -c 'import jax.ffi; print(jax.ffi.include_dir())') \\
        -I$(.venv/bin/python -c 'import sysconfig; print(sysconfig.get_paths()["include"])')
    taskset -c 0 .venv/bin/python benchmarks/grey_kernel_builds.py \\
        src/sloshrom/rom/grey/_window.cpython-311-x86_64-linux-gnu.so /tmp/variant.so

About 10 s a build for the default ``--rounds``.
"""

from __future__ import annotations

import argparse
import importlib.util
import os
import shutil
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path
from types import ModuleType

# Eigen's products on one thread; the kernel's blocks run on as many threads as the process
# has cores (one under taskset -c N), which the script prints
os.environ.setdefault("XLA_FLAGS", "--xla_cpu_multi_thread_eigen=false")

import jax  # noqa: E402
import jax.numpy as jnp  # noqa: E402
import numpy as np  # noqa: E402

from grey_free_run import network  # noqa: E402
from sloshrom.rom.grey.kernel import WEIGHTS  # noqa: E402
from sloshrom.rom.grey.network import N_FEATURES  # noqa: E402

#: Calls of the kernel in one timed compiled loop.
CALLS = 20


def load_build(path: Path, prefix: str) -> ModuleType:
    """Load the extension at ``path`` as a module of its own and register its handlers with
    ``prefix`` before their names."""
    if not path.is_file():
        sys.exit(f"{path}: not a file")
    d = Path(tempfile.mkdtemp())
    try:
        # the module's init function is PyInit__window: its file must be named _window
        shutil.copy(path, d / "_window.so")
        spec = importlib.util.spec_from_file_location(f"{prefix}._window", d / "_window.so")
        if spec is None or spec.loader is None:
            sys.exit(f"{path}: not a loadable extension")
        try:
            mod = importlib.util.module_from_spec(spec)  # loads the shared object
            spec.loader.exec_module(mod)
        except ImportError as e:
            sys.exit(f"{path}: not a build of the grey kernel's extension ({e})")
    finally:
        shutil.rmtree(d)  # the loaded object stays mapped
    if not hasattr(mod, "handlers"):
        sys.exit(f"{path}: not a build of the grey kernel's extension (no handlers())")
    for name, capsule in mod.handlers().items():
        jax.ffi.register_ffi_target(f"{prefix}{name}", capsule, platform="cpu")
    return mod


def programs(prefix: str, w: list[jax.Array], x0: jax.Array, seq: jax.Array, dy: jax.Array
             ) -> tuple[Callable[[], jax.Array], Callable[[], jax.Array],
                        Callable[[], tuple[jax.Array, ...]]]:
    """The build's timed loops (forward; forward and reverse) and its gradients."""
    t, _, b = seq.shape
    nx, n = w[0].shape[1], w[1].shape[1]
    dt, s = seq.dtype, jax.ShapeDtypeStruct
    suffix = "f64" if dt == jnp.float64 else "f32"
    fwd = jax.ffi.ffi_call(f"{prefix}sloshrom_grey_forward_{suffix}",
                           (s((t, b), dt), s((t, nx, b), dt), s((t, n, b), dt), s((t, n, b), dt)))
    bwd = jax.ffi.ffi_call(f"{prefix}sloshrom_grey_backward_{suffix}",
                           (*(s(a.shape, dt) for a in w), s((nx, b), dt)))

    @jax.jit
    def forward(w: list[jax.Array], x0: jax.Array, seq: jax.Array) -> jax.Array:
        def body(i: int, acc: jax.Array) -> jax.Array:
            y, xs, hs, gs = fwd(*w, x0 + 0 * acc[0, 0], seq)  # each call waits on the last
            return acc + y[:1, :1] + xs[0, :1, :1] + hs[0, :1, :1] + gs[0, :1, :1]
        return jax.lax.fori_loop(0, CALLS, body, jnp.zeros((1, 1), dt))

    @jax.jit
    def both(w: list[jax.Array], x0: jax.Array, seq: jax.Array, dy: jax.Array) -> jax.Array:
        def body(i: int, acc: jax.Array) -> jax.Array:
            y, xs, hs, gs = fwd(*w, x0 + 0 * acc[0, 0], seq)
            g = bwd(*w, seq, xs, hs, gs, dy + 0 * y)
            return acc + g[0][:1, :1]
        return jax.lax.fori_loop(0, CALLS, body, jnp.zeros((1, 1), dt))

    grads = jax.jit(lambda w, x0, seq, dy: bwd(*w, seq, *fwd(*w, x0, seq)[1:], dy))
    return (lambda: forward(w, x0, seq), lambda: both(w, x0, seq, dy),
            lambda: grads(w, x0, seq, dy))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("builds", type=Path, nargs="+", help="the extension's shared objects")
    ap.add_argument("--dtype", choices=("float64", "float32"), default="float32")
    ap.add_argument("--rounds", type=int, default=12, help="timed rounds (each build once a round)")
    a = ap.parse_args()
    if a.rounds < 1:
        sys.exit("--rounds must be at least 1")
    jax.config.update("jax_enable_x64", True)
    dt = np.dtype(a.dtype)
    nx, n, nf, t, b = 8, 32, 1 + N_FEATURES, 200, 160
    p = network(nx, n, 0)
    w = [jnp.asarray(p[k], dt) for k in WEIGHTS]
    rng = np.random.default_rng(0)
    x0 = jnp.asarray(rng.standard_normal((nx, b)), dt)
    seq = jnp.asarray(rng.standard_normal((t, nf, b)), dt)
    dy = jnp.asarray(rng.standard_normal((t, b)), dt)
    names = [str(p) for p in a.builds]
    progs, mods = {}, {}
    for k, path in enumerate(a.builds):
        mods[names[k]] = load_build(path, f"build{k}_")
        progs[names[k]] = programs(f"build{k}_", w, x0, seq, dy)
    ref = [np.asarray(g) for g in progs[names[0]][2]()]
    print(f"threads that ran the kernel's blocks: {mods[names[0]].threads_used()}")
    for name in names[1:]:
        out = [np.asarray(g) for g in progs[name][2]()]
        if all(np.array_equal(x, y) for x, y in zip(ref, out, strict=True)):
            print(f"{name}: gradients equal to the first build's to the bit")
        else:
            rel = max(float(np.max(np.abs(x - y)) / np.max(np.abs(x)))
                      for x, y in zip(ref, out, strict=True))
            print(f"{name}: gradients differ from the first build's by {rel:.2e} (relative)")
    times: dict[str, tuple[list[float], list[float]]] = {k: ([], []) for k in names}
    for r in range(a.rounds):
        for name in names if r % 2 == 0 else names[::-1]:  # alternated: drift hits all
            for prog, acc in zip(progs[name][:2], times[name], strict=True):
                jax.block_until_ready(prog())
                t0 = time.perf_counter()
                jax.block_until_ready(prog())
                acc.append((time.perf_counter() - t0) / CALLS * 1e3)
    print(f"{a.dtype}, {b} rows x {t} samples, per call (ms; median, least):")
    for name in names:
        f, fb = (np.asarray(x) for x in times[name])
        print(f"  {name}: forward {np.median(f):.3f}, {f.min():.3f}; forward and reverse "
              f"{np.median(fb):.3f}, {fb.min():.3f}; the reverse alone about "
              f"{np.median(fb) - np.median(f):.3f}")


if __name__ == "__main__":
    main()
