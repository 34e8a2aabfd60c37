"""SSI-cov (``sloshrom.beam.damping.ssi``), the estimator added through the registry: it recovers a
known oscillator, is reachable by name, and its interval comes from the generic bootstrap."""

from __future__ import annotations

import numpy as np
import pytest

from sloshrom.beam.damping.analysis import AnalysisError
from sloshrom.beam.damping.estimators import DampingEstimator, RandomTest
from sloshrom.beam.damping.registry import ESTIMATORS, TABLE2, get_estimator
from sloshrom.beam.damping.ssi import ssi_cov_damping, ssi_cov_poles
from sloshrom.beam.damping.uncertainty import _simulate, damping_dataset

FS, F1, ZETA = 500.0, 10.0, 0.01


def _sdof(duration: float, seed: int) -> tuple[np.ndarray, np.ndarray]:
    # a base-excited single-degree-of-freedom oscillator under Gaussian white noise
    u, y = _simulate(F1, ZETA, FS, int(duration * FS), 1, (0.0, 0.0),
                     np.random.default_rng(seed))
    return u[0], y[0]


def test_registered_by_name_not_in_table2():
    est = get_estimator("ssi_cov")
    assert isinstance(est, DampingEstimator)
    assert est.uncertainty == "bootstrap" and est.label == "SSI-cov"
    assert "ssi_cov" in ESTIMATORS and "ssi_cov" not in TABLE2


def test_poles_of_a_clean_oscillator():
    # the exact correlation of an oscillator: R(k) ~ exp(-zeta w k dt) cos(w_d k dt); SSI's
    # order-2 model must give the pole itself
    u, y = _sdof(600.0, 1)
    p = ssi_cov_poles(y, FS, 60, 10)
    two = p["order"] == 2
    assert two.sum() == 1
    assert p["frequency"][two][0] == pytest.approx(F1, rel=0.01)
    assert p["zeta"][two][0] == pytest.approx(ZETA, rel=0.3)
    with pytest.raises(AnalysisError, match="must exceed"):
        ssi_cov_poles(y, FS, 10, 10)


def test_the_interval_of_a_short_record_comes_from_the_bootstrap():
    """The fast version of the next test (slow tier): the estimator runs through
    ``damping_dataset`` and gives a value inside an interval of positive width, and the
    frequency, on 90 s with a few resamples."""
    u, y = _sdof(90.0, 200)
    d = damping_dataset(u, y, FS, F1, estimators=["ssi_cov"], n_resamples=4).sel(
        estimator="ssi_cov")
    value, low, high = float(d.value), float(d.low), float(d.high)
    assert str(d.reason.values) == ""
    assert low < value < high and float(d["std"]) > 0
    assert abs(float(d.frequency) / F1 - 1) < 0.005


@pytest.mark.slow  # 600 s and 20 resamples: a statistical benchmark of the estimator
def test_sdof_white_noise_within_its_own_interval():
    # 600 s of a 1 %, 10 Hz oscillator: Au's bound is 5 %, the estimate must land within its
    # own 95 % interval of the truth and the frequency within 0.5 %
    u, y = _sdof(600.0, 200)
    ds = damping_dataset(u, y, FS, F1, estimators=["ssi_cov"], n_resamples=20)
    d = ds.sel(estimator="ssi_cov")
    value, low, high = float(d.value), float(d.low), float(d.high)
    assert str(d.reason.values) == ""
    assert low < ZETA < high
    assert 0 < float(d["std"]) < 0.2 * ZETA  # an interval of a useful width
    assert abs(float(d.frequency) / F1 - 1) < 0.005
    assert value == pytest.approx(ZETA, rel=0.2)


def test_too_short_record_gives_nan_with_its_reason():
    u, y = _sdof(8.0, 3)
    e = get_estimator("ssi_cov").estimate(RandomTest(u, y, FS, F1))
    assert np.isnan(e.value) and "too short" in e.reason
    with pytest.raises(AnalysisError, match="too short"):
        ssi_cov_damping(y, FS, F1, (5.0, 15.0))
