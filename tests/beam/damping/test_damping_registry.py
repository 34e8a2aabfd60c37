"""The registry of damping estimators (``sloshrom.beam.damping.registry``): one list, checked names,
and the Table 2 rows seen as a dataset over (level, estimator)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pytest

from sloshrom.beam.damping.columns import table2_dataset
from sloshrom.beam.damping.estimators import DampingEstimate, DampingEstimator, RandomTest
from sloshrom.beam.damping.registry import (
    ESTIMATORS,
    REFERENCE,
    TABLE2,
    estimator_names,
    get_estimator,
    label,
    register,
)
from sloshrom.beam.errors import BeamError


@dataclass(frozen=True)
class _Fake:
    name: str = "fake_one"
    label: str = "fake"
    uncertainty: str = "bootstrap"
    efficiency: float = float("nan")

    def estimate(self, test: RandomTest) -> DampingEstimate:
        return DampingEstimate(value=float("nan"), reason="fake")

    def estimate_records(self, records: RandomTest) -> np.ndarray:
        return np.full(records.base.shape[0], np.nan)


def test_table2_is_the_papers_three_in_order():
    assert TABLE2 == ("lscf_h1", "lscf_output", "half_power")
    assert REFERENCE == "lscf_h1"
    assert [label(n) for n in TABLE2] == ["LSCF on H1", "output-only LSCF", "half power"]
    assert label("hilbert") == "Hilbert"
    for est in ESTIMATORS.values():
        assert isinstance(est, DampingEstimator)


def test_names_are_checked():
    assert estimator_names() == TABLE2
    assert estimator_names(["ssi_cov", "lscf_h1", "ssi_cov"]) == ("ssi_cov", "lscf_h1")
    with pytest.raises(BeamError, match="unknown damping estimator 'nope'; known: lscf_h1"):
        get_estimator("nope")
    with pytest.raises(BeamError, match="no damping estimator"):
        estimator_names([])
    with pytest.raises(BeamError, match="already registered"):
        register(_Fake(name="lscf_h1"))
    with pytest.raises(BeamError, match="lower-case identifier"):
        register(_Fake(name="Bad name"))
    with pytest.raises(BeamError, match="uncertainty must be"):
        register(_Fake(uncertainty="guess"))
    assert "fake_one" not in ESTIMATORS


def test_table2_rows_as_a_dataset():
    rows = [{"case": "x", "rms_g": lv, "lscf_h1": 0.01, "lscf_h1_std": 0.001,
             "lscf_h1_low": 0.008, "lscf_h1_high": 0.012, "ssi_cov": 0.011} for lv in (0.1, 0.2)]
    ds = table2_dataset(rows)
    assert ds["value"].dims == ("level", "estimator")
    assert list(ds.estimator.values) == [*TABLE2, "ssi_cov"]
    assert ds.level.values.tolist() == [0.1, 0.2]
    assert float(ds["low"].sel(level=0.2, estimator="lscf_h1")) == pytest.approx(0.008)
    assert np.isnan(float(ds["value"].sel(level=0.1, estimator="half_power")))
    assert float(ds["value"].sel(level=0.1, estimator="ssi_cov")) == pytest.approx(0.011)


@pytest.mark.long
def test_table2_as_a_dataset_over_case_level_estimator():
    # output-only LSCF alone (Au's law, no bootstrap: fast); the dataset holds what the rows do
    from sloshrom.beam.damping.tables import mode1_damping_dataset, mode1_damping_table
    from sloshrom.beam.damping.uncertainty import _simulate

    u, y = _simulate(10.0, 0.01, 500.0, 20000, 2, (0.0, 0.0), np.random.default_rng(1))
    rnd = {"a": {"base_acceleration": u, "tank_acceleration": y, "fs": 500.0},
           "b": {"base_acceleration": u[::-1], "tank_acceleration": y[::-1], "fs": 500.0}}
    out_only = TABLE2[1]
    ds = mode1_damping_dataset(rnd, [0.1, 0.2], 10.0, estimators=[out_only])
    rows = mode1_damping_table(rnd, [0.1, 0.2], 10.0, estimators=[out_only])
    assert ds["value"].dims == ("case", "level", "estimator")
    assert ds["noise_input"].dims == ("case", "level")
    assert ds.case.values.tolist() == ["a", "b"] and ds.level.values.tolist() == [0.1, 0.2]
    for r in rows:
        e = ds.sel(case=r["case"], level=r["rms_g"], estimator=out_only)
        for v, suffix in (("value", ""), ("std", "_std"), ("low", "_low"), ("high", "_high")):
            np.testing.assert_equal(float(e[v]), r[out_only + suffix])
        assert (str(e.reason.values) == "") == bool(np.isfinite(float(e["value"])))
