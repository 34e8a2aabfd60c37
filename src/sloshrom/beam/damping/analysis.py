"""Damping and spectral analysis of sloshing-beam responses (paper Sect. 4.3-5).

* :func:`modal_filter` - modal accelerations from station accelerations (pseudo-inverse of the
  station mode-shape matrix).
* :func:`instantaneous_damping` - first-mode damping from the Hilbert envelope,
  ``zeta = -(d ln A/dt) / omega`` with a local-regression slope over a few periods.
* :func:`log_decrement` - the same from successive peaks (cross-check).
* :func:`noise_floor` - the band-passed noise amplitude of a decay record (its floor);
  :func:`spectral_noise_floor` - the same from the record's spectrum (a decay that stops above
  its floor);
  :func:`bandpass_noise_gain`, :func:`decay_copy` - for the bootstrap of the band intervals.
* :func:`welch_psd`, :func:`frf_h1` - Welch estimates (Hann window, 50 % overlap, explicit
  ``nperseg``).
* :func:`lscf_poles`, :func:`stable_pole_cluster`, :func:`lscf_cluster_damping` - poles of the
  LSCF estimator of sdypy-EMA (a maintained library) for every model order, and the median
  frequency and damping over the cluster of poles that are stable across orders.
* :func:`correlation`, :func:`half_spectrum`, :func:`output_only_damping` - output-only
  estimate: LSCF on the positive half-spectrum (FFT of the positive-lag correlation with an
  exponential window), the window's damping removed exactly.
* :func:`half_power_damping` - half-power bandwidth; :func:`lscf_damping` - the single-pole LSCF
  pick, kept as a baseline.

The estimators of paper Table 2 built from these functions, behind one protocol, are in
``sloshrom.beam.damping.estimators`` (registered in ``sloshrom.beam.damping.registry``); their
intervals in ``sloshrom.beam.damping.uncertainty``.

Pure numerical functions: arrays in, arrays/dicts out; signal functions take ``fs`` (Hz). A
response that cannot be analysed (too short, no peak in the band, modes that the stations cannot
separate) raises :class:`AnalysisError`, a property of the data; a malformed argument (wrong
dimension, unknown option) raises the room's base :class:`~sloshrom.beam.errors.BeamError`, not
an ``AnalysisError``.
"""

from __future__ import annotations

import contextlib
import functools
import io
import math
import warnings
from typing import Any

import numpy as np
from numpy.typing import ArrayLike
from scipy import linalg, optimize, signal
from scipy.ndimage import minimum_filter1d

from sloshrom.beam.damping.limits import SMOOTH_PERIODS, TRIM_PERIODS
from sloshrom.beam.errors import BeamError


class AnalysisError(BeamError):
    """A response cannot be analysed as asked (too short, no resonance peak in the band, modes
    the stations cannot separate): a property of the data or of the user's modal model."""


def modal_filter(station_acceleration: Any, psi_stations: Any) -> np.ndarray:
    """Modal accelerations ``q'' = pinv(Psi) a`` (least squares over the stations).

    Parameters
    ----------
    station_acceleration : array (..., n, n_stations)
        Accelerations relative to the base (subtract the base acceleration from absolute
        readings), m/s^2.
    psi_stations : array (n_stations, n_modes)
        Mode shapes at the stations; needs n_stations >= n_modes and full column rank.

    Returns
    -------
    ndarray (..., n, n_modes)
    """
    a = np.asarray(station_acceleration, dtype=float)
    psi = np.asarray(psi_stations, dtype=float)
    if psi.ndim != 2 or a.shape[-1] != psi.shape[0]:
        raise BeamError(
            f"psi_stations must be (n_stations, n_modes) with n_stations = {a.shape[-1]}, "
            f"got {psi.shape}"
        )
    if psi.shape[0] < psi.shape[1]:
        raise AnalysisError(
            f"{psi.shape[0]} station(s) for {psi.shape[1]} modes: modal filtering separates "
            "at most as many modes as there are stations (add stations, or keep fewer modes)")
    if np.linalg.matrix_rank(psi) < psi.shape[1]:
        raise AnalysisError(
            "mode shapes at the stations are not independent: cannot separate modes")
    return a @ np.linalg.pinv(psi).T


def _predict(y: np.ndarray, order: int, n: int) -> np.ndarray | None:
    # n samples after y by linear prediction: an AR(order) model of the last 20 periods (order
    # ~ one period); None if the prediction grows beyond the record's scale
    seg = y[-max(20 * order, 4 * order):]
    if seg.size < 2 * order + 2 or not np.any(seg):
        return None
    # Yule-Walker (Levinson recursion): a stable model, and no BLAS call, which a loaded
    # machine made a hundred times slower for this small fit. a[j]: weight of seg[k - 1 - j]
    r = np.array([np.dot(seg[: seg.size - k], seg[k:]) for k in range(order + 1)])
    try:
        a = linalg.solve_toeplitz(r[:-1], r[1:])
    except linalg.LinAlgError:
        return None
    # the prediction as an all-pole filter run on zeros from the record's last samples
    den = np.concatenate([[1.0], -a])
    zi = signal.lfiltic([1.0], den, seg[::-1][:order])
    out, _ = signal.lfilter([1.0], den, np.zeros(n), zi=zi)
    scale = float(np.max(np.abs(seg)))
    return out if np.all(np.isfinite(out)) and np.max(np.abs(out)) <= 10 * scale else None


@functools.lru_cache(maxsize=64)
def _bandpass_sos(fs: float, lo: float, hi: float) -> np.ndarray:
    # cached: butter took longer than the filtering of a decay (callers must not modify it)
    return signal.butter(4, [lo, hi], btype="bandpass", fs=fs, output="sos")


def _bandpass(x: np.ndarray, fs: float, f1: float, rel_band: float) -> np.ndarray:
    lo, hi = f1 * (1 - rel_band), f1 * (1 + rel_band)
    sos = _bandpass_sos(float(fs), float(lo), float(hi))
    # the record continued at both ends by linear prediction: a decay that starts at the
    # record's first sample is no step for the filter, whose ringing after a step biased the
    # first ~12 periods (log decrement -2 % over 3-5 g of a 10 Hz, 1.37 % decay from 8 g)
    order = int(min(64, max(8, round(fs / f1))))
    n = int(round(12 * fs / f1))
    if x.ndim == 1 and x.size > 8 * order:
        pre, post = _predict(x[::-1], order, n), _predict(x, order, n)
        if pre is not None and post is not None:
            xx = np.concatenate([pre[::-1], x, post])
            return signal.sosfiltfilt(sos, xx)[n : n + x.size]
    return signal.sosfiltfilt(sos, x)


def _analytic(x: np.ndarray) -> np.ndarray:
    # zero padding to twice the length: the FFT Hilbert transform must not wrap the large start
    # of a decay onto its small end
    return signal.hilbert(x, N=2 * x.size)[: x.size]


def instantaneous_damping(
    x: Any,
    fs: float,
    f1: float,
    rel_band: float = 0.35,
    smooth_periods: float = float(SMOOTH_PERIODS),
    trim_periods: float = float(TRIM_PERIODS),
    reference: Any = None,
    min_relative_amplitude: float = 1e-2,
) -> dict[str, np.ndarray]:
    """Instantaneous damping ratio of a (mode-1 dominated) decaying response.

    Band-pass around ``f1`` (Butterworth order 4, zero phase; the record continued at both ends
    by 12 periods of linear prediction, so that a decay starting at the first sample is no
    step for the filter), Hilbert envelope A(t) and phase;
    ``zeta(t) = -(d ln A/dt) / omega(t)`` with both derivatives from a local linear regression
    (Savitzky-Golay, order 1) over ``smooth_periods`` periods; ``trim_periods`` periods are cut
    at both ends (filter and Hilbert end effects).

    Parameters
    ----------
    x : array (n,)
        Modal (or tank) acceleration, any unit.
    fs : float
        Hz.
    f1 : float
        Approximate first-mode frequency, Hz.
    reference : array (n,), optional
        Signal whose band-passed envelope is returned as ``amplitude`` (e.g. the tank absolute
        acceleration, to plot damping against tank acceleration amplitude, paper Fig. 21);
        default ``x``.
    min_relative_amplitude : float
        Samples whose envelope is below this fraction of its maximum are dropped (the decay has
        reached the noise / round-off floor there).

    Returns
    -------
    dict
        ``time`` (s), ``zeta`` (-), ``frequency`` (Hz), ``amplitude`` (units of reference).
    """
    x = np.asarray(x, dtype=float)
    if x.ndim != 1:
        raise BeamError("x must be 1-D")
    n_win = int(round(smooth_periods * fs / f1)) | 1
    n_trim = int(round(trim_periods * fs / f1))
    if x.size <= 2 * n_trim + n_win:
        raise AnalysisError("record too short for the smoothing window and end trimming")
    xa = _analytic(_bandpass(x, fs, f1, rel_band))
    ln_a = np.log(np.abs(xa))
    phase = np.unwrap(np.angle(xa))
    dlna = signal.savgol_filter(ln_a, n_win, 1, deriv=1, delta=1 / fs)
    omega = signal.savgol_filter(phase, n_win, 1, deriv=1, delta=1 / fs)
    ref = x if reference is None else np.asarray(reference, dtype=float)
    amp = np.abs(_analytic(_bandpass(ref, fs, f1, rel_band)))
    amp = signal.savgol_filter(amp, n_win, 1)
    env = np.exp(ln_a)
    keep = np.zeros(x.size, bool)
    keep[n_trim : x.size - n_trim] = True
    # drop samples whose smoothing window reaches down to the noise / round-off floor
    floor = min_relative_amplitude * env[keep].max()
    keep &= minimum_filter1d(env, n_win) > floor
    t = np.arange(x.size) / fs
    return {"time": t[keep], "zeta": -dlna[keep] / omega[keep],
            "frequency": omega[keep] / (2 * np.pi), "amplitude": amp[keep]}


#: Frequency lines of a band-pass filter's gain in :func:`bandpass_noise_gain` (not a Welch
#: segment: the integral over the whole band needs only a fine grid).
_GAIN_LINES = 16384


def bandpass_noise_gain(fs: float, f: float, rel_band: float = 0.35) -> float:
    """RMS of white noise of unit standard deviation after the analyses' band-pass around ``f``
    (Butterworth order 4, zero phase: ``|H|^4``), -."""
    w, h = signal.sosfreqz(signal.butter(4, [f * (1 - rel_band), f * (1 + rel_band)],
                                         btype="bandpass", fs=fs, output="sos"),
                             worN=_GAIN_LINES)
    return float(np.sqrt(np.mean(np.abs(h) ** 4)))


def noise_floor(x: ArrayLike, fs: float, f: float, rel_band: float = 0.35,
                window_periods: float = 2.0, tail_fraction: float = 0.05) -> float:
    """Noise amplitude of a free-decay record in the analyses' band around the mode at ``f``.

    The record is band-passed as by :func:`instantaneous_damping` (around ``f``, any mode); its
    mean power over windows of ``window_periods`` periods is fitted, over the tail (the windows
    after the power first falls below ``tail_fraction`` of its largest value, at least 8),
    by ``P(t) = a exp(-b t) + c`` (relative least squares; ``a, c >= 0``): the decay still
    present in the tail and the band-passed noise power ``c``. The result is the RMS envelope of
    that noise, ``sqrt(2 c)``, comparable with a Hilbert amplitude (its mean envelope is
    ``0.89`` times it); the noise's RMS in the band is ``sqrt(c)``.

    Assumes a noise stationary over the record and a decay that is exponential in its tail (a
    linear mode at small amplitude). NaN for a record whose power never falls below
    ``tail_fraction`` of its largest, or whose last window is still more decay than noise (a
    noise-free simulation, a record stopped early): its floor is not measurable.

    Parameters
    ----------
    x : array (n,)
        The decay, any unit.
    fs, f : float
        Sampling frequency and the mode's frequency (the band-pass centre), Hz.
    rel_band : float
        Half-width of the band-pass, relative to ``f``.
    window_periods : float
        Length of the power windows, periods of ``f``.
    tail_fraction : float
        Power, relative to the largest window's, below which the tail starts.

    Returns
    -------
    float
        Noise amplitude (RMS envelope of the band-passed noise), unit of ``x``; NaN if the
        record does not reach it.
    """
    x = np.asarray(x, dtype=float)
    if x.ndim != 1:
        raise BeamError("x must be 1-D")
    nw = max(4, int(round(window_periods * fs / f)))
    edge = int(round(5 * fs / f))  # the zero-phase filter's end effects
    xb = _bandpass(x, fs, f, rel_band)[edge : x.size - edge]
    k = xb.size // nw
    if k < 8:
        raise AnalysisError("record too short for a noise-floor estimate")
    p = np.mean(xb[: k * nw].reshape(k, nw) ** 2, axis=1)
    t = (np.arange(k) + 0.5) * nw / fs
    if not (p < tail_fraction * p.max()).any():
        return float("nan")  # the record never decays towards its floor
    start = min(int(np.argmax(p < tail_fraction * p.max())), k - 8)
    t, p = t[start:] - t[start], np.maximum(p[start:], 1e-300)

    # maximum likelihood for window powers scattered as chi-square about P(t) (a Whittle-type
    # likelihood, sum p / P + ln P, by iteratively reweighted least squares for a and c on a grid
    # of b): plain least squares would be pulled to the powers' frequent small values. The
    # decay must fall by e^3 over the tail at least (or it would stand for the noise), at most
    # at the rate of a damping ratio of 1
    def profile(b: float) -> tuple[float, float, float]:
        u = np.exp(-b * t)
        m = np.maximum(p, p.mean() * 1e-6)
        for _ in range(8):
            coef, _ = optimize.nnls(np.stack([u, np.ones(t.size)], axis=1) / m[:, None], p / m)
            m = np.maximum(coef[0] * u + coef[1], 1e-300)
        return float(np.sum(p / m + np.log(m))), float(coef[1]), float(coef[0] * u[-1])

    _, c, left = min(profile(b) for b in np.geomspace(3 / t[-1], 4 * np.pi * f, 48))
    if not c > 0 or c < left:
        # the decay still dominates the last window: the noise is below what the record shows
        return float("nan")
    return float(math.sqrt(2 * c))


#: The noise floor of a record's spectrum: this percentile of its lines (in dB, or as
#: powers: the same line) over the band searched. A decay's or a response's spectrum is mostly
#: noise, the modes a few narrow peaks; the median rises with every mode's skirt (four modes of
#: a 20 s decay put it up to 4 dB above the floor), a low percentile does not
#: (``sloshrom.beam.damping.peaks`` finds a decay's modes 10 dB above it).
FLOOR_PERCENTILE = 25.0


def spectral_noise_floor(x: ArrayLike, fs: float, f: float, rel_band: float = 0.35) -> float:
    """Noise amplitude of a record in the analyses' band around ``f`` (Hz), from its spectrum:
    the record's white noise PSD is the :data:`FLOOR_PERCENTILE` percentile of its Welch PSD
    (Hann, segments of an eighth of the record) up to 0.9 Nyquist, and its band-passed RMS
    envelope (as :func:`noise_floor` gives it) ``sqrt(2 N fs / 2)`` times the band-pass's noise
    gain (:func:`bandpass_noise_gain`).

    For a decay that stops above its floor (:func:`noise_floor` NaN): its sensor noise still
    shows where no mode is. An upper bound where the record has no line free of response.
    """
    x = np.asarray(x, dtype=float)
    if x.ndim != 1 or x.size < 64:
        raise BeamError("x must be 1-D with at least 64 samples")
    nper = 2 ** int(math.log2(max(x.size // 8, 64)))
    fr, p = welch_psd(x, fs, nper)
    sel = (fr > 0) & (fr <= 0.9 * fs / 2)
    n_psd = float(np.percentile(p[sel], FLOOR_PERCENTILE))
    return math.sqrt(2 * n_psd * fs / 2) * bandpass_noise_gain(fs, f, rel_band)


def _peak_interpolation(xb: np.ndarray, peaks: np.ndarray, fs: float
                        ) -> tuple[np.ndarray, np.ndarray]:
    # the sinusoid through the three samples around each peak (exact for a sinusoid of the
    # peaks' mean frequency): its amplitude and the time of its crest. A sampled peak is up to
    # 1 - cos(pi f / fs) low (8 % at 64 Hz, 500 Hz), a deterministic scatter the log decrement
    # would take for noise
    if peaks.size < 2:
        return peaks / fs, xb[peaks]
    period = float(np.polyfit(np.arange(peaks.size), peaks, 1)[0])  # samples
    theta = 2 * np.pi / period
    x0, xm, xp = xb[peaks], xb[peaks - 1], xb[peaks + 1]
    s = (xp - xm) / (2 * math.sin(theta))  # -A sin(phase) at the sample
    amp = np.hypot(x0, s)
    phase = np.arctan2(-s, x0)
    return (peaks - phase / theta) / fs, amp


def _positive_peaks(xb: np.ndarray, fs: float, f1: float) -> np.ndarray:
    # positive peaks of the band-passed signal, one per period, away from the filter's ends
    peaks, _ = signal.find_peaks(xb, distance=max(1, int(0.6 * fs / f1)))
    peaks = peaks[xb[peaks] > 0]
    edge = int(5 * fs / f1)  # drop peaks spoilt by the zero-phase filter's end effects
    return peaks[(peaks > edge) & (peaks < xb.size - edge)]


def decay_copy(x: np.ndarray, fs: float, f1: float, rel_band: float = 0.35,
               smooth_periods: float = 4.0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The damping analyses of a decay without their selections, for resampled copies: one
    band-pass for both.

    Returns
    -------
    (ndarray, ndarray, ndarray)
        ``zeta(t)`` of :func:`instantaneous_damping` at every sample (-, untrimmed), and the
        ``peak_time`` (s) and ``peak`` (unit of x) of :func:`log_decrement`.
    """
    xb = _bandpass(np.asarray(x, dtype=float), fs, f1, rel_band)
    xa = _analytic(xb)
    n_win = int(round(smooth_periods * fs / f1)) | 1
    dlna = signal.savgol_filter(np.log(np.abs(xa)), n_win, 1, deriv=1, delta=1 / fs)
    omega = signal.savgol_filter(np.unwrap(np.angle(xa)), n_win, 1, deriv=1, delta=1 / fs)
    t_peak, a_peak = _peak_interpolation(xb, _positive_peaks(xb, fs, f1), fs)
    return -dlna / omega, t_peak, a_peak


def log_decrement(
    x: Any, fs: float, f1: float, rel_band: float = 0.35, reference: Any = None
) -> dict[str, np.ndarray]:
    """Damping from successive positive peaks of the band-passed response.

    ``delta = ln(x_i / x_{i+1})``, ``zeta = delta / sqrt(4 pi^2 + delta^2)``; each value is placed
    at the mid time of its pair, with ``amplitude`` the mean peak of ``reference`` (default x).
    Each peak is the crest of the sinusoid through the three samples around the sampled maximum
    (of the peaks' mean period), not the sampled maximum: at a few samples per period the
    latter is low by up to ``1 - cos(pi f1 / fs)``.

    Returns
    -------
    dict
        Per pair of successive peaks: ``time`` (s), ``zeta`` (-), ``amplitude`` (units of
        reference). Per peak (for a regression of ``ln(peak)`` on time, see
        ``sloshrom.beam.damping.uncertainty.band_damping``): ``peak_time`` (s), ``peak`` (the
        band-passed ``x`` at the peak, units of x) and ``peak_amplitude`` (``|reference|``
        band-passed, at the peak).
    """
    x = np.asarray(x, dtype=float)
    xb = _bandpass(x, fs, f1, rel_band)
    ref = xb if reference is None else _bandpass(np.asarray(reference, float), fs, f1, rel_band)
    peaks = _positive_peaks(xb, fs, f1)
    t_peak, a_peak = _peak_interpolation(xb, peaks, fs)
    _, r_peak = _peak_interpolation(ref, peaks, fs)
    per_peak = {"peak_time": t_peak, "peak": a_peak, "peak_amplitude": np.abs(r_peak)}
    if peaks.size < 2:
        return {"time": np.zeros(0), "zeta": np.zeros(0), "amplitude": np.zeros(0), **per_peak}
    delta = np.log(a_peak[:-1] / a_peak[1:])
    zeta = delta / np.sqrt(4 * np.pi**2 + delta**2)
    return {"time": 0.5 * (t_peak[:-1] + t_peak[1:]), "zeta": zeta,
            "amplitude": 0.5 * (np.abs(r_peak[:-1]) + np.abs(r_peak[1:])), **per_peak}


def welch_psd(x: Any, fs: float, nperseg: int = 4096) -> tuple[np.ndarray, np.ndarray]:
    """One-sided Welch PSD: Hann window, ``nperseg`` samples, 50 % overlap, linear detrend off.

    Returns ``(f (Hz), Pxx (units^2/Hz))``; ``x`` shape (..., n).
    """
    x = np.asarray(x, dtype=float)
    nperseg = min(int(nperseg), x.shape[-1])
    return signal.welch(x, fs=fs, window="hann", nperseg=nperseg, noverlap=nperseg // 2,
                        detrend="constant", axis=-1)


def input_psd(base: np.ndarray, fs: float) -> tuple[np.ndarray, np.ndarray]:
    """The input PSD of a record, smooth: Welch over segments of 1/32 of the record (at least
    256 samples; about 60 averages, +/- 13 % per line), for the shape of a coloured input.

    Returns
    -------
    (ndarray, ndarray)
        Frequencies (Hz) and one-sided PSD (the record's unit squared per Hz).
    """
    nps = int(min(base.size, max(256, base.size // 32)))
    return welch_psd(base, fs, nps)


def frf_h1(
    base: Any, response: Any, fs: float, nperseg: int = 4096, *, one_pass: bool = False
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """H1 FRF estimate ``S_xy / S_xx`` (Hann, 50 % overlap, constant detrend) and coherence.

    Two computations of the same estimate, which agree to round-off (not bit for bit):

    * ``one_pass=False`` (default): scipy's ``welch``, ``csd`` and ``coherence``. Every damping
      estimate of a record (Table 2 and the tests that check it) uses this path, so its figures
      stay those already published.
    * ``one_pass=True``: one pass over the segments, one FFT per channel and segment, for a
      stack of records ``(n_records, n)`` at once (scipy's coherence recomputes both
      auto-spectra and the cross-spectrum: five passes instead of two). The bootstrap of
      ``sloshrom.beam.damping.uncertainty`` analyses hundreds of simulated records this way; each
      row of a stack gets exactly (bit for bit) what it gets alone. ``nperseg`` must not exceed the
      record length here.

    Parameters
    ----------
    base, response : array (..., n)
        Input and output records, same unit or not (H1 is in response / base).
    fs : float
        Sampling frequency, Hz.
    nperseg : int
        Welch segment length, samples.
    one_pass : bool
        See above.

    Returns
    -------
    (f (Hz), H (complex, response / base), coherence (-))
    """
    x, y = np.asarray(base, dtype=float), np.asarray(response, dtype=float)
    nperseg = min(int(nperseg), x.shape[-1])
    if one_pass:
        return _frf_h1_one_pass(x, y, fs, nperseg)
    kw = dict(fs=fs, window="hann", nperseg=nperseg, noverlap=nperseg // 2, axis=-1)
    f, sxx = signal.welch(x, **kw)
    _, sxy = signal.csd(x, y, **kw)
    _, coh = signal.coherence(x, y, **kw)
    return f, sxy / sxx, coh


def _frf_h1_one_pass(base: np.ndarray, tank: np.ndarray, fs: float, nperseg: int
                     ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    from scipy import fft

    window = signal.get_window("hann", nperseg)
    step = nperseg // 2
    k = 1 + (base.shape[-1] - nperseg) // step
    idx = np.arange(k)[:, None] * step + np.arange(nperseg)
    # C order, as base[idx] of one record: the means then sum in the same order, and a stack
    # gives each record exactly its own H1
    u, y = np.ascontiguousarray(base[..., idx]), np.ascontiguousarray(tank[..., idx])
    uf = fft.rfft((u - u.mean(axis=-1, keepdims=True)) * window, axis=-1)
    yf = fft.rfft((y - y.mean(axis=-1, keepdims=True)) * window, axis=-1)
    sxx, syy = np.sum(np.abs(uf)**2, -2), np.sum(np.abs(yf)**2, -2)
    sxy = np.sum(np.conj(uf) * yf, -2)
    with np.errstate(invalid="ignore", divide="ignore"):
        return fft.rfftfreq(nperseg, 1 / fs), sxy / sxx, np.abs(sxy)**2 / (sxx * syy)


def band_text(band: tuple[float, float]) -> str:
    """A frequency band as messages print it, ``"143.1-225 Hz"``: four significant digits (a
    band's edges are computed, e.g. geometric means of two modes; their 16 digits say
    nothing)."""
    return f"{float(band[0]):.4g}-{float(band[1]):.4g} Hz"


def _check_band_lines(f: np.ndarray, band: tuple[float, float], need: int) -> None:
    """An :class:`AnalysisError` when the spectrum's lines ``f`` (Hz, evenly spaced) put fewer
    than ``need`` in ``band``: its spacing is the sample rate over the segment length, so a
    wrong ``fs`` (or too short a segment) is the usual cause."""
    n = int(np.count_nonzero((f >= band[0]) & (f <= band[1])))
    if n >= need:
        return
    df = float(f[1] - f[0]) if f.size > 1 else float("nan")
    raise AnalysisError(
        f"too few frequency points in band {band_text(band)}: {n} line(s) "
        f"{df:.3g} Hz apart, the fit needs {need}; the spacing is the sample rate (fs) over "
        "the Welch segment's samples: is the record's fs (its time axis) right?")


def half_power_damping(f: Any, spectrum: Any, band: tuple[float, float]) -> dict[str, float]:
    """Half-power bandwidth damping of the peak of ``|spectrum|`` in ``band`` (Hz).

    For an FRF magnitude the half-power level is ``peak/sqrt(2)``; pass ``|H|`` (or
    ``sqrt(PSD)``). ``zeta = (f_b - f_a) / (2 f_n)`` with linearly interpolated crossings.
    Raises :class:`AnalysisError` when the band has no interior peak or its half-power points
    are not found.
    """
    f = np.asarray(f, dtype=float)
    s = np.abs(np.asarray(spectrum))
    sel = np.nonzero((f >= band[0]) & (f <= band[1]))[0]
    _check_band_lines(f, band, 5)
    ip = sel[np.argmax(s[sel])]
    if not (sel[0] < ip < sel[-1] and s[ip] > 0):
        raise AnalysisError(f"no peak inside band {band_text(band)} (maximum at its edge)")
    # parabolic refinement of the peak on the log magnitude
    y0, y1, y2 = np.log(s[ip - 1 : ip + 2])
    if not y0 - 2 * y1 + y2 < 0:
        raise AnalysisError(f"no peak inside band {band_text(band)} (flat maximum)")
    off = 0.5 * (y0 - y2) / (y0 - 2 * y1 + y2)
    fn = f[ip] + off * (f[1] - f[0])
    peak = math.exp(y1 - 0.25 * (y0 - y2) * off)
    level = peak / math.sqrt(2)
    i = ip
    while i > 0 and s[i] > level:
        i -= 1
    j = ip
    while j < f.size - 1 and s[j] > level:
        j += 1
    if s[i] > level or s[j] > level:
        raise AnalysisError("half-power points not found: widen the band or the record")
    fa = np.interp(level, [s[i], s[i + 1]], [f[i], f[i + 1]])
    fb = np.interp(level, [s[j], s[j - 1]], [f[j], f[j - 1]])
    return {"frequency": float(fn), "zeta": float((fb - fa) / (2 * fn))}


def lscf_poles(
    f: Any,
    spectrum: Any,
    band: tuple[float, float],
    pol_order_high: int = 20,
    solver: str = "qr",
) -> dict[str, np.ndarray]:
    """Poles of the LSCF common-denominator model for every model order.

    The model of sdypy-EMA's LSCF (``get_poles(method="lscf")``): ``H = B(z) / A(z)`` with
    ``z = exp(-i omega dt)``, ``dt = 1 / (2 f_upper)`` (``f_upper`` the last frequency of the
    band), real polynomial coefficients, numerator and denominator of order ``n``, ``a_n = 1``,
    unit weights, fitted by linear least squares to the equation error ``B - H A`` on ``band``;
    ``n = 2, 4, ..., 2 pol_order_high``; poles ``lambda = -ln(z_r) / dt`` from the roots of A.

    ``solver="qr"`` (default) works on the column-scaled equations themselves: one Householder
    QR of the equations of the highest order (every order uses a subset of their columns), then
    a pivoted-QR least-squares solve per order. sdypy forms the normal equations, whose
    condition number is the square: its high-order poles change with the round-off of the data
    (scaling 20 records of 90 s by 3 moved the cluster median by up to 9 % (output-only) and
    2.4 % (H1); with QR by less than 1e-4). ``solver="sdypy"`` calls sdypy-EMA (same model; on
    clean data the poles agree).

    One pole per complex-conjugate pair is kept (``Im > 0``); unstable poles (``Re > 0``) are
    kept too, with a negative damping ratio, for the caller to reject.

    Parameters
    ----------
    f : array (n_f,)
        Equally spaced frequencies, Hz.
    spectrum : array (n_f,)
        An FRF or a half-spectrum (complex); a real PSD is accepted (the old, biased use).
    band : (float, float)
        Fitting band, Hz.
    pol_order_high : int
        Models with 2 to ``2 pol_order_high`` poles.
    solver : {"qr", "sdypy"}

    Returns
    -------
    dict
        Flat arrays, one entry per pole: ``order`` (number of poles of its model, -), ``pole``
        (complex, rad/s), ``frequency`` (undamped natural frequency ``|lambda|/2 pi``, Hz),
        ``zeta`` (``-Re lambda / |lambda|``, -).
    """
    f = np.asarray(f, dtype=float)
    h = np.asarray(spectrum)
    sel = f <= band[1]
    _check_band_lines(f, band, 8)
    if solver == "qr":
        order, pole = _lscf_qr(f, h[None, :], band, int(pol_order_high))[0]
    elif solver == "sdypy":
        from sdypy import EMA

        with warnings.catch_warnings(), contextlib.redirect_stderr(io.StringIO()):
            warnings.simplefilter("ignore", UserWarning)
            model = EMA.Model(
                frf=h[sel][None, :], freq=f[sel], lower=band[0], upper=float(f[sel][-1]),
                pol_order_high=int(pol_order_high),
            )
            model.get_poles(method="lscf", show_progress=False)
        lams = [np.asarray(lam, dtype=complex) for lam in model.all_poles]
        order = np.concatenate([np.full(lam.size, lam.size) for lam in lams])
        pole = np.concatenate(lams)
    else:
        raise BeamError(f"solver must be 'qr' or 'sdypy', got {solver!r}")
    return _pole_table(order, pole)


def lscf_poles_batch(
    f: Any,
    spectra: Any,
    band: tuple[float, float],
    pol_order_high: int = 20,
) -> list[dict[str, np.ndarray]]:
    """:func:`lscf_poles` (``solver="qr"``) of several spectra on one frequency axis.

    Each spectrum gets exactly the poles :func:`lscf_poles` gives it alone (the same arithmetic,
    record by record); the polynomial roots of one model order are found for all spectra in one
    batched eigenvalue call, which is what makes hundreds of fits (a bootstrap) cheap.

    Parameters
    ----------
    f : array (n_f,)
        Equally spaced frequencies, Hz.
    spectra : array (n_spectra, n_f)
        FRFs or half-spectra (complex), one per row.
    band : (float, float)
        Fitting band, Hz.
    pol_order_high : int
        Models with 2 to ``2 pol_order_high`` poles.

    Returns
    -------
    list of dict
        One pole table per row of ``spectra``, as :func:`lscf_poles` returns.
    """
    f = np.asarray(f, dtype=float)
    h = np.asarray(spectra)
    if h.ndim != 2 or h.shape[1] != f.size:
        raise BeamError("spectra must be a 2-D array with one row of f.size values per spectrum")
    _check_band_lines(f, band, 8)
    return [_pole_table(o, p) for o, p in _lscf_qr(f, h, band, int(pol_order_high))]


def _lscf_qr(
    f: np.ndarray, h: np.ndarray, band: tuple[float, float], pol_order_high: int
) -> list[tuple[np.ndarray, np.ndarray]]:
    # h: (n_spectra, n_f); returns (order, pole) per spectrum
    from scipy import linalg

    f_upper = f[f <= band[1]][-1]
    dt = 1.0 / (2.0 * f_upper)
    sel = (f >= band[0]) & (f <= f_upper)
    z = np.exp(-2j * np.pi * f[sel] * dt)
    n_max = 2 * pol_order_high
    v = z[:, None] ** np.arange(n_max + 1)
    k = n_max + 1  # first column of -H z^j
    # every order's equations use columns of M = [z^j, -H z^j], j = 0..n_max (real and imaginary
    # parts stacked): one QR of M, then each order is a small problem in R with the same
    # conditioning (no squaring as in the normal equations, one large factorisation only). R's
    # rows below its 2 k columns are zero: dropped, they only cost time in the solves
    factors = []
    for hr in h:
        hk = hr[sel] / np.sqrt(np.mean(np.abs(hr[sel]) ** 2))
        m = np.hstack([v, -hk[:, None] * v])
        m = np.vstack([m.real, m.imag])
        scale = np.linalg.norm(m, axis=0)
        scale[scale == 0] = 1.0
        r = linalg.qr(m / scale, mode="r", check_finite=False)[0][: 2 * k]
        factors.append((r, scale))
    order: list[list[np.ndarray]] = [[] for _ in factors]
    pole: list[list[np.ndarray]] = [[] for _ in factors]
    for n in range(2, n_max + 1, 2):
        cols = np.r_[0 : n + 1, k : k + n]  # b_0..b_n, a_0..a_{n-1}; a_n = 1
        a = np.empty((len(factors), n + 1))
        for i, (r, scale) in enumerate(factors):
            x = linalg.lstsq(r[:, cols], -r[:, k + n], lapack_driver="gelsy",
                             check_finite=False)[0] / scale[cols]
            a[i] = np.append(x[n + 1 :], 1.0 / scale[k + n])
        roots = _roots(a[:, ::-1])
        with np.errstate(divide="ignore", invalid="ignore"):
            lam = -np.log(roots) / dt
        for i in range(len(factors)):
            order[i].append(np.full(lam.shape[1], n))
            pole[i].append(lam[i])
    return [(np.concatenate(o), np.concatenate(p)) for o, p in zip(order, pole, strict=True)]


def _roots(p: np.ndarray) -> np.ndarray:
    # np.roots of every row of p (n_rows, N), highest power first: the same companion matrices
    # and eigenvalue routine, in one batched call; rows np.roots would trim (a zero first or
    # last coefficient) or reject (not finite) go through np.roots itself
    n_rows, n = p.shape
    plain = np.all(np.isfinite(p), axis=1) & (p[:, 0] != 0) & (p[:, -1] != 0)
    if n < 2 or not plain.all():
        rows = [np.roots(row).astype(complex) for row in p]
        if len({r.size for r in rows}) == 1:
            return np.array(rows).reshape(n_rows, -1)
        width = max(r.size for r in rows)  # trimmed rows: padded with NaN (dropped later)
        return np.array([np.pad(r, (0, width - r.size), constant_values=np.nan) for r in rows])
    a = np.zeros((n_rows, n - 1, n - 1))
    i = np.arange(n - 2)
    a[:, i + 1, i] = 1.0
    a[:, 0, :] = -p[:, 1:] / p[:, :1]
    return np.linalg.eigvals(a).astype(complex)


def _pole_table(order: np.ndarray, pole: np.ndarray) -> dict[str, np.ndarray]:
    # the denominators have real coefficients: complex poles come in conjugate pairs, keep the
    # member with Im > 0 (real poles are no modes)
    keep = np.isfinite(pole) & (pole.imag > 0)
    order, pole = order[keep], pole[keep]
    w = np.abs(pole)
    return {"order": order, "pole": pole, "frequency": w / (2 * np.pi), "zeta": -pole.real / w}


def stable_pole_cluster(
    poles: dict[str, np.ndarray],
    f_target: float,
    f_window: float = 0.1,
    tol_frequency: float = 0.01,
    tol_zeta: float = 0.05,
    zeta_max: float = 0.5,
    min_poles: int = 10,
    decay_correction: float = 0.0,
) -> dict[str, Any]:
    """Median frequency and damping over the cluster of stable poles near ``f_target``.

    A pole of the model with ``n`` poles is *stable* if the model with the next lower order has a
    pole within ``tol_frequency`` (relative) in frequency and ``tol_zeta`` (relative) in damping.
    Only physically damped poles (``0 < zeta < zeta_max``) within ``f_window`` (relative) of
    ``f_target`` count. The stable poles are grouped by frequency (a relative gap larger than
    ``tol_frequency`` starts a new group); the group spanning the most model orders (then the one
    nearest ``f_target``) is the mode. The median over the group is robust to the one-order jumps
    of a single selected pole.

    With ``decay_correction = beta`` (an exponential lag window ``exp(-beta tau)``, see
    :func:`half_spectrum`) the stability test is made on the poles as fitted (it is a property
    of the fit), and every pole is moved back by ``lambda = lambda_w + beta`` before the physical
    test, the grouping and the medians.

    Parameters
    ----------
    poles : dict
        As returned by :func:`lscf_poles`.
    f_target : float
        Expected natural frequency, Hz.
    f_window, tol_frequency, tol_zeta : float
        Relative tolerances (-).
    zeta_max : float
        Upper bound of a physical damping ratio (-).
    min_poles : int
        Fewest stable poles that make a cluster. The default 10 is about half the 19 order pairs
        of :func:`lscf_poles`' default: on 90 s of a 1 % mode every record gave >= 14, on 200
        records of pure white noise the output-only fit gave at most 11 (>= 8 in 2 %).
    decay_correction : float
        Real part added to every pole before it is reported, 1/s (0: none).

    Returns
    -------
    dict
        ``frequency`` (Hz) and ``zeta`` (-): medians over the cluster (NaN if there is none);
        ``frequency_iqr`` (Hz) and ``zeta_iqr`` (-): interquartile ranges over the cluster (the
        spread across model orders, not the statistical error of the record); ``n_poles``;
        ``orders`` (array: model orders in the cluster); ``reason`` ("" or why NaN).
    """
    order, fw, zw = poles["order"], poles["frequency"], poles["zeta"]
    lam = poles["pole"] + decay_correction
    fr, z = np.abs(lam) / (2 * np.pi), -lam.real / np.abs(lam)
    cand = (np.abs(fr - f_target) <= f_window * f_target) & (z > 0) & (z < zeta_max)
    levels = np.unique(order)
    stable = np.zeros(order.size, bool)
    for lo, hi in zip(levels[:-1], levels[1:], strict=True):
        prev = np.nonzero(cand & (order == lo))[0]
        for i in np.nonzero(cand & (order == hi))[0]:
            stable[i] = np.any((np.abs(fw[i] - fw[prev]) <= tol_frequency * fw[prev])
                               & (np.abs(zw[i] - zw[prev]) <= tol_zeta * zw[prev]))
    nan = float("nan")
    out: dict[str, Any] = {"frequency": nan, "zeta": nan, "frequency_iqr": nan, "zeta_iqr": nan,
                           "n_poles": 0, "orders": np.zeros(0, int), "reason": ""}
    idx = np.nonzero(stable)[0]
    if idx.size == 0:
        out["reason"] = (f"no stable physical pole within {100 * f_window:.0f} % of "
                         f"{f_target:.4g} Hz")
        return out
    idx = idx[np.argsort(fr[idx])]
    breaks = np.nonzero(np.diff(fr[idx]) > tol_frequency * fr[idx][:-1])[0] + 1
    groups = np.split(idx, breaks)
    best = max(groups, key=lambda g: (np.unique(order[g]).size,
                                      -abs(np.median(fr[g]) - f_target)))
    if best.size < min_poles:
        out["reason"] = (f"largest stable cluster near {f_target:.4g} Hz has {best.size} "
                         f"pole(s), fewer than {min_poles}")
        return out
    q = np.percentile
    out.update(frequency=float(np.median(fr[best])), zeta=float(np.median(z[best])),
               frequency_iqr=float(np.subtract(*q(fr[best], [75, 25]))),
               zeta_iqr=float(np.subtract(*q(z[best], [75, 25]))), n_poles=int(best.size),
               orders=np.sort(order[best]))
    return out


def lscf_cluster_damping(
    f: Any,
    spectrum: Any,
    f_approx: float,
    band: tuple[float, float],
    pol_order_high: int = 20,
    **cluster: Any,
) -> dict[str, Any]:
    """Modal frequency and damping near ``f_approx``: LSCF poles over model orders, then the
    median of the stable-pole cluster (:func:`lscf_poles`, :func:`stable_pole_cluster`).

    Parameters
    ----------
    f, spectrum : array (n_f,)
        Frequencies (Hz) and an FRF (e.g. H1) or a half-spectrum, complex.
    f_approx : float
        Expected natural frequency, Hz.
    band : (float, float)
        Fitting band, Hz.
    pol_order_high : int
        Models with 2 to ``2 pol_order_high`` poles.
    **cluster
        Tolerances passed to :func:`stable_pole_cluster`.

    Returns
    -------
    dict
        As :func:`stable_pole_cluster`.
    """
    return stable_pole_cluster(lscf_poles(f, spectrum, band, pol_order_high), f_approx,
                               **cluster)


def correlation(x: Any, fs: float, max_lag: float,
                divide: tuple[np.ndarray, np.ndarray] | None = None
                ) -> tuple[np.ndarray, np.ndarray]:
    """Unbiased auto-correlation ``R(k) = sum_n x_n x_{n+k} / (N - k)``, ``0 <= k dt <= max_lag``.

    The mean is removed first; the sum is one zero-padded FFT of the whole record (no segment
    window, hence no window-shaped bias on ``R``). With ``divide = (f (Hz), S)``, a smooth
    positive spectrum, the record's spectrum is divided by ``S`` (interpolated) line by line
    first: the correlation of the record as if filtered by ``1 / sqrt(S)`` (an
    auto-correlation depends on the spectrum's magnitude alone, so no phase is needed).
    Returns ``(lag (s), R (units^2, over S's unit with divide))``.
    """
    from scipy import fft

    x = np.asarray(x, dtype=float)
    if x.ndim != 1:
        raise BeamError("x must be 1-D")
    n_lag = int(round(max_lag * fs)) + 1
    if not 2 <= n_lag <= x.size // 2:
        raise AnalysisError(
            f"max_lag = {max_lag} s must be between one sample and half the record")
    x = x - x.mean()
    m = fft.next_fast_len(2 * x.size, real=True)
    xf = fft.rfft(x, m)
    p = xf.real**2 + xf.imag**2
    if divide is not None:
        p = p / np.interp(fft.rfftfreq(m, 1 / fs), *divide)
    r = fft.irfft(p, m)[:n_lag] / (x.size - np.arange(n_lag))
    return np.arange(n_lag) / fs, r


def half_spectrum(
    r: Any, fs: float, window_end: float = 0.01, nfft: int | None = None
) -> dict[str, Any]:
    """Positive half-spectrum of a correlation function, with an exponential lag window.

    ``S+(f) = dt sum_k w_k R(k) exp(-2 pi i f k dt)`` over the lags ``k >= 0`` given, with
    ``w(tau) = exp(-beta tau)``, ``beta = -ln(window_end) / tau_max`` and ``R(0)`` halved (so that
    ``2 Re S+`` is the two-sided PSD smoothed by the window, and ``4 Re S+`` the one-sided one).

    For a linear system driven by white noise, ``R(tau >= 0) = sum_r A_r exp(lambda_r tau) +
    c.c.``, so ``S+`` is a sum of ``A_r / (2 pi i f - lambda_r)`` terms: an FRF-like rational
    function with the system's poles, causal and complex, which a common-denominator model fits
    (unlike ``|H|^2 S``, a real function with the mirrored poles ``-conj(lambda_r)`` as well).
    The window turns every ``exp(lambda tau)`` into ``exp((lambda - beta) tau)``: it moves each
    pole left by ``beta`` and leaves the damped frequency unchanged. The exact correction is
    ``lambda = lambda_w + beta``, i.e. with ``lambda = -zeta omega_n + i omega_d``::

        zeta omega_n = zeta_w omega_nw - beta,   omega_d unchanged,
        zeta ~= zeta_w - beta / omega_n          (first order in beta / omega_n).

    Parameters
    ----------
    r : array (n_lag,)
        Correlation at lags ``0, dt, ..., tau_max`` (e.g. from :func:`correlation`), units^2.
    fs : float
        Sampling frequency, Hz.
    window_end : float
        Window value at the largest lag, in (0, 1): small enough that the truncation of the
        correlation adds no leakage.
    nfft : int, optional
        FFT length (zero padding); default the next fast length >= 8 n_lag.

    Returns
    -------
    dict
        ``f`` (Hz), ``spectrum`` (complex, units^2/Hz), ``beta`` (window decay, 1/s).
    """
    from scipy import fft

    r = np.asarray(r, dtype=float)
    if r.ndim != 1 or r.size < 2:
        raise BeamError("r must be 1-D with at least two lags")
    if not 0 < window_end < 1:
        raise BeamError("window_end must be in (0, 1)")
    lag = np.arange(r.size) / fs
    beta = -math.log(window_end) / lag[-1]
    rw = r * np.exp(-beta * lag)
    rw[0] *= 0.5
    nfft = fft.next_fast_len(8 * r.size, real=True) if nfft is None else int(nfft)
    return {"f": fft.rfftfreq(nfft, 1 / fs), "spectrum": fft.rfft(rw, nfft) / fs, "beta": beta}


#: How far (dB below its value at the mode) the input spectrum divides the output's
#: (:func:`input_shape`): beyond a shaker's band (24 dB/octave roll-off) the input is its
#: noise, and dividing by it there would raise the output's noise into the correlation. The
#: whole spectrum is divided, not only the fitting band: the lag window spreads every line
#: over its neighbours, and the other modes' lines, left coloured, biased mode 3 of a
#: four-mode beam under a -6 dB/octave input by -15 % (divided over the band alone), +2 %
#: divided everywhere (6 records of 120 s; 40 and 60 dB gave the same).
INPUT_SHAPE_RANGE_DB = 20.0


def input_shape(base: ArrayLike, fs: float, f_mode: float) -> tuple[np.ndarray, np.ndarray] | None:
    """The measured input's spectral shape, to divide an output spectrum by: the smooth input
    PSD (:func:`input_psd`) over its value at the mode ``f_mode`` (Hz), at least
    :data:`INPUT_SHAPE_RANGE_DB` below it (1 at the mode). ``None`` where the base holds no
    power (not measured).
    """
    b = np.asarray(base, dtype=float)
    if b.ndim != 1 or not np.all(np.isfinite(b)) or not np.std(b) > 0:
        return None
    f, s = input_psd(b, fs)
    at = float(np.interp(f_mode, f, s))
    if not at > 0:
        return None
    return f, np.maximum(s / at, 10 ** (-INPUT_SHAPE_RANGE_DB / 10))


def output_only_damping(
    x: Any,
    fs: float,
    f_approx: float,
    band: tuple[float, float],
    max_lag_periods: float = 30.0,
    window_end: float = 0.01,
    pol_order_high: int = 20,
    base: ArrayLike | None = None,
    **cluster: Any,
) -> dict[str, Any]:
    """Output-only modal frequency and damping: LSCF on the half-spectrum, window corrected.

    :func:`correlation` up to ``max_lag = max_lag_periods / f_approx``, :func:`half_spectrum`
    (exponential window), LSCF poles of every order on ``band`` (:func:`lscf_poles`), then the
    stable-pole cluster (:func:`stable_pole_cluster`), whose poles are moved back by the window's
    decay (``lambda = lambda_w + beta``, exact) before the median. Assumes a broadband (white
    over the mode's bandwidth) excitation, the usual operational-modal-analysis hypothesis;
    with a measured ``base`` (its input), the output spectrum is first divided by the input's
    shape (:func:`input_shape`), so that a coloured input (a shaker's tilt and roll-off) is
    the white one the fit assumes. Only the base's power spectrum is used, not its phase: the
    estimate stays output-only in its fit.

    The defaults (30 periods, window 1 % at the end: ``beta / omega_n = ln(100) / (2 pi 30) =
    0.024``) balance two biases measured on a 1 %, 10 Hz mode: shorter lags need a stronger
    window, whose broad peak LSCF fits less well (on the exact correlation -0.2 % at 30
    periods, -1.7 % at 20, -4.7 % at 15), while longer lags add the noisy tail of the estimated
    correlation, which looks like a persisting oscillation (mean over 90 s records of
    white-noise response: -6 % at 30 periods, -10 % at 50). The random error cannot be much
    smaller than the output-only bound
    ``std(zeta) / zeta ~ 1 / sqrt(zeta omega_n T)`` for a record of T seconds (13 % at 90 s,
    5 % at 600 s for 1 % at 10 Hz; see ``benchmarks/damping_estimators.py``).

    Parameters
    ----------
    x : array (n,)
        Response (any unit).
    fs, f_approx : float
        Sampling frequency and expected natural frequency, Hz.
    band : (float, float)
        Fitting band, Hz.
    max_lag_periods : float
        Correlation lags kept, in periods of ``f_approx``.
    window_end : float
        Exponential window value at the largest lag (-).
    pol_order_high : int
        Models with 2 to ``2 pol_order_high`` poles.
    base : array (n,), optional
        The measured input (base acceleration) of the record; ``None``: the input is taken
        as white.
    **cluster
        Tolerances passed to :func:`stable_pole_cluster`.

    Returns
    -------
    dict
        As :func:`stable_pole_cluster`, plus ``beta`` (1/s, window decay), ``zeta_window``
        (-, the first-order correction ``beta / (2 pi frequency)`` that was removed) and
        ``input_divided`` (bool: the output was divided by the measured input's shape).
    """
    shape = input_shape(base, fs, f_approx) if base is not None else None
    _, r = correlation(x, fs, max_lag_periods / f_approx, divide=shape)
    hs = half_spectrum(r, fs, window_end)
    p = lscf_poles(hs["f"], hs["spectrum"], band, pol_order_high)
    out = stable_pole_cluster(p, f_approx, decay_correction=hs["beta"], **cluster)
    out["beta"] = hs["beta"]
    out["zeta_window"] = hs["beta"] / (2 * np.pi * out["frequency"])
    out["input_divided"] = shape is not None
    return out


def lscf_damping(
    f: Any,
    spectrum: Any,
    f_approx: float,
    band: tuple[float, float],
    pol_order_high: int = 20,
    frf_form: str = "accelerance",
) -> dict[str, float]:
    """Single-pole LSCF estimate (sdypy-EMA ``select_closest_poles``), kept as a baseline.

    sdypy's stabilisation picks one stable pole, of one model order, closest to ``f_approx``:
    its damping jumps with small changes of the data or of the numerics. Use
    :func:`lscf_cluster_damping` (median over the stable-pole cluster) for estimates. On a real
    PSD the fit is only approximate (``|H|^2 S`` has the mirrored poles and no phase).

    Returns ``{"frequency": Hz, "zeta": -}``.
    """
    from sdypy import EMA

    f = np.asarray(f, dtype=float)
    h = np.asarray(spectrum)
    sel = f <= band[1]
    _check_band_lines(f, band, 8)
    fw = max(1, int(round(band[1] - band[0])))
    with warnings.catch_warnings(), contextlib.redirect_stderr(io.StringIO()):
        warnings.simplefilter("ignore", UserWarning)
        model = EMA.Model(
            frf=h[sel][None, :], freq=f[sel], lower=band[0], upper=float(f[sel][-1]),
            pol_order_high=int(pol_order_high), frf_form=frf_form,
        )
        model.get_poles(method="lscf", show_progress=False)
        model.select_closest_poles([f_approx], f_window=fw)
    return {"frequency": float(model.nat_freq[0]), "zeta": float(model.nat_xi[0])}

