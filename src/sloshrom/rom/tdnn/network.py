"""The pure network of the NFIR/NOE ROMs: normalized RBF layer, delay lines, fitted networks.

Everything here is a pure JAX function of explicit arguments (no estimator object): the
estimators (:mod:`sloshrom.rom.tdnn.estimators`) and the trainers
(:mod:`sloshrom.rom.tdnn.training`) are both built on it. Units are the min-max *scaled* ones
(``s(v) = 2 (v - v_min)/(v_max - v_min) - 1``) unless a docstring says otherwise.

Model equations:

- regressor at step k: ``x_k = [u_{k-d_1}, ..., u_{k-d_n}]`` (delays ``d_i``, samples); the NOE
  appends its own past outputs ``[y^_{k-1}, ..., y^_{k-m}]``;
- hidden layer, normalized RBF, ``a_j = exp(-n_j^2) / sum_l exp(-n_l^2)`` with ``"matlab"``:
  ``n_j = W_j . x + b_j`` (MATLAB ``radbasn``) or ``"distance"``: ``n_j = b_j ||x - C_j||``;
- linear output ``y = sum_j c_j a_j + c_0``.

The parameters are ``{"W": (H, D), "b": (H,), "c": (H,), "c0": ()}`` or the same packed into one
vector ``theta`` of length ``H (D + 2) + 1`` (:func:`pack`, :func:`unpack`). Hyperparameters
(delays, neurons, hidden kind, output delays) are static arguments of the jitted functions: one
compilation per architecture and input shape.

Precision follows the caller's JAX configuration; the estimators and trainers call these
functions inside ``jax.enable_x64(True)`` (:mod:`sloshrom._x64`).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from functools import partial
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np
from jax import lax

from sloshrom._x64 import float64
from sloshrom.limits import HIDDEN_KINDS
from sloshrom.models import model_input
from sloshrom.rom.errors import ROMError
from sloshrom.rom.losses import windows
from sloshrom.rom.network import FittedNetwork, MinMaxScaler
from sloshrom.rom.registry import ModelClass
from sloshrom.rom.tdnn.entry import NFIR_CLASS, NOE_CLASS, PARAM_NAMES, check_delays

__all__ = [
    "MinMaxScaler",
    "NFIRNetwork",
    "NOENetwork",
    "Network",
    "NetworkSpec",
    "PARAM_NAMES",
    "check_delays",
    "hidden_activations",
    "n_params",
    "nfir_free_run",
    "nfir_rows",
    "noe_free_run",
    "noe_history_run",
    "noe_rest_state",
    "noe_simulate",
    "noe_step",
    "pack",
    "past_lines",
    "rbf_apply",
    "rbf_rows",
    "regressors",
    "row_index",
    "unpack",
]


# ---------------------------------------------------------------------------------------------
# Architecture
# ---------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class NetworkSpec:
    """The static architecture of a time-delay RBF network (hashable: a jit static argument).

    Parameters
    ----------
    arch : {"nfir", "noe"}
    delays : tuple of int
        Input delays, samples.
    neurons : int
        Hidden neurons H.
    hidden : {"matlab", "distance"}
    out_delays : int
        Fed-back past outputs m (NOE; 0 for the NFIR).
    """

    arch: str
    delays: tuple[int, ...]
    neurons: int
    hidden: str = "matlab"
    out_delays: int = 0

    @property
    def n_inputs(self) -> int:
        """Length D of the regressor."""
        return len(self.delays) + self.out_delays

    @property
    def n_params(self) -> int:
        """The number of trained parameters."""
        return n_params(self.n_inputs, self.neurons)

    @property
    def max_delay(self) -> int:
        """The longest input delay, samples."""
        return max(self.delays)


def n_params(n_inputs: int, neurons: int) -> int:
    """Number of parameters of the RBF network: ``H (D + 2) + 1``."""
    return neurons * (n_inputs + 2) + 1


def pack(params: dict[str, Any]) -> jnp.ndarray:
    """Flatten ``{"W", "b", "c", "c0"}`` into one parameter vector (row-major ``W`` first)."""
    return jnp.concatenate([jnp.ravel(jnp.asarray(params[k])) for k in PARAM_NAMES])


def unpack(theta: Any, n_inputs: int, neurons: int) -> dict[str, Any]:
    """Inverse of :func:`pack`."""
    h, d = neurons, n_inputs
    i = h * d
    return {
        "W": theta[:i].reshape(h, d),
        "b": theta[i : i + h],
        "c": theta[i + h : i + 2 * h],
        "c0": theta[i + 2 * h],
    }


# ---------------------------------------------------------------------------------------------
# Network (scaled units)
# ---------------------------------------------------------------------------------------------


def hidden_activations(params: dict[str, Any], X: Any, hidden: str = "matlab", *,
                       single: bool = False) -> jnp.ndarray:
    """Normalized RBF activations ``a`` of shape ``(..., H)`` for regressors ``X`` ``(..., D)``.

    ``"matlab"``: ``n = X W^T + b``; ``"distance"``: ``n_j = b_j ||x - C_j||`` with the centres
    ``C`` stored in ``params["W"]``. ``a = softmax(-n^2)`` (log-sum-exp stable).

    ``single=True``: ``X`` is one regressor (D,) and ``X W^T`` is computed as ``W X`` (the same
    products, perhaps summed in another order): inside a ``lax.scan`` whose ``W`` is traced (a
    model passed into ``jit``), XLA runs this form about twice as fast.
    """
    W, b = params["W"], params["b"]

    def times_wt(x: Any) -> Any:  # x W^T
        return W @ x if single else x @ W.T

    if hidden == "matlab":
        n2 = (times_wt(X) + b) ** 2
    elif hidden == "distance":
        # squared distance without sqrt: differentiable at x = C_j
        d2 = jnp.sum(X**2, axis=-1, keepdims=True) - times_wt(2.0 * X) + jnp.sum(W**2, axis=-1)
        n2 = b**2 * jnp.maximum(d2, 0.0)
    else:
        raise ROMError(f"hidden must be one of {HIDDEN_KINDS}, got {hidden!r}")
    return jax.nn.softmax(-n2, axis=-1)


def rbf_apply(params: dict[str, Any], X: Any, hidden: str = "matlab", *,
              single: bool = False) -> jnp.ndarray:
    """Network output (scaled) ``y = a(X) @ c + c0`` for regressors ``X`` of shape ``(..., D)``
    (``single``: see :func:`hidden_activations`)."""
    return hidden_activations(params, X, hidden, single=single) @ params["c"] + params["c0"]


def rbf_rows(params: dict[str, jax.Array], X: jax.Array, hidden: str = "matlab") -> jax.Array:
    """:func:`rbf_apply` for a trainer's loss: the same function, computed for speed in
    reverse mode; for ``"matlab"``:

    - the neurons on the leading axis (``n^T = W X^T + b``): the softmax's reductions over the
      neurons then run along the samples, in the vector registers;
    - the gradient in closed form: with ``y = a . c + c0``, ``a = softmax(-n^2)``,
      ``dy/dn_k = -2 n_k a_k (c_k - a . c)``, one pass over the activations where the
      differentiated softmax makes several.

    An NFIR(70, 40) epoch of plain Adam steps 0.25 -> 0.17 s. The values and the gradient are
    :func:`rbf_apply`'s rounded otherwise (a few ulps; the gradient relative 5e-8 in float32).
    Reverse mode only (a ``jax.custom_vjp``): the networks' runs use :func:`rbf_apply`, which any
    transformation differentiates.
    """
    if hidden != "matlab":
        return rbf_apply(params, X, hidden)
    return _matlab_rbf(params["W"], params["b"], params["c"], params["c0"], X)


@jax.custom_vjp
def _matlab_rbf(W: jax.Array, b: jax.Array, c: jax.Array, c0: jax.Array,
                X: jax.Array) -> jax.Array:
    return _matlab_rbf_fwd(W, b, c, c0, X)[0]


def _matlab_rbf_fwd(W: jax.Array, b: jax.Array, c: jax.Array, c0: jax.Array,
                    X: jax.Array) -> tuple[jax.Array, tuple[jax.Array, ...]]:
    Xf = X.reshape(-1, X.shape[-1])
    nT = W @ Xf.T + b[:, None]  # (neurons, samples)
    z = -(nT**2)
    e = jnp.exp(z - jnp.max(z, axis=0, keepdims=True))  # log-sum-exp stable
    s = jnp.sum(e, axis=0)
    y = (c @ e) / s
    return (y + c0).reshape(X.shape[:-1]), (W, Xf, nT, e, s, c, y)


def _matlab_rbf_bwd(res: tuple[jax.Array, ...], g: jax.Array) -> tuple[jax.Array, ...]:
    W, Xf, nT, e, s, c, y = res
    gf = g.reshape(-1)
    aT = e / s
    dnT = (-2.0 * gf) * nT * aT * (c[:, None] - y)
    # the cotangent of X is dropped (compiled away) where X is data, as in an NFIR
    return (dnT @ Xf, jnp.sum(dnT, axis=1), aT @ gf, jnp.sum(gf),
            (dnT.T @ W).reshape(*g.shape, W.shape[1]))


_matlab_rbf.defvjp(_matlab_rbf_fwd, _matlab_rbf_bwd)


def row_index(rows: Any, delays: Sequence[int]) -> jnp.ndarray:
    """Indices into the rest-padded input ``up`` (``up[dmax + k] = u_k``) of the regressor rows
    at time indices ``rows``: shape ``(len(rows), len(delays))``."""
    d = np.asarray(delays)
    dmax = int(d.max())
    return rows[:, None] + (dmax - d)[None, :]


def regressors(up: jax.Array, rows: jax.Array, delays: Sequence[int]) -> jax.Array:
    """The regressors at time indices ``rows`` (1-D) from the rest-padded input ``up``:
    ``up[row_index(rows, delays)]``, shape ``(len(rows), len(delays))``, the same values.

    Each row is read as one window of ``up`` (:func:`sloshrom.rom.losses.windows`), then its
    columns are put in the order of ``delays`` (reversed, for the usual increasing delays):
    XLA reads the windows 8x faster than it gathers the ``rows x delays`` single elements of
    the index form (an NFIR(70, 40)'s plain Adam epoch 0.29 -> 0.27 s, its validation run
    1.5x faster).
    """
    d = np.asarray(delays)
    off = int(d.max()) - d
    span = int(off.max()) + 1
    win = windows(up, rows, span)
    if np.array_equal(off, np.arange(span)[::-1]):
        return lax.rev(win, (1,))
    if np.array_equal(off, np.arange(span)):
        return win
    return win[:, off]


def nfir_rows(theta: Any, up: Any, rows: Any, delays: Sequence[int], neurons: int,
              hidden: str) -> jnp.ndarray:
    """NFIR scaled outputs at time indices ``rows`` from the rest-padded scaled input ``up``."""
    X = regressors(up, rows, delays)
    return rbf_apply(unpack(theta, len(delays), neurons), X, hidden)


@partial(jax.jit, static_argnames=("delays", "neurons", "hidden", "chunk"))
def nfir_free_run(theta: Any, u_s: Any, rest_u: Any, delays: tuple[int, ...], neurons: int,
                  hidden: str, chunk: int = 2048) -> jnp.ndarray:
    """NFIR over a whole scaled input ``u_s`` (n,), at rest (``rest_u``) before the start.

    Rows are evaluated in chunks of ``chunk`` (memory bounded): 2048 rows of 70 float64
    regressors (1.1 MB) stay in the second-level cache, where 8192 did not; a validation run
    of 251,000 samples 7-30 % faster (NFIR(70, 40) to NFIR(70, 5), one core), the same bits.
    Returns the scaled output (n,).
    """
    d = np.asarray(delays)
    dmax = int(d.max())
    n = u_s.shape[0]
    n_chunks = -(-n // chunk)
    up = jnp.concatenate([jnp.full(dmax, rest_u), u_s, jnp.full(n_chunks * chunk - n, rest_u)])

    def one(start):
        rows = start + jnp.arange(chunk)
        return nfir_rows(theta, up, rows, d, neurons, hidden)

    y = lax.map(one, jnp.arange(n_chunks) * chunk)
    return y.reshape(-1)[:n]


def noe_step(theta: Any, state: tuple[Any, Any], u_s: Any, delays: Sequence[int],
             out_delays: int, neurons: int, hidden: str, *,
             single: bool = False) -> tuple[tuple[Any, Any], Any]:
    """One NOE step in scaled units: ``state = (u_buf, y_buf)``, most recent first.

    Returns the new state and the output at the current sample (it depends on the past only).
    ``single``: see :func:`hidden_activations`.
    """
    ubuf, ybuf = state
    d = np.asarray(delays)
    x = jnp.concatenate([ubuf[d - 1], ybuf])
    y = rbf_apply(unpack(theta, len(d) + out_delays, neurons), x, hidden, single=single)
    ubuf = jnp.concatenate([jnp.reshape(u_s, (1,)), ubuf[:-1]])
    ybuf = jnp.concatenate([jnp.reshape(y, (1,)), ybuf[:-1]])
    return (ubuf, ybuf), y


def noe_rest_state(rest_u: Any, rest_y: Any, delays: Sequence[int],
                   out_delays: int) -> tuple[jnp.ndarray, jnp.ndarray]:
    """NOE delay lines at rest (scaled units): ``(u_buf (max_delay,), y_buf (out_delays,))``."""
    dmax = int(np.max(delays))
    return (jnp.full(dmax, rest_u, dtype=jnp.float64), jnp.full(out_delays, rest_y, jnp.float64))


def noe_simulate(theta: Any, u_s: Any, state0: tuple[Any, Any], delays: Sequence[int],
                 out_delays: int, neurons: int, hidden: str) -> tuple[Any, jnp.ndarray]:
    """Closed-loop NOE simulation (``lax.scan``) of a scaled input; returns ``(state, y_s)``.

    The loop is unrolled by 8 (the same arithmetic): its step is small, and the loop's own cost
    per iteration was most of a free run's time (2.4x faster, as measured); each step in the
    ``single`` form (the Levenberg-Marquardt Jacobian through it 1.4x faster, as measured).
    """

    def body(state, uk):
        return noe_step(theta, state, uk, delays, out_delays, neurons, hidden, single=True)

    return lax.scan(body, state0, u_s, unroll=8)


@partial(jax.jit, static_argnames=("delays", "out_delays", "neurons", "hidden"))
def noe_free_run(theta: Any, u_s: Any, rest_u: Any, rest_y: Any, delays: tuple[int, ...],
                 out_delays: int, neurons: int, hidden: str) -> jnp.ndarray:
    """NOE free run (closed loop) of a scaled input from rest; returns the scaled output."""
    state0 = noe_rest_state(rest_u, rest_y, delays, out_delays)
    return noe_simulate(theta, u_s, state0, delays, out_delays, neurons, hidden)[1]


def past_lines(past: jax.Array, length: int) -> jax.Array:
    """A delay line filled with measured history: the last ``length`` samples of ``past``
    (..., n >= length; oldest first), most recent first."""
    return jnp.flip(past[..., past.shape[-1] - length:], axis=-1)


@partial(jax.jit, static_argnames=("delays", "out_delays", "neurons", "hidden"))
def noe_history_run(theta: jax.Array, u_past: jax.Array, y_past: jax.Array, u_s: jax.Array,
                    delays: tuple[int, ...], out_delays: int, neurons: int, hidden: str
                    ) -> jax.Array:
    """NOE closed loop of a scaled input ``u_s`` started from measured history: the delay lines
    hold the last inputs and outputs of ``u_past``/``y_past`` (scaled, oldest first, at least
    ``max(delays)`` and ``out_delays`` samples); returns the scaled output."""
    state0 = (past_lines(u_past, int(np.max(delays))), past_lines(y_past, out_delays))
    return noe_simulate(theta, u_s, state0, delays, out_delays, neurons, hidden)[1]


# ---------------------------------------------------------------------------------------------
# The fitted networks as sloshing models
# ---------------------------------------------------------------------------------------------


@dataclass(frozen=True, eq=False)
class Network(FittedNetwork):
    """A fitted time-delay RBF network, NFIR (:class:`NFIRNetwork`) or NOE
    (:class:`NOENetwork`): an immutable sloshing model and a JAX pytree.

    The model the estimators (:class:`~sloshrom.rom.NFIR`, :class:`~sloshrom.rom.NOE`) fit and
    delegate to. Its parameters and scaler bounds are the pytree's leaves, the rest is static: a
    network passed as an argument into a jitted function is traced with the weights as data (one
    compilation per architecture), and ``jax.grad`` with respect to it gives a network-shaped
    gradient.

    Parameters
    ----------
    params : dict
        ``{"W": (H, D), "b": (H,), "c": (H,), "c0": ()}`` (:func:`unpack`).
    scaler : MinMaxScaler
        Bounds of the training input and output (physical units).
    spec : NetworkSpec
        The architecture.
    input : {"velocity", "acceleration"}
        The tank signal the network reads (:func:`sloshrom.models.input_of`).
    fs : float
        Sample rate of the training record, Hz; the model's step is ``dt = 1 / fs``.
    unstable_bound : float
        An NOE whose scaled output exceeds this magnitude (or is not finite) is unstable.
    """

    params: dict[str, Any]
    scaler: MinMaxScaler
    spec: NetworkSpec
    input: str = "velocity"
    fs: float = 1.0
    unstable_bound: float = 10.0

    #: the kernel of an FMU's C model (sloshrom_model.h)
    _kernel = ""

    def describe(self) -> str:
        """A one-line description of the network."""
        spec = self.spec
        return (f"{self.model_class.class_name} ({len(spec.delays)} delays up to "
                f"{spec.max_delay}, {spec.neurons} neurons"
                + (f", {spec.out_delays} output delays" if spec.out_delays else "") + ")")

    def fmu_member(self) -> tuple[str, dict[str, np.ndarray], dict[str, float | int | str]]:
        """The FMU's C data of this network: member kind, arrays and constants."""
        spec = self.spec
        p = {k: np.asarray(v, dtype=np.float64) for k, v in self.params.items()}
        arrays = {"delays": np.asarray(spec.delays, dtype=np.int64),
                  **{k: p[k] for k in ("W", "b", "c")}}
        return (self._kernel, arrays,
                {"hidden": "SL_HIDDEN_DISTANCE" if spec.hidden == "distance"
                 else "SL_HIDDEN_MATLAB", "n_delays": len(spec.delays),
                 "max_delay": spec.max_delay, "out_delays": spec.out_delays,
                 "neurons": spec.neurons, "c0": float(p["c0"])})

    def _run(self, u: Any, fn: Any) -> np.ndarray:
        """``fn(u_s)`` on the scaled input (vmapped over a batch), the scaled output."""
        u_s = jnp.asarray(self.scaler.u(u))
        return np.asarray(jax.vmap(fn)(u_s) if u_s.ndim == 2 else fn(u_s))


@partial(jax.tree_util.register_dataclass, data_fields=["params", "scaler"],
         meta_fields=["spec", "input", "fs", "unstable_bound"])
@dataclass(frozen=True, eq=False)
class NFIRNetwork(Network):
    """A fitted NFIR: the force from the last inputs' delay line (:class:`Network`)."""

    _kernel = "SL_NFIR"

    @property
    def model_class(self) -> ModelClass:
        """The class's registry entry."""
        return NFIR_CLASS

    def init_state(self) -> Any:
        """The input delay line at rest (scaled units, most recent first), shape
        (max_delay,)."""
        ru, _ = self._rest()
        return jnp.full(self.spec.max_delay, ru, dtype=jnp.float64)

    def step(self, state: Any, velocity: Any, acceleration: Any = None) -> tuple[Any, Any]:
        """One pure, jax-traceable step: ``(state, dynamic_force)`` at the current sample k.

        A velocity network takes ``velocity`` v_k: the force from the delay line, then v_k is
        pushed into it. A network on the acceleration takes ``acceleration`` a_{k-1}, as the
        coupled beam passes it: a_{k-1} is pushed, then the force is evaluated. Both give
        :meth:`free_run` sample by sample.
        """
        s, spec = self.scaler, self.spec
        d = np.asarray(spec.delays)

        def push(state: Any, u: Any) -> Any:
            u_s = s.u(jnp.asarray(u, jnp.float64))
            return jnp.concatenate([jnp.reshape(u_s, (1,)), state[:-1]])

        if self.input == "acceleration":
            state = push(state, model_input(self, velocity, acceleration))
        # single: W x, fast in a scan whose weights are traced (the coupled simulation)
        y_s = rbf_apply(self.params, state[d - 1], spec.hidden, single=True)
        if self.input != "acceleration":
            state = push(state, velocity)
        return state, s.y_inverse(y_s)

    @float64
    def free_run(self, u: Any) -> np.ndarray:
        """Free-run output from rest for an input record at ``fs`` (physical units).

        Parameters
        ----------
        u : array_like, shape (n,) or (batch, n)
            The network's input, finite (checked by the caller).

        Returns
        -------
        ndarray, same shape as ``u``
            Output (physical units, e.g. N), float64.
        """
        spec, theta = self.spec, pack(self.params)
        ru, _ = (float(r) for r in self._rest())
        y_s = self._run(u, lambda x: nfir_free_run(theta, x, ru, spec.delays, spec.neurons,
                                                   spec.hidden))
        return np.asarray(self.scaler.y_inverse(y_s))

    @property
    def history_samples(self) -> int:
        """The delay line: ``max_delay`` samples of input (the output is not read)."""
        return int(self.spec.max_delay)

    def _history_run(self, u_past: np.ndarray, y_past: np.ndarray, u: np.ndarray
                     ) -> np.ndarray:
        # a feed-forward network: the measured inputs before the start replace the rest padding
        d = self.spec.max_delay
        return np.asarray(self.free_run(np.concatenate([u_past[u_past.size - d:], u])))[d:]


@partial(jax.tree_util.register_dataclass, data_fields=["params", "scaler"],
         meta_fields=["spec", "input", "fs", "unstable_bound"])
@dataclass(frozen=True, eq=False)
class NOENetwork(Network):
    """A fitted NOE: the force from the last inputs and its own last outputs, a closed loop
    (:class:`Network`); the tank velocity only."""

    _kernel = "SL_NOE"
    _simulation = "NOE simulation"

    @property
    def model_class(self) -> ModelClass:
        """The class's registry entry."""
        return NOE_CLASS

    def init_state(self) -> Any:
        """``(input line, output line)`` at rest (scaled units, most recent first)."""
        ru, ry = self._rest()
        return noe_rest_state(ru, ry, self.spec.delays, self.spec.out_delays)

    def step(self, state: Any, velocity: Any, acceleration: Any = None) -> tuple[Any, Any]:
        """One pure, jax-traceable step of the closed loop: ``(state, dynamic_force)`` at the
        current sample k from v_k (:meth:`free_run` sample by sample)."""
        s, spec = self.scaler, self.spec
        u_s = s.u(jnp.asarray(velocity, jnp.float64))
        state, y_s = noe_step(pack(self.params), state, u_s, spec.delays, spec.out_delays,
                              spec.neurons, spec.hidden, single=True)
        return state, s.y_inverse(y_s)

    @float64
    def free_run(self, u: Any) -> np.ndarray:
        """Free-run output from rest for an input record at ``fs`` (physical units).

        Parameters
        ----------
        u : array_like, shape (n,) or (batch, n)
            The network's input, finite (checked by the caller).

        Returns
        -------
        ndarray, same shape as ``u``
            Output (physical units, e.g. N), float64.

        Raises
        ------
        UnstableModelError
            The simulation left its stability bound.
        """
        spec, theta = self.spec, pack(self.params)
        ru, ry = (float(r) for r in self._rest())
        y_s = self._run(u, lambda x: noe_free_run(theta, x, ru, ry, spec.delays,
                                                  spec.out_delays, spec.neurons, spec.hidden))
        self._check_stable(y_s)
        return np.asarray(self.scaler.y_inverse(y_s))

    @property
    def history_samples(self) -> int:
        """The delay lines: the longest input delay and the fed-back outputs."""
        return max(int(self.spec.max_delay), int(self.spec.out_delays))

    def _history_run(self, u_past: np.ndarray, y_past: np.ndarray, u: np.ndarray
                     ) -> np.ndarray:
        spec, s = self.spec, self.scaler
        y_s = np.asarray(noe_history_run(pack(self.params), jnp.asarray(s.u(u_past)),
                                         jnp.asarray(s.y(y_past)), jnp.asarray(s.u(u)),
                                         spec.delays, spec.out_delays, spec.neurons,
                                         spec.hidden))
        self._check_stable(y_s)
        return np.asarray(s.y_inverse(y_s))
