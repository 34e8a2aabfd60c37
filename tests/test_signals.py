"""Excitation signals: VFA paths (domain, splits, shaker limits, exact integrals), random input."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import signal
from scipy.spatial import cKDTree

from sloshrom.config import G, Tank
from sloshrom.signals import (
    ShakerLimits,
    gaussian_psd,
    power_band,
    random_base_acceleration,
    vfa,
    vfa_gamma_limit,
)

FS = 200.0  # enough for the path checks (8 samples per cycle at 25 Hz)


@pytest.fixture(scope="module")
def paths():
    return {s: vfa(FS, s) for s in ("train", "validation")}


def test_vfa_durations_and_rest_at_ends(paths):
    assert paths["train"].time[-1] == pytest.approx(480.0)
    assert paths["validation"].time[-1] == pytest.approx(240.0)
    for p in paths.values():
        for x in (p.displacement, p.velocity, p.acceleration):
            scale = np.abs(x).max()
            assert abs(x[0]) < 1e-9 * scale and abs(x[-1]) < 1e-9 * scale


@pytest.mark.parametrize("split", ["train", "validation"])
def test_vfa_covers_domain(paths, split):
    p = paths[split]
    active = p.gamma > 0.02
    assert p.frequency[active].min() < 5.1 and p.frequency[active].max() > 24.9
    assert p.gamma.max() > 5.7 and p.a_bar.max() > 0.43
    # every cell of (log f) x (gamma / gamma_limit(f)) is visited
    x = np.log(p.frequency / 5.0) / np.log(5.0)
    y = p.gamma / vfa_gamma_limit(p.frequency)
    hist, _, _ = np.histogram2d(x, y, bins=5, range=[[0, 1], [0, 1.0001]])
    assert np.all(hist > 0), hist
    # no big holes: 95 % of a 60 x 60 grid of the normalised domain lies within 0.025 (train) /
    # 0.05 (validation, half as long) of the path; a path retracing its arches scores ~0.06
    grid = np.stack(np.meshgrid(np.linspace(0, 1, 60), np.linspace(0, 1, 60)), -1).reshape(-1, 2)
    gap, _ = cKDTree(np.c_[x, y]).query(grid)
    assert np.percentile(gap, 95) < {"train": 0.025, "validation": 0.05}[split]


def test_vfa_splits_differ(paths):
    tr, va = paths["train"], paths["validation"]

    # normalised coordinates of the validation path vs the nearest train point in time-aligned
    # samples: the paths are different curves, not the same one at another speed.
    def norm(p, n):
        idx = np.linspace(0, len(p.time) - 1, n).astype(int)
        return np.column_stack(
            [
                np.log(p.frequency[idx]) / np.log(5.0),
                p.gamma[idx] / vfa_gamma_limit(p.frequency[idx]),
            ]
        )

    a, b = norm(tr, 4000), norm(va, 2000)
    d, _ = cKDTree(a).query(b)
    assert np.median(d) > 0.005
    assert not np.allclose(tr.frequency[:1000], va.frequency[:1000])


def test_vfa_exact_derivatives_and_law(paths):
    # fine sampling so that the O(dt^2) error of the numerical check is ~1e-5
    p = vfa(20000.0, "validation", duration=10.0)
    dt = 1.0 / p.fs
    vnum = np.gradient(p.displacement, dt)
    anum = np.gradient(p.velocity, dt)
    assert np.abs(vnum - p.velocity)[2:-2].max() < 1e-4 * np.abs(p.velocity).max()
    assert np.abs(anum - p.acceleration)[2:-2].max() < 1e-4 * np.abs(p.acceleration).max()
    # on the real (slow) path the acceleration follows A(t) cos(theta), A = a Omega^2 (the
    # paper's law), to within the slow-variation terms a'/(a Omega), Omega'/Omega
    q = paths["validation"]
    amp = q.amplitude * (2 * np.pi * q.frequency) ** 2
    assert np.all(np.abs(q.acceleration) <= 1.01 * amp + 1e-3 * amp.max())
    assert np.abs(q.acceleration).max() == pytest.approx(amp.max(), rel=1e-2)


def test_vfa_respects_shaker_limits():
    lim = ShakerLimits(max_displacement=0.008, max_velocity=0.5, max_acceleration=4 * G)
    p = vfa(FS, "train", duration=120.0, limits=lim)
    assert np.abs(p.displacement).max() <= 0.008 * 1.001
    assert np.abs(p.velocity).max() <= 0.5 * 1.01
    assert np.abs(p.acceleration).max() <= 4 * G * 1.01
    # default limits with a taller tank: a_bar <= 0.45 would exceed the stroke, the stroke wins
    tall = Tank(height=0.06)
    q = vfa(FS, "validation", duration=60.0, tank=tall)
    assert np.abs(q.displacement).max() <= ShakerLimits().max_displacement * 1.001
    assert np.abs(q.velocity).max() <= ShakerLimits().max_velocity * 1.01


def test_vfa_seed_and_bad_input():
    a = vfa(FS, "train", duration=60.0, seed=1)
    b = vfa(FS, "train", duration=60.0, seed=1)
    c = vfa(FS, "train", duration=60.0, seed=2)
    np.testing.assert_array_equal(a.acceleration, b.acceleration)
    assert not np.allclose(a.frequency, c.frequency)
    with pytest.raises(ValueError, match="split"):
        vfa(FS, "test")
    with pytest.raises(ValueError, match="too low"):
        vfa(100.0, "train")


def test_gaussian_psd_integrates_to_variance():
    f = np.linspace(0, 200, 200001)
    S = gaussian_psd(f, 12.0, 4.0, 3.0)
    assert np.trapezoid(S, f) == pytest.approx(3.0, rel=1e-6)


@pytest.mark.parametrize("fade", [0.0, 2.0])
def test_random_exact_rms_zero_mean_same_phases(fade):
    levels = np.array([0.1, 0.2, 0.4]) * G
    x = random_base_acceleration(500.0, 90.0, levels, seed=3, fade=fade)
    assert x.shape == (3, 45000)
    np.testing.assert_allclose(np.sqrt(np.mean(x**2, axis=1)), levels, rtol=1e-12)
    assert np.all(np.abs(x.mean(axis=1)) < 1e-12 * levels)
    # same phases: each level is the same signal scaled
    np.testing.assert_allclose(x[2] / levels[2], x[0] / levels[0], rtol=0, atol=1e-12)
    single = random_base_acceleration(500.0, 90.0, levels[1], seed=3, fade=fade)
    np.testing.assert_allclose(single, x[1], rtol=0, atol=1e-12)
    if fade:
        assert x[0, 0] == 0.0 and x[0, -1] == 0.0


def test_random_psd_matches_eq8():
    rms = 0.2 * G
    fs = 500.0
    x = random_base_acceleration(fs, 90.0, rms, f0=12.0, sigma=4.0, seed=0)
    # the periodogram of the whole (periodic) record is Eq. 8 bin by bin (amplitudes are exact;
    # 1e-4 covers the discrete-sum vs integral normalisation, DC is zeroed)
    X = np.fft.rfft(x)
    fk = np.fft.rfftfreq(x.size, 1 / fs)
    per = 2 * np.abs(X) ** 2 / (fs * x.size)
    strong = (fk > 0) & (
        gaussian_psd(fk, 12.0, 4.0, 1.0) > 1e-3 * gaussian_psd(12.0, 12.0, 4.0, 1.0)
    )
    np.testing.assert_allclose(per[strong], gaussian_psd(fk, 12.0, 4.0, rms**2)[strong], rtol=1e-4)
    # Welch (Hann, 8 s segments) against Eq. 8, averaged over 2 Hz bands within 2 sigma
    f, pxx = signal.welch(x, fs=fs, window="hann", nperseg=4096)
    target = gaussian_psd(f, 12.0, 4.0, rms**2)
    for lo in np.arange(4.0, 20.0, 2.0):
        band = (f >= lo) & (f < lo + 2.0)
        assert pxx[band].mean() == pytest.approx(target[band].mean(), rel=0.1), lo
    # the spectrum is empty far from the band
    assert pxx[f > 40].max() < 1e-4 * target.max()
    # different seeds -> different signals
    y = random_base_acceleration(fs, 90.0, rms, seed=1)
    assert abs(np.corrcoef(x, y)[0, 1]) < 0.1


def test_random_bad_input():
    with pytest.raises(ValueError, match="rms"):
        random_base_acceleration(500.0, 10.0, -1.0)
    with pytest.raises(ValueError, match="too low"):
        random_base_acceleration(50.0, 10.0, 1.0)


def test_plot_vfa_paths(tmp_path, paths):
    from sloshrom.plotting.signals import plot_vfa_paths

    ax = plot_vfa_paths([paths["train"], paths["validation"]])
    assert len(ax.get_legend().get_texts()) == 2
    assert ax.get_xlabel() and ax.get_ylabel()
    ax.figure.savefig(tmp_path / "p.png")
    assert (tmp_path / "p.png").stat().st_size > 1000


def test_power_band_of_a_tone_and_of_white_noise():
    fs = 500.0
    t = np.arange(0, 20.0, 1 / fs)
    lo, hi = power_band(np.sin(2 * np.pi * 10.0 * t), fs)
    assert lo == pytest.approx(10.0, abs=0.1) and hi == pytest.approx(10.0, abs=0.1)
    noise = np.random.default_rng(0).standard_normal(t.size)
    lo, hi = power_band(noise, fs)  # flat power: the 1 % and 99 % quantiles of 0..250 Hz
    assert lo == pytest.approx(2.5, abs=1.0) and hi == pytest.approx(247.5, abs=1.0)
    assert power_band(np.ones(100), fs) == [0.0, 0.0]
