"""Uncertainty of the first-mode damping estimates of the beam tests: every damping ratio with
its standard deviation and confidence interval.

* :func:`au_damping_cov`, :func:`required_duration` - Au's uncertainty law of output-only
  (ambient) damping identification and its inverse (the record length a precision needs).
* :func:`band_damping` - free decays: Hilbert and log-decrement damping per amplitude band,
  with intervals.
* :func:`random_damping` - random tests (paper Table 2): the estimators of
  :func:`sloshrom.beam.analysis.mode1_damping_random`, the bias of the H1 estimators removed
  (parametric bootstrap), each with a standard deviation and an interval.
* :func:`noise_ratios` - the input and output noise of a random test, from its coherence.

Pure numerical functions: arrays in, dicts out. Intervals are two-sided at ``confidence``
(default :data:`CONFIDENCE`); NaN where an estimate or its spread cannot be formed.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
from scipy import fft, optimize, signal, stats
from scipy.signal import get_window
from threadpoolctl import threadpool_limits

from sloshrom.beam.analysis import (
    AnalysisError,
    frf_h1,
    half_power_damping,
    lscf_cluster_damping,
    lscf_poles_batch,
    output_only_damping,
    stable_pole_cluster,
    welch_psd,
)
from sloshrom.beam.errors import BeamError
from sloshrom.config import G

__all__ = [
    "BANDS", "CONFIDENCE", "OUTPUT_ONLY_EFFICIENCY", "ShortRecordWarning", "au_damping_cov",
    "band_damping", "noise_ratios", "random_damping", "required_duration",
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
      Each ``zeta(t)`` is a regression slope of ``ln A`` over the smoothing window ``W``
      (``smooth_periods`` periods); over a band of length ``L`` their mean is about the slope
      between the band's ends, whose variance is ``W^2 / (6 L^2)`` times that of one sample
      (noise on ``ln A`` correlated over less than ``W``). Standard error ``1.2533 s W /
      (sqrt(6) L)`` (``s`` the samples' standard deviation, 1.2533 the median's efficiency),
      interval from Student's t with ``L / W + 1`` degrees of freedom; for ``L < W`` the
      median without an interval.
    * ``log_decrement``: least-squares slope ``-sigma`` of ``ln(peak)`` against time over the
      peaks in the band, ``zeta = sigma / sqrt(omega_d^2 + sigma^2)`` with ``omega_d`` from the
      median peak spacing; standard error of the slope, its variance inflated by ``(1 + rho) /
      (1 - rho)`` (``rho`` the lag-one correlation of the residuals, corrected for its small-sample
      bias ``-(1 + 3 rho) / n`` and clipped to [0, 0.9]: neighbouring peaks share band-passed
      noise), Student's t with ``n_peaks - 2`` degrees of
      freedom.

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
        Factor from the amplitude's unit to g (default: amplitudes in m/s^2).
    bands : sequence of (float, float)
        Amplitude bands ``[low, high)``, g.
    confidence : float
        Two-sided confidence level of the intervals.
    smooth_periods : float
        The smoothing window of ``instantaneous_damping``, periods.

    Returns
    -------
    list of dict
        One row per band and method (Hilbert first): ``band`` (e.g. ``"1-2 g"``), ``method``
        (``"hilbert"`` or ``"log_decrement"``), ``zeta``, ``std``, ``low``, ``high`` (damping
        ratio, -) and ``n_cycles`` (cycles of the band, -). A Hilbert band shorter than one
        smoothing window keeps its median (as :func:`sloshrom.beam.results.damping_by_band`,
        more than 10 samples) with NaN ``std``/``low``/``high``: no interval; NaN throughout
        where the band has too little data (10 samples or fewer, fewer than 3 peaks).
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
        name = f"{lo:g}-{hi:g} g"
        sel = (ah >= lo) & (ah < hi)
        n_cyc = float(np.count_nonzero(sel) * dt * np.median(fh[sel])) if sel.any() else 0.0
        span = n_cyc / smooth_periods  # band length in smoothing windows
        if span >= 1 and np.isfinite(dt):
            z = float(np.median(zh[sel]))
            # zeta(t) is a regression slope over the window W: over a band of length L their
            # mean is about the slope between the band's two ends, of variance W^2 / (6 L^2)
            # times a single slope's (white or short-correlated noise on ln A)
            std = 1.2533 * float(np.std(zh[sel], ddof=1)) / math.sqrt(max(1.0, 6 * span**2))
            half = _t(confidence, span + 1) * std
            rows.append(_row(name, "hilbert", z, std, half, n_cyc))
        elif np.count_nonzero(sel) > 10:
            # shorter than one smoothing window: the samples are one estimate, with no
            # independent values to state its scatter (the median of damping_by_band)
            rows.append(_row(name, "hilbert", float(np.median(zh[sel])), nan, nan, n_cyc))
        else:
            rows.append(_row(name, "hilbert", nan, nan, nan, n_cyc))
        sp = (ap >= lo) & (ap < hi)
        t, y = tp[sp], lp[sp]
        if t.size >= 3:
            fit = stats.linregress(t, y)
            sigma = -fit.slope
            wd = 2 * math.pi / float(np.median(np.diff(t)))
            z = sigma / math.hypot(wd, sigma)
            # neighbouring peaks share band-passed noise: inflate the slope's standard error
            # as for AR(1) residuals, (1 + rho) / (1 - rho) on the variance
            res = y - (fit.intercept + fit.slope * t)
            rho = np.sum(res[1:] * res[:-1]) / max(np.sum(res**2), 1e-300)
            # the lag-one correlation of a few residuals is biased low by about (1 + 3 rho) / n
            rho = float(np.clip(rho + (1 + 3 * rho) / t.size, 0, 0.9))
            std = fit.stderr / wd * math.sqrt((1 + rho) / (1 - rho))
            n_cyc_p = (t[-1] - t[0]) * wd / (2 * math.pi)
            half = _t(confidence, t.size - 2) * std
            rows.append(_row(name, "log_decrement", z, std, half, n_cyc_p))
        else:
            rows.append(_row(name, "log_decrement", nan, nan, nan, max(t.size - 1, 0)))
    return rows


# -- random tests: a parametric bootstrap of the H1 estimators -------------------------------------
def _h1(base: np.ndarray, tank: np.ndarray, fs: float, nperseg: int,
        window: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    # frf_h1 (Hann, 50 % overlap, constant detrend) on one pass over the segments, of one record
    # (n,) or of a stack of them (n_records, n): the bootstrap computes hundreds of them
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


def noise_ratios(f: np.ndarray, h: np.ndarray, coh: np.ndarray, leakage: np.ndarray,
                 sxx: np.ndarray, frequency: float, zeta: float,
                 band: tuple[float, float]) -> tuple[float, float]:
    """Input and output noise of a random test, from the part of its incoherence that the
    mode's leakage does not explain.

    With white noise on both channels, ``1/coh - 1 = n_u + N_y / (|H|^2 S_xx) + c L`` (``n_u``
    the input's noise-to-signal ratio, ``N_y`` the output noise PSD, ``L`` the incoherence of
    noise-free records of the fitted mode - the window's leakage and the bias of a coherence
    from few segments -, ``c`` near 1); the three are fitted by non-negative least squares,
    each line weighted by ``1 / (L + median(1/coh - 1))`` and ``S_xx`` taken as flat (its
    median over the band), on the lines of ``band`` more than one
    half-power bandwidth from the resonance.

    Parameters
    ----------
    f, h, coh, sxx : array (n_f,)
        Frequencies (Hz), H1, coherence and input PSD of the record.
    leakage : array (n_f,)
        ``1/coh - 1`` of noise-free simulated records of the fitted mode, averaged.
    frequency, zeta : float
        The mode (Hz, -).
    band : (float, float)
        Fitting band, Hz.

    Returns
    -------
    (float, float)
        ``n_u`` (-) and the output noise-to-signal ratio at the resonance ``N_y / (|H(f_n)|^2
        S_xx(f_n))`` (-).
    """
    with np.errstate(divide="ignore", invalid="ignore"):
        r = 1 / coh - 1
    sel = ((f >= band[0]) & (f <= band[1]) & np.isfinite(r) & np.isfinite(leakage)
           & (np.abs(f - frequency) > 2 * zeta * frequency))
    if np.count_nonzero(sel) < 6:
        return 0.0, 0.0
    # the input PSD as flat over the band (white or smooth excitation): its estimate from a few
    # segments scatters from line to line far more than the input does
    s_in = float(np.median(sxx[sel]))
    g = np.abs(h[sel]) ** 2 * s_in
    lk = np.clip(leakage[sel], 0, None)
    w = 1 / (lk + np.median(r[sel]) + 1e-12)
    a = np.stack([np.ones(g.size), 1 / g, lk], axis=1) * w[:, None]
    scale = np.linalg.norm(a, axis=0)
    scale[scale == 0] = 1.0
    x, _ = optimize.nnls(a / scale, r[sel] * w)
    n_u, n_y = x[0] / scale[0], x[1] / scale[1]
    i = int(np.argmin(np.abs(f - frequency)))
    return float(n_u), float(n_y / (np.abs(h[i]) ** 2 * s_in))


def _simulate(frequency: float, zeta: float, fs: float, n: int, n_records: int,
              noise: tuple[float, float], rng: np.random.Generator
              ) -> tuple[np.ndarray, np.ndarray]:
    # the fitted mode as a base-excited oscillator (base -> absolute acceleration), exact
    # zero-order-hold discretisation, white input; start-up of 20 time constants discarded
    wn = 2 * math.pi * frequency
    b, a, _ = signal.cont2discrete(([2 * zeta * wn, wn**2], [1, 2 * zeta * wn, wn**2]),
                                   1 / fs, method="zoh")
    n0 = int(min(20 / (zeta * wn), 60.0) * fs)
    u = rng.standard_normal((n_records, n + n0))
    y = signal.lfilter(np.ravel(b), a, u, axis=1)[:, n0:]
    u = u[:, n0:]
    gain = 1 / abs(signal.freqz(np.ravel(b), a, worN=[frequency], fs=fs)[1][0])
    n_u, n_y = noise
    u = u + math.sqrt(n_u) * rng.standard_normal(u.shape)
    y = y + math.sqrt(n_y) / gain * rng.standard_normal(y.shape)
    return u, y


# BLAS on one thread: the bootstrap's LSCF fits are small (a QR of ~700 x 82) and many; on a
# loaded machine a multithreaded BLAS made each one up to ten times slower than on one thread
@threadpool_limits.wrap(limits=1, user_api="blas")
def random_damping(
    base: Any,
    tank: Any,
    fs: float,
    f1: float,
    *,
    confidence: float = CONFIDENCE,
    n_resamples: int = 40,
    seed: int = 0,
    accuracy: float | None = None,
    rel_band: float = 0.5,
    nperseg: int = 16384,
) -> dict[str, Any]:
    """First-mode damping of a random test (paper Table 2) with standard deviations and
    intervals.

    * ``lscf_h1`` and ``half_power`` (estimates on the Welch H1): a parametric bootstrap.
      ``n_resamples`` records of the record's length are simulated from the fitted mode (a
      base-excited oscillator with the estimated frequency and damping, white input) with the
      record's input and output noise (:func:`noise_ratios`), and analysed as the record was.
      Their mean minus the simulated damping is the estimator's bias (the Welch window's
      leakage, and the equation-error bias that noise causes); it is removed, and the
      simulation repeated once around the corrected damping. ``std`` is the standard
      deviation of the simulated estimates, the interval ``zeta +/- t std`` (Student's ``t``
      with ``n_resamples - 1`` degrees of freedom). The raw values are kept as
      ``lscf_h1_uncorrected`` and ``half_power_uncorrected``.
    * ``lscf_output`` (output-only): ``std = OUTPUT_ONLY_EFFICIENCY * zeta * au_damping_cov(
      zeta, frequency, duration)`` (Au's law times the estimator's measured efficiency),
      interval ``zeta +/- z std``; no bias correction.

    Parameters
    ----------
    base, tank : array (n,)
        Base and tank accelerations, same unit.
    fs, f1 : float
        Sampling frequency and approximate first-mode frequency, Hz.
    confidence : float
        Two-sided confidence level of the intervals.
    n_resamples : int
        Simulated records per bootstrap round (two rounds; each record one LSCF fit).
    seed : int
        Seed of the simulations.
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
        ``half_power`` bias-corrected; ``lscf_h1_uncorrected``, ``half_power_uncorrected``;
        for ``est`` in (``lscf_h1``, ``lscf_output``, ``half_power``): ``{est}_std``,
        ``{est}_low``, ``{est}_high`` (damping ratio, -); ``noise_input``, ``noise_output``
        (the noise-to-signal ratios of :func:`noise_ratios`, -; NaN if no bootstrap was
        possible); ``duration_s`` (s), ``n_cycles`` (record length in periods of the first
        mode, -). Without a first H1 estimate, the H1 estimators and their spreads are NaN;
        so are the corrected values when fewer than half of the simulated records give an
        estimate (the record's estimate is not reproducible: e.g. a 34 s record at 500 Hz,
        one Welch segment of 16384 samples, lost the mode in half or more of them).
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

    window = get_window("hann", nseg)

    def estimates(u: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        # the estimates of records (n_records, n) as the record's, all at once: (n_records, 2)
        # (LSCF, half-power) and every record's incoherence 1/coh - 1
        fr, hr, coh = _h1(u, y, fs, nseg, window)
        est = np.full((hr.shape[0], 2), nan)
        for k, poles in enumerate(lscf_poles_batch(fr, hr, band)):
            est[k, 0] = stable_pole_cluster(poles, f1)["zeta"]
            try:
                est[k, 1] = half_power_damping(fr, hr[k], band)["zeta"]
            except AnalysisError:  # no clear peak in this record: the estimate is missing
                pass
        with np.errstate(divide="ignore"):
            return est, 1 / coh - 1

    # the raw values exactly as mode1_damping_random (frf_h1's H1; _h1 agrees to round-off)
    z_raw = float(r_h1["zeta"])
    try:
        hp_raw = half_power_damping(f, h, band)["zeta"]
    except AnalysisError:
        hp_raw = nan
    f_mode = r_h1["frequency"] if np.isfinite(r_h1["frequency"]) else f1
    duration = base.size / fs
    out: dict[str, Any] = {
        "lscf_h1": nan, "lscf_output": r_out["zeta"], "half_power": nan,
        "frequency_h1": r_h1["frequency"], "frequency_output": r_out["frequency"],
        "lscf_h1_iqr": r_h1["zeta_iqr"], "lscf_output_iqr": r_out["zeta_iqr"],
        "lscf_h1_n": r_h1["n_poles"], "lscf_output_n": r_out["n_poles"],
        "lscf_h1_uncorrected": z_raw, "half_power_uncorrected": hp_raw,
        "noise_input": nan, "noise_output": nan,
    }
    std = {"lscf_h1": nan, "half_power": nan}
    zeta_model = z_raw if np.isfinite(z_raw) and z_raw > 0 else hp_raw
    if np.isfinite(zeta_model) and 0 < zeta_model < 0.5:
        raw = np.array([z_raw, hp_raw])

        def bootstrap(noise: tuple[float, float]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
            # both rounds draw the same records (the noise after them): the result is
            # continuous in the estimated noise, which round-off may move off zero
            rng = np.random.default_rng(seed)
            u, y = _simulate(f_mode, zeta_model, fs, base.size, n_resamples, noise, rng)
            sims, incoherence = estimates(u, y)
            bias, spread = np.full(2, np.nan), np.full(2, np.nan)
            for c in range(2):
                v = sims[np.isfinite(sims[:, c]), c]
                if v.size >= max(2, n_resamples // 2):  # else the mode is mostly lost: no spread
                    bias[c], spread[c] = v.mean() - zeta_model, v.std(ddof=1)
            return bias, spread, np.mean(incoherence, axis=0)

        # round 1, noise-free: the leakage bias and the incoherence the leakage causes; the
        # rest of the record's incoherence is noise, which biases LSCF strongly (1 % RMS on the
        # input moved a 90 s estimate by -5 %): round 2 simulates it
        bias, spread, leak = bootstrap((0.0, 0.0))
        _, sxx = welch_psd(base, fs, nseg)
        noise = noise_ratios(f, h, coh, leak, sxx, f_mode, zeta_model, band)
        if max(noise) > 0:
            bias, spread, _ = bootstrap(noise)
        corrected = raw - bias
        out["lscf_h1"], out["half_power"] = float(corrected[0]), float(corrected[1])
        out["noise_input"], out["noise_output"] = noise
        std = {"lscf_h1": float(spread[0]), "half_power": float(spread[1])}
    # the spread is estimated from n_resamples records: Student's t, not the normal quantile
    t_boot = _t(confidence, n_resamples - 1)
    for est in ("lscf_h1", "half_power"):
        out.update({f"{est}_std": std[est], f"{est}_low": out[est] - t_boot * std[est],
                    f"{est}_high": out[est] + t_boot * std[est]})

    zo, fo = r_out["zeta"], r_out["frequency"]
    std_out = (OUTPUT_ONLY_EFFICIENCY * zo * au_damping_cov(zo, fo, duration)
               if np.isfinite(zo) and zo > 0 and np.isfinite(fo) else nan)
    out.update(lscf_output_std=std_out, lscf_output_low=zo - z * std_out,
               lscf_output_high=zo + z * std_out, duration_s=duration,
               n_cycles=duration * (fo if np.isfinite(fo) else f_mode))

    if accuracy is not None:
        _warn_short(accuracy, zo if np.isfinite(zo) and zo > 0 else out["lscf_h1"],
                    fo if np.isfinite(fo) else f_mode, duration)
    return out


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
