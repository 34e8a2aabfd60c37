"""The laboratory beam generator (sloshrom.beam.lab.synthetic) against its own modal physics.

The truth is the beam's stated modes: the FRF estimated from a long random record must show
them (peaks, half-power bandwidths), the modal coordinates of a free decay must decay at
``exp(-zeta omega t)``, and the records must have the asked levels.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from sloshrom.beam.damping.analysis import frf_h1, half_power_damping, modal_filter
from sloshrom.beam.errors import BeamError
from sloshrom.beam.lab.synthetic import LabBeam, free_decay, random_test
from sloshrom.config import G

FS = 500.0
NPERSEG = 16384
DF = FS / NPERSEG  # frequency resolution of the FRF, Hz


@pytest.fixture(scope="module")
def long_record() -> dict:
    return random_test(LabBeam(), 0.1, 600.0, FS, seed=3)


def test_shapes_and_participation_of_a_uniform_cantilever() -> None:
    beam = LabBeam()
    psi = beam.shapes()
    assert psi.shape == (5, 3)
    np.testing.assert_allclose(psi[-1], 1.0)  # unit tip displacement
    # the uniform clamped-free participation of tip-normalised shapes: 1.566, -0.868, 0.509
    # (int psi / int psi^2 of the closed form); Simpson/trapezoid to 1e-4
    np.testing.assert_allclose(beam.participation, [1.566, -0.868, 0.509], atol=2e-3)
    # the sum over all modes of psi_k(L) Gamma_k is 1; truncated to three modes it overshoots
    assert 1.0 < float(psi[-1] @ beam.participation) < 1.3


def test_random_record_levels_and_stationarity(long_record: dict) -> None:
    base, y = long_record["base"], long_record["stations"]
    assert base.shape == (300000,) and y.shape == (300000, 5)
    # the noise (0.5 % of the RMS) adds 1.25e-5 to the variance
    assert np.std(base) / G == pytest.approx(0.1, rel=1e-3)
    # stationary: the RMS of each half of the tip record agrees to the scatter of a variance
    # estimate over ~300 s of a 1.4 % mode (~5 %, its correlation time 1 / (zeta omega))
    halves = np.std(y[:150000, -1]), np.std(y[150000:, -1])
    assert halves[0] == pytest.approx(halves[1], rel=0.1)


def test_random_frf_matches_the_modal_frf(long_record: dict) -> None:
    beam = LabBeam()
    f, h, coh = frf_h1(long_record["base"], long_record["stations"][:, -1], FS, NPERSEG)
    ha = beam.frf(f, [beam.length])[:, 0]
    for fk, zk in zip(beam.frequencies, beam.damping, strict=True):
        band = (0.8 * fk, 1.2 * fk)
        sel = (f > band[0]) & (f < band[1])
        est = half_power_damping(f, h, band)
        # the peak within the Hann window's main lobe (+/- 2 lines)
        assert abs(est["frequency"] - fk) < 2 * DF
        # half-power bandwidth 2 zeta f within one frequency line (the Hann leakage widens
        # the 10 Hz mode's 0.28 Hz bandwidth by ~5 %, 0.4 line)
        assert abs(2 * est["zeta"] * fk - 2 * zk * fk) < DF
        # magnitude over the band: H1's random error over 36 segments with coherence > 0.99
        # is well below 1 %; Hann leakage at the peak lines a few %
        assert np.median(np.abs(h[sel]) / np.abs(ha[sel])) == pytest.approx(1.0, abs=0.02)
        assert np.median(coh[sel]) > 0.99


def test_band_ending_at_40_hz_leaves_mode_3_unexcited() -> None:
    beam = LabBeam()
    r = random_test(beam, 0.1, 120.0, FS, band=(3.0, 40.0), seed=1)
    f, _, coh = frf_h1(r["base"], r["stations"][:, -1], FS, NPERSEG)
    near = lambda fk: (f > 0.95 * fk) & (f < 1.05 * fk)  # noqa: E731
    assert np.median(coh[near(10.3)]) > 0.99
    # 2.2 octaves above the 24 dB/octave edge: the base is ~50 dB below the sensor noise's
    # share of the tip, so the coherence is noise
    assert np.median(coh[near(180.0)]) < 0.5


def test_random_test_rejects_a_band_above_nyquist() -> None:
    with pytest.raises(BeamError, match="band"):
        random_test(LabBeam(), 0.1, 10.0, FS, band=(3.0, 260.0))


def test_free_decay_modes_decay_at_their_damping() -> None:
    beam = LabBeam()
    d = free_decay(beam, 1.0, 8.0, FS, seed=2)
    y = d["stations"]
    assert np.max(np.abs(y[:, -1])) / G == pytest.approx(1.0, abs=0.05)  # + 0.002 g noise
    q = modal_filter(y, beam.shapes())  # no base motion: absolute = relative
    t = d["time"]
    for k, (fk, zk) in enumerate(zip(beam.frequencies, beam.damping, strict=True)):
        wk = 2 * math.pi * fk
        # peaks of |q_k| per period over the first 3 time constants (the amplitude stays far
        # above the filtered noise), their log slope is -zeta omega
        per = int(FS / fk)
        end = min(t.size, int(3 / (zk * wk) * FS))
        blocks = np.abs(q[: end - end % per, k]).reshape(-1, per)
        tp = t[: end - end % per].reshape(-1, per)[np.arange(blocks.shape[0]),
                                                   np.argmax(blocks, axis=1)]
        slope = np.polyfit(tp, np.log(blocks.max(axis=1)), 1)[0]
        # sampling the peak of a 180 Hz wave at 500 Hz misses it by up to 1 - cos(pi fk/fs)
        # at random, a scatter of a few % on ln A that averages out over the fitted peaks
        assert -slope == pytest.approx(zk * wk, rel=0.05), k


def test_lab_beam_validation() -> None:
    with pytest.raises(BeamError):
        LabBeam(frequencies=(10.0, 5.0), damping=(0.01, 0.01))
    with pytest.raises(BeamError):
        LabBeam(damping=(0.01, 0.0, 0.01))
    with pytest.raises(BeamError):
        LabBeam(positions=(0.5, 1.5))
