"""Coupled sloshing-beam simulation (paper Eqs. 4, 7, 9).

Relative modal coordinates q (dry structure modes, see :mod:`sloshrom.beam.simulation.structure`),
base acceleration ``a_s``::

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
:class:`~sloshrom.beam.simulation.structure.ModalModel` are those of the frozen-liquid modes (paper
Table 1).

Backends, chosen by the model's capabilities (:mod:`sloshrom.models`): a JAX ``lax.scan`` (jit;
``vmap`` over batches of base accelerations) for a JAX model
(:func:`~sloshrom.models.is_jax_model`: ROMs, :class:`~sloshrom.models.FrozenLiquid`); a numba
loop for a model with a kernel (:func:`~sloshrom.models.has_kernel`: the virtual rig, the
bouncing ball, at their fine step, output decimated to a sensor rate); a plain Python loop
for any other sloshing model.

The JAX backend is the pure function :func:`simulate_jax` of the model and the discretisation,
both pytrees: a model whose parameters are pytree leaves (the ROMs) is an *argument* of the
jitted scan (its stepper, :func:`~sloshrom.models.stepper_of`: a fitted estimator's network,
without its training's hyperparameters such as the seed that sets an ensemble's members
apart), so one compilation serves every model of the same architecture and record length,
and ``jax.grad`` of any function of the response with respect to the model's parameters works.
A jax-traceable model that is not a pytree (:class:`~sloshrom.models.FrozenLiquid`) is compiled
in as a constant. Simulations run in float64 (``jax.enable_x64`` around the call) without
changing the process's JAX configuration.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np
from numba import types as nb_types
from scipy.linalg import eigh, expm
from scipy.signal import resample_poly

from sloshrom._jit import njit
from sloshrom._threads import map_threads
from sloshrom._x64 import float64
from sloshrom.beam.errors import BeamError
from sloshrom.beam.simulation.envelope import envelope_coverage
from sloshrom.beam.simulation.structure import (
    TANK_KEYS,
    ModalDataError,
    ModalModel,
    frozen_mass_matrix,
    liquid_masses,
)
from sloshrom.config import G, Tank
from sloshrom.models import (
    SloshingModel,
    check_envelope,
    envelope_of,
    has_kernel,
    has_no_force,
    input_of,
    is_jax_model,
    model_input,
    stepper_of,
)
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


class SimulationDivergedError(BeamError, RuntimeError):
    """The coupled simulation blew up (reported with the time at which it did): a sloshing
    model far outside its valid range on the user's structure, not a bug."""


class StepMismatchError(BeamError):
    """A sloshing model's time step does not match the step the simulation was asked to use."""


def damping_matrix(modal: ModalModel, liquid_mass: Any) -> np.ndarray:
    """Modal damping matrix giving the frozen-liquid modes the ratios ``modal.damping``, N s/m."""
    mf = frozen_mass_matrix(modal, liquid_mass)
    w2, v = eigh(np.diag(modal.stiffness), mf)  # v^T mf v = I
    # the coupled modes keep the order of the dry ones (tank mass only shifts them a little)
    c_modal = 2.0 * modal.damping * np.sqrt(w2)
    return mf @ v @ np.diag(c_modal) @ v.T @ mf


@jax.tree_util.register_dataclass
@dataclass
class Discretisation:
    """Exact ZOH discretisation of the structure: z = [q, q'], u = [dF_1 .. dF_T, a_s].

    A JAX pytree (every field a leaf): passed into the jitted scan as data, so beams of the
    same numbers of modes and tanks share one compilation.
    """

    dt: float  # s
    Phi: np.ndarray  # (2N, 2N)
    Gam: np.ndarray  # (2N, T + 1)
    A2: np.ndarray  # (N, 2N): q'' = A2 z + B2 u
    B2: np.ndarray  # (N, T + 1)
    mass: np.ndarray  # M + sum_j m_j psi_j psi_j^T, kg
    stiffness: np.ndarray  # N/m
    damping: np.ndarray  # N s/m
    psi: np.ndarray  # (T, N) modes at the tanks
    m_total: np.ndarray  # (T,) m_struct + m_l of each tank, kg


def discretise(modal: ModalModel, liquid_mass: Any, dt: float) -> Discretisation:
    """Zero-order-hold discretisation of the coupled linear structure at step ``dt`` (s).

    ``liquid_mass`` (kg) is one value for every tank or one per tank. Unknown participation
    factors (``modal.has_participation`` False) give a zero base-input column:
    :class:`CoupledSimulator` then refuses a non-zero base acceleration.
    """
    if not (math.isfinite(dt) and dt > 0):
        raise BeamError(f"dt must be a finite positive step in s, got {dt!r}")
    n = modal.n_modes
    psi = modal.psi_tanks
    ml = liquid_masses(modal, liquid_mass)
    nt = psi.shape[0]
    mass = frozen_mass_matrix(modal, ml)
    k = np.diag(modal.stiffness)
    c = damping_matrix(modal, ml)
    mi = np.linalg.inv(mass)
    a = np.zeros((2 * n, 2 * n))
    a[:n, n:] = np.eye(n)
    a[n:, :n] = -mi @ k
    a[n:, n:] = -mi @ c
    b = np.zeros((2 * n, nt + 1))
    b[n:, :nt] = mi @ psi.T
    gamma = np.nan_to_num(modal.participation, nan=0.0)
    b[n:, nt] = -mi @ (gamma + psi.T @ ml)
    aug = np.zeros((2 * n + nt + 1, 2 * n + nt + 1))
    aug[: 2 * n, : 2 * n] = a
    aug[: 2 * n, 2 * n :] = b
    e = expm(aug * dt)
    return Discretisation(
        dt=float(dt), Phi=e[: 2 * n, : 2 * n], Gam=e[: 2 * n, 2 * n :], A2=a[n:], B2=b[n:],
        mass=mass, stiffness=k, damping=c, psi=psi.copy(),
        m_total=modal.structure_masses + ml,
    )


# ------------------------------------------------------------------------------------------
# Backends
# ------------------------------------------------------------------------------------------


def _outputs(q: Any, qdd: Any, acc: Any, df: Any, vel: Any, m_total: Any) -> dict[str, Any]:
    """The per-step outputs of every backend (NumPy or JAX arrays, time on axis 0)."""
    return {"q": q, "qdd": qdd, "tank_acceleration": acc, "dynamic_force": df,
            "interface_force": -m_total * acc + df, "tank_velocity": vel}


def simulate_jax(model: SloshingModel | Sequence[SloshingModel], disc: Discretisation,
                 base_acceleration: Any, z0: Any, unroll: int = 1) -> dict[str, Any]:
    """Coupled simulation at the model rate as a pure JAX function (``lax.scan``).

    Traceable in the model(s) and ``disc`` (pytrees): jit it, ``vmap`` it over base
    accelerations, or differentiate a function of its outputs with respect to the model's
    parameters (``jax.grad(lambda m: loss(simulate_jax(m, disc, a, z0)))(rom)``). Precision
    follows the caller's JAX configuration (float64 under ``jax.enable_x64(True)``).

    Parameters
    ----------
    model : sloshing model or sequence of sloshing models
        JAX-traceable (:func:`~sloshrom.models.is_jax_model`), stepping at ``disc.dt``; a
        sequence gives one model per tank (in the order of ``disc.psi``'s rows).
    disc : Discretisation
        The structure, :func:`discretise` d at ``model.dt``.
    base_acceleration : array_like, shape (n,)
        Base acceleration a_s, m/s^2.
    z0 : array_like, shape (2 N,)
        Initial modal displacements (m) and velocities (m/s), ``[q0, qd0]``.
    unroll : int
        Steps per trip of the scan's loop (``lax.scan``'s ``unroll``): the same results, bit
        for bit; more steps run faster once compiled but compile longer.

    Returns
    -------
    dict
        Arrays of shape (n[, N]): ``q`` (m), ``qdd`` (m/s^2); per tank, shape (n, T) for a
        sequence of models and (n,) for a single model (one tank): ``tank_acceleration``
        (m/s^2), ``dynamic_force``, ``interface_force`` (N), ``tank_velocity`` (m/s).
    """
    single = not isinstance(model, (tuple, list))
    models = (model,) if single else tuple(model)
    Phi, Gam = jnp.asarray(disc.Phi), jnp.asarray(disc.Gam)
    A2, B2, psi = jnp.asarray(disc.A2), jnp.asarray(disc.B2), jnp.asarray(disc.psi)
    n = psi.shape[1]
    if len(models) != psi.shape[0]:
        raise BeamError(f"{len(models)} sloshing model(s) for {psi.shape[0]} tank(s)")
    dt = disc.dt

    def body(carry, a_s):
        z, vs, acc_prev, states = carry
        v_abs = psi @ z[n:] + vs
        stepped = [m.step(st, v_abs[j], acc_prev[j])
                   for j, (m, st) in enumerate(zip(models, states, strict=True))]
        df = jnp.stack([jnp.asarray(f, jnp.float64) for _, f in stepped])
        u = jnp.concatenate([df, a_s[None]])
        qdd = A2 @ z + B2 @ u
        acc = psi @ qdd + a_s
        z_next = Phi @ z + Gam @ u
        return ((z_next, vs + dt * a_s, acc, tuple(st for st, _ in stepped)),
                (z[:n], qdd, acc, df, v_abs))

    carry = (jnp.asarray(z0), jnp.zeros(()), jnp.zeros(psi.shape[0]),
             tuple(m.init_state() for m in models))
    _, (q, qdd, acc, df, v) = jax.lax.scan(body, carry, jnp.asarray(base_acceleration),
                                           unroll=unroll)
    out = _outputs(q, qdd, acc, df, v, jnp.asarray(disc.m_total))
    return _squeeze_tanks(out) if single else out


def _squeeze_tanks(out: dict[str, Any]) -> dict[str, Any]:
    """One tank: drop the trailing tank axis of the per-tank outputs."""
    return {k: (v[..., 0] if k in TANK_KEYS else v) for k, v in out.items()}


@jax.tree_util.register_pytree_node_class
class _Constant:
    """A jax-traceable model that is not a pytree, carried as static data (compiled in)."""

    def __init__(self, model: SloshingModel) -> None:
        self.model = model

    def tree_flatten(self) -> tuple[tuple[()], SloshingModel]:
        return (), self.model  # compared by ==: one compilation per equal model

    @classmethod
    def tree_unflatten(cls, model: SloshingModel, children: tuple[()]) -> _Constant:
        return cls(model)


def _simulate(models: tuple, disc: Discretisation, base_acceleration: Any, z0: Any,
              unroll: int = 1) -> dict:
    return simulate_jax([m.model if isinstance(m, _Constant) else m for m in models], disc,
                        base_acceleration, z0, unroll)


@functools.cache
def _jitted(unroll: int, batch: bool) -> Any:
    # module level, the models an argument: the compiled scans are shared by every simulator
    fn = functools.partial(_simulate, unroll=unroll)
    return jax.jit(jax.vmap(fn, in_axes=(None, None, 0, None)) if batch else fn)


def _jax_argument(model: SloshingModel) -> Any:
    """The model's stepper (:func:`~sloshrom.models.stepper_of`) as a jit argument: itself if
    it is a pytree, else wrapped as a constant."""
    stepper = stepper_of(model)
    if jax.tree_util.treedef_is_leaf(jax.tree_util.tree_structure(stepper)):
        return _Constant(stepper)
    return stepper


def _numba_loop_py(step_fn, mstate, mparams, active, Phi, Gam, A2, B2, psi, a_s, z0, dt):
    # mstate, mparams: one row per active tank (same kernel); active: their tank indices
    nt = a_s.size
    ntank, n = psi.shape
    q = np.empty((nt, n))
    qdd = np.empty((nt, n))
    acc = np.empty((nt, ntank))
    dfo = np.zeros((nt, ntank))
    vel = np.empty((nt, ntank))
    z = z0.copy()
    zn = np.empty_like(z)
    vs = 0.0
    acc_prev = np.zeros(ntank)
    df = np.zeros(ntank)
    for k in range(nt):
        for t in range(ntank):
            v_abs = vs
            for i in range(n):
                v_abs += psi[t, i] * z[n + i]
            vel[k, t] = v_abs
        for j in range(active.size):
            t = active[j]
            df[t] = step_fn(mstate[j], mparams[j], vel[k, t], acc_prev[t])
        a = a_s[k]
        for i in range(n):
            s = 0.0
            for t in range(ntank):
                s += B2[i, t] * df[t]
            s += B2[i, ntank] * a
            for j in range(2 * n):
                s += A2[i, j] * z[j]
            qdd[k, i] = s
            q[k, i] = z[i]
        for t in range(ntank):
            tacc = a
            for i in range(n):
                tacc += psi[t, i] * qdd[k, i]
            acc[k, t] = tacc
            acc_prev[t] = tacc
            dfo[k, t] = df[t]
        for i in range(2 * n):
            s = 0.0
            for t in range(ntank):
                s += Gam[i, t] * df[t]
            s += Gam[i, ntank] * a
            for j in range(2 * n):
                s += Phi[i, j] * z[j]
            zn[i] = s
        z[:] = zn
        vs += dt * a
    return q, qdd, acc, dfo, vel


# the kernel's step (sloshrom.models contract) as a typed function, not as its dispatcher: a
# dispatcher argument is typed by its identity, which numba's cache cannot find again in another
# process (the loop was compiled anew, 4 s, by every process that ran the rig in a beam)
_M, _V = nb_types.float64[:, ::1], nb_types.float64[::1]
_STEP = nb_types.FunctionType(nb_types.float64(_V, _V, nb_types.float64, nb_types.float64))
_LOOP_SIGNATURE = nb_types.Tuple((_M,) * 5)(_STEP, _M, _M, nb_types.int64[::1], _M, _M, _M, _M,
                                             _M, _V, _V, nb_types.float64)


@functools.cache
def _numba_loop() -> Any:
    """The numba backend's loop, compiled (or loaded from numba's cache) on first use; without
    the GIL, so that a batch's runs share the cores (:meth:`CoupledSimulator.run_raw`)."""
    return njit(_numba_loop_py, nogil=True, signature_or_function=[_LOOP_SIGNATURE])


def _python_loop(models: Sequence[SloshingModel], d: Discretisation, a_s: np.ndarray,
                 z0: np.ndarray) -> dict:
    ntank, n = d.psi.shape
    nt = a_s.size
    q, qdd = np.empty((nt, n)), np.empty((nt, n))
    acc, dfo, vel = np.empty((nt, ntank)), np.empty((nt, ntank)), np.empty((nt, ntank))
    z, vs, acc_prev = z0.copy(), 0.0, np.zeros(ntank)
    states = [m.init_state() for m in models]
    u = np.empty(ntank + 1)
    for k in range(nt):
        vel[k] = d.psi @ z[n:] + vs
        for j, m in enumerate(models):
            states[j], f = m.step(states[j], vel[k, j], acc_prev[j])
            u[j] = float(f)
        u[ntank] = a_s[k]
        qdd[k] = d.A2 @ z + d.B2 @ u
        q[k] = z[:n]
        acc[k] = d.psi @ qdd[k] + a_s[k]
        dfo[k] = u[:ntank]
        z = d.Phi @ z + d.Gam @ u
        vs += d.dt * a_s[k]
        acc_prev = acc[k]
    return _outputs(q, qdd, acc, dfo, vel, d.m_total)


def _default_backend(models: Sequence[Any]) -> str:
    # frozen liquid has no force: any backend skips it
    active = [m for m in models if not has_no_force(m)]
    if active and all(has_kernel(m) for m in active):
        return "numba"
    return "jax" if all(is_jax_model(m) for m in models) else "python"


# ------------------------------------------------------------------------------------------
# Public API
# ------------------------------------------------------------------------------------------


class CoupledSimulator:
    """Sloshing structure: modal structure carrying one or more tanks, each with its liquid
    modelled by any sloshing model.

    Parameters
    ----------
    model : SloshingModel or sequence of SloshingModel
        Implements the contract of :mod:`sloshrom.models` (``dt``, ``init_state``, ``step``);
        one model for every tank, or one per tank (in the order of ``modal.psi_tanks``). Every
        model that is not a :class:`~sloshrom.models.FrozenLiquid` must run at the same step
        (the rig's 1e-4 s and a ROM's 1/fs do not mix: :class:`StepMismatchError`). ``"auto"``
        picks the numba backend when the sloshing tanks are all
        :class:`~sloshrom.models.CompiledKernel` s (virtual rigs), JAX when every model is a
        JAX model (:func:`~sloshrom.models.is_jax_model`), else the Python loop.
    modal : ModalModel
        Dry-structure modes (structure + tank structures); its ``psi_tank`` places the tanks.
    tank : Tank or sequence of Tank
        Gives each tank's liquid mass m_l (default: paper tank, for every tank).
    dt : float, optional
        Requested step, s; must equal the models' step (a :class:`StepMismatchError`
        otherwise).
    output_fs : float, optional
        Output sample rate, Hz (default 1/dt; must divide 1/dt). Outputs are decimated with a
        zero-phase anti-alias FIR (``scipy.signal.resample_poly``).
    backend : {"auto", "jax", "numba", "python"}
    unroll : int
        JAX backend: steps per trip of the scan's loop (bit-identical results). 1 compiles
        fastest, which suits a few runs of each model (``sloshrom reproduce``); 8 runs a
        10 s free response with an NFIR(70, 35) 1.2-1.3x faster once compiled but compiles
        2.5-3x longer, which pays off over many runs of one model and record length
        (``benchmarks/beam_speed.py``).
    """

    def __init__(
        self,
        model: SloshingModel | Sequence[SloshingModel],
        modal: ModalModel,
        tank: Tank | Sequence[Tank] | None = None,
        dt: float | None = None,
        output_fs: float | None = None,
        backend: str = "auto",
        unroll: int = 1,
    ) -> None:
        nt = modal.n_tanks
        self.model = model
        self.models = _per_tank(model, nt, "sloshing model")
        self.modal = modal
        self.tanks = _per_tank(tank if tank is not None else Tank(), nt, "tank")
        self.tank = self.tanks[0]
        mdt = _common_step(self.models)
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
            raise BeamError(
                f"output_fs = {output_fs} Hz must divide the model rate {fs} Hz by an integer"
            )
        self.decimation = int(round(ratio))
        if backend == "auto":
            backend = _default_backend(self.models)
        if backend not in ("jax", "numba", "python"):
            raise BeamError(f"unknown backend {backend!r} (jax, numba, python)")
        self.active = tuple(j for j, m in enumerate(self.models) if not has_no_force(m))
        if backend == "numba":
            kernels = [self.models[j] for j in self.active]
            if not kernels or not all(has_kernel(m) for m in kernels):
                raise BeamError("the numba backend needs a model with kernel()")
            if len({id(m.kernel()[0]) for m in kernels}) > 1:
                raise BeamError("the numba backend needs one kernel for every sloshing tank; "
                                 "use backend='python' for different kernels")
        if backend == "jax" and not all(is_jax_model(m) for m in self.models):
            raise BeamError("the jax backend needs a jax-traceable model (sloshrom.models."
                             "JaxModel)")
        self.backend = backend
        if not (isinstance(unroll, (int, np.integer)) and unroll >= 1):
            raise BeamError(f"unroll must be a positive integer, got {unroll!r}")
        self.unroll = int(unroll)
        self.disc = discretise(modal, [t.liquid_mass for t in self.tanks], mdt)

    # -- core -------------------------------------------------------------------------------
    def _z0(self, q0: Any, qd0: Any) -> np.ndarray:
        n = self.modal.n_modes
        z0 = np.zeros(2 * n)
        if q0 is not None:
            z0[:n] = np.broadcast_to(np.asarray(q0, dtype=float), (n,))
        if qd0 is not None:
            z0[n:] = np.broadcast_to(np.asarray(qd0, dtype=float), (n,))
        return z0

    def _numba(self, row: np.ndarray, z0: np.ndarray) -> dict:
        kernels = [self.models[j].kernel() for j in self.active]
        step_fn = kernels[0][0]
        try:
            params = np.stack([np.asarray(k[1], dtype=np.float64) for k in kernels])
            states = np.stack([np.asarray(k[2], dtype=np.float64) for k in kernels])
        except ValueError as exc:  # kernels of different sizes cannot share one loop
            raise BeamError("the numba backend needs sloshing tanks whose kernels have "
                             "parameter and state arrays of one size") from exc
        d = self.disc
        c = np.ascontiguousarray
        q, qdd, acc, dfo, vel = _numba_loop()(
            step_fn, states, params, np.asarray(self.active, dtype=np.int64), c(d.Phi), c(d.Gam),
            c(d.A2), c(d.B2), c(d.psi), c(row), c(z0), float(d.dt),
        )
        return _outputs(q, qdd, acc, dfo, vel, d.m_total)

    @float64
    def run_raw(self, base_acceleration: Any, q0: Any = None, qd0: Any = None) -> dict:
        """Simulate at the model rate; arrays of shape (batch..., n[, n_modes]) and, for the
        per-tank outputs of a structure with a 2-D ``psi_tank``, (batch..., n, n_tanks); no
        decimation."""
        a = np.asarray(base_acceleration, dtype=np.float64)
        if a.ndim == 0:
            raise BeamError("base_acceleration must have a time axis")
        if not np.all(np.isfinite(a)):
            raise BeamError("base_acceleration must be finite")
        if not self.modal.has_participation and np.any(a != 0):
            raise ModalDataError(
                "the modal model has no participation factors (kg), which base excitation "
                "needs; give them (a 'participation' column of the mode table) or run a free "
                "response")
        z0 = self._z0(q0, qd0)
        lead = a.shape[:-1]
        flat = a.reshape(-1, a.shape[-1])
        if self.backend == "jax":
            m, d, zj = tuple(_jax_argument(m) for m in self.models), self.disc, jnp.asarray(z0)
            if flat.shape[0] > 1:
                res = _jitted(self.unroll, True)(m, d, jnp.asarray(flat), zj)
                out = {k: np.asarray(v) for k, v in res.items()}
            else:
                # the batch axis added in NumPy (in jnp it would compile for each shape)
                res = _jitted(self.unroll, False)(m, d, jnp.asarray(flat[0]), zj)
                out = {k: np.asarray(v)[None] for k, v in res.items()}
        else:
            if self.backend == "numba":
                # the batch's runs (e.g. a random test's levels) in threads, a core each
                outs = map_threads(lambda row: self._numba(row, z0), list(flat))
            else:
                outs = [_python_loop(self.models, self.disc, row, z0) for row in flat]
            out = {k: np.stack([o[k] for o in outs]) for k in outs[0]}
        self._check_divergence(out["q"])
        out = {k: v.reshape(lead + v.shape[1:]) for k, v in out.items()}
        return _squeeze_tanks(out) if self.modal.psi_tank.ndim == 1 else out

    def _check_divergence(self, q: np.ndarray) -> None:
        """Stop with the time of divergence instead of returning NaNs.

        Diverged = a non-finite modal displacement, or a displacement of a tank or output
        point larger than the structure itself (its length; 10 m without one): no longer a
        vibration.
        """
        bound = float(getattr(self.modal, "length", None) or 10.0)
        finite = np.isfinite(q).all(axis=-1)
        qf = np.where(finite[..., None], q, 0.0)
        bad = ~finite
        for shape in np.vstack([self.modal.psi_tanks, self.modal.psi_stations]):
            bad |= np.abs(qf @ shape) > bound  # one point at a time: bounded memory
        if not bad.any():
            return
        k = int(np.argmax(bad.reshape(bad.shape[0], -1).any(axis=0)))
        raise SimulationDivergedError(
            f"the coupled simulation diverged at t = {k * self.disc.dt:.4g} s "
            f"(modal displacement non-finite or a point beyond {bound:g} m); the sloshing "
            f"model ({', '.join(sorted({type(m).__name__ for m in self.models}))}) is "
            "probably outside its valid range"
        )

    def _per_tank_columns(self, x: np.ndarray) -> list[np.ndarray]:
        return [x] if self.modal.psi_tank.ndim == 1 else [x[..., j] for j in range(x.shape[-1])]

    def _check_envelope(self, v: np.ndarray, acc: np.ndarray) -> None:
        # a ROM inside the loop cannot warn from within lax.scan: check its input afterwards
        for j, (model, vj, aj) in enumerate(zip(self.models, self._per_tank_columns(v),
                                                self._per_tank_columns(acc), strict=True)):
            where = "" if self.modal.psi_tank.ndim == 1 else f" of tank {j + 1}"
            check_envelope(model, model_input(model, vj, aj),
                           what=f"tank {input_of(model)}{where}", stacklevel=3)

    def _coverage(self, v: np.ndarray, acc: np.ndarray) -> tuple[Any, Any, Any]:
        covs = [envelope_coverage(envelope_of(m), model_input(m, vj, aj), aj)
                for m, vj, aj in zip(self.models, self._per_tank_columns(v),
                                     self._per_tank_columns(acc), strict=True)]
        if self.modal.psi_tank.ndim == 1:
            c = covs[0]
            return c.outside_fraction, c.acceleration_ratio, c.training_peak_acceleration
        return (np.stack([c.outside_fraction for c in covs], axis=-1),
                np.stack([c.acceleration_ratio for c in covs], axis=-1),
                np.array([c.training_peak_acceleration for c in covs]))

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
            (:func:`sloshrom.beam.simulation.envelope.envelope_coverage`, shape (...), NaN for a
            model without an envelope): ``envelope_outside_fraction`` (-),
            ``envelope_acceleration_ratio`` (peak tank acceleration / training peak
            acceleration, -) and ``training_peak_acceleration`` (m/s^2). With a 2-D
            ``psi_tank`` (several tanks) the four per-tank signals have a trailing tank axis,
            (..., n, n_tanks), the coverage entries shape (..., n_tanks), and
            ``training_peak_acceleration`` one value per tank.
        """
        a = np.asarray(base_acceleration, dtype=np.float64)
        raw = self.run_raw(a, q0, qd0)
        self._check_envelope(raw["tank_velocity"], raw["tank_acceleration"])
        outside, ratio, train_peak = self._coverage(raw["tank_velocity"],
                                                    raw["tank_acceleration"])
        raw["base_acceleration"] = a
        dec = self.decimation
        out: dict[str, Any] = {}
        for k, v in raw.items():
            if dec == 1:
                out[k] = v
            else:
                out[k] = resample_poly(v, 1, dec, axis=a.ndim - 1, padtype="line")
        n_out = out["base_acceleration"].shape[-1]
        out["time"] = np.arange(n_out) / self.output_fs
        out["fs"] = self.output_fs
        out["modal_acceleration"] = out.pop("qdd")
        out["station_acceleration"] = (
            out["modal_acceleration"] @ self.modal.psi_stations.T
            + out["base_acceleration"][..., None]
        )
        out["stations"] = self.modal.stations
        out["envelope_outside_fraction"] = outside
        out["envelope_acceleration_ratio"] = ratio
        out["training_peak_acceleration"] = train_peak
        return out


def _per_tank(value: Any, n_tanks: int, what: str) -> tuple:
    """One value per tank: a sequence of ``n_tanks`` or one value for every tank."""
    if isinstance(value, (list, tuple)):
        if len(value) != n_tanks:
            raise BeamError(f"{len(value)} {what}(s) for a structure with {n_tanks} tank(s)")
        return tuple(value)
    return (value,) * n_tanks


def _common_step(models: Sequence[SloshingModel]) -> float:
    """The step every sloshing (not frozen) model runs at, s; frozen tanks follow it."""
    active = [m for m in models if not has_no_force(m)] or list(models)
    steps = [float(m.dt) for m in active]
    if any(not math.isclose(x, steps[0], rel_tol=1e-9) for x in steps):
        raise StepMismatchError(
            "the tanks' sloshing models run at different steps ("
            + ", ".join(f"{type(m).__name__} {x:g} s" for m, x in zip(active, steps, strict=True))
            + "); one coupled simulation needs one step (frozen tanks adapt)")
    return steps[0]


def free_response(
    model: SloshingModel | Sequence[SloshingModel],
    modal: ModalModel,
    tip_displacement: float = 0.0146,
    duration: float = 10.0,
    tank: Tank | Sequence[Tank] | None = None,
    output_fs: float | None = None,
    load_tank: int = 0,
) -> dict:
    """Free response released at rest from the static tip-load shape (paper Sect. 4.3).

    Parameters
    ----------
    model, tank
        One for every tank or one per tank (:class:`CoupledSimulator`).
    tip_displacement : float
        Initial displacement of the loaded tank, m (paper: 1.46 cm).
    duration : float
        s.
    load_tank : int
        With several tanks: the tank (0-based) at which the static force acts.

    Returns
    -------
    dict
        As :meth:`CoupledSimulator.run`, plus ``q0``.
    """
    sim = CoupledSimulator(model, modal, tank=tank, output_fs=output_fs)
    n = int(round(duration / sim.dt))
    q0 = modal.static_tip_state(tip_displacement, tank=load_tank)
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
    model: SloshingModel | Sequence[SloshingModel],
    modal: ModalModel,
    rms_levels_g: Any = (0.1, 0.2, 0.4),
    duration: float = 90.0,
    seed: int = 0,
    f0: float = 12.0,
    sigma: float = 4.0,
    signal_fs: float = 500.0,
    tank: Tank | Sequence[Tank] | None = None,
    output_fs: float | None = None,
    fade: float = 1.0,
    gain: float = 1.0,
) -> dict:
    """Random base excitation (paper Sect. 4.4): Gaussian-PSD a_s at several RMS levels.

    The base acceleration is made at ``signal_fs`` (same phases for all levels) and, if the
    model runs faster (rig), upsampled band-limited, so that every model sees the same signal.

    Parameters
    ----------
    rms_levels_g : sequence of float
        RMS of the base acceleration **in g** (paper: 0.1, 0.2, 0.4).
    duration : float
        s (paper: 90).
    seed : int or sequence of int
        Phase seed(s); several seeds give a batch of shape (n_seeds, n_levels, n).
    f0, sigma : float
        PSD centre and standard deviation, Hz (estimates).
    gain : float
        Factor on every level's signal, -: 1 = the test as asked; close to 1, the same test
        with its input's gain changed (a twin run, ``sloshrom.pipeline.waveform``).
        ``rms_levels_g`` is returned as given.

    Returns
    -------
    dict
        As :meth:`CoupledSimulator.run` with leading axes ([seed,] level).
    """
    sim = CoupledSimulator(model, modal, tank=tank, output_fs=output_fs)
    fs_model = 1.0 / sim.dt
    factor = fs_model / signal_fs
    if abs(factor - round(factor)) > 1e-6 or round(factor) < 1:
        raise BeamError(f"model rate {fs_model} Hz must be an integer multiple of {signal_fs} Hz")
    # the gain scales the levels: the same phases, every sample times gain (1.0 is exact)
    levels = np.asarray(rms_levels_g, dtype=float) * G * gain
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
    out["rms_levels_g"] = np.asarray(rms_levels_g, dtype=float)
    return out


def modal_energy(d: Discretisation, q: np.ndarray, qd: np.ndarray) -> np.ndarray:
    """Mechanical energy of the (frozen) structure, J: ``q'^T M q'/2 + q^T K q/2``."""
    return 0.5 * np.einsum("...i,ij,...j->...", qd, d.mass, qd) + 0.5 * np.einsum(
        "...i,ij,...j->...", q, d.stiffness, q
    )
