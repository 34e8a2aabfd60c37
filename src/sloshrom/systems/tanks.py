"""A short-record system: the Cascaded Tanks benchmark, simulated.

The benchmark (Schoukens, Mattsson, Wigren and Noel, "Cascaded tanks benchmark combining soft
and hard nonlinearities", Workshop on nonlinear system identification benchmarks, 2016;
nonlinearbenchmark.org) is a pump that fills an upper tank, which drains through a small
opening into a lower tank, which drains back into the reservoir. Input: the pump voltage
``u`` (V); output: the level of the lower tank measured as a voltage ``y`` (V). Two records
of 1024 samples at ``Ts = 4 s`` (one to estimate, one to test), a random-phase multisine
input: a short record with a soft nonlinearity (the outflow through an opening goes with the
square root of the level) and a hard one (a full tank overflows).

The model simulated here is the benchmark description's (levels ``h1``, ``h2`` in volts of
the level sensors, ``t`` in s)::

    h1' = -k1 sqrt(h1) + k4 u + w1
    h2' =  k2 sqrt(h1) - k3 sqrt(h2) + k5 q_over + w2
    y   =  h2 + e

with the hard saturation of the tanks' tops: a level at ``h_max`` stays there while more
flows in, and the excess inflow ``q_over = k4 u - k1 sqrt(h1)`` of a full upper tank spills;
the fraction ``k5`` of it falls into the lower tank (the rest is lost), a full lower tank
overflows likewise. ``w1``, ``w2`` are a small process noise, ``e`` white measurement noise.
The parameters are chosen, not identified, so that the records look like the benchmark's
(levels between 0 and 10 V, the upper tank overflowing at the input's peaks of the
estimation record, a time constant of about 80 s); the records are a stand-in for the
measured ones, with a known truth.

The estimation record starts with the tanks empty (at rest: ``u = 0``, ``h = 0``); the test
record starts after a warm-up of ``warmup`` samples of its own input, far from rest, so a
model must estimate its initial state from the test record's first samples (an encoder), as
on the measured benchmark.

This module is pure NumPy; it imports the base and :mod:`sloshrom.io` only.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np

from sloshrom.io import Record

__all__ = ["HISTORY", "TankParameters", "cascaded_tanks", "multisine", "simulate_tanks",
           "steady_levels", "tank_records"]


@dataclass(frozen=True)
class TankParameters:
    """The cascaded tanks' coefficients (levels and inputs in V, time in s).

    Parameters
    ----------
    k1 : float
        Outflow of the upper tank, V^0.5/s: ``-k1 sqrt(h1)``.
    k2 : float
        Inflow of the lower tank from the upper one, V^0.5/s.
    k3 : float
        Outflow of the lower tank, V^0.5/s.
    k4 : float
        Pump gain, 1/s: ``k4 u`` into the upper tank.
    k5 : float
        Fraction (-) of the upper tank's overflow that falls into the lower tank.
    h_max : float
        Level of the tanks' tops, V: a tank at ``h_max`` overflows.
    """

    k1: float = 0.06
    k2: float = 0.06
    k3: float = 0.065
    k4: float = 0.033
    k5: float = 0.4
    h_max: float = 10.0


def steady_levels(u: float, p: TankParameters = TankParameters()) -> tuple[float, float]:
    """The levels (V) at rest under a constant input ``u`` (V), overflow ignored.

    ``h1 = (k4 u / k1)^2`` (inflow equals outflow of the upper tank) and
    ``h2 = (k2 / k3)^2 h1`` (of the lower one).
    """
    h1 = (p.k4 * max(u, 0.0) / p.k1) ** 2
    return h1, (p.k2 / p.k3) ** 2 * h1


def _rates(h: np.ndarray, u: float, p: TankParameters) -> tuple[np.ndarray, float]:
    """The levels' rates (V/s) without noise, and the upper tank's spilled inflow (V/s)."""
    s1, s2 = np.sqrt(max(h[0], 0.0)), np.sqrt(max(h[1], 0.0))
    d1 = -p.k1 * s1 + p.k4 * u
    spill = 0.0
    if h[0] >= p.h_max and d1 > 0.0:
        # a full upper tank: what flows in beyond its outflow spills over its top
        spill, d1 = d1, 0.0
    d2 = p.k2 * s1 - p.k3 * s2 + p.k5 * spill
    if h[1] >= p.h_max and d2 > 0.0:
        d2 = 0.0
    return np.array([d1, d2]), spill


def simulate_tanks(u: np.ndarray, ts: float, p: TankParameters = TankParameters(),
                   h0: tuple[float, float] = (0.0, 0.0), process_noise: float = 0.0,
                   rng: np.random.Generator | None = None, substeps: int = 20
                   ) -> np.ndarray:
    """Levels of the tanks driven by the pump voltage ``u`` (zero-order hold).

    Parameters
    ----------
    u : ndarray, shape (n,)
        Pump voltage, V, one value per sample (held over the sample).
    ts : float
        Sample time, s.
    p : TankParameters
    h0 : (float, float)
        Levels at the first sample, V.
    process_noise : float
        Standard deviation (V) of the level change each sample from the noises ``w1``, ``w2``
        (white, independent).
    rng : numpy.random.Generator, optional
        The noise's generator (needed when ``process_noise > 0``).
    substeps : int
        Classical Runge-Kutta steps per sample (the levels stay within ``[0, h_max]`` after
        each).

    Returns
    -------
    ndarray, shape (n, 2)
        ``h1``, ``h2`` at each sample (before that sample's input acts), V.
    """
    n = np.size(u)
    out = np.empty((n, 2))
    h = np.array(h0, dtype=float)
    dt = ts / substeps
    for k in range(n):
        out[k] = h
        uk = float(u[k])
        for _ in range(substeps):
            k1 = _rates(h, uk, p)[0]
            k2 = _rates(np.clip(h + 0.5 * dt * k1, 0.0, p.h_max), uk, p)[0]
            k3 = _rates(np.clip(h + 0.5 * dt * k2, 0.0, p.h_max), uk, p)[0]
            k4 = _rates(np.clip(h + dt * k3, 0.0, p.h_max), uk, p)[0]
            # the tops and bottoms are hard limits: a step that crosses one ends on it
            h = np.clip(h + dt / 6.0 * (k1 + 2 * k2 + 2 * k3 + k4), 0.0, p.h_max)
        if process_noise > 0.0:
            assert rng is not None
            h = np.clip(h + process_noise * rng.standard_normal(2), 0.0, p.h_max)
    return out


def multisine(n: int, ts: float, f_max: float, rng: np.random.Generator, mean: float,
              std: float, lo: float = 0.0, hi: float = 10.0) -> np.ndarray:
    """A random-phase multisine of flat amplitude on the bins ``k / (n ts)`` up to ``f_max``.

    Parameters
    ----------
    n : int
        Samples (one period).
    ts : float
        Sample time, s.
    f_max : float
        Highest excited frequency, Hz.
    rng : numpy.random.Generator
        Draws the phases.
    mean, std : float
        Mean and standard deviation of the signal before clipping, V.
    lo, hi : float
        The pump's range, V: the signal is clipped to it.

    Returns
    -------
    ndarray, shape (n,)
    """
    k_max = max(1, int(np.floor(f_max * n * ts)))
    spec = np.zeros(n // 2 + 1, dtype=complex)
    spec[1:k_max + 1] = np.exp(2j * np.pi * rng.uniform(size=k_max))
    x = np.fft.irfft(spec, n)
    x = (x - x.mean()) / x.std()
    return np.clip(mean + std * x, lo, hi)


def cascaded_tanks(seed: int = 0, n: int = 1024, *, ts: float = 4.0, f_max: float = 0.0144,
                   u_mean: float = 5.0, u_std: float = 1.8, noise: float = 0.03,
                   process_noise: float = 0.005, warmup: int = 256,
                   params: TankParameters = TankParameters()) -> tuple[Record, Record]:
    """The two records of the Cascaded Tanks benchmark, simulated (module docstring).

    Parameters
    ----------
    seed : int
        Seeds the inputs' phases and the noises: one seed, the same records.
    n : int
        Samples of each record (1024 in the benchmark).
    ts : float
        Sample time, s (4 s).
    f_max : float
        The multisine's highest frequency, Hz (0.0144 Hz: the benchmark's band).
    u_mean, u_std : float
        The input's mean and standard deviation before clipping to the pump's 0-10 V, V.
    noise : float
        Standard deviation of the white measurement noise ``e`` on ``y``, V.
    process_noise : float
        Standard deviation of the levels' random change each sample, V.
    warmup : int
        Samples of the test input run before the test record starts (its initial state).
    params : TankParameters

    Returns
    -------
    estimation, test : Record
        Variables ``u`` (pump voltage, V) and ``y`` (lower tank's level, V); ``time`` from 0
        in s. Attributes: ``system`` ("cascaded_tanks"), ``seed``, ``overflow_fraction`` (the
        fraction of samples with the upper tank full), ``initial_levels`` (V), the
        parameters.
    """
    rng = np.random.default_rng(seed)
    u_est = multisine(n, ts, f_max, rng, u_mean, u_std)
    # the test input: another realisation of the same spectrum, run for warmup samples
    # before the record starts, so that the test starts where that input left the tanks
    u_test_all = multisine(n + warmup, ts, f_max, rng, u_mean, u_std)
    h_est = simulate_tanks(u_est, ts, params, (0.0, 0.0), process_noise, rng)
    h_test_all = simulate_tanks(u_test_all, ts, params, (0.0, 0.0), process_noise, rng)
    u_test, h_test = u_test_all[warmup:], h_test_all[warmup:]
    t = np.arange(n) * ts
    records = []
    for name, u, h in (("estimation", u_est, h_est), ("test", u_test, h_test)):
        y = h[:, 1] + noise * rng.standard_normal(n)
        attrs = {"system": "cascaded_tanks", "record": name, "seed": int(seed),
                 "overflow_fraction": float(np.mean(h[:, 0] >= params.h_max - 1e-9)),
                 "initial_levels": [float(h[0, 0]), float(h[0, 1])],
                 "noise_std": float(noise), "process_noise_std": float(process_noise),
                 "parameters": {k: float(v) for k, v in asdict(params).items()}}
        records.append(Record(time=t, fs=1.0 / ts, variables={"u": u, "y": y},
                              units={"u": "V", "y": "V"}, attrs=attrs))
    return records[0], records[1]


#: Samples of measured history at the head of the validation record of :func:`tank_records`
#: (``sloshrom train --history``): at least any encoder window of the short-record sweep.
HISTORY = 50


def _part(rec: Record, start: int, stop: int, name: str) -> Record:
    t = np.asarray(rec.time)[start:stop]
    return Record(time=t - t[0], fs=rec.fs,
                  variables={k: np.asarray(rec[k])[start:stop] for k in ("u", "y")},
                  units=dict(rec.units), attrs={**rec.attrs, "record": name,
                                                "first_sample": int(start)})


def tank_records(seed: int = 0, n: int = 1024, noise: float = 0.03,
                 warmup: int = 256) -> dict[str, Record]:
    """The records of :func:`cascaded_tanks` by file stem, for the systems' registry.

    Parameters
    ----------
    seed, n, noise, warmup
        As :func:`cascaded_tanks` (``noise``: the measurement noise's standard deviation, V).

    Returns
    -------
    dict of str to Record
        ``train``: the estimation record's first 80 %; ``validation``: the rest, preceded by
        :data:`HISTORY` samples of the training part as measured history (train with
        ``--history 50``); ``test``: the test record (far from rest: predict with
        ``--history``); ``estimation``: the whole estimation record.
    """
    est, test = cascaded_tanks(seed=seed, n=int(n), noise=float(noise), warmup=int(warmup))
    n_train = int(round(0.8 * len(est)))
    return {"train": _part(est, 0, n_train, "train"),
            "validation": _part(est, max(0, n_train - HISTORY), len(est), "validation"),
            "test": test, "estimation": est}
