"""A laboratory beam of known modes and the tests a laboratory runs on it.

:class:`LabBeam` is a uniform clamped-free cantilever *without tank*, of given natural
frequencies and modal damping ratios, instrumented by accelerometers along its length.
:func:`random_test` shakes its base with band-limited, coloured random acceleration;
:func:`free_decay` releases a static tip deflection. Both return records as a laboratory would
store them: sampled at ``fs``, stationary (random) or starting at the release (decay), with
sensor noise. The modal damping is the truth the damping estimators are checked against.

Modal model
-----------
Relative displacement ``w(x, t) = sum_k psi_k(x) q_k(t)`` (up positive, ``x`` from the clamp)
with the base acceleration ``a_b(t)``::

    q_k'' + 2 zeta_k omega_k q_k' + omega_k^2 q_k = -Gamma_k a_b
    a(x, t) = a_b + sum_k psi_k(x) q_k''          (absolute acceleration)

``psi_k`` are the uniform clamped-free shapes normalised to a unit maximum (tip) displacement,
``Gamma_k = int psi_k dx / int psi_k^2 dx`` (uniform mass: the modal masses normalised to
one). Station FRF base -> absolute acceleration::

    H(x, omega) = 1 + sum_k psi_k(x) Gamma_k omega^2
                      / (omega_k^2 - omega^2 + 2 i zeta_k omega_k omega)

Pure numerics: arrays in, dicts of arrays out; accelerations in m/s^2, frequencies in Hz.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property
from typing import Any

import numpy as np
from numpy.typing import ArrayLike
from scipy import signal

from sloshrom.beam.errors import BeamError
from sloshrom.beam.simulation.structure import CantileverBeam
from sloshrom.config import G

__all__ = ["DEFAULT_BAND", "DEFAULT_TILT", "LabBeam", "base_input", "free_decay",
           "random_test"]

#: Default shaker band of :func:`random_test`, Hz: all three default modes (10.3, 64.1,
#: 180 Hz) excited, the upper edge below the 250 Hz Nyquist frequency of 500 Hz sampling.
DEFAULT_BAND: tuple[float, float] = (3.0, 220.0)
#: Default spectral tilt of the base acceleration, dB per octave (a shaker's acceleration PSD
#: is rarely flat: -3 dB/octave makes the input coloured across the band).
DEFAULT_TILT: float = -3.0


@dataclass(frozen=True)
class LabBeam:
    """A uniform clamped-free cantilever (no tank) of known modes, with accelerometers.

    Parameters
    ----------
    frequencies : tuple of float
        Natural frequencies, Hz (default: the uniform clamped-free ratios 1 : 6.27 : 17.5).
    damping : tuple of float
        Modal damping ratios, -.
    length : float
        Beam length, m.
    positions : tuple of float
        Accelerometer stations, m from the clamp (the last one at the tip by default).
    """

    frequencies: tuple[float, ...] = (10.3, 64.1, 180.0)
    damping: tuple[float, ...] = (0.0137, 0.0062, 0.0048)
    length: float = 1.0
    positions: tuple[float, ...] = (0.2, 0.4, 0.6, 0.8, 1.0)

    def __post_init__(self) -> None:
        f = np.asarray(self.frequencies, dtype=float)
        z = np.asarray(self.damping, dtype=float)
        if f.ndim != 1 or f.size == 0 or f.shape != z.shape:
            raise BeamError("frequencies and damping must be non-empty sequences of one length")
        if not (np.all(np.isfinite(f)) and np.all(f > 0) and np.all(np.diff(f) > 0)):
            raise BeamError(f"frequencies must be positive and increasing, got {self.frequencies}")
        if not (np.all(np.isfinite(z)) and np.all(z > 0) and np.all(z < 1)):
            raise BeamError(f"damping ratios must be in (0, 1), got {self.damping}")
        if not (math.isfinite(self.length) and self.length > 0):
            raise BeamError(f"length must be positive, got {self.length}")
        x = np.asarray(self.positions, dtype=float)
        if x.ndim != 1 or x.size == 0 or np.any(x < 0) or np.any(x > self.length):
            raise BeamError(f"positions must lie on the beam [0, {self.length}] m")

    @property
    def n_modes(self) -> int:
        """Number of modes."""
        return len(self.frequencies)

    @cached_property
    def _cantilever(self) -> CantileverBeam:
        # the shapes of a uniform clamped-free beam do not depend on its section or material
        return CantileverBeam(length=self.length)

    def shapes(self, x: ArrayLike | None = None) -> np.ndarray:
        """Mode shapes at ``x`` (m; default the stations), ``(n_x, n_modes)``, -: uniform
        clamped-free, unit maximum (tip) displacement, tip positive."""
        x = self.positions if x is None else x
        return self._cantilever.mode_shapes(x, self.n_modes)

    @cached_property
    def participation(self) -> np.ndarray:
        """Participation ``Gamma_k = int psi_k dx / int psi_k^2 dx`` of a vertical base
        translation (uniform mass, modal masses normalised to one), ``(n_modes,)``, -."""
        x = np.linspace(0.0, self.length, 4001)
        psi = self.shapes(x)
        w = np.full(x.size, x[1] - x[0])
        w[[0, -1]] *= 0.5  # trapezoid weights
        return (w @ psi) / (w @ psi**2)

    @property
    def omegas(self) -> np.ndarray:
        """Natural circular frequencies, rad/s."""
        return 2 * math.pi * np.asarray(self.frequencies, dtype=float)

    def frf(self, f: ArrayLike, x: ArrayLike | None = None) -> np.ndarray:
        """Analytical FRF base -> absolute acceleration at ``x`` (m; default the stations) at
        frequencies ``f`` (Hz), ``(n_f, n_x)``, complex, -."""
        w = 2 * math.pi * np.atleast_1d(np.asarray(f, dtype=float))[:, None]
        wk, zk = self.omegas, np.asarray(self.damping)
        modal = w**2 / (wk**2 - w**2 + 2j * zk * wk * w)  # (n_f, n_modes)
        return 1 + modal @ (self.shapes(x) * self.participation).T


def _response(beam: LabBeam, base: np.ndarray, fs: float) -> np.ndarray:
    """Absolute station accelerations under ``base`` (m/s^2, ``(n,)``), ``(n, n_stations)``:
    the base's spectrum times the beam's continuous FRF, line by line (the sampled response
    of the continuous beam to the band-limited input those samples define; the circular
    wrap-around is a start-up the caller discards). A zero-order-hold discretisation keeps the
    poles but not the residues: at 500 Hz sampling it put the 180 Hz mode's peak 20 % low."""
    f = np.fft.rfftfreq(base.size, 1 / fs)
    return np.fft.irfft(np.fft.rfft(base)[:, None] * beam.frf(f), base.size, axis=0)


def base_input(n: int, fs: float, band: tuple[float, float], tilt: float,
               rng: np.random.Generator) -> np.ndarray:
    """Band-limited, coloured random acceleration of unit RMS, ``(n,)``.

    Gaussian white noise tilted by ``tilt`` dB/octave (a gain ``f^(tilt / (20 log10 2))``
    applied to its spectrum, reference the band's geometric centre), then band-passed by a
    4th-order Butterworth filter (each edge rolls off at 24 dB/octave) over ``band`` (Hz).
    The filter's start-up is the caller's to discard.
    """
    lo, hi = band
    if not (0 < lo < hi < fs / 2):
        raise BeamError(f"band must satisfy 0 < low < high < fs/2 = {fs / 2:g} Hz, got {band}")
    u = rng.standard_normal(n)
    spec = np.fft.rfft(u)
    f = np.fft.rfftfreq(n, 1 / fs)
    f[0] = f[1]  # the DC line: any finite gain (the band-pass removes it)
    spec *= (f / math.sqrt(lo * hi)) ** (tilt / (20 * math.log10(2)))
    u = np.fft.irfft(spec, n)
    sos = signal.butter(4, [lo, hi], btype="bandpass", fs=fs, output="sos")
    u = signal.sosfilt(sos, u)
    return u / float(np.std(u))


def random_test(
    beam: LabBeam,
    rms_g: float,
    duration: float,
    fs: float = 500.0,
    *,
    band: tuple[float, float] = DEFAULT_BAND,
    tilt: float = DEFAULT_TILT,
    noise: float = 0.005,
    noise_g: float = 0.0,
    seed: int = 0,
) -> dict[str, Any]:
    """A random base-excitation test of ``beam``: stationary records of the base and stations.

    The base acceleration is Gaussian, coloured (``tilt`` dB/octave) and band-limited by a
    4th-order Butterworth band-pass over ``band`` (:func:`base_input`), scaled to ``rms_g``
    RMS. The default band, 3-220 Hz, excites the three default modes (10.3, 64.1, 180 Hz)
    below the 250 Hz Nyquist frequency of 500 Hz sampling; a band ending at 40 Hz (a
    laboratory's shaker) leaves mode 2 on the filter's roll-off and mode 3 below the noise.
    The stations' response is the base's spectrum times the continuous modal FRF
    (:meth:`LabBeam.frf`), exact for the band-limited input; a start-up of 20 time constants of
    the slowest-decaying mode (at most 60 s) plus 20 periods of the band's lower edge is
    simulated and discarded, so that the records are stationary. White sensor noise of
    ``noise`` times each channel's RMS is added to every channel, base included, and white
    noise of ``noise_g`` RMS (a sensor's own floor, the same at every level: the
    signal-to-noise ratio then grows with the level, as in a laboratory).

    Parameters
    ----------
    beam : LabBeam
        The beam.
    rms_g : float
        RMS of the base acceleration, g.
    duration : float
        Record length, s.
    fs : float
        Sampling frequency, Hz.
    band : (float, float)
        Shaker band, Hz (``0 < low < high < fs / 2``).
    tilt : float
        Spectral tilt of the base acceleration, dB/octave (0: flat in the band).
    noise : float
        Sensor noise RMS over each channel's RMS, -.
    noise_g : float
        Sensor noise RMS of every channel, g (independent of the level).
    seed : int
        Seed of the input and the noise.

    Returns
    -------
    dict
        ``time`` (s, ``(n,)``), ``fs`` (Hz), ``base`` (m/s^2, ``(n,)``), ``stations``
        (absolute accelerations, m/s^2, ``(n, n_stations)``), ``band`` (Hz), ``rms_g`` (g).
    """
    if not (rms_g > 0 and duration > 0 and fs > 0 and noise >= 0 and noise_g >= 0):
        raise BeamError("rms_g, duration and fs must be positive, noise and noise_g "
                        "non-negative")
    n = int(round(duration * fs))
    if n < 16:
        raise BeamError(f"a {duration:g} s record at {fs:g} Hz has fewer than 16 samples")
    rng = np.random.default_rng(seed)
    # start-up: 20 time constants of the slowest-decaying mode, plus the band-pass's own
    sigma = np.asarray(beam.damping) * beam.omegas
    n0 = int(min(20 / float(sigma.min()), 60.0) * fs) + int(20 * fs / band[0])
    u = base_input(n0 + n, fs, band, tilt, rng)
    u *= rms_g * G / float(np.std(u[n0:]))
    y = _response(beam, u, fs)
    u, y = u[n0:], y[n0:]
    u = u + noise * float(np.std(u)) * rng.standard_normal(u.shape)
    y = y + noise * np.std(y, axis=0) * rng.standard_normal(y.shape)
    if noise_g > 0:  # drawn after the proportional noise: records without it are unchanged
        u = u + noise_g * G * rng.standard_normal(u.shape)
        y = y + noise_g * G * rng.standard_normal(y.shape)
    return {"time": np.arange(n) / fs, "fs": float(fs), "base": u, "stations": y,
            "band": (float(band[0]), float(band[1])), "rms_g": float(rms_g)}


def free_decay(
    beam: LabBeam,
    peak_g: float,
    duration: float,
    fs: float = 500.0,
    *,
    noise_g: float = 0.002,
    seed: int = 0,
) -> dict[str, Any]:
    """The free decay of ``beam`` after the release of a static tip deflection.

    The initial deflection is the static shape under a tip load, ``x^2 (3 L - x)``, projected
    on the modes (``q_k(0) = int psi_k w0 dx / int psi_k^2 dx``, ``q_k'(0) = 0``): about 97 %
    of the tip displacement is mode 1, while in acceleration every mode starts with a
    comparable share and the higher ones die out first. Each mode decays exactly as
    ``exp(-zeta_k omega_k t)`` (the closed-form response, sampled). Scaled so that the tip's
    (last station's) peak absolute acceleration is ``peak_g``; white sensor noise of
    ``noise_g`` RMS on every channel.

    Parameters
    ----------
    beam : LabBeam
        The beam.
    peak_g : float
        Peak acceleration of the last station, g.
    duration : float
        Record length from the release, s.
    fs : float
        Sampling frequency, Hz.
    noise_g : float
        Sensor noise RMS, g.
    seed : int
        Seed of the noise.

    Returns
    -------
    dict
        ``time`` (s, ``(n,)``), ``fs`` (Hz), ``stations`` (m/s^2, ``(n, n_stations)``),
        ``modal`` (the noise-free modal accelerations ``q_k''``, m/s^2, ``(n, n_modes)``).
    """
    if not (peak_g > 0 and duration > 0 and fs > 0 and noise_g >= 0):
        raise BeamError("peak_g, duration and fs must be positive, noise_g non-negative")
    n = int(round(duration * fs))
    t = np.arange(n) / fs
    x = np.linspace(0.0, beam.length, 4001)
    psi = beam.shapes(x)
    w0 = x**2 * (3 * beam.length - x)
    q0 = (w0 @ psi) / np.sum(psi**2, axis=0)  # uniform grid: the weights cancel
    wn, zk = beam.omegas, np.asarray(beam.damping)
    wd = wn * np.sqrt(1 - zk**2)
    sig = zk * wn
    tt = t[:, None]
    # q'' of q(t) = q0 e^(-sig t) (cos wd t + sig/wd sin wd t)
    qdd = -q0 * wn**2 * np.exp(-sig * tt) * (np.cos(wd * tt) - sig / wd * np.sin(wd * tt))
    y = qdd @ beam.shapes().T
    scale = peak_g * G / float(np.max(np.abs(y[:, -1])))
    qdd, y = qdd * scale, y * scale
    rng = np.random.default_rng(seed)
    y = y + noise_g * G * rng.standard_normal(y.shape)
    return {"time": t, "fs": float(fs), "stations": y, "modal": qdd}
