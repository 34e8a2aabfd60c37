"""The identification test designed for its use: a shaker programme derived from the structure.

A ROM identified on VFA sweeps alone is applied, in the sloshing beam, to a different *kind* of
motion: narrow-band random motion at the structure's first frequency (the random base tests)
and decaying sines (the free response), in a closed loop. The programme of this module plays
those kinds of motion on the shaker, next to the paper's VFA:

* **random segments**: the tank acceleration of the structure with frozen liquid under random
  base excitation (the beam tests' Gaussian PSD, other phase seeds than the tests') at a set of
  RMS levels spanning the tests' levels: narrow-band motion around the structure's frequency,
  with the amplitude statistics the application will see;
* **decay segments**: the tank acceleration of the frozen structure's free response, released
  from a set of tip displacements, faded in over a few cycles (a shaker starts at rest).

Frozen liquid is the least-damped case (sloshing only adds dissipation), so its motion bounds
that of the rig or a ROM in the loop; the structure is linear then, and a run takes
milliseconds. Every segment starts and ends at rest (zero acceleration, velocity and
displacement: :func:`sloshrom.signals.to_rest`), so a shaker controller can play the
concatenated programme (:meth:`Programme.acceleration`) with a pause between segments.

Pure functions on arrays; the files a controller reads are written by
``sloshrom.io.programme`` (by the command line).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from scipy import signal as sig

from sloshrom.beam.simulation.coupled import free_response, random_response, upsample_periodic
from sloshrom.beam.simulation.structure import ModalModel
from sloshrom.config import G, Tank
from sloshrom.errors import SloshromError
from sloshrom.models import FrozenLiquid
from sloshrom.signals import ShakerLimits, to_rest

__all__ = ["Programme", "ProgrammeError", "Segment", "concatenate", "structure_segments"]

#: Segment kinds: the paper's VFA sweep, narrow-band random motion, a decaying sine.
KINDS = ("vfa", "random", "decay")


class ProgrammeError(SloshromError):
    """A shaker programme that cannot be made or played (bad parameters, limits)."""


@dataclass(frozen=True)
class Segment:
    """One piece of a shaker programme.

    Attributes
    ----------
    name : str
        E.g. ``"vfa"``, ``"random 0.2 g"``, ``"decay 1.00"``.
    kind : str
        One of :data:`KINDS`.
    acceleration : ndarray (n,)
        Tank vertical acceleration, m/s^2, at the programme's rate; starts and ends at rest.
    level : float
        RMS base acceleration of the structure test it stands for, g (random); factor on the
        tip displacement (decay); peak acceleration, g (vfa).
    """

    name: str
    kind: str
    acceleration: np.ndarray
    level: float

    def __post_init__(self) -> None:
        if self.kind not in KINDS:
            raise ProgrammeError(f"segment kind must be one of {KINDS}, got {self.kind!r}")


@dataclass(frozen=True)
class Programme:
    """A shaker programme: segments played one after the other, with a pause between them.

    Attributes
    ----------
    fs : float
        Sample rate of the segments, Hz.
    segments : tuple of Segment
    pause : float
        Rest between two segments, s (the controller's settling; part of the lab time).
    """

    fs: float
    segments: tuple[Segment, ...]
    pause: float = 0.0

    def acceleration(self) -> np.ndarray:
        """The whole programme, m/s^2 at ``fs``: the segments with ``pause`` s of rest between
        them."""
        gap = np.zeros(int(round(self.pause * self.fs)))
        parts: list[np.ndarray] = []
        for k, s in enumerate(self.segments):
            if k:
                parts.append(gap)
            parts.append(np.asarray(s.acceleration, dtype=float))
        return np.concatenate(parts) if parts else np.zeros(0)

    @property
    def duration(self) -> float:
        """Length of :meth:`acceleration`, s (from the segments' lengths: nothing is
        concatenated)."""
        n_gap = int(round(self.pause * self.fs))
        n = sum(np.size(s.acceleration) for s in self.segments)
        return (n + n_gap * max(len(self.segments) - 1, 0)) / self.fs

    def motion(self) -> dict[str, float]:
        """Peaks of the programme: ``acceleration`` (m/s^2), ``velocity`` (m/s) and
        ``displacement`` (m), from the exact trapezoidal integrals (each segment starts at
        rest)."""
        a = self.acceleration()
        v = np.concatenate([[0.0], np.cumsum(0.5 * (a[1:] + a[:-1])) / self.fs])
        x = np.concatenate([[0.0], np.cumsum(0.5 * (v[1:] + v[:-1])) / self.fs])
        return {"acceleration": float(np.max(np.abs(a))), "velocity": float(np.max(np.abs(v))),
                "displacement": float(np.max(np.abs(x)))}

    def check(self, limits: ShakerLimits, max_duration: float | None = None) -> list[str]:
        """The shaker limits the programme exceeds, each as a sentence (empty: it fits).

        Parameters
        ----------
        limits : ShakerLimits
            Stroke (m, amplitude), velocity (m/s) and acceleration (m/s^2) of the shaker.
        max_duration : float, optional
            Longest run the shaker (or its amplifier's duty cycle) allows, s.
        """
        m = self.motion()
        out = []
        for key, word, lim, unit, scale in (
                ("acceleration", "acceleration", limits.max_acceleration, "g", 1.0 / G),
                ("velocity", "velocity", limits.max_velocity, "m/s", 1.0),
                ("displacement", "stroke", limits.max_displacement, "mm", 1e3)):
            if m[key] > lim * (1 + 1e-9):
                out.append(f"peak {word} {m[key] * scale:.4g} {unit} exceeds the shaker's "
                           f"{lim * scale:.4g} {unit}")
        if max_duration is not None and self.duration > max_duration:
            out.append(f"duration {self.duration:.0f} s exceeds the shaker's "
                       f"{max_duration:.0f} s")
        return out

    def lab_time(self, setup: float = 60.0) -> float:
        """How long a laboratory takes to play it, s: the programme plus ``setup`` s per
        segment (loading the drive file, the controller's pre-test at low level)."""
        return self.duration + setup * len(self.segments)


def concatenate(fs: float, segments: Sequence[Segment], pause: float = 0.0) -> Programme:
    """A :class:`Programme` of ``segments`` at ``fs`` (Hz), checked: at least one segment,
    each 1-D, finite and starting and ending at rest (|a| below 1e-9 of its peak at the ends)."""
    if not segments:
        raise ProgrammeError("a programme needs at least one segment")
    if not (np.isfinite(fs) and fs > 0):
        raise ProgrammeError(f"fs must be a finite positive rate in Hz, got {fs!r}")
    for s in segments:
        a = np.asarray(s.acceleration)
        if a.ndim != 1 or a.size < 2 or not np.all(np.isfinite(a)):
            raise ProgrammeError(f"segment {s.name!r}: acceleration must be a finite 1-D array")
        peak = float(np.max(np.abs(a)))
        if peak and max(abs(a[0]), abs(a[-1])) > 1e-9 * peak:
            raise ProgrammeError(f"segment {s.name!r} does not start and end at rest")
    return Programme(float(fs), tuple(segments), float(pause))


def structure_segments(
    modal: ModalModel,
    tank: Tank,
    fs: float,
    signal_fs: float,
    levels_g: Sequence[float],
    duration: float,
    seed: int,
    f0: float,
    sigma: float,
    tip_displacement: float,
    decay_factors: Sequence[float] = (),
    decay_duration: float = 10.0,
    fade: float = 2.0,
    decay_fade: float = 0.3,
    highpass: float = 2.0,
) -> list[Segment]:
    """The segments of the structure's own motion (random and decay), from frozen-liquid runs.

    Parameters
    ----------
    modal : ModalModel
        The structure (the beam stage's).
    tank : Tank
    fs : float
        Rate of the segments, Hz (the rig's integration rate: an integer multiple of
        ``signal_fs``).
    signal_fs : float
        Rate of the frozen simulations, Hz (the beam tests' record rate).
    levels_g : sequence of float
        RMS base acceleration of each random segment, g.
    duration : float
        Length of each random segment, s.
    seed : int
        Phase seed of the first random segment (segment k: ``seed + k``); choose it apart from
        the beam tests' seed so that no test signal is trained on.
    f0, sigma : float
        Centre and standard deviation of the base PSD, Hz (the beam tests').
    tip_displacement : float
        The free test's release displacement, m.
    decay_factors : sequence of float
        One decay segment per factor on ``tip_displacement``.
    decay_duration : float
        Length of each decay segment, s.
    fade : float
        Fade in/out of each random segment, s.
    decay_fade : float
        Fade-in of each decay segment, s (a few cycles: the shaker builds the first peak up).
    highpass : float
        Corner of the zero-phase high-pass (4th-order Butterworth) applied to the random
        segments, Hz (0 = none). The base of a random test drifts (its Gaussian PSD reaches
        0 Hz): metres of displacement in 25 s that no shaker plays. The force does not depend on
        the drift's velocity (Galilean invariance), so the drift is left to the training's
        augmentation (``velocity_offset`` of the NSS) rather than to the shaker.

    Returns
    -------
    list of Segment
        The random segments (``level`` in g), then the decays (``level`` the factor).
    """
    factor = fs / signal_fs
    if abs(factor - round(factor)) > 1e-9 or round(factor) < 1:
        raise ProgrammeError(f"fs={fs} Hz must be an integer multiple of {signal_fs} Hz")
    up = int(round(factor))
    frozen = FrozenLiquid(1.0 / signal_fs)
    segments: list[Segment] = []
    for k, level in enumerate(levels_g):
        r = random_response(frozen, modal, [float(level)], duration, seed + k, f0, sigma,
                            signal_fs=signal_fs, tank=tank, fade=fade)
        a = np.asarray(r["tank_acceleration"][0])
        if highpass > 0:
            sos = sig.butter(4, highpass, "highpass", fs=signal_fs, output="sos")
            a = sig.sosfiltfilt(sos, a)
        a = upsample_periodic(a, up)
        segments.append(Segment(f"random {level:g} g", "random", to_rest(a, fs, fade),
                                 float(level)))
    for c in decay_factors:
        r = free_response(frozen, modal, c * tip_displacement, decay_duration, tank)
        # the release's jump rings in the band-limited upsampling only where the fade-in is ~0
        a = upsample_periodic(np.asarray(r["tank_acceleration"]), up)
        segments.append(Segment(f"decay {c:.2f}", "decay",
                                to_rest(a, fs, decay_fade, end_fade=decay_fade), float(c)))
    return segments
