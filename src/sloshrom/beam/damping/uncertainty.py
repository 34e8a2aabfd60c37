"""Uncertainty of the first-mode damping estimates of the beam tests: every damping ratio with
its standard deviation and confidence interval.

* :func:`au_damping_cov`, :func:`required_duration` - Au's uncertainty law of output-only
  (ambient) damping identification and its inverse (the record length a precision needs).
* :func:`band_damping` - free decays: Hilbert and log-decrement damping per amplitude band,
  with intervals (a noise-added bootstrap of the record); :func:`amplitude_bands` - the bands
  of a decay's own amplitude range.
* :func:`estimate_random` (typed), :func:`damping_dataset` (an xarray Dataset over the
  estimators), :func:`random_damping` (Table 2's flat columns, made by
  ``sloshrom.beam.damping.columns``) - random tests: every asked estimator of
  ``sloshrom.beam.damping.registry`` through its protocol, the bias of the bootstrapped ones
  removed (parametric bootstrap under the record's own input PSD), each with a standard
  deviation and an interval (or the reason why there is none); any mode, in a band of its own
  (``band``). :func:`mode1_damping_random`: Table 2's raw estimates only.
* :func:`noise_ratios`, :func:`input_psd` - the input and output noise of a random test, from
  its coherence, and the shape of its input spectrum.

Pure numerical functions: arrays in, typed results, datasets or Table 2's columns (a file
contract, ``sloshrom.beam.damping.columns.table2_columns``) out. Intervals are two-sided at
``confidence`` (default :data:`CONFIDENCE`); NaN where an estimate or its spread cannot be
formed.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace
from typing import Any, TypedDict

import numpy as np
import xarray as xr
from numpy.typing import ArrayLike
from scipy import ndimage, optimize, signal, stats
from scipy.stats._stats_py import LinregressResult
from threadpoolctl import threadpool_limits

from sloshrom.beam.damping.analysis import (
    AnalysisError,
    bandpass_noise_gain,
    decay_copy,
    input_psd,
    noise_floor,
)
from sloshrom.beam.damping.columns import column, table2_columns
from sloshrom.beam.damping.estimators import (
    OUTPUT_ONLY_EFFICIENCY,
    DampingEstimate,
    RandomTest,
    bootstrap_estimator,
)
from sloshrom.beam.damping.limits import WELCH_SEGMENT
from sloshrom.beam.damping.registry import TABLE2, estimator_names, get_estimator, label
from sloshrom.beam.errors import BeamError
from sloshrom.config import G

__all__ = [
    "BANDS", "CONFIDENCE", "FLOOR_FACTOR", "MIN_COHERENCE", "OUTPUT_ONLY_EFFICIENCY",
    "RandomDamping", "ShortRecordWarning", "amplitude_bands", "au_damping_cov", "band_damping",
    "damping_dataset", "estimate_random", "format_interval", "input_noise_floor", "input_psd",
    "mode_frf", "near_modes",
    "mode1_damping_random", "noise_ratios", "random_damping", "required_duration",
]

#: Two-sided confidence level of every interval.
CONFIDENCE: float = 0.95
#: The most decimals :func:`format_interval` prints.
MAX_DECIMALS = 6


def format_interval(low: float, high: float, *values: float,
                    max_decimals: int = MAX_DECIMALS) -> tuple[str, ...]:
    """An interval's bounds and values printed with the decimals the interval needs.

    All numbers get one number of decimals: enough for two significant digits of the width
    ``|high - low|`` (so that the bounds differ visibly: ``1.3684, 1.3751``, not ``1.37,
    1.37``), at most ``max_decimals``. A zero or unknown width gives three significant digits
    of the largest number. Non-finite numbers print as ``"—"``.

    Parameters
    ----------
    low, high : float
        The interval, in the unit it is printed in (e.g. %).
    *values : float
        Numbers printed beside it (its estimate, a prediction), same unit.
    max_decimals : int
        Cap on the decimals (>= 0).

    Returns
    -------
    tuple of str
        ``low``, ``high``, then each of ``values``.
    """
    nums = (low, high, *values)
    width = abs(high - low) if math.isfinite(low) and math.isfinite(high) else math.nan
    if width > 0:
        decimals = 1 - math.floor(math.log10(width))
    else:
        top = max((abs(x) for x in nums if math.isfinite(x)), default=0.0)
        decimals = 2 - math.floor(math.log10(top)) if top > 0 else 0
    decimals = min(max(decimals, 0), max(int(max_decimals), 0))
    return tuple(f"{x:.{decimals}f}" if math.isfinite(x) else "—" for x in nums)

#: Bands of tank-acceleration amplitude (g) in which the instantaneous first-mode damping is
#: summarised.
BANDS: tuple[tuple[float, float], ...] = ((0.5, 1.0), (1.0, 2.0), (2.0, 3.0), (3.0, 5.0))

#: Amplitudes below this multiple of the noise floor
#: (``sloshrom.beam.damping.analysis.noise_floor``, the RMS envelope of the band-passed noise) carry
#: no damping information: there the noise moves ``ln A`` by about 1/3 and the Hilbert envelope's
#: noise bias (``+noise^2 / (2 A)``) is no longer small.
FLOOR_FACTOR: float = 3.0

#: The mantissas of the amplitude bands' edges (1-2-3-5 series).
_SERIES = (1.0, 2.0, 3.0, 5.0)


def amplitude_bands(amplitude_g: ArrayLike, floor_g: float | None = None
                    ) -> tuple[tuple[float, float], ...]:
    """Amplitude bands of a decay's own range: consecutive edges of the 1-2-3-5 series
    (..., 0.1, 0.2, 0.3, 0.5, 1, 2, 3, 5, 10, 20, ... g) that the amplitudes above ``floor_g``
    reach.

    A decay that covers 0.5-5 g has :data:`BANDS` among its bands, unchanged.

    Parameters
    ----------
    amplitude_g : array
        Amplitudes of the decay (e.g. the Hilbert envelope of the reference), g.
    floor_g : float, optional
        Lowest amplitude that carries information, g (e.g. :data:`FLOOR_FACTOR` times the
        noise floor); default: every finite positive amplitude.

    Returns
    -------
    tuple of (float, float)
        Bands ``[low, high)`` in increasing order, g; empty if no amplitude is above the floor.
    """
    a = np.asarray(amplitude_g, dtype=float).ravel()
    a = a[np.isfinite(a) & (a > 0)]
    if floor_g is not None and np.isfinite(floor_g):
        a = a[a >= floor_g]
    if a.size == 0:
        return ()
    lo, hi = float(a.min()), float(a.max())
    k0, k1 = math.floor(math.log10(lo)) - 1, math.floor(math.log10(hi)) + 1
    # round the edges: 0.3 must be 0.3, not 0.30000000000000004, in the band's name
    edges = [float(f"{m * 10.0**k:.12g}") for k in range(k0, k1 + 1) for m in _SERIES]
    return tuple((e0, e1) for e0, e1 in zip(edges[:-1], edges[1:], strict=True)
                 if e1 > lo and e0 < hi)

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
         n_cycles: float, reason: str = "") -> dict[str, Any]:
    return {"band": band, "method": method, "zeta": float(zeta), "std": float(std),
            "low": float(zeta - half), "high": float(zeta + half), "n_cycles": float(n_cycles),
            "reason": reason}


def band_damping(
    hilbert: Mapping[str, Any],
    log_decrement: Mapping[str, Any],
    f1: float,
    *,
    amplitude_scale: float = 1 / G,
    bands: Sequence[tuple[float, float]] | None = BANDS,
    confidence: float = CONFIDENCE,
    smooth_periods: float = 4.0,
    record: ArrayLike | None = None,
    fs: float | None = None,
    noise: float | None = None,
    floor: float | None = None,
    floor_factor: float = FLOOR_FACTOR,
    rel_band: float = 0.35,
    n_boot: int = 40,
    seed: int = 0,
) -> list[dict[str, Any]]:
    """Instantaneous damping of a mode per amplitude band of a free decay, with intervals.

    * ``hilbert``: the median of ``zeta(t)`` over the samples whose amplitude is in the band.
    * ``log_decrement``: least-squares slope ``-sigma`` of ``ln(peak)`` against time over the
      peaks in the band, ``zeta = sigma / sqrt(omega_d^2 + sigma^2)`` with ``omega_d`` from the
      peaks' mean spacing.

    Intervals. With the analysed ``record`` (and ``fs``) that reaches its noise floor: a
    noise-added bootstrap. ``n_boot``
    copies of the record, each plus white noise of the record's own band-passed level
    (``noise``, default ``sloshrom.beam.damping.analysis.noise_floor`` of the record), are analysed
    the same way over the same samples (Hilbert) or time span (peaks) of each band; the
    standard deviation of their band values is the estimate's (the estimator is nearly linear
    in the noise above the floor), the interval Student's t with ``n_boot - 1`` degrees of
    freedom. The analysis' own deterministic ripple (the Hilbert envelope of a decaying
    sinusoid, the smoothing's end effects) is the same in every copy and does not widen the
    interval, and the correlation of neighbouring samples (smoothing window, band-passed noise)
    is in the copies. Without the record, or if its floor is not measurable (``noise_floor``
    NaN: a noise-free simulation, a record stopped above its floor): the closed forms, which
    count the ripple as scatter (too wide at a high signal-to-noise ratio): Hilbert
    ``1.2533 s W / (sqrt(6) L)`` (``s`` the samples' standard deviation, ``W`` the window,
    ``L`` the band's length; t with ``L / W + 1`` degrees of freedom), log decrement the
    slope's standard error inflated by the residuals' lag-one correlation (t with
    ``n_peaks - 2``).

    Samples and peaks whose amplitude is below ``floor_factor * floor`` are dropped: there the
    noise, not the decay, sets the envelope.

    A noise-free decay gives very narrow intervals: they hold the record's statistical error
    only, not the method's own (small) bias.

    Parameters
    ----------
    hilbert, log_decrement : mapping
        Results of ``sloshrom.beam.damping.analysis.instantaneous_damping`` and ``log_decrement``
        (the latter with its per-peak entries ``peak_time``, ``peak``, ``peak_amplitude``) of one
        mode; amplitudes in the reference's unit.
    f1 : float
        The mode's frequency (the band-pass centre), Hz.
    amplitude_scale : float
        Factor from the amplitude's unit to g (default: amplitudes in m/s^2).
    bands : sequence of (float, float), optional
        Amplitude bands ``[low, high)``, g; ``None``: the decay's own
        (:func:`amplitude_bands` of the amplitudes above ``floor_factor * floor``).
    confidence : float
        Two-sided confidence level of the intervals.
    smooth_periods : float
        The smoothing window of ``instantaneous_damping``, periods.
    record : array (n,), optional
        The signal both analyses were given (``x``, unit of the ``peak``); enables the
        bootstrap. Both analyses must have used the default trimming and ``rel_band``.
    fs : float, optional
        Its sampling frequency, Hz (with ``record``).
    noise : float, optional
        The record's noise amplitude, unit of ``record``; default its ``noise_floor``.
    floor : float, optional
        Noise floor of the amplitude (the reference's ``noise_floor``), unit of the amplitude
        (before ``amplitude_scale``); default: no sample dropped.
    floor_factor : float
        Multiple of ``floor`` below which samples are dropped (:data:`FLOOR_FACTOR`).
    rel_band : float
        Half-width of the analyses' band-pass, relative to ``f1``.
    n_boot : int
        Bootstrap copies (at least 2).
    seed : int
        Seed of the bootstrap's noise.

    Returns
    -------
    list of dict
        One row per band and method (Hilbert first): ``band`` (e.g. ``"1-2 g"``), ``method``
        (``"hilbert"`` or ``"log_decrement"``), ``zeta``, ``std``, ``low``, ``high`` (damping
        ratio, -), ``n_cycles`` (cycles of the band, -) and ``reason`` (``""`` when the value
        and its interval exist, else why not: every NaN has one). Without a record, a Hilbert
        band shorter than one smoothing window keeps its median with NaN
        ``std``/``low``/``high``; NaN throughout where the band has too little data (10
        samples or fewer, fewer than 3 peaks).
    """
    missing = [k for k in ("peak_time", "peak", "peak_amplitude") if k not in log_decrement]
    if missing:
        raise BeamError(f"log_decrement lacks {missing}: pass the dict of analysis.log_decrement")
    if f1 <= 0 or smooth_periods <= 0:
        raise BeamError("f1 and smooth_periods must be positive")
    if record is not None and (fs is None or fs <= 0 or n_boot < 2):
        raise BeamError("a record needs its positive fs and n_boot >= 2")
    nan = float("nan")
    zh = np.asarray(hilbert["zeta"], dtype=float)
    ah = np.asarray(hilbert["amplitude"], dtype=float) * amplitude_scale
    th = np.asarray(hilbert["time"], dtype=float)
    fh = np.asarray(hilbert.get("frequency", np.full(zh.size, f1)), dtype=float)
    dt = float(np.min(np.diff(th))) if th.size > 1 else nan
    tp = np.asarray(log_decrement["peak_time"], dtype=float)
    lp = np.log(np.abs(np.asarray(log_decrement["peak"], dtype=float)))
    ap = np.asarray(log_decrement["peak_amplitude"], dtype=float) * amplitude_scale
    least = (floor_factor * floor * amplitude_scale if floor is not None and np.isfinite(floor)
             else -np.inf)
    if bands is None:
        bands = amplitude_bands(ah, least if np.isfinite(least) else None)
    rate = float(fs) if fs is not None else nan  # checked above when there is a record
    if record is not None and noise is None:
        try:
            noise = noise_floor(np.asarray(record, dtype=float), rate, f1, rel_band)
        except AnalysisError:
            noise = nan
    # a record that does not reach its noise floor (noise-free, stopped early) keeps the
    # closed forms: its noise is not measurable
    boot = (_decay_bootstrap(np.asarray(record, dtype=float), rate, f1, th, noise,
                             smooth_periods, rel_band, n_boot, seed)
            if record is not None and noise is not None and np.isfinite(noise) else None)
    t_boot = _t(confidence, n_boot - 1)
    below = f"below {floor_factor:g} times the noise floor" if np.isfinite(least) else ""
    rows = []
    for lo, hi in bands:
        name = f"{lo:g}-{hi:g} g"
        in_band = (ah >= lo) & (ah < hi)
        sel = in_band & (ah >= least)
        n_sel = int(np.count_nonzero(sel))
        n_cyc = float(n_sel * dt * np.median(fh[sel])) if n_sel else 0.0
        span = n_cyc / smooth_periods  # band length in smoothing windows
        lost = (f" ({int(np.count_nonzero(in_band)) - n_sel} more {below})"
                if below and np.count_nonzero(in_band) > n_sel else "")
        if n_sel <= 10:
            rows.append(_row(name, "hilbert", nan, nan, nan, n_cyc,
                             f"the decay has {n_sel} sample(s) in the band{lost}, 10 or fewer "
                             "(it does not pass through it)"))
        elif boot is not None:
            z = float(np.median(zh[sel]))
            std = float(np.std(np.median(boot["hilbert"][:, sel], axis=1), ddof=1))
            rows.append(_row(name, "hilbert", z, std, t_boot * std, n_cyc))
        elif span >= 1 and np.isfinite(dt):
            z = float(np.median(zh[sel]))
            # zeta(t) is a regression slope over the window W: over a band of length L their
            # mean is about the slope between the band's two ends, of variance W^2 / (6 L^2)
            # times a single slope's (white or short-correlated noise on ln A)
            std = 1.2533 * float(np.std(zh[sel], ddof=1)) / math.sqrt(max(1.0, 6 * span**2))
            half = _t(confidence, span + 1) * std
            rows.append(_row(name, "hilbert", z, std, half, n_cyc))
        else:
            # shorter than one smoothing window: the samples are one estimate, with no
            # independent values to state its scatter (the median of damping_by_band)
            rows.append(_row(name, "hilbert", float(np.median(zh[sel])), nan, nan, n_cyc,
                             f"no interval: the band holds {n_cyc:.2g} cycles, fewer than the "
                             f"{smooth_periods:g} of one smoothing window (its samples are one "
                             "estimate)"))
        sp = (ap >= lo) & (ap < hi) & (ap >= least)
        t, y = tp[sp], lp[sp]
        if t.size < 3:
            n_out = int(np.count_nonzero((ap >= lo) & (ap < hi))) - t.size
            rows.append(_row(name, "log_decrement", nan, nan, nan, max(t.size - 1, 0),
                             f"{t.size} peak(s) in the band"
                             + (f" ({n_out} more {below})" if below and n_out else "")
                             + ", fewer than the 3 a slope and its error need"))
            continue
        z, wd, fit = _slope_damping(t, y)
        n_cyc_p = (t[-1] - t[0]) * wd / (2 * math.pi)
        if boot is not None:
            half_period = math.pi / wd
            zb = [_slope_damping(tb[m], yb[m])[0] for tb, yb in boot["peaks"]
                  for m in [(tb >= t[0] - half_period) & (tb <= t[-1] + half_period)]
                  if np.count_nonzero(m) >= 3]
            if len(zb) < 2:
                rows.append(_row(name, "log_decrement", z, nan, nan, n_cyc_p,
                                 "no interval: the noisy copies of the record lose the band's "
                                 "peaks"))
                continue
            std = float(np.std(zb, ddof=1))
            rows.append(_row(name, "log_decrement", z, std, _t(confidence, len(zb) - 1) * std,
                             n_cyc_p))
            continue
        # neighbouring peaks share band-passed noise: inflate the slope's standard error
        # as for AR(1) residuals, (1 + rho) / (1 - rho) on the variance
        res = y - (fit.intercept + fit.slope * t)
        rho = np.sum(res[1:] * res[:-1]) / max(np.sum(res**2), 1e-300)
        # the lag-one correlation of a few residuals is biased low by about (1 + 3 rho) / n
        rho = float(np.clip(rho + (1 + 3 * rho) / t.size, 0, 0.9))
        std = fit.stderr / wd * math.sqrt((1 + rho) / (1 - rho))
        half = _t(confidence, t.size - 2) * std
        rows.append(_row(name, "log_decrement", z, std, half, n_cyc_p))
    return rows


def _slope_damping(t: np.ndarray, y: np.ndarray) -> tuple[float, float, LinregressResult]:
    # damping ratio from the slope of ln(peak) against time, the damped circular frequency
    # from the peaks' mean spacing (interpolated peak times)
    fit = stats.linregress(t, y)
    sigma = -fit.slope
    wd = 2 * math.pi * (t.size - 1) / float(t[-1] - t[0])
    return sigma / math.hypot(wd, sigma), wd, fit


def _decay_bootstrap(x: np.ndarray, fs: float, f: float, times: np.ndarray, noise: float,
                     smooth_periods: float, rel_band: float, n_boot: int, seed: int
                     ) -> _Copies:
    # the record plus white noise of its own band-passed level, analysed n_boot times: zeta(t)
    # at the record's Hilbert samples, and every copy's peaks
    # noise is the RMS envelope, sqrt(2) times the band-passed RMS
    sd = noise / math.sqrt(2) / bandpass_noise_gain(fs, f, rel_band)
    idx = np.rint(times * fs).astype(int)
    rng = np.random.default_rng(seed)
    zeta = np.empty((n_boot, idx.size))
    peaks = []
    for k in range(n_boot):
        z, tp, ap = decay_copy(x + sd * rng.standard_normal(x.size), fs, f, rel_band,
                               smooth_periods)
        zeta[k] = z[idx]
        peaks.append((tp, np.log(np.abs(ap))))
    return {"hilbert": zeta, "peaks": peaks}


class _Copies(TypedDict):
    hilbert: np.ndarray  # (n_boot, n): zeta(t) of each copy at the record's Hilbert samples
    peaks: list[tuple[np.ndarray, np.ndarray]]  # each copy's peak times and ln(peak)


# -- random tests: every estimator through its protocol, with intervals ---------------------
def noise_ratios(f: np.ndarray, h: np.ndarray, coh: np.ndarray, leakage: np.ndarray,
                 sxx: np.ndarray, frequency: float, zeta: float,
                 band: tuple[float, float]) -> tuple[float, float]:
    """Input and output noise of a random test, from the part of its incoherence that the
    mode's leakage does not explain.

    With white noise on both channels (PSDs ``N_u``, ``N_y``), line by line
    ``1/coh - 1 = N_u / S_xx + N_y / (|H|^2 S_xx) + c L`` (``S_xx`` the input PSD, coloured or
    not; ``L`` the incoherence of noise-free records of the fitted mode - the window's
    leakage and the bias of a coherence from few segments -, ``c`` near 1); the three are
    fitted by non-negative least squares on the lines of ``band`` more than one half-power
    bandwidth from the resonance, each line weighted by the inverse of its expected value
    (``L`` plus an 11-line running median of ``1/coh - 1``: the scatter of an incoherence
    estimate grows with it). A shaker band that ends inside the fitting band leaves lines
    where the input is mostly noise; a flat ``S_xx`` would read their incoherence as input
    noise everywhere.

    Parameters
    ----------
    f, h, coh : array (n_f,)
        Frequencies (Hz), H1 and coherence of the record.
    leakage : array (n_f,)
        ``1/coh - 1`` of noise-free simulated records of the fitted mode, averaged.
    sxx : array (n_f,)
        Input PSD of the record at ``f``, smoothed (its Welch estimate over many short
        segments, interpolated): a line-by-line estimate from a few long segments scatters
        far more than the input does.
    frequency, zeta : float
        The mode (Hz, -).
    band : (float, float)
        Fitting band, Hz.

    Returns
    -------
    (float, float)
        The input's noise-to-signal ratio at the resonance ``N_u / S_xx(f_n)`` (-) and the
        output's ``N_y / (|H(f_n)|^2 S_xx(f_n))`` (-).
    """
    with np.errstate(divide="ignore", invalid="ignore"):
        r = 1 / coh - 1
    sel = ((f >= band[0]) & (f <= band[1]) & np.isfinite(r) & np.isfinite(leakage)
           & (np.abs(f - frequency) > 2 * zeta * frequency) & (sxx > 0))
    if np.count_nonzero(sel) < 6:
        return 0.0, 0.0
    s_in = sxx[sel]
    g = np.abs(h[sel]) ** 2 * s_in
    lk = np.clip(leakage[sel], 0, None)
    r_sel = r[sel]
    # relative weights: an incoherence estimate scatters in proportion to its size
    typical = ndimage.median_filter(np.clip(r_sel, 0, None), size=11, mode="nearest")
    w = 1 / (lk + typical + 1e-12)
    a = np.stack([1 / s_in, 1 / g, lk], axis=1) * w[:, None]
    scale = np.linalg.norm(a, axis=0)
    scale[scale == 0] = 1.0
    x, _ = optimize.nnls(a / scale, r_sel * w)
    n_u, n_y = x[0] / scale[0], x[1] / scale[1]
    i = int(np.argmin(np.abs(f - frequency)))
    return float(n_u / sxx[i]), float(n_y / (np.abs(h[i]) ** 2 * sxx[i]))


def input_noise_floor(psd: np.ndarray) -> float:
    """The floor of a smooth input PSD (:func:`input_psd`): the median of its lines within a
    factor 2 of its smallest positive one, the record's unit squared per Hz. Beyond a shaker's
    band it is the input's white noise; with no line free of excitation, an upper bound of it.
    """
    p = psd[psd > 0]
    if p.size == 0:
        return 0.0
    return float(np.median(p[p <= 2 * p.min()]))


#: Neighbouring modes within this factor of a mode's frequency enter its model
#: (:func:`mode_frf`) as resonances of their own; farther ones are smooth in its band, which
#: the tail terms hold.
NEIGHBOUR_FACTOR = 2.0


def _resonance(w: np.ndarray, wn: float, zeta: float) -> np.ndarray:
    # a base-excited mode's term of the absolute acceleration FRF, unit residue
    return w**2 / (wn**2 - w**2 + 2j * zeta * wn * w)


def _mode_terms(f: np.ndarray, frequency: float, zeta: float,
                neighbours: Sequence[float] = ()) -> np.ndarray:
    # the columns of mode_frf's model at f (Hz): the constant and the tail terms, the
    # neighbouring modes' resonances (damped as the mode: their tails in its band hardly
    # depend on it), then the mode's own term (last)
    w = 2 * math.pi * np.asarray(f, dtype=float)
    wn = 2 * math.pi * frequency
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.stack([np.ones(w.size), (wn / w) ** 2, (wn / w) ** 4, (w / wn) ** 2,
                         (w / wn) ** 4,
                         *(_resonance(w, 2 * math.pi * fj, zeta) for fj in neighbours),
                         _resonance(w, wn, zeta)], axis=-1)


def mode_frf(f: np.ndarray, h: np.ndarray, frequency: float, zeta: float,
             band: tuple[float, float], weight: np.ndarray | None = None,
             neighbours: Sequence[float] = ()) -> np.ndarray:
    """The FRF base -> absolute acceleration of a mode among others, fitted to a record's H1.

    ``H(w) = c0 + c1 (w_n/w)^2 + c2 (w_n/w)^4 + c3 (w/w_n)^2 + c4 (w/w_n)^4
    + sum_j R_j w^2 / (w_j^2 - w^2 + 2 i zeta w_j w) + R w^2 / (w_n^2 - w^2 + 2 i zeta w_n w)``:
    the mode of residue ``R`` (a base-excited oscillator has ``c0 = R = 1``, the others 0), the
    neighbouring modes ``neighbours`` (Hz) as resonances of residue ``R_j``, the farther modes
    below as a mass line (a constant, ``c1``, ``c2``: the first terms of their tails'
    expansion in ``w_k / w``), those above as a stiffness line (``c3``, ``c4``: in
    ``w / w_k``); ``R``, ``R_j`` and the ``c`` real (light, proportional damping), fitted by
    weighted least squares on the lines of ``band`` with ``frequency`` and ``zeta`` held; the
    tails (``c1`` to ``c4``) only if they reduce the residual significantly (F-test at 1 %),
    else ``c0``, the ``R_j`` and ``R`` alone. A tip accelerometer sees mode 2 of a cantilever
    with ``R = -0.87`` over a background near -0.5: the bias of LSCF on H1 there differs from
    that of a lone oscillator by 2.4 % of the damping (noise-free 120 s records at 500 Hz),
    more than its scatter. A neighbour 15 % away (closely spaced modes) is no smooth tail: the
    four tail terms took the values -300 to +300 to follow it, and the simulated records biased
    the correction by 7 %.

    Parameters
    ----------
    f, h : array (n_f,)
        Frequencies (Hz) and H1 of the record.
    frequency, zeta : float
        The mode (Hz, -).
    band : (float, float)
        Fitting band, Hz.
    weight : array (n_f,), optional
        Weight of each line's squared residual (default 1), e.g. the inverse of H1's
        variance.
    neighbours : sequence of float
        Frequencies of the neighbouring modes, Hz (those within :data:`NEIGHBOUR_FACTOR` of
        ``frequency``; :func:`near_modes`).

    Returns
    -------
    ndarray (6 + len(neighbours),)
        ``c0, c1, c2, c3, c4``, the ``R_j``, ``R``, -; those of the lone oscillator (1, 0, ...,
        0, 1) if the band holds fewer than 8 lines.
    """
    n_col = 6 + len(neighbours)
    w = np.ones(f.size) if weight is None else np.asarray(weight, dtype=float)
    sel = (f >= band[0]) & (f <= band[1]) & (f > 0) & np.isfinite(h) & (w > 0)
    if np.count_nonzero(sel) < 8:
        lone = np.zeros(n_col)
        lone[[0, -1]] = 1.0
        return lone
    sw = np.sqrt(np.concatenate([w[sel], w[sel]]))[:, None]
    a = _mode_terms(f[sel], frequency, zeta, neighbours)
    a_ri = np.concatenate([a.real, a.imag]) * sw
    rhs = np.concatenate([h[sel].real, h[sel].imag]) * sw[:, 0]

    def fit(cols: list[int]) -> tuple[np.ndarray, float]:
        m = a_ri[:, cols]
        scale = np.linalg.norm(m, axis=0)
        scale[scale == 0] = 1.0
        x = np.linalg.lstsq(m / scale, rhs, rcond=None)[0] / scale
        out = np.zeros(a.shape[1])
        out[cols] = x
        return out, float(np.sum((rhs - m @ x) ** 2))

    full, rss_full = fit(list(range(n_col)))
    # the far modes' tails only where the record shows them (F-test at 1 %): on a noisy
    # record of a lone mode the four collinear tail terms fit the noise, and moved the
    # background by +/-5 % from record to record
    reduced, rss_red = fit([0, *range(5, n_col)])
    dof = rhs.size - n_col
    if dof <= 0 or rss_full <= 0:
        return full
    f_stat = (rss_red - rss_full) / 4 / (rss_full / dof)
    return full if stats.f.sf(f_stat, 4, dof) < 0.01 else reduced


def near_modes(frequency: float, others: Sequence[float]) -> tuple[float, ...]:
    """The modes of ``others`` (Hz) within :data:`NEIGHBOUR_FACTOR` of ``frequency`` (Hz),
    the mode itself left out: those :func:`mode_frf` models as resonances."""
    return tuple(float(v) for v in others if v != frequency
                 and 1 / NEIGHBOUR_FACTOR < v / frequency < NEIGHBOUR_FACTOR
                 and abs(v / frequency - 1) > 1e-3)


def _simulate(frequency: float, zeta: float, fs: float, n: int, n_records: int,
              noise: tuple[float, float], rng: np.random.Generator,
              psd: tuple[np.ndarray, np.ndarray] | None = None,
              frf: tuple[np.ndarray, tuple[float, float], Sequence[float]] | None = None,
              ) -> tuple[np.ndarray, np.ndarray]:
    # The fitted mode, base -> absolute acceleration; start-up of 20 time constants discarded.
    # Input: white, or Gaussian of the one-sided PSD psd = (f (Hz), S) (the noise-free part of
    # the record's input), white noise shaped in the frequency domain (periodic over n + n0
    # samples). Response: a lone oscillator (exact zero-order-hold discretisation), or with
    # frf = (mode_frf coefficients, band, neighbours) the mode among its neighbours, line by
    # line in the
    # frequency domain over the band widened by a tenth on each side (zero outside: only the
    # band is analysed). Noise: white, noise = (input, output) noise-to-signal ratios at the
    # resonance.
    wn = 2 * math.pi * frequency
    n0 = int(min(20 / (zeta * wn), 60.0) * fs)
    u = rng.standard_normal((n_records, n + n0))
    s_n = 2 / fs  # the white input's one-sided PSD at the resonance
    fl = np.fft.rfftfreq(n + n0, 1 / fs)
    spec = None
    if psd is not None:
        spec = np.fft.rfft(u, axis=1) * np.sqrt(np.clip(np.interp(fl, *psd), 0, None) * fs / 2)
        u = np.fft.irfft(spec, n + n0, axis=1)
        s_n = float(np.interp(frequency, *psd))
    if frf is not None:
        coef, (lo, hi), near = frf
        pad = 0.1 * (hi - lo)
        on = (fl >= lo - pad) & (fl <= hi + pad) & (fl > 0)
        h = np.zeros(fl.size, dtype=complex)
        h[on] = _mode_terms(fl[on], frequency, zeta, near) @ coef
        spec = np.fft.rfft(u, axis=1) if spec is None else spec
        y = np.fft.irfft(spec * h, n + n0, axis=1)[:, n0:]
        gain2 = float(abs(_mode_terms(np.array([frequency]), frequency, zeta, near)[0]
                          @ coef)) ** 2
    else:
        b, a, _ = signal.cont2discrete(([2 * zeta * wn, wn**2], [1, 2 * zeta * wn, wn**2]),
                                       1 / fs, method="zoh")
        y = signal.lfilter(np.ravel(b), a, u, axis=1)[:, n0:]
        gain2 = abs(signal.freqz(np.ravel(b), a, worN=[frequency], fs=fs)[1][0]) ** 2
    u = u[:, n0:]
    n_u, n_y = noise
    # white noise of one-sided PSD N has variance N fs / 2
    u = u + math.sqrt(n_u * s_n * fs / 2) * rng.standard_normal(u.shape)
    y = y + math.sqrt(n_y * gain2 * s_n * fs / 2) * rng.standard_normal(y.shape)
    return u, y


# BLAS on one thread: the bootstrap's LSCF fits are small (a QR of ~700 x 82) and many; on a
# loaded machine a multithreaded BLAS made each one up to ten times slower than on one thread
@threadpool_limits.wrap(limits=1, user_api="blas")
def estimate_random(
    base: Any,
    tank: Any,
    fs: float,
    f1: float,
    *,
    estimators: Sequence[str] | None = None,
    confidence: float = CONFIDENCE,
    n_resamples: int = 40,
    seed: int = 0,
    accuracy: float | None = None,
    rel_band: float = 0.5,
    nperseg: int = WELCH_SEGMENT,
    band: tuple[float, float] | None = None,
    neighbours: Sequence[float] = (),
) -> RandomDamping:
    """Damping of the mode near ``f1`` (the first one by default) in a random test by every
    asked estimator, each with its standard deviation and interval (the estimators of
    ``sloshrom.beam.damping.registry``, through their protocol).

    * A mode the input does not excite (coherence below :data:`MIN_COHERENCE` at the peak of
      ``|H1|`` near ``f1``: e.g. above a shaker's band) gets NaN for every estimator, with
      that reason, its raw value (``uncorrected``) and frequency too: what a fit gives there
      is not the mode's.
    * Estimators of ``uncertainty == "bootstrap"`` (``lscf_h1``, ``half_power``): a parametric
      bootstrap. ``n_resamples`` records of the record's length are simulated from the fitted
      mode (a base-excited oscillator driven by Gaussian noise of the record's input PSD,
      :func:`input_psd`: coloured and band-limited as the shaker's) with the record's input
      and output noise (:func:`noise_ratios`), and analysed as the record was
      (``DampingEstimator.estimate_records``). Their mean minus the simulated damping is the
      estimator's bias (the Welch window's leakage, and the equation-error bias that noise
      causes); it is removed, and the simulation repeated once around the corrected damping.
      ``std`` is the standard deviation of the simulated estimates, the interval
      ``value +/- t std`` (Student's ``t`` with ``n_resamples - 1`` degrees of freedom). The
      simulated mode: the damping ratio of the first bootstrapped estimator (in the order
      asked) that gives one in (0, 0.5), the frequency of the first bootstrapped estimator
      (``f1`` if it has none).
    * Estimators of ``uncertainty == "spread"`` (``lscf_output``): the same simulated records,
      analysed by the estimator too. ``value`` is the raw value (the simulated bias ``b`` is
      not removed: on a lone mode it is the record's, among other modes it need not be),
      ``std`` the simulated estimates' standard deviation, and the interval the union of
      ``value +/- t std`` and ``value - b +/- t std``, the intervals around the raw and the
      bias-corrected value: ``[min(value, value - b) - t std, max(value, value - b) + t std]``.
      Where there is no bootstrap (no damping ratio to simulate, or fewer than half of the
      simulated records gave an estimate), Au's law as below.
    * Estimators of ``uncertainty == "au"``: ``std = efficiency * zeta *
      au_damping_cov(zeta, frequency, duration)`` (Au's law times the estimator's measured
      efficiency), interval ``zeta +/- z std``; no bias correction.

    Parameters
    ----------
    base, tank : array (n,)
        Base and tank accelerations, same unit.
    fs, f1 : float
        Sampling frequency and approximate first-mode frequency, Hz.
    estimators : sequence of str, optional
        Registered estimator names (default ``registry.TABLE2``).
    confidence : float
        Two-sided confidence level of the intervals.
    n_resamples : int
        Simulated records per bootstrap round (two rounds).
    seed : int
        Seed of the simulations.
    accuracy : float, optional
        Wanted relative 1-sigma precision of the damping ratio (e.g. 0.1). If Au's law (times
        the output-only estimator's efficiency) says the record cannot give it, a
        :class:`ShortRecordWarning` names the record length that would.
    rel_band : float
        Fitting band ``f1 (1 -/+ rel_band)``, Hz, unless ``band`` is given.
    nperseg : int
        Welch segment length, samples.
    band : (float, float), optional
        Fitting band (low, high), Hz, overriding ``rel_band``: for a mode between neighbours,
        the band between them. Must hold ``f1``; clipped to the Nyquist frequency.
    neighbours : sequence of float
        The test's other modes, Hz: those near ``f1`` (:func:`near_modes`) enter the
        bootstrap's model of the record as resonances (:func:`mode_frf`).

    Returns
    -------
    RandomDamping
        Per estimator a :class:`~sloshrom.beam.damping.estimators.DampingEstimate` (NaN values with
        their reason: no estimate, or fewer than half of the simulated records gave one - the
        record's estimate is not reproducible), and the record's noise ratios, length and
        cycles.
    """
    nan = float("nan")
    names = estimator_names(estimators)
    test = RandomTest(base, tank, fs, f1, rel_band=rel_band, nperseg=nperseg, band=band)
    if test.base.ndim != 1:
        raise BeamError("base and tank must be 1-D arrays of the same length")
    if n_resamples < 2:
        raise BeamError("n_resamples must be at least 2")
    z = _z(confidence)
    ests = {n: get_estimator(n) for n in names}
    raw = {n: e.estimate(test) for n, e in ests.items()}
    unexcited = _unexcited(test)
    if unexcited:
        # the input does not reach the mode above the noise: whatever an estimator fitted there
        # is not the mode's damping (a raw half-power value of 42 % at a phantom peak), and
        # no interval can say how far it is: no value is written, raw or corrected
        raw = {n: replace(r, value=nan, uncorrected=nan, frequency=nan, reason=unexcited)
               for n, r in raw.items()}
    # those whose bias the bootstrap removes first: the simulated mode is theirs
    boot = ([n for n in names if ests[n].uncertainty == "bootstrap"]
            + [n for n in names if ests[n].uncertainty == "spread"])
    # the simulated records are analysed by the procedure (attempt) that gave the value
    boot_ests = {n: bootstrap_estimator(ests[n], raw[n]) for n in boot}
    duration = test.duration
    out: dict[str, DampingEstimate] = {}

    noise = (nan, nan)
    zeta_model = next((raw[n].value for n in boot if 0 < raw[n].value < 0.5), nan)
    f_mode = raw[boot[0]].frequency if boot and np.isfinite(raw[boot[0]].frequency) else f1
    bias = {n: nan for n in boot}
    spread = dict(bias)
    if np.isfinite(zeta_model):
        f, h, coh = test.h1

        def bootstrap(noise: tuple[float, float]) -> np.ndarray:
            # both rounds draw the same records (the noise after them): the result is
            # continuous in the estimated noise, which round-off may move off zero
            rng = np.random.default_rng(seed)
            # the ratios are to the record's input PSD, noise included; the simulation's are to
            # its noise-free input
            clean = max(1 - noise[0], 1e-3)
            u, y = _simulate(f_mode, zeta_model, fs, test.base.size, n_resamples,
                             (noise[0] / clean, noise[1] / clean), rng,
                             psd=(f_in, np.clip(s_in - noise[0] * s_mode, 0, None)),
                             frf=(coef, test.fit_band, near))
            sims = RandomTest(u, y, fs, f1, rel_band=rel_band, nperseg=test.nperseg,
                              band=test.band)
            for n in boot:
                v = boot_ests[n].estimate_records(sims)
                v = v[np.isfinite(v)]
                if v.size >= max(2, n_resamples // 2):  # else the mode is mostly lost
                    bias[n], spread[n] = v.mean() - zeta_model, v.std(ddof=1)
                else:
                    bias[n], spread[n] = nan, nan
            with np.errstate(divide="ignore"):
                return np.mean(1 / sims.h1[2] - 1, axis=0)

        # the simulated input has the record's input PSD (coloured, band-limited), less its
        # noise once that is known
        f_in, s_in = input_psd(test.base, fs)
        s_mode = float(np.interp(f_mode, f_in, s_in))
        # the simulated mode has the record's FRF shape around it (the estimators' bias depends
        # on it): each line of H1 weighted by the inverse of its variance, |H|^2 (1 - coh) / coh
        s_f = np.interp(f, f_in, s_in)
        # (coherence and |H| smoothed over 11 lines: weights from the very lines they weigh,
        # whose errors they share, biased the fit by 5 % on a lone oscillator with 5 % noise)
        c_s = np.clip(ndimage.median_filter(np.nan_to_num(coh), size=11, mode="nearest"), 0,
                      0.9999)
        a_s = ndimage.median_filter(np.abs(np.nan_to_num(h)), size=11, mode="nearest")
        with np.errstate(divide="ignore", invalid="ignore"):
            w_h1 = np.nan_to_num(c_s / (1 - c_s) / a_s**2, nan=0.0, posinf=0.0)
        near = near_modes(f_mode, neighbours)
        coef = mode_frf(f, h, f_mode, zeta_model, test.fit_band, w_h1, near)
        # round 1, noise-free: the leakage bias and the incoherence the leakage causes; the
        # rest of the record's incoherence is noise, which biases LSCF strongly (1 % RMS on the
        # input moved a 90 s estimate by -5 %): round 2 simulates it
        leak = bootstrap((0.0, 0.0))
        noise = noise_ratios(f, h, coh, leak, s_f, f_mode, zeta_model, test.fit_band)
        # white input noise cannot exceed the floor of the input PSD (beyond a shaker's band
        # the base records its noise alone, which the floor measures to ~1 %): the clean input
        # the bootstrap simulates is the PSD less that noise, which shapes H1 where the input
        # rolls off
        noise = (min(noise[0], input_noise_floor(s_in) / s_mode), noise[1])
        # H1 is biased low by the input noise, by 1 - N_u / S_xx: the simulated mode must be
        # the noise-free one (the simulation adds the noise again); lines where the noise is
        # half the input or more are left out
        keep = 1 - noise[0] * s_mode / np.where(s_f > 0, s_f, np.inf)
        coef = mode_frf(f, h / np.clip(keep, 0.5, 1), f_mode, zeta_model, test.fit_band,
                        np.where(keep > 0.5, w_h1, 0.0), near)
        if max(noise) > 0:
            bootstrap(noise)
    # the spread is estimated from n_resamples records: Student's t, not the normal quantile
    t_boot = _t(confidence, n_resamples - 1)
    for n in names:
        r = raw[n]
        # the interval is [value + lo_shift - q std, value + hi_shift + q std]
        lo_shift = hi_shift = 0.0
        if ests[n].uncertainty == "bootstrap":
            value, std, q = float(r.value - bias[n]), float(spread[n]), t_boot
            why = _bootstrap_reason(r, zeta_model, value, std, n_resamples)
        elif ests[n].uncertainty == "spread" and np.isfinite(spread[n]):
            value, std, q = r.value, float(spread[n]), t_boot
            # the simulated bias is the record's on a lone mode, not among other modes: the
            # union of the intervals around the raw and the bias-corrected value covers both
            lo_shift, hi_shift = min(0.0, -float(bias[n])), max(0.0, -float(bias[n]))
            why = r.reason or ("" if np.isfinite(value) else "no estimate")
        else:
            value, q = r.value, z
            ok = np.isfinite(value) and value > 0 and np.isfinite(r.frequency)
            std = (ests[n].efficiency * value * au_damping_cov(value, r.frequency, duration)
                   if ok else nan)
            why = r.reason or ("" if ok else f"no positive damping ratio ({value:.3g})")
        out[n] = replace(r, value=value, std=std, low=value + lo_shift - q * std,
                         high=value + hi_shift + q * std,
                         reason="" if np.isfinite(value) and np.isfinite(std)
                         else why or "no estimate")
    # Au's law speaks of output-only estimates: the first such estimator asked gives the record's
    # cycles and the length a precision needs
    au_name = next((n for n in names if ests[n].uncertainty in ("spread", "au")), None)
    au = out[au_name] if au_name is not None else None
    f_cyc = au.frequency if au is not None and np.isfinite(au.frequency) else f_mode
    result = RandomDamping(out, noise_input=noise[0], noise_output=noise[1],
                           duration_s=duration, n_cycles=duration * f_cyc,
                           confidence=confidence)
    if accuracy is not None:
        zeta = au.value if au is not None and np.isfinite(au.value) and au.value > 0 else (
            out[boot[0]].value if boot else nan)
        _warn_short(accuracy, zeta, au.frequency if au is not None
                    and np.isfinite(au.frequency) else f_mode, duration,
                    ests[au_name].efficiency if au is not None and au_name is not None
                    else OUTPUT_ONLY_EFFICIENCY)
    return result


#: Coherence at the resonance below which a random test does not excite the mode: the noise
#: there carries as much power as the mode's response.
MIN_COHERENCE: float = 0.5


def _unexcited(test: RandomTest) -> str:
    """``""`` if the record's input excites the mode near ``test.f1``, else why not.

    The coherence at the peak of ``|H1|`` within ``f1 -/+ 5 %`` (median over its 5 lines) must
    reach :data:`MIN_COHERENCE`; from ``n_d`` Welch segments the coherence of noise alone is
    about ``1 / n_d`` (0.17 for 120 s at 500 Hz and 16384-sample segments).
    """
    f, h, coh = test.h1
    near = np.flatnonzero(np.abs(f - test.f1) <= 0.05 * test.f1)
    if near.size == 0:
        return f"no frequency line within 5 % of {test.f1:.4g} Hz"
    k = int(near[np.argmax(np.abs(h[near]))])
    c = float(np.median(coh[max(0, k - 2):k + 3]))
    if c >= MIN_COHERENCE:
        return ""
    return (f"low coherence at the mode: {c:.2f} at {f[k]:.4g} Hz (the peak of |H1| within 5 % "
            f"of {test.f1:.4g} Hz), below {MIN_COHERENCE:g}: the input does not excite the mode "
            "above the noise")


def _bootstrap_reason(r: DampingEstimate, zeta_model: float, value: float, std: float,
                      n_resamples: int) -> str:
    if r.reason:
        return r.reason
    if not np.isfinite(r.value):
        return "no estimate"
    if not np.isfinite(zeta_model):
        return "no damping ratio in (0, 0.5) to simulate: no bias correction, no interval"
    if not (np.isfinite(value) and np.isfinite(std)):
        return (f"fewer than half of the {n_resamples} simulated records gave an estimate: "
                "the record's estimate is not reproducible")
    return ""


@dataclass(frozen=True)
class RandomDamping:
    """First-mode damping of one random test by several estimators
    (:func:`estimate_random`).

    Attributes
    ----------
    estimates : dict
        Estimator name -> :class:`~sloshrom.beam.damping.estimators.DampingEstimate`, in the order
        asked.
    noise_input, noise_output : float
        Noise-to-signal ratios of the record (:func:`noise_ratios`), -; NaN without a
        bootstrap.
    duration_s : float
        Record length, s.
    n_cycles : float
        Record length in periods of the first mode, -.
    confidence : float
        Two-sided level of the intervals.
    """

    estimates: dict[str, DampingEstimate]
    noise_input: float
    noise_output: float
    duration_s: float
    n_cycles: float
    confidence: float = CONFIDENCE

    def to_dataset(self) -> xr.Dataset:
        """The result as a Dataset with dimension ``estimator`` (see :func:`damping_dataset`).
        """
        names = list(self.estimates)
        e = [self.estimates[n] for n in names]
        var: dict[str, tuple[Any, Any, dict[str, str]]] = {
            k: ("estimator", np.array([getattr(x, k) for x in e]), {"units": u})
            for k, u in _FIELDS.items()}
        var["reason"] = ("estimator", np.array([x.reason for x in e], dtype=object), {})
        var["note"] = ("estimator", np.array([x.note for x in e], dtype=object), {})
        var.update({k: ((), getattr(self, k), {"units": u}) for k, u in
                    (("noise_input", "1"), ("noise_output", "1"), ("duration_s", "s"),
                     ("n_cycles", "1"))})
        return xr.Dataset(var, coords={"estimator": names,
                                       "label": ("estimator", [label(n) for n in names])},
                          attrs={"confidence": self.confidence})

    def columns(self) -> dict[str, Any]:
        """The flat columns of Table 2 (the file contract of ``table2_mode1_damping.csv``:
        ``sloshrom.beam.damping.columns.table2_columns``)."""
        return table2_columns(self.to_dataset())


#: The per-estimator variables of a damping dataset and their units.
_FIELDS: dict[str, str] = {"value": "1", "std": "1", "low": "1", "high": "1", "frequency": "Hz",
                           "uncorrected": "1", "iqr": "1", "n_poles": "1"}


def damping_dataset(base: Any, tank: Any, fs: float, f1: float, **kw: Any) -> xr.Dataset:
    """:func:`estimate_random` as an xarray Dataset.

    Returns
    -------
    xarray.Dataset
        Dimension ``estimator`` (coordinates: the names, and ``label``); variables ``value``,
        ``std``, ``low``, ``high``, ``uncorrected``, ``iqr`` (damping ratio, -),
        ``frequency`` (Hz), ``n_poles``, ``reason`` (str, ``""`` where the value and its
        interval exist) and ``note`` (str, ``""`` unless a fallback attempt gave the value);
        scalars ``noise_input``, ``noise_output`` (-), ``duration_s`` (s),
        ``n_cycles`` (-); attribute ``confidence``.
    """
    return estimate_random(base, tank, fs, f1, **kw).to_dataset()


# -- the flat columns of Table 2 (a file contract: sloshrom.beam.damping.columns) -----------
def random_damping(base: Any, tank: Any, fs: float, f1: float, **kw: Any) -> dict[str, Any]:
    """:func:`estimate_random` as the flat columns of a Table 2 row
    (``sloshrom.beam.damping.columns.table2_columns``):
    ``lscf_h1``, ``lscf_output``, ``half_power`` (the bootstrapped ones bias-corrected),
    ``{est}_std``, ``{est}_low``, ``{est}_high``, the uncorrected values, ``frequency_h1``,
    ``frequency_output``, ``noise_input``, ``noise_output``, ``duration_s``, ``n_cycles``.
    Keyword arguments as :func:`estimate_random`."""
    return table2_columns(estimate_random(base, tank, fs, f1, **kw).to_dataset())


def mode1_damping_random(
    base: Any,
    tank: Any,
    fs: float,
    f1: float,
    rel_band: float = 0.5,
    nperseg: int = WELCH_SEGMENT,
    pol_order_high: int = 20,
) -> dict[str, float]:
    """The raw first-mode damping of a random response by paper Table 2's three estimators, no
    intervals, as flat columns.

    * ``lscf_h1``: LSCF on H1 = base -> tank acceleration (Welch, Hann, ``nperseg`` samples,
      50 % overlap), median over the stable-pole cluster (``analysis.lscf_cluster_damping``);
    * ``lscf_output``: output-only, LSCF on the half-spectrum of the tank acceleration with the
      exponential-window correction, cluster median (``analysis.output_only_damping``);
    * ``half_power``: half-power bandwidth of |H1|.

    Band ``f1 (1 -/+ rel_band)`` Hz. The default 16384 samples (33 s at 500 Hz, 0.03 Hz
    resolution) resolves a 1 % mode at 10 Hz (half-power bandwidth 0.2 Hz); the Hann window
    still biases the H1 estimate upward: +2.9 % at 16384, +4.3 % at 8192, +1.6 % at 32768
    (1 %, 10 Hz mode, 600 s records). Bias and scatter: ``benchmarks/damping_estimators.py``.

    Returns
    -------
    dict
        Damping ratios (-): ``lscf_h1``, ``lscf_output``, ``half_power``; their spreads over
        the stable-pole cluster ``lscf_h1_iqr``, ``lscf_output_iqr`` (-) and cluster sizes
        ``lscf_h1_n``, ``lscf_output_n``; frequencies ``frequency_h1``, ``frequency_output``
        (Hz). An estimator that finds no stable cluster gives NaN (and size 0); the reasons are
        in the estimates of ``registry.get_estimator(name).estimate``.
    """
    test = RandomTest(base, tank, fs, f1, rel_band=rel_band, nperseg=nperseg,
                      pol_order_high=pol_order_high)
    e = {n: get_estimator(n).estimate(test) for n in TABLE2}
    h1, out_only, hp = TABLE2
    return {h1: e[h1].value, out_only: e[out_only].value, hp: e[hp].value,
            **{column(n, "frequency"): e[n].frequency for n in (h1, out_only)},
            **{column(n, "iqr"): e[n].iqr for n in (h1, out_only)},
            **{column(n, "n_poles"): e[n].n_poles for n in (h1, out_only)}}


def _warn_short(accuracy: float, zeta: float, frequency: float, duration: float,
                efficiency: float = OUTPUT_ONLY_EFFICIENCY) -> None:
    if not accuracy > 0:
        raise BeamError(f"accuracy must be positive, got {accuracy}")
    if not (np.isfinite(zeta) and zeta > 0 and np.isfinite(frequency)):
        return
    cov = efficiency * au_damping_cov(zeta, frequency, duration)
    if cov > accuracy:
        need = required_duration(zeta, frequency, accuracy / efficiency)
        warnings.warn(
            f"a {duration:.0f} s random record of a {100 * zeta:.2g} % mode at "
            f"{frequency:.3g} Hz gives ±{100 * cov:.0f} % (1 sigma) on the damping ratio; "
            f"±{100 * accuracy:.0f} % needs {need:.0f} s", ShortRecordWarning, stacklevel=3)
