"""The neural state-space ROM's model: a network with an internal state, and its encoder.

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

Everything here is a pure function of explicit arguments or an immutable pytree; the training
is :mod:`sloshrom.rom.nss.training`, the estimator :class:`sloshrom.rom.NSS`.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from functools import partial
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np
from jax import lax

from sloshrom._x64 import float64
from sloshrom.models import model_input
from sloshrom.rom.errors import ROMError
from sloshrom.rom.network import FittedNetwork, MinMaxScaler
from sloshrom.rom.nss.entry import NSS_CLASS, NSS_PARAM_NAMES, nss_shapes
from sloshrom.rom.registry import ModelClass
from sloshrom.rom.shooting import ss_encode

__all__ = [
    "NSS_PARAM_NAMES",
    "StateSpaceNetwork",
    "StateSpaceSpec",
    "param_shapes",
    "ss_free_run",
    "ss_history_run",
    "ss_simulate",
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
        ru, ry = (float(r) for r in self._rest())
        return self._checked_free_run(u, lambda u2: np.asarray(
            ss_free_run(self.params, jnp.asarray(self.scaler.u(u2).T), ru, ry)).T)

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
