"""The passive recipe's loss terms and their data, written once for every trainer.

Pure functions of the training record (NumPy) and small JAX pytrees of what they give:

- the amplitude weighting: per-sample loss weights ``1 / (a^2 + eps^2)``
  (:func:`amplitude_weights`), so that small cycles count as much as large ones, as they do
  in Phi_d;
- the harmonic probes of the passivity penalty inside the training envelope (the NFIR's
  delay-line windows, :func:`harmonic_probes`; the recurrent classes' simulated sub-sequences,
  :func:`shooting_probes`);
- the energy cycles of the cycle-energy term (the NFIR's cycles of the record,
  :func:`energy_cycles`; the recurrent classes' energy weights of a sub-sequence and its
  cycle count, :func:`window_energy_weights`, :func:`cycles_per_window`);
- :data:`TRAIN_DTYPE`, the precision of the shooting trainers' Adam steps.

The terms that evaluate a model on them live with the model's trainer
(:mod:`sloshrom.rom.tdnn.training` for the NFIR, :mod:`sloshrom.rom.shooting` for the recurrent
classes).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import partial
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np

from sloshrom.rom.errors import ROMError
from sloshrom.rom.network import MinMaxScaler

__all__ = ["MAX_CYCLE", "TRAIN_DTYPE", "EnergyCycles", "HarmonicProbes", "PackedCycles",
           "ShootingProbes", "amplitude_weights", "cycle_slots", "cycles_per_window",
           "energy_cycles", "harmonic_probes", "pack_cycles", "shooting_probes",
           "window_energy_weights", "windows"]

#: longest input cycle of the cycle-energy term, samples (the cycles are padded to the longest)
MAX_CYCLE = 2048


def windows(x: jax.Array, starts: jax.Array, length: int) -> jax.Array:
    """The sub-sequences of ``length`` samples of ``x`` (along its first axis) that begin at
    ``starts``: ``x[starts[:, None] + arange(length)]``, the same values, shape
    ``(len(starts), length, *x.shape[1:])``.

    Each is read as one contiguous slice: XLA gathers the index form element by element (the
    rows of an NFIR's Adam step 8x slower). The windows must lie inside ``x``, as the trainers'
    starts are drawn (a slice that would pass the end is moved back, where the index form would
    clamp each index).
    """
    return jax.vmap(lambda s: jax.lax.dynamic_slice_in_dim(x, s, length, axis=0))(starts)


def amplitude_weights(u: np.ndarray, fs: float, eps: float, window: float = 1.0) -> np.ndarray:
    """Per-sample loss weights ``1 / (a^2 + eps^2)``, normalised to mean 1.

    ``a`` is the local amplitude of the input, sqrt(2) times its RMS over ``window`` seconds
    (centred). Phi_d divides the dissipated energy by the squared amplitude, so a cycle at
    small amplitude matters to the map as much as any; with a plain MSE its small forces
    barely count.

    Parameters
    ----------
    u : ndarray, shape (n,)
        Input record, physical units (m/s).
    fs : float
        Sample rate, Hz.
    eps : float
        Amplitude floor, units of ``u``; below it every sample weighs the same.
    window : float
        RMS window, s.
    """
    u = np.asarray(u, dtype=np.float64)
    k = max(1, min(int(round(window * fs)), u.size))
    ms = np.convolve(u**2, np.full(k, 1.0 / k), mode="same")
    w = 1.0 / (2.0 * ms + eps**2)
    return w / w.mean()


@partial(jax.tree_util.register_dataclass, data_fields=["windows", "weight"], meta_fields=[])
@dataclass(frozen=True)
class HarmonicProbes:
    """Steady harmonic inputs on which the NFIR's dissipated energy is evaluated.

    ``windows`` (p, max_delay + P_max): scaled input, the harmonic already running before the
    first counted sample; ``weight`` (p, P_max): for the counted samples (one whole period,
    zero after it), ``-v / (fs m_ref V^2) * out_half_range``, so that
    ``phi = sum(y_scaled * weight)`` is the dissipated energy per cycle over ``m_ref V^2``
    (a Phi_d with the data's mass scale ``m_ref`` in place of the liquid mass).
    """

    windows: Any
    weight: Any

    @property
    def n(self) -> int:
        """The number of probe windows."""
        return int(self.windows.shape[0])


def harmonic_probes(
    u: np.ndarray,
    fs: float,
    scaler: MinMaxScaler,
    delays: tuple[int, ...],
    band: tuple[float, float],
    n_freq: int = 14,
    n_amp: int = 16,
    amp_ratio: float = 100.0,
) -> HarmonicProbes:
    """Harmonic probes inside the training envelope of the input record ``u``.

    Frequencies ``fs / P`` (integer periods P, so a period is summed exactly) spaced
    logarithmically over ``band``; velocity amplitudes V spaced logarithmically from
    ``V_top / amp_ratio`` to ``V_top = min(max |u|, max |du/dt| / Omega)`` (inside both the
    velocity and the acceleration range the network was trained on). The mass scale is
    ``m_ref = out_half_range / max |du/dt|`` (kg for m/s in, N out).
    """
    u = np.asarray(u, dtype=np.float64)
    d = np.asarray(delays)
    dmax = int(d.max())
    v_max = min(-scaler.in_min, scaler.in_max)
    a_max = float(np.max(np.abs(np.gradient(u)))) * fs
    if not (v_max > 0 and a_max > 0):
        raise ROMError("passivity probes need an input that swings both ways around rest")
    m_ref = scaler.out_half_range / a_max
    f_lo, f_hi = max(band[0], fs / 1e4), min(band[1], fs / 4.0)
    if not f_hi > f_lo:
        f_lo, f_hi = fs / 100.0, fs / 4.0
    periods = np.unique(np.round(np.geomspace(fs / f_hi, fs / f_lo, n_freq)).astype(int))
    p_max = int(periods.max())
    k = np.arange(dmax + p_max) - dmax
    windows, weight = [], []
    for P in periods:
        om = 2.0 * np.pi * fs / P
        v_top = min(v_max, a_max / om)
        for V in np.geomspace(v_top / amp_ratio, v_top, n_amp):
            v = V * np.sin(2.0 * np.pi * k / P)
            windows.append(scaler.u(v))
            counted = np.where((k >= 0) & (k < P), v, 0.0)[dmax:]
            weight.append(-counted * scaler.out_half_range / (fs * m_ref * V * V))
    return HarmonicProbes(jnp.asarray(np.array(windows)), jnp.asarray(np.array(weight)))


@partial(jax.tree_util.register_dataclass, data_fields=["rows", "weight", "length"],
         meta_fields=[])
@dataclass(frozen=True)
class EnergyCycles:
    """The cycles of a record over which the exchanged energy is compared.

    ``rows`` (c, L): sample indices of each cycle, padded with 0; ``weight`` (c, L):
    ``v_k a_max / (fs V^2)`` on the cycle's samples (0 on the padding), ``V`` the cycle's peak
    velocity and ``a_max`` the record's peak acceleration, so that ``sum(e_scaled * weight)`` is
    the error of the cycle's energy ``sum(F v) / fs`` over ``m_ref V^2`` (the normalisation of
    :func:`harmonic_probes`, ``m_ref = out_half_range / a_max``); ``length`` (c,): the samples
    of each cycle (the rest of its row is padding).
    """

    rows: Any
    weight: Any
    length: np.ndarray

    @property
    def n(self) -> int:
        """The number of cycles."""
        return int(self.rows.shape[0])


def energy_cycles(
    u: np.ndarray,
    fs: float,
    band: tuple[float, float],
    amp_ratio: float = 100.0,
) -> EnergyCycles:
    """Cycles of the input record ``u`` (physical units, rest = 0) between upward zero crossings.

    A cycle is kept if its length lies within half the shortest and twice the longest period
    of ``band`` (Hz), at most ``MAX_CYCLE`` samples (bounded memory), and its peak |u| is at
    least ``max |u| / amp_ratio`` (below it, crossings of noise are not cycles). Over a cycle
    from one upward crossing to the next the liquid's inertia exchanges no net energy, so
    ``sum(F v) / fs`` is the energy the liquid took.

    Raises
    ------
    ROMError
        No cycle in the record.
    """
    u = np.asarray(u, dtype=np.float64)
    if not (fs > 0 and band[1] > band[0] >= 0):
        raise ROMError(f"energy cycles need fs > 0 and a frequency band, got {fs}, {band}")
    ups = np.flatnonzero((u[:-1] < 0.0) & (u[1:] >= 0.0)) + 1
    # an open band edge (0 or inf) leaves that side to the record
    l_min = max(4, int(fs / (2.0 * band[1])) if math.isfinite(band[1]) else 4)
    l_max = (max(l_min + 1, int(math.ceil(2.0 * fs / band[0]))) if band[0] > 0
             else u.size)
    l_max = min(l_max, MAX_CYCLE)
    v_min = float(np.max(np.abs(u))) / amp_ratio
    a_max = float(np.max(np.abs(np.gradient(u)))) * fs
    starts, ends, peaks = [], [], []
    for a, b in zip(ups[:-1], ups[1:], strict=True):
        if l_min <= b - a <= l_max:
            peak = float(np.max(np.abs(u[a:b])))
            if peak >= v_min:
                starts.append(a)
                ends.append(b)
                peaks.append(peak)
    if not starts:
        raise ROMError("no input cycle for the cycle-energy term: is the record oscillating?")
    length = max(e - a for a, e in zip(starts, ends, strict=True))
    rows = np.zeros((len(starts), length), dtype=np.int64)
    weight = np.zeros((len(starts), length))
    for i, (a, b, peak) in enumerate(zip(starts, ends, peaks, strict=True)):
        rows[i, : b - a] = np.arange(a, b)
        weight[i, : b - a] = u[a:b] * a_max / (fs * peak**2)
    return EnergyCycles(jnp.asarray(rows), jnp.asarray(weight),
                        np.array([e - a for a, e in zip(starts, ends, strict=True)]))


@dataclass(frozen=True)
class PackedCycles:
    """Drawn cycles' samples one cycle after the other in ``slots`` places a step (no padding
    between them: a cycle of 43 samples takes 43 places, not the longest cycle's 138).

    ``rows``, ``weight`` (steps, slots): :class:`EnergyCycles`' of the cycles' samples, then
    row 0 and weight 0 in the free places; ``segment`` (steps, slots): each sample's cycle, its
    position among the step's ``k`` drawn cycles (``k`` in the free places: a segment of its
    own, never summed with a cycle's).
    """

    rows: np.ndarray
    weight: np.ndarray
    segment: np.ndarray
    k: int


#: Places of a step of packed cycles are a multiple of this (fewer distinct shapes to compile)
_SLOT_QUANTUM = 128


def cycle_slots(cycles: EnergyCycles, k: int) -> int:
    """Places a step of ``k`` cycles drawn at random from ``cycles`` is given by
    :func:`pack_cycles`: ``k`` times the mean length plus six standard deviations of the sum,
    rounded up to a multiple of 128, at most the sum of the ``k`` longest (which always fits).
    On the default training record: 2,048 places for the 32 cycles of a step, where padding
    each cycle to the longest took 4,416."""
    length = np.sort(np.asarray(cycles.length))
    most = int(length[-k:].sum()) if k else 0
    likely = k * float(length.mean()) + 6.0 * math.sqrt(k) * float(length.std())
    return min(most, -(-int(math.ceil(likely)) // _SLOT_QUANTUM) * _SLOT_QUANTUM)


def pack_cycles(cycles: EnergyCycles, idx: np.ndarray, slots: int,
                dtype: type[np.floating] = np.float64) -> PackedCycles:
    """The samples of the cycles ``idx`` (steps, k) packed in ``slots`` places a step
    (:class:`PackedCycles`; a step whose cycles need more places makes every step of the
    call take as many, rounded up to a multiple of 128: the draw is never truncated)."""
    idx = np.asarray(idx)
    steps, k = idx.shape
    length = np.asarray(cycles.length)[idx]
    need = int(length.sum(axis=1).max()) if k else 0
    if need > slots:
        slots = -(-need // _SLOT_QUANTUM) * _SLOT_QUANTUM
    # one entry per drawn sample, cycle after cycle: (its step, its cycle's draw, the cycle,
    # its sample in the cycle, its place in the step); no (steps, k, longest) temporary
    n = length.ravel()
    within = np.arange(int(n.sum())) - np.repeat(np.cumsum(n) - n, n)
    cycle = np.repeat(idx.ravel(), n)
    step = np.repeat(np.repeat(np.arange(steps), k), n)
    place = np.repeat((np.cumsum(length, axis=1) - length).ravel(), n) + within
    rows = np.asarray(cycles.rows)
    out_rows = np.zeros((steps, slots), dtype=rows.dtype)
    out_weight = np.zeros((steps, slots), dtype=dtype)
    segment = np.full((steps, slots), k, dtype=np.int32)
    out_rows[step, place] = rows[cycle, within]
    out_weight[step, place] = np.asarray(cycles.weight)[cycle, within]
    segment[step, place] = np.repeat(np.tile(np.arange(k, dtype=np.int32), steps), n)
    return PackedCycles(out_rows, out_weight, segment, k)



#: Training precision of the shooting trainers: float32 Adam steps (measured 1.7x faster than
#: float64 through a 300-step scan on this machine's CPU); validation runs are float64.
TRAIN_DTYPE = jnp.float32


@dataclass(frozen=True)
class ShootingProbes:
    """Harmonic probes run from rest: scaled inputs (p, T) and the weights (p, T) whose sum with
    the scaled output is the dissipated energy per cycle over ``m_ref V^2`` (counted over the
    last whole period; 0 elsewhere)."""

    u: np.ndarray
    weight: np.ndarray


def shooting_probes(u: np.ndarray, fs: float, scaler: MinMaxScaler, horizon: int,
                    band: tuple[float, float], n_freq: int = 14, n_amp: int = 16,
                    amp_ratio: float = 100.0) -> ShootingProbes:
    """Probes inside the training envelope of ``u`` (m/s), each ``horizon`` samples long: a
    raised-cosine ramp over the first quarter, then the harmonic; the last whole period counts.
    Frequencies ``fs / P`` (integer periods) log-spaced over ``band`` (Hz) with at least half
    the horizon left to settle before the counted period.

    Raises
    ------
    ROMError
        An input that does not swing both ways around rest.
    """
    v_max = min(-scaler.in_min, scaler.in_max)
    a_max = float(np.max(np.abs(np.gradient(u)))) * fs
    if not (v_max > 0 and a_max > 0):
        raise ROMError("passivity probes need an input that swings both ways around rest")
    m_ref = scaler.out_half_range / a_max
    p_max = horizon // 2
    f_lo = max(band[0], fs / p_max)
    f_hi = min(band[1], fs / 8.0)
    if not f_hi > f_lo:
        f_lo, f_hi = fs / p_max, fs / 8.0
    periods = np.unique(np.round(np.geomspace(fs / f_hi, fs / f_lo, n_freq)).astype(int))
    k = np.arange(horizon)
    ramp_n = horizon // 4
    ramp = np.where(k < ramp_n, 0.5 - 0.5 * np.cos(np.pi * k / ramp_n), 1.0)
    us, ws = [], []
    for P in periods:
        om = 2.0 * np.pi * fs / P
        v_top = min(v_max, a_max / om)
        counted = (k >= horizon - P)
        for V in np.geomspace(v_top / amp_ratio, v_top, n_amp):
            v = V * np.sin(2.0 * np.pi * (k - (horizon - P)) / P) * ramp
            us.append(scaler.u(v))
            ws.append(np.where(counted, -v, 0.0) * scaler.out_half_range / (fs * m_ref * V * V))
    return ShootingProbes(np.array(us), np.array(ws))


def window_energy_weights(v: np.ndarray, fs: float, a_max: float, starts: np.ndarray,
                          horizon: int, v_floor: float) -> np.ndarray:
    """Per-window weights (w, horizon): ``v_k a_max / (fs V^2)``, V the window's peak |v|
    (floored), so that ``sum(e_scaled * weight)`` is the window's energy error over m_ref V^2."""
    idx = starts[:, None] + np.arange(horizon)[None, :]
    vw = v[idx]
    peak = np.maximum(np.max(np.abs(vw), axis=1), v_floor)
    return vw * a_max / (fs * peak[:, None] ** 2)


def cycles_per_window(v: np.ndarray, offset: int, horizon: int) -> np.ndarray:
    """Upward zero crossings of ``v`` in ``v[s + offset : s + offset + horizon]`` for every
    start ``s`` (at least 1), shape ``(v.size,)`` (0-padded at the end)."""
    up = np.concatenate([[0], (v[:-1] < 0) & (v[1:] >= 0)]).astype(np.float64)
    c = np.concatenate([[0.0], np.cumsum(up)])
    s = np.arange(v.size)
    lo = np.minimum(s + offset, v.size)
    hi = np.minimum(s + offset + horizon, v.size)
    return np.maximum(c[hi] - c[lo], 1.0)
