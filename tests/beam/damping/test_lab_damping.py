"""Random-test damping at any mode of a laboratory beam, under band-limited coloured inputs
(sloshrom.beam.damping.uncertainty with ``band``; the records of sloshrom.beam.lab.synthetic).

The laboratory's case: mode 2 (64.1 Hz, 0.62 %) of the three-mode beam forced by a shaker
band ending at 40 Hz, 2 % sensor noise. A bootstrap that assumed a white input read the
incoherence of the lines above the shaker's band as input noise (ratio ~1 instead of ~0.03)
and moved half power to 1.1 % with an interval excluding the truth. Mode 3 (180 Hz) is not
excited by that band: every estimator must say so rather than give an interval.
"""

from __future__ import annotations

import importlib.util
import math

import numpy as np
import pytest

from helpers import REPO
from sloshrom.beam.damping.estimators import RandomTest
from sloshrom.beam.damping.uncertainty import (
    damping_dataset,
    estimate_random,
    input_noise_floor,
    input_psd,
    mode_frf,
    random_damping,
)
from sloshrom.beam.errors import BeamError
from sloshrom.beam.lab.synthetic import LabBeam, random_test

FS = 500.0
BEAM = LabBeam()

_SPEC = importlib.util.spec_from_file_location(
    "lab_coverage", REPO / "benchmarks" / "lab_coverage.py")
_BENCH = importlib.util.module_from_spec(_SPEC)
_SPEC.loader.exec_module(_BENCH)


def test_band_overrides_rel_band_and_is_clipped_at_nyquist() -> None:
    u = np.random.default_rng(0).standard_normal(4096)
    assert RandomTest(u, u, FS, 64.1).fit_band == pytest.approx((32.05, 96.15))
    assert RandomTest(u, u, FS, 64.1, band=(30.0, 100.0)).fit_band == (30.0, 100.0)
    # mode 3 at 180 Hz: f1 (1 + 0.5) = 270 Hz lies above the 250 Hz Nyquist frequency
    assert RandomTest(u, u, FS, 180.0).fit_band == pytest.approx((90.0, 250.0))
    assert RandomTest(u, u, FS, 180.0, band=(110.0, 300.0)).fit_band == (110.0, 250.0)
    for bad in ((70.0, 100.0), (10.0, 60.0), (-1.0, 100.0)):
        with pytest.raises(BeamError, match="band"):
            RandomTest(u, u, FS, 64.1, band=bad)


@pytest.fixture(scope="module")
def lab_mode2() -> tuple[dict, float]:
    r = random_test(BEAM, 0.1, 120.0, FS, band=(3.0, 40.0), noise=0.02, seed=0)
    clean = random_test(BEAM, 0.1, 120.0, FS, band=(3.0, 40.0), noise=0.0, seed=0)
    # the true input noise-to-signal ratio at 64.1 Hz: white noise of 2 % of the base RMS
    # (one-sided PSD 2 sigma^2 / fs) over the record's input PSD there
    f, s = input_psd(r["base"], FS)
    n_u = (0.02 * float(np.std(clean["base"]))) ** 2 * 2 / FS
    return r, n_u / float(np.interp(64.1, f, s))


def test_coloured_band_limited_input_keeps_the_bias_correction_small(lab_mode2) -> None:
    r, true_noise = lab_mode2
    e = estimate_random(r["base"], r["stations"][:, -1], FS, 64.1, n_resamples=20,
                        band=_BENCH.mode_band(BEAM, 1))
    # the noise fit follows the coloured input: the white-input fit gave 1.0 here
    assert true_noise / 3 < e.noise_input < 3 * true_noise
    for name in ("lscf_h1", "half_power"):
        x = e.estimates[name]
        assert x.reason == "" and x.low < x.value < x.high, name
        # the white-input bootstrap put half power at 1.1 % (+80 %, 5 of its stated std off the
        # 0.62 % truth) and LSCF at NaN; a correct std puts the truth within 3 of them but for
        # 0.3 % of records
        assert abs(x.value - BEAM.damping[1]) < 3 * x.std, (name, x)


def test_an_unexcited_mode_is_nan_with_its_reason() -> None:
    r = random_test(BEAM, 0.1, 120.0, FS, band=(3.0, 40.0), seed=1)
    ds = damping_dataset(r["base"], r["stations"][:, -1], FS, 180.0, n_resamples=4,
                         band=_BENCH.mode_band(BEAM, 2))
    for est in ds.estimator.values:
        e = ds.sel(estimator=est)
        assert math.isnan(float(e.value)) and math.isnan(float(e.low)), est
        # no raw value either: a fit there is not the mode's (issue 53: a phantom peak's raw
        # half power of 42 % was written)
        assert math.isnan(float(e.uncorrected)) and math.isnan(float(e.frequency)), est
        assert "does not excite the mode" in str(e.reason.values), est
    # the wide band excites it: values and intervals
    r = random_test(BEAM, 0.1, 120.0, FS, seed=1)
    cols = random_damping(r["base"], r["stations"][:, -1], FS, 180.0, n_resamples=4,
                          band=_BENCH.mode_band(BEAM, 2))
    for est in ("lscf_h1", "half_power", "lscf_output"):
        assert cols[f"{est}_reason"] == "" and np.isfinite(cols[f"{est}_low"]), est


@pytest.mark.slow
def test_lab_coverage_mode2_band_limited() -> None:
    # 30 records of the laboratory's case (mode 2, shaker band ending at 40 Hz, 0.1 g), about
    # 3 minutes. Half power: a correct 95 % interval covers >= 25 of 30 with probability 0.98
    # (binomial). LSCF on H1 and output-only miss the target there (docs/beam.md: 81 % and
    # 78 % over 36 records; the first's std is 1.5 times low, the second is biased +10 % by the
    # input's roll-off across the mode); the floor of 18 of 30 still catches the white-input
    # bootstrap, which covered none with half power and gave LSCF NaN
    rows = [row for s in range(500, 530)
            for row in _BENCH.one_record(("3-40 Hz", 0.1, s, 120.0), modes=(2,))]
    for est, floor in (("half_power", 25), ("lscf_h1", 18), ("lscf_output", 18)):
        sel = [r for r in rows if r["estimator"] == est and np.isfinite(r["low"])]
        covered = sum(r["low"] <= r["truth"] <= r["high"] for r in sel)
        assert len(sel) >= 27 and covered >= floor, (est, len(sel), covered)


def test_check_analysis_band_with_a_band() -> None:
    from sloshrom.beam.damping.limits import check_analysis_band
    from sloshrom.config import ConfigError

    check_analysis_band(180.0, fs=FS, band=(107.0, 300.0))  # the upper edge is clipped later
    with pytest.raises(ConfigError, match="too high"):
        check_analysis_band(180.0, fs=FS)  # 1.5 f1 = 270 Hz: no band between neighbours
    with pytest.raises(ConfigError, match="must hold the mode"):
        check_analysis_band(64.1, fs=FS, band=(70.0, 100.0))
    with pytest.raises(ConfigError, match="too high"):
        check_analysis_band(210.0, fs=FS, band=(150.0, 250.0))


def test_mode_frf_recovers_a_mode_among_its_neighbours() -> None:
    f = np.linspace(0.5, 250.0, 4000)
    band = _BENCH.mode_band(BEAM, 1)
    sel = (f >= band[0]) & (f <= band[1])
    h = BEAM.frf(f, [BEAM.length])[:, 0]
    c = mode_frf(f, h, 64.1, 0.0062, band)
    # the residue of mode 2 at the tip is psi_2(L) Gamma_2; the neighbours' tails are not
    # exactly the model's five terms (their own damping, higher powers): a few 1e-3
    assert c[-1] == pytest.approx(BEAM.participation[1], rel=0.01)
    from sloshrom.beam.damping.uncertainty import _mode_terms
    fit = _mode_terms(f[sel], 64.1, 0.0062) @ c
    assert np.max(np.abs(fit - h[sel]) / np.abs(h[sel])) < 0.02
    # a lone base-excited oscillator is the model with c0 = R = 1
    w, wn = 2 * np.pi * f, 2 * np.pi * 64.1
    sdof = (wn**2 + 2j * 0.0062 * wn * w) / (wn**2 - w**2 + 2j * 0.0062 * wn * w)
    np.testing.assert_allclose(mode_frf(f, sdof, 64.1, 0.0062, band), [1, 0, 0, 0, 0, 1],
                               atol=1e-6)


def test_input_noise_floor_is_the_noise_beyond_the_band() -> None:
    r = random_test(BEAM, 0.1, 120.0, FS, band=(3.0, 40.0), noise=0.02, seed=4)
    _, s = input_psd(r["base"], FS)
    n_u = (0.02 * float(np.std(r["base"]))) ** 2 * 2 / FS  # white: 2 sigma^2 / fs
    # ~60 Welch averages per line: +/- 13 %; the median over the floor's lines is within 5 %
    assert input_noise_floor(s) == pytest.approx(n_u, rel=0.05)
