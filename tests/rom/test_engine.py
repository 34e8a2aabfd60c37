"""The training engine (:mod:`sloshrom.rom.engine`): one compiled epoch, early stopping, history."""

from __future__ import annotations

import dataclasses
import math

import jax
import jax.numpy as jnp
import numpy as np
import optax
import pytest

from helpers import compiled_programs
from sloshrom.rom.engine import AdamProblem, SharedJit, adam_epochs, epoch_program

STEPS = 5


def _linear_problem(validate=None, lr=0.05, noise=0.0):
    """Least squares y = X w on a fixed record: minibatches of 8 rows per step."""
    rng = np.random.default_rng(0)
    X = rng.standard_normal((200, 3))
    w_true = np.array([1.0, -2.0, 0.5])
    y = X @ w_true + noise * rng.standard_normal(200)
    Xj, yj = jnp.asarray(X), jnp.asarray(y)

    def loss(w, data, rows):
        Xd, yd = data
        e = Xd[rows] @ w - yd[rows]
        return jnp.mean(e**2), jnp.mean(e**2)

    def draw(g):
        return (g.integers(0, 200, (STEPS, 8)),)

    return (AdamProblem(loss, jnp.zeros(3), optax.adam(lr), draw, validate, data=(Xj, yj)),
            X, y, w_true)


def test_epoch_program_is_the_loop_of_its_steps():
    with jax.enable_x64(True):
        problem, *_ = _linear_problem()
        rows = np.random.default_rng(1).integers(0, 200, (STEPS, 8))
        opt = problem.optimizer
        p, s, mse = epoch_program(problem.loss, opt)(problem.params0,
                                                     opt.init(problem.params0),
                                                     (jnp.asarray(rows),), problem.data)
        q, t, mses = problem.params0, opt.init(problem.params0), []
        for r in rows:
            (_, m), g = jax.value_and_grad(problem.loss, has_aux=True)(q, problem.data,
                                                                       jnp.asarray(r))
            upd, t = opt.update(g, t, q)
            q = optax.apply_updates(q, upd)
            mses.append(float(m))
        np.testing.assert_allclose(np.asarray(p), np.asarray(q), rtol=1e-12, atol=1e-14)
        assert float(mse) == pytest.approx(np.mean(mses), rel=1e-12)


def _problem_on(X, y):
    """A least-squares problem on the record ``X``, ``y``: a new loss closure each call, the
    record as the problem's data."""

    def loss(w, data, rows):
        e = data[0][rows] @ w - data[1][rows]
        return jnp.mean(e**2), jnp.mean(e**2)

    n = X.shape[0]
    return AdamProblem(loss, jnp.zeros(X.shape[1]), optax.adam(0.05),
                       lambda g: (g.integers(0, n, (STEPS, 8)),),
                       data=(jnp.asarray(X), jnp.asarray(y)))


def _steps_by_hand(problem, epochs, seed=0):
    """The parameters after ``epochs`` epochs of the problem's Adam steps, one step at a time
    (no compiled epoch): the engine's draws from the same seed."""
    rng = np.random.default_rng(seed)
    opt = problem.optimizer
    q, t = problem.params0, opt.init(problem.params0)
    for _ in range(epochs):
        for r in problem.draw(rng)[0]:
            g = jax.grad(lambda w, r=r: problem.loss(w, problem.data, jnp.asarray(r))[0])(q)
            upd, t = opt.update(g, t, q)
            q = optax.apply_updates(q, upd)
    return np.asarray(q)


def test_trainings_on_other_arrays_share_one_compiled_epoch():
    """Two trainings whose losses are other closures over other records of one shape (an
    ensemble's members) compile one epoch program; each still trains on its own record."""
    rng = np.random.default_rng(7)
    X1, X2 = rng.standard_normal((2, 173, 3))  # a shape no other test of the module trains
    with jax.enable_x64(True):
        a = _problem_on(X1, X1 @ np.array([1.0, -2.0, 0.5]))
        b = _problem_on(X2, X2 @ np.array([-0.5, 1.0, 3.0]))
        with compiled_programs() as first:
            ra = adam_epochs(a, max_epochs=3)
        with compiled_programs() as second:
            rb = adam_epochs(b, max_epochs=3)
        # the engine returns its best epoch's parameters
        hand_a, hand_b = _steps_by_hand(a, ra.best_epoch), _steps_by_hand(b, rb.best_epoch)
    assert first.count("jit(epoch)") == 1
    assert second.count("jit(epoch)") == 0
    np.testing.assert_allclose(np.asarray(ra.params), hand_a, rtol=1e-12, atol=1e-14)
    np.testing.assert_allclose(np.asarray(rb.params), hand_b, rtol=1e-12, atol=1e-14)
    assert ra.best_epoch > 0 and rb.best_epoch > 0
    assert np.max(np.abs(hand_a - hand_b)) > 0.1


def test_a_closure_over_an_array_is_its_own_program():
    """An array a function closes over is a constant of its program: two such functions that
    differ only in it never share a compilation (each gives its own result)."""

    def times(c):
        cj = jnp.asarray(c)
        return SharedJit(lambda x: x * cj)

    x = jnp.ones(1000)
    two, three = times(np.full(1000, 2.0)), times(np.full(1000, 3.0))
    np.testing.assert_array_equal(np.asarray(two(x)), 2.0)
    np.testing.assert_array_equal(np.asarray(three(x)), 3.0)
    # another shape or dtype: another program of the same function
    np.testing.assert_array_equal(np.asarray(two(jnp.ones(1000, jnp.int32))), 2.0)


def test_converges_and_records_every_epoch():
    with jax.enable_x64(True):
        problem, X, y, w_true = _linear_problem()
        res = adam_epochs(problem, max_epochs=60, seed=0, mse_scale=4.0)
    np.testing.assert_allclose(np.asarray(res.params), w_true, atol=0.05)
    h = res.history
    assert set(h) == {"train_mse", "val_mse", "val_objective", "seconds", "step_seconds",
                      "validation_seconds"}
    assert h["step_seconds"][0] < h["step_seconds"][1]  # epoch 0 runs no step
    assert np.all(np.diff(h["seconds"]) > 0)
    assert all(len(v) == 61 for v in h.values())
    assert math.isnan(h["train_mse"][0]) and h["val_objective"][0] == math.inf
    # without validation the objective is the epoch's training mse, in scaled units; the
    # history's mse is scaled by mse_scale
    assert h["val_mse"][-1] == pytest.approx(4.0 * h["val_objective"][-1])
    assert res.stop_reason == "max_epochs"
    assert res.best_epoch == int(np.nanargmin(h["val_objective"]))


def test_early_stopping_returns_the_best_epoch():
    # a validation objective that is best at epoch 3 and worse after it
    calls = []

    def validate(w):
        k = len(calls)
        calls.append(k)
        return float(k), float(abs(k - 3)) + 1.0

    with jax.enable_x64(True):
        problem, *_ = _linear_problem(validate)
        seen = []
        res = adam_epochs(problem, max_epochs=50, max_fail=4,
                          callback=lambda e, info: seen.append(np.asarray(0)) and False)
    assert res.stop_reason == "validation_stop"
    assert res.best_epoch == 3
    assert len(res.history["val_objective"]) == 3 + 4 + 1  # epochs 0..7
    assert len(seen) == 8


def test_no_early_stop_before_min_epochs():
    # the objective of test_early_stopping_returns_the_best_epoch: with min_epochs 20 the run
    # goes on to epoch 20, and the best epoch is still 3
    calls = []

    def validate(w):
        k = len(calls)
        calls.append(k)
        return float(k), float(abs(k - 3)) + 1.0

    with jax.enable_x64(True):
        problem, *_ = _linear_problem(validate)
        res = adam_epochs(problem, max_epochs=50, max_fail=4, min_epochs=20)
    assert res.stop_reason == "validation_stop" and res.best_epoch == 3
    assert len(res.history["val_objective"]) == 21  # epochs 0..20


def test_a_blow_up_continues_from_the_best_epoch():
    # the validation objective explodes at epoch 4: with rollback the next epoch starts from
    # epoch 3's parameters (the best), without it from epoch 4's
    seen = []

    def validate(w):
        seen.append(np.asarray(w).copy())
        k = len(seen) - 1
        return 1.0, (100.0 if k == 4 else 1.0 / (k + 1))

    starts = {}
    for rb in (None, 10.0):
        seen.clear()
        with jax.enable_x64(True):
            problem, *_ = _linear_problem(validate)
            res = adam_epochs(problem, max_epochs=6, rollback=rb)
        starts[rb] = [w.copy() for w in seen]
        assert res.best_epoch == 6
    # epoch 5 trains from epoch 3's parameters with rollback: it differs from the run without
    np.testing.assert_array_equal(starts[None][4], starts[10.0][4])
    assert not np.array_equal(starts[None][5], starts[10.0][5])
    # a moderate rise (below 10x the best) does not roll back
    assert np.array_equal(starts[None][3], starts[10.0][3])


def test_the_best_parameters_are_those_of_the_best_epoch():
    snapshots = []

    def validate(w):
        snapshots.append(np.asarray(w).copy())
        return 0.0, [5.0, 4.0, 1.0, 3.0, 2.0, 6.0][len(snapshots) - 1]

    with jax.enable_x64(True):
        problem, *_ = _linear_problem(validate)
        res = adam_epochs(problem, max_epochs=5, max_fail=10)
    assert res.best_epoch == 2 and res.stop_reason == "max_epochs"
    np.testing.assert_array_equal(np.asarray(res.params), snapshots[2])


def test_callback_stops_and_constant_keys_are_recorded():
    with jax.enable_x64(True):
        problem, *_ = _linear_problem()
        res = adam_epochs(problem, max_epochs=20, callback=lambda e, info: e == 2,
                          constant_history={"mu": math.nan})
    assert res.stop_reason == "callback"
    assert len(res.history["mu"]) == 3 and all(math.isnan(v) for v in res.history["mu"])


def test_a_diverging_training_stops_and_keeps_its_last_finite_best():
    def loss(w, data, rows):
        # unbounded below: gradient descent drives it to -inf, and the epoch's mse with it
        e = -jnp.exp(10.0 * jnp.sum(w)) * jnp.ones(rows.shape)
        return jnp.mean(e), jnp.mean(e)

    problem = AdamProblem(loss, jnp.zeros(2), optax.sgd(1.0),
                          lambda g: (g.integers(0, 9, (STEPS, 4)),), None)
    with jax.enable_x64(True):
        res = adam_epochs(problem, max_epochs=10)
    assert res.stop_reason == "diverged"
    assert np.all(np.isfinite(np.asarray(res.params)))


def test_patience_without_validation_is_optional():
    with jax.enable_x64(True):
        problem, *_ = _linear_problem(lr=0.0)
        # no learning and the same rows at every step: every epoch's objective is the same
        problem = dataclasses.replace(problem, draw=lambda g: (np.zeros((STEPS, 8), int),))
        a = adam_epochs(problem, max_epochs=30, max_fail=3)
        b = adam_epochs(problem, max_epochs=30, max_fail=3, patience_without_validation=True)
    assert a.stop_reason == "max_epochs"
    assert b.stop_reason == "validation_stop"


def test_same_seed_same_result_other_seed_other_draws():
    with jax.enable_x64(True):
        problem, *_ = _linear_problem(noise=0.5)
        a = adam_epochs(problem, max_epochs=3, seed=4)
        b = adam_epochs(problem, max_epochs=3, seed=4)
        c = adam_epochs(problem, max_epochs=3, seed=5)
    np.testing.assert_array_equal(np.asarray(a.params), np.asarray(b.params))
    assert not np.array_equal(np.asarray(a.params), np.asarray(c.params))


def test_a_validation_plateau_stops_the_training():
    # the objective falls by 10 % an epoch up to epoch 6, then by 0.2 %: with plateau (3, 1 %)
    # the run stops at the first epoch whose best is within 1 % of the best 3 epochs before
    # (epoch 9), from min_epochs on, and returns its best epoch; without, it runs to the end
    def objective(k):
        return 0.9 ** min(k, 6) * 0.998 ** max(0, k - 6)

    def run(**kw):
        calls = []

        def validate(w):
            calls.append(len(calls))
            return 1.0, objective(calls[-1])

        with jax.enable_x64(True):
            problem, *_ = _linear_problem(validate)
            return adam_epochs(problem, max_epochs=20, max_fail=4, **kw)

    res = run(plateau=(3, 0.01), min_epochs=2)
    assert res.stop_reason == "validation_plateau" and res.best_epoch == 9
    assert len(res.history["val_objective"]) == 10
    late = run(plateau=(3, 0.01), min_epochs=12)
    assert late.stop_reason == "validation_plateau" and late.best_epoch == 12
    assert run(min_epochs=2).stop_reason == "max_epochs"
