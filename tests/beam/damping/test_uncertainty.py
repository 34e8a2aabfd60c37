"""Intervals of the damping estimates (sloshrom.beam.damping.uncertainty) on records of known
damping.

Truth: the base-excited SDOF of benchmarks/damping_estimators.py (10 Hz, zeta 1 %, exact ZOH
discretisation at 500 Hz, Gaussian white base, 90 s) plus white sensor noise of 5 % of each
channel's RMS; and a free decay 8 exp(-zeta w t) cos(w_d t) "g" plus 0.04 g of white noise,
12 s, crossing the bands 0.5-1, 1-2, 2-3 and 3-5 g (slow tier: 10 Hz, 1.37 % and 64 Hz, 0.62 %
with 0.05 g).

Coverage bounds. Fast tier: 10 random records (20 decays); a correct 95 % interval covers >= 8
of 10 (>= 16 of 20) with probability 0.99 (0.98, binomial); one that misses the bias of the
uncorrected H1 estimate (-7 % at this noise, 1.7 % scatter) covers almost none. To catch
intervals that are merely wide, the mean stated standard deviation must be within a factor 2 of
the estimates' scatter. Slow tier: 100 records per estimator, coverage in [90, 98] % (the
acceptance figure), except where docs/beam.md reports a measured miss.
"""

from __future__ import annotations

import importlib.util
import math
import warnings

import numpy as np
import pytest
from scipy import stats

from helpers import REPO
from sloshrom.beam.damping.analysis import instantaneous_damping, log_decrement
from sloshrom.beam.damping.tables import Mode1Decay, damping_band_table, damping_summary
from sloshrom.beam.damping.uncertainty import (
    ShortRecordWarning,
    au_damping_cov,
    band_damping,
    mode1_damping_random,
    random_damping,
    required_duration,
)
from sloshrom.beam.errors import BeamError
from sloshrom.config import G

# the truth and the coverage statistics are the benchmark's own (one definition of each)
_SPEC = importlib.util.spec_from_file_location(
    "damping_estimators", REPO / "benchmarks"
    / "damping_estimators.py")
_BENCH = importlib.util.module_from_spec(_SPEC)
_SPEC.loader.exec_module(_BENCH)
coverage_decay, coverage_random = _BENCH.coverage_decay, _BENCH.coverage_random
noisy_decay, noisy_sdof = _BENCH.noisy_decay, _BENCH.noisy_sdof

FS, F1, ZETA = 500.0, 10.0, 0.01


def test_au_law_and_its_inverse():
    # 1 / sqrt(2 pi zeta f T): 13.3 % for 1 %, 10 Hz, 90 s
    assert au_damping_cov(0.01, 10.0, 90.0) == pytest.approx(1 / math.sqrt(0.01 * 2 * np.pi
                                                                           * 10 * 90))
    assert au_damping_cov(0.01, 10.0, 90.0) == pytest.approx(0.1330, abs=1e-4)
    t = required_duration(0.01, 10.0, 0.05)
    assert au_damping_cov(0.01, 10.0, t) == pytest.approx(0.05)
    with pytest.raises(BeamError):
        au_damping_cov(0.0, 10.0, 90.0)
    with pytest.raises(BeamError):
        required_duration(0.01, 10.0, -0.1)


@pytest.fixture(scope="module")
def one_record():
    u, y = noisy_sdof(90.0, 3, 0.05)
    return u, y, random_damping(u, y, FS, F1, n_resamples=10)


def test_random_damping_keys_and_raw_values(one_record):
    u, y, d = one_record
    raw = mode1_damping_random(u, y, FS, F1)
    assert set(raw) <= set(d)
    # the raw estimates are those of mode1_damping_random; output-only is not corrected
    assert d["lscf_h1_uncorrected"] == raw["lscf_h1"]
    assert d["half_power_uncorrected"] == raw["half_power"]
    assert d["lscf_output"] == raw["lscf_output"]
    t_boot = stats.t.ppf(0.975, 9)  # the spreads are estimated from 10 simulated records
    for est in ("lscf_h1", "lscf_output", "half_power"):
        assert d[f"{est}_low"] < d[est] < d[f"{est}_high"]
        assert d[f"{est}_std"] > 0
        below, above = d[est] - d[f"{est}_low"], d[f"{est}_high"] - d[est]
        if est == "lscf_output":
            # widened on one side by the bootstrap's bias (the bias-corrected value's interval)
            assert min(below, above) == pytest.approx(t_boot * d[f"{est}_std"])
            assert max(below, above) > t_boot * d[f"{est}_std"]
        else:
            assert below == pytest.approx(above) == pytest.approx(t_boot * d[f"{est}_std"])
    assert d["duration_s"] == pytest.approx(90.0)
    assert d["n_cycles"] == pytest.approx(900.0, rel=0.01)
    # the noise fit sees the 5 % input noise: ratio 0.0025
    assert 0.001 < d["noise_input"] < 0.005


def test_output_only_takes_the_bootstrap_spread_or_else_au_s_law(one_record, monkeypatch):
    """Output-only LSCF's std is the spread of the simulated records' output-only estimates
    (not Au's law, which overstates it once the base's colour is divided out); where the
    simulated records give none, Au's law times the efficiency, with the normal quantile."""
    from sloshrom.beam.damping.estimators import OUTPUT_ONLY_EFFICIENCY, LscfOutput

    u, y, d = one_record
    au = OUTPUT_ONLY_EFFICIENCY * d["lscf_output"] * au_damping_cov(
        d["lscf_output"], d["frequency_output"], 90.0)
    assert d["lscf_output_std"] != pytest.approx(au, rel=0.05)
    monkeypatch.setattr(LscfOutput, "estimate_records",
                        lambda self, records: np.full(records.base.shape[0], np.nan))
    e = random_damping(u, y, FS, F1, n_resamples=10)
    assert e["lscf_output"] == d["lscf_output"]  # the raw value either way
    assert e["lscf_output_std"] == pytest.approx(au, rel=1e-12)
    assert e["lscf_output_high"] - e["lscf_output_low"] == pytest.approx(
        2 * 1.959964 * au, rel=1e-6)
    assert e["lscf_h1_std"] == d["lscf_h1_std"]  # the others' bootstrap as before


def test_output_only_interval_holds_the_raw_and_the_bias_corrected_value(one_record,
                                                                         monkeypatch):
    """The output-only interval is the union of t std around the raw value and around the
    value less the bootstrap's bias (mean of the simulated estimates less the simulated
    damping, the raw LSCF H1 value): the bias is the record's on a lone mode, not always among
    other modes."""
    from sloshrom.beam.damping.estimators import LscfOutput

    u, y, d = one_record
    zeta_sim = d["lscf_h1_uncorrected"]  # the simulated mode's damping
    spread = 0.01 * np.linspace(-1.0, 1.0, 10)  # std 0.0067 of zeta_sim
    t_boot = stats.t.ppf(0.975, 9)
    for rel_bias in (-0.1, 0.2):
        monkeypatch.setattr(LscfOutput, "estimate_records", lambda self, records, b=rel_bias:
                            zeta_sim * (1 + b + spread[:records.base.shape[0]]))
        e = random_damping(u, y, FS, F1, n_resamples=10)
        v, std, corrected = e["lscf_output"], e["lscf_output_std"], d["lscf_output"] - (
            rel_bias * zeta_sim)
        assert v == d["lscf_output"]  # the raw value: not corrected
        assert std == pytest.approx(zeta_sim * spread.std(ddof=1), rel=1e-9)
        assert e["lscf_output_low"] == pytest.approx(min(v, corrected) - t_boot * std)
        assert e["lscf_output_high"] == pytest.approx(max(v, corrected) + t_boot * std)


def test_short_record_warning(one_record):
    u, y, d = one_record
    with pytest.warns(ShortRecordWarning, match=r"gives ±\d+ % \(1 sigma\).*±5 % needs \d+ s"):
        random_damping(u, y, FS, F1, n_resamples=2, accuracy=0.05)
    with warnings.catch_warnings():
        warnings.simplefilter("error", ShortRecordWarning)
        random_damping(u, y, FS, F1, n_resamples=2, accuracy=0.5)
    need = required_duration(d["lscf_output"], d["frequency_output"], 0.05 / 1.3)
    assert need > 600  # 1 % at 10 Hz: +-5 % needs about 20 minutes with this estimator


def test_batched_bootstrap_equals_the_record_by_record_estimates():
    # the bootstrap analyses its simulated records as a stack: every record must get exactly
    # (bit for bit) the H1 and the LSCF poles it gets alone
    from sloshrom.beam.damping.analysis import frf_h1, lscf_poles, lscf_poles_batch
    from sloshrom.beam.damping.uncertainty import _simulate

    u, y = _simulate(F1, ZETA, FS, 20000, 3, (0.002, 0.01), np.random.default_rng(5))
    f, h, coh = frf_h1(u, y, FS, 8192, one_pass=True)
    band = (0.5 * F1, 1.5 * F1)
    stacked = lscf_poles_batch(f, h, band)
    assert len(stacked) == 3
    for k in range(3):
        f1, h1, coh1 = frf_h1(u[k], y[k], FS, 8192, one_pass=True)
        assert np.array_equal(f1, f)
        assert np.array_equal(h1, h[k]) and np.array_equal(coh1, coh[k])
        alone = lscf_poles(f, h[k], band)
        assert stacked[k].keys() == alone.keys()
        for key in alone:
            assert np.array_equal(stacked[k][key], alone[key]), key
    with pytest.raises(BeamError, match="2-D"):
        lscf_poles_batch(f, h[0], band)


def test_random_damping_bad_inputs():
    u, y = noisy_sdof(10.0, 0, 0.0)
    with pytest.raises(BeamError):
        random_damping(u, y[:-1], FS, F1)
    with pytest.raises(BeamError):
        random_damping(u, y, FS, F1, confidence=1.5)
    with pytest.raises(BeamError):
        random_damping(u, y, FS, F1, n_resamples=1)


def _assert_coverage(c: dict, n: int, k_min: int) -> None:
    # coverage among the records with an estimate (half power may find no peak: no interval)
    assert c["n"] >= n - 1
    assert round(c["coverage"] * c["n"]) >= k_min - (n - c["n"]), c
    # intervals must not be merely wide: stated std within a factor 2 of the actual scatter
    assert 0.5 <= c["stated_std"] / c["scatter"] <= 2.0, c


@pytest.mark.long
def test_random_coverage_fast():
    # 10 records (each 21 LSCF fits): >= 8 covered has probability 0.99 for a correct interval
    seeds = list(range(100, 110))
    table = coverage_random(90.0, seeds, 0.05, n_resamples=10)
    for est in ("lscf_h1", "half_power", "lscf_output"):
        _assert_coverage(table[est], 10, 8)
    # the correction matters: the raw H1 estimate is biased by several of its scatters
    raw = table["lscf_h1_uncorrected"]
    assert abs(raw["bias"]) > 2 * raw["scatter"]
    assert abs(table["lscf_h1"]["bias"]) < table["lscf_h1"]["scatter"]


@pytest.mark.long
def test_band_coverage_fast():
    # 12 s: the decay reaches the noise floor, which the bootstrap's noise is measured from
    # (an 8 s record ends at 0.05 g, 5 times the floor, and the floor is then an upper bound)
    table = coverage_decay(0.04, list(range(20)), duration=12.0)
    assert len(table) == 8
    for c in table.values():
        _assert_coverage(c, 20, 16)


def test_band_damping_noise_free_decay_is_narrow_and_right():
    x = noisy_decay(0.0, 0)
    rows = band_damping(instantaneous_damping(x, FS, F1), log_decrement(x, FS, F1), F1,
                        amplitude_scale=1.0)
    assert [(r["band"], r["method"]) for r in rows[:2]] == [("0.5-1 g", "hilbert"),
                                                             ("0.5-1 g", "log_decrement")]
    for r in rows:
        assert r["zeta"] == pytest.approx(ZETA, rel=2e-3)
        # noisy decays: 2.5-8 %; without noise only the method's own tiny bias is left, which
        # the interval (the record's statistical error) need not cover
        assert r["high"] - r["low"] < 0.02 * ZETA
        lo, hi = map(float, r["band"].removesuffix(" g").split("-"))
        # ln(hi / lo) / (2 pi zeta) cycles (log decrement: one fewer, between its peaks)
        assert r["n_cycles"] == pytest.approx(math.log(hi / lo) / (2 * np.pi * ZETA), rel=0.2)


def test_band_damping_missing_band_and_bad_input():
    x = noisy_decay(0.01, 0, amplitude_g=1.5)  # never reaches 2 g
    h, ld = instantaneous_damping(x, FS, F1), log_decrement(x, FS, F1)
    rows = {(r["band"], r["method"]): r for r in band_damping(h, ld, F1, amplitude_scale=1.0)}
    for method in ("hilbert", "log_decrement"):
        assert np.isnan(rows[("3-5 g", method)]["zeta"])
        assert np.isnan(rows[("3-5 g", method)]["low"])
        assert np.isfinite(rows[("0.5-1 g", method)]["zeta"])
    with pytest.raises(BeamError, match="peak_time"):
        band_damping(h, {"time": ld["time"], "zeta": ld["zeta"]}, F1)


def test_damping_band_table_in_g_and_summary_unchanged():
    x = noisy_decay(0.04, 1) * G  # m/s^2, as the tank acceleration of a free response
    decay = Mode1Decay(modal=x[:, None], hilbert=instantaneous_damping(x, FS, F1),
                       log_decrement=log_decrement(x, FS, F1))
    free = {"rig": {"tank_acceleration": x, "fs": FS}}
    rows = damping_band_table(free, {"rig": decay}, F1)
    assert list(rows[0]) == ["case", "band", "method", "zeta", "std", "low", "high", "n_cycles",
                            "reason"]
    assert {r["band"] for r in rows} == {"0.5-1 g", "1-2 g", "2-3 g", "3-5 g"}
    summary = damping_summary(free, {"rig": decay})["rig"]
    hilbert = {r["band"]: r["zeta"] for r in rows if r["method"] == "hilbert"}
    for band, z in hilbert.items():
        assert z == pytest.approx(summary[band])  # the same median as the summary's


# --- slow tier: the acceptance test, 100 records per estimator -------------------------------
@pytest.mark.slow
def test_random_coverage_100_records():
    table = coverage_random(90.0, list(range(1000, 1100)), 0.05)
    for est in ("lscf_h1", "half_power", "lscf_output"):
        assert 0.90 <= table[est]["coverage"] <= 0.98, (est, table[est])


@pytest.mark.slow
@pytest.mark.parametrize("f, zeta, duration", _BENCH.DECAY_MODES)
def test_band_coverage_100_records(f, zeta, duration):
    # the bootstrap's intervals, at the noise where they hold the whole error (0.05 g white:
    # 0.008 g band-passed at 10 Hz); at 0.005 g the method's own deterministic bias (0.1-0.2 %
    # of zeta) is no longer small against them (docs/beam.md)
    table = coverage_decay(0.05, list(range(1000, 1100)), f, zeta, duration)
    for key, c in table.items():
        assert c["coverage"] >= 0.90, (key, c)
        # not merely wide: 3.9-4.3 times the scatter for a calibrated interval (measured 3.7-5.2
        # on seeds 0-99). Hilbert 3-5 g at 10 Hz covers 100 % on these seeds with a calibrated
        # width (docs/beam.md): the width, not the count, is the test of a too wide interval
        assert c["width"] / c["scatter"] < 6, (key, c)


def test_a_missing_estimate_carries_its_reason():
    # 34 s with 1 % input and 5 % output noise: LSCF finds no stable cluster (NaN), half power
    # still a value; every NaN says why, and the dataset holds what the flat columns hold
    from sloshrom.beam.damping.columns import table2_columns
    from sloshrom.beam.damping.uncertainty import _simulate, estimate_random

    u, y = _simulate(F1, ZETA, FS, 17000, 1, (0.01, 0.05), np.random.default_rng(5))
    result = estimate_random(u[0], y[0], FS, F1, n_resamples=12)
    ds = result.to_dataset()
    assert ds["value"].dims == ("estimator",)
    assert list(ds.estimator.values) == ["lscf_h1", "lscf_output", "half_power"]
    for est in ds.estimator.values:
        e = ds.sel(estimator=est)
        has_all = all(np.isfinite(float(e[v])) for v in ("value", "std", "low", "high"))
        assert (str(e.reason.values) == "") == has_all, est
    assert "stable" in str(ds.reason.sel(estimator="lscf_h1").values)
    flat = table2_columns(result)  # what random_damping returns and Table 2 files hold
    for est in ds.estimator.values:
        for v, suffix in (("value", ""), ("std", "_std"), ("low", "_low"), ("high", "_high")):
            np.testing.assert_equal(float(ds[v].sel(estimator=est)), flat[f"{est}{suffix}"])
