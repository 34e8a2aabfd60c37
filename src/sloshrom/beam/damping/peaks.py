"""The modes of a measured test, found from its data: peak picking on the H1 of a random test
or on the output spectrum of a free decay, and the analysis band of each mode.

* :func:`find_modes` - the resonances of one record (:class:`FoundMode`: frequency, prominence,
  coherence, how it was found); :func:`station_modes` - those of every station of a test,
  each confirmed by other stations (an antiresonance of one channel is no mode).
* :func:`common_modes` - the modes that the records of one test (its levels) share.
* :func:`mode_bands` - each mode's analysis band, between its neighbours and below Nyquist.
* :func:`given_modes` - modes named by the user (``--f1``, ``--frequencies``).

A laboratory's beam is not the paper's: its first frequency, and the modes in the tested band,
come from the data rather than from a built-in model. Pure functions on arrays.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from scipy import signal

from sloshrom.beam.damping.analysis import FLOOR_PERCENTILE, AnalysisError

__all__ = [
    "FLOOR_PERCENTILE", "FREQUENCY_RESOLUTION", "MIN_COHERENCE", "MIN_PROMINENCE_DB",
    "FoundMode", "band_maximum", "common_modes", "find_modes", "given_modes", "mode_bands",
    "station_modes",
]

#: A resonance must stand this far (dB) above the spectrum on both sides of it (scipy's
#: prominence of the smoothed log spectrum): a 1 % mode stands about 30 dB above its
#: neighbourhood, the scatter of a Welch estimate from ten segments about 2 dB.
MIN_PROMINENCE_DB = 10.0
#: Coherence of H1 at a random test's resonance: below it the peak is noise, not a mode the
#: base excites.
MIN_COHERENCE = 0.5
#: Target spectral resolution of the search, Hz (the Welch segment is the power of two that
#: gives it, or the record's length / 8).
FREQUENCY_RESOLUTION = 0.05
# A decay's mode must stand MIN_PROMINENCE_DB above the noise floor of its spectrum
# (analysis.FLOOR_PERCENTILE): a fast-decaying mode stands 10-16 dB above the median and was
# lost at 20 dB above it.


@dataclass(frozen=True)
class FoundMode:
    """One resonance of a test.

    Attributes
    ----------
    frequency : float
        Peak frequency, Hz.
    prominence_db : float
        Height above the spectrum on both sides, dB (NaN for a given mode).
    coherence : float
        H1 coherence at the peak (NaN for an output spectrum or a given mode).
    source : str
        How it was found: ``"H1 peak"``, ``"output spectrum peak"``, ``"given"``.
    """

    frequency: float
    prominence_db: float = float("nan")
    coherence: float = float("nan")
    source: str = "given"


def _nperseg(n: int, fs: float) -> int:
    want = 2 ** math.ceil(math.log2(fs / FREQUENCY_RESOLUTION))
    return int(max(min(want, 2 ** int(math.log2(max(n // 8, 16)))), 16))


def find_modes(response: Sequence[float] | np.ndarray, fs: float,
               base: Sequence[float] | np.ndarray | None = None, *,
               f_range: tuple[float, float] | None = None,
               min_prominence_db: float = MIN_PROMINENCE_DB,
               min_coherence: float = MIN_COHERENCE) -> list[FoundMode]:
    """The resonances of one record, lowest first.

    With ``base`` (a random test): peaks of ``|H1|`` (base -> response, Welch, Hann, segments
    for :data:`FREQUENCY_RESOLUTION` or an eighth of the record) where the coherence is at
    least ``min_coherence``. Without (a free decay): peaks of the response's Welch spectrum
    (segments of half of the record) that stand ``min_prominence_db`` above its noise floor
    (the :data:`FLOOR_PERCENTILE` percentile of the band's lines), each located on the whole
    record's periodogram (Hann, zero-padded four times). The log spectrum is smoothed over 5
    lines (3 for a decay: a Welch estimate's scatter) before the peaks are picked; a peak must
    stand ``min_prominence_db`` above its surroundings.

    Parameters
    ----------
    response : array (n,)
        The response (e.g. the tank or tip acceleration), any unit.
    fs : float
        Sample rate, Hz.
    base : array (n,), optional
        Base acceleration of a random test.
    f_range : (float, float), optional
        Search band, Hz; default from 2 lines (and 0.5 Hz) to 0.9 Nyquist.
    min_prominence_db, min_coherence : float
        See :data:`MIN_PROMINENCE_DB`, :data:`MIN_COHERENCE`.

    Returns
    -------
    list of FoundMode
        Possibly empty.
    """
    y = np.asarray(response, dtype=float)
    if y.ndim != 1 or y.size < 64:
        raise AnalysisError("a mode search needs a 1-D record of at least 64 samples")
    nper = _nperseg(y.size, fs)
    kw = dict(fs=fs, window="hann", nperseg=nper, noverlap=nper // 2)
    if base is not None:
        x = np.asarray(base, dtype=float)
        f, sxx = signal.welch(x, **kw)
        _, sxy = signal.csd(x, y, **kw)
        _, coh = signal.coherence(x, y, **kw)
        with np.errstate(divide="ignore", invalid="ignore"):
            mag = np.abs(sxy / sxx)
        source = "H1 peak"
    else:
        # a decay is short: segments of half of it (three averages tame the scatter of the
        # noise floor); each peak is then located on the whole record's periodogram
        nper = max(2 ** int(math.log2(max(y.size // 2, 64))), 64)
        f, mag = signal.welch(y - y.mean(), fs=fs, window="hann", nperseg=nper,
                              noverlap=nper // 2)
        mag = np.sqrt(mag)
        coh = np.full(f.size, np.nan)
        source = "output spectrum peak"
    lo, hi = f_range if f_range is not None else (max(2 * fs / nper, 0.5), 0.9 * fs / 2)
    with np.errstate(divide="ignore", invalid="ignore"):
        db = 20 * np.log10(mag)
    db[~np.isfinite(db)] = np.nan
    floor = np.nanmin(db) if np.isfinite(db).any() else 0.0
    db = np.nan_to_num(db, nan=floor)
    # a random test's H1 has many lines to smooth; a short decay's spectrum has few
    w = 5 if base is not None else 3
    smooth = np.convolve(db, np.ones(w) / w, mode="same")
    peaks, props = signal.find_peaks(smooth, prominence=min_prominence_db)
    # a decay's resonance also stands above the noise floor
    in_range = (f >= lo) & (f <= hi)
    high = float(np.percentile(smooth[in_range] if in_range.any() else smooth,
                               FLOOR_PERCENTILE)) + min_prominence_db
    fine = None
    out = []
    for p, prom in zip(peaks, props["prominences"], strict=True):
        if not lo <= f[p] <= hi:
            continue
        # the unsmoothed maximum near the smoothed peak is the resonance
        j = p - 2 + int(np.argmax(db[max(p - 2, 0):p + 3]))
        c = float(coh[j])
        if base is not None and not c >= min_coherence:
            continue
        fj = float(f[j])
        if base is None:
            if db[j] < high:
                continue
            if fine is None:  # the whole record, zero-padded: the decay's peak between lines
                fine = signal.periodogram(y - y.mean(), fs=fs, window="hann",
                                          nfft=min(4 * y.size, 2**22))
            near = np.abs(fine[0] - fj) <= 1.5 * fs / nper
            fj = float(fine[0][near][np.argmax(fine[1][near])])
        out.append(FoundMode(fj, float(prom), c, source))
    return out


def station_modes(stations: np.ndarray, fs: float, base: np.ndarray | None = None, *,
                  min_stations: int = 2, rel_tol: float = 0.01) -> list[FoundMode]:
    """The resonances of a test's stations, lowest first: :func:`find_modes` of each station
    (``stations``: ``(n, n_stations)``; with ``base``, a random test's H1 of each), the peaks
    within ``rel_tol`` (or two lines) of one another one mode, kept when at least
    ``min_stations`` stations (all of them, if fewer) show it.

    Why more than one station: a channel's antiresonance is its own (the other stations' lie
    elsewhere), and in it the noise of H1 can raise a peak that stands 10 dB above its
    surroundings; a mode shows at every station but its nodes. And a mode that one channel
    barely shows (two close modes of opposite signs there, a node) stands out at others.

    Returns
    -------
    list of FoundMode
        Frequency: that of the station with the most prominent peak; prominence and coherence
        that station's.
    """
    y = np.atleast_2d(np.asarray(stations, dtype=float).T).T  # (n, n_stations)
    peaks = sorted(((m, k) for k in range(y.shape[1]) for m in find_modes(y[:, k], fs, base)),
                   key=lambda mk: mk[0].frequency)
    line = fs / _nperseg(y.shape[0], fs)
    groups: list[list[tuple[FoundMode, int]]] = []
    for m, k in peaks:
        g = groups[-1] if groups else None
        if g is not None and m.frequency - g[-1][0].frequency <= max(rel_tol * m.frequency,
                                                                       2 * line):
            g.append((m, k))
        else:
            groups.append([(m, k)])
    need = min(min_stations, y.shape[1])
    return [max((m for m, _ in g), key=lambda m: m.prominence_db) for g in groups
            if len({k for _, k in g}) >= need]


def band_maximum(response: Sequence[float] | np.ndarray, fs: float, band: tuple[float, float],
                 base: Sequence[float] | np.ndarray | None = None
                 ) -> tuple[float, float, float] | None:
    """Where the response's spectrum is largest in ``band`` (Hz), and where over the whole
    spectrum (up to 0.9 Nyquist): a resonance in the band has its maximum inside it, a band
    beside a resonance at the edge nearest it.

    The spectrum is that :func:`find_modes` searches: ``|H1|`` (base -> response, Welch) of a
    random test (with ``base``, each row a level, their mean in dB), the whole record's
    periodogram (Hann, zero-padded four times) of a free decay.

    Parameters
    ----------
    response : array (n,) or (n_levels, n)
        The response (e.g. the tank acceleration relative to the base), any unit.
    fs : float
        Sample rate, Hz.
    band : (float, float)
        The band, Hz.
    base : array like ``response``, optional
        Base acceleration of a random test.

    Returns
    -------
    (float, float, float) or None
        The frequencies (Hz) of the band's maximum and of the spectrum's, and the spacing of
        its lines (Hz); ``None`` when the band holds fewer than 3 lines of the spectrum (its
        shape cannot tell).
    """
    y = np.atleast_2d(np.asarray(response, dtype=float))
    if base is not None:
        x = np.atleast_2d(np.asarray(base, dtype=float))
        nper = _nperseg(y.shape[-1], fs)
        kw = dict(fs=fs, window="hann", nperseg=nper, noverlap=nper // 2)
        f, sxx = signal.welch(x, **kw)
        _, sxy = signal.csd(x, y, **kw)
        with np.errstate(divide="ignore", invalid="ignore"):
            db = np.nanmean(20 * np.log10(np.abs(sxy / sxx)), axis=0)
    else:
        z = y[0] - y[0].mean()
        f, p = signal.periodogram(z, fs=fs, window="hann", nfft=min(4 * z.size, 2**22))
        with np.errstate(divide="ignore"):
            db = 10 * np.log10(p)
    db = np.where(np.isfinite(db), db, -np.inf)
    inside = np.flatnonzero((f >= band[0]) & (f <= band[1]))
    search = np.flatnonzero((f > 0) & (f <= 0.9 * fs / 2))
    if inside.size < 3 or search.size == 0:
        return None
    return (float(f[inside[np.argmax(db[inside])]]), float(f[search[np.argmax(db[search])]]),
            float(f[1] - f[0]))


def common_modes(per_record: Sequence[Sequence[FoundMode]], rel_tol: float = 0.1,
                 share: float = 0.5) -> list[FoundMode]:
    """The modes that at least ``share`` of a test's records (its levels) show, lowest first
    (``share`` 0: every mode any record shows, e.g. the modes of a campaign's tests).

    Peaks within ``rel_tol`` of each other are one mode (a mode moves with the level when the
    structure is nonlinear); its frequency is the median over the records that show it, its
    prominence and coherence the smallest.
    """
    groups: list[list[FoundMode]] = []
    for modes in per_record:
        for m in modes:
            g = next((g for g in groups
                      if abs(m.frequency / np.median([x.frequency for x in g]) - 1) <= rel_tol),
                     None)
            if g is None:
                groups.append([m])
            else:
                g.append(m)
    need = max(1, math.ceil(share * len(per_record)))
    out = [FoundMode(float(np.median([m.frequency for m in g])),
                     float(min(m.prominence_db for m in g)),
                     float(min(m.coherence for m in g)), g[0].source)
           for g in groups if len(g) >= need]
    return sorted(out, key=lambda m: m.frequency)


def given_modes(frequencies: Sequence[float]) -> list[FoundMode]:
    """Modes named by the user, Hz (positive, distinct), lowest first."""
    fr = sorted(float(v) for v in frequencies)
    if not fr or not all(math.isfinite(v) and v > 0 for v in fr):
        raise AnalysisError(f"mode frequencies must be positive numbers of Hz, got {fr}")
    if len(set(fr)) != len(fr):
        raise AnalysisError(f"mode frequencies {fr} Hz are not distinct")
    return [FoundMode(v) for v in fr]


def mode_bands(frequencies: Sequence[float], fs: float, rel_band: float = 0.5
               ) -> list[tuple[float, float]]:
    """Each mode's analysis band, Hz: ``f (1 -/+ rel_band)``, cut at the geometric mean with
    each neighbour (so that no band holds two modes) and at 0.9 Nyquist.

    Raises
    ------
    AnalysisError
        A mode at or above 0.9 Nyquist (its band would be empty).
    """
    fr = [float(v) for v in frequencies]
    out = []
    top = 0.9 * fs / 2
    for k, f in enumerate(fr):
        if not f < top:
            raise AnalysisError(f"the mode at {f:.4g} Hz is too close to the Nyquist frequency "
                                f"({fs / 2:g} Hz) to analyse: its band must stay below "
                                f"{top:g} Hz")
        lo, hi = f * (1 - rel_band), min(f * (1 + rel_band), top)
        if k > 0:
            lo = max(lo, math.sqrt(fr[k - 1] * f))
        if k + 1 < len(fr):
            hi = min(hi, math.sqrt(f * fr[k + 1]))
        out.append((lo, hi))
    return out
