"""Energy dissipated by sloshing in harmonic motion: hysteresis loops and Phi_d maps.

Conventions (paper section 2): w up positive, ``f_S = -m_l w'' + dF`` is the
force the liquid exerts on the tank, the energy dissipated per cycle is
``L_d = -oint f_S dw = -oint dF dw`` (the inertia term integrates to zero over whole cycles),
``Phi_d = L_d / (m_l a^2 Omega^2)``, ``omega_bar = Omega / sqrt(g/h)``, ``a_bar = a / h`` and the
acceleration amplitude in g is ``Gamma = a_bar omega_bar^2``.

The maps are evaluated inside the shaker envelope :data:`sloshrom.signals.SHAKER_ENVELOPE` (the
one definition of the test domain, shared with the VFA paths). Arrays put time on the last axis,
independent runs (batches) on the leading axes, as ``SloshingModel.simulate`` does.
:func:`map_fidelity` compares a map with a reference: whole map, dissipative region, passivity.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np
import numpy.typing as npt
import xarray as xr

from sloshrom import __version__
from sloshrom.config import Tank
from sloshrom.errors import SloshromError
from sloshrom.models import SloshingModel, envelope_quiet, is_jax_model, tank_of
from sloshrom.signals import DEFAULT_A_BAR_MIN, SHAKER_ENVELOPE, harmonic

__all__ = [
    "DISSIPATIVE_THRESHOLD",
    "JAX_BLOCK",
    "PASSIVITY_TOLERANCE",
    "EnergyError",
    "default_grid",
    "dissipated_energy",
    "frame_change",
    "frame_probes",
    "frame_sensitivity",
    "hysteresis_loop",
    "map_fidelity",
    "map_maximum",
    "phi_d",
    "phi_d_map",
    "shaker_envelope",
]


class EnergyError(SloshromError):
    """A harmonic test or a map that cannot be made: a bad grid, record or missing tank."""


#: Dissipative region of a map: where Phi_d exceeds this fraction of the map's maximum (-).
DISSIPATIVE_THRESHOLD = 0.1
#: Non-passive points: Phi_d below minus this fraction of the reference maximum (-); smaller
#: negative values are round-off of the energy integral where nothing dissipates.
PASSIVITY_TOLERANCE = 0.02


def dissipated_energy(
    w: Any, dynamic_force: Any, n_cycles: int = 1, rule: str = "trapezoid"
) -> np.ndarray:
    """Energy dissipated per cycle ``L_d = -oint dF dw`` (J), over whole cycles.

    Parameters
    ----------
    w : array_like
        Tank displacement over an integer number of cycles, m, shape ``(..., n)``.
    dynamic_force : array_like
        Dynamic force dF (or f_S: same result over whole cycles), N, same shape.
    n_cycles : int
        Number of whole cycles in the samples; the result is per cycle.
    rule : {"trapezoid", "step"}
        ``"trapezoid"``: force samples at the sample instants (ROMs, measured data);
        ``"step"``: force sample k is the average over [t_k, t_k+1] (the virtual rig's output).

    Returns
    -------
    ndarray
        L_d per cycle, J, shape ``(...)``.
    """
    w = np.asarray(w, dtype=np.float64)
    f = np.asarray(dynamic_force, dtype=np.float64)
    if w.shape != f.shape or w.ndim == 0 or w.shape[-1] < 2:
        raise EnergyError("w and dynamic_force must have the same shape with >= 2 samples")
    if n_cycles < 1:
        raise EnergyError(f"n_cycles must be >= 1, got {n_cycles}")
    dw = np.diff(w, axis=-1)
    if rule == "trapezoid":
        fm = 0.5 * (f[..., 1:] + f[..., :-1])
    elif rule == "step":
        fm = f[..., :-1]
    else:
        raise EnergyError(f"rule must be 'trapezoid' or 'step', got {rule!r}")
    return -np.sum(fm * dw, axis=-1) / n_cycles


def frame_probes(velocity: npt.ArrayLike, fs: float, offsets: Sequence[float] = (0.1, 0.3)
                 ) -> tuple[np.ndarray, np.ndarray]:
    """The inputs :func:`frame_sensitivity` drives a model with (its parameters).

    Returns
    -------
    probes : ndarray, shape (1 + 2 len(offsets), n)
        The velocity (m/s), then for each offset ``c`` the velocity plus ``c`` and minus ``c``.
    acceleration : ndarray, shape (n,)
        Their common acceleration (m/s^2): a uniform velocity has none.
    """
    v = np.asarray(velocity, dtype=float)
    acc = np.gradient(v) * fs
    return np.stack([v, *(v + s * c for c in offsets for s in (1.0, -1.0))]), acc


def frame_change(probes: np.ndarray, fs: float, forces: Sequence[npt.ArrayLike],
                 offsets: Sequence[float] = (0.1, 0.3)) -> dict[str, list[float]]:
    """:func:`frame_sensitivity`'s figures from a model's forces for :func:`frame_probes`.

    For a caller that runs the model itself (e.g. an ensemble's members, each on a core as it
    becomes free): ``forces[i]`` is the dynamic force (N) for ``probes[i]``, as
    ``model.simulate(probes[i], acceleration)`` gives it.

    Raises
    ------
    EnergyError
        The unshifted record dissipates no energy with this model, or ``forces`` does not
        match ``probes``.
    """
    v = np.asarray(probes[0], dtype=float)
    if not len(forces) == len(probes) == 1 + 2 * len(offsets):
        raise EnergyError(f"{len(forces)} forces for {len(probes)} probes of "
                          f"{len(offsets)} offsets: one a probe, 1 + 2 per offset")
    f0, e0 = _dissipating(forces[0], v, fs)
    rms = float(np.std(f0))
    energy, force = [], []
    for i, _ in enumerate(offsets):
        runs = [np.asarray(forces[1 + 2 * i + j], dtype=float) for j in (0, 1)]
        energy.append(max(abs(-float(np.sum(f * v)) / fs / e0 - 1) for f in runs))
        force.append(max(float(np.std(f - f0)) for f in runs) / rms)
    return {"offsets_m_s": [float(c) for c in offsets], "energy_change": energy,
            "force_change": force}


def _dissipating(force: npt.ArrayLike, velocity: np.ndarray, fs: float
                 ) -> tuple[np.ndarray, float]:
    """``force`` as floats and the energy the record dissipates with it (J), if any."""
    f0 = np.asarray(force, dtype=float)
    e0 = -float(np.sum(f0 * velocity)) / fs
    if not (np.isfinite(e0) and e0 != 0 and float(np.std(f0)) > 0):
        raise EnergyError("the record dissipates no energy with this model: nothing to compare")
    return f0, e0


def frame_sensitivity(model: SloshingModel, velocity: npt.ArrayLike, fs: float,
                      offsets: Sequence[float] = (0.1, 0.3)) -> dict[str, list[float]]:
    """How much a model's force and dissipation depend on the frame it is driven in.

    The sloshing force does not depend on the tank's uniform velocity (Galilean invariance;
    the virtual rig's force is invariant to it exactly): the same record with its velocity
    shifted by a constant must give the same force. A model of the velocity learns that only
    from data, and a structure under random base excitation drifts (the paper beam's tank, by
    0.09 / 0.18 / 0.36 m/s RMS below 3 Hz at 0.1 / 0.2 / 0.4 g), so its dissipation in the
    coupled loop changes with the drift when the model's does.

    Parameters
    ----------
    model : SloshingModel
        Driven by ``model.simulate(velocity, acceleration)``.
    velocity : array_like, shape (n,)
        A record's tank velocity, m/s, at ``fs`` (a motion about rest, e.g. the validation
        record).
    fs : float
        Hz.
    offsets : sequence of float
        Uniform velocities added, m/s (each with both signs).

    Returns
    -------
    dict
        ``offsets_m_s``; ``energy_change``: per offset the largest relative change of the
        energy dissipated over the record (``-sum F v / fs``, J, in the record's frame) over
        ``+offset`` and ``-offset`` (-; 0 for an invariant model); ``force_change``: per offset
        the largest RMS change of the force over the force's RMS (-).
    """
    probes, acc = frame_probes(velocity, fs, offsets)
    # the record itself first: no shifted run for a model that dissipates nothing
    f0, _ = _dissipating(model.simulate(probes[0], acc), probes[0], fs)
    # the record's peaks leave a model's envelope by the offset: a deliberate probe
    with envelope_quiet():
        runs = [np.asarray(model.simulate(p, acc), dtype=float) for p in probes[1:]]
    return frame_change(probes, fs, [f0, *runs], offsets)


def phi_d(l_d: Any, amplitude: Any, omega: Any, liquid_mass: float) -> np.ndarray:
    """Non-dimensional dissipated energy ``Phi_d = L_d / (m_l a^2 Omega^2)``.

    Parameters
    ----------
    l_d : array_like
        Energy per cycle, J.
    amplitude : array_like
        Displacement amplitude a, m.
    omega : array_like
        Angular frequency Omega, rad/s.
    liquid_mass : float
        m_l, kg.
    """
    a = np.asarray(amplitude, dtype=np.float64)
    om = np.asarray(omega, dtype=np.float64)
    return np.asarray(l_d, dtype=np.float64) / (liquid_mass * a * a * om * om)


def hysteresis_loop(
    w: Any,
    dynamic_force: Any,
    acceleration: Any,
    amplitude: float,
    omega: float,
    liquid_mass: float,
) -> tuple[np.ndarray, np.ndarray]:
    """Normalised hysteresis loop of the sloshing force (paper Fig. 3b).

    Parameters
    ----------
    w, dynamic_force, acceleration : array_like
        Tank displacement (m), dynamic force dF (N) and tank acceleration (m/s^2).
    amplitude, omega : float
        a (m) and Omega (rad/s) of the harmonic motion.
    liquid_mass : float
        m_l, kg.

    Returns
    -------
    x : ndarray
        ``w / a``.
    y : ndarray
        ``f_S / (m_l a Omega^2)`` with ``f_S = dF - m_l w''``.
    """
    if not (amplitude > 0 and omega > 0 and liquid_mass > 0):
        raise EnergyError("amplitude, omega and liquid_mass must be positive")
    w = np.asarray(w, dtype=np.float64)
    f_s = np.asarray(dynamic_force, dtype=np.float64) - liquid_mass * np.asarray(
        acceleration, dtype=np.float64
    )
    return w / amplitude, f_s / (liquid_mass * amplitude * omega**2)


def shaker_envelope(
    omega_bar: Any,
    a_bar: Any,
    tank: Tank,
    f_min: float = SHAKER_ENVELOPE.f_min,
    f_max: float = SHAKER_ENVELOPE.f_max,
    gamma_max: float = SHAKER_ENVELOPE.gamma_max,
    a_bar_max: float = SHAKER_ENVELOPE.a_bar_max,
) -> np.ndarray:
    """Boolean mask of the grid points (omega_bar, a_bar) the shaker can play.

    Parameters
    ----------
    omega_bar, a_bar : array_like
        1-D grids of Omega / sqrt(g/h) and a / h.
    tank : Tank
        Sets h.
    f_min, f_max, gamma_max, a_bar_max : float
        The envelope (Hz, Hz, g, -); default :data:`sloshrom.signals.SHAKER_ENVELOPE`.

    Returns
    -------
    ndarray of bool
        Shape ``(len(omega_bar), len(a_bar))``.
    """
    ob = np.asarray(omega_bar, dtype=np.float64)[:, None]
    ab = np.asarray(a_bar, dtype=np.float64)[None, :]
    f = ob * tank.reference_frequency / (2 * math.pi)
    return (
        (f >= f_min * (1 - 1e-9))
        & (f <= f_max * (1 + 1e-9))
        & (ab * ob**2 <= gamma_max * (1 + 1e-9))
        & (ab <= a_bar_max * (1 + 1e-9))
        & (ab > 0)
    )


def default_grid(n: int = 30, tank: Tank | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Default (omega_bar, a_bar) grid over the shaker envelope, n x n points.

    Frequencies ``SHAKER_ENVELOPE.f_min`` to ``f_max`` (5-25 Hz) and a_bar from
    :data:`DEFAULT_A_BAR_MIN` to ``SHAKER_ENVELOPE.a_bar_max`` (0.01-0.45), both linear.

    Parameters
    ----------
    n : int
        Points per axis.
    tank : Tank, optional
        Sets sqrt(g/h) (default: the paper tank).

    Returns
    -------
    omega_bar, a_bar : ndarray
    """
    tank = tank if tank is not None else Tank()
    env = SHAKER_ENVELOPE
    w0 = tank.reference_frequency
    ob = np.linspace(2 * math.pi * env.f_min / w0, 2 * math.pi * env.f_max / w0, n)
    ab = np.linspace(DEFAULT_A_BAR_MIN, env.a_bar_max, n)
    return ob, ab


#: tests per call of a JAX model's run in a map (memory: a delay-line network holds its
#: regressors, block x samples x delays)
JAX_BLOCK = 64


def _simulate_batches(model: SloshingModel,
                      batches: list[tuple[np.ndarray, np.ndarray]]) -> list[np.ndarray]:
    """``model.simulate`` of each (velocity, acceleration) batch, float64.

    A JAX model compiles its run once per input shape: its tests (whose lengths differ from
    one frequency to the next) run in blocks of :data:`JAX_BLOCK` tests of one shape, each test
    padded at the end with rest (the tests end at rest, and a causal model's output before the
    padding does not see it), the last block with tests at rest. The others (the rig, the
    frozen liquid) run batch by batch: padding would only add work.
    """
    if not batches:
        return []
    if not is_jax_model(model):
        return [np.asarray(model.simulate(v, a), dtype=np.float64) for v, a in batches]
    n = max(v.shape[1] for v, _ in batches)
    rows = sum(v.shape[0] for v, _ in batches)
    m = -(-rows // JAX_BLOCK) * JAX_BLOCK
    vel, acc = np.zeros((m, n)), np.zeros((m, n))
    k = 0
    for v, a in batches:
        vel[k:k + v.shape[0], : v.shape[1]] = v
        acc[k:k + a.shape[0], : a.shape[1]] = a
        k += v.shape[0]
    df = np.concatenate([np.asarray(model.simulate(vel[b:b + JAX_BLOCK], acc[b:b + JAX_BLOCK]),
                                    dtype=np.float64) for b in range(0, m, JAX_BLOCK)])
    out, k = [], 0
    for v, _ in batches:
        out.append(df[k:k + v.shape[0], : v.shape[1]])
        k += v.shape[0]
    return out


def phi_d_map(
    model: SloshingModel,
    omega_bar: Any,
    a_bar: Any,
    tank: Tank | None = None,
    n_cycles: int = 12,
    n_ramp: int = 3,
    settle_time: float = 0.5,
    f_min: float = SHAKER_ENVELOPE.f_min,
    f_max: float = SHAKER_ENVELOPE.f_max,
    gamma_max: float = SHAKER_ENVELOPE.gamma_max,
    a_bar_max: float = SHAKER_ENVELOPE.a_bar_max,
    progress: Callable[[int, int], None] | None = None,
) -> xr.DataArray:
    """Phi_d(omega_bar, a_bar) from batched ramped harmonic tests through ``model.simulate``.

    For each omega_bar all amplitudes inside the shaker envelope run as one batch at the model's
    step ``model.dt`` (a JAX model runs the tests of every frequency in blocks of one shape, the
    shorter tests padded with rest: one compilation, not one per frequency); points outside the
    envelope are NaN.

    Parameters
    ----------
    model : SloshingModel
        Rig, ROM or frozen liquid: ``dt``, ``force_rule`` (how its force samples integrate) and
        ``simulate(velocity, acceleration)`` on batches ``(n_runs, n)``.
    omega_bar, a_bar : array_like
        1-D grids of Omega / sqrt(g/h) and a / h.
    tank : Tank, optional
        Sets h, m_l. Default: the model's own tank (:func:`sloshrom.models.tank_of`: the virtual
        rig's); required for a model that does not carry one (a network, the frozen liquid).
    n_cycles : int
        Steady cycles evaluated per point.
    n_ramp : int
        Ramp cycles at each end.
    settle_time : float
        Time held at full amplitude before the evaluated cycles, s (at least 2 cycles).
    f_min, f_max, gamma_max, a_bar_max : float
        Shaker envelope (Hz, Hz, g, -); default :data:`sloshrom.signals.SHAKER_ENVELOPE`.
    progress : callable, optional
        Called as ``progress(done, total)`` after each frequency.

    Returns
    -------
    xarray.DataArray
        ``phi_d`` with dims ``(omega_bar, a_bar)``, coordinate ``frequency`` (Hz) on omega_bar,
        attrs with units and provenance.
    """
    tank = tank if tank is not None else tank_of(model)
    if tank is None:
        # a network does not know the tank it was identified on: guessing the paper's would
        # scale the map silently wrong for any other tank
        raise EnergyError(f"the {type(model).__name__} does not say which tank it simulates: "
                          "pass tank= (sloshrom.Tank(...); the paper's tank is Tank())")
    ob = np.atleast_1d(np.asarray(omega_bar, dtype=np.float64))
    ab = np.atleast_1d(np.asarray(a_bar, dtype=np.float64))
    if ob.ndim != 1 or ab.ndim != 1 or np.any(ob <= 0) or np.any(~np.isfinite(ab)):
        raise EnergyError("omega_bar and a_bar must be 1-D grids of positive numbers")
    fs = 1.0 / float(model.dt)
    rule = model.force_rule
    mask = shaker_envelope(ob, ab, tank, f_min, f_max, gamma_max, a_bar_max)
    out = np.full((ob.size, ab.size), np.nan)
    t0 = time.perf_counter()
    h_ref = tank.height
    w0 = tank.reference_frequency
    # the tests of each frequency: its in-envelope amplitudes, one batch
    tests = []
    for i, obi in enumerate(ob):
        cols = np.flatnonzero(mask[i])
        if cols.size:
            freq = obi * w0 / (2 * math.pi)
            if fs < 8 * freq:
                raise EnergyError(f"model rate {fs} Hz too low for {freq:.1f} Hz")
            n_settle = max(2, int(math.ceil(settle_time * freq)))
            sigs = [
                harmonic(fs, freq, ab[j] * h_ref, n_cycles=n_cycles, n_ramp=n_ramp,
                         n_settle=n_settle)
                for j in cols
            ]
            tests.append((i, cols, freq, sigs))
    forces = _simulate_batches(model, [(np.stack([s.velocity for s in sigs]),
                                        np.stack([s.acceleration for s in sigs]))
                                       for _, _, _, sigs in tests])
    done = 0
    for (i, cols, freq, sigs), df in zip(tests, forces, strict=True):
        sl = sigs[0].steady
        disp = np.stack([s.displacement for s in sigs])
        # include the sample that closes the last cycle
        seg = slice(sl.start, sl.stop + 1)
        l_d = dissipated_energy(disp[:, seg], df[:, seg], n_cycles=n_cycles, rule=rule)
        out[i, cols] = phi_d(l_d, ab[cols] * h_ref, 2 * math.pi * freq, tank.liquid_mass)
        if progress is not None:
            # the frequencies before this one with no point inside the envelope are done too
            done = i + 1
            progress(done, ob.size)
    if progress is not None and done < ob.size:
        progress(ob.size, ob.size)
    elapsed = time.perf_counter() - t0
    da = xr.DataArray(
        out,
        dims=("omega_bar", "a_bar"),
        coords={
            "omega_bar": ("omega_bar", ob, {"units": "1", "long_name": "Omega / sqrt(g/h)"}),
            "a_bar": ("a_bar", ab, {"units": "1", "long_name": "a / h"}),
            "frequency": ("omega_bar", ob * w0 / (2 * math.pi), {"units": "Hz"}),
        },
        name="phi_d",
        attrs={
            "units": "1",
            "long_name": "non-dimensional dissipated energy L_d / (m_l a^2 Omega^2)",
            "model": type(model).__name__,
            "model_dt": float(model.dt),
            "n_cycles": int(n_cycles),
            "n_ramp": int(n_ramp),
            "settle_time": float(settle_time),
            "envelope": f"{f_min}-{f_max} Hz, Gamma <= {gamma_max} g, a_bar <= {a_bar_max}",
            "tank_height": tank.height,
            "tank_fill": tank.fill,
            "liquid_mass": tank.liquid_mass,
            "elapsed_s": elapsed,
            "provenance": "sloshrom.energy.phi_d_map (ramped harmonic tests)",
            "sloshrom_version": __version__,
            # provenance only (not part of the contract): -1 for models without a seed
            "model_seed": int(getattr(model, "seed", -1)),
        },
    )
    return da


def map_maximum(da: xr.DataArray) -> dict[str, float]:
    """Location and value of the maximum of a Phi_d map (omega_bar, a_bar, Gamma, Hz)."""
    vals = np.asarray(da.values)
    if np.all(np.isnan(vals)):
        raise EnergyError("the map is all NaN")
    i, j = np.unravel_index(np.nanargmax(vals), vals.shape)
    ob = float(da.omega_bar[i])
    ab = float(da.a_bar[j])
    return {
        "phi_d": float(vals[i, j]),
        "omega_bar": ob,
        "a_bar": ab,
        "gamma": ab * ob**2,
        "frequency": float(da.frequency[i]) if "frequency" in da.coords else float("nan"),
    }


def _point_coords(da: Any, index: tuple[int, ...]) -> tuple[float, float]:
    """(omega_bar, a_bar) of one grid point of ``da``; NaN where ``da`` does not carry them."""
    if not isinstance(da, xr.DataArray):
        return float("nan"), float("nan")
    point = da.isel(dict(zip(da.dims, index, strict=True)))
    return tuple(  # type: ignore[return-value]
        float(point[name]) if name in point.coords else float("nan")
        for name in ("omega_bar", "a_bar")
    )


def _relative_l2(r: np.ndarray, o: np.ndarray) -> float:
    """``||o - r|| / ||r||`` (-), NaN for no points or a zero reference."""
    norm = np.linalg.norm(r)
    if r.size == 0 or norm == 0:
        return float("nan")
    return float(np.linalg.norm(o - r) / norm)


def map_fidelity(
    reference: Any,
    other: Any,
    dissipative_threshold: float = DISSIPATIVE_THRESHOLD,
    passivity_tolerance: float = PASSIVITY_TOLERANCE,
) -> dict[str, float | int]:
    """How well the Phi_d map ``other`` (a ROM) matches ``reference`` (the rig): whole map first.

    Every figure is computed on the points where both maps are finite (NaN marks points outside
    the shaker envelope). A single error over the dissipative region hides what the model does
    everywhere else, in particular whether it stays passive (Phi_d >= 0: the liquid can only
    take energy from the tank), so the whole map, the dissipative region and the passivity are
    reported side by side.

    Parameters
    ----------
    reference, other : array_like or xarray.DataArray
        Phi_d maps (-) on the same grid, e.g. dims ``(omega_bar, a_bar)``. DataArrays with the
        same dims in another order are aligned; differing grid coordinates raise.
    dissipative_threshold : float
        The dissipative region is where ``reference > dissipative_threshold * max(reference)``
        (-, fraction of the reference maximum).
    passivity_tolerance : float
        A point is non-passive where ``other < -passivity_tolerance * max(reference)`` (-,
        fraction of the reference maximum): small negative values are numerical noise.

    Returns
    -------
    dict
        Plain ``float``/``int`` values (NaN where undefined, e.g. an empty region):

        ``full_l2``
            ``||o - r|| / ||r||`` over all compared points (-).
        ``dissipative_l2``
            The same over the dissipative region only (-).
        ``n_points``, ``n_dissipative``, ``n_nonpassive``
            Compared points, those in the dissipative region, those below the passivity
            threshold.
        ``nonpassive_fraction``
            ``n_nonpassive / n_points`` (-).
        ``min_phi_d``, ``min_omega_bar``, ``min_a_bar``
            The smallest (most negative) value of ``other`` (-) and where it is (-; NaN unless
            ``other`` or ``reference`` is a DataArray with ``omega_bar``/``a_bar`` coordinates).
        ``reference_maximum``
            ``max(reference)`` over its finite points (-).
        ``dissipative_threshold``, ``dissipative_level``
            The fraction passed and the Phi_d level it sets (-).
        ``passivity_tolerance``, ``passivity_threshold``
            The fraction passed and the Phi_d level it sets, ``-passivity_tolerance *
            max(0, reference_maximum)`` (-).

    Raises
    ------
    ValueError
        The maps differ in shape or grid, or a fraction is negative or not finite.
    """
    for name, value in (("dissipative_threshold", dissipative_threshold),
                        ("passivity_tolerance", passivity_tolerance)):
        if not (math.isfinite(value) and value >= 0):
            raise EnergyError(f"{name} must be a finite number >= 0, got {value}")
    if isinstance(reference, xr.DataArray) and isinstance(other, xr.DataArray):
        if set(reference.dims) == set(other.dims):
            other = other.transpose(*reference.dims)
        for dim in reference.dims:
            if dim in reference.coords and dim in other.coords and not np.allclose(
                reference[dim].values, other[dim].values, rtol=1e-9, equal_nan=True
            ):
                raise EnergyError(f"the maps have different {dim} grids")
    r = np.asarray(reference, dtype=np.float64)
    o = np.asarray(other, dtype=np.float64)
    if r.shape != o.shape:
        raise EnergyError(f"the maps differ in shape: reference {r.shape}, other {o.shape}")
    finite = np.isfinite(r) & np.isfinite(o)
    r_max = float(np.max(r[np.isfinite(r)])) if np.isfinite(r).any() else float("nan")
    level = dissipative_threshold * r_max
    # a reference with no positive value dissipates nowhere: empty region, zero tolerance
    if r_max > 0:
        dissipative = finite & (r > level)
        pass_thr = -passivity_tolerance * r_max
    else:
        dissipative = np.zeros_like(finite)
        pass_thr = 0.0 if math.isfinite(r_max) else float("nan")
    nonpassive = finite & (o < pass_thr)
    n_points = int(finite.sum())
    n_nonpassive = int(nonpassive.sum())
    if n_points:
        flat = np.where(finite, o, np.inf)
        idx = np.unravel_index(int(np.argmin(flat)), o.shape)
        min_phi = float(o[idx])
        coords_from = other if isinstance(other, xr.DataArray) else reference
        min_ob, min_ab = _point_coords(coords_from, idx)
    else:
        min_phi = min_ob = min_ab = float("nan")
    return {
        "full_l2": _relative_l2(r[finite], o[finite]),
        "dissipative_l2": _relative_l2(r[dissipative], o[dissipative]),
        "n_points": n_points,
        "n_dissipative": int(dissipative.sum()),
        "n_nonpassive": n_nonpassive,
        "nonpassive_fraction": n_nonpassive / n_points if n_points else float("nan"),
        "min_phi_d": min_phi,
        "min_omega_bar": min_ob,
        "min_a_bar": min_ab,
        "reference_maximum": r_max,
        "dissipative_threshold": float(dissipative_threshold),
        "dissipative_level": float(level),
        "passivity_tolerance": float(passivity_tolerance),
        "passivity_threshold": float(pass_thr),
    }
