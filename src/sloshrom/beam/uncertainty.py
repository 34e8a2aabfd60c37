"""Uncertainty of the first-mode damping estimates of the beam tests: every damping ratio with
its standard deviation and confidence interval.

* :func:`au_damping_cov`, :func:`required_duration` - Au's uncertainty law of output-only
  (ambient) damping identification and its inverse (the record length a precision needs).
* :func:`band_damping` - free decays: Hilbert and log-decrement damping per amplitude band,
  with intervals.
* :func:`random_damping` - random tests (paper Table 2): the estimators of
  :func:`sloshrom.beam.analysis.mode1_damping_random`, the leakage bias of the H1 estimators
  removed, each with a standard deviation and an interval.
* :func:`expected_h1`, :func:`leakage_bias` - the Welch H1 that a single mode gives on average
  under white input, and the bias of an estimator on it.

Pure numerical functions: arrays in, dicts out. Intervals are two-sided at ``confidence``
(default :data:`CONFIDENCE`); NaN where an estimate or its spread cannot be formed.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Callable, Mapping, Sequence
from typing import Any

import numpy as np
from scipy import fft, stats
from scipy.signal import get_window

from sloshrom.beam.analysis import (
    AnalysisError,
    frf_h1,
    half_power_damping,
    lscf_cluster_damping,
    output_only_damping,
)
from sloshrom.beam.errors import BeamError
from sloshrom.config import G

__all__ = [
    "BANDS", "CONFIDENCE", "OUTPUT_ONLY_EFFICIENCY", "ShortRecordWarning", "au_damping_cov",
    "band_damping", "expected_h1", "leakage_bias", "random_damping", "required_duration",
    "welch_averages",
]

#: Two-sided confidence level of every interval.
CONFIDENCE: float = 0.95

#: Bands of tank-acceleration amplitude (g) in which the instantaneous first-mode damping is
#: summarised.
BANDS: tuple[tuple[float, float], ...] = ((0.5, 1.0), (1.0, 2.0), (2.0, 3.0), (3.0, 5.0))

#: Scatter of the output-only estimator (``analysis.output_only_damping``) over Au's bound
#: ``1 / sqrt(zeta omega_n T)``: 17.2 % / 13.3 % = 1.29 at 90 s and 6.8 % / 5.2 % = 1.31 at 600 s
#: (standard deviation over 50 records of a base-excited 1 %, 10 Hz oscillator under Gaussian
#: white noise, ``benchmarks/damping_estimators.py``).
OUTPUT_ONLY_EFFICIENCY: float = 1.3


class ShortRecordWarning(UserWarning):
    """A random test is too short for the asked precision of the damping ratio; the message
    says how long the record would need to be."""


# -- Au's uncertainty law -------------------------------------------------------------------------
def au_damping_cov(zeta: float, frequency: float, duration: float) -> float:
    """Au's uncertainty law: coefficient of variation of an output-only damping ratio.

    For a well-separated, lightly damped mode identified from ``duration`` seconds of its
    response to broadband excitation, ``cov(zeta) ~ 1 / sqrt(2 pi zeta N_c B_zeta)`` with
    ``N_c = frequency * duration`` cycles and the data-length factor ``B_zeta -> 1`` for a wide
    fitting band (S.-K. Au, "Uncertainty law in ambient modal identification - Part I: Theory",
    Mech. Syst. Signal Process. 48, 2014). Equivalently ``1 / sqrt(zeta omega_n T)``.

    Parameters
    ----------
    zeta : float
        Damping ratio, -.
    frequency : float
        Natural frequency, Hz.
    duration : float
        Record length, s.

    Returns
    -------
    float
        Coefficient of variation (1 sigma) of the damping ratio, -.
    """
    if not (zeta > 0 and frequency > 0 and duration > 0):
        raise BeamError("zeta, frequency and duration must be positive")
    return 1.0 / math.sqrt(2 * math.pi * zeta * frequency * duration)


def required_duration(zeta: float, frequency: float, cov: float) -> float:
    """Record length (s) for which :func:`au_damping_cov` equals ``cov`` (-):
    ``T = 1 / (2 pi zeta frequency cov^2)``."""
    if not (zeta > 0 and frequency > 0 and cov > 0):
        raise BeamError("zeta, frequency and cov must be positive")
    return 1.0 / (2 * math.pi * zeta * frequency * cov**2)


def _z(confidence: float) -> float:
    if not 0 < confidence < 1:
        raise BeamError(f"confidence must be in (0, 1), got {confidence}")
    return float(stats.norm.ppf(0.5 + 0.5 * confidence))


def _t(confidence: float, dof: float) -> float:
    _z(confidence)
    return float(stats.t.ppf(0.5 + 0.5 * confidence, dof))


# -- free decays ----------------------------------------------------------------------------------
def _row(band: str, method: str, zeta: float, std: float, half: float,
         n_cycles: float) -> dict[str, Any]:
    return {"band": band, "method": method, "zeta": float(zeta), "std": float(std),
            "low": float(zeta - half), "high": float(zeta + half), "n_cycles": float(n_cycles)}


def band_damping(
    hilbert: Mapping[str, Any],
    log_decrement: Mapping[str, Any],
    f1: float,
    *,
    amplitude_scale: float = 1 / G,
    bands: Sequence[tuple[float, float]] = BANDS,
    confidence: float = CONFIDENCE,
    smooth_periods: float = 4.0,
) -> list[dict[str, Any]]:
    """Instantaneous first-mode damping per amplitude band of a free decay, with intervals.

    * ``hilbert``: the median of ``zeta(t)`` over the samples whose amplitude is in the band.
      Its samples are correlated over the smoothing window of ``smooth_periods`` periods, so the
      band holds about ``n_eff = n_cycles / smooth_periods`` independent values; standard error
      of the median ``1.2533 s / sqrt(n_eff)`` (s the samples' standard deviation), interval
      from Student's t with ``n_eff - 1`` degrees of freedom (at least one).
    * ``log_decrement``: least-squares slope ``-sigma`` of ``ln(peak)`` against time over the
      peaks in the band, ``zeta = sigma / sqrt(omega_d^2 + sigma^2)`` with ``omega_d`` from the
      median peak spacing; standard error of the slope, Student's t with ``n_peaks - 2``
      degrees of freedom.

    A noise-free decay gives very narrow intervals: they hold the record's statistical error
    only, not the method's own (small) bias.

    Parameters
    ----------
    hilbert, log_decrement : mapping
        Results of ``sloshrom.beam.analysis.instantaneous_damping`` and ``log_decrement`` (the
        latter with its per-peak entries ``peak_time``, ``peak``, ``peak_amplitude``);
        amplitudes in the reference's unit.
    f1 : float
        First-mode frequency (the band-pass centre), Hz.
    amplitude_scale : float
        Factor from the amplitude's unit to the unit of ``bands`` (default m/s^2 -> g).
    bands : sequence of (float, float)
        Amplitude bands ``[low, high)``.
    confidence : float
        Two-sided confidence level of the intervals.
    smooth_periods : float
        The smoothing window of ``instantaneous_damping``, periods.

    Returns
    -------
    list of dict
        One row per band and method (Hilbert first): ``band`` (e.g. ``"1-2 g"`` when the
        bands are in g), ``method`` (``"hilbert"`` or ``"log_decrement"``), ``zeta``, ``std``,
        ``low``, ``high`` (damping ratio, -) and ``n_cycles`` (cycles of the band, -); NaN where
        the band has too little data (fewer than 2 independent Hilbert values, 3 peaks).
    """
    missing = [k for k in ("peak_time", "peak", "peak_amplitude") if k not in log_decrement]
    if missing:
        raise BeamError(f"log_decrement lacks {missing}: pass the dict of analysis.log_decrement")
    if f1 <= 0 or smooth_periods <= 0:
        raise BeamError("f1 and smooth_periods must be positive")
    nan = float("nan")
    zh = np.asarray(hilbert["zeta"], dtype=float)
    ah = np.asarray(hilbert["amplitude"], dtype=float) * amplitude_scale
    th = np.asarray(hilbert["time"], dtype=float)
    fh = np.asarray(hilbert.get("frequency", np.full(zh.size, f1)), dtype=float)
    dt = float(np.min(np.diff(th))) if th.size > 1 else nan
    tp = np.asarray(log_decrement["peak_time"], dtype=float)
    lp = np.log(np.abs(np.asarray(log_decrement["peak"], dtype=float)))
    ap = np.asarray(log_decrement["peak_amplitude"], dtype=float) * amplitude_scale
    rows = []
    for lo, hi in bands:
        name = f"{lo:g}-{hi:g} g" if amplitude_scale == 1 / G else f"{lo:g}-{hi:g}"
        sel = (ah >= lo) & (ah < hi)
        n_cyc = float(np.count_nonzero(sel) * dt * np.median(fh[sel])) if sel.any() else 0.0
        n_eff = n_cyc / smooth_periods
        if n_eff >= 2 and np.isfinite(dt):
            z = float(np.median(zh[sel]))
            std = 1.2533 * float(np.std(zh[sel], ddof=1)) / math.sqrt(n_eff)
            rows.append(_row(name, "hilbert", z, std, _t(confidence, n_eff - 1) * std, n_cyc))
        else:
            rows.append(_row(name, "hilbert", nan, nan, nan, n_cyc))
        sp = (ap >= lo) & (ap < hi)
        t, y = tp[sp], lp[sp]
        if t.size >= 3:
            fit = stats.linregress(t, y)
            sigma = -fit.slope
            wd = 2 * math.pi / float(np.median(np.diff(t)))
            z = sigma / math.hypot(wd, sigma)
            std = fit.stderr / wd
            n_cyc_p = (t[-1] - t[0]) * wd / (2 * math.pi)
            half = _t(confidence, t.size - 2) * std
            rows.append(_row(name, "log_decrement", z, std, half, n_cyc_p))
        else:
            rows.append(_row(name, "log_decrement", nan, nan, nan, max(t.size - 1, 0)))
    return rows


# -- random tests: leakage bias of Welch H1 --------------------------------------------------------
def welch_averages(n: int, nperseg: int) -> tuple[int, float]:
    """Number of Hann segments with 50 % overlap in ``n`` samples and their effective number
    of independent averages ``n_d = K / (1 + 2 sum_j (1 - j/K) rho_j^2)`` (Welch 1967; Hann at
    50 % overlap: ``rho_1 = 1/6``, ``rho_j = 0`` beyond)."""
    nperseg = min(int(nperseg), int(n))
    k = 1 + (int(n) - nperseg) // (nperseg // 2) if nperseg >= 2 else 1
    rho1 = 1.0 / 6.0
    return k, k / (1 + 2 * (1 - 1 / k) * rho1**2) if k > 1 else 1.0


def _hann_lag_correlation(nperseg: int) -> np.ndarray:
    # w2[k] = sum_n w[n] w[n + k] / sum_n w[n]^2, k = 0..N-1 (scipy's periodic Hann, as welch)
    w = get_window("hann", nperseg)
    m = fft.next_fast_len(2 * nperseg, real=True)
    wf = fft.rfft(w, m)
    r = fft.irfft(wf.real**2 + wf.imag**2, m)[:nperseg]
    return r / r[0]


def expected_h1(frequency: float, zeta: float, fs: float, nperseg: int) -> tuple[np.ndarray,
                                                                                np.ndarray]:
    """The Welch H1 (Hann, 50 % overlap, ``nperseg``) of one mode under white input, on average.

    For white input the expected cross-spectrum of the segments is the DFT of the causal
    impulse response times the window's lag correlation ``w2[k] = sum_n w_n w_{n+k} /
    sum_n w_n^2`` (``k = 0 .. nperseg - 1``), and the expected input spectrum is flat: the
    window smears the resonance (leakage) and widens the peak. The mode is ``h(t) = exp(-zeta
    omega_n t) sin(omega_d t)`` (a displacement-type residue; the bias depends on the pole).

    Parameters
    ----------
    frequency : float
        Undamped natural frequency, Hz.
    zeta : float
        Damping ratio, -.
    fs : float
        Sampling frequency, Hz.
    nperseg : int
        Welch segment length, samples.

    Returns
    -------
    (ndarray, ndarray)
        Frequencies (Hz, as ``frf_h1``) and the expected H1 (complex, arbitrary scale).
    """
    wn = 2 * math.pi * frequency
    t = np.arange(int(nperseg)) / fs
    h = np.exp(-zeta * wn * t) * np.sin(wn * math.sqrt(1 - zeta**2) * t)
    return fft.rfftfreq(int(nperseg), 1 / fs), fft.rfft(h * _hann_lag_correlation(int(nperseg)))


def leakage_bias(estimator: Callable[[np.ndarray, np.ndarray], float], frequency: float,
                 zeta: float, fs: float, nperseg: int) -> float:
    """Bias of a damping estimator of an H1 (``estimator(f, H) -> zeta``) caused by the Welch
    window: ``estimator(expected_h1(frequency, zeta)) - zeta`` (damping ratio, -)."""
    f, h = expected_h1(frequency, zeta, fs, nperseg)
    return float(estimator(f, h)) - zeta


def _corrected(estimator: Callable[[np.ndarray, np.ndarray], float], raw: float,
               frequency: float, fs: float, nperseg: int) -> tuple[float, float]:
    # b from the mode as fitted, then once more from the corrected mode (the bias grows with
    # the leakage, i.e. as zeta falls, so the first step under-corrects slightly)
    if not (np.isfinite(raw) and raw > 0 and np.isfinite(frequency)):
        return float("nan"), float("nan")
    b = leakage_bias(estimator, frequency, raw, fs, nperseg)
    if np.isfinite(b) and raw - b > 0:
        b2 = leakage_bias(estimator, frequency, raw - b, fs, nperseg)
        b = b2 if np.isfinite(b2) else b
    return raw - b, b


# -- random tests ---------------------------------------------------------------------------------
def _hann_correlated_noise(rng: np.random.Generator, shape: tuple[int, int]) -> np.ndarray:
    # the Hann window's DFT is [-1/4, 1/2, -1/4] times the rectangular window's (independent
    # lines): neighbouring lines of a Hann spectrum correlate -2/3, lines two apart 1/6
    e = (rng.standard_normal((shape[0], shape[1] + 2))
         + 1j * rng.standard_normal((shape[0], shape[1] + 2))) / math.sqrt(2)
    return (0.5 * e[:, 1:-1] - 0.25 * (e[:, :-2] + e[:, 2:])) / math.sqrt(0.375)


def random_damping(
    base: Any,
    tank: Any,
    fs: float,
    f1: float,
    *,
    confidence: float = CONFIDENCE,
    n_resamples: int = 100,
    seed: int = 0,
    accuracy: float | None = None,
    rel_band: float = 0.5,
    nperseg: int = 16384,
) -> dict[str, Any]:
    """First-mode damping of a random test (paper Table 2) with standard deviations and
    intervals.

    * ``lscf_h1`` and ``half_power`` (estimates on the Welch H1): the window's leakage bias is
      removed with the fitted mode itself (:func:`leakage_bias` on :func:`expected_h1` of the
      estimated frequency and damping, iterated once); the raw values are kept as
      ``lscf_h1_uncorrected`` and ``half_power_uncorrected``. Spread: parametric resampling
      of H1 - per frequency line a complex Gaussian relative error of variance ``(1 - coh) /
      (n_d coh)`` (Bendat & Piersol; ``coh`` the estimated coherence, ``n_d`` the effective
      number of Welch averages, :func:`welch_averages`), correlated across lines as a Hann
      spectrum - refitted ``n_resamples`` times; ``std`` is the resamples' standard deviation,
      the interval ``zeta +/- z std`` (normal quantile ``z``).
    * ``lscf_output`` (output-only): ``std = OUTPUT_ONLY_EFFICIENCY * zeta * au_damping_cov(
      zeta, frequency, duration)`` (Au's law times the estimator's measured efficiency),
      interval ``zeta +/- z std``.

    Parameters
    ----------
    base, tank : array (n,)
        Base and tank accelerations, same unit.
    fs, f1 : float
        Sampling frequency and approximate first-mode frequency, Hz.
    confidence : float
        Two-sided confidence level of the intervals.
    n_resamples : int
        Resamples of H1 (each one LSCF fit, about 9 ms).
    seed : int
        Seed of the resampling.
    accuracy : float, optional
        Wanted relative 1-sigma precision of the damping ratio (e.g. 0.1). If Au's law (times
        the output-only estimator's efficiency) says the record cannot give it, a
        :class:`ShortRecordWarning` names the record length that would.
    rel_band : float
        Fitting band ``f1 (1 -/+ rel_band)``, Hz.
    nperseg : int
        Welch segment length, samples.

    Returns
    -------
    dict
        Every key of ``sloshrom.beam.analysis.mode1_damping_random``, with ``lscf_h1`` and
        ``half_power`` leakage-corrected; ``lscf_h1_uncorrected``, ``half_power_uncorrected``;
        for ``est`` in (``lscf_h1``, ``lscf_output``, ``half_power``): ``{est}_std``,
        ``{est}_low``, ``{est}_high`` (damping ratio, -); ``duration_s`` (s), ``n_cycles``
        (record length in periods of the first mode, -).
    """
    base = np.asarray(base, dtype=float)
    tank = np.asarray(tank, dtype=float)
    if base.ndim != 1 or tank.shape != base.shape:
        raise BeamError("base and tank must be 1-D arrays of the same length")
    if n_resamples < 2:
        raise BeamError("n_resamples must be at least 2")
    z = _z(confidence)
    nan = float("nan")
    band = (f1 * (1 - rel_band), f1 * (1 + rel_band))
    nseg = min(int(nperseg), base.size)
    f, h, coh = frf_h1(base, tank, fs, nseg)
    r_h1 = lscf_cluster_damping(f, h, f1, band)
    r_out = output_only_damping(tank, fs, f1, band)

    def lscf(fr: np.ndarray, hr: np.ndarray) -> float:
        return float(lscf_cluster_damping(fr, hr, f1, band)["zeta"])

    def half_power(fr: np.ndarray, hr: np.ndarray) -> float:
        try:
            return half_power_damping(fr, hr, band)["zeta"]
        except AnalysisError:  # no clear peak in this record: the estimate is missing
            return nan

    hp_raw = half_power(f, h)
    f_mode = r_h1["frequency"] if np.isfinite(r_h1["frequency"]) else f1
    zeta_h1, b_h1 = _corrected(lscf, r_h1["zeta"], f_mode, fs, nseg)
    zeta_hp, b_hp = _corrected(half_power, hp_raw, f_mode, fs, nseg)

    duration = base.size / fs
    out: dict[str, Any] = {
        "lscf_h1": zeta_h1, "lscf_output": r_out["zeta"], "half_power": zeta_hp,
        "frequency_h1": r_h1["frequency"], "frequency_output": r_out["frequency"],
        "lscf_h1_iqr": r_h1["zeta_iqr"], "lscf_output_iqr": r_out["zeta_iqr"],
        "lscf_h1_n": r_h1["n_poles"], "lscf_output_n": r_out["n_poles"],
        "lscf_h1_uncorrected": r_h1["zeta"], "half_power_uncorrected": hp_raw,
    }

    # parametric resampling of H1 (few Welch averages: a segment bootstrap has too few)
    _, n_d = welch_averages(base.size, nseg)
    sel = np.nonzero(f <= band[1] * 1.05)[0]
    std_h1 = std_hp = nan
    if n_d > 1 and (np.isfinite(zeta_h1) or np.isfinite(zeta_hp)):
        c = np.clip(coh[sel], 1e-6, 1.0)
        rel = np.sqrt((1 - c) / (n_d * c))
        eps = _hann_correlated_noise(np.random.default_rng(seed), (n_resamples, sel.size)) * rel
        zs_h1, zs_hp = [], []
        hr = h.copy()
        for k in range(n_resamples):
            hr[sel] = h[sel] * (1 + eps[k])
            if np.isfinite(zeta_h1):
                zs_h1.append(lscf(f, hr))
            if np.isfinite(zeta_hp):
                zs_hp.append(half_power(f, hr))
        std_h1, std_hp = _spread(zs_h1), _spread(zs_hp)
    for est, zeta, std in (("lscf_h1", zeta_h1, std_h1), ("half_power", zeta_hp, std_hp)):
        out.update({f"{est}_std": std, f"{est}_low": zeta - z * std,
                    f"{est}_high": zeta + z * std})

    zo, fo = r_out["zeta"], r_out["frequency"]
    std_out = (OUTPUT_ONLY_EFFICIENCY * zo * au_damping_cov(zo, fo, duration)
               if np.isfinite(zo) and zo > 0 and np.isfinite(fo) else nan)
    out.update(lscf_output_std=std_out, lscf_output_low=zo - z * std_out,
               lscf_output_high=zo + z * std_out, duration_s=duration,
               n_cycles=duration * (fo if np.isfinite(fo) else f_mode))

    if accuracy is not None:
        _warn_short(accuracy, zo if np.isfinite(zo) and zo > 0 else zeta_h1,
                    fo if np.isfinite(fo) else f_mode, duration)
    return out


def _spread(values: list[float]) -> float:
    v = np.asarray(values, dtype=float)
    ok = v[np.isfinite(v)]
    # a resampling that mostly loses the mode has no meaningful spread
    return float(np.std(ok, ddof=1)) if ok.size >= max(2, v.size // 2) else float("nan")


def _warn_short(accuracy: float, zeta: float, frequency: float, duration: float) -> None:
    if not accuracy > 0:
        raise BeamError(f"accuracy must be positive, got {accuracy}")
    if not (np.isfinite(zeta) and zeta > 0 and np.isfinite(frequency)):
        return
    cov = OUTPUT_ONLY_EFFICIENCY * au_damping_cov(zeta, frequency, duration)
    if cov > accuracy:
        need = required_duration(zeta, frequency, accuracy / OUTPUT_ONLY_EFFICIENCY)
        warnings.warn(
            f"a {duration:.0f} s random record of a {100 * zeta:.2g} % mode at "
            f"{frequency:.3g} Hz gives ±{100 * cov:.0f} % (1 sigma) on the damping ratio; "
            f"±{100 * accuracy:.0f} % needs {need:.0f} s", ShortRecordWarning, stacklevel=3)
