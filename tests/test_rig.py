"""Virtual rig: physics sanity checks, determinism, sensor model and kernel contract."""

from __future__ import annotations

import math

import numba as nb
import numpy as np
import pytest

from sloshrom.config import ConfigError, G, Tank
from sloshrom.energy import default_grid, dissipated_energy, map_maximum, phi_d_map
from sloshrom.models import SloshingModel, has_kernel
from sloshrom.rig import RigParams, SensorParams, VirtualRig, energy_audit
from sloshrom.rig import physics as rigmod
from sloshrom.signals import harmonic

TANK = Tank()


def _harm(rig: VirtualRig, f: float, gamma: float, **kw):
    om = 2 * math.pi * f
    return harmonic(1.0 / rig.dt, f, gamma * G / om**2, **kw)


def _phi(rig: VirtualRig, f: float, gamma: float) -> float:
    h = _harm(rig, f, gamma, n_cycles=8, n_settle=int(0.5 * f) + 2)
    df = rig.simulate(h.velocity, h.acceleration)
    seg = slice(h.steady.start, h.steady.stop + 1)
    l_d = dissipated_energy(h.displacement[seg], df[seg], n_cycles=8, rule=rig.force_rule)
    return float(l_d / (TANK.liquid_mass * h.amplitude**2 * (2 * math.pi * f) ** 2))


@pytest.fixture(scope="module")
def rig():
    return VirtualRig()


@pytest.mark.parametrize("f", [6.0, 12.0, 24.0])
@pytest.mark.parametrize("gamma", [0.3, 0.7])
def test_force_is_zero_below_one_g(rig, f, gamma):
    h = _harm(rig, f, gamma, n_cycles=10)
    df = rig.simulate(h.velocity, h.acceleration)
    # only the seeded micrometre surface noise is left: far below the load-cell noise
    assert np.max(np.abs(df)) < 1e-4
    assert abs(dissipated_energy(h.displacement, df)) < 1e-8


def test_strong_dissipation_above_one_g(rig):
    assert _phi(rig, 12.0, 4.0) > 0.1
    assert _phi(rig, 12.0, 4.0) > 10 * abs(_phi(rig, 12.0, 0.9))


def test_free_flight_identity(rig):
    p = rig.params
    n = p.n_layers
    st = rig.init_state()
    top = rigmod._S_HEAD + n - 1
    st[top] = 0.5 * TANK.ullage  # top layer in mid-gap, released
    st[top + n] = 0.01
    st[top + 2 * n] = 1.0
    for acc in (-2.5 * G, -0.5 * G, 3.0 * G):
        s0 = st.copy()
        s0[rigmod._S_APREV] = acc  # constant tank acceleration
        s_before = s0.copy()
        s1, df = rig.step(s0, 0.0, acc)
        np.testing.assert_array_equal(s0, s_before)  # pure step
        rel_acc = (s1[top + n] - s0[top + n]) / rig.dt
        assert rel_acc == pytest.approx(-(G + acc), rel=1e-9)
        z_expect = s0[top] + s0[top + n] * rig.dt - 0.5 * (G + acc) * rig.dt**2
        assert s1[top] == pytest.approx(z_expect, rel=1e-12)
        # the force of the flying layer: -chi m_i z''  (modes at noise level)
        m_i = p.beta * TANK.liquid_mass / n
        chi = s1[rigmod._S_CHI]
        assert df == pytest.approx(chi * m_i * (G + acc), rel=1e-4)


@pytest.mark.parametrize(("f", "gamma"), [(12.0, 4.0), (20.0, 3.0), (8.0, 2.0), (14.0, 1.3)])
def test_energy_balance(rig, f, gamma):
    h = _harm(rig, f, gamma, n_cycles=8)
    au = energy_audit(rig, h.velocity, h.acceleration)
    assert au["released_at_end"] == 0.0
    assert au["work"] > 0
    assert au["contact_loss"] > 0 and au["attach_loss"] >= 0
    assert abs(au["relative_residual"]) < 0.01


def test_phi_d_converges_when_dt_halves():
    fine = VirtualRig(dt=5e-5)
    base = VirtualRig(dt=1e-4)
    for f, gamma in [(12.0, 4.0), (8.0, 2.5), (20.0, 3.0)]:
        a, b = _phi(base, f, gamma), _phi(fine, f, gamma)
        assert abs(a - b) / abs(b) < 0.02, (f, gamma, a, b)


def test_same_seed_same_output_different_seed_different_noise():
    h = _harm(VirtualRig(), 12.0, 3.0, n_cycles=4)
    acc = h.acceleration
    m1 = VirtualRig(seed=3).measure(acc)
    m2 = VirtualRig(seed=3).measure(acc)
    m3 = VirtualRig(seed=4).measure(acc)
    for k in ("acceleration", "force", "true_dynamic_force", "true_velocity"):
        np.testing.assert_array_equal(m1[k], m2[k])
    assert not np.array_equal(m1["force"], m3["force"])
    assert not np.array_equal(m1["acceleration"], m3["acceleration"])
    # the physics is the same up to the seeded micrometre surface noise
    np.testing.assert_allclose(m1["true_velocity"], m3["true_velocity"])


def test_measure_rate_length_keys_and_force_convention(rig):
    h = _harm(rig, 10.0, 2.5, n_cycles=6)
    m = rig.measure(h.acceleration)
    assert set(m) == {"fs", "time", "acceleration", "force", "true_velocity",
                      "true_dynamic_force"}
    assert m["fs"] == 500.0
    duration = (h.acceleration.size - 1) * rig.dt
    assert m["time"].size == int(math.floor(duration * 500 + 1e-9)) + 1
    np.testing.assert_allclose(np.diff(m["time"]), 1 / 500)
    for k in ("acceleration", "force", "true_velocity", "true_dynamic_force"):
        assert m[k].shape == m["time"].shape
    # preprocessing recovers dF = force + (m_l + m_struct) w'' to within the sensor noise
    m_tot = TANK.liquid_mass + TANK.structure_mass
    df_est = m["force"] + m_tot * m["acceleration"]
    err = np.std(df_est - m["true_dynamic_force"])
    assert err < 0.05
    assert np.std(m["true_dynamic_force"]) > 10 * err  # the signal stands out of the noise
    # the true velocity is the integral of the acceleration
    np.testing.assert_allclose(m["true_velocity"], np.interp(m["time"], h.time, h.velocity),
                               atol=2e-3)


def test_measure_rejects_bad_input(rig):
    with pytest.raises(ValueError):
        rig.measure(np.zeros((2, 100)))
    with pytest.raises(ValueError):
        rig.measure(np.array([0.0, np.nan] * 2000))
    with pytest.raises(ValueError, match="too short"):
        rig.measure(np.zeros(500))


def test_step_is_pure_and_matches_simulate(rig):
    h = _harm(rig, 12.0, 3.0, n_cycles=2)
    st = rig.init_state()
    st_copy = st.copy()
    forces = []
    for k in range(h.velocity.size):
        new, f = rig.step(st, h.velocity[k], h.acceleration[k])
        if k == 0:
            np.testing.assert_array_equal(st, st_copy)
        st = new
        forces.append(f)
    np.testing.assert_allclose(forces, rig.simulate(h.velocity, h.acceleration), rtol=0,
                               atol=1e-12)
    with pytest.raises(ValueError, match="state"):
        rig.step(np.zeros(3), 0.0, 0.0)


def test_simulate_batched_leading_axes(rig):
    hs = [_harm(rig, 12.0, g, n_cycles=2, n_ramp=1) for g in (0.5, 2.0, 3.0, 4.0)]
    n = min(h.velocity.size for h in hs)
    v = np.stack([h.velocity[:n] for h in hs]).reshape(2, 2, n)
    a = np.stack([h.acceleration[:n] for h in hs]).reshape(2, 2, n)
    out = rig.simulate(v, a)
    assert out.shape == (2, 2, n)
    np.testing.assert_array_equal(out[1, 0], rig.simulate(v[1, 0], a[1, 0]))


def test_rig_satisfies_the_model_protocols(rig):
    assert isinstance(rig, SloshingModel)
    assert has_kernel(rig)
    assert rig.force_rule == "step"


def test_kernel_inside_numba_loop(rig):
    step_fn, params, state = rig.kernel()

    @nb.njit
    def run(state, params, v, a):
        out = np.empty(v.size)
        for k in range(v.size):
            out[k] = step_fn(state, params, v[k], a[k])
        return out

    h = _harm(rig, 12.0, 4.0, n_cycles=2)
    out = run(state, params, h.velocity, h.acceleration)
    np.testing.assert_allclose(out, rig.simulate(h.velocity, h.acceleration), atol=1e-12)
    assert state[rigmod._S_LC] > 0  # advanced in place


def test_params_toml_round_trip_and_validation(tmp_path):
    p = RigParams.default()
    path = tmp_path / "rig.toml"
    p.to_toml(path, comment="test")
    assert RigParams.from_toml(path) == p
    assert not list(tmp_path.glob("*.tmp"))
    with pytest.raises(ConfigError):
        RigParams(beta=1.5)
    with pytest.raises(ConfigError):
        RigParams(restitution=1.0)
    with pytest.raises(ConfigError):
        RigParams.from_dict({"bogus": 1})
    with pytest.raises(ConfigError):
        RigParams.from_toml(tmp_path / "missing.toml")
    with pytest.raises(ConfigError):
        SensorParams(output_fs=10000.0)
    with pytest.raises(ValueError):
        VirtualRig(dt=-1.0)
    # restitution -> dashpot damping ratio: e = exp(-pi z / sqrt(1 - z^2))
    z = RigParams(restitution=0.2).contact_damping_ratio
    assert math.exp(-math.pi * z / math.sqrt(1 - z * z)) == pytest.approx(0.2)


def test_map_maximum_near_target():
    """Calibrated map: max near omega_bar 4, a_bar 0.25 (~4 g); ~0 below 1 g; falls at high f."""
    rig = VirtualRig()
    ob, ab = default_grid(12)
    da = phi_d_map(rig, ob, ab, n_cycles=6)
    mx = map_maximum(da)
    assert 3.0 <= mx["omega_bar"] <= 5.5
    assert 0.15 <= mx["a_bar"] <= 0.35
    assert 3.0 <= mx["gamma"] <= 5.5
    gamma = ab[None, :] * ob[:, None] ** 2
    vals = da.values
    assert np.nanmax(np.abs(vals[gamma < 0.9])) < 1e-4
    high = vals[ob >= 7.0]
    assert np.nanmax(high) < 0.6 * mx["phi_d"]


def test_sensor_filter_row_by_row_is_the_filter_along_the_last_axis():
    """The anti-alias filter runs one signal at a time (smaller temporaries): the same bits as
    scipy's filter of the stacked signals."""
    import scipy.signal as sps

    from sloshrom.rig.virtual import _lowpass

    sp = SensorParams()
    x = np.random.default_rng(3).standard_normal((4, 20_000))
    y = _lowpass(x, 10_000.0, sp.acquisition_fs, sp)
    wn = sp.anti_alias_fraction * 0.5 * sp.acquisition_fs / (0.5 * 10_000.0)
    ref = sps.sosfiltfilt(sps.butter(int(sp.filter_order), wn, output="sos"), x, axis=-1)
    assert np.array_equal(y, ref)
    assert _lowpass(x, 500.0, 500.0, sp) is x  # no decimation, no filter
