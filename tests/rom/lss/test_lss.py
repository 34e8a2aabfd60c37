"""The linear state-space baseline (LSS) as a ROM: the estimator, its model file, its step in
the coupled beam and the maps, its FMU. The numerics (N4SID, the output-error refinement) are
tested in test_lss_core.py."""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from scipy import signal

from helpers import LinearDamper
from sloshrom import Tank
from sloshrom.beam.simulation.coupled import free_response
from sloshrom.beam.simulation.structure import ModalModel
from sloshrom.energy import phi_d_map
from sloshrom.models import is_jax_model
from sloshrom.rom import LSS, load_model
from sloshrom.rom.errors import NotFittedError, ROMError

FS = 500.0
C = 5.0  # N s/m: the damper the LSS is identified on


def _records(n: int = 12_000, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """A band-limited random tank velocity (m/s) and a linear force of it (N): a damper plus
    a lightly damped 6 Hz mode."""
    rng = np.random.default_rng(seed)
    sos = signal.butter(4, [0.5, 40.0], btype="band", fs=FS, output="sos")
    u = signal.sosfilt(sos, rng.standard_normal(n))
    u *= 0.05 / np.std(u)
    b, a = signal.cheby1(2, 1.0, [5.5, 6.5], btype="band", fs=FS)
    return u, -C * u + 20.0 * signal.lfilter(b, a, u)


def _damper_records(n: int = 12_000) -> tuple[np.ndarray, np.ndarray]:
    """A damper's records, at the beam's tank velocities (peak ~1.3 m/s)."""
    u, _ = _records(n)
    return 6 * u, -C * 6 * u


@pytest.fixture(scope="module")
def fitted():
    u, y = _records()
    uv, yv = _records(seed=1)
    return LSS(n_states=6, block_rows=20, max_epochs=20).fit(u, y, FS, validation=(uv, yv))


@pytest.mark.filterwarnings("ignore::sloshrom.models.EnvelopeWarning")
def test_a_linear_system_is_identified_exactly(fitted):
    """Noise-free records of a linear system: the free run matches them to rounding level
    (the tolerance 1e-6 is far above the 1e-12 the refinement reaches and far below any
    model error a nonlinearity would leave)."""
    uv, yv = _records(seed=2)
    e = fitted.predict(uv) - yv
    assert np.sqrt(np.mean(e**2) / np.mean(yv**2)) < 1e-6
    assert fitted.history_["train_mse"][-1] <= fitted.history_["train_mse"][0]
    assert np.max(np.abs(np.linalg.eigvals(fitted.params_["A"]))) < 1.0
    assert fitted.envelope_["input_max"] == pytest.approx(fitted.scaler_.in_max)


def test_the_step_is_the_free_run_and_a_pytree(fitted):
    assert is_jax_model(fitted)
    uv, _ = _records(2000, seed=3)
    with jax.enable_x64(True):
        def body(state, v):
            return fitted.step(state, v)

        _, y = jax.lax.scan(body, jnp.asarray(fitted.init_state()), jnp.asarray(uv))
    np.testing.assert_allclose(np.asarray(y), fitted.predict(uv), rtol=1e-9,
                               atol=1e-12 * np.abs(y).max())
    leaves, tree = jax.tree_util.tree_flatten(fitted)
    back = jax.tree_util.tree_unflatten(tree, leaves)
    np.testing.assert_array_equal(back.predict(uv), fitted.predict(uv))


def test_save_and_load_round_trip(fitted, tmp_path):
    path = fitted.save(tmp_path / "lss.npz")
    back = load_model(path)
    assert type(back) is LSS and back.get_params() == fitted.get_params()
    uv, _ = _records(3000, seed=4)
    np.testing.assert_array_equal(back.predict(uv), fitted.predict(uv))
    assert back.history_ == fitted.history_


def test_bad_hyperparameters_and_records_are_refused():
    u, y = _records(3000)
    with pytest.raises(ROMError, match="block_rows .* must be more than n_states"):
        LSS(n_states=8, block_rows=8).fit(u, y, FS)
    with pytest.raises(ROMError, match="n_states must be an integer in"):
        LSS(n_states=0).fit(u, y, FS)
    with pytest.raises(ROMError, match="too few"):
        LSS(block_rows=400).fit(u, y, FS)
    with pytest.raises(ROMError, match="velocity"):
        LSS(names=("acceleration", "dynamic_force")).fit(u, y, FS)
    with pytest.raises(NotFittedError):
        LSS().predict(u)


def test_in_the_coupled_beam_it_adds_the_damping_of_what_it_was_identified_on():
    """An LSS identified on a damper's records couples to the beam as the damper does."""
    u, y = _damper_records()
    model = LSS(n_states=2, block_rows=10, max_epochs=10).fit(u, y, FS)
    modal = ModalModel.from_beam(tank=Tank(), n_modes=3)
    damped = free_response(LinearDamper(C, 1 / FS), modal, duration=4.0)
    lss = free_response(model, modal, duration=4.0)
    scale = np.abs(damped["dynamic_force"]).max()
    np.testing.assert_allclose(lss["dynamic_force"], damped["dynamic_force"], rtol=0,
                               atol=1e-6 * scale)


def test_its_map_is_the_damper_s_and_independent_of_the_amplitude():
    """Phi_d = L_d / (m_l a^2 Omega^2): for a linear model the dissipated energy grows with
    a^2, so the map does not depend on a_bar; the damper's Phi_d is pi c / (m_l Omega)."""
    u, y = _damper_records()
    model = LSS(n_states=2, block_rows=10, max_epochs=10).fit(u, y, FS)
    tank = Tank()
    ob, ab = np.array([0.6, 0.8]), np.array([0.02, 0.04])
    m = phi_d_map(model, ob, ab, tank=tank, a_bar_max=1.0, gamma_max=100.0)
    ref = phi_d_map(LinearDamper(C, 1 / FS), ob, ab, tank=tank, a_bar_max=1.0,
                    gamma_max=100.0)
    np.testing.assert_allclose(m.values, ref.values, rtol=1e-4)
    np.testing.assert_allclose(m.values[:, 0], m.values[:, 1], rtol=1e-4)


@pytest.mark.filterwarnings("ignore::sloshrom.rom.errors.FeedthroughWarning")  # its D term
def test_the_fmu_gives_its_force(fitted, tmp_path):
    pytest.importorskip("fmpy")
    from sloshrom.rom.fmu import export_fmu, load_fmu

    try:
        path = export_fmu(fitted, tmp_path / "lss.fmu")
    except ROMError as exc:  # no C compiler on this machine: the source FMU is tested elsewhere
        pytest.skip(str(exc))
    fmu = load_fmu(path)
    uv, _ = _records(4000, seed=5)
    try:
        got = fmu.simulate(uv)
    finally:
        fmu.close()
    want = fitted.predict(uv)
    # the FMU runs the model in its scaled state-space form: equal to rounding (measured
    # 7e-15 relative to the force's peak)
    np.testing.assert_allclose(got, want, rtol=0, atol=1e-12 * np.abs(want).max())
