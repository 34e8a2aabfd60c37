"""Modes named as the structure has them (issue 53): a peak of one channel alone is no mode,
a mode one channel barely shows is found at the others, a fast-decaying mode stands above the
decay's noise floor, the numbers follow the structure's modes; and the estimators at such
modes: output-only LSCF under a coloured base, LSCF on H1 beside a close neighbour.

The truth is :class:`sloshrom.beam.lab.synthetic.LabBeam`'s modes (``benchmarks/lab_coverage.py``
campaigns ``four`` and ``close``)."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import signal

from sloshrom.beam.damping.analysis import output_only_damping
from sloshrom.beam.damping.peaks import given_modes, mode_bands, station_modes
from sloshrom.beam.damping.uncertainty import estimate_random
from sloshrom.beam.lab.every_mode import TestModes, modes_of_test, number_modes
from sloshrom.beam.lab.synthetic import LabBeam, free_decay, random_test

FS = 500.0
FOUR = LabBeam(frequencies=(8.1, 50.8, 143.1, 205.6), damping=(0.011, 0.0072, 0.0051, 0.0043))
CLOSE = LabBeam(frequencies=(10.3, 11.9, 64.1), damping=(0.0137, 0.011, 0.0062))


def _random_res(beam, levels, **kw):
    runs = [random_test(beam, g, 120.0, FS, seed=10 + i, **kw) for i, g in enumerate(levels)]
    st = np.stack([r["stations"] for r in runs])
    return {"fs": FS, "base_acceleration": np.stack([r["base"] for r in runs]),
            "station_acceleration": st, "tank_acceleration": st[..., -1],
            "rms_levels_g": np.asarray(levels)}


def test_a_peak_of_one_channel_alone_is_no_mode():
    """The tip channel with a peak of its own at 37 Hz (a narrow resonance of the base's
    signal added to that channel alone: what noise in a channel's antiresonance, or a loose
    sensor mount, makes): it stands 10 dB above its surroundings with a high coherence at the
    tip, but no other station shows it. The structure's three modes are found, no fourth."""
    res = _random_res(LabBeam(), (0.1, 0.2))
    sos = signal.butter(2, [36.5, 37.5], btype="bandpass", fs=FS, output="sos")
    for i in range(2):
        res["station_acceleration"][i, :, -1] += 30 * signal.sosfilt(
            sos, res["base_acceleration"][i])
    res["tank_acceleration"] = res["station_acceleration"][..., -1]
    tip = [m.frequency for m in station_modes(res["station_acceleration"][0][:, -1:], FS,
                                              res["base_acceleration"][0])]
    assert any(abs(f - 37.0) < 0.5 for f in tip)  # the tip alone shows it
    found = modes_of_test(res, "random").frequencies
    np.testing.assert_allclose(found, LabBeam().frequencies, rtol=0.01)


def test_a_mode_one_channel_barely_shows_is_found_at_the_others():
    """Two modes 15 % apart (10.3 and 11.9 Hz): at the tip the second stands 8 dB above the
    valley between them (below the 10 dB a peak needs); at 0.6 m, 24 dB. Both are found."""
    res = _random_res(CLOSE, (0.1, 0.2), noise=0.002, noise_g=0.0005)
    tip = [m.frequency for m in station_modes(res["station_acceleration"][0][:, -1:], FS,
                                              res["base_acceleration"][0])]
    assert not any(abs(f - 11.9) < 0.3 for f in tip)
    np.testing.assert_allclose(modes_of_test(res, "random").frequencies, CLOSE.frequencies,
                               rtol=0.01)


def test_a_fast_decaying_mode_above_the_noise_floor_is_found():
    """A 20 s decay of four modes: the fourth (205.6 Hz, 0.43 %) stands about 15 dB above the
    spectrum's median and 19 dB above its noise floor; 20 dB above the median lost it."""
    d = free_decay(FOUR, 8.5, 20.0, FS, noise_g=0.002, seed=0)
    n = d["time"].size
    res = {"fs": FS, "station_acceleration": d["stations"],
           "tank_acceleration": d["stations"][:, -1], "base_acceleration": np.zeros(n)}
    np.testing.assert_allclose(modes_of_test(res, "free").frequencies, FOUR.frequencies,
                               rtol=0.01)


def test_mode_numbers_follow_the_structure_not_the_order_of_the_peaks():
    """A decay that misses mode 2 calls its second mode 3, as the random test of the same
    campaign (which shows all three) does."""
    def modes(fr):
        return TestModes(given_modes(fr), mode_bands(fr, FS), "found")

    decay, rnd = number_modes([modes([10.3, 180.0]), modes([10.35, 64.1, 179.9])])
    assert decay.numbers == (1, 3) and rnd.numbers == (1, 2, 3)
    assert modes([10.3, 180.0]).number(1) == 2  # alone, in the peaks' order


def test_output_only_lscf_under_a_coloured_base_within_3_percent():
    """Mode 2 (64.1 Hz, 0.62 %) of the three-mode beam on a 3-40 Hz shaker band: the input
    falls 24 dB/octave across it. Dividing the output spectrum by the measured base's takes
    the output-only estimate from +11 % (white-input assumption, 8 records) to within the
    issue's +/-3 % (mean of 4 records of 120 s; their scatter 1.5 %, so +/-3 % is 4 standard
    errors)."""
    beam = LabBeam()
    band = mode_bands(beam.frequencies, FS)[1]
    est, white = [], []
    for seed in range(4):
        r = random_test(beam, 0.2, 120.0, FS, band=(3.0, 40.0), seed=seed)
        y = r["stations"][:, -1]
        est.append(output_only_damping(y, FS, 64.1, band, base=r["base"])["zeta"])
        white.append(output_only_damping(y, FS, 64.1, band)["zeta"])
    assert np.mean(est) / beam.damping[1] - 1 == pytest.approx(0.0, abs=0.03)
    assert np.mean(white) / beam.damping[1] - 1 > 0.06  # the bias it removes


@pytest.mark.long
def test_lscf_h1_beside_a_close_neighbour_has_a_calibrated_interval():
    """Mode 2 of two modes 15 % apart: the bootstrap's model of the record holds the
    neighbour as a resonance (its four tail terms took values of +/-300 and lost the mode in
    most simulated records: no value). Now a value whose interval holds the truth, and whose
    std is that of the mode's records (0.8-1.2 % of the damping over 8 records of 120 s)."""
    r = random_test(CLOSE, 0.2, 120.0, FS, seed=1, noise=0.002, noise_g=0.0005)
    band = mode_bands(CLOSE.frequencies, FS)[1]
    e = estimate_random(r["base"], r["stations"][:, -1], FS, 11.9, band=band,
                        neighbours=CLOSE.frequencies, estimators=["lscf_h1"]).estimates["lscf_h1"]
    assert e.reason == "" and e.low <= CLOSE.damping[1] <= e.high
    assert 0.003 < e.std / CLOSE.damping[1] < 0.03
