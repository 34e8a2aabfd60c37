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

Backends: JAX ``lax.scan`` (jit; ``vmap`` over batches of base accelerations) for models with a
jax-traceable ``step`` (ROMs, :class:`~sloshrom.models.FrozenLiquid`); a numba loop for models with
``kernel()`` (the virtual rig, at its fine step, output decimated to a sensor rate); a plain
Python loop for anything else.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass, field
from typing import Any

import jax
import jax.numpy as jnp
import numba as nb
import numpy as np
from scipy.linalg import eigh, expm
from scipy.signal import resample_poly

from sloshrom.beam.structure import ModalModel
from sloshrom.config import Tank
from sloshrom.models import FrozenLiquid

jax.config.update("jax_enable_x64", True)


class SimulationDivergedError(RuntimeError):
    """The coupled simulation blew up (reported with the time at which it did)."""


class StepMismatchError(ValueError):
    """A sloshing model's time step does not match the step the simulation was asked to use."""


def damping_matrix(modal: ModalModel, liquid_mass: float) -> np.ndarray:
    """Modal damping matrix giving the frozen-liquid modes the ratios ``modal.damping``, N s/m."""
    mf = np.diag(modal.modal_masses) + liquid_mass * np.outer(modal.psi_tank, modal.psi_tank)
    w2, v = eigh(np.diag(modal.stiffness), mf)  # v^T mf v = I
    # the coupled modes keep the order of the dry ones (tank mass only shifts them a little)
    c_modal = 2.0 * modal.damping * np.sqrt(w2)
    return mf @ v @ np.diag(c_modal) @ v.T @ mf


@dataclass
class Discretisation:
    """Exact ZOH discretisation of the structure: z = [q, q'], u = [df, a_s]."""

    dt: float
    Phi: np.ndarray  # (2N, 2N)
    Gam: np.ndarray  # (2N, 2)
    A2: np.ndarray  # (N, 2N): q'' = A2 z + B2 u
    B2: np.ndarray  # (N, 2)
    mass: np.ndarray  # M + m_l psi psi^T
    stiffness: np.ndarray
    damping: np.ndarray
    psi: np.ndarray
    m_total: float  # m_struct + m_l at the interface
    extra: dict[str, Any] = field(default_factory=dict)


def discretise(modal: ModalModel, liquid_mass: float, dt: float) -> Discretisation:
    """Zero-order-hold discretisation of the coupled linear structure at step ``dt`` (s)."""
    if not (math.isfinite(dt) and dt > 0):
        raise ValueError(f"dt must be a finite positive step in s, got {dt!r}")
    n = modal.n_modes
    psi = modal.psi_tank
    mass = np.diag(modal.modal_masses) + liquid_mass * np.outer(psi, psi)
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


def _jax_scan(model: Any, d: Discretisation):
    """jit-compiled ``run(a_s (n,), z0 (2N,)) -> dict of (n, ...)`` arrays."""
    Phi, Gam = jnp.asarray(d.Phi), jnp.asarray(d.Gam)
    A2, B2, psi = jnp.asarray(d.A2), jnp.asarray(d.B2), jnp.asarray(d.psi)
    n = d.psi.size
    dt, m_total = d.dt, d.m_total
    mstate0 = model.init_state()

    def body(carry, a_s):
        z, vs, acc_prev, ms = carry
        v_abs = psi @ z[n:] + vs
        ms, df = model.step(ms, v_abs, acc_prev)
        df = jnp.asarray(df, jnp.float64)
        u = jnp.stack([df, a_s])
        qdd = A2 @ z + B2 @ u
        acc = psi @ qdd + a_s
        z_next = Phi @ z + Gam @ u
        out = (z[:n], qdd, acc, df, -m_total * acc + df, v_abs)
        return (z_next, vs + dt * a_s, acc, ms), out

    def run(a_s, z0):
        carry = (z0, jnp.zeros(()), jnp.zeros(()), mstate0)
        _, (q, qdd, acc, df, fi, v) = jax.lax.scan(body, carry, a_s)
        return {"q": q, "qdd": qdd, "tank_acceleration": acc, "dynamic_force": df,
                "interface_force": fi, "tank_velocity": v}

    return run


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


def _python_loop(model: Any, d: Discretisation, a_s: np.ndarray, z0: np.ndarray) -> dict:
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
    return {"q": q, "qdd": qdd, "tank_acceleration": acc, "dynamic_force": dfo,
            "interface_force": -d.m_total * acc + dfo, "tank_velocity": vel}


def _is_jax_model(model: Any) -> bool:
    if isinstance(model, FrozenLiquid):
        return True
    return type(model).__module__.startswith("sloshrom.rom") or getattr(model, "jax_traceable",
                                                                         False)


# ------------------------------------------------------------------------------------------
# Public API
# ------------------------------------------------------------------------------------------


class CoupledSimulator:
    """Sloshing beam: a modal structure carrying a tank whose liquid is any sloshing model.

    Parameters
    ----------
    model : sloshing model
        Implements the contract of :mod:`sloshrom.models` (``dt``, ``init_state``, ``step``);
        with ``kernel()`` (virtual rig) the numba backend is used.
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
        model: Any,
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
            if hasattr(model, "kernel"):
                backend = "numba"
            elif _is_jax_model(model):
                backend = "jax"
            else:
                backend = "python"
        if backend not in ("jax", "numba", "python"):
            raise ValueError(f"unknown backend {backend!r} (jax, numba, python)")
        if backend == "numba" and not hasattr(model, "kernel"):
            raise ValueError("the numba backend needs a model with kernel()")
        self.backend = backend
        self.disc = discretise(modal, self.tank.liquid_mass, mdt)
        self._run = None

    # -- core -------------------------------------------------------------------------------
    def _z0(self, q0: Any, qd0: Any) -> np.ndarray:
        n = self.modal.n_modes
        z0 = np.zeros(2 * n)
        if q0 is not None:
            z0[:n] = np.broadcast_to(np.asarray(q0, dtype=float), (n,))
        if qd0 is not None:
            z0[n:] = np.broadcast_to(np.asarray(qd0, dtype=float), (n,))
        return z0

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
            if self._run is None:
                run = _jax_scan(self.model, self.disc)
                self._run = (jax.jit(run), jax.jit(jax.vmap(run, in_axes=(0, None))))
            fn = self._run[1] if flat.shape[0] > 1 else (lambda x, z: jax.tree_util.tree_map(
                lambda y: y[None], self._run[0](x[0], z)))
            out = {k: np.asarray(v) for k, v in fn(jnp.asarray(flat), jnp.asarray(z0)).items()}
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
                    outs.append({"q": q, "qdd": qdd, "tank_acceleration": acc,
                                 "dynamic_force": dfo, "tank_velocity": vel,
                                 "interface_force": -self.disc.m_total * acc + dfo})
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
        env = getattr(self.model, "envelope_", None)
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
            (absolute, m/s^2, (..., n, stations)), ``stations`` (m).
        """
        a = np.asarray(base_acceleration, dtype=np.float64)
        raw = self.run_raw(a, q0, qd0)
        self._check_envelope(raw["tank_velocity"])
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
        return out


def free_response(
    model: Any,
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
    model: Any,
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
    from sloshrom.config import G
    from sloshrom.signals import random_base_acceleration

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
