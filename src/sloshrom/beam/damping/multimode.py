"""The damping of each mode of a structure with several active modes, from random tests.

* :func:`mode_damping_random`, :func:`modal_damping_table`: modal filtering of the stations
  with the frozen-liquid mode shapes (``sloshrom.beam.simulation.wing.frozen_station_shapes``),
  then per mode the H1 of base -> modal acceleration and the LSCF stable-pole-cluster damping
  in a band around it, with the half-power bandwidth as a cross-check.
* :func:`tank_mode_shares`: how hard each mode shakes the tank.
* :func:`band_power`: the mean power the liquid takes from the tank in each mode's band.

The two-mode wing of ``sloshrom.beam.simulation.wing`` and the ``multimode`` study use them.
Pure numerics: arrays in, arrays and dicts out; no files.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from sloshrom.beam.damping.analysis import (
    AnalysisError,
    frf_h1,
    half_power_damping,
    lscf_cluster_damping,
    modal_filter,
)
from sloshrom.beam.damping.limits import WELCH_SEGMENT
from sloshrom.beam.errors import BeamError
from sloshrom.beam.simulation.structure import ModalModel
from sloshrom.beam.simulation.wing import frozen_station_shapes
from sloshrom.config import G

__all__ = ["band_power", "modal_damping_table", "mode_damping_random", "tank_mode_shares"]


def tank_mode_shares(modal_acceleration: Any, tank_shapes: Any) -> np.ndarray:
    """RMS tank acceleration contributed by each mode, m/s^2.

    Parameters
    ----------
    modal_acceleration : array (..., n, n_modes)
        Modal accelerations of the frozen-liquid modes (:func:`frozen_station_shapes`), m/s^2.
    tank_shapes : array (n_modes,)
        Their tank displacement (-).

    Returns
    -------
    ndarray (..., n_modes)
        ``rms(psi_T,k eta_k'')``: how hard each mode shakes the tank (relative to the base).
    """
    q = np.asarray(modal_acceleration, dtype=float)
    return np.sqrt(np.mean((q * np.asarray(tank_shapes, dtype=float)) ** 2, axis=-2))


def mode_damping_random(
    base: Any,
    modal_acceleration: Any,
    fs: float,
    frequencies: Sequence[float],
    rel_band: float = 0.3,
    nperseg: int = WELCH_SEGMENT,
    pol_order_high: int = 20,
    tol_zeta: float = 0.10,
) -> list[dict[str, Any]]:
    """Frequency and damping of every mode of a random base-excitation test.

    For mode k: H1 of base acceleration -> modal acceleration k (:func:`frf_h1`, Hann,
    ``nperseg`` samples, 50 % overlap), then the LSCF stable-pole cluster in the band
    ``f_k (1 -/+ rel_band)`` (:func:`lscf_cluster_damping`); the half-power bandwidth of |H1|
    (:func:`half_power_damping`) as a cross-check. The estimator of the paper beam's Table 2
    (``mode1_damping_random``'s ``lscf_h1``), applied to each modal coordinate.

    Parameters
    ----------
    base : array (n,)
        Base acceleration, m/s^2.
    modal_acceleration : array (n, n_modes)
        Modal accelerations (modal filtering of the stations, :func:`modal_filter`), m/s^2.
    fs : float
        Hz.
    frequencies : sequence of float
        Expected natural frequencies (e.g. frozen liquid), Hz, one per column.
    rel_band : float
        Half-width of each mode's fitting band, relative (-): keep it below the modes'
        relative spacing so that each band holds one mode.
    nperseg : int
        Welch segment, samples (16384 at 500 Hz: 0.03 Hz resolution, 33 s).
    pol_order_high : int
        LSCF models with 2 .. 2 ``pol_order_high`` poles.
    tol_zeta : float
        Relative damping change between successive model orders within which a pole is stable
        (:func:`~sloshrom.beam.damping.analysis.stable_pole_cluster`). 10 %, not the paper beam's 5
        %: on the H1 of a sloshing (nonlinear) response the lightly damped torsion mode's poles
        alternate by about 6 % from one order to the next, and 5 % left some records (the rig's
        among them) without any cluster; where 5 % finds one, 10 % moves its median by less
        than 1 %.

    Returns
    -------
    list of dict
        One per mode: ``mode`` (1-based), ``zeta`` (-, NaN if no stable cluster),
        ``frequency`` (Hz), ``zeta_iqr`` (-, spread over model orders), ``n_poles``,
        ``half_power`` (-, NaN if no clean peak), ``reason`` ("" or why NaN).
    """
    q = np.asarray(modal_acceleration, dtype=float)
    freqs = np.atleast_1d(np.asarray(frequencies, dtype=float))
    if q.ndim != 2 or q.shape[1] != freqs.size:
        raise BeamError(f"modal_acceleration must be (n, {freqs.size}), got {q.shape}")
    if not 0 < rel_band < 1:
        raise BeamError(f"rel_band must be in (0, 1), got {rel_band!r}")
    rows = []
    for k, fk in enumerate(freqs):
        band = (fk * (1 - rel_band), fk * (1 + rel_band))
        f, h, _ = frf_h1(base, q[:, k], fs, nperseg)
        r = lscf_cluster_damping(f, h, fk, band, pol_order_high, tol_zeta=tol_zeta)
        try:
            hp = half_power_damping(f, h, band)["zeta"]
        except AnalysisError:  # no clean peak in this record: the cross-check is missing
            hp = float("nan")
        rows.append({"mode": k + 1, "zeta": r["zeta"], "frequency": r["frequency"],
                     "zeta_iqr": r["zeta_iqr"], "n_poles": int(r["n_poles"]),
                     "half_power": hp, "reason": r["reason"]})
    return rows


def modal_damping_table(
    results: Mapping[str, Mapping[str, Any]],
    modal: ModalModel,
    liquid_mass: float,
    levels: Sequence[float],
    rel_band: float = 0.3,
    nperseg: int = WELCH_SEGMENT,
    tol_zeta: float = 0.10,
) -> list[dict[str, Any]]:
    """Damping of every mode of every random response: one row per case, level and mode.

    The station accelerations relative to the base are filtered with the frozen-liquid shapes
    (:func:`frozen_station_shapes`, :func:`modal_filter`); each mode's damping is then
    :func:`mode_damping_random`'s.

    Parameters
    ----------
    results : mapping
        Case -> random response (``sloshrom.beam.simulation.coupled.random_response``: leading level
        axis, ``station_acceleration``, ``base_acceleration``, ``tank_acceleration``, ``fs``).
    modal : ModalModel
        The dry structure (one tank).
    liquid_mass : float
        kg.
    levels : sequence of float
        Base RMS of each level, g.
    rel_band, nperseg, tol_zeta
        As :func:`mode_damping_random`.

    Returns
    -------
    list of dict
        ``case``, ``rms_g`` (g), ``mode``, ``zeta`` (-), ``frequency_hz``, ``zeta_iqr`` (-),
        ``n_poles``, ``half_power`` (-), ``tank_peak_g`` (peak |tank acceleration| of the run,
        g), ``tank_mode_rms_g`` (RMS tank acceleration contributed by this mode, g,
        :func:`tank_mode_shares`).
    """
    f_frozen, st_shapes, tk_shapes = frozen_station_shapes(modal, liquid_mass)
    rows = []
    for case, res in results.items():
        rel = res["station_acceleration"] - res["base_acceleration"][..., None]
        eta = modal_filter(rel, st_shapes)
        shares = tank_mode_shares(eta, tk_shapes)
        for i, level in enumerate(levels):
            peak = float(np.max(np.abs(res["tank_acceleration"][i]))) / G
            for r in mode_damping_random(res["base_acceleration"][i], eta[i], float(res["fs"]),
                                         f_frozen, rel_band, nperseg, tol_zeta=tol_zeta):
                rows.append({"case": case, "rms_g": float(level), "mode": r["mode"],
                             "zeta": r["zeta"], "frequency_hz": r["frequency"],
                             "zeta_iqr": r["zeta_iqr"], "n_poles": r["n_poles"],
                             "half_power": r["half_power"], "tank_peak_g": peak,
                             "tank_mode_rms_g": float(shares[i, r["mode"] - 1]) / G})
    return rows


def band_power(
    velocity: Any,
    force: Any,
    fs: float,
    frequencies: Sequence[float],
    rel_band: float = 0.3,
) -> np.ndarray:
    """Mean power the liquid takes from the tank in each mode's frequency band, W.

    The exact partition of ``-mean(F v)`` by frequency (Parseval on the real FFT): the band
    ``f_k (1 -/+ rel_band)`` holds the share carried by the motion near mode k. Positive: the
    liquid dissipates (takes energy from the structure). Fed the same velocity, two sloshing
    models' powers compare their damping of each mode in open loop, free of the feedback of
    the coupled run.

    Parameters
    ----------
    velocity : array (..., n)
        Tank vertical velocity, m/s.
    force : array (..., n)
        Dynamic sloshing force on the tank (the records' ``dynamic_force``), N.
    fs : float
        Sample rate, Hz.
    frequencies : sequence of float
        Mode frequencies, Hz.
    rel_band : float
        Half-width of each band, relative (-), in (0, 1).

    Returns
    -------
    ndarray (..., n_modes)
        W.
    """
    v = np.asarray(velocity, dtype=float)
    f = np.asarray(force, dtype=float)
    if v.shape != f.shape or v.shape[-1] < 2:
        raise BeamError(f"velocity and force must have the same shape (..., n >= 2), got "
                        f"{v.shape} and {f.shape}")
    if not (np.isfinite(fs) and fs > 0):
        raise BeamError(f"fs must be a finite positive rate in Hz, got {fs!r}")
    if not 0 < rel_band < 1:
        raise BeamError(f"rel_band must be in (0, 1), got {rel_band!r}")
    n = v.shape[-1]
    # one-sided: every bin but DC (and Nyquist for even n) stands for two
    weight = np.full(n // 2 + 1, 2.0)
    weight[0] = 1.0
    if n % 2 == 0:
        weight[-1] = 1.0
    power = -weight * np.real(np.fft.rfft(f, axis=-1) * np.conj(np.fft.rfft(v, axis=-1))) / n**2
    freq = np.fft.rfftfreq(n, 1.0 / fs)
    out = [np.sum(power[..., (freq >= fk * (1 - rel_band)) & (freq <= fk * (1 + rel_band))],
                  axis=-1)
           for fk in np.atleast_1d(np.asarray(frequencies, dtype=float))]
    return np.stack(out, axis=-1)

