"""Excitation signals: harmonic tests, variable-frequency-amplitude (VFA) paths, random base input.

Functions take the sample rate ``fs`` (Hz) and return plain arrays, in the style of
``scipy.signal``. Displacement w is positive up; all quantities SI.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Harmonic:
    """A ramped harmonic motion ``w = a r(t) cos(Omega t)`` sampled at ``fs``.

    Attributes
    ----------
    time, displacement, velocity, acceleration : ndarray
        s, m, m/s, m/s^2 (exact derivatives of the ramped displacement).
    steady : slice
        Samples of the whole steady cycles (ramps excluded), for per-cycle energy.
    frequency : float
        Hz.
    amplitude : float
        Displacement amplitude a, m.
    """

    time: np.ndarray
    displacement: np.ndarray
    velocity: np.ndarray
    acceleration: np.ndarray
    steady: slice
    frequency: float
    amplitude: float


def _ramp(t: np.ndarray, t_up: float, t_total: float) -> tuple[np.ndarray, ...]:
    """Raised-cosine ramp r(t) in [0, t_up] and out over the last t_up, with r', r''."""
    r = np.ones_like(t)
    dr = np.zeros_like(t)
    ddr = np.zeros_like(t)
    if t_up <= 0:
        return r, dr, ddr
    k = np.pi / t_up
    up = t < t_up
    down = t > t_total - t_up
    for mask, tau, sign in ((up, t, 1.0), (down, t_total - t, -1.0)):
        x = k * tau[mask]
        r[mask] = 0.5 * (1.0 - np.cos(x))
        dr[mask] = sign * 0.5 * k * np.sin(x)
        ddr[mask] = 0.5 * k * k * np.cos(x)
    return r, dr, ddr


def harmonic(
    fs: float,
    frequency: float,
    amplitude: float,
    n_cycles: int = 10,
    n_ramp: int = 3,
    n_settle: int = 2,
) -> Harmonic:
    """Ramped harmonic tank motion ``w(t) = a r(t) cos(2 pi f t)``.

    The motion ramps in over ``n_ramp`` cycles (raised cosine), holds ``n_settle`` cycles for the
    transient to die, then ``n_cycles`` steady cycles (the ones to evaluate), then ramps out.

    Parameters
    ----------
    fs : float
        Sample rate, Hz.
    frequency : float
        Excitation frequency f = Omega / 2 pi, Hz.
    amplitude : float
        Displacement amplitude a, m.
    n_cycles : int
        Steady cycles to evaluate.
    n_ramp, n_settle : int
        Cycles of ramp (each end) and of settling before the evaluated cycles.

    Returns
    -------
    Harmonic
    """
    if not (fs > 0 and frequency > 0 and np.isfinite(fs) and np.isfinite(frequency)):
        raise ValueError(f"fs and frequency must be positive, got fs={fs!r}, f={frequency!r}")
    if not (amplitude >= 0 and np.isfinite(amplitude)):
        raise ValueError(f"amplitude must be a finite non-negative length in m, got {amplitude!r}")
    if fs < 8 * frequency:
        raise ValueError(f"fs={fs} Hz is too low for f={frequency} Hz (need >= 8 samples/cycle)")
    if n_cycles < 1 or n_ramp < 0 or n_settle < 0:
        raise ValueError("n_cycles must be >= 1 and n_ramp, n_settle >= 0")
    period = 1.0 / frequency
    t_up = n_ramp * period
    t_total = (2 * n_ramp + n_settle + n_cycles) * period
    n = int(round(t_total * fs)) + 1
    t = np.arange(n) / fs
    om = 2.0 * np.pi * frequency
    r, dr, ddr = _ramp(t, t_up, t_total)
    c, s = np.cos(om * t), np.sin(om * t)
    w = amplitude * r * c
    v = amplitude * (dr * c - om * r * s)
    acc = amplitude * (ddr * c - 2.0 * om * dr * s - om * om * r * c)
    i0 = int(round((n_ramp + n_settle) * period * fs))
    i1 = int(round((n_ramp + n_settle + n_cycles) * period * fs))
    return Harmonic(t, w, v, acc, slice(i0, i1), float(frequency), float(amplitude))
