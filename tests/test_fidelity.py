"""Waveform fidelity (sloshrom.fidelity): analytical cases, the twin run's exactness, the wiring
of the figures into `reproduce` (its outputs, summary and report), and the benchmark's printout.

Tolerances: the figures are sums over n <= 1e5 float64 samples, whose rounding is at most
n * eps ~ 2e-11 relative; 1e-9 is used where an exact identity holds analytically.
"""

from __future__ import annotations

import importlib.util
import json
import math
from pathlib import Path

import numpy as np
import pytest

from sloshrom import fidelity as fid

FS = 500.0
RTOL = 1e-9  # n eps with n <= 1e5 samples, with margin (module docstring)


def _time(seconds: float) -> np.ndarray:
    return np.arange(int(round(seconds * FS))) / FS


# -- analytical cases ----------------------------------------------------------------------------
def test_rms_ratio_of_two_sines_is_their_amplitude_ratio_whatever_their_means():
    t = _time(10.0)  # 100 whole cycles of 10 Hz: the mean of each sine is 0
    ref = -1.0 + 1.0 * np.sin(2 * np.pi * 10 * t)
    model = 3.0 + 2.0 * np.sin(2 * np.pi * 10 * t + 0.3)
    assert fid.dynamic_rms(ref) == pytest.approx(1 / math.sqrt(2), rel=RTOL)
    assert fid.rms_ratio(ref, model) == pytest.approx(2.0, rel=RTOL)
    assert fid.rms_ratio(np.ones(100), model[:100]) == math.inf


def test_band_power_ratio_of_two_tones_is_their_power_ratio():
    # tones on Welch bins (2 s segments: 0.5 Hz): a Hann window's leakage stays in the
    # neighbouring bins, each band holds one tone's whole power a^2 / 2 (Parseval)
    t = _time(60.0)
    a_lo, a_hi = 2.0, 0.5
    x = 7.0 + a_lo * np.sin(2 * np.pi * 10 * t) + a_hi * np.sin(2 * np.pi * 100 * t)
    assert fid.band_power(x, FS, (5.0, 20.0)) == pytest.approx(a_lo**2 / 2, rel=RTOL)
    assert fid.band_power(x, FS, (60.0, None)) == pytest.approx(a_hi**2 / 2, rel=RTOL)
    assert fid.band_power_ratio(x, FS) == pytest.approx((a_hi / a_lo) ** 2, rel=RTOL)
    # the bands are parameters: a band that holds neither tone has no power
    assert fid.band_power(x, FS, (30.0, 50.0)) == pytest.approx(0.0, abs=1e-9 * a_lo**2)
    assert fid.band_power_ratio(x, FS, high=(5.0, 20.0), low=(60.0, None)) == pytest.approx(
        (a_lo / a_hi) ** 2, rel=RTOL)


def _impact_train(seed: int = 0) -> tuple[np.ndarray, np.ndarray, np.ndarray, float]:
    """A smooth 10 Hz sloshing force with downward impacts of known amplitudes, each followed
    6 ms later by a smaller rebound (one impact, two spikes): force (N), the impacts' samples,
    their amplitudes from the mean (N) and the duration (s)."""
    rng = np.random.default_rng(seed)
    duration = 20.0
    t = _time(duration)
    x = 0.3 * np.sin(2 * np.pi * 10 * t)
    at = np.arange(250, t.size - 250, 50)  # one every 0.1 s
    amp = rng.uniform(3.0, 6.0, at.size)  # rebounds (half) above the 1 N threshold too
    at = at + (rng.integers(0, 3, at.size) if seed else 0)
    x[at] -= amp
    x[at + 3] -= 0.5 * amp  # the rebound, 6 ms after: part of the same impact
    expected = amp - 0.3 * np.sin(2 * np.pi * 10 * t[at]) + x.mean()
    return x, at, expected, duration


def test_impacts_of_a_synthetic_train_are_found_exactly():
    x, at, amp, duration = _impact_train(seed=1)
    idx, found = fid.impact_peaks(x, FS, threshold=1.0)
    np.testing.assert_array_equal(idx, at)
    np.testing.assert_allclose(found, amp, rtol=RTOL)
    assert fid.impact_rate(x, FS, threshold=1.0) == pytest.approx(at.size / duration, rel=RTOL)
    # without the minimum separation, the rebounds count as impacts of their own
    assert fid.impact_peaks(x, FS, 1.0, min_separation=0.0)[0].size == 2 * at.size


def test_white_noise_below_the_threshold_has_no_impact():
    rng = np.random.default_rng(3)
    noise = 0.1 * rng.standard_normal(50_000)
    threshold = 1.01 * np.max(np.abs(noise - noise.mean()))
    assert fid.impact_rate(noise, FS, threshold=threshold) == 0.0
    # the default threshold (3 RMS of the signal itself): Gaussian white noise exceeds it in
    # 0.13 % of its samples, 0.7 /s at 500 Hz, far below the rig's impacts (3-5 /s)
    assert fid.impact_rate(noise, FS) < 1.0
    x, _, _, _ = _impact_train()
    assert fid.impact_rate(np.zeros_like(x), FS) == 0.0  # a constant force: no scale


def test_peak_quantiles_are_those_of_the_peaks():
    # a train of downward spikes on a flat force: the peaks are the spikes
    x = np.zeros(10_000)
    amp = np.linspace(1.0, 10.0, 50)
    x[np.arange(100, 10_000, 198)[:50]] = -amp
    q = fid.peak_quantiles(x, FS, quantiles=(0.0, 0.5, 1.0))
    np.testing.assert_allclose(q, np.quantile(amp + x.mean(), [0.0, 0.5, 1.0]), rtol=RTOL)
    assert np.all(np.isnan(fid.peak_quantiles(np.zeros(100), FS)))
    # upward peaks on request
    np.testing.assert_allclose(fid.peak_quantiles(-x, FS, (1.0,), polarity=1),
                               [10.0 - (-x).mean()], rtol=RTOL)


def test_waveform_fidelity_of_a_signal_against_itself_and_against_a_smooth_model():
    x, at, _, duration = _impact_train()
    same = fid.waveform_fidelity(x, x, FS)
    assert same["fit"] == 100.0 and same["nrmse"] == 0.0 and same["rms_ratio"] == 1.0
    assert same["hf_factor"] == 1.0 and same["impact_rate"] == same["impact_rate_reference"]
    assert same["peak_quantiles"] == same["peak_quantiles_reference"]
    # the smooth part alone: no impact beyond the reference's threshold, little high-frequency
    # power (a 10 Hz sine has none above 60 Hz), weaker RMS
    smooth = 0.3 * np.sin(2 * np.pi * 10 * _time(duration))
    f = fid.waveform_fidelity(x, smooth, FS)
    assert f["impact_rate"] == 0.0 and f["impact_rate_reference"] == pytest.approx(
        at.size / duration, rel=RTOL)
    assert f["impact_threshold"] == pytest.approx(3 * fid.dynamic_rms(x), rel=RTOL)
    assert f["hf_ratio"] < 1e-6 < 1.0 < f["hf_ratio_reference"]
    assert f["rms_ratio"] < 1.0
    assert json.loads(json.dumps(f)) == f  # JSON-able as it is


def test_a_diverged_model_has_nan_figures_and_the_reference_keeps_its_own():
    x, at, _, duration = _impact_train()
    bad = np.full_like(x, np.nan)
    f = fid.waveform_fidelity(x, bad, FS)
    assert set(f) == set(fid.waveform_fidelity(x, x, FS))
    assert math.isnan(f["fit"]) and math.isnan(f["rms_ratio"]) and math.isnan(f["impact_rate"])
    assert f["impact_rate_reference"] == pytest.approx(at.size / duration, rel=RTOL)
    assert math.isnan(fid.point_errors(x, bad)["nrmse"])


def test_refusals_name_the_argument():
    x = np.zeros(100)
    with pytest.raises(fid.FidelityError, match="same length"):
        fid.waveform_fidelity(x, x[:50], FS)
    with pytest.raises(fid.FidelityError, match="fs"):
        fid.band_power(x, -1.0, (5.0, 20.0))
    with pytest.raises(fid.FidelityError, match="band"):
        fid.band_power(x, FS, (20.0, 5.0))
    with pytest.raises(fid.FidelityError, match="threshold"):
        fid.impact_peaks(x, FS, 0.0)
    with pytest.raises(fid.FidelityError, match="polarity"):
        fid.force_peaks(x, FS, polarity=0)
    with pytest.raises(fid.FidelityError, match="finite"):
        fid.dynamic_rms([1.0, np.nan])


# -- the twin run: gain 1 is the nominal run, exactly ---------------------------------------------
def test_random_twin_with_gain_one_is_the_nominal_run(builtin_modal):
    from sloshrom.beam.simulation.coupled import random_response
    from sloshrom.models import FrozenLiquid

    model = FrozenLiquid(1 / FS)
    kw = {"rms_levels_g": [0.1, 0.2], "duration": 4.0, "signal_fs": FS, "output_fs": FS}
    nominal = random_response(model, builtin_modal, **kw)
    same = random_response(model, builtin_modal, gain=1.0, **kw)
    for key in ("base_acceleration", "dynamic_force", "tank_acceleration"):
        np.testing.assert_array_equal(same[key], nominal[key])
    twin = random_response(model, builtin_modal, gain=1.001, **kw)
    np.testing.assert_allclose(twin["base_acceleration"], 1.001 * nominal["base_acceleration"],
                               rtol=RTOL, atol=RTOL * np.max(np.abs(nominal["base_acceleration"])))
    np.testing.assert_array_equal(twin["rms_levels_g"], [0.1, 0.2])


def _ctx(tiny_reproduce):
    from sloshrom.pipeline.context import Context

    return Context(tiny_reproduce["out"], tiny_reproduce["cfg"])


def test_validation_twin_with_gain_one_is_the_record(tiny_reproduce):
    """The data stage's validation record, played again through the rig with gain 1: the same
    force, sample for sample (the input is made again, not read back)."""
    from sloshrom.io import read_record
    from sloshrom.pipeline.data import replay_record

    ctx = _ctx(tiny_reproduce)
    rec = read_record(tiny_reproduce["out"] / "data" / "validation.nc")
    np.testing.assert_array_equal(replay_record(ctx, "validation", 1.0), rec["dynamic_force"])


def test_beam_twin_with_gain_one_is_the_stage_s_rig_run(tiny_reproduce):
    import xarray as xr

    from sloshrom.beam.simulation.cases import simulate_cases
    from sloshrom.pipeline.beam import beam_structure, beam_tests

    ctx = _ctx(tiny_reproduce)
    cfg, fs = ctx.cfg.beam, float(ctx.cfg.rig.fs)
    _, modal = beam_structure(cfg, ctx.tank)
    run = simulate_cases({"twin": ctx.rig()}, beam_tests(cfg, modal, ctx.tank, fs, gain=1.0)[
        "random"], fs)["twin"]
    with xr.open_dataset(tiny_reproduce["out"] / "beam" / "random_rig.nc",
                         engine="h5netcdf") as ds:
        np.testing.assert_array_equal(np.atleast_2d(run["dynamic_force"]),
                                      np.atleast_2d(ds["dynamic_force"].values))


# -- the wiring: outputs, summary, report, benchmark ----------------------------------------------
FIGURE_KEYS = {"nrmse", "fit", "rms_ratio", "hf_ratio", "hf_ratio_reference", "hf_factor",
               "impact_threshold", "impact_rate", "impact_rate_reference", "quantiles",
               "peak_quantiles", "peak_quantiles_reference"}


def _finite_figures(f):
    assert set(f) == FIGURE_KEYS
    for k in FIGURE_KEYS - {"quantiles", "peak_quantiles", "peak_quantiles_reference"}:
        assert math.isfinite(f[k]), k
    assert len(f["peak_quantiles"]) == len(f["quantiles"]) == len(fid.QUANTILES)
    assert all(math.isfinite(v) for v in f["peak_quantiles_reference"])


def test_reproduce_records_the_waveform_figures(tiny_reproduce):
    s = tiny_reproduce["resumed"]
    cfg = tiny_reproduce["cfg"]
    wr = s["stages"]["rom"]["waveform_fidelity"]
    assert wr["twin_gain"] == cfg.rig.twin_gain == 1.001 and wr["twin_seconds"] > 0
    for run in ("rom", "twin"):
        _finite_figures(wr[run])
    # the twin run of the rig is close to the nominal run in its statistics: its RMS within
    # 1 % (the gain is 0.1 %) and its point-wise error well inside the ROM's scale
    assert wr["twin"]["rms_ratio"] == pytest.approx(1.0, abs=0.01)
    assert 0 < wr["twin"]["nrmse"] < 1.0
    wb = s["stages"]["beam"]["waveform_fidelity"]
    assert set(wb["levels"]) == {f"{g:g}" for g in cfg.beam.rms_g}
    assert wb["twin_seconds"] > 0
    for per in wb["levels"].values():
        assert set(per) == {"rom", "twin"}
        for f in per.values():
            _finite_figures(f)
        assert per["twin"]["rms_ratio"] == pytest.approx(1.0, abs=0.01)
    html = (tiny_reproduce["out"] / "report.html").read_text()
    assert "Waveform fidelity" in html and "rig, input × 1.001 (twin)" in html
    # rows rig, ROM and twin for the validation record and for each level (in the paper's
    # sections: "At a glance" names the record too)
    html = html.split("<h2>1. Setup")[1]
    assert html.count("validation record</td>") == 3
    assert html.count("beam random, ") == 3 * len(cfg.beam.rms_g)


def test_report_table_without_the_figures_is_empty():
    from sloshrom.pipeline.report import waveform_table

    assert waveform_table({}, {}) == [] and waveform_table(None, None) == []


def _benchmark():
    path = Path(__file__).parents[1] / "benchmarks" / "fidelity.py"
    spec = importlib.util.spec_from_file_location("bench_fidelity", path)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def test_benchmark_prints_the_waveform_figures_and_n_a_for_an_old_summary(tiny_reproduce,
                                                                           tmp_path, capsys):
    bench = _benchmark()
    path = tiny_reproduce["out"] / "summary.json"
    assert bench.main(["--summary", str(path)]) == 0
    out = capsys.readouterr().out
    assert "force RMS / rig's" in out and "twin" in out and "n/a" not in out.split(
        "waveform")[1]
    # a summary written before the waveform figures: the rest printed, the new lines n/a
    old = json.loads(path.read_text())
    del old["stages"]["rom"]["waveform_fidelity"], old["stages"]["beam"]["waveform_fidelity"]
    (tmp_path / "summary.json").write_text(json.dumps(old))
    assert bench.main(["--summary", str(tmp_path / "summary.json")]) == 0
    out = capsys.readouterr().out
    assert "validation fit" in out and "n/a" in out.split("waveform")[1]
