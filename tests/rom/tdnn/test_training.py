"""Levenberg-Marquardt (trainlm) schedule, stopping rules, Jacobians and small end-to-end fits."""

from __future__ import annotations

import math
from functools import partial

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from sloshrom import rom
from sloshrom.rom import losses
from sloshrom.rom.tdnn import network, training
from sloshrom.rom.tdnn.training import LMProblem, levenberg_marquardt


def _linear_problem(A: np.ndarray, b: np.ndarray, val=None) -> LMProblem:
    """Least squares ``min ||A x - b||^2``: J = A, e = A x - b."""

    def normal_eq(x):
        e = A @ x - b
        return A.T @ A, A.T @ e, float(e @ e), b.size

    def sse(x):
        e = A @ x - b
        return float(e @ e)

    return LMProblem(normal_eq, sse, val)


def test_lm_identifies_linear_fir_to_machine_precision():
    # a linear FIR system, regressors = delayed inputs: linear in the parameters, so LM (Gauss-
    # Newton with a vanishing mu) must land on the exact coefficients
    rng = np.random.default_rng(0)
    u = rng.standard_normal(2000)
    h = rng.standard_normal(8)
    X = np.column_stack([np.concatenate([np.zeros(d), u[:-d]]) for d in range(1, 9)])
    y = X @ h
    res = levenberg_marquardt(_linear_problem(X, y), np.zeros(8), max_epochs=50)
    np.testing.assert_allclose(res.theta, h, rtol=0, atol=1e-12)
    assert res.stop_reason == "min_grad"


def test_lm_mu_decreases_by_10_on_success():
    rng = np.random.default_rng(1)
    A, b = rng.standard_normal((50, 3)), rng.standard_normal(50)
    res = levenberg_marquardt(_linear_problem(A, b), np.ones(3), max_epochs=2, min_grad=0.0)
    np.testing.assert_allclose(res.history["mu"], [1e-3, 1e-4, 1e-5], rtol=1e-12)
    assert res.stop_reason == "max_epochs"


def test_lm_mu_increases_by_10_on_failure_and_retries_within_the_epoch():
    # steps longer than 0.05 are "failures" (sse = inf): mu must grow x10 until the step is short
    rng = np.random.default_rng(2)
    A, b = rng.standard_normal((50, 3)), 10 * rng.standard_normal(50)
    base = _linear_problem(A, b)
    tried = []
    x0 = np.zeros(3)

    def sse(x):
        tried.append(np.linalg.norm(x - current[0]))
        return base.sse(x) if tried[-1] < 0.05 else math.inf

    current = [x0]

    prob = LMProblem(base.normal_eq, sse)
    res = levenberg_marquardt(prob, x0, max_epochs=1)
    # epoch 1: tried with mu = 1e-3, 1e-2, ... until the step is shorter than 0.05
    jtj, jte, _, _ = base.normal_eq(x0)
    expect_mu = 1e-3
    while np.linalg.norm(np.linalg.solve(jtj + expect_mu * np.eye(3), jte)) >= 0.05:
        expect_mu *= 10
    assert len(tried) == round(math.log10(expect_mu / 1e-3)) + 1
    np.testing.assert_allclose(res.history["mu"][-1], expect_mu * 0.1, rtol=1e-12)


def test_lm_stops_at_mu_max_when_nothing_improves():
    A, b = np.eye(2), np.ones(2)
    prob = LMProblem(_linear_problem(A, b).normal_eq, lambda x: math.inf)
    res = levenberg_marquardt(prob, np.zeros(2), max_epochs=100)
    assert res.stop_reason == "mu_max"
    assert len(res.history["mu"]) == 2  # epoch 0 and the one failed epoch
    assert res.history["mu"][-1] > 1e10


def test_lm_early_stopping_after_6_validation_failures_returns_best():
    xs = []

    def val(x):
        xs.append(np.array(x))
        k = len(xs) - 1  # epoch
        return 1.0 / (k + 1) if k <= 3 else 1.0 + k  # best at epoch 3, worse afterwards

    # an over-estimated curvature (100 I for a unit Hessian) makes every step a small success,
    # so only the validation rule can stop the run
    def normal_eq(x):
        return 100 * np.eye(4), x - 1.0, float((x - 1.0) @ (x - 1.0)), 4

    prob = LMProblem(normal_eq, lambda x: float((x - 1.0) @ (x - 1.0)), val)
    res = levenberg_marquardt(prob, np.zeros(4), max_epochs=100, min_grad=0.0)
    assert res.stop_reason == "validation_stop"
    assert len(res.history["val_mse"]) == 3 + 6 + 1  # epochs 0..9
    assert res.best_epoch == 3
    np.testing.assert_array_equal(res.theta, xs[3])


@pytest.mark.parametrize("delays", [(1, 2, 3, 4, 5), (5, 4, 3, 2, 1), (1, 3, 7), (6, 2, 4), (3,),
                                    (2, 3)])
def test_regressors_read_as_windows_are_the_index_form_s(delays):
    # increasing (the usual, reversed windows), decreasing (windows as read), gaps and any order
    # (a static take), one delay, and delays that do not start at 1
    rng = np.random.default_rng(9)
    up = jnp.asarray(rng.standard_normal(60 + max(delays)))
    rows = jnp.asarray(np.concatenate([[0, 59], rng.integers(0, 60, 25)]))
    want = np.asarray(up)[network.row_index(np.asarray(rows), delays)]  # NumPy: no compiling
    got = np.asarray(network.regressors(up, rows, delays))
    assert got.shape == (rows.size, len(delays))
    np.testing.assert_array_equal(got, want)


@jax.enable_x64(True)
@pytest.mark.parametrize("shape", [(9,), (3, 5)])
def test_rbf_rows_is_rbf_apply_with_its_gradient_in_closed_form(shape):
    # a batch (the NFIR's steps) and a batch of windows (its passivity probes)
    rng = np.random.default_rng(11)
    dim, h = 4, 6
    params = {"W": jnp.asarray(rng.standard_normal((h, dim))),
              "b": jnp.asarray(rng.standard_normal(h)),
              "c": jnp.asarray(rng.standard_normal(h)), "c0": jnp.asarray(0.3)}
    X = jnp.asarray(rng.uniform(-1, 1, (*shape, dim)))
    g = jnp.asarray(rng.standard_normal(shape))
    for hidden in ("matlab", "distance"):
        want = np.asarray(network.rbf_apply(params, X, hidden))
        np.testing.assert_allclose(np.asarray(network.rbf_rows(params, X, hidden)), want,
                                   rtol=0, atol=1e-14 * np.max(np.abs(want)))

        def dot(f, p, x, hidden=hidden):
            return jnp.sum(g * f(p, x, hidden))

        want = jax.jit(jax.grad(partial(dot, network.rbf_apply), (0, 1)))(params, X)
        got = jax.jit(jax.grad(partial(dot, network.rbf_rows), (0, 1)))(params, X)
        for a, b in zip(jax.tree.leaves(want), jax.tree.leaves(got), strict=True):
            # the same function rounded otherwise: a few float64 ulps of the largest entry
            scale = float(np.max(np.abs(a)))
            np.testing.assert_allclose(np.asarray(b), np.asarray(a), rtol=0,
                                       atol=1e-13 * scale)


@jax.enable_x64(True)
def test_cycle_energy_of_packed_cycles_is_the_padded_cycles_with_its_gradient():
    # the term on cycles packed one after the other against its first form (each cycle padded
    # to the longest, the network evaluated on every padded row): the same sums in another
    # order, float64
    rng = np.random.default_rng(4)
    fs = 200.0
    t = np.arange(int(4 * fs)) / fs
    u_s = np.sin(2 * np.pi * (5 + 3 * t) * t) * (0.3 + 0.1 * t)
    y_s = 0.5 * np.roll(u_s, 2) + 0.05 * rng.standard_normal(u_s.size)
    delays, neurons = (1, 2, 3, 4), 5
    theta = network.pack({"W": rng.standard_normal((neurons, len(delays))),
                          "b": rng.standard_normal(neurons), "c": rng.standard_normal(neurons),
                          "c0": np.array(0.1)})
    cyc = training.energy_cycles(u_s, fs, (4.0, 40.0))
    idx = rng.integers(0, cyc.n, 7)
    packed = losses.pack_cycles(cyc, idx[None], losses.cycle_slots(cyc, 7))
    up = jnp.asarray(np.concatenate([np.zeros(max(delays)), u_s]))
    ys = jnp.asarray(y_s)

    def padded(th):
        r = cyc.rows[idx]
        e = network.nfir_rows(th, up, r.reshape(-1), delays, neurons, "matlab").reshape(r.shape)
        return jnp.mean(jnp.sum((e - ys[r]) * cyc.weight[idx], axis=-1) ** 2)

    def packed_term(th):
        return training.cycle_energy_error(th, up, ys, packed.rows[0], packed.weight[0],
                                           packed.segment[0], 7, delays, neurons, "matlab")

    (want, gw), (got, gg) = (jax.jit(jax.value_and_grad(f))(theta)
                             for f in (padded, packed_term))
    want, got, gw, gg = float(want), float(got), np.asarray(gw), np.asarray(gg)
    assert want > 0 and got == pytest.approx(want, rel=1e-12, abs=0)
    np.testing.assert_allclose(gg, gw, rtol=0, atol=1e-12 * np.max(np.abs(gw)))
    # another draw is another value: the comparison is not vacuous
    other = losses.pack_cycles(cyc, (idx[None] + 1) % cyc.n, 0)
    assert float(jax.jit(training.cycle_energy_error, static_argnums=(6, 7, 8, 9))(
        theta, up, ys, other.rows[0], other.weight[0], other.segment[0], 7, delays, neurons,
        "matlab")) != pytest.approx(want, rel=1e-6)


@jax.enable_x64(True)  # the trainers' internals follow the caller's precision
def test_nfir_jacobian_matches_finite_differences():
    rng = np.random.default_rng(4)
    delays, h = (1, 2, 3, 5), 3
    p = network.n_params(4, h)
    theta = rng.standard_normal(p)
    u = rng.uniform(-1, 1, 40)
    up = jnp.asarray(np.concatenate([np.zeros(5), u]))
    ys = jnp.asarray(rng.standard_normal(40))
    rows = jnp.arange(10, 20)
    for hidden in ("matlab", "distance"):
        J, e = training._nfir_jac_chunk(jnp.asarray(theta), up, ys, rows, jnp.ones(10), delays,
                                        h, hidden)

        def f(th, hidden=hidden):
            return np.asarray(network.nfir_rows(jnp.asarray(th), up, rows, delays, h, hidden))

        fd = np.empty((10, p))
        for i in range(p):
            d = np.zeros(p)
            d[i] = 1e-6
            fd[:, i] = (f(theta + d) - f(theta - d)) / 2e-6
        np.testing.assert_allclose(np.asarray(J), fd, atol=1e-7)
        np.testing.assert_allclose(np.asarray(e), f(theta) - np.asarray(ys[rows]), atol=1e-14)


@jax.enable_x64(True)
def test_noe_jacobian_through_time_matches_finite_differences_across_chunks():
    rng = np.random.default_rng(5)
    delays, m, h = (1, 2), 2, 3
    p = network.n_params(4, h)
    theta = 0.5 * rng.standard_normal(p)
    n = 37
    u = rng.uniform(-1, 1, n)
    y = rng.uniform(-1, 1, n)
    # chunk 10 (not dividing n) checks the state sensitivities carried between chunks
    prob = training.noe_problem(u, y, delays, m, h, "matlab", 0.1, -0.2, 1e6, chunk=10)
    jtj, jte, sse, nn = prob.normal_eq(theta)

    def sim(th):
        return np.asarray(network.noe_free_run(jnp.asarray(th), jnp.asarray(u), 0.1, -0.2,
                                               delays, m, h, "matlab"))

    fd = np.empty((n, p))
    for i in range(p):
        d = np.zeros(p)
        d[i] = 1e-6
        fd[:, i] = (sim(theta + d) - sim(theta - d)) / 2e-6
    e = sim(theta) - y
    assert nn == n
    np.testing.assert_allclose(sse, e @ e, rtol=1e-12)
    np.testing.assert_allclose(jte, fd.T @ e, rtol=1e-6, atol=1e-8)
    np.testing.assert_allclose(jtj, fd.T @ fd, rtol=1e-6, atol=1e-8)


@jax.enable_x64(True)
@pytest.mark.long
@pytest.mark.parametrize("delays, m, hidden", [((1, 3), 1, "distance"), ((2,), 3, "matlab")])
def test_noe_normal_equations_are_those_of_forward_mode_through_the_free_run(delays, m, hidden):
    # the partial derivatives at every sample and the recurrence through the fed-back outputs
    # give the Jacobian of the whole closed loop (jax.jacfwd of the free run), across chunks
    # (97 not dividing 300) and delay lines: to round-off (measured 1.3e-15 of the largest
    # entry; 1e-12 is a thousand roundings of it)
    rng = np.random.default_rng(6)
    h, n = 4, 300
    p = network.n_params(len(delays) + m, h)
    theta = 0.5 * rng.standard_normal(p)
    u = np.cumsum(rng.standard_normal(n)) * 0.05
    y = np.tanh(u) + 0.1 * rng.standard_normal(n)
    prob = training.noe_problem(u, y, delays, m, h, hidden, 0.1, -0.2, 1e6, chunk=97)
    jtj, jte, sse, _ = prob.normal_eq(theta)

    def run(th):
        return network.noe_free_run(th, jnp.asarray(u), 0.1, -0.2, delays, m, h, hidden)

    J = np.asarray(jax.jacfwd(run)(jnp.asarray(theta)))
    e = np.asarray(run(jnp.asarray(theta))) - y
    np.testing.assert_allclose(sse, e @ e, rtol=1e-12)
    np.testing.assert_allclose(jtj, J.T @ J, rtol=0, atol=1e-12 * np.max(np.abs(J.T @ J)))
    np.testing.assert_allclose(jte, J.T @ e, rtol=0, atol=1e-12 * np.max(np.abs(J.T @ e)))


@jax.enable_x64(True)
@pytest.mark.parametrize("n", [300, 291])
def test_noe_normal_equations_at_a_trial_step_reuse_its_run(n, monkeypatch):
    # Levenberg-Marquardt asks for the normal equations where its last trial run was: the
    # chunks take that run's outputs (a padded last chunk (300 = 3 x 97 + 9) still simulates;
    # 291 = 3 x 97 fills every chunk) and give the simulating chunks' normal equations, to
    # round-off (the same arithmetic on the same values: bit for bit on this machine)
    rng = np.random.default_rng(13)
    delays, m, h = (1, 3), 2, 4
    theta = 0.5 * rng.standard_normal(network.n_params(len(delays) + m, h))
    u = np.cumsum(rng.standard_normal(n)) * 0.05
    y = np.tanh(u) + 0.1 * rng.standard_normal(n)
    reused = []
    chunk_fn = training._noe_jac_chunk

    def spy(*args, y_sim=None, **kw):
        reused.append(y_sim is not None)
        return chunk_fn(*args, y_sim=y_sim, **kw)

    monkeypatch.setattr(training, "_noe_jac_chunk", spy)
    prob = training.noe_problem(u, y, delays, m, h, "matlab", 0.1, -0.2, 1e6, chunk=97)
    simulated = prob.normal_eq(theta)
    assert reused == [False] * -(-n // 97)
    reused.clear()
    prob.sse(theta)
    from_run = prob.normal_eq(theta)
    assert reused == [True, True, True] + [False] * (n == 300)
    reused.clear()
    prob.sse(theta + 1e-3)  # another step's run is not taken for this one
    again = prob.normal_eq(theta)
    assert not any(reused)
    for a, b, c in zip(simulated, from_run, again, strict=True):
        a = np.asarray(a)
        tol = 1e-14 * max(float(np.max(np.abs(a))), 1e-300)
        np.testing.assert_allclose(np.asarray(b), a, rtol=0, atol=tol)
        np.testing.assert_array_equal(np.asarray(c), a)


def _system(u):
    """A nonlinear FIR test system (saturating + quadratic on a decaying impulse response)."""
    h = np.exp(-np.arange(1, 16) / 4.0)
    lin = np.convolve(np.concatenate([[0.0], u[:-1]]), h)[: u.size]
    return np.tanh(lin) + 0.3 * lin**2


def _signal(n, seed):
    from scipy.signal import butter, filtfilt

    b, a = butter(4, 0.08)
    return 3 * filtfilt(b, a, np.random.default_rng(seed).standard_normal(n))


@pytest.mark.filterwarnings("ignore::sloshrom.rom.EnvelopeWarning")
@pytest.mark.parametrize("trainer", ["fast", "lm"])
def test_nfir_fit_reduces_validation_error(trainer):
    u, uv = _signal(3000, 1), _signal(1500, 2)
    y, yv = _system(u), _system(uv)
    m = rom.NFIR(delays=15, neurons=6, max_epochs=15, trainer=trainer).fit(
        u, y, fs=100.0, validation=(uv, yv)
    )
    hist = m.history_
    assert hist["val_mse"][m.history_["best_epoch"]] < 0.5 * hist["val_mse"][0]
    # the returned network is the best-validation one
    np.testing.assert_allclose(np.mean((m.predict(uv) - yv) ** 2), min(hist["val_mse"]),
                               rtol=1e-9)


@pytest.mark.filterwarnings("ignore::sloshrom.rom.EnvelopeWarning")
def test_noe_fit_reduces_simulation_error():
    u, uv = _signal(2000, 3), _signal(1000, 4)
    y, yv = _system(u), _system(uv)
    m = rom.NOE(delays=2, neurons=5, max_epochs=8).fit(u, y, fs=100.0, validation=(uv, yv))
    assert min(m.history_["val_mse"]) < m.history_["val_mse"][0]
    np.testing.assert_allclose(np.mean((m.predict(uv) - yv) ** 2), min(m.history_["val_mse"]),
                               rtol=1e-9)


def test_callback_called_every_epoch():
    u = _signal(800, 5)
    calls = []
    m = rom.NFIR(delays=5, neurons=3, max_epochs=3).fit(u, _system(u), fs=100.0,
                                                         callback=lambda e, info: calls.append(e))
    assert calls == [0, 1, 2, 3]
    for k in ("train_mse", "val_mse", "mu", "grad", "seconds"):
        assert len(m.history_[k]) == 4
    assert m.history_["stop_reason"] == "max_epochs" and m.history_["train_seconds"] > 0


def test_callback_returning_true_stops():
    u = _signal(800, 6)
    m = rom.NFIR(delays=5, neurons=3, max_epochs=50).fit(u, _system(u), fs=100.0,
                                                          callback=lambda e, info: e >= 2)
    assert m.history_["stop_reason"] == "callback" and len(m.history_["mu"]) == 3


@pytest.mark.filterwarnings("ignore::sloshrom.rom.EnvelopeWarning")
@pytest.mark.long
def test_adam_trainer_early_stopping_and_best_network():
    u, uv = _signal(3000, 7), _signal(1500, 8)
    y, yv = _system(u), _system(uv)
    m = rom.NFIR(delays=15, neurons=6, max_epochs=40, trainer="adam").fit(
        u, y, fs=100.0, validation=(uv, yv)
    )
    h = m.history_
    assert h["trainer"] == "adam"
    assert h["val_mse"][h["best_epoch"]] < 0.5 * h["val_mse"][0]
    assert h["val_mse"][h["best_epoch"]] == min(h["val_mse"])
    np.testing.assert_allclose(np.mean((m.predict(uv) - yv) ** 2), min(h["val_mse"]), rtol=1e-9)


@pytest.mark.filterwarnings("ignore::sloshrom.rom.EnvelopeWarning")
def test_adam_validation_stop_returns_the_best_network():
    # validation targets of the opposite sign: the better the fit to the training record, the
    # worse the validation error, so the stop after 6 epochs without a new best must happen
    u, uv = _signal(3000, 7), _signal(1500, 8)
    y, yv = _system(u), -_system(uv)
    m = rom.NFIR(delays=15, neurons=6, max_epochs=200, trainer="adam").fit(
        u, y, fs=100.0, validation=(uv, yv)
    )
    h = m.history_
    assert h["stop_reason"] == "validation_stop"
    assert len(h["val_mse"]) - 1 == h["best_epoch"] + 6
    assert h["val_mse"][h["best_epoch"]] == min(h["val_mse"])
    # the returned network is the best-validation one, not the last one
    np.testing.assert_allclose(np.mean((m.predict(uv) - yv) ** 2), min(h["val_mse"]), rtol=1e-9)
    assert min(h["val_mse"]) < h["val_mse"][-1]


@jax.enable_x64(True)
def test_optax_adam_is_the_textbook_adam_with_eps_outside_the_root():
    # what adam_nfir relies on: optax.adam(lr, b1, b2, eps) = Kingma & Ba, Algorithm 1
    import optax

    rng = np.random.default_rng(9)
    A, b = rng.standard_normal((20, 4)), rng.standard_normal(20)

    def loss(x):
        return jnp.mean((A @ x - b) ** 2)

    opt = optax.adam(1e-2, b1=0.9, b2=0.999, eps=1e-8)
    x, state = jnp.zeros(4), opt.init(jnp.zeros(4))
    y, m, v = np.zeros(4), np.zeros(4), np.zeros(4)
    for t in range(1, 51):
        upd, state = opt.update(jax.grad(loss)(x), state, x)
        x = optax.apply_updates(x, upd)
        g = np.asarray(jax.grad(loss)(jnp.asarray(y)))
        m, v = 0.9 * m + 0.1 * g, 0.999 * v + 0.001 * g**2
        y = y - 1e-2 * (m / (1 - 0.9**t)) / (np.sqrt(v / (1 - 0.999**t)) + 1e-8)
    np.testing.assert_allclose(np.asarray(x), y, rtol=1e-12, atol=1e-15)


def test_train_takes_the_architecture_explicitly():
    u = _signal(800, 10)
    y = _system(u)
    spec = network.NetworkSpec("nfir", (1, 2, 3), 3)
    sc = network.MinMaxScaler.fit(u, y)
    theta, hist = training.train(spec, u, y, sc, trainer="lm", max_epochs=2)
    assert theta.shape == (spec.n_params,) and hist["trainer"] == "lm"
    assert len(hist["train_mse"]) == 3
    with pytest.raises(rom.ROMError, match="trainer"):
        training.train(spec, u, y, sc, trainer="sgd")
    with pytest.raises(rom.ROMError, match="needs trainer 'adam'"):
        training.train(network.NetworkSpec("noe", (1, 2), 3, out_delays=2), u, y, sc,
                       trainer="lm", fs=100.0, passivity=1.0)


@pytest.mark.filterwarnings("ignore::sloshrom.rom.EnvelopeWarning")
@pytest.mark.long
def test_float32_adam_steps_train_the_float64_network(tmp_path):
    # the two precisions follow one trajectory: float32 round-off (6e-8 a step) moves the
    # network by 1.2e-4 of the force's peak on the default run (and by 9e-5 from one CPU to
    # another); 1e-3 here. More than 1e-9: the float32 path is taken (two float64 runs agree
    # to 1e-12 across CPUs), so the option is not a no-op
    u, uv = _signal(3000, 7), _signal(1500, 8)
    y, yv = _system(u), _system(uv)
    runs = {p: rom.NFIR(delays=15, neurons=6, max_epochs=4, trainer="adam", precision=p).fit(
        u, y, fs=100.0, validation=(uv, yv)) for p in ("float64", "float32")}
    p64, p32 = (np.asarray(runs[p].predict(uv)) for p in ("float64", "float32"))
    moved = np.max(np.abs(p32 - p64)) / np.max(np.abs(p64))
    assert 1e-9 < moved < 1e-3, moved
    assert runs["float32"].history_["best_epoch"] == runs["float64"].history_["best_epoch"]
    assert all(v.dtype == np.float64 for v in runs["float32"].params_.values())
    back = rom.load_model(runs["float32"].save(tmp_path / "nfir32.npz"))
    assert back.precision == "float32"
    np.testing.assert_array_equal(back.predict(uv), p32)


@pytest.mark.filterwarnings("ignore::sloshrom.rom.EnvelopeWarning")
def test_levenberg_marquardt_runs_float64_whatever_the_precision():
    # precision is the Adam steps': a configuration's float32 ([rom.nfir] of reproduce and
    # train) leaves an LM training as it was, to the bit
    u, uv = _signal(1500, 7), _signal(600, 8)
    for trainer in ("lm", "fast"):
        p = [rom.NFIR(delays=5, neurons=3, max_epochs=2, trainer=trainer, precision=prec).fit(
             u, _system(u), fs=100.0, validation=(uv, _system(uv))).predict(uv)
             for prec in ("float64", "float32")]
        np.testing.assert_array_equal(p[0], p[1])
    with pytest.raises(rom.ROMError, match="precision"):
        rom.NFIR(delays=15, neurons=6, precision="float16").fit(u, _system(u), fs=100.0)
