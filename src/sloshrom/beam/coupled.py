"""Coupled sloshing-beam simulation (paper Eqs. 4, 7, 9).

Relative modal coordinates q (dry structure modes, see :mod:`sloshrom.beam.structure`), base
acceleration ``a_s``::

    (M + m_l psi psi^T) q'' + C q' + K q = psi * df(v_abs, a_abs) - (Gamma + m_l psi) a_s

with ``v_abs = psi^T q' + v_s`` the tank's absolute vertical velocity (``v_s`` the base velocity,
integrated from ``a_s``) and ``df`` the dynamic sloshing force of any sloshing model (contract of
:mod:`sloshrom.models`). The linear structure is discretised *exactly* for inputs held constant
over a step (zero-order hold, matrix exponential of the augmented matrix) at the sloshing model's
own step ``model.dt``; the sloshing model is evaluated once per step with inputs from the current
state (velocity) and the tank absolute acceleration of the previous step (one-step lag; no
algebraic loop).

Outputs per step: ``tank_acceleration`` = psi^T q'' + a_s (absolute, m/s^2), ``dynamic_force``
df (N) and ``interface_force = -(m_struct + m_l) tank_acceleration + df`` (N): the dynamic force
the tank assembly (structure + liquid) exerts on the beam, static weight removed. With the
paper's ``f_S = -m_l w'' + df`` (liquid on tank, Eq. 2) this is ``-m_struct w'' + f_S``: the same
convention as the rig's load cells.

Damping: ``C = M_f V diag(2 zeta_n omega_n) V^T M_f`` with (omega_n, V) the mass-normalised modes
of the frozen system ``(M_f = M + m_l psi psi^T, K)``; so the modal damping ratios given in the
:class:`~sloshrom.beam.structure.ModalModel` are those of the frozen-liquid modes (paper Table 1).

Backends, chosen by the model's capabilities (:mod:`sloshrom.models`): a JAX ``lax.scan`` (jit;
``vmap`` over batches of base accelerations) for a :class:`~sloshrom.models.JaxModel` (ROMs,
:class:`~sloshrom.models.FrozenLiquid`); a numba loop for a
:class:`~sloshrom.models.CompiledKernel` (the virtual rig, at its fine step, output decimated to
a sensor rate); a plain Python loop for any other sloshing model.

The JAX backend is the pure function :func:`simulate_jax` of the model and the discretisation,
both pytrees: a model whose parameters are pytree leaves (the ROMs) is an *argument* of the
jitted scan, so one compilation serves every model of the same architecture and record length,
and ``jax.grad`` of any function of the response with respect to the model's parameters works.
A jax-traceable model that is not a pytree (:class:`~sloshrom.models.FrozenLiquid`) is compiled
in as a constant. Simulations run in float64 (``jax.enable_x64`` around the call) without
changing the process's JAX configuration.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass
from typing import Any

import jax
import jax.numpy as jnp
import numba as nb
import numpy as np
from scipy.linalg import eigh, expm
from scipy.signal import resample_poly

from sloshrom._x64 import float64
from sloshrom.beam.envelope import envelope_coverage
from sloshrom.beam.structure import ModalModel, frozen_mass_matrix
from sloshrom.config import G, Tank
from sloshrom.models import CompiledKernel, Enveloped, JaxModel, SloshingModel
from sloshrom.signals import random_base_acceleration

__all__ = [
    "CoupledSimulator",
    "Discretisation",
    "SimulationDivergedError",
    "StepMismatchError",
    "damping_matrix",
    "discretise",
    "free_response",
    "modal_energy",
    "random_response",
    "simulate_jax",
    "upsample_periodic",
]


class SimulationDivergedError(RuntimeError):
    """The coupled simulation blew up (reported with the time at which it did)."""


class StepMismatchError(ValueError):
    """A sloshing model's time step does not match the step the simulation was asked to use."""


def damping_matrix(modal: ModalModel, liquid_mass: float) -> np.ndarray:
    """Modal damping matrix giving the frozen-liquid modes the ratios ``modal.damping``, N s/m."""
    mf = frozen_mass_matrix(modal, liquid_mass)
    w2, v = eigh(np.diag(modal.stiffness), mf)  # v^T mf v = I
    # the coupled modes keep the order of the dry ones (tank mass only shifts them a little)
    c_modal = 2.0 * modal.damping * np.sqrt(w2)
    return mf @ v @ np.diag(c_modal) @ v.T @ mf


@jax.tree_util.register_dataclass
@dataclass
class Discretisation:
    """Exact ZOH discretisation of the structure: z = [q, q'], u = [df, a_s].

    A JAX pytree (every field a leaf): passed into the jitted scan as data, so beams of the
    same number of modes share one compilation.
    """

    dt: float  # s
    Phi: np.ndarray  # (2N, 2N)
    Gam: np.ndarray  # (2N, 2)
    A2: np.ndarray  # (N, 2N): q'' = A2 z + B2 u
    B2: np.ndarray  # (N, 2)
    mass: np.ndarray  # M + m_l psi psi^T, kg
    stiffness: np.ndarray  # N/m
    damping: np.ndarray  # N s/m
    psi: np.ndarray  # (N,) modes at the tank
    m_total: float  # m_struct + m_l at the interface, kg


def discretise(modal: ModalModel, liquid_mass: float, dt: float) -> Discretisation:
    """Zero-order-hold discretisation of the coupled linear structure at step ``dt`` (s)."""
    if not (math.isfinite(dt) and dt > 0):
        raise ValueError(f"dt must be a finite positive step in s, got {dt!r}")
    n = modal.n_modes
    psi = modal.psi_tank
    mass = frozen_mass_matrix(modal, liquid_mass)
    k = np.diag(modal.stiffness)
    c = damping_matrix(modal, liquid_mass)
    mi = np.linalg.inv(mass)
    a = np.zeros((2 * n, 2 * n))
    a[:n, n:] = np.eye(n)
    a[n:, :n] = -mi @ k
    a[n:, n:] = -mi @ c
    b = np.zeros((2 * n, 2))
    b[n:, 0] = mi @ psi
    b[n:, 1] = -mi @ (modal.participation + liquid_mass * psi)
    aug = np.zeros((2 * n + 2, 2 * n + 2))
    aug[: 2 * n, : 2 * n] = a
    aug[: 2 * n, 2 * n :] = b
    e = expm(aug * dt)
    return Discretisation(
        dt=float(dt), Phi=e[: 2 * n, : 2 * n], Gam=e[: 2 * n, 2 * n :], A2=a[n:], B2=b[n:],
        mass=mass, stiffness=k, damping=c, psi=psi.copy(),
        m_total=modal.structure_mass + liquid_mass,
    )


# ------------------------------------------------------------------------------------------
# Backends
# ------------------------------------------------------------------------------------------


def _outputs(q: Any, qdd: Any, acc: Any, df: Any, vel: Any, m_total: Any) -> dict[str, Any]:
    """The per-step outputs of every backend (NumPy or JAX arrays, time on axis 0)."""
    return {"q": q, "qdd": qdd, "tank_acceleration": acc, "dynamic_force": df,
            "interface_force": -m_total * acc + df, "tank_velocity": vel}


def simulate_jax(model: JaxModel, disc: Discretisation, base_acceleration: Any,
                 z0: Any) -> dict[str, Any]:
    """Coupled simulation at the model rate as a pure JAX function (``lax.scan``).

    Traceable in ``model`` and ``disc`` (both pytrees): jit it, ``vmap`` it over base
    accelerations, or differentiate a function of its outputs with respect to the model's
    parameters (``jax.grad(lambda m: loss(simulate_jax(m, disc, a, z0)))(rom)``). Precision
    follows the caller's JAX configuration (float64 under ``jax.enable_x64(True)``).

    Parameters
    ----------
    model : JaxModel
        Sloshing model with a traceable ``step`` at the step ``disc.dt``.
    disc : Discretisation
        The structure, :func:`discretise` d at ``model.dt``.
    base_acceleration : array_like, shape (n,)
        Base acceleration a_s, m/s^2.
    z0 : array_like, shape (2 N,)
        Initial modal displacements (m) and velocities (m/s), ``[q0, qd0]``.

    Returns
    -------
    dict
        Arrays of shape (n[, N]): ``q`` (m), ``qdd`` (m/s^2), ``tank_acceleration`` (m/s^2),
        ``dynamic_force``, ``interface_force`` (N), ``tank_velocity`` (m/s).
    """
    Phi, Gam = jnp.asarray(disc.Phi), jnp.asarray(disc.Gam)
    A2, B2, psi = jnp.asarray(disc.A2), jnp.asarray(disc.B2), jnp.asarray(disc.psi)
    n = psi.shape[0]
    dt = disc.dt

    def body(carry, a_s):
        z, vs, acc_prev, ms = carry
        v_abs = psi @ z[n:] + vs
        ms, df = model.step(ms, v_abs, acc_prev)
        df = jnp.asarray(df, jnp.float64)
        u = jnp.stack([df, a_s])
        qdd = A2 @ z + B2 @ u
        acc = psi @ qdd + a_s
        z_next = Phi @ z + Gam @ u
        return (z_next, vs + dt * a_s, acc, ms), (z[:n], qdd, acc, df, v_abs)

    carry = (jnp.asarray(z0), jnp.zeros(()), jnp.zeros(()), model.init_state())
    _, (q, qdd, acc, df, v) = jax.lax.scan(body, carry, jnp.asarray(base_acceleration))
    return _outputs(q, qdd, acc, df, v, disc.m_total)


@jax.tree_util.register_pytree_node_class
class _Constant:
    """A jax-traceable model that is not a pytree, carried as static data (compiled in)."""

    def __init__(self, model: JaxModel) -> None:
        self.model = model

    def tree_flatten(self) -> tuple[tuple[()], JaxModel]:
        return (), self.model  # hashed by identity: one compilation per such model

    @classmethod
    def tree_unflatten(cls, model: JaxModel, children: tuple[()]) -> _Constant:
        return cls(model)


def _simulate(model: Any, disc: Discretisation, base_acceleration: Any, z0: Any) -> dict:
    return simulate_jax(model.model if isinstance(model, _Constant) else model, disc,
                        base_acceleration, z0)


# module level, the model an argument: the compiled scans are shared by every simulator
_simulate_one = jax.jit(_simulate)
_simulate_batch = jax.jit(jax.vmap(_simulate, in_axes=(None, None, 0, None)))


def _jax_argument(model: JaxModel) -> Any:
    """The model as a jit argument: itself if it is a pytree, else wrapped as a constant."""
    if jax.tree_util.treedef_is_leaf(jax.tree_util.tree_structure(model)):
        return _Constant(model)
    return model


@nb.njit(cache=True)
def _numba_loop(step_fn, mstate, mparams, Phi, Gam, A2, B2, psi, a_s, z0, dt, m_total):
    nt = a_s.size
    n = psi.size
    q = np.empty((nt, n))
    qdd = np.empty((nt, n))
    acc = np.empty(nt)
    dfo = np.empty(nt)
    vel = np.empty(nt)
    z = z0.copy()
    zn = np.empty_like(z)
    vs = 0.0
    acc_prev = 0.0
    for k in range(nt):
        v_abs = vs
        for i in range(n):
            v_abs += psi[i] * z[n + i]
        df = step_fn(mstate, mparams, v_abs, acc_prev)
        vel[k] = v_abs
        a = a_s[k]
        tacc = a
        for i in range(n):
            s = B2[i, 0] * df + B2[i, 1] * a
            for j in range(2 * n):
                s += A2[i, j] * z[j]
            qdd[k, i] = s
            q[k, i] = z[i]
            tacc += psi[i] * s
        for i in range(2 * n):
            s = Gam[i, 0] * df + Gam[i, 1] * a
            for j in range(2 * n):
                s += Phi[i, j] * z[j]
            zn[i] = s
        z[:] = zn
        acc[k] = tacc
        dfo[k] = df
        vs += dt * a
        acc_prev = tacc
    return q, qdd, acc, dfo, vel


def _python_loop(model: SloshingModel, d: Discretisation, a_s: np.ndarray,
                 z0: np.ndarray) -> dict:
    n = d.psi.size
    nt = a_s.size
    q, qdd = np.empty((nt, n)), np.empty((nt, n))
    acc, dfo, vel = np.empty(nt), np.empty(nt), np.empty(nt)
    z, vs, acc_prev, ms = z0.copy(), 0.0, 0.0, model.init_state()
    for k in range(nt):
        vel[k] = d.psi @ z[n:] + vs
        ms, df = model.step(ms, vel[k], acc_prev)
        df = float(df)
        u = np.array([df, a_s[k]])
        qdd[k] = d.A2 @ z + d.B2 @ u
        q[k] = z[:n]
        acc[k] = d.psi @ qdd[k] + a_s[k]
        dfo[k] = df
        z = d.Phi @ z + d.Gam @ u
        vs += d.dt * a_s[k]
        acc_prev = acc[k]
    return _outputs(q, qdd, acc, dfo, vel, d.m_total)


def _is_jax(model: Any) -> bool:
    # the protocol checks that the attribute exists; a model may declare it False
    return isinstance(model, JaxModel) and getattr(model, "jax_traceable", False) is True


def _default_backend(model: Any) -> str:
    if isinstance(model, CompiledKernel):
        return "numba"
    return "jax" if _is_jax(model) else "python"


# ------------------------------------------------------------------------------------------
# Public API
# ------------------------------------------------------------------------------------------


class CoupledSimulator:
    """Sloshing beam: a modal structure carrying a tank whose liquid is any sloshing model.

    Parameters
    ----------
    model : SloshingModel
        Implements the contract of :mod:`sloshrom.models` (``dt``, ``init_state``, ``step``);
        ``"auto"`` picks the numba backend for a :class:`~sloshrom.models.CompiledKernel`
        (virtual rig), JAX for a :class:`~sloshrom.models.JaxModel`, else the Python loop.
    modal : ModalModel
        Dry-structure modes (beam + tank structure).
    tank : Tank
        Gives the liquid mass m_l (default: paper tank).
    dt : float, optional
        Requested step, s; must equal ``model.dt`` (a :class:`StepMismatchError` otherwise).
    output_fs : float, optional
        Output sample rate, Hz (default 1/dt; must divide 1/dt). Outputs are decimated with a
        zero-phase anti-alias FIR (``scipy.signal.resample_poly``).
    backend : {"auto", "jax", "numba", "python"}
    """

    def __init__(
        self,
        model: SloshingModel,
        modal: ModalModel,
        tank: Tank | None = None,
        dt: float | None = None,
        output_fs: float | None = None,
        backend: str = "auto",
    ) -> None:
        self.model = model
        self.modal = modal
        self.tank = tank if tank is not None else Tank()
        mdt = float(model.dt)
        if dt is not None and not math.isclose(float(dt), mdt, rel_tol=1e-9):
            raise StepMismatchError(
                f"the sloshing model runs at dt = {mdt} s but a step of {dt} s was requested; "
                "the coupled simulation must use the model's own step"
            )
        self.dt = mdt
        fs = 1.0 / mdt
        self.output_fs = fs if output_fs is None else float(output_fs)
        ratio = fs / self.output_fs
        if not (self.output_fs > 0 and abs(ratio - round(ratio)) < 1e-6 and round(ratio) >= 1):
            raise ValueError(
                f"output_fs = {output_fs} Hz must divide the model rate {fs} Hz by an integer"
            )
        self.decimation = int(round(ratio))
        if backend == "auto":
            backend = _default_backend(model)
        if backend not in ("jax", "numba", "python"):
            raise ValueError(f"unknown backend {backend!r} (jax, numba, python)")
        if backend == "numba" and not isinstance(model, CompiledKernel):
            raise ValueError("the numba backend needs a model with kernel()")
        if backend == "jax" and not _is_jax(model):
            raise ValueError("the jax backend needs a jax-traceable model (sloshrom.models."
                             "JaxModel)")
        self.backend = backend
        self.disc = discretise(modal, self.tank.liquid_mass, mdt)

    # -- core -------------------------------------------------------------------------------
    def _z0(self, q0: Any, qd0: Any) -> np.ndarray:
        n = self.modal.n_modes
        z0 = np.zeros(2 * n)
        if q0 is not None:
            z0[:n] = np.broadcast_to(np.asarray(q0, dtype=float), (n,))
        if qd0 is not None:
            z0[n:] = np.broadcast_to(np.asarray(qd0, dtype=float), (n,))
        return z0

    @float64
    def run_raw(self, base_acceleration: Any, q0: Any = None, qd0: Any = None) -> dict:
        """Simulate at the model rate; arrays of shape (batch..., n[, n_modes]); no decimation."""
        a = np.asarray(base_acceleration, dtype=np.float64)
        if a.ndim == 0:
            raise ValueError("base_acceleration must have a time axis")
        if not np.all(np.isfinite(a)):
            raise ValueError("base_acceleration must be finite")
        z0 = self._z0(q0, qd0)
        lead = a.shape[:-1]
        flat = a.reshape(-1, a.shape[-1])
        if self.backend == "jax":
            m, d, zj = _jax_argument(self.model), self.disc, jnp.asarray(z0)
            if flat.shape[0] > 1:
                res = _simulate_batch(m, d, jnp.asarray(flat), zj)
            else:
                res = {k: v[None] for k, v in _simulate_one(m, d, jnp.asarray(flat[0]), zj).items()}
            out = {k: np.asarray(v) for k, v in res.items()}
        else:
            outs = []
            for row in flat:
                if self.backend == "numba":
                    step_fn, params, state = self.model.kernel()
                    d = self.disc
                    q, qdd, acc, dfo, vel = _numba_loop(
                        step_fn, state, params, d.Phi, d.Gam, d.A2, d.B2, d.psi,
                        np.ascontiguousarray(row), z0, d.dt, d.m_total,
                    )
                    outs.append(_outputs(q, qdd, acc, dfo, vel, d.m_total))
                else:
                    outs.append(_python_loop(self.model, self.disc, row, z0))
            out = {k: np.stack([o[k] for o in outs]) for k in outs[0]}
        self._check_divergence(out["q"])
        return {k: v.reshape(lead + v.shape[1:]) for k, v in out.items()}

    def _check_divergence(self, q: np.ndarray) -> None:
        """Stop with the time of divergence instead of returning NaNs.

        Diverged = a non-finite modal displacement, or one larger than the beam itself (with
        modes normalised to unit maximum displacement, |q| > L is no longer a beam vibration).
        """
        bound = float(getattr(self.modal, "length", 1.0) or 1.0)
        bad = ~np.isfinite(q) | (np.abs(np.nan_to_num(q, nan=np.inf)) > bound)
        if not bad.any():
            return
        k = int(np.argmax(bad.reshape(bad.shape[0], bad.shape[1], -1).any(axis=(0, 2))))
        raise SimulationDivergedError(
            f"the coupled simulation diverged at t = {k * self.disc.dt:.4g} s "
            f"(modal displacement non-finite or beyond {bound:g} m); the sloshing model "
            f"({type(self.model).__name__}) is probably outside its valid range"
        )

    def _check_envelope(self, v: np.ndarray) -> None:
        # a ROM inside the loop cannot warn from within lax.scan: check its input afterwards
        if not isinstance(self.model, Enveloped):
            return
        env = self.model.envelope_
        if not isinstance(env, dict) or "input_min" not in env:
            return
        lo, hi = float(env["input_min"]), float(env["input_max"])
        over = max(float(np.max(v)) - hi, lo - float(np.min(v)), 0.0)
        if over > 0:
            warnings.warn(
                f"tank velocity left the ROM's training envelope [{lo:.4g}, {hi:.4g}] m/s by "
                f"{over:.4g} m/s: the sloshing force is extrapolated",
                UserWarning,
                stacklevel=3,
            )

    def run(self, base_acceleration: Any, q0: Any = None, qd0: Any = None) -> dict:
        """Simulate and return results at ``output_fs``.

        Parameters
        ----------
        base_acceleration : array_like, shape (..., n)
            Base (root) vertical acceleration a_s sampled at 1/dt, m/s^2; leading axes batched.
        q0, qd0 : array_like (n_modes,), optional
            Initial modal displacements (m) and velocities (m/s).

        Returns
        -------
        dict
            ``time`` (s), ``fs`` (Hz), ``base_acceleration``, ``tank_acceleration`` (m/s^2),
            ``tank_velocity`` (absolute, the sloshing model's input, m/s),
            ``interface_force``, ``dynamic_force`` (N), ``q`` (m, (..., n, modes)),
            ``modal_acceleration`` (q'', m/s^2, (..., n, modes)), ``station_acceleration``
            (absolute, m/s^2, (..., n, stations)), ``stations`` (m); and the coverage of the
            model's training envelope at the model rate
            (:func:`sloshrom.beam.envelope.envelope_coverage`, shape (...), NaN for a model
            without an envelope): ``envelope_outside_fraction`` (-),
            ``envelope_acceleration_ratio`` (peak tank acceleration / training peak
            acceleration, -) and ``training_peak_acceleration`` (m/s^2).
        """
        a = np.asarray(base_acceleration, dtype=np.float64)
        raw = self.run_raw(a, q0, qd0)
        self._check_envelope(raw["tank_velocity"])
        cov = envelope_coverage(getattr(self.model, "envelope_", None), raw["tank_velocity"],
                                raw["tank_acceleration"])
        raw["base_acceleration"] = a
        dec = self.decimation
        out: dict[str, Any] = {}
        for k, v in raw.items():
            if dec == 1:
                out[k] = v
            else:
                t_axis = a.ndim - 1
                out[k] = resample_poly(v, 1, dec, axis=t_axis, padtype="line")
        n_out = out["tank_acceleration"].shape[-1]
        out["time"] = np.arange(n_out) / self.output_fs
        out["fs"] = self.output_fs
        out["modal_acceleration"] = out.pop("qdd")
        out["station_acceleration"] = (
            out["modal_acceleration"] @ self.modal.psi_stations.T
            + out["base_acceleration"][..., None]
        )
        out["stations"] = self.modal.stations
        out["envelope_outside_fraction"] = cov.outside_fraction
        out["envelope_acceleration_ratio"] = cov.acceleration_ratio
        out["training_peak_acceleration"] = cov.training_peak_acceleration
        return out


def free_response(
    model: SloshingModel,
    modal: ModalModel,
    tip_displacement: float = 0.0146,
    duration: float = 10.0,
    tank: Tank | None = None,
    output_fs: float | None = None,
) -> dict:
    """Free response released at rest from the static tip-load shape (paper Sect. 4.3).

    Parameters
    ----------
    tip_displacement : float
        Initial tank displacement, m (paper: 1.46 cm).
    duration : float
        s.

    Returns
    -------
    dict
        As :meth:`CoupledSimulator.run`, plus ``q0``.
    """
    sim = CoupledSimulator(model, modal, tank=tank, output_fs=output_fs)
    n = int(round(duration / sim.dt))
    q0 = modal.static_tip_state(tip_displacement)
    out = sim.run(np.zeros(n), q0=q0)
    out["q0"] = q0
    return out


def upsample_periodic(x: np.ndarray, factor: int) -> np.ndarray:
    """Band-limited (FFT) upsampling of a periodic record by an integer factor, last axis."""
    if factor == 1:
        return x
    n = x.shape[-1]
    spec = np.fft.rfft(x, axis=-1)
    return np.fft.irfft(spec, n * factor, axis=-1) * factor


def random_response(
    model: SloshingModel,
    modal: ModalModel,
    rms_levels: Any = (0.1, 0.2, 0.4),
    duration: float = 90.0,
    seed: int = 0,
    f0: float = 12.0,
    sigma: float = 4.0,
    signal_fs: float = 500.0,
    tank: Tank | None = None,
    output_fs: float | None = None,
    fade: float = 1.0,
) -> dict:
    """Random base excitation (paper Sect. 4.4): Gaussian-PSD a_s at several RMS levels.

    The base acceleration is made at ``signal_fs`` (same phases for all levels) and, if the
    model runs faster (rig), upsampled band-limited, so that every model sees the same signal.

    Parameters
    ----------
    rms_levels : sequence of float
        RMS of the base acceleration **in g** (paper: 0.1, 0.2, 0.4).
    duration : float
        s (paper: 90).
    seed : int or sequence of int
        Phase seed(s); several seeds give a batch of shape (n_seeds, n_levels, n).
    f0, sigma : float
        PSD centre and standard deviation, Hz (estimates).

    Returns
    -------
    dict
        As :meth:`CoupledSimulator.run` with leading axes ([seed,] level).
    """
    sim = CoupledSimulator(model, modal, tank=tank, output_fs=output_fs)
    fs_model = 1.0 / sim.dt
    factor = fs_model / signal_fs
    if abs(factor - round(factor)) > 1e-6 or round(factor) < 1:
        raise ValueError(f"model rate {fs_model} Hz must be an integer multiple of {signal_fs} Hz")
    levels = np.asarray(rms_levels, dtype=float) * G
    seeds = np.atleast_1d(seed)
    a = np.stack([
        random_base_acceleration(signal_fs, duration, levels, f0=f0, sigma=sigma, seed=int(s),
                                 fade=fade)
        for s in seeds
    ])
    a = upsample_periodic(a, int(round(factor)))
    if np.ndim(seed) == 0:
        a = a[0]
    out = sim.run(a)
    out["rms_levels_g"] = np.asarray(rms_levels, dtype=float)
    return out


def modal_energy(d: Discretisation, q: np.ndarray, qd: np.ndarray) -> np.ndarray:
    """Mechanical energy of the (frozen) structure, J: ``q'^T M q'/2 + q^T K q/2``."""
    return 0.5 * np.einsum("...i,ij,...j->...", qd, d.mass, qd) + 0.5 * np.einsum(
        "...i,ij,...j->...", q, d.stiffness, q
    )
