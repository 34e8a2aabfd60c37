"""The neural state-space ROM: a model with an internal state, identified by simulation error.

Model equations (scaled units of :class:`~sloshrom.rom.network.MinMaxScaler`; ``u_k`` the scaled
input, ``r_u``/``r_y`` the scaled rest input and output, ``z_k = [x_k, u_k]``)::

    x_{k+1} = x_k + F(z_k) - F(z_rest),   F(z) = z A + tanh(z W1 + b1) W2
    y_k     = H(z_k) - H(z_rest) + r_y,    H(z) = z C + tanh(z V1 + d1) V2

with ``z_rest = [0, r_u]``: the state ``x = 0`` with the tank at rest is an equilibrium whose
output is the physical zero force, by construction. A strictly proper model
(``NSS(feedthrough="no")``) holds the input's rows of ``C`` and ``V1`` at zero: ``y_k`` is a
function of ``x_k`` alone. A run from rest (the coupled beam, the
energy maps, :meth:`StateSpaceNetwork.free_run`) starts there.

An **encoder** estimates the state from the ``window`` samples of input and output that precede
a start (the subspace encoder of SUBNET: Beintema, Schoukens and Toth, Automatica 2023)::

    x_0 = E(q) - E(0),   E(q) = tanh(q E1 + e1) E2,   q = [u_past - r_u, y_past - r_y]

so a window at rest encodes the rest state. Training uses it to start each of many short
simulations (multiple shooting) from where the record is, not from rest;
:meth:`StateSpaceNetwork.encode` gives the state for a user who has measured history. The
coupled beam and the maps never need it: they start at rest.

Training (:func:`fit_statespace`, epochs run by :func:`sloshrom.rom.engine.adam_epochs`):
minibatch Adam (``optax``) on the simulation error of
``batch`` sub-sequences of ``horizon`` samples drawn at random from the record, each started by
the encoder; early stopping on the free run of the whole validation record from rest (the same
test as the NFIR's). The loss terms of the passive recipe carry over: amplitude weights
(:func:`sloshrom.rom.training.amplitude_weights`), the error of the energy each sub-sequence
exchanges with the liquid (the state-space form of the cycle-energy term) and a passivity
penalty on harmonic probes run from rest inside the training envelope, simulated in the same
batch as the data.

Everything here is a pure function of explicit arguments; the estimator is
:class:`sloshrom.rom.NSS`.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from functools import partial
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np
from jax import lax

from sloshrom._x64 import float64
from sloshrom.models import model_input
from sloshrom.rom.engine import AdamProblem, adam_epochs
from sloshrom.rom.errors import ROMError
from sloshrom.rom.losses import TRAIN_DTYPE
from sloshrom.rom.network import FittedNetwork, MinMaxScaler
from sloshrom.rom.registry import NSS_CLASS, ModelClass, nss_shapes
from sloshrom.rom.shooting import PyTree, Recurrence, ShootingOptions
from sloshrom.rom.shooting import shooting_problem as shooting

#: The arrays of a neural state-space network, in file order.
NSS_PARAM_NAMES = NSS_CLASS.param_names()
#: The state-space ROM's multiple-shooting recipe by default (its estimator passes its own)
NSS_SHOOTING = ShootingOptions()

__all__ = [
    "NSS_PARAM_NAMES",
    "StateSpaceNetwork",
    "StateSpaceSpec",
    "fit_statespace",
    "init_params",
    "shooting_problem",
    "param_shapes",
    "ss_encode",
    "ss_free_run",
    "ss_history_run",
    "ss_step",
    "strictly_proper",
]

@dataclass(frozen=True)
class StateSpaceSpec:
    """The static architecture of a state-space network (hashable: a jit static argument).

    Parameters
    ----------
    n_states : int
        Dimension of the state x.
    neurons : int
        Hidden tanh units of each of F, H and the encoder E.
    window : int
        Samples of past input and output the encoder reads.
    proper : bool
        Strictly proper: the output map reads the state alone (the input rows of ``C`` and
        ``V1`` held at zero, :func:`strictly_proper`).
    """

    n_states: int
    neurons: int
    window: int
    proper: bool = False

    @property
    def n_params(self) -> int:
        """The number of trained parameters."""
        return sum(math.prod(s) for s in param_shapes(self).values())

    @property
    def max_delay(self) -> int:
        """The longest history the model reads from a record: the encoder window, samples."""
        return self.window

    @property
    def n_inputs(self) -> int:
        """Inputs of F and H: the state and the scaled input."""
        return self.n_states + 1


def param_shapes(spec: StateSpaceSpec) -> dict[str, tuple[int, ...]]:
    """Shape of every parameter array of ``spec`` (:data:`NSS_PARAM_NAMES` order)."""
    return nss_shapes({"n_states": spec.n_states, "neurons": spec.neurons,
                       "window": spec.window})


def init_params(spec: StateSpaceSpec, seed: int) -> dict[str, np.ndarray]:
    """Seeded initial parameters: tanh layers scaled by 1/sqrt(fan-in), small linear parts and
    output layers so that the untrained model is a slow, nearly linear system."""
    rng = np.random.default_rng(seed)
    out = {}
    for name, shape in param_shapes(spec).items():
        if name in ("b1", "d1", "e1"):
            out[name] = np.zeros(shape)
            continue
        fan_in = shape[0]
        small = 0.1 if name in ("A", "W2", "C", "V2", "E2") else 1.0
        out[name] = small * rng.standard_normal(shape) / math.sqrt(fan_in)
    # a slowly decaying linear part: the untrained model is stable over a whole horizon
    out["A"][: spec.n_states] -= 0.05 * np.eye(spec.n_states)
    return out


# ---------------------------------------------------------------------------------------------
# Pure model functions (scaled units)
# ---------------------------------------------------------------------------------------------


def strictly_proper(p: Mapping[str, jax.Array]) -> dict[str, jax.Array]:
    """``p`` with the input rows of the output map (the last rows of ``C`` and ``V1``) at zero:
    ``y_k = H(x_k)``, no direct feed-through. The rows stay in the arrays, so every reader of
    the file layout (the FMU, ONNX) runs the strictly proper model unchanged; the gradient
    through them is zero, so Adam never moves them."""
    return {**p, "C": p["C"].at[-1].set(0.0), "V1": p["V1"].at[-1].set(0.0)}


def _f(p: dict[str, Any], z: Any) -> Any:
    return z @ p["A"] + jnp.tanh(z @ p["W1"] + p["b1"]) @ p["W2"]


def _h(p: dict[str, Any], z: Any) -> Any:
    return z @ p["C"] + jnp.tanh(z @ p["V1"] + p["d1"]) @ p["V2"]


def _rest_terms(p: dict[str, Any], r_u: Any, n_states: int) -> tuple[Any, Any]:
    z0 = jnp.concatenate([jnp.zeros(n_states, dtype=p["A"].dtype),
                          jnp.reshape(jnp.asarray(r_u, p["A"].dtype), (1,))])
    return _f(p, z0), _h(p, z0)


def ss_step(p: dict[str, Any], x: Any, u_s: Any, r_u: Any, r_y: Any) -> tuple[Any, Any]:
    """One step in scaled units: ``(x_{k+1}, y_k)`` from ``x_k`` (..., nx) and ``u_k`` (...)."""
    nx = p["A"].shape[1]
    f0, h0 = _rest_terms(p, r_u, nx)
    z = jnp.concatenate([x, jnp.asarray(u_s, x.dtype)[..., None]], axis=-1)
    return x + _f(p, z) - f0, _h(p, z) - h0 + r_y


def ss_simulate(p: dict[str, Any], x0: Any, u_s: Any, r_u: Any, r_y: Any,
                unroll: int = 1) -> tuple[Any, Any]:
    """Simulation from ``x0`` (b, nx) of the scaled inputs ``u_s`` (n, b): ``(x_n, y (n, b))``.

    ``unroll``: steps per iteration of the compiled loop (:func:`jax.lax.scan`); the same
    arithmetic.
    """

    def body(x: Any, uk: Any) -> tuple[Any, Any]:
        return ss_step(p, x, uk, r_u, r_y)

    return lax.scan(body, x0, u_s, unroll=unroll)


@jax.jit
def ss_free_run(p: dict[str, Any], u_s: Any, r_u: Any, r_y: Any) -> Any:
    """Free run from rest of scaled inputs ``u_s`` (n, b); the scaled outputs (n, b)."""
    x0 = jnp.zeros((u_s.shape[1], p["A"].shape[1]), dtype=p["A"].dtype)
    # unrolled by 8: 1.5x faster for one long record (a validation run), as measured; no gain
    # for the batches of training
    return ss_simulate(p, x0, u_s, r_u, r_y, unroll=8)[1]


def ss_encode(p: dict[str, Any], u_past: Any, y_past: Any, r_u: Any, r_y: Any) -> Any:
    """State (..., nx) from the scaled past ``window`` inputs and outputs (..., window), oldest
    first; a window at rest gives the rest state 0."""
    q = jnp.concatenate([u_past - r_u, y_past - r_y], axis=-1)
    e0 = jnp.tanh(p["e1"]) @ p["E2"]
    return jnp.tanh(q @ p["E1"] + p["e1"]) @ p["E2"] - e0


@jax.jit
def ss_history_run(p: dict[str, jax.Array], u_past: jax.Array, y_past: jax.Array,
                   u_s: jax.Array, r_u: float, r_y: float) -> jax.Array:
    """Run of the scaled input ``u_s`` (n,) from the state encoded from measured history: the
    last ``window`` samples of the scaled ``u_past``/``y_past`` (oldest first); the scaled
    outputs (n,)."""
    w = p["E1"].shape[0] // 2
    x0 = ss_encode(p, u_past[u_past.shape[0] - w:], y_past[y_past.shape[0] - w:], r_u, r_y)
    return ss_simulate(p, x0[None, :], u_s[:, None], r_u, r_y, unroll=8)[1][:, 0]


# ---------------------------------------------------------------------------------------------
# The fitted model
# ---------------------------------------------------------------------------------------------


@partial(jax.tree_util.register_dataclass, data_fields=["params", "scaler"],
         meta_fields=["spec", "input", "fs", "unstable_bound"])
@dataclass(frozen=True, eq=False)
class StateSpaceNetwork(FittedNetwork):
    """A fitted neural state-space ROM: an immutable sloshing model and a JAX pytree.

    Parameters
    ----------
    params : dict
        The arrays of :data:`NSS_PARAM_NAMES` (:func:`param_shapes`).
    scaler : MinMaxScaler
        Bounds of the training input and output (physical units).
    spec : StateSpaceSpec
        The architecture.
    input : {"velocity"}
        The tank signal the model reads.
    fs : float
        Sample rate of the training record, Hz; the model's step is ``dt = 1 / fs``.
    unstable_bound : float
        A run whose scaled output exceeds this magnitude (or is not finite) is unstable.
    """

    params: dict[str, Any]
    scaler: MinMaxScaler
    spec: StateSpaceSpec
    input: str = "velocity"
    fs: float = 1.0
    unstable_bound: float = 10.0

    _simulation = "state-space simulation"

    @property
    def feedthrough(self) -> bool:
        """Whether the force reads the current input directly (False: strictly proper)."""
        return bool(np.any(np.asarray(self.params["C"])[-1])
                    or np.any(np.asarray(self.params["V1"])[-1]))

    @property
    def model_class(self) -> ModelClass:
        """The class's registry entry."""
        return NSS_CLASS

    def describe(self) -> str:
        """A one-line description of the model."""
        return f"NSS ({self.spec.n_states} states, {self.spec.neurons} neurons)"

    def fmu_member(self) -> tuple[str, dict[str, np.ndarray], dict[str, float | int | str]]:
        """The FMU's C data of this model: member kind, arrays and constants."""
        p = {k: np.asarray(v, dtype=np.float64) for k, v in self.params.items()}
        return ("SL_NSS", {k: p[k] for k in ("A", "W1", "b1", "W2", "C", "V1", "d1", "V2")},
                {"hidden": "SL_HIDDEN_MATLAB", "n_states": self.spec.n_states,
                 "neurons": self.spec.neurons})

    def init_state(self) -> Any:
        """The rest state: zeros, shape (n_states,) (NumPy float64: the precision of the
        caller's JAX configuration once traced)."""
        return np.zeros(self.spec.n_states)

    def step(self, state: Any, velocity: Any, acceleration: Any = None) -> tuple[Any, Any]:
        """One pure, jax-traceable step: ``(x_{k+1}, dynamic_force_k)`` from the velocity v_k
        (m/s). The force at k depends on the state and, unless the model is strictly proper
        (:attr:`feedthrough` False), on v_k: it is known once v_k is."""
        ru, ry = self._rest()
        u_s = self.scaler.u(jnp.asarray(model_input(self, velocity, acceleration), jnp.float64))
        x, y_s = ss_step(self.params, state, u_s, ru, ry)
        return x, self.scaler.y_inverse(y_s)

    @float64
    def free_run(self, u: Any) -> np.ndarray:
        """Free-run output from rest for an input record at ``fs`` (physical units).

        Parameters
        ----------
        u : array_like, shape (n,) or (batch, n)
            The model's input, finite (checked by the caller).

        Returns
        -------
        ndarray, same shape as ``u``
            Output (physical units, N), float64.

        Raises
        ------
        UnstableModelError
            The run left the stability bound.
        """
        u = np.asarray(u, dtype=np.float64)
        u2 = np.atleast_2d(u)
        ru, ry = (float(r) for r in self._rest())
        y_s = np.asarray(ss_free_run(self.params, jnp.asarray(self.scaler.u(u2).T), ru, ry)).T
        self._check_stable(y_s)
        out = np.asarray(self.scaler.y_inverse(y_s))
        return out if u.ndim == 2 else out[0]

    @property
    def history_samples(self) -> int:
        """The encoder's window."""
        return int(self.spec.window)

    def _history_run(self, u_past: np.ndarray, y_past: np.ndarray, u: np.ndarray
                     ) -> np.ndarray:
        ru, ry = (float(r) for r in self._rest())
        s = self.scaler
        y_s = np.asarray(ss_history_run(self.params, jnp.asarray(s.u(u_past)),
                                        jnp.asarray(s.y(y_past)), jnp.asarray(s.u(u)), ru, ry))
        self._check_stable(y_s)
        return np.asarray(s.y_inverse(y_s))

    @float64
    def encode(self, u_past: Any, y_past: Any) -> np.ndarray:
        """The state at the sample after measured history (physical units, oldest first).

        Parameters
        ----------
        u_past, y_past : array_like, shape (window,)
            The ``spec.window`` input (m/s) and output (N) samples before the start.

        Returns
        -------
        ndarray, shape (n_states,)
            A state to pass to :meth:`step` instead of :meth:`init_state`.

        Raises
        ------
        ROMError
            Histories of another length.
        """
        up = np.asarray(u_past, dtype=np.float64)
        yp = np.asarray(y_past, dtype=np.float64)
        w = self.spec.window
        if up.shape != (w,) or yp.shape != (w,):
            raise ROMError(f"the encoder reads {w} past samples of input and output, got "
                           f"shapes {up.shape} and {yp.shape}")
        ru, ry = self._rest()
        return np.asarray(ss_encode(self.params, jnp.asarray(self.scaler.u(up)),
                                    jnp.asarray(self.scaler.y(yp)), ru, ry))



# ---------------------------------------------------------------------------------------------
# Training: multiple shooting with the passive recipe's loss terms
# ---------------------------------------------------------------------------------------------


def _as64(p: dict[str, Any]) -> dict[str, Any]:
    return {k: jnp.asarray(v, jnp.float64) for k, v in p.items()}


def shooting_problem(
    spec: StateSpaceSpec,
    u: np.ndarray,
    y: np.ndarray,
    fs: float,
    scaler: MinMaxScaler,
    validation: tuple[np.ndarray, np.ndarray] | None = None,
    options: ShootingOptions = NSS_SHOOTING,
    seed: int = 0,
    validation_history: int = 0,
) -> AdamProblem:
    """The multiple-shooting problem of :func:`fit_statespace` for the training engine
    (:func:`sloshrom.rom.engine.adam_epochs`); the parameters are :func:`fit_statespace`'s.

    Call it inside ``jax.enable_x64(True)``: the validation runs in float64, the Adam steps in
    :data:`~sloshrom.rom.training.TRAIN_DTYPE`.
    """
    n, w, T = np.size(u), spec.window, int(options.horizon)
    if n < w + T + 1:
        raise ROMError(f"{n} samples are too few for an encoder window of {w} and a horizon "
                       f"of {T} samples (need at least {w + T + 1})")
    ru, ry = float(scaler.u(0.0)), float(scaler.y(0.0))
    f32 = TRAIN_DTYPE
    u_s = jnp.asarray(scaler.u(np.asarray(u, dtype=np.float64)), f32)
    y_s = jnp.asarray(scaler.y(np.asarray(y, dtype=np.float64)), f32)

    def start(p: PyTree, starts: jax.Array, shift: jax.Array) -> jax.Array:
        # the state encoded from the window of measured input and output before the start
        past = starts[:, None] + jnp.arange(w)[None, :]
        return ss_encode(p, u_s[past] + shift[:, None], y_s[past], ru, ry)

    out_map = strictly_proper if spec.proper else (lambda p: p)

    def simulate(p: PyTree, x0: jax.Array, uf: jax.Array) -> jax.Array:
        return ss_simulate(out_map(p), x0, uf.T, ru, ry)[1].T

    def free_run(p: PyTree, uv: np.ndarray) -> np.ndarray:
        return np.asarray(ss_free_run(_as64(out_map(p)), jnp.asarray(uv)[:, None], ru,
                                      ry))[:, 0]

    def history_run(p: PyTree, up: np.ndarray, yp: np.ndarray, uv: np.ndarray) -> np.ndarray:
        return np.asarray(ss_history_run(_as64(out_map(p)), jnp.asarray(up), jnp.asarray(yp),
                                         jnp.asarray(uv), ru, ry))

    rec = Recurrence(offset=w, n_starts=n - w - T, start=start,
                     rest=lambda k: jnp.zeros((k, spec.n_states), f32), simulate=simulate,
                     free_run=free_run, history_run=history_run)
    params0 = out_map({k: jnp.asarray(v, f32) for k, v in init_params(spec, seed).items()})
    return shooting(rec, params0, u, y, fs, scaler, validation, options, validation_history)


@float64
def fit_statespace(
    spec: StateSpaceSpec,
    u: np.ndarray,
    y: np.ndarray,
    fs: float,
    scaler: MinMaxScaler,
    validation: tuple[np.ndarray, np.ndarray] | None = None,
    options: ShootingOptions = NSS_SHOOTING,
    *,
    max_fail: int = 6,
    seed: int = 0,
    callback: Callable[[int, dict], Any] | None = None,
    validation_history: int = 0,
) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
    """Identify a state-space network by multiple shooting (see the module docstring).

    Parameters
    ----------
    spec : StateSpaceSpec
    u, y : ndarray, shape (n,)
        Input (m/s) and output (N) records at ``fs``, physical units.
    fs : float
        Sample rate, Hz.
    scaler : MinMaxScaler
        Scaling of input and output (normally fitted on ``u``, ``y``).
    validation : (u_val, y_val), optional
        Early stopping: the free run of the whole record from rest; the best parameters are
        returned. Without it, the epoch of the lowest training MSE.
    validation_history : int
        The validation record's first samples (>= ``spec.window``) taken as measured history:
        the run starts from the state the encoder gives for them and is scored after them
        (a validation record that does not start at rest); 0: from rest.
    options : ShootingOptions
        The recipe (:class:`sloshrom.rom.shooting.ShootingOptions`): horizon (samples simulated
        from each encoded start), batch, epochs of ``steps_per_epoch`` Adam steps at most, the
        learning rate, the passive recipe's weights (0 = off), the probes.
    max_fail : int
        Epochs without a new best validation objective before stopping, once half of
        ``options.max_epochs`` have run.
    seed : int
        Seeds the initialisation and the draws of sub-sequences and probes.
    callback : callable, optional
        ``callback(epoch, info)`` after every epoch; True stops the training.

    Returns
    -------
    params : dict of ndarray
        The parameters (scaled units).
    history : dict
        Per-epoch ``train_mse``, ``val_mse`` (N^2), ``val_objective``, ``seconds``,
        ``step_seconds``, ``validation_seconds`` (:func:`sloshrom.rom.engine.adam_epochs`);
        ``stop_reason``, ``best_epoch``, ``trainer`` ("shooting"), ``n_rows``,
        ``train_seconds``.
    """
    problem = shooting_problem(spec, u, y, fs, scaler, validation, options, seed,
                               validation_history)
    t0 = time.perf_counter()
    # no early stop in the first half of the cosine schedule, and a blow-up (validation 10x
    # the best) continues from the best epoch: on a CPU with another instruction set a member
    # blew up twice and stopped at epoch 15 of 60 (map error 64 %, its twin's 9 %)
    res = adam_epochs(problem, max_epochs=int(options.max_epochs), max_fail=max_fail,
                      min_epochs=int(options.max_epochs) // 2, rollback=10.0, seed=seed,
                      mse_scale=scaler.out_half_range**2, callback=callback)
    history: dict[str, Any] = dict(res.history)
    history.update(stop_reason=res.stop_reason, best_epoch=res.best_epoch, trainer="shooting",
                   n_rows=int(np.asarray(u).size), train_seconds=time.perf_counter() - t0)
    params = strictly_proper(res.params) if spec.proper else res.params
    return {k: np.asarray(v, dtype=np.float64) for k, v in params.items()}, history
