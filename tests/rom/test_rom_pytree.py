"""ROMs as JAX pytrees: leaves and static part, one compilation per architecture, gradients of a
coupled simulation with respect to the ROM parameters, float64 without a global switch."""

from __future__ import annotations

import copy
import dataclasses
import subprocess
import sys
import textwrap

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from sloshrom.beam.simulation import coupled
from sloshrom.beam.simulation.coupled import CoupledSimulator, discretise, simulate_jax
from sloshrom.config import Tank
from sloshrom.models import SloshingModel, has_kernel, is_jax_model
from sloshrom.rom.network import MinMaxScaler
from sloshrom.rom.tdnn.estimators import NFIR, NOE


def _model(cls=NFIR, seed=0, scale=1.0, **kw):
    """A 'fitted' model with random parameters."""
    kw = {"delays": 3, "neurons": 4, **kw}
    m = cls(**kw)
    rng = np.random.default_rng(seed)
    h, d = m.neurons, m.n_inputs
    params = {"W": rng.standard_normal((h, d)), "b": rng.standard_normal(h),
              "c": scale * rng.standard_normal(h), "c0": np.float64(rng.standard_normal())}
    envelope = {"input_min": -0.5, "input_max": 0.7, "output_min": -3.0, "output_max": 2.0,
                "frequency_band": [5.0, 25.0]}
    return cls.fitted(params, MinMaxScaler(-0.5, 0.7, -3.0 * scale, 2.0 * scale), 500.0,
                      envelope, **m.get_params())


@pytest.fixture(scope="module")
def modal(builtin_modal):
    return builtin_modal


@pytest.mark.parametrize("cls", [NFIR, NOE])
def test_parameters_are_leaves_hyperparameters_static(cls):
    m = _model(cls)
    leaves, treedef = jax.tree_util.tree_flatten(m)
    assert len(leaves) == 4 + 4  # W, b, c, c0 and the scaler's four bounds
    assert is_jax_model(m) and isinstance(m, SloshingModel) and m.force_rule == "trapezoid"
    # same hyperparameters, other weights: the same tree structure (the jit cache key)
    assert jax.tree_util.tree_structure(_model(cls, seed=1)) == treedef
    assert jax.tree_util.tree_structure(_model(cls, neurons=5)) != treedef
    back = jax.tree_util.tree_unflatten(treedef, leaves)
    assert type(back) is cls and back.get_params() == m.get_params() and back.fs_ == m.fs_
    u = np.linspace(-0.4, 0.6, 40)
    np.testing.assert_array_equal(back.predict(u), m.predict(u))
    # an unfitted model is not a sloshing model (dt raises NotFittedError, an AttributeError)
    assert not isinstance(cls(), SloshingModel)


def test_step_reads_the_leaves_under_jit():
    m1, m2 = _model(seed=1), _model(seed=2)

    @jax.jit
    def run(model, v):
        return jax.lax.scan(lambda s, x: model.step(s, x, 0.0), model.init_state(), v)[1]

    u = np.linspace(-0.4, 0.6, 30)
    with jax.enable_x64(True):
        y1, y2 = np.asarray(run(m1, jnp.asarray(u))), np.asarray(run(m2, jnp.asarray(u)))
    np.testing.assert_allclose(y1, m1.predict(u), rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(y2, m2.predict(u), rtol=1e-12, atol=1e-12)
    assert run._cache_size() == 1


def test_one_compilation_per_architecture_and_shape(modal):
    a = np.sin(2 * np.pi * 9 * np.arange(400) / 500.0)
    one = coupled._jitted(1, False)  # the single-run scan (unroll 1, the default)
    n0 = one._cache_size()
    r1 = CoupledSimulator(_model(seed=1), modal).run_raw(a)
    assert one._cache_size() == n0 + 1
    # other weights and another scaler, same hyperparameters and record length: no new compile
    r2 = CoupledSimulator(_model(seed=2, scale=3.0), modal).run_raw(a)
    assert one._cache_size() == n0 + 1
    assert not np.allclose(r1["dynamic_force"], r2["dynamic_force"])
    # another architecture: one more
    CoupledSimulator(_model(seed=1, neurons=6), modal).run_raw(a)
    assert one._cache_size() == n0 + 2


def test_models_that_differ_only_in_their_training_share_one_compilation(modal):
    # an ensemble's members: the same architecture, another seed (a hyperparameter, in the
    # estimator's static part), coupled one at a time by the beam stage
    a = np.sin(2 * np.pi * 9 * np.arange(401) / 500.0)  # a length no other test simulates
    m1, m2 = _model(seed=1), _model(seed=2)
    m2.set_params(seed=5, max_epochs=3)
    assert jax.tree_util.tree_structure(m1) != jax.tree_util.tree_structure(m2)
    one = coupled._jitted(1, False)
    n0 = one._cache_size()
    CoupledSimulator(m1, modal).run_raw(a)
    r2 = CoupledSimulator(m2, modal).run_raw(a)
    assert one._cache_size() == n0 + 1
    # the fitted network steps as its estimator: the same program, to the bit
    sim = CoupledSimulator(m2, modal)
    with jax.enable_x64(True):
        ref = jax.jit(simulate_jax)(m2, sim.disc, jnp.asarray(a), jnp.zeros(2 * modal.n_modes))
    np.testing.assert_array_equal(r2["dynamic_force"], np.asarray(ref["dynamic_force"]))
    np.testing.assert_array_equal(r2["q"], np.asarray(ref["q"]))
    assert m2.stepper is m2.model_


@pytest.mark.long
def test_grad_of_coupled_response_matches_finite_differences(modal):
    m = _model(seed=3, scale=5.0)  # forces of a few N: a visible effect on the beam
    tank = Tank()
    disc = discretise(modal, tank.liquid_mass, m.dt)
    z0 = np.concatenate([modal.static_tip_state(0.0146), np.zeros(modal.n_modes)])
    a = np.zeros(250)

    def loss(model):
        out = simulate_jax(model, disc, a, z0)
        return jnp.sum(out["tank_acceleration"] ** 2)

    def perturbed(name, index, h):
        params = {k: np.array(v, dtype=np.float64) for k, v in m.params_.items()}
        params[name][index] += h
        p = copy.copy(m)
        p.model_ = dataclasses.replace(m.model_, params=params)
        return p

    with jax.enable_x64(True):
        g = jax.jit(jax.grad(loss))(m)
        assert type(g) is NFIR and g.params_["W"].shape == m.params_["W"].shape
        for name, index in (("c", (0,)), ("W", (1, 2)), ("b", (3,))):
            h = 1e-6
            fd = (float(loss(perturbed(name, index, h))) - float(loss(perturbed(name, index, -h)))
                  ) / (2 * h)
            got = float(g.params_[name][index])
            assert abs(fd) > 1e-6, (name, fd)
            assert got == pytest.approx(fd, rel=1e-5), (name, got, fd)
        # the gradient also runs outside jit and agrees
        g2 = jax.grad(loss)(m)
        np.testing.assert_allclose(g2.params_["c"], g.params_["c"], rtol=1e-10)


def test_simulator_uses_simulate_jax(modal):
    m = _model(seed=4, scale=0.5)
    a = 0.5 * np.sin(2 * np.pi * 9 * np.arange(300) / 500.0)
    raw = CoupledSimulator(m, modal).run_raw(a)
    disc = discretise(modal, Tank().liquid_mass, m.dt)
    with jax.enable_x64(True):
        out = simulate_jax(m, disc, a, np.zeros(2 * modal.n_modes))
    for k in ("tank_acceleration", "dynamic_force", "interface_force", "q"):
        np.testing.assert_allclose(raw[k], np.asarray(out[k]), rtol=1e-12, atol=1e-15)
    py = CoupledSimulator(m, modal, backend="python").run_raw(a)
    np.testing.assert_allclose(raw["tank_acceleration"], py["tank_acceleration"], rtol=1e-9,
                               atol=1e-12)


def test_backend_by_protocol(modal):
    from sloshrom.models import FrozenLiquid

    class Plain:  # the contract only: Python loop
        dt, force_rule = 1 / 500, "trapezoid"

        def init_state(self):
            return np.zeros(0)

        def step(self, state, velocity, acceleration):
            return state, 0.0

        def simulate(self, velocity, acceleration):
            return np.zeros_like(velocity)

    class Declined(Plain):  # has the attribute but declares it False
        jax_traceable = False

    assert CoupledSimulator(_model(), modal).backend == "jax"
    assert CoupledSimulator(FrozenLiquid(1 / 500), modal).backend == "jax"
    assert CoupledSimulator(Plain(), modal).backend == "python"
    assert CoupledSimulator(Declined(), modal).backend == "python"
    with pytest.raises(ValueError, match="jax backend"):
        CoupledSimulator(Plain(), modal, backend="jax")
    with pytest.raises(ValueError, match="numba backend"):
        CoupledSimulator(_model(), modal, backend="numba")
    assert not has_kernel(_model())


@pytest.mark.long
def test_no_global_x64_switch_and_float64_results():
    code = textwrap.dedent("""
        import warnings
        import numpy as np
        import jax
        import sloshrom
        from sloshrom.beam.simulation.coupled import free_response
        from sloshrom.beam.simulation.structure import ModalModel
        from sloshrom.rom.tdnn.estimators import NFIR
        from sloshrom.rom import onnx
        from sloshrom.rom.tdnn import training
        assert not jax.config.jax_enable_x64, "import flipped jax_enable_x64"
        t = np.arange(1500) / 500.0
        u = 0.3 * np.sin(2 * np.pi * 4 * t) * np.sin(np.pi * t / t[-1])
        y = np.tanh(3 * np.roll(u, 2))
        m = NFIR(delays=4, neurons=3, max_epochs=2, trainer="lm").fit(u, y, fs=500.0)
        assert not jax.config.jax_enable_x64, "fit flipped jax_enable_x64"
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            p = m.predict(u)
            r = free_response(m, ModalModel.from_beam(), duration=0.2)
        assert not jax.config.jax_enable_x64, "predict/coupled flipped jax_enable_x64"
        assert p.dtype == np.float64 and r["tank_acceleration"].dtype == np.float64
        assert all(np.asarray(v).dtype == np.float64 for v in m.params_.values())
        assert jax.numpy.ones(1).dtype == np.float32  # the user's JAX is untouched
        print("ok")
    """)
    res = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         timeout=300)
    assert res.returncode == 0 and res.stdout.strip() == "ok", res.stderr[-2000:]
