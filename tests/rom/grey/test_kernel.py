"""The grey box's training kernel in C (sloshrom.rom.grey.kernel) against the pure-JAX path,
the reference: the same loss and gradient over random shapes, in float64 and float32; and the
trainer's choice of path."""

from __future__ import annotations

import logging

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from sloshrom.rom.errors import ROMError
from sloshrom.rom.grey import kernel as gk
from sloshrom.rom.grey import training as gt
from sloshrom.rom.grey.network import N_FEATURES, grey_free_run, grey_run, grey_simulate

needs_kernel = pytest.mark.skipif(not gk.kernel_available(),
                                  reason="the grey kernel is not built here")

#: (states, neurons, batch, samples): odd sizes reach the kernel's remainder loops (neurons
#: not a multiple of 4, batches padded to a multiple of 16, odd numbers of z rows)
SHAPES = [(3, 16, 17, 7), (16, 33, 40, 9)]


def _problem(nx, n, b, t, dtype, seed):
    rng = np.random.default_rng(seed)
    nz, no = nx + 1 + N_FEATURES, nx + N_FEATURES
    shapes = {"A": (nz, nx), "W1": (nz, n), "b1": (n,), "W2": (n, nx), "C": (no,),
              "V1": (no, n), "d1": (n,), "V2": (n,)}
    # weights of 1/sqrt(fan-in) scaled by 0.5: a contracting map, so that the round-off of one
    # step is not amplified along the window (the bound below assumes it)
    p = {k: jnp.asarray(0.5 * rng.standard_normal(s) / np.sqrt(s[0]), dtype)
         for k, s in shapes.items()}
    x0 = jnp.asarray(0.3 * rng.standard_normal((b, nx)), dtype)
    seq = jnp.asarray(rng.uniform(-1, 1, (b, t, 1 + N_FEATURES)), dtype)
    target = jnp.asarray(rng.uniform(-1, 1, (b, t)), dtype)
    return p, x0, seq, target


def _loss(simulate, seq, target):
    def loss(p, x0):
        return jnp.mean((simulate(p, x0, seq) - target) ** 2)
    return jax.jit(jax.value_and_grad(loss, argnums=(0, 1)))


def _tolerance(nx, n, t, dtype):
    """Round-off bound of the difference of the two paths, relative to the largest value.

    The paths do the same arithmetic in another order (sums reordered and fused multiply-adds
    in C; XLA's own order) and with different tanh implementations (a few ulp each). A sum of
    K products carries a relative error of at most K eps (gamma_K, Higham ch. 3) of the sum of
    the magnitudes, which the scaled weights keep of the order of the result; a tanh adds at
    most 4 eps. One step of the window is K = nz + n + 4 deep; with a contracting map the
    errors of the T steps add up at most linearly, and the reverse pass goes through as many
    again: 2 T (nz + n + 4) eps, times 4 for the cancellation of differences of like terms.
    """
    eps = float(jnp.finfo(dtype).eps)
    nz = nx + 1 + N_FEATURES
    return 4.0 * 2.0 * t * (nz + n + 4) * eps


@needs_kernel
@pytest.mark.parametrize("dtype", [jnp.float64, jnp.float32])
@pytest.mark.parametrize("shape", SHAPES)
def test_kernel_matches_pure_jax(shape, dtype):
    nx, n, b, t = shape
    ru, ry = 0.05, -0.1
    with jax.enable_x64(True):
        p, x0, seq, target = _problem(nx, n, b, t, dtype, seed=sum(shape))
        ref = _loss(lambda p, x, s: grey_simulate(p, x, jnp.swapaxes(s, 0, 1), ru, ry).T,
                    seq, target)
        ker = _loss(lambda p, x, s: gk.grey_window(p, x, s, ru, ry), seq, target)
        # NumPy from here: each jnp operation on a new shape would compile
        (v0, (g0, d0)), (v1, (g1, d1)) = jax.tree.map(np.asarray, (ref(p, x0), ker(p, x0)))
        tol = _tolerance(nx, n, t, dtype)
        assert abs(float(v1) - float(v0)) <= tol * abs(float(v0))
        for k in gk.WEIGHTS:
            scale = float(np.max(np.abs(g0[k])))
            assert g1[k].shape == g0[k].shape and g1[k].dtype == g0[k].dtype == dtype
            assert float(np.max(np.abs(g1[k] - g0[k]))) <= tol * scale, k
        assert float(np.max(np.abs(d1 - d0))) <= tol * float(np.max(np.abs(d0)))


@needs_kernel
def test_a_wrong_kernel_would_fail_the_comparison():
    """The tolerance is far below a real error: the gradient of a model whose one weight is
    off by 1e-6 differs by more (the comparison above can fail)."""
    nx, n, b, t = SHAPES[1]
    with jax.enable_x64(True):
        p, x0, seq, target = _problem(nx, n, b, t, jnp.float64, seed=3)
        ker = _loss(lambda p, x, s: gk.grey_window(p, x, s, 0.0, 0.0), seq, target)
        g0 = np.asarray(ker(p, x0)[1][0]["W1"])
        q = dict(p, W2=p["W2"].at[0, 0].add(1e-6))
        g1 = np.asarray(ker(q, x0)[1][0]["W1"])
        tol = _tolerance(nx, n, t, jnp.float64)
        assert float(np.max(np.abs(g1 - g0))) > 10 * tol * float(np.max(np.abs(g0)))


#: (states, neurons, rows, samples) of free runs: neurons and states not whole vectors of the
#: row kernel (8 float64), one row and a few
RUN_SHAPES = [(8, 32, 1, 3000), (3, 7, 2, 500), (16, 65, 4, 800), (5, 9, 3, 1)]


def _free_run_case(nx, n, b, t, seed):
    with jax.enable_x64(True):
        p, x0, seq, _ = _problem(nx, n, b, t, jnp.float64, seed)
    p = {k: np.array(v, dtype=np.float64) for k, v in p.items()}
    # x_{t+1} = x_t + x_t A_x + ...: A_x near -I/2 makes the long run contract (the bound
    # assumes it)
    p["A"][:nx] = 0.3 * p["A"][:nx] - 0.5 * np.eye(nx)
    seq = np.asarray(seq, dtype=np.float64)
    return (p, np.asarray(x0, dtype=np.float64), np.swapaxes(seq[..., 0], 0, 1),
            np.swapaxes(seq[..., 1:], 0, 1))


@needs_kernel
@pytest.mark.parametrize("shape", RUN_SHAPES)
def test_free_run_by_rows_is_grey_run(shape):
    """The validation's and the predictions' free run in C, a row at a time, against
    ``lax.scan``: the forward half of the window's bound (T (nz + n + 4) eps, x4)."""
    nx, n, b, t = shape
    with jax.enable_x64(True):
        p, x0, u, phi = _free_run_case(nx, n, b, t, seed=sum(shape))
        ref = np.asarray(grey_run({k: jnp.asarray(v) for k, v in p.items()}, jnp.asarray(u),
                                  jnp.asarray(phi), jnp.asarray(x0), 0.05, -0.1))
    got = gk.free_run_rows(p, u, phi, x0, 0.05, -0.1)
    assert got.shape == ref.shape == (t, b) and got.dtype == np.float64
    assert np.max(np.abs(got - ref)) <= _tolerance(nx, n, t, jnp.float64) / 2 * np.max(
        np.abs(ref))
    # and a weight off by 1e-6 is far outside it (the comparison can fail)
    q = dict(p, W2=p["W2"] + np.eye(*p["W2"].shape) * 1e-6)
    if t > 1:
        off = gk.free_run_rows(q, u, phi, x0, 0.05, -0.1)
        assert np.max(np.abs(off - got)) > 10 * _tolerance(nx, n, t, jnp.float64) / 2 * np.max(
            np.abs(ref))


def test_free_run_takes_a_few_rows_and_says_none_otherwise(monkeypatch):
    p, x0, u, phi = _free_run_case(4, 9, gk.FREE_RUN_ROWS + 1, 20, seed=5)
    # more rows than FREE_RUN_ROWS: lax.scan's products over the rows are as fast
    assert gk.free_run_rows(p, u, phi, x0, 0.0, 0.0) is None
    with jax.enable_x64(True):
        ref = np.asarray(grey_run({k: jnp.asarray(v) for k, v in p.items()}, jnp.asarray(u),
                                  jnp.asarray(phi), jnp.asarray(x0), 0.0, 0.0))
        assert np.array_equal(grey_free_run(p, u, phi, x0, 0.0, 0.0), ref)
        # the kernel turned off: lax.scan for one row too
        monkeypatch.setenv(gk.KERNEL_ENV, "jax")
        one = (u[:, :1], phi[:, :1], x0[:1], 0.0, 0.0)
        assert gk.free_run_rows(p, *one) is None
        ref1 = np.asarray(grey_run({k: jnp.asarray(v) for k, v in p.items()},
                                   *(jnp.asarray(a) for a in one[:3]), 0.0, 0.0))
        assert np.array_equal(grey_free_run(p, *one), ref1)


@needs_kernel
def test_free_run_refuses_arrays_that_do_not_match():
    p, x0, u, phi = _free_run_case(4, 9, 2, 20, seed=6)
    with pytest.raises(ROMError, match="do not match"):
        gk.free_run_rows(p, u, phi[:-1], x0, 0.0, 0.0)
    with pytest.raises(ROMError, match="do not match"):
        gk.free_run_rows(p, u, phi, x0[:, :3], 0.0, 0.0)
    with pytest.raises(ROMError, match="W2 has shape"):
        gk.free_run_rows(dict(p, W2=p["W2"][:-1]), u, phi, x0, 0.0, 0.0)
    # the extension checks the byte counts itself: a caller that skips the wrapper
    w = [np.ascontiguousarray(p[k]) for k in gk.WEIGHTS]
    seq = np.zeros((2, 20, 5))
    with pytest.raises(ValueError, match="sizes do not match"):
        gk._MODULE.free_run(*w, x0, seq, np.empty((2, 19)), 4, 5, 9, 20, 2)
    with pytest.raises(ValueError, match="contiguous"):  # no copy behind the caller's back
        gk._MODULE.free_run(*w, x0, seq[:, ::2], np.empty((2, 10)), 4, 5, 9, 10, 2)
    out = gk.free_run_rows(p, u[:0], phi[:0], x0, 0.0, 0.0)  # no samples: no outputs
    assert out.shape == (0, 2)


def test_the_pure_jax_path_is_said_once(monkeypatch, caplog, request):
    monkeypatch.setenv(gk.KERNEL_ENV, "jax")
    gt._note_path.cache_clear()
    request.addfinalizer(gt._note_path.cache_clear)  # the process's later trainings say it
    assert not gk.kernel_available()
    with caplog.at_level(logging.WARNING, logger="sloshrom"):
        gt._note_path()
        gt._note_path()
    lines = [r.getMessage() for r in caplog.records if r.name == "sloshrom"]
    assert len(lines) == 1 and "pure-JAX path" in lines[0]


#: Run by a process with one XLA thread (the environment a Dask worker on one core gets):
#: the kernel's results of every case and the threads it used, written to the file argv[1].
_ONE_THREAD_RUN = """
import sys
import numpy as np
import jax
sys.path.insert(0, sys.argv[2])
from test_kernel import _threaded_cases
with jax.enable_x64(True):
    out, used = _threaded_cases()
np.savez(sys.argv[1], used=np.array(used), **out)
"""


#: The tries of the threaded cases before the test says the blocks never ran on two threads.
_TRIES = 30


def _threaded_cases():
    """Outputs and gradients of windows of several shapes (float64 and float32, batches of 6
    to 20 blocks of rows) by the kernel, and the threads each call used."""
    out, used = {}, []
    for i, (nx, n, b, t) in enumerate([(8, 32, 160, 120), (4, 17, 96, 60)]):
        for dtype in (jnp.float64, jnp.float32):
            p, x0, seq, target = _problem(nx, n, b, t, dtype, 10 + i)
            y = gk.grey_window(p, x0, seq, 0.1, -0.2)
            used.append(gk._MODULE.threads_used())
            loss, (gp, gx) = _loss(lambda p, x, s: gk.grey_window(p, x, s, 0.1, -0.2), seq,
                                   target)(p, x0)
            used.append(gk._MODULE.threads_used())
            key = f"{i}{np.dtype(dtype).name}"
            out[key + "y"], out[key + "x"] = np.asarray(y), np.asarray(gx)
            out |= {key + k: np.asarray(v) for k, v in gp.items()}
    return out, used


@needs_kernel
@pytest.mark.long
@pytest.mark.skipif(len(gt.usable_cores()) < 2, reason="one core: one thread")
def test_blocks_on_several_threads_give_the_one_thread_results(tmp_path):
    """The blocks of rows shared among XLA's threads: the same outputs and gradients to the
    bit as one thread (a process limited to one, as a worker on one core), and more than one
    thread really ran them here."""
    import os
    import subprocess
    import sys
    from pathlib import Path

    # Whether a helper of XLA's pool starts before the calling thread has run every block is
    # the OS's choice (a CI machine under load gave all eight calls to one thread): the cases
    # again, each time to the same bits, until one call has run on several threads.
    with jax.enable_x64(True):
        threaded, used = _threaded_cases()
        for _ in range(_TRIES - 1):
            if max(used) >= 2:
                break
            again, used = _threaded_cases()
            for k, v in threaded.items():
                np.testing.assert_array_equal(again[k], v, err_msg=k)
    pool = gk._MODULE.pool_threads()
    assert max(used) >= 2, f"one thread in {_TRIES} tries; XLA's pool has {pool}"
    env = {**os.environ, "NPROC": "1", "XLA_FLAGS": "--xla_cpu_multi_thread_eigen=false"}
    f = tmp_path / "one.npz"
    subprocess.run([sys.executable, "-c", _ONE_THREAD_RUN, str(f), str(Path(__file__).parent)],
                   env=env, check=True, timeout=300)
    with np.load(f) as one:
        assert set(one["used"].tolist()) == {1}
        assert set(one.files) - {"used"} == set(threaded)
        for k, v in threaded.items():
            np.testing.assert_array_equal(one[k], v, err_msg=k)
