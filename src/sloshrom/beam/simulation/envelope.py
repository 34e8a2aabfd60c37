"""The tank motion a beam test asks of a sloshing model, and how much of it a ROM was trained on.

Two questions about the sloshing model inside the coupled loop:

* *Design* (:func:`tank_motion`, :func:`frozen_tank_motion`): how large are the tank's
  acceleration, velocity and displacement in the beam tests? With the liquid **frozen** the
  coupled system is linear (a run takes milliseconds) and it is the least-damped case: sloshing
  only adds dissipation (paper Figs. 21, 23), so the tank motion with the rig or a ROM in the
  loop stays below the frozen one (measured, paper beam: random 0.1/0.2/0.4 g RMS give 3.6/7.2/
  14.5 g frozen, 3.1/5.9/12.4 g rig). The frozen peaks therefore bound what a training record
  must cover.
* *Coverage* (:func:`envelope_coverage`): which fraction of a run lies outside the training
  envelope of the model (:func:`sloshrom.models.envelope_of`): its input (the velocity, or
  the acceleration for a network on it) outside ``[input_min, input_max]`` or, when the envelope
  records it, ``|acceleration|`` above the training record's peak acceleration
  ``acceleration_max``.

Pure functions on arrays and result dicts (no files).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from sloshrom.beam.errors import BeamError
from sloshrom.config import G
from sloshrom.models import Envelope, FrozenLiquid, SloshingModel

__all__ = [
    "Coverage",
    "RunMotion",
    "TankMotion",
    "envelope_coverage",
    "frozen_tank_motion",
    "run_motion",
    "tank_motion",
]

#: Frequencies below this are ignored when looking for the dominant one (drift, fades), Hz.
_MIN_DOMINANT_HZ = 1.0


@dataclass(frozen=True)
class RunMotion:
    """Peaks of the tank motion in one run (one test, one level).

    Attributes
    ----------
    run : str
        Name of the run, e.g. ``"free"``, ``"random 0.4 g"``.
    peak_acceleration : float
        max |tank absolute acceleration|, m/s^2.
    peak_velocity : float
        max |tank absolute velocity| (the sloshing model's input, base drift included), m/s.
    peak_displacement : float
        max |x - x_slow|, x the tank displacement from the start (trapezoidal integral of the
        velocity) and x_slow its centred 1 s moving average, m. (The displacement from the
        start drifts with the base velocity of a random test, metres in 90 s; the oscillation
        is what a shaker would have to play.)
    frequency : float
        Dominant frequency of the tank velocity (largest spectral line above 1 Hz), Hz.
    """

    run: str
    peak_acceleration: float
    peak_velocity: float
    peak_displacement: float
    frequency: float

    def as_dict(self) -> dict[str, Any]:
        """JSON-able, accelerations also in g: ``run``, ``peak_acceleration_g``,
        ``peak_acceleration_m_s2``, ``peak_velocity_m_s``, ``peak_displacement_m``,
        ``frequency_hz``."""
        return {"run": self.run, "peak_acceleration_g": self.peak_acceleration / G,
                "peak_acceleration_m_s2": self.peak_acceleration,
                "peak_velocity_m_s": self.peak_velocity,
                "peak_displacement_m": self.peak_displacement,
                "frequency_hz": self.frequency}


@dataclass(frozen=True)
class TankMotion:
    """The largest tank motion over a set of runs (:func:`tank_motion`).

    Attributes
    ----------
    peak_acceleration : float
        m/s^2, the largest over the runs.
    peak_velocity : float
        m/s.
    peak_displacement : float
        m (the oscillation, without drift: :class:`RunMotion`).
    frequency : float
        Hz: the dominant frequency of the run with the largest velocity.
    runs : tuple of RunMotion
        Every run.
    """

    peak_acceleration: float
    peak_velocity: float
    peak_displacement: float
    frequency: float
    runs: tuple[RunMotion, ...] = field(default_factory=tuple)

    def as_dict(self) -> dict[str, Any]:
        """JSON-able: the peaks (``peak_acceleration_g``, ``peak_velocity_m_s``, ...) and
        ``runs`` (:meth:`RunMotion.as_dict` of each)."""
        return {"peak_acceleration_g": self.peak_acceleration / G,
                "peak_acceleration_m_s2": self.peak_acceleration,
                "peak_velocity_m_s": self.peak_velocity,
                "peak_displacement_m": self.peak_displacement,
                "frequency_hz": self.frequency,
                "runs": [r.as_dict() for r in self.runs]}


def run_motion(run: str, acceleration: np.ndarray, velocity: np.ndarray,
               fs: float) -> RunMotion:
    """Peaks of one run from its tank acceleration (m/s^2) and velocity (m/s) at ``fs`` (Hz)."""
    a = np.asarray(acceleration, dtype=float)
    v = np.asarray(velocity, dtype=float)
    if a.ndim != 1 or v.shape != a.shape or a.size < 2:
        raise BeamError("acceleration and velocity must be 1-D arrays of the same length >= 2")
    if not (np.isfinite(fs) and fs > 0):
        raise BeamError(f"fs must be a finite positive rate in Hz, got {fs!r}")
    spec = np.abs(np.fft.rfft(v - np.mean(v)))
    f = np.fft.rfftfreq(v.size, 1.0 / fs)
    spec[f < _MIN_DOMINANT_HZ] = 0.0
    f_dom = float(f[int(np.argmax(spec))])
    # displacement from the start, minus its centred moving average over 1 s (at least two
    # periods): the oscillation, without the drift of the base
    x = np.concatenate([[0.0], np.cumsum(0.5 * (v[1:] + v[:-1])) / fs])
    n = min(x.size, int(round(fs * max(1.0 / _MIN_DOMINANT_HZ, 2.0 / max(f_dom, 1e-9)))))
    box = np.ones(n)
    slow = np.convolve(x, box, "same") / np.convolve(np.ones_like(x), box, "same")
    return RunMotion(run=run, peak_acceleration=float(np.max(np.abs(a))),
                     peak_velocity=float(np.max(np.abs(v))),
                     peak_displacement=float(np.max(np.abs(x - slow))), frequency=f_dom)


def tank_motion(results: Mapping[str, Mapping[str, Any]]) -> TankMotion:
    """The largest tank motion of a set of coupled-simulation results.

    Parameters
    ----------
    results : mapping
        Test name -> result dict of :func:`sloshrom.beam.simulation.coupled.free_response` or
        :func:`~sloshrom.beam.simulation.coupled.random_response` (``tank_acceleration``,
        ``tank_velocity``, ``fs``; a random response has one run per level, named
        ``"<test> <level> g"`` from ``rms_levels_g``).

    Returns
    -------
    TankMotion
    """
    runs: list[RunMotion] = []
    for test, res in results.items():
        acc = np.asarray(res["tank_acceleration"], dtype=float)
        vel = np.asarray(res["tank_velocity"], dtype=float)
        if acc.ndim == 1:
            runs.append(run_motion(test, acc, vel, float(res["fs"])))
            continue
        levels = res.get("rms_levels_g", range(acc.shape[0]))
        for i, level in enumerate(levels):
            runs.append(run_motion(f"{test} {level:g} g", acc[i], vel[i], float(res["fs"])))
    if not runs:
        raise BeamError("no runs given")
    fastest = max(runs, key=lambda r: r.peak_velocity)
    return TankMotion(
        peak_acceleration=max(r.peak_acceleration for r in runs),
        peak_velocity=fastest.peak_velocity,
        peak_displacement=max(r.peak_displacement for r in runs),
        frequency=fastest.frequency,
        runs=tuple(runs),
    )


def frozen_tank_motion(tests: Mapping[str, Callable[[SloshingModel, float | None], dict]],
                       fs: float) -> TankMotion:
    """Run the beam tests with frozen liquid at ``fs`` and return their tank motion.

    Frozen liquid is the least-damped case, so its peaks bound those of the same tests with the
    rig or a ROM in the loop. Linear and run by the JAX backend: a 90 s random test at three
    levels takes milliseconds once compiled.

    Parameters
    ----------
    tests : mapping
        Test name -> ``simulate(model, output_fs)`` returning the result dict (the same
        callables the beam tests use, so that the signals are exactly theirs).
    fs : float
        Step of the frozen model, 1/fs s, Hz (the beam's record rate).

    Returns
    -------
    TankMotion
    """
    frozen = FrozenLiquid(1.0 / fs)
    return tank_motion({name: sim(frozen, None) for name, sim in tests.items()})


@dataclass(frozen=True)
class Coverage:
    """How much of a run lies outside a model's training envelope.

    Arrays have the shape of the run's leading (batch) axes; NaN where the model has no
    envelope (rig, frozen liquid) or, for the acceleration entries, where the envelope does not
    record ``acceleration_max``.

    Attributes
    ----------
    outside_fraction : ndarray
        Fraction of samples outside the envelope (input outside ``[input_min, input_max]``,
        or ``|acceleration| > acceleration_max`` when known), -.
    peak_acceleration : ndarray
        max |tank acceleration| of the run, m/s^2.
    training_peak_acceleration : float
        ``acceleration_max`` of the envelope, m/s^2 (NaN if absent).
    acceleration_ratio : ndarray
        ``peak_acceleration / training_peak_acceleration``, -.
    """

    outside_fraction: np.ndarray
    peak_acceleration: np.ndarray
    training_peak_acceleration: float
    acceleration_ratio: np.ndarray


def envelope_coverage(envelope: Envelope | Mapping[str, Any] | None, velocity: Any,
                      acceleration: Any) -> Coverage:
    """Fraction of a run outside a training envelope and its peak-acceleration ratio.

    Parameters
    ----------
    envelope : Envelope, mapping or None
        A model's envelope (:func:`sloshrom.models.envelope_of`) or its ``envelope_``:
        ``input_min``, ``input_max`` (the input's units) and optionally
        ``acceleration_max`` (m/s^2, the training record's peak tank acceleration). An old
        envelope without ``acceleration_max`` is judged on the input only; ``None`` (or no
        ``input_min``): everything NaN.
    velocity : array_like, shape (..., n)
        The model's input (:func:`sloshrom.models.model_input`): the tank's absolute velocity,
        m/s, or its acceleration, m/s^2, for a network on the acceleration.
    acceleration : array_like, shape (..., n)
        The tank's absolute acceleration, m/s^2.

    Returns
    -------
    Coverage
    """
    v = np.asarray(velocity, dtype=float)
    a = np.asarray(acceleration, dtype=float)
    if v.shape != a.shape or v.ndim == 0:
        raise BeamError(f"velocity and acceleration must have the same shape with a time axis, "
                        f"got {v.shape} and {a.shape}")
    peak = np.max(np.abs(a), axis=-1)
    nan = np.full(peak.shape, np.nan)
    env = envelope if isinstance(envelope, Envelope) else Envelope.from_mapping(envelope)
    if env is None:
        return Coverage(nan, peak, float("nan"), nan.copy())
    outside = (v < env.input_min) | (v > env.input_max)
    acc_max = env.acceleration_max
    if acc_max is None:
        return Coverage(np.mean(outside, axis=-1), peak, float("nan"), nan)
    outside |= np.abs(a) > acc_max
    return Coverage(np.mean(outside, axis=-1), peak, acc_max, peak / acc_max)
