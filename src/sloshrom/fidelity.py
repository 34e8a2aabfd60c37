"""Waveform fidelity: a sloshing force judged as a physicist would, not point by point.

The virtual rig is deterministic but chaotic: the same test with the input's gain changed by
0.1 % gives a force that differs from the nominal one by an NRMSE of about 0.3 on the validation
record (the rig's *twin run*, docs/rom.md, "Waveform fidelity"). A point-wise fit far above what
a twin run reaches is beyond what a laboratory could confirm; what it can confirm are the
statistics of the force: how strong it is (RMS), how much of its power lies in the impacts'
high frequencies, how often the liquid impacts the tank and how hard.

Functions take plain arrays of one force signal (N, time on the last axis) and the sample rate
``fs`` (Hz), in the style of ``scipy.signal``. Forces follow the package's convention: the
dynamic force ``dF`` is part of the force the liquid exerts on the tank, positive up, so the
column's impact on the tank floor is a *downward* spike (``polarity = -1``).
:func:`waveform_fidelity` gathers every figure for a (reference, model) pair.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy import signal as sps

from sloshrom.errors import SloshromError

__all__ = [
    "HIGH_BAND",
    "IMPACT_THRESHOLD",
    "LOW_BAND",
    "MIN_SEPARATION",
    "POLARITY",
    "QUANTILES",
    "FidelityError",
    "Figures",
    "band_power",
    "band_power_ratio",
    "dynamic_rms",
    "force_peaks",
    "impact_peaks",
    "impact_rate",
    "impact_threshold",
    "peak_quantiles",
    "point_errors",
    "rms_ratio",
    "waveform_fidelity",
]

#: Band of the impacts, Hz (upper edge ``None`` = the Nyquist frequency): above the first
#: harmonics of the sloshing driven at 5-25 Hz, where the rig's force has 4-6 times the power of
#: its 5-20 Hz band and a smooth model almost none.
HIGH_BAND: tuple[float, float | None] = (60.0, None)
#: Band of the driven sloshing, Hz: the beam's first mode (about 10 Hz) and the VFA's 5-25 Hz.
LOW_BAND: tuple[float, float | None] = (5.0, 20.0)
#: Impact threshold in units of the reference's dynamic-force RMS. A Gaussian force crosses
#: 3 sigma upward at exp(-9/2) = 1.1 % of its zero-crossing rate (Rice), about 0.2 /s for
#: 10 Hz sloshing, while the rig's impacts exceed it 5-8 times a second.
IMPACT_THRESHOLD = 3.0
#: Shortest time between two impacts, s. The rig's spikes above the threshold come either
#: within 15 ms of each other (rebounds and ringing of one impact, 2-8 ms wide) or more than
#: 30 ms apart (one per sloshing cycle, at most 25 Hz: 40 ms); none lie in between, so 20 ms
#: groups one impact's sub-spikes and separates the cycles.
MIN_SEPARATION = 0.02
#: Direction of an impact: -1 = downward (the column falls on the tank floor).
POLARITY = -1
#: Quantiles of the force peaks' amplitudes reported, as fractions.
QUANTILES = (0.01, 0.5, 0.99)

#: The figures of :func:`waveform_fidelity` by name (JSON-able): numbers, and lists of them.
Figures = dict[str, float | list[float]]


class FidelityError(SloshromError):
    """A fidelity figure cannot be computed as asked: signals of different lengths, a rate,
    band or threshold out of range (the message names the argument and its value)."""


def _signal(x: ArrayLike, what: str = "x") -> NDArray[np.float64]:
    a = np.asarray(x, dtype=np.float64)
    if a.ndim != 1 or a.size < 2:
        raise FidelityError(f"{what} must be a 1-D signal of at least 2 samples, got shape "
                            f"{a.shape}")
    if not np.all(np.isfinite(a)):
        raise FidelityError(f"{what} must be finite")
    return a


def _pair(reference: ArrayLike, model: ArrayLike
          ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    r, m = _signal(reference, "reference"), _signal(model, "model")
    if r.shape != m.shape:
        raise FidelityError(f"reference and model must have the same length, got {r.size} and "
                            f"{m.size} samples")
    return r, m


def _rate(fs: float) -> float:
    if not (np.isfinite(fs) and fs > 0):
        raise FidelityError(f"fs must be a positive rate in Hz, got {fs!r}")
    return float(fs)


def dynamic_rms(x: ArrayLike) -> float:
    """RMS of a force about its mean, N.

    Parameters
    ----------
    x : array_like, shape (n,)
        Force, N.

    Returns
    -------
    float
        ``sqrt(mean((x - mean(x))^2))``, N.
    """
    a = _signal(x)
    return float(np.sqrt(np.mean((a - a.mean()) ** 2)))


def rms_ratio(reference: ArrayLike, model: ArrayLike) -> float:
    """RMS of the model's dynamic force over the reference's, both about their means, -.

    The mean is removed because a constant offset (the static weight's share, a drift of the
    load cells) carries no sloshing and is not what the liquid exchanges with the structure.

    Parameters
    ----------
    reference, model : array_like, shape (n,)
        Forces, N.

    Returns
    -------
    float
        ``dynamic_rms(model) / dynamic_rms(reference)`` (1 = as strong as the reference); inf
        for a constant reference.
    """
    r, m = _signal(reference, "reference"), _signal(model, "model")
    den = dynamic_rms(r)
    return float(dynamic_rms(m) / den) if den > 0 else math.inf


def band_power(x: ArrayLike, fs: float, band: tuple[float, float | None],
               nperseg: int | None = None) -> float:
    """Power of a signal in a frequency band, from its Welch PSD, in the signal's unit squared.

    Parameters
    ----------
    x : array_like, shape (n,)
        Signal (e.g. force, N); its mean is removed (Welch's constant detrend per segment).
    fs : float
        Sample rate, Hz.
    band : (float, float or None)
        ``(f_low, f_high)``, Hz: the bins with ``f_low <= f < f_high`` count; ``f_high`` None =
        up to and including the Nyquist frequency.
    nperseg : int, optional
        Welch segment, samples (Hann window, half overlap); default 2 s of signal (0.5 Hz
        resolution, fine enough for the 5-20 Hz band), at most the signal's length.

    Returns
    -------
    float
        ``sum(PSD) df`` over the band (e.g. N^2): the band's share of the mean square.
    """
    a = _signal(x)
    fs = _rate(fs)
    lo, hi = band
    if not (lo >= 0 and (hi is None or hi > lo)):
        raise FidelityError(f"band must be (f_low >= 0, f_high > f_low or None), got {band!r}")
    n = min(a.size, int(round(2.0 * fs)) if nperseg is None else int(nperseg))
    f, p = sps.welch(a, fs=fs, nperseg=n)
    sel = (f >= lo) & (f < hi) if hi is not None else f >= lo
    return float(np.sum(p[sel]) * (f[1] - f[0]))


def band_power_ratio(x: ArrayLike, fs: float,
                     high: tuple[float, float | None] = HIGH_BAND,
                     low: tuple[float, float | None] = LOW_BAND,
                     nperseg: int | None = None) -> float:
    """Power in the ``high`` band over the power in the ``low`` band, -.

    With the defaults, the power above 60 Hz relative to 5-20 Hz: the share of the impacts'
    sharp spikes against the driven sloshing (the rig: about 4-6; a smooth model: below 0.5).

    Parameters
    ----------
    x : array_like, shape (n,)
        Force, N.
    fs : float
        Sample rate, Hz.
    high, low : (float, float or None)
        Bands, Hz (:func:`band_power`).
    nperseg : int, optional
        Welch segment, samples (:func:`band_power`).

    Returns
    -------
    float
        ``band_power(x, high) / band_power(x, low)``; inf when the low band holds no power.
    """
    den = band_power(x, fs, low, nperseg)
    num = band_power(x, fs, high, nperseg)
    return float(num / den) if den > 0 else math.inf


def impact_threshold(reference: ArrayLike, k: float = IMPACT_THRESHOLD) -> float:
    """The force an impact must exceed, N: ``k`` times the reference's dynamic-force RMS.

    Tied to the reference's scale, and used for the model too (:func:`waveform_fidelity`): an
    impact is a force, and a model whose force is weaker must not count its smaller bumps as
    impacts against a threshold of its own.

    Parameters
    ----------
    reference : array_like, shape (n,)
        Force, N.
    k : float
        Threshold in RMS (:data:`IMPACT_THRESHOLD`).

    Returns
    -------
    float
        N.
    """
    if not (np.isfinite(k) and k > 0):
        raise FidelityError(f"k must be a positive number of RMS, got {k!r}")
    return float(k * dynamic_rms(reference))


def force_peaks(x: ArrayLike, fs: float, height: float | None = None,
                min_separation: float = MIN_SEPARATION, polarity: int = POLARITY
                ) -> tuple[NDArray[np.intp], NDArray[np.float64]]:
    """Local maxima of the force in the direction ``polarity``, at least ``min_separation``
    apart, and their amplitudes.

    Parameters
    ----------
    x : array_like, shape (n,)
        Force, N.
    fs : float
        Sample rate, Hz.
    height : float, optional
        Keep only the peaks whose amplitude exceeds it, N (None: every peak).
    min_separation : float
        s; of two peaks closer than this only the larger is kept (``scipy.signal.find_peaks``'s
        ``distance``).
    polarity : {-1, 1}
        -1 = downward peaks (local minima of ``x``), 1 = upward.

    Returns
    -------
    index : ndarray of int
        Sample of each peak.
    amplitude : ndarray
        Its amplitude from the signal's mean, in the direction ``polarity``, N (positive for a
        peak beyond the mean).
    """
    a = _signal(x)
    fs = _rate(fs)
    if polarity not in (-1, 1):
        raise FidelityError(f"polarity must be -1 (downward) or 1 (upward), got {polarity!r}")
    if not (np.isfinite(min_separation) and min_separation >= 0):
        raise FidelityError(f"min_separation must be a non-negative time in s, got "
                            f"{min_separation!r}")
    y = polarity * (a - a.mean())
    distance = max(1, int(round(min_separation * fs)))
    idx, _ = sps.find_peaks(y, height=height, distance=distance)
    return idx.astype(np.intp), y[idx]


def impact_peaks(x: ArrayLike, fs: float, threshold: float,
                 min_separation: float = MIN_SEPARATION, polarity: int = POLARITY
                 ) -> tuple[NDArray[np.intp], NDArray[np.float64]]:
    """The impacts of a force: its peaks (:func:`force_peaks`) beyond ``threshold``.

    An impact is a peak of the dynamic force (mean removed) in the direction ``polarity`` whose
    amplitude exceeds ``threshold`` (:func:`impact_threshold`), at least ``min_separation``
    after the previous one; of the sub-spikes of one impact (rebounds, ringing) the largest
    counts.

    Parameters
    ----------
    x : array_like, shape (n,)
        Force, N.
    fs : float
        Sample rate, Hz.
    threshold : float
        N, > 0.
    min_separation : float
        s (:data:`MIN_SEPARATION`).
    polarity : {-1, 1}
        :data:`POLARITY`.

    Returns
    -------
    index : ndarray of int
        Sample of each impact's peak.
    amplitude : ndarray
        Its amplitude from the mean, N.
    """
    if not (np.isfinite(threshold) and threshold > 0):
        raise FidelityError(f"threshold must be a positive force in N, got {threshold!r}")
    # peaks are separated among those above the threshold only: the sub-threshold wiggles
    # around an impact must not hide it
    return force_peaks(x, fs, height=threshold, min_separation=min_separation,
                       polarity=polarity)


def impact_rate(x: ArrayLike, fs: float, threshold: float | None = None,
                min_separation: float = MIN_SEPARATION, polarity: int = POLARITY) -> float:
    """Impacts per second (:func:`impact_peaks`), 1/s.

    Parameters
    ----------
    x : array_like, shape (n,)
        Force, N.
    fs : float
        Sample rate, Hz.
    threshold : float, optional
        N; default :func:`impact_threshold` of ``x`` itself (pass the reference's to compare a
        model with it).
    min_separation : float
        s.
    polarity : {-1, 1}
        Direction of an impact.

    Returns
    -------
    float
        Number of impacts over the signal's duration ``n / fs``, 1/s.
    """
    a = _signal(x)
    th = impact_threshold(a) if threshold is None else threshold
    if not th > 0:  # a constant signal: no scale, no impact
        return 0.0
    idx, _ = impact_peaks(a, fs, th, min_separation, polarity)
    return float(idx.size * _rate(fs) / a.size)


def peak_quantiles(x: ArrayLike, fs: float, quantiles: Sequence[float] = QUANTILES,
                   min_separation: float = MIN_SEPARATION, polarity: int = POLARITY
                   ) -> NDArray[np.float64]:
    """Quantiles of the amplitudes of the force's peaks (all of them, no threshold), N.

    Of every local maximum in the direction ``polarity`` (:func:`force_peaks`), not of the
    impacts alone: the impacts' lowest quantile would be the threshold by construction, and a
    model without impacts would have none; the peaks exist for every signal, and their
    distribution reads as the physicist's picture: the 50 % quantile is the typical
    per-cycle peak of the sloshing, the 99 % one the hardest impacts, the 1 % one the quiet
    stretches.

    Parameters
    ----------
    x : array_like, shape (n,)
        Force, N.
    fs : float
        Sample rate, Hz.
    quantiles : sequence of float
        In [0, 1] (:data:`QUANTILES`).
    min_separation : float
        s.
    polarity : {-1, 1}
        Direction of the peaks.

    Returns
    -------
    ndarray, shape (len(quantiles),)
        N (NaN when the signal has no peak).
    """
    q = np.asarray(quantiles, dtype=np.float64)
    if q.ndim != 1 or not np.all((q >= 0) & (q <= 1)):
        raise FidelityError(f"quantiles must be fractions in [0, 1], got {quantiles!r}")
    _, amp = force_peaks(x, fs, None, min_separation, polarity)
    if amp.size == 0:
        return np.full(q.shape, np.nan)
    return np.asarray(np.quantile(amp, q), dtype=np.float64)


def point_errors(reference: ArrayLike, model: ArrayLike) -> dict[str, float]:
    """Point-wise errors of a model's force against the reference's.

    Parameters
    ----------
    reference, model : array_like
        Forces of the same shape, N. A model's force that is not finite (a diverged free run)
        gives NaN figures, not an error: the caller says what it makes of it.

    Returns
    -------
    dict
        ``mse`` (N^2), ``nrmse`` (RMS error / RMS of the reference, -) and ``fit``
        (MATLAB's, %: ``100 (1 - |e| / |y - mean y|)``).
    """
    y = np.asarray(reference, dtype=np.float64)
    y_hat = np.asarray(model, dtype=np.float64)
    if y.shape != y_hat.shape:
        raise FidelityError(f"reference and model must have the same shape, got {y.shape} and "
                            f"{y_hat.shape}")
    e = y_hat - y
    mse = float(np.mean(e**2))
    nrmse = float(np.sqrt(mse) / np.sqrt(np.mean(y**2)))
    fit = float(100.0 * (1.0 - np.linalg.norm(e) / np.linalg.norm(y - y.mean())))
    return {"mse": mse, "nrmse": nrmse, "fit": fit}


def waveform_fidelity(reference: ArrayLike, model: ArrayLike, fs: float,
                      high: tuple[float, float | None] = HIGH_BAND,
                      low: tuple[float, float | None] = LOW_BAND,
                      k: float = IMPACT_THRESHOLD, min_separation: float = MIN_SEPARATION,
                      quantiles: Sequence[float] = QUANTILES, polarity: int = POLARITY,
                      nperseg: int | None = None) -> Figures:
    """Every waveform figure of a model's force against a reference's (JSON-able).

    Parameters
    ----------
    reference, model : array_like, shape (n,)
        Dynamic forces of the same test, N, at ``fs``; a model's force that is not finite (a
        diverged free run) gives NaN for its figures (the reference's stand).
    fs : float
        Sample rate, Hz.
    high, low : (float, float or None)
        Bands of :func:`band_power_ratio`, Hz.
    k : float
        Impact threshold in RMS of the reference (:func:`impact_threshold`): one threshold, N,
        for both signals.
    min_separation : float
        s, between impacts and between peaks.
    quantiles : sequence of float
        Of the peaks' amplitudes (:func:`peak_quantiles`).
    polarity : {-1, 1}
        Direction of an impact.
    nperseg : int, optional
        Welch segment, samples.

    Returns
    -------
    dict
        ``nrmse`` (-), ``fit`` (%) (:func:`point_errors`); ``rms_ratio`` (-,
        :func:`rms_ratio`); ``hf_ratio`` and ``hf_ratio_reference`` (-, each signal's
        :func:`band_power_ratio`) and ``hf_factor`` = their ratio (-); ``impact_threshold``
        (N), ``impact_rate`` and ``impact_rate_reference`` (1/s); ``quantiles`` (-),
        ``peak_quantiles`` and ``peak_quantiles_reference`` (N, one per quantile, NaN without
        a peak).
    """
    r = _signal(reference, "reference")
    m = np.asarray(model, dtype=np.float64)
    if m.shape != r.shape:
        raise FidelityError(f"reference and model must have the same length, got {r.size} and "
                            f"{m.size} samples")
    fs = _rate(fs)
    err = point_errors(r, m)
    hf_r = band_power_ratio(r, fs, high, low, nperseg)
    th = impact_threshold(r, k)

    def rate(x: NDArray[np.float64]) -> float:
        return impact_rate(x, fs, th, min_separation, polarity) if th > 0 else 0.0

    def peaks(x: NDArray[np.float64]) -> list[float]:
        return [float(v) for v in peak_quantiles(x, fs, quantiles, min_separation, polarity)]

    reference_figures: Figures = {
        "hf_ratio_reference": hf_r,
        "impact_threshold": th,
        "impact_rate_reference": rate(r),
        "quantiles": [float(q) for q in quantiles],
        "peak_quantiles_reference": peaks(r),
    }
    if not np.all(np.isfinite(m)):
        # a diverged free run: the model has no waveform to judge (NaN), the reference's
        # figures stand, as the point-wise errors are NaN rather than an error
        nan = math.nan
        return {"nrmse": nan, "fit": nan, "rms_ratio": nan, "hf_ratio": nan, "hf_factor": nan,
                "impact_rate": nan, "peak_quantiles": [nan] * len(quantiles),
                **reference_figures}
    hf_m = band_power_ratio(m, fs, high, low, nperseg)
    return {
        "nrmse": err["nrmse"],
        "fit": err["fit"],
        "rms_ratio": rms_ratio(r, m),
        "hf_ratio": hf_m,
        "hf_factor": float(hf_m / hf_r) if hf_r > 0 else math.inf,
        "impact_rate": rate(m),
        "peak_quantiles": peaks(m),
        **reference_figures,
    }
