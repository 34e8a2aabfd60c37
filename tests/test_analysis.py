"""Damping and spectral estimators on signals with known answers."""

import numpy as np
import pytest
from scipy import signal

from sloshrom.analysis import (
    frf_h1,
    half_power_damping,
    instantaneous_damping,
    log_decrement,
    lscf_damping,
    modal_filter,
    welch_psd,
)
from sloshrom.config import G

FS, F1, ZETA = 500.0, 10.0, 0.02


def _decay(zeta=ZETA, f1=F1, duration=15.0):
    t = np.arange(0, duration, 1 / FS)
    wd = 2 * np.pi * f1 * np.sqrt(1 - zeta**2)
    return np.exp(-zeta * 2 * np.pi * f1 * t) * np.cos(wd * t)


@pytest.mark.parametrize("zeta", [0.005, 0.02, 0.05])
def test_hilbert_and_log_decrement_recover_zeta(zeta):
    x = _decay(zeta)
    r = instantaneous_damping(x, FS, F1)
    assert np.median(r["zeta"]) == pytest.approx(zeta, rel=0.05)
    assert np.median(r["frequency"]) == pytest.approx(F1 * np.sqrt(1 - zeta**2), rel=0.01)
    ld = log_decrement(x, FS, F1)
    assert np.median(ld["zeta"]) == pytest.approx(zeta, rel=0.05)
    # the envelope decreases along the record
    assert r["amplitude"][0] > r["amplitude"][-1]


def test_hilbert_tracks_amplitude_dependent_damping():
    # damping that grows with amplitude (as sloshing): zeta = 0.01 + 0.02 A
    t = np.arange(0, 20, 1 / FS)
    amp, z = np.empty_like(t), []
    a = 1.0
    for i in range(t.size):
        amp[i] = a
        zi = 0.01 + 0.02 * a
        z.append(zi)
        a *= np.exp(-zi * 2 * np.pi * F1 / FS)
    x = amp * np.cos(2 * np.pi * F1 * t)
    r = instantaneous_damping(x, FS, F1)
    expected = 0.01 + 0.02 * r["amplitude"]
    np.testing.assert_allclose(r["zeta"], expected, atol=0.002)


def _sdof_random(zeta=ZETA, duration=90.0, seed=0):
    rng = np.random.default_rng(seed)
    a = rng.standard_normal(int(duration * FS))
    wn = 2 * np.pi * F1
    sys = signal.lti([2 * zeta * wn, wn**2], [1, 2 * zeta * wn, wn**2])  # base -> absolute acc
    _, y, _ = signal.lsim(sys, a, np.arange(a.size) / FS)
    return a, y


def test_lscf_on_h1_and_psd_recovers_zeta():
    a, y = _sdof_random()
    f, h, coh = frf_h1(a, y, FS, nperseg=4096)
    assert np.all(coh[(f > 5) & (f < 20)] > 0.8)  # dips at resonance (window bias)
    r = lscf_damping(f, h, F1, (5.0, 20.0))
    assert r["zeta"] == pytest.approx(ZETA, rel=0.05)
    assert r["frequency"] == pytest.approx(F1, rel=0.01)
    fp, p = welch_psd(y, FS, nperseg=4096)
    rp = lscf_damping(fp, p, F1, (5.0, 20.0))
    assert rp["zeta"] == pytest.approx(ZETA, rel=0.05)
    hp = half_power_damping(f, h, (5.0, 20.0))
    # half power is biased up by the Hann window's resolution: a check, looser
    assert hp["zeta"] == pytest.approx(ZETA, rel=0.15)


def test_welch_psd_integral_is_variance():
    from sloshrom.signals import gaussian_psd, random_base_acceleration

    x = random_base_acceleration(FS, 90.0, 0.2 * G, f0=12.0, sigma=4.0, seed=0)
    assert np.sqrt(np.mean(x**2)) == pytest.approx(0.2 * G, rel=1e-12)
    f, p = welch_psd(x, FS, nperseg=2048)
    var = np.trapezoid(p, f)
    assert var == pytest.approx((0.2 * G) ** 2, rel=0.03)
    band = (f > 6) & (f < 18)
    np.testing.assert_allclose(p[band], gaussian_psd(f[band], 12.0, 4.0, (0.2 * G) ** 2),
                               rtol=0.3)


def test_modal_filter_separates_modes():
    rng = np.random.default_rng(0)
    psi = rng.standard_normal((5, 3))
    q = rng.standard_normal((100, 3))
    np.testing.assert_allclose(modal_filter(q @ psi.T, psi), q, atol=1e-12)
    with pytest.raises(ValueError, match="n_stations"):
        modal_filter(q @ psi.T, psi[:4])
    with pytest.raises(ValueError, match="independent"):
        modal_filter(np.zeros((10, 2)), np.ones((2, 2)))


def test_bad_inputs():
    with pytest.raises(ValueError, match="too short"):
        instantaneous_damping(np.ones(100), FS, F1)
    f = np.linspace(0, 250, 100)
    with pytest.raises(ValueError, match="too few"):
        half_power_damping(f, np.ones_like(f), (10.0, 11.0))
