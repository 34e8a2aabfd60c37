"""The bouncing-ball equivalent mechanical model of vertical sloshing: the physics baseline.

Violent vertical sloshing is, to first order, a lump of liquid thrown off the floor when the tank
accelerates downward faster than gravity, flying through the ullage and slamming back (or into
the lid). The classical equivalent mechanical model keeps exactly that and nothing else:

* the liquid mass ``m_l`` (``Tank.liquid_mass``) is split into a *frozen* part ``(1 - beta) m_l``
  that moves with the tank (no dynamic force) and a *ball* of mass ``m_b = beta m_l``;
* the ball moves vertically in the gap between the liquid surface at rest (``z = 0``) and the
  ceiling (``z = Gap``), ``Gap = gamma * Tank.ullage``; ``z`` is its position relative to the
  tank, up positive, and ``w''`` the tank's vertical acceleration (the input, m/s^2, up
  positive);
* in flight ``z'' = -(g + w'')``; it rests on the floor (``z = 0, z' = 0``) while ``g + w'' >= 0``
  and lifts off when ``g + w'' < 0``; symmetrically it rests against the ceiling while
  ``g + w'' < 0``;
* an impact on the floor or the ceiling reverses the relative velocity with restitution ``e``,
  ``z'+ = -e z'-``, and dissipates ``m_b (1 - e^2) z'-^2 / 2``. A rebound slower than
  ``REST_SPEED`` (10 µm/s: a hop of 5e-12 m) off a wall the ball is pushed onto makes it rest
  there instead (no Zeno chatter); the whole impact energy ``m_b z'-^2 / 2`` is then
  dissipated. The rule does not depend on the step, so the model's physics does not either.

Three parameters are identified from force data (:class:`BouncingBall`): the mass fraction
``beta``, the restitution ``e`` and the gap factor ``gamma``.

Dynamic force
-------------
The package's dynamic force (paper Eq. 2) is ``dF = f_S + m_l w''``, ``f_S`` the force the liquid
exerts on the tank with the static weight removed (the load cells are tared). Newton's law for
the frozen part, which moves with the tank, and for the ball, whose absolute acceleration is
``w'' + z''``, gives the force of the tank on the liquid ``(1 - beta) m_l w'' + m_b (w'' + z'')``
beyond the weight; the liquid pushes back with the opposite, so

    f_S = -m_l w'' - m_b z''      and      dF = -m_b z''

(minus the liquid mass times the acceleration of its centre of mass relative to the tank, as for
the virtual rig). In flight ``dF = m_b (g + w'')``; at rest ``dF = 0``; an impact is an impulse
``-m_b (z'+ - z'-)``.

Discrete step (force rule ``"step"``)
-------------------------------------
The input acceleration ``a_k`` is held over ``[t_k, t_k+1]`` (zero-order hold) and the motion is
integrated *exactly* and event-driven: the parabolic flight ``z(t) = z + z' t - (g + a_k) t^2/2``
is advanced to the first root of ``z(t) = 0`` or ``z(t) = Gap`` inside the step (a quadratic,
solved in the cancellation-free form), the impact or the rest is applied, and the flight goes on
to the end of the step. The output is the exact average of ``dF`` over the step, impulses
included:

    dF_k = -m_b (z'(t_k+1) - z'(t_k)) / dt.

Energy bookkeeping, exact to round-off: with ``a_k`` held, the tank's pseudo-force ``-m_b w''``
does the work ``W_k = -m_b a_k (z(t_k+1) - z(t_k))`` on the relative motion in step k, and
``sum W_k = Delta(m_b z'^2/2 + m_b g z) + (dissipated energy)``. The absolute work of the tank on
the liquid, ``-integral dF w' dt``, differs from ``sum W_k`` by the boundary term
``m_b [z' w']``: over a record that starts and ends at rest the tank's work equals the impact
losses. The state accumulates both the dissipated energy and ``sum W_k``
(:data:`STATE_NAMES`).

What the step cannot make exact is what a *user* of the force does with it: the Phi_d maps
(``-sum dF_k (w_k+1 - w_k)``) and the coupled beam (the force held over the step) meet an
impulse as a force spread over its whole step, which misplaces its work by up to the tank's
velocity change over a step. At the record rate (2 ms) that error is of the order of the impact
losses themselves at 20 Hz; the fitted model therefore runs at a finer step, ``n_substeps`` per
record sample (default: the rig's 1e-4 s), while it is identified at the record rate, which with
the acceleration held over each sample is exactly the same physics (:class:`BouncingBall`).

The kernel (:func:`ball_kernel_step`) is numba-compiled: a fitted :class:`BouncingBall` is a
:class:`sloshrom.models.CompiledKernel`, so the coupled beam simulation runs it in its numba
loop, and :meth:`BouncingBall.simulate` runs batches (leading axes) in one compiled loop.
"""

from __future__ import annotations

import math
import operator
import time
import tomllib
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, ClassVar, Literal

import numpy as np
import tomli_w
from scipy.fft import rfft
from scipy.optimize import differential_evolution

from sloshrom import __version__
from sloshrom._jit import njit
from sloshrom.config import ConfigError, G, Tank
from sloshrom.fileio import atomic_write_text, not_a_regular_file
from sloshrom.rom.ball.entry import (
    BALL_FORMAT,
    BALL_FORMAT_VERSION,
    LIMITS,
    MAX_MODEL_STEP,
    is_ball_file,
)
from sloshrom.rom.errors import NotFittedError, ROMError
from sloshrom.rom.modelfile import ModelFileError
from sloshrom.signals import power_band

__all__ = [
    "BALL_FORMAT",
    "BALL_FORMAT_VERSION",
    "LIMITS",
    "MAX_MODEL_STEP",
    "REST_SPEED",
    "STATE_NAMES",
    "Ball",
    "BouncingBall",
    "ball_kernel_step",
    "forward_acceleration",
    "is_ball_file",
    "lowpass_gain",
]

#: A rebound slower than this off a wall the ball is pushed against ends in rest, m/s.
REST_SPEED = 1e-5

#: The kernel's state vector, in order: relative position (m) and velocity (m/s), contact
#: (0 flight, 1 resting on the floor, 2 resting against the ceiling), dissipated energy (J),
#: number of impacts (-), work of the tank's pseudo-force on the relative motion (J).
STATE_NAMES = ("z", "zdot", "contact", "dissipated", "impacts", "work")

_S_Z, _S_V, _S_CONTACT, _S_LOSS, _S_IMPACTS, _S_WORK = range(6)
_N_STATE = 6
_FLIGHT, _FLOOR, _CEILING = 0.0, 1.0, 2.0
# params: [Gap (m), m_b (kg), e (-), g (m/s^2), dt (s)]
_P_GAP, _P_MASS, _P_E, _P_G, _P_DT = range(5)
_N_PARAMS = 5
#: events (impacts, lift-offs) handled in one step at most: with e < 1 a chatter from 1 m/s down
#: to REST_SPEED takes log(1e-5)/log(e) bounces (1100 for e = 0.99); a step that would need more
#: (e = 1 against a wall) ends the chatter in rest
_MAX_EVENTS = 100_000


# --------------------------------------------------------------------------------------------
# Numba kernel
# --------------------------------------------------------------------------------------------


@njit
def _first_exit(h: float, b: float, c: float, tau: float) -> float:
    """First ``t`` in ``[0, tau]`` at which ``p(t) = h t^2 + b t + c`` (``c >= 0``) turns negative.

    ``p`` is the distance to a wall (allowed side ``p >= 0``). Returns -1 if there is none.
    """
    if c <= 0.0:
        # on the wall: moving into it (or pushed into it from rest) is an impact now
        if b < 0.0 or (b == 0.0 and h < 0.0):
            return 0.0
        if h < 0.0:  # leaving; the other root is the return
            t = -b / h
            return t if t <= tau else -1.0
        return -1.0
    if h == 0.0:
        if b < 0.0:
            t = -c / b
            return t if t <= tau else -1.0
        return -1.0
    disc = b * b - 4.0 * h * c
    if disc < 0.0:
        return -1.0
    # roots q/h and c/q without cancellation; q != 0 because c > 0
    q = -0.5 * (b + math.copysign(math.sqrt(disc), b))
    r1 = q / h
    r2 = c / q
    best = -1.0
    if 0.0 < r1 <= tau:
        best = r1
    if 0.0 < r2 <= tau and (best < 0.0 or r2 < best):
        best = r2
    return best


@njit
def ball_kernel_step(state: np.ndarray, params: np.ndarray, velocity: float,
                     acceleration: float) -> float:
    """Advance the ball by one step ``dt`` in place; return the step-average dynamic force, N.

    Parameters
    ----------
    state : ndarray, shape (6,)
        :data:`STATE_NAMES`; updated in place.
    params : ndarray, shape (5,)
        ``[Gap (m), m_b (kg), e (-), g (m/s^2), dt (s)]``.
    velocity : float
        Tank vertical velocity, m/s (unused: the ball feels the acceleration only).
    acceleration : float
        Tank vertical acceleration, m/s^2, held over the step.
    """
    gap = params[_P_GAP]
    m = params[_P_MASS]
    e = params[_P_E]
    dt = params[_P_DT]
    geff = params[_P_G] + acceleration
    acc = -geff  # relative acceleration in flight
    z = state[_S_Z]
    v = state[_S_V]
    contact = state[_S_CONTACT]
    z0 = z
    v0 = v
    tau = dt
    loss = 0.0
    impacts = 0.0
    done = False
    for _ in range(_MAX_EVENTS):
        if contact == _FLOOR:
            if geff >= 0.0:
                done = True  # stays on the floor for the rest of the step
                break
            contact = _FLIGHT  # lift-off from z = 0, z' = 0
        elif contact == _CEILING:
            if geff < 0.0:
                done = True
                break
            contact = _FLIGHT
        t_floor = _first_exit(0.5 * acc, v, z, tau)
        t_ceil = _first_exit(-0.5 * acc, -v, gap - z, tau)
        if t_floor < 0.0 and t_ceil < 0.0:
            z = z + tau * (v + 0.5 * acc * tau)
            v = v + acc * tau
            z = min(max(z, 0.0), gap)  # round-off only: the flight stays inside
            done = True
            break
        if t_ceil < 0.0 or (t_floor >= 0.0 and t_floor <= t_ceil):
            t = t_floor
            z = 0.0
            pushed = geff >= 0.0  # onto the floor
            wall = _FLOOR
        else:
            t = t_ceil
            z = gap
            pushed = geff < 0.0
            wall = _CEILING
        v_hit = v + acc * t
        tau -= t
        impacts += 1.0
        v_out = -e * v_hit
        if pushed and abs(v_out) <= REST_SPEED:
            loss += 0.5 * m * v_hit * v_hit
            v = 0.0
            contact = wall
        else:
            loss += 0.5 * m * (1.0 - e * e) * v_hit * v_hit
            v = v_out
        if tau <= 0.0:
            done = True
            break
    if not done and contact == _FLIGHT:
        # chatter beyond _MAX_EVENTS in one step: it ends in rest against the pushing wall
        if z == 0.0 and geff >= 0.0:
            contact = _FLOOR
        elif z == gap and geff < 0.0:
            contact = _CEILING
        if contact != _FLIGHT:
            loss += 0.5 * m * v * v
            v = 0.0
    state[_S_Z] = z
    state[_S_V] = v
    state[_S_CONTACT] = contact
    state[_S_LOSS] += loss
    state[_S_IMPACTS] += impacts
    state[_S_WORK] += -m * acceleration * (z - z0)
    return -m * (v - v0) / dt


@njit(inline="always")
def _rest(state: np.ndarray) -> None:
    for i in range(state.size):
        state[i] = 0.0
    state[_S_CONTACT] = _FLOOR


@njit
def _simulate_rows(params: np.ndarray, acc: np.ndarray) -> np.ndarray:
    """Dynamic force (N) of independent runs from rest: ``acc`` of shape (runs, n)."""
    out = np.empty_like(acc)
    st = np.empty(_N_STATE)
    for r in range(acc.shape[0]):
        _rest(st)
        for k in range(acc.shape[1]):
            out[r, k] = ball_kernel_step(st, params, 0.0, acc[r, k])
    return out


@njit
def _mse_rows(param_rows: np.ndarray, acc: np.ndarray, target: np.ndarray) -> np.ndarray:
    """Mean squared error (N^2) of the force of each parameter row against ``target``."""
    n = target.size
    out = np.empty(param_rows.shape[0])
    st = np.empty(_N_STATE)
    for s in range(param_rows.shape[0]):
        p = param_rows[s]
        _rest(st)
        sse = 0.0
        for k in range(n):
            d = ball_kernel_step(st, p, 0.0, acc[k]) - target[k]
            sse += d * d
        out[s] = sse / n
    return out


# --------------------------------------------------------------------------------------------
# Helpers
# --------------------------------------------------------------------------------------------


def forward_acceleration(velocity: Any, fs: float) -> np.ndarray:
    """The acceleration held over each step: ``a_k = (u_k+1 - u_k) fs``, m/s^2 (last axis).

    The forward difference is the exact mean acceleration over ``[t_k, t_k+1]``, so the
    zero-order-hold tank motion it drives passes through every velocity sample. The last sample
    repeats the one before (one sample, after the last output that uses it).
    """
    u = np.asarray(velocity, dtype=np.float64)
    if u.shape[-1] < 2:
        raise ROMError("need at least two velocity samples to derive the acceleration")
    d = np.diff(u, axis=-1) * float(fs)
    return np.concatenate([d, d[..., -1:]], axis=-1)


def _signal(name: str, x: Any, allow_batch: bool = False) -> np.ndarray:
    try:
        a = np.asarray(x, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise ROMError(f"{name} must be an array of numbers ({exc})") from None
    if a.ndim == 0 or (a.ndim != 1 and not allow_batch):
        shape = "(..., n)" if allow_batch else "(n,)"
        raise ROMError(f"{name} must have shape {shape}, got {a.shape}")
    if not np.all(np.isfinite(a)):
        bad = int(np.argmin(np.isfinite(a).ravel()))
        raise ROMError(f"{name} contains NaN or inf (first at flat index {bad})")
    return a


def _number(name: str, v: Any) -> float:
    if isinstance(v, bool) or not isinstance(v, int | float | np.integer | np.floating):
        raise ROMError(f"{name} must be a number, got {v!r}")
    f = float(v)
    if not math.isfinite(f):
        raise ROMError(f"{name} must be finite, got {v!r}")
    return f


def _integer(name: str, v: Any, lo: int) -> int:
    try:
        i = operator.index(v)
    except TypeError:
        raise ROMError(f"{name} must be an integer, got {v!r}") from None
    if isinstance(v, bool) or i < lo:
        raise ROMError(f"{name} must be an integer >= {lo}, got {v!r}")
    return i


def _in_limits(name: str, value: float) -> bool:
    lo, hi, open_lo = LIMITS[name]
    return (value > lo if open_lo else value >= lo) and value <= hi


def _limits_text(name: str) -> str:
    lo, hi, open_lo = LIMITS[name]
    return f"{'(' if open_lo else '['}{lo:g}, {hi:g}]"


def _bounds(name: str, v: Any) -> tuple[float, float]:
    """A (low, high) search bound inside the parameter's physical limits."""
    if isinstance(v, str) or not isinstance(v, Sequence) or len(v) != 2:
        raise ROMError(f"{name} must be a (low, high) pair, got {v!r}")
    lo, hi = _number(f"{name}[0]", v[0]), _number(f"{name}[1]", v[1])
    if lo > hi:
        raise ROMError(f"{name} bounds out of order: low {lo:g} > high {hi:g}")
    for x in (lo, hi):
        if not _in_limits(name, x):
            raise ROMError(f"{name} bound {x:g} outside the physical range "
                           f"{_limits_text(name)}")
    return lo, hi


def _step_average(y: np.ndarray) -> np.ndarray:
    """Samples at t_k -> averages over [t_k, t_k+1] (trapezoid), n - 1 values."""
    return 0.5 * (y[..., 1:] + y[..., :-1])


def lowpass_gain(f: Any, cutoff: float) -> np.ndarray:
    """Gain (-) of the objective's zero-phase low-pass at frequencies ``f`` (Hz).

    ``1 / (1 + (f / cutoff)^8)``: a 4th-order Butterworth run forward and backward (what
    ``scipy.signal.sosfiltfilt`` does), -6 dB at ``cutoff`` (Hz).
    """
    return 1.0 / (1.0 + (np.asarray(f, dtype=np.float64) / cutoff) ** 8)


class _ForceError:
    """Mean squared error (N^2) of forces against a fixed target, low-passed or not.

    Low-passed, the error is evaluated in the frequency domain (Parseval): the target's
    spectrum is computed once and each candidate costs one real FFT.
    """

    def __init__(self, target: np.ndarray, fs: float, cutoff: float | None) -> None:
        self.target = np.ascontiguousarray(target)
        n = self.target.size
        self.n = n
        self.cutoff = cutoff
        if cutoff is None:
            self.weight = None
            self.power = float(np.mean(self.target**2))
            return
        f = np.fft.rfftfreq(n, 1.0 / fs)
        c = np.full(f.size, 2.0)  # one-sided spectrum: every bin but DC (and Nyquist) twice
        c[0] = 1.0
        if n % 2 == 0:
            c[-1] = 1.0
        self.weight = c * lowpass_gain(f, cutoff) ** 2 / (n * n)
        self.spectrum = rfft(self.target)
        self.power = float(np.sum(self.weight * np.abs(self.spectrum) ** 2))

    def of_force(self, force: np.ndarray) -> float:
        if self.weight is None:
            return float(np.mean((force - self.target) ** 2))
        return float(np.sum(self.weight * np.abs(rfft(force) - self.spectrum) ** 2))

    def of_params(self, rows: np.ndarray, acc: np.ndarray) -> np.ndarray:
        """The error of the ball of each parameter row (shape (S, 5)) driven by ``acc``."""
        if self.weight is None:
            return _mse_rows(rows, acc, self.target)
        out = np.empty(rows.shape[0])
        for i, p in enumerate(rows):  # one row at a time: bounded memory
            out[i] = self.of_force(_simulate_rows(p, acc[None])[0])
        return out

    def nrmse(self, mse: float) -> float:
        """``sqrt(mse / mean(target^2))`` on the same (filtered or not) measure, -."""
        return float(np.sqrt(mse / self.power)) if self.power > 0 else float("nan")


# --------------------------------------------------------------------------------------------
# Estimator
# --------------------------------------------------------------------------------------------


def _rest_state() -> np.ndarray:
    st = np.zeros(_N_STATE)
    st[_S_CONTACT] = _FLOOR
    return st


@dataclass(frozen=True)
class Ball:
    """A fitted bouncing ball: an immutable sloshing model with a numba kernel.

    The model :class:`BouncingBall` fits and delegates to (the networks' split of model and
    estimator). Its step is exact for the acceleration held over the step.

    Parameters
    ----------
    mass_fraction : float
        ``beta = m_b / m_l``, in (0, 1].
    restitution : float
        Coefficient of restitution ``e``, in [0, 1].
    gap : float
        Free travel of the ball, m.
    dt : float
        The model step, s.
    tank : Tank
        The tank and liquid (``m_l``; its fill is the one the ball stands for).
    """

    mass_fraction: float
    restitution: float
    gap: float
    dt: float
    tank: Tank

    #: output k is the average force over [t_k, t_k+1] (for energy integrals)
    force_rule: ClassVar[Literal["step"]] = "step"
    #: the numba kernel is the fast path; the step is not a JAX function
    jax_traceable: ClassVar[bool] = False
    #: the signal the ball reads: its step is driven by the tank acceleration alone
    input: ClassVar[Literal["acceleration"]] = "acceleration"

    @property
    def ball_mass(self) -> float:
        """``m_b = beta m_l``, kg."""
        return self.mass_fraction * self.tank.liquid_mass

    @property
    def fill_range(self) -> tuple[float, float]:
        """``(fill, fill)`` of the tank: the one fill level the ball stands for (-)."""
        f = float(self.tank.fill)
        return f, f

    def params(self, dt: float | None = None) -> np.ndarray:
        """Kernel parameters at the model step (or at ``dt``, s: the kernel is exact for any
        step with the acceleration held over it)."""
        p = np.empty(_N_PARAMS)
        p[_P_GAP] = self.gap
        p[_P_MASS] = self.ball_mass
        p[_P_E] = self.restitution
        p[_P_G] = G
        p[_P_DT] = self.dt if dt is None else dt
        return p

    def init_state(self) -> np.ndarray:
        """At rest on the floor: :data:`STATE_NAMES` ``(0, 0, 1, 0, 0, 0)``."""
        return _rest_state()

    def step(self, state: Any, velocity: Any, acceleration: Any) -> tuple[np.ndarray, float]:
        """Pure step: ``(new_state, dynamic_force)`` (N); ``state`` is not modified.

        ``acceleration`` (m/s^2) is held over the step; ``velocity`` is ignored.
        """
        st = np.array(state, dtype=np.float64, copy=True)
        if st.shape != (_N_STATE,):
            raise ROMError(f"state must be a 1-D array of {_N_STATE} values (init_state())")
        f = ball_kernel_step(st, self.params(), 0.0, float(acceleration))
        return st, f

    def simulate_acceleration(self, acceleration: Any, dt: float | None = None) -> np.ndarray:
        """Force (N) from rest for accelerations (m/s^2, (..., n)) held over steps of ``dt``
        (s, default the model step)."""
        a = np.asarray(acceleration, dtype=np.float64)
        flat = np.ascontiguousarray(a.reshape(-1, a.shape[-1]))
        return _simulate_rows(self.params(dt), flat).reshape(a.shape)

    def simulate(self, velocity: Any, acceleration: Any = None) -> np.ndarray:
        """Dynamic force (N) for tank acceleration (m/s^2) sampled at ``1 / dt``.

        Arrays of shape ``(..., n)`` (broadcast together); leading axes are independent runs,
        each from :meth:`init_state`. ``velocity`` (m/s) is ignored unless ``acceleration`` is
        ``None``, when the acceleration is its forward difference
        (:func:`forward_acceleration`).
        """
        if acceleration is None:
            v = _signal("velocity", velocity, allow_batch=True)
            return self.simulate_acceleration(forward_acceleration(v, 1.0 / self.dt))
        a = _signal("acceleration", acceleration, allow_batch=True)
        shape = np.broadcast_shapes(np.shape(velocity), a.shape)
        return self.simulate_acceleration(np.broadcast_to(a, shape))

    def kernel(self) -> tuple[Any, np.ndarray, np.ndarray]:
        """``(step_fn, params, state)`` for numba loops (:func:`sloshrom.models.has_kernel`).

        ``step_fn(state, params, velocity, acceleration) -> dynamic_force`` is
        :func:`ball_kernel_step`; it advances ``state`` (float64, :data:`STATE_NAMES`) in place
        by one step ``dt``.
        """
        return ball_kernel_step, self.params(), self.init_state()


class BouncingBall:
    """Bouncing-ball equivalent mechanical model, identified from force data.

    A scikit-learn style estimator (the constructor only stores its arguments, :meth:`fit`
    validates them and returns self, learned attributes end in ``_``) and, once fitted, a
    sloshing model (:mod:`sloshrom.models`: force rule ``"step"``, a numba kernel, a training
    envelope). The physics is in the module docstring.

    Parameters
    ----------
    tank : Tank, optional
        Tank and liquid: ``liquid_mass`` sets the ball mass ``beta m_l``, ``ullage`` the gap
        ``gamma * ullage`` (default: the paper tank).
    mass_fraction : (float, float)
        Search bounds of ``beta = m_b / m_l``, in (0, 1].
    restitution : (float, float)
        Search bounds of the restitution ``e``, in [0, 1].
    gap_factor : (float, float)
        Search bounds of ``gamma = Gap / ullage``, in (0, 10].
    seed : int
        Seeds the optimiser (>= 0); the fit is deterministic.
    lowpass : "input", float or None
        Low-pass of the force error in the objective: ``"input"`` (default) cuts at the upper
        edge of the band holding 99.8 % of the training input's power, a number is the cutoff
        in Hz, ``None`` is the plain MSE. Why: a force component at a frequency where the tank
        does not move does no work on it (Parseval: ``integral dF w' dt = sum_f Re F(f)
        conj(V(f))``), so the force inside the input's band carries the whole energy exchange
        that Phi_d and the beam's damping measure; above it, the ball's impulses (one sample
        each) against the rig's smoother, sensor-filtered pulses dominate a plain MSE, whose
        optimum is then the smallest ball the bounds allow (docs/rom.md).
    n_substeps : int or None
        Model steps per sample of the training record (>= 1): the fitted model's ``dt`` is
        ``1 / (fs_ * n_substeps)``, the step at which the Phi_d maps and the coupled beam run
        it (their inputs are smooth, sampled at ``1 / dt``). Default ``None``: the fewest that
        make ``dt <= MAX_MODEL_STEP`` (20 at 500 Hz: 10 kHz, the rig's step). Why: the maps
        and the beam integrate the impulses at the model step (the force held over the step of
        the impact), which at 500 Hz misplaces the work of an impact by up to a step; at 500 Hz
        this alone made a fitted ball's map non-passive at 5 points (docs/rom.md). The
        identification is not affected: :meth:`fit` and :meth:`predict` run at the record rate,
        exactly what ``n_substeps`` model steps with the acceleration held over the sample give.
    maxiter : int
        Generations of differential evolution at most (>= 1).
    popsize : int
        Population size per parameter of differential evolution (>= 2).
    tol : float
        Relative convergence tolerance of differential evolution (>= 0).

    Attributes
    ----------
    mass_fraction_, restitution_ : float
        Identified ``beta`` and ``e``, -.
    gap_ : float
        Identified gap, m.
    fs_ : float
        Sample rate of the training record, Hz (:meth:`predict` works at this rate).
    n_substeps_ : int
        Model steps per record sample: the model's step is ``dt = 1 / (fs_ * n_substeps_)``.
    envelope_ : dict
        ``input_min``, ``input_max`` (training acceleration, m/s^2: the ball's
        :attr:`input`), ``output_min``, ``output_max``
        (training force, N), ``frequency_band`` (Hz, central 98 % of the input power),
        ``acceleration_max`` (peak |acceleration| of the training record, m/s^2): the keys of
        the networks' envelopes, so the beam's envelope checks apply.
    history_ : dict
        ``objective`` (training MSE of the low-passed force, N^2), ``nrmse`` (its root over
        the RMS of the low-passed record, -), ``lowpass_hz`` (the cutoff, NaN for the plain
        MSE), ``evaluations`` (ball simulations), ``generations``, ``seconds``, ``converged``,
        ``n_samples`` and, with a validation record, ``validation_mse`` (N^2),
        ``validation_nrmse`` (-, same measure) and ``validation_nrmse_unfiltered`` (-).

    Examples
    --------
    >>> ball = BouncingBall(seed=0).fit(u, y, fs=500.0)                   # doctest: +SKIP
    >>> ball.mass_fraction_, ball.restitution_, ball.gap_                  # doctest: +SKIP
    >>> df = ball.simulate(velocity, acceleration)                        # doctest: +SKIP
    """

    force_rule = Ball.force_rule
    jax_traceable = Ball.jax_traceable
    #: the signal the ball reads, and the one its envelope's input range describes
    input = Ball.input
    #: the record variables and units the ball is identified from (as the networks'; the
    #: acceleration driving the ball is given beside them or derived from the velocity)
    names: ClassVar[tuple[str, str]] = ("velocity", "dynamic_force")
    units: ClassVar[tuple[str, str]] = ("m/s", "N")

    def __init__(
        self,
        tank: Tank | None = None,
        mass_fraction: tuple[float, float] = (0.05, 1.0),
        restitution: tuple[float, float] = (0.0, 0.95),
        gap_factor: tuple[float, float] = (0.2, 2.0),
        seed: int = 0,
        lowpass: float | str | None = "input",
        n_substeps: int | None = None,
        maxiter: int = 30,
        popsize: int = 10,
        tol: float = 1e-3,
    ) -> None:
        self.tank = tank
        self.mass_fraction = mass_fraction
        self.restitution = restitution
        self.gap_factor = gap_factor
        self.seed = seed
        self.lowpass = lowpass
        self.n_substeps = n_substeps
        self.maxiter = maxiter
        self.popsize = popsize
        self.tol = tol

    # -- hyperparameters ----------------------------------------------------------------------
    _PARAM_NAMES: ClassVar[tuple[str, ...]] = (
        "tank", "mass_fraction", "restitution", "gap_factor", "seed", "lowpass", "n_substeps",
        "maxiter", "popsize", "tol")

    def get_params(self, deep: bool = True) -> dict[str, Any]:
        """Every constructor argument by name (``deep`` accepted for scikit-learn)."""
        return {k: getattr(self, k) for k in self._PARAM_NAMES}

    def set_params(self, **params: Any) -> BouncingBall:
        """Set constructor arguments by name (checked by the next :meth:`fit`); returns self.

        Raises
        ------
        ROMError
            A name that is not a constructor argument.
        """
        for k, v in params.items():
            if k not in self._PARAM_NAMES:
                raise ROMError(f"BouncingBall has no parameter {k!r} "
                               f"(valid: {', '.join(self._PARAM_NAMES)})")
            setattr(self, k, v)
        return self

    @property
    def tank_(self) -> Tank:
        """The tank of the model (``tank`` or the paper tank)."""
        if self.tank is None:
            return Tank()
        if not isinstance(self.tank, Tank):
            raise ROMError(f"tank must be a sloshrom.config.Tank, got {type(self.tank).__name__}")
        return self.tank

    @property
    def fill_range(self) -> tuple[float, float]:
        """``(fill, fill)`` of :attr:`tank_`, the one fill level the model stands for (-).

        The ball's mass and gap are fractions of its tank's liquid mass and ullage: like a ROM
        identified at one fill (:func:`sloshrom.rom.family.check_fill`), a ball is refused at
        another fill, never run there silently.
        """
        f = float(self.tank_.fill)
        return f, f

    def _check_hyperparameters(self) -> dict[str, tuple[float, float]]:
        bounds = {name: _bounds(name, getattr(self, name))
                  for name in ("mass_fraction", "restitution", "gap_factor")}
        _integer("seed", self.seed, 0)
        _integer("maxiter", self.maxiter, 1)
        _integer("popsize", self.popsize, 2)
        if self.n_substeps is not None:
            _integer("n_substeps", self.n_substeps, 1)
        if not (_number("tol", self.tol) >= 0):
            raise ROMError(f"tol must be >= 0, got {self.tol!r}")
        self.tank_  # noqa: B018 -- checks the type
        if self.lowpass is not None and self.lowpass != "input":
            if not _number("lowpass", self.lowpass) > 0:
                raise ROMError(f"lowpass must be 'input', None or a cutoff > 0 Hz, got "
                               f"{self.lowpass!r}")
        return bounds

    def _cutoff(self, u: np.ndarray, fs: float) -> float | None:
        """The objective's low-pass cutoff, Hz (None: plain MSE)."""
        if self.lowpass is None:
            return None
        if self.lowpass == "input":
            cutoff = power_band(u, fs, 0.001, 0.999)[1]
            if not cutoff > 0:
                raise ROMError("the input has no power at any frequency above 0 Hz: cannot "
                               "set the low-pass of the objective from it")
        else:
            cutoff = float(self.lowpass)
        if cutoff >= 0.5 * fs:
            raise ROMError(f"lowpass cutoff {cutoff:g} Hz must be below the Nyquist frequency "
                           f"{0.5 * fs:g} Hz")
        return cutoff

    # -- fitted parameters --------------------------------------------------------------------
    def _check_fitted(self) -> None:
        if not hasattr(self, "model_"):
            raise NotFittedError("this BouncingBall is not fitted: call fit() first")

    @property
    def mass_fraction_(self) -> float:
        """Identified ``beta = m_b / m_l``, -."""
        self._check_fitted()
        return self.model_.mass_fraction

    @property
    def restitution_(self) -> float:
        """Identified restitution ``e``, -."""
        self._check_fitted()
        return self.model_.restitution

    @property
    def gap_(self) -> float:
        """Identified gap, m."""
        self._check_fitted()
        return self.model_.gap

    @property
    def dt(self) -> float:
        """Model time step ``1 / (fs_ * n_substeps_)``, s."""
        self._check_fitted()
        return self.model_.dt

    @property
    def ball_mass_(self) -> float:
        """``m_b = beta m_l``, kg."""
        self._check_fitted()
        return self.model_.ball_mass

    @property
    def gap_factor_(self) -> float:
        """``gamma = Gap / ullage``, -."""
        self._check_fitted()
        return self.gap_ / self.tank_.ullage

    def parameters(self) -> dict[str, float]:
        """The identified parameters, JSON-able: ``mass_fraction`` (-), ``ball_mass_kg``,
        ``restitution`` (-), ``gap_m``, ``gap_factor`` (-), ``fs_hz`` (record rate),
        ``n_substeps`` and ``dt_s`` (the model step)."""
        self._check_fitted()
        return {"mass_fraction": self.mass_fraction_, "ball_mass_kg": self.ball_mass_,
                "restitution": self.restitution_, "gap_m": self.gap_,
                "gap_factor": self.gap_factor_, "fs_hz": self.fs_,
                "n_substeps": self.n_substeps_, "dt_s": self.dt}

    @classmethod
    def from_parameters(cls, mass_fraction: float, restitution: float, gap: float, fs: float,
                        tank: Tank | None = None, n_substeps: int | None = 1) -> BouncingBall:
        """A ball with given parameters (no identification): ``beta`` (-), ``e`` (-), ``Gap``
        (m), record rate ``fs`` (Hz) and ``n_substeps`` (default 1: the model step is
        ``1 / fs``; ``None``: as :class:`BouncingBall`). The envelope is left empty
        (``envelope_ = {}``).

        Raises
        ------
        ROMError
            A parameter outside its physical range.
        """
        model = cls(tank=tank, n_substeps=n_substeps)
        model._check_hyperparameters()
        model._set_fitted(mass_fraction, restitution, gap, fs)
        model.envelope_ = {}
        model.history_ = {}
        return model

    def _set_fitted(self, mass_fraction: float, restitution: float, gap: float,
                    fs: float) -> None:
        beta = _number("mass_fraction", mass_fraction)
        e = _number("restitution", restitution)
        gap = _number("gap", gap)
        fs = _number("fs", fs)
        if not _in_limits("mass_fraction", beta):
            raise ROMError(f"mass_fraction {beta:g} outside {_limits_text('mass_fraction')}")
        if not _in_limits("restitution", e):
            raise ROMError(f"restitution {e:g} outside {_limits_text('restitution')}")
        if not _in_limits("gap_factor", gap / self.tank_.ullage):
            raise ROMError(f"gap {gap:g} m outside (0, {10 * self.tank_.ullage:g}] m "
                           "(10 ullages)")
        if not fs > 0:
            raise ROMError(f"fs must be a finite positive sample rate in Hz, got {fs!r}")
        self.fs_ = fs
        self.n_substeps_ = (int(self.n_substeps) if self.n_substeps is not None
                            else max(1, math.ceil(1.0 / (fs * MAX_MODEL_STEP) - 1e-9)))
        self.model_ = Ball(beta, e, gap, 1.0 / (fs * self.n_substeps_), self.tank_)

    # -- identification -----------------------------------------------------------------------
    def fit(
        self,
        u: Any,
        y: Any,
        fs: float,
        validation: tuple[Any, ...] | None = None,
        acceleration: Any = None,
    ) -> BouncingBall:
        """Identify ``beta``, ``e`` and ``Gap`` from a force record.

        Minimises the mean squared error between the simulated step-average dynamic force and
        the record's, ``(y_k + y_k+1) / 2`` (the trapezoid average over ``[t_k, t_k+1]``, what
        output k of the ball is), both low-passed (``lowpass``: the zero-phase gain
        :func:`lowpass_gain`, applied in the frequency domain), over the bounded parameters by
        differential evolution (``scipy.optimize.differential_evolution``, seeded, Latin
        hypercube start, no gradient polish: the force is discontinuous in the parameters
        through the impacts).

        Parameters
        ----------
        u : array_like, shape (n,)
            Tank vertical velocity, m/s, sampled at ``fs``, starting at rest (the envelope; the
            acceleration if ``acceleration`` is not given).
        y : array_like, shape (n,)
            Dynamic sloshing force, N.
        fs : float
            Sample rate, Hz.
        validation : (u_val, y_val) or (u_val, y_val, acceleration_val), optional
            A validation record at the same rate: its MSE and NRMSE go to ``history_``.
        acceleration : array_like, shape (n,), optional
            Tank vertical acceleration, m/s^2. Default: the forward difference of ``u``
            (:func:`forward_acceleration`), the exact mean acceleration over each step.

        Returns
        -------
        self

        Raises
        ------
        ROMError
            Bounds out of order or outside the physical limits, another bad hyperparameter, a
            bad record (shape, NaN, different lengths, constant force, too short, a tank that
            never accelerates down faster than g, so the ball never leaves the floor) or a bad
            ``fs``.
        """
        bounds = self._check_hyperparameters()
        tank = self.tank_
        fs_ = _number("fs", fs)
        if not fs_ > 0:
            raise ROMError(f"fs must be a finite positive sample rate in Hz, got {fs!r}")
        u_, y_, a_ = self._record(u, y, acceleration, fs_, "")
        val = None
        if validation is not None:
            if not isinstance(validation, tuple | list) or len(validation) not in (2, 3):
                raise ROMError("validation must be (u_val, y_val) or (u_val, y_val, "
                               "acceleration_val)")
            a_v = validation[2] if len(validation) == 3 else None
            val = self._record(validation[0], validation[1], a_v, fs_, "validation ")
        if np.min(a_) >= -G:
            raise ROMError(
                f"the tank acceleration never falls below -g (min {np.min(a_):.3g} m/s^2): the "
                "ball never leaves the floor, so the record cannot identify it")

        m_l = tank.liquid_mass
        ullage = tank.ullage
        cutoff = self._cutoff(u_, fs_)
        target = _step_average(y_)
        acc = np.ascontiguousarray(a_[:-1])
        error = _ForceError(target, fs_, cutoff)
        names = ("mass_fraction", "restitution", "gap_factor")
        free = [n for n in names if bounds[n][0] < bounds[n][1]]
        fixed = {n: bounds[n][0] for n in names if n not in free}
        evaluations = [0]

        def rows(x: np.ndarray) -> np.ndarray:
            s = x.shape[1]  # x: (n_free, S), one column per candidate
            vals = {n: np.full(s, v) for n, v in fixed.items()}
            vals.update({n: x[i] for i, n in enumerate(free)})
            p = np.empty((s, _N_PARAMS))
            p[:, _P_GAP] = vals["gap_factor"] * ullage
            p[:, _P_MASS] = vals["mass_fraction"] * m_l
            p[:, _P_E] = vals["restitution"]
            p[:, _P_G] = G
            p[:, _P_DT] = 1.0 / fs_
            return p

        def objective(x: np.ndarray) -> np.ndarray:
            p = rows(np.asarray(x, dtype=np.float64))
            evaluations[0] += p.shape[0]
            return error.of_params(p, acc)

        t0 = time.perf_counter()
        if free:
            res = differential_evolution(
                objective, [bounds[n] for n in free], seed=int(self.seed),
                maxiter=int(self.maxiter), popsize=int(self.popsize), tol=float(self.tol),
                polish=False, init="latinhypercube", updating="deferred", vectorized=True)
            best = dict(fixed, **{n: float(v) for n, v in zip(free, res.x, strict=True)})
            history: dict[str, Any] = {"objective": float(res.fun),
                                       "generations": int(res.nit),
                                       "converged": bool(res.success)}
        else:  # every parameter fixed by its bounds: nothing to search
            best = dict(fixed)
            history = {"objective": float(objective(np.zeros((0, 1)))[0]), "generations": 0,
                       "converged": True}
        history["evaluations"] = evaluations[0]
        history["seconds"] = time.perf_counter() - t0
        history["n_samples"] = int(y_.size)
        history["lowpass_hz"] = float("nan") if cutoff is None else float(cutoff)
        history["nrmse"] = error.nrmse(history["objective"])

        self._set_fitted(best["mass_fraction"], best["restitution"],
                         best["gap_factor"] * ullage, fs_)
        self.envelope_ = {
            "input_min": float(np.min(a_)),
            "input_max": float(np.max(a_)),
            "output_min": float(np.min(y_)),
            "output_max": float(np.max(y_)),
            "frequency_band": power_band(u_, fs_),
            "acceleration_max": float(np.max(np.abs(a_))),
        }
        if val is not None:
            uv, yv, av = val
            pred = self.model_.simulate_acceleration(av, 1.0 / fs_)[:-1]
            verr = _ForceError(_step_average(yv), fs_, cutoff)
            mse = float(verr.of_force(pred))
            history["validation_mse"] = mse
            history["validation_nrmse"] = verr.nrmse(mse)
            raw = _ForceError(_step_average(yv), fs_, None)
            history["validation_nrmse_unfiltered"] = raw.nrmse(float(raw.of_force(pred)))
        self.history_ = history
        return self

    def _record(self, u: Any, y: Any, acceleration: Any, fs: float,
                what: str) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        u_ = _signal(f"{what}u", u)
        y_ = _signal(f"{what}y", y)
        if u_.shape != y_.shape:
            raise ROMError(f"{what}u and {what}y must have the same length, got {u_.size} and "
                           f"{y_.size}")
        need = max(100, int(math.ceil(fs)))
        if u_.size < need:
            raise ROMError(f"{what}record too short: {u_.size} samples, need at least {need} "
                           "(1 s and 100 samples)")
        if np.ptp(y_) == 0:
            raise ROMError(f"{what}y is constant: there is no sloshing force to identify from")
        if acceleration is None:
            a_ = forward_acceleration(u_, fs)
        else:
            a_ = _signal(f"{what}acceleration", acceleration)
            if a_.shape != u_.shape:
                raise ROMError(f"{what}acceleration must have the length of {what}u, got "
                               f"{a_.size} and {u_.size}")
        return u_, y_, np.ascontiguousarray(a_)

    # -- sloshing-model contract: the fitted Ball's ---------------------------------------------
    def init_state(self) -> np.ndarray:
        """At rest on the floor (:meth:`Ball.init_state`)."""
        return _rest_state()

    def step(self, state: Any, velocity: Any, acceleration: Any) -> tuple[np.ndarray, float]:
        """Pure step (:meth:`Ball.step`): ``(new_state, dynamic_force)`` (N)."""
        self._check_fitted()
        return self.model_.step(state, velocity, acceleration)

    def simulate(self, velocity: Any, acceleration: Any = None) -> np.ndarray:
        """Dynamic force (N) for tank acceleration (m/s^2) sampled at ``1 / dt``
        (:meth:`Ball.simulate`)."""
        self._check_fitted()
        return self.model_.simulate(velocity, acceleration)

    def predict(self, u: Any, acceleration: Any = None) -> np.ndarray:
        """Dynamic force (N) from rest at the record rate ``fs_`` (not the model step).

        Output k is the exact average over ``[t_k, t_k+1]`` with the acceleration held over the
        sample step: what the model gives at its step ``dt`` with that held input, averaged
        over the ``n_substeps_`` steps of each sample; what :meth:`fit` compares with the
        record.

        Parameters
        ----------
        u : array_like, shape (n,) or (batch, n)
            Tank vertical velocity at ``fs_``, m/s.
        acceleration : array_like, same shape, optional
            Tank vertical acceleration at ``fs_``, m/s^2; default the forward difference of
            ``u``.
        """
        self._check_fitted()
        u_ = _signal("u", u, allow_batch=True)
        if acceleration is None:
            return self.model_.simulate_acceleration(forward_acceleration(u_, self.fs_),
                                                     1.0 / self.fs_)
        a = _signal("acceleration", acceleration, allow_batch=True)
        if a.shape != u_.shape:
            raise ROMError(f"acceleration must have the shape of u, got {a.shape} and "
                           f"{u_.shape}")
        return self.model_.simulate_acceleration(a, 1.0 / self.fs_)

    def kernel(self) -> tuple[Any, np.ndarray, np.ndarray]:
        """``(step_fn, params, state)`` for numba loops (:meth:`Ball.kernel`)."""
        self._check_fitted()
        return self.model_.kernel()

    # -- persistence --------------------------------------------------------------------------
    def save(self, path: str | Path) -> Path:
        """Write the fitted model to a small TOML file atomically (table ``[bouncing_ball]``).

        Keys carry their units (``gap_m``, ``fs_hz``, ``ball_mass_kg``); the file also holds the
        search bounds, the tank, the envelope and the fit's history numbers. Plain text, read
        back by :meth:`load` without executing anything.

        Returns
        -------
        Path
        """
        self._check_fitted()
        p = Path(path)
        if p.suffix.lower() != ".toml":
            raise ROMError(f"{p}: a bouncing-ball model file ends in .toml")
        hyper = {n: [float(x) for x in _bounds(n, getattr(self, n))]
                 for n in ("mass_fraction", "restitution", "gap_factor")}
        hyper.update(seed=int(self.seed), maxiter=int(self.maxiter), popsize=int(self.popsize),
                     tol=float(self.tol),
                     n_substeps="auto" if self.n_substeps is None else int(self.n_substeps),
                     lowpass="none" if self.lowpass is None else
                     "input" if self.lowpass == "input" else float(self.lowpass))
        table = {
            "format": BALL_FORMAT,
            "format_version": BALL_FORMAT_VERSION,
            "sloshrom_version": __version__,
            "mass_fraction": float(self.mass_fraction_),
            "restitution": float(self.restitution_),
            "gap_m": float(self.gap_),
            "fs_hz": float(self.fs_),
            "n_substeps": int(self.n_substeps_),
            "ball_mass_kg": float(self.ball_mass_),
            "gap_factor": float(self.gap_factor_),
            "hyperparameters": hyper,
            "tank": {k: float(v) for k, v in self.tank_.to_dict().items()},
            "envelope": {k: ([float(x) for x in v] if isinstance(v, list | tuple) else float(v))
                         for k, v in self.envelope_.items()},
            "history": {k: v for k, v in self.history_.items()
                        if isinstance(v, bool | int | float | str)},
        }
        head = ("# sloshrom bouncing-ball equivalent mechanical model (docs/rom.md, \"The "
                "bouncing-ball baseline\").\n# mass_fraction = m_b / m_l (-), restitution (-), "
                "gap_m = Gap (m), fs_hz = sample rate (Hz),\n# ball_mass_kg and gap_factor "
                "(= Gap / ullage) are derived and checked on load.\n")
        return atomic_write_text(p, head + tomli_w.dumps({"bouncing_ball": table}))

    @classmethod
    def load(cls, path: str | Path) -> BouncingBall:
        """Read a model written by :meth:`save` (TOML; never executes code).

        Raises
        ------
        ModelFileError
            Missing file, not TOML, no ``[bouncing_ball]`` table, another format or a newer
            version, a missing key, a value of the wrong type or outside its physical range,
            derived values that contradict the parameters.
        """
        p = Path(path)
        why = not_a_regular_file(p)
        if why is not None:
            raise ModelFileError(f"{p}: {why}")
        if not p.is_file():
            raise ModelFileError(f"{p}: no such model file")
        try:
            data = tomllib.loads(p.read_text(encoding="utf-8"))
        except (tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
            raise ModelFileError(f"{p}: not a valid TOML file ({exc})") from None
        t = data.get("bouncing_ball")
        if not isinstance(t, dict):
            raise ModelFileError(f"{p}: no [bouncing_ball] table: not a bouncing-ball model")

        def get(table: Mapping[str, Any], key: str, kind: type | tuple[type, ...],
                where: str = "bouncing_ball") -> Any:
            if key not in table:
                raise ModelFileError(f"{p}: [{where}] has no key {key!r}")
            v = table[key]
            if isinstance(v, bool) or not isinstance(v, kind):
                raise ModelFileError(f"{p}: [{where}] {key} has the wrong type "
                                     f"({type(v).__name__}: {v!r})")
            return v

        def number(table: Mapping[str, Any], key: str, where: str = "bouncing_ball") -> float:
            v = float(get(table, key, (int, float), where))
            if not math.isfinite(v):
                raise ModelFileError(f"{p}: [{where}] {key} must be finite, got {v!r}")
            return v

        if get(t, "format", str) != BALL_FORMAT:
            raise ModelFileError(f"{p}: format {t['format']!r} is not {BALL_FORMAT!r}")
        version = get(t, "format_version", int)
        if not 1 <= version <= BALL_FORMAT_VERSION:
            raise ModelFileError(f"{p}: format version {version} is not supported (this "
                                 f"sloshrom reads version {BALL_FORMAT_VERSION})")
        try:
            tank = Tank.from_dict(get(t, "tank", dict))
        except (ConfigError, TypeError) as exc:
            raise ModelFileError(f"{p}: [bouncing_ball.tank] {exc}") from None
        hyper = get(t, "hyperparameters", dict)
        kwargs: dict[str, Any] = {}
        for name in ("mass_fraction", "restitution", "gap_factor"):
            pair = get(hyper, name, list, "bouncing_ball.hyperparameters")
            kwargs[name] = tuple(pair)
        for name in ("seed", "maxiter", "popsize"):
            kwargs[name] = get(hyper, name, int, "bouncing_ball.hyperparameters")
        kwargs["tol"] = number(hyper, "tol", "bouncing_ball.hyperparameters")
        lowpass = get(hyper, "lowpass", (str, int, float), "bouncing_ball.hyperparameters")
        if isinstance(lowpass, str) and lowpass not in ("input", "none"):
            raise ModelFileError(f"{p}: [bouncing_ball.hyperparameters] lowpass must be "
                                 f"'input', 'none' or a cutoff in Hz, got {lowpass!r}")
        kwargs["lowpass"] = None if lowpass == "none" else lowpass
        sub = get(hyper, "n_substeps", (str, int), "bouncing_ball.hyperparameters")
        if isinstance(sub, str) and sub != "auto":
            raise ModelFileError(f"{p}: [bouncing_ball.hyperparameters] n_substeps must be "
                                 f"'auto' or an integer, got {sub!r}")
        kwargs["n_substeps"] = None if sub == "auto" else sub
        model = cls(tank=tank, **kwargs)
        try:
            model._check_hyperparameters()
            model._set_fitted(number(t, "mass_fraction"), number(t, "restitution"),
                              number(t, "gap_m"), number(t, "fs_hz"))
        except ROMError as exc:
            raise ModelFileError(f"{p}: {exc}") from None
        if get(t, "n_substeps", int) != model.n_substeps_:
            raise ModelFileError(f"{p}: n_substeps = {t['n_substeps']!r} contradicts the "
                                 f"hyperparameters ({model.n_substeps_})")
        for key, value in (("ball_mass_kg", model.ball_mass_), ("gap_factor", model.gap_factor_)):
            if not math.isclose(number(t, key), value, rel_tol=1e-9):
                raise ModelFileError(f"{p}: {key} = {t[key]!r} contradicts the parameters "
                                     f"({value!r}): the file was edited inconsistently")
        env = get(t, "envelope", dict)
        envelope: dict[str, Any] = {}
        for key in ("input_min", "input_max", "output_min", "output_max", "acceleration_max"):
            envelope[key] = number(env, key, "bouncing_ball.envelope")
        band = get(env, "frequency_band", list, "bouncing_ball.envelope")
        if len(band) != 2 or not all(isinstance(x, int | float) and not isinstance(x, bool)
                                     and math.isfinite(x) for x in band):
            raise ModelFileError(f"{p}: [bouncing_ball.envelope] frequency_band must be two "
                                 f"finite numbers, got {band!r}")
        envelope["frequency_band"] = [float(x) for x in band]
        if version == 1:
            # its input range was the velocity's: the ball reads the acceleration, whose range
            # the peak training acceleration bounds
            peak = envelope["acceleration_max"]
            envelope["input_min"], envelope["input_max"] = -peak, peak
        if envelope["input_min"] > envelope["input_max"] or \
                envelope["output_min"] > envelope["output_max"] or \
                envelope["acceleration_max"] < 0:
            raise ModelFileError(f"{p}: [bouncing_ball.envelope] is inconsistent (min > max or "
                                 "a negative peak acceleration)")
        hist = get(t, "history", dict)
        model.envelope_ = envelope
        model.history_ = {k: v for k, v in hist.items()
                          if isinstance(v, bool | int | float | str)}
        return model
