"""Damping estimators of random beam tests behind one protocol.

A *damping estimator* is an object with a ``name`` (its key in results and files), a human
``label`` (tables, figures), the kind of ``uncertainty`` its intervals come from, and two
methods: :meth:`~DampingEstimator.estimate` (the first-mode damping of one record, a
:class:`DampingEstimate`) and :meth:`~DampingEstimator.estimate_records` (the damping ratio of
each of a stack of simulated records, for the bootstrap). The estimators of paper Table 2 are
defined here; ``sloshrom.beam.damping.registry`` holds the one list of estimators that everything
else loops over, and ``sloshrom.beam.damping.uncertainty`` gives any of them its standard deviation
and interval through this protocol.

Uncertainty kinds (``DampingEstimator.uncertainty``):

* ``"bootstrap"`` - a parametric bootstrap: records simulated from the fitted mode are analysed
  as the record was; their mean gives the estimator's bias (removed), their spread the
  standard deviation (``sloshrom.beam.damping.uncertainty.damping_estimates``).
* ``"spread"`` - the same parametric bootstrap, its bias not removed: the standard deviation of
  the simulated records' estimates, the interval the union of those around the raw and the
  bias-corrected value (output-only LSCF: the simulation's bias of an output-only estimate is
  the record's on a lone mode, not always among other modes, see :class:`LscfOutput`); where
  the bootstrap gives no spread (no damping ratio to simulate), Au's law times
  ``efficiency``.
* ``"au"`` - output-only estimators of known efficiency: Au's uncertainty law times
  ``efficiency`` (the estimator's measured scatter over the law), no bias correction.

A missing estimate is NaN *with a reason*: :attr:`DampingEstimate.reason` carries what the
analysis found and what it tried (e.g. "no stable pole cluster in 9.1-11.2 Hz (model orders
2-40 poles): largest stable cluster near 10.3 Hz has 9 pole(s), fewer than 10, at damping
tolerance 5 %; ...").

LSCF on H1 tries a documented sequence of stable-pole tolerances (:data:`LSCF_H1_ATTEMPTS`):
the primary attempt first, the relaxed ones only where it finds no cluster, so that a value a
record has today never changes; :attr:`DampingEstimate.note` says which attempt gave a
fallback value, and the bootstrap analyses its simulated records with that same attempt.

Arrays in, typed results out; frequencies in Hz, damping ratios dimensionless (-).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from functools import cached_property
from typing import Any, Literal, Protocol, runtime_checkable

import numpy as np

from sloshrom.beam.damping.analysis import (
    AnalysisError,
    band_text,
    frf_h1,
    half_power_damping,
    lscf_poles,
    lscf_poles_batch,
    output_only_damping,
    stable_pole_cluster,
)
from sloshrom.beam.damping.limits import WELCH_SEGMENT
from sloshrom.beam.errors import BeamError

__all__ = [
    "LSCF_H1_ATTEMPTS", "OUTPUT_ONLY_EFFICIENCY", "UNCORRECTED_INPUT_NOTE", "ClusterAttempt",
    "DampingEstimate",
    "DampingEstimator", "HalfPower", "LscfH1", "LscfOutput", "RandomTest", "Uncertainty",
    "bootstrap_estimator",
]

#: Where an estimator's interval comes from (see the module docstring).
Uncertainty = Literal["bootstrap", "spread", "au"]

#: Scatter of the output-only estimator (``analysis.output_only_damping``) over Au's bound
#: ``1 / sqrt(zeta omega_n T)``: 17.2 % / 13.3 % = 1.29 at 90 s and 6.8 % / 5.2 % = 1.31 at 600 s
#: (standard deviation over 50 records of a base-excited 1 %, 10 Hz oscillator under Gaussian
#: white noise, ``benchmarks/damping_estimators.py``).
OUTPUT_ONLY_EFFICIENCY: float = 1.3

_NAN = float("nan")


@dataclass(frozen=True)
class DampingEstimate:
    """One estimator's first-mode damping of one record.

    Attributes
    ----------
    value : float
        Damping ratio, - (bias-corrected where the estimator's uncertainty is a bootstrap);
        NaN when there is none, and then ``reason`` says why.
    std : float
        Standard deviation of ``value``, - (NaN: not stated).
    low, high : float
        Two-sided interval of ``value`` at the stated confidence, - (NaN: none).
    reason : str
        ``""`` when ``value`` and its interval exist; otherwise why they do not.
    frequency : float
        The mode's natural frequency, Hz (NaN if the estimator gives none).
    uncorrected : float
        The estimate before any bias correction, -.
    iqr : float
        Spread of the damping ratio over the stabilisation diagram's cluster (interquartile
        range across model orders), -; NaN for an estimator without one.
    n_poles : int
        Poles in that cluster (0: none found, or no cluster).
    note : str
        ``""`` when the value comes from the estimator's primary procedure; otherwise how it
        was obtained (the fallback attempt of :data:`LSCF_H1_ATTEMPTS` and why the primary one
        failed).
    attempt : int
        Index of the attempt that gave the value (0: the primary one; an estimator without
        attempts: 0).
    """

    value: float
    std: float = _NAN
    low: float = _NAN
    high: float = _NAN
    reason: str = ""
    frequency: float = _NAN
    uncorrected: float = _NAN
    iqr: float = _NAN
    n_poles: int = 0
    note: str = ""
    attempt: int = 0


@dataclass(frozen=True, eq=False)
class RandomTest:
    """A random base-excitation test (or a stack of simulated ones) and the analysis options.

    Attributes
    ----------
    base, response : ndarray (n,) or (n_records, n)
        Base and response (tank) accelerations, same unit.
    fs, f1 : float
        Sampling frequency and approximate first-mode frequency, Hz.
    rel_band : float
        Fitting band ``f1 (1 -/+ rel_band)``, Hz, unless ``band`` is given.
    nperseg : int
        Welch segment length of H1, samples (at most the record length).
    pol_order_high : int
        Highest model order of the LSCF fits (models with 2 to ``2 pol_order_high`` poles).
    band : (float, float), optional
        Fitting band (low, high), Hz, overriding ``rel_band``: a mode between neighbours needs
        a band between them, not a symmetric one. Must hold ``f1``.

    Notes
    -----
    The band the estimators fit is :attr:`fit_band`, clipped to the Nyquist frequency.
    """

    base: np.ndarray
    response: np.ndarray
    fs: float
    f1: float
    rel_band: float = 0.5
    nperseg: int = WELCH_SEGMENT
    pol_order_high: int = 20
    band: tuple[float, float] | None = None

    def __post_init__(self) -> None:
        base = np.asarray(self.base, dtype=float)
        resp = np.asarray(self.response, dtype=float)
        if base.ndim not in (1, 2) or resp.shape != base.shape:
            raise BeamError("base and tank must be 1-D arrays (or stacks of them) of the same "
                            "length")
        object.__setattr__(self, "base", base)
        object.__setattr__(self, "response", resp)
        object.__setattr__(self, "nperseg", min(int(self.nperseg), base.shape[-1]))
        if self.band is not None:
            lo, hi = (float(v) for v in self.band)
            if not (math.isfinite(lo) and math.isfinite(hi) and 0 <= lo < self.f1 < hi):
                raise BeamError(f"the fitting band must hold the mode: 0 <= low < f1 = "
                                f"{self.f1:.4g} Hz < high, got {self.band}")
            if not self.f1 < self.fs / 2:
                raise BeamError(f"the mode ({self.f1:.4g} Hz) must lie below the Nyquist "
                                f"frequency ({self.fs / 2:g} Hz)")
            object.__setattr__(self, "band", (lo, hi))

    @property
    def fit_band(self) -> tuple[float, float]:
        """The fitting band, Hz: ``band`` if given, else ``f1 (1 -/+ rel_band)``; its upper
        edge clipped to the Nyquist frequency (no line lies above it)."""
        lo, hi = self.band if self.band is not None else (self.f1 * (1 - self.rel_band),
                                                          self.f1 * (1 + self.rel_band))
        return (lo, min(hi, self.fs / 2))

    @property
    def duration(self) -> float:
        """Record length, s."""
        return self.base.shape[-1] / self.fs

    @cached_property
    def h1(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``analysis.frf_h1`` of the record: ``(f (Hz), H1, coherence)``; a stack in one pass
        (each record bit for bit as alone), one record by scipy's Welch functions."""
        return frf_h1(self.base, self.response, self.fs, self.nperseg,
                      one_pass=self.base.ndim == 2)


@runtime_checkable
class DampingEstimator(Protocol):
    """What every damping estimator of a random test is.

    Attributes
    ----------
    name : str
        Key in results and result files (``lscf_h1``): letters, digits, ``_``.
    label : str
        Human name for tables and figures (``LSCF on H1``).
    uncertainty : {"bootstrap", "spread", "au"}
        Where its interval comes from (module docstring).
    efficiency : float
        For ``"au"`` (and ``"spread"`` without a bootstrap): the estimator's scatter over Au's
        law (-); NaN for the others.
    """

    # read-only members: an estimator may be a frozen dataclass
    @property
    def name(self) -> str:
        """Key in results and file columns."""
        ...

    @property
    def label(self) -> str:
        """Human name for tables and figures."""
        ...

    @property
    def uncertainty(self) -> Uncertainty:
        """How its interval is found."""
        ...

    @property
    def efficiency(self) -> float:
        """For ``"au"`` (and ``"spread"`` without a bootstrap): its scatter over Au's law
        (-)."""
        ...

    def estimate(self, test: RandomTest) -> DampingEstimate:
        """The first-mode damping of one record (``test.base`` 1-D): ``value`` (raw),
        ``frequency``, ``reason``; no interval yet."""
        ...

    def estimate_records(self, records: RandomTest) -> np.ndarray:
        """Damping ratio (-) of each record of a stack ``(n_records, n)``, NaN where none,
        exactly as :meth:`estimate` would give each alone."""
        ...


def _cluster_estimate(r: dict[str, Any]) -> DampingEstimate:
    return DampingEstimate(value=float(r["zeta"]), frequency=float(r["frequency"]),
                           uncorrected=float(r["zeta"]), reason=str(r["reason"]),
                           iqr=float(r["zeta_iqr"]), n_poles=int(r["n_poles"]))


@dataclass(frozen=True)
class ClusterAttempt:
    """The stable-pole tolerances of one attempt at a cluster (``analysis.stable_pole_cluster``).

    Attributes
    ----------
    tol_frequency, tol_zeta : float
        Relative frequency and damping tolerances between the poles of neighbouring model
        orders, -.
    min_poles : int
        Fewest stable poles that make a cluster.
    """

    tol_frequency: float = 0.01
    tol_zeta: float = 0.05
    min_poles: int = 10

    def describe(self) -> str:
        """The tolerances as text (reasons and notes)."""
        return (f"damping tolerance {100 * self.tol_zeta:g} %, frequency tolerance "
                f"{100 * self.tol_frequency:g} %, at least {self.min_poles} poles")

    def cluster(self, poles: dict[str, np.ndarray], f1: float) -> dict[str, float | str]:
        """``analysis.stable_pole_cluster`` of ``poles`` near ``f1`` (Hz) with these
        tolerances."""
        c = stable_pole_cluster(poles, f1, tol_frequency=self.tol_frequency,
                                tol_zeta=self.tol_zeta, min_poles=self.min_poles)
        return {k: c[k] for k in ("frequency", "zeta", "zeta_iqr", "n_poles", "reason")}


#: The attempts of LSCF on H1, in order; the first that finds a cluster gives the value.
#: 0 is the primary procedure (the tolerances of ``analysis.stable_pole_cluster``), the
#: only one applied wherever it finds a cluster. Where it does not, the damping tolerance is
#: relaxed to 10 %, then 20 % (same band, model orders and minimum of 10 poles): the ROM
#: members at 0.4 g RMS (2026-11-28) had clusters of 5 and 6 poles at 5 %, and of 14 and 12
#: at 10 % (1.72 % and 1.53 %); nonlinear responses move the fitted damping between model
#: orders more than a linear mode does. On 100 records of H1 between independent white
#: noises (90 s, 500 Hz) no tolerance up to 20 % found a stable pole near f1, so the
#: relaxed attempts do not invent a mode from noise.
LSCF_H1_ATTEMPTS: tuple[ClusterAttempt, ...] = (
    ClusterAttempt(), ClusterAttempt(tol_zeta=0.10), ClusterAttempt(tol_zeta=0.20))


def _no_cluster_reason(band: tuple[float, float], pol_order_high: int,
                       tried: list[tuple[ClusterAttempt, str]]) -> str:
    # what was tried, attempt by attempt, with what each found
    return (f"no stable pole cluster in {band_text(band)} (LSCF model orders "
            f"2-{2 * pol_order_high} poles): "
            + "; ".join(f"{a.describe()}: {why}" for a, why in tried))


@dataclass(frozen=True)
class LscfH1:
    """LSCF on H1 (base -> tank acceleration), the median of the stable-pole cluster
    (``analysis.lscf_poles``, ``analysis.stable_pole_cluster``), the attempts of
    :data:`LSCF_H1_ATTEMPTS` in order; bias-corrected by the bootstrap."""

    name: str = "lscf_h1"
    label: str = "LSCF on H1"
    uncertainty: Uncertainty = "bootstrap"
    efficiency: float = _NAN
    attempts: tuple[ClusterAttempt, ...] = LSCF_H1_ATTEMPTS
    first_attempt: int = 0

    def at_attempt(self, k: int) -> LscfH1:
        """This estimator restricted to attempt ``k`` (the bootstrap of a value attempt ``k``
        gave analyses its simulated records the same way)."""
        return replace(self, attempts=(self.attempts[k],), first_attempt=k)

    def estimate(self, test: RandomTest) -> DampingEstimate:
        """The raw first-mode damping of one record (the protocol's ``estimate``)."""
        f, h, _ = test.h1
        poles = lscf_poles(f, h, test.fit_band, test.pol_order_high)
        tried: list[tuple[ClusterAttempt, str]] = []
        for k, a in enumerate(self.attempts):
            c = a.cluster(poles, test.f1)
            if np.isfinite(c["zeta"]):
                e = _cluster_estimate(c)
                if not tried:
                    return e
                note = (f"fallback attempt {self.first_attempt + k} ({a.describe()}): "
                        + _no_cluster_reason(test.fit_band, test.pol_order_high, tried))
                return replace(e, note=note, attempt=self.first_attempt + k)
            tried.append((a, str(c["reason"])))
        return replace(_cluster_estimate(c),
                       reason=_no_cluster_reason(test.fit_band, test.pol_order_high, tried))

    def estimate_records(self, records: RandomTest) -> np.ndarray:
        """Damping ratio (-) of each record of a stack, NaN where none (the protocol's
        ``estimate_records``): each record by the first attempt that finds a cluster."""
        f, h, _ = records.h1
        out = []
        for p in lscf_poles_batch(f, h, records.fit_band, records.pol_order_high):
            z = _NAN
            for a in self.attempts:
                z = float(a.cluster(p, records.f1)["zeta"])
                if np.isfinite(z):
                    break
            out.append(z)
        return np.array(out, dtype=float)


def bootstrap_estimator(est: DampingEstimator, estimate: DampingEstimate) -> DampingEstimator:
    """The estimator the bootstrap of ``estimate`` analyses its simulated records with.

    An estimator with attempts (``at_attempt``, e.g. :class:`LscfH1`) is restricted to the
    attempt that gave ``estimate`` (the primary one where it gave the value): the bias and
    spread are those of the procedure that made the value, and a record whose primary attempt
    succeeds is bootstrapped exactly as before the fallbacks existed. Others: ``est``.
    """
    at = getattr(est, "at_attempt", None)
    return at(estimate.attempt) if at is not None else est


#: The note of an output-only estimate whose record has no measured base to divide by.
UNCORRECTED_INPUT_NOTE = ("the base is not measured (no power in its channel): the output "
                          "spectrum is taken as the response to a white input, not corrected "
                          "for the input's colour")


@dataclass(frozen=True)
class LscfOutput:
    """Output-only LSCF on the half-spectrum of the tank acceleration, window corrected
    (``analysis.output_only_damping``), the output spectrum divided by the measured base's
    (a coloured input made white; where the base is not measured, uncorrected, with a note).

    Its interval is the parametric bootstrap's (``"spread"``), not Au's law: once the base's
    colour is divided out, the estimate scatters 0.2-0.3 times the law's bound times
    :data:`OUTPUT_ONLY_EFFICIENCY` at the higher modes of a laboratory beam (the law's
    intervals covered 100 %; the scatter is 0.8-1.45 times the bootstrap's spread;
    ``benchmarks/lab_coverage.py``, docs/beam.md). The value is not bias-corrected: the
    simulated records hold one mode and its near neighbours, and their output-only bias is not
    always the record's (removed, it moved an unbiased third mode +3.6 %). On a lone mode it
    is (-4.6 % simulated and measured: 90 s records, 5 % noise), so the interval is the union
    of ``t std`` around the raw value and around the bias-corrected one."""

    name: str = "lscf_output"
    label: str = "output-only LSCF"
    uncertainty: Uncertainty = "spread"
    efficiency: float = OUTPUT_ONLY_EFFICIENCY

    def estimate(self, test: RandomTest) -> DampingEstimate:
        """The raw first-mode damping of one record (the protocol's ``estimate``)."""
        r = output_only_damping(test.response, test.fs, test.f1, test.fit_band,
                                pol_order_high=test.pol_order_high, base=test.base)
        e = _cluster_estimate(r)
        if e.reason:  # say what was tried, as LSCF on H1 does
            e = replace(e, reason=_no_cluster_reason(test.fit_band, test.pol_order_high,
                                                     [(ClusterAttempt(), e.reason)]))
        return e if r["input_divided"] else replace(e, note=UNCORRECTED_INPUT_NOTE)

    def estimate_records(self, records: RandomTest) -> np.ndarray:
        """Damping ratio (-) of each record of a stack, NaN where none (the protocol's
        ``estimate_records``)."""
        return np.array([output_only_damping(y, records.fs, records.f1, records.fit_band,
                                             pol_order_high=records.pol_order_high,
                                             base=u)["zeta"]
                         for u, y in zip(records.base, records.response, strict=True)])


@dataclass(frozen=True)
class HalfPower:
    """Half-power bandwidth of |H1| (``analysis.half_power_damping``); bias-corrected by the
    bootstrap."""

    name: str = "half_power"
    label: str = "half power"
    uncertainty: Uncertainty = "bootstrap"
    efficiency: float = _NAN

    def estimate(self, test: RandomTest) -> DampingEstimate:
        """The raw first-mode damping of one record (the protocol's ``estimate``)."""
        f, h, _ = test.h1
        try:
            r = half_power_damping(f, h, test.fit_band)
        except AnalysisError as e:  # no clear peak in this record: the estimate is missing
            return DampingEstimate(value=_NAN, reason=str(e))
        return DampingEstimate(value=r["zeta"], frequency=r["frequency"],
                               uncorrected=r["zeta"])

    def estimate_records(self, records: RandomTest) -> np.ndarray:
        """Damping ratio (-) of each record of a stack, NaN where none (the protocol's
        ``estimate_records``)."""
        f, h, _ = records.h1
        out = np.full(h.shape[0], _NAN)
        for k in range(h.shape[0]):
            try:
                out[k] = half_power_damping(f, h[k], records.fit_band)["zeta"]
            except AnalysisError:  # no clear peak in this record: the estimate is missing
                pass
        return out

