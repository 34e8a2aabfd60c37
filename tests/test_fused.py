"""The state-space ROM's compiled training simulation (sloshrom.rom.fused) against XLA's.

Tolerances are measured, not chosen: a float32 recurrence of T = 200 steps differs from its
float64 run by 1e-6 to 1e-4 (relative, per output or parameter gradient; measured 2e-6 to 2e-4
for XLA's float32 as for these loops). Each check allows the larger of 4x XLA's own float32 error
against float64 in the same case, and T float32 roundings (T * 1.2e-7 = 2.4e-5: the error of a
sum over the recurrence's steps).
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from sloshrom.rom import fused
from sloshrom.rom.statespace import StateSpaceSpec, init_params, strictly_proper

NX, N, B, T = 8, 64, 37, 200  # a batch that is no multiple of the vector width
FLOOR32 = T * float(np.finfo(np.float32).eps)


def _case(proper: bool = True, seed: int = 0):
    spec = StateSpaceSpec(NX, N, 50, proper=proper)
    p = {k: np.asarray(v, np.float64) for k, v in init_params(spec, seed).items()}
    rng = np.random.default_rng(seed)
    # hidden units away from the linear regime, so the tanh derivatives matter
    p["b1"] = 0.3 * rng.standard_normal(N)
    p["d1"] = 0.3 * rng.standard_normal(N)
    p["W1"] = 3.0 * p["W1"]
    if proper:
        p = {k: np.asarray(v) for k, v in strictly_proper(
            {k: jnp.asarray(v) for k, v in p.items()}).items()}
    w = [p[k] for k in fused.WEIGHT_NAMES]
    f0 = 0.01 * rng.standard_normal(NX)
    c0 = np.asarray(-0.2)
    x0 = 0.3 * rng.standard_normal((B, NX))
    u = rng.uniform(-1.0, 1.0, (B, T))
    weight = rng.standard_normal((B, T))
    return w, f0, c0, x0, u, weight


def _xla(w, f0, c0, x0, u):
    p = dict(zip(fused.WEIGHT_NAMES, w, strict=True))

    def body(x, uk):
        z = jnp.concatenate([x, uk[:, None]], axis=-1)
        return (x + z @ p["A"] + jnp.tanh(z @ p["W1"] + p["b1"]) @ p["W2"] - f0,
                z @ p["C"] + jnp.tanh(z @ p["V1"] + p["d1"]) @ p["V2"] + c0)

    return jax.lax.scan(body, x0, u.T)[1].T


def _rel(a, b) -> float:
    a, b = np.asarray(a, np.float64), np.asarray(b, np.float64)
    return float(np.max(np.abs(a - b)) / np.max(np.abs(b)))


def test_tanh32_is_tanh_to_float32_accuracy():
    x = np.linspace(-12.0, 12.0, 200_001).astype(np.float32)
    t = np.array([fused.tanh32(v) for v in x[::50]])
    ref = np.tanh(x[::50].astype(np.float64))
    assert np.max(np.abs(t - ref)) <= 3e-7
    assert np.all(np.abs(t) <= 1.0)
    np.testing.assert_array_equal(t, -t[::-1])  # odd, exactly


@pytest.mark.parametrize("proper", [True, False])
def test_forward_and_gradient_match_xla(proper):
    w, f0, c0, x0, u, weight = _case(proper)
    with jax.enable_x64(True):
        args64 = [jnp.asarray(a, jnp.float64) for a in w], *(jnp.asarray(a, jnp.float64)
                                                              for a in (f0, c0, x0, u))
        args32 = [jnp.asarray(a, jnp.float32) for a in w], *(jnp.asarray(a, jnp.float32)
                                                              for a in (f0, c0, x0, u))
        y64 = np.asarray(_xla(*args64))

        def loss(sim, dtype):
            return lambda *a: jnp.sum(jnp.asarray(weight, dtype) * sim(*a))

        g64 = jax.grad(loss(_xla, jnp.float64), argnums=(0, 1, 2, 3, 4))(*args64)
        g_xla = jax.jit(jax.grad(loss(_xla, jnp.float32), argnums=(0, 1, 2, 3, 4)))(*args32)
        g_fused = jax.jit(jax.grad(loss(fused.simulate, jnp.float32),
                                   argnums=(0, 1, 2, 3, 4)))(*args32)
        y_fused = np.asarray(jax.jit(fused.simulate)(*args32))
        y_xla = np.asarray(jax.jit(_xla)(*args32))
    assert y_fused.dtype == np.float32 and y_fused.shape == (B, T)
    assert _rel(y_fused, y64) <= max(4 * _rel(y_xla, y64), FLOOR32)
    flat64, flat_xla, flat_fused = (jax.tree_util.tree_leaves(g) for g in (g64, g_xla, g_fused))
    for k, (a, b, ref) in enumerate(zip(flat_fused, flat_xla, flat64, strict=True)):
        assert _rel(a, ref) <= max(4 * _rel(b, ref), FLOOR32), k


def test_a_lost_forward_run_is_recomputed():
    # the backward pass finds the forward run's intermediates by ticket; a ticket gone
    # (evicted, another thread's) must give the same gradient, recomputed
    w, f0, c0, x0, u, weight = _case()
    args = [np.asarray(a, np.float32) for a in (*w, f0, c0, x0, u)]
    y, ticket = fused._forward_kept(*args)
    kept = fused._backward_host(*args, ticket, weight.astype(np.float32))
    lost = fused._backward_host(*args, np.asarray(-1, np.int32), weight.astype(np.float32))
    for a, b in zip(kept, lost, strict=True):
        np.testing.assert_array_equal(a, b)


def test_training_loss_and_gradient_unchanged(monkeypatch):
    # the NSS's multiple-shooting loss (encoder, probes, loss terms) with the compiled loops
    # against the same loss on XLA's simulation
    from sloshrom.rom import statespace
    from sloshrom.rom.network import MinMaxScaler
    from sloshrom.rom.shooting import ShootingOptions

    rng = np.random.default_rng(3)
    fs = 500.0
    t = np.arange(20_000) / fs
    u = 0.3 * np.sin(2 * np.pi * 9.0 * t) * (1 + 0.5 * np.sin(2 * np.pi * 0.2 * t))
    y = np.gradient(u) * fs * 0.2 + 0.05 * u**3 + 0.01 * rng.standard_normal(t.size)
    opts = ShootingOptions(horizon=100, batch=16, steps_per_epoch=1, passivity=1.0,
                           cycle_energy=0.1, frequency_band=(5.0, 25.0), probes_per_step=4,
                           velocity_offset=0.5)
    spec = StateSpaceSpec(NX, 16, 20, proper=True)
    sc = MinMaxScaler.fit(u, y)
    out = []
    with jax.enable_x64(True):
        for sim in (fused.simulate, _xla):
            monkeypatch.setattr(statespace.fused, "simulate", sim)
            pr = statespace.shooting_problem(spec, u, y, fs, sc, None, opts, 0)
            draws = tuple(jnp.asarray(a[0]) for a in pr.draw(np.random.default_rng(0)))
            (value, _), g = jax.value_and_grad(pr.loss, has_aux=True)(pr.params0, *draws)
            out.append((float(value), g))
    assert out[0][0] == pytest.approx(out[1][0], rel=1e-5)
    for k in out[0][1]:
        assert _rel(out[0][1][k], out[1][1][k]) <= 1e-4, k
