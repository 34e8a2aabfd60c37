"""Time-delay neural-network reduced-order models: NFIR and NOE with a normalized RBF layer.

Paper section 3 and Appendix A. Both models map a scalar input history
(tank vertical velocity, m/s) to a scalar output (dynamic sloshing force, N), but work for any
single-input single-output record.

Model equations (all in min-max scaled units, ``s(v) = 2 (v - v_min)/(v_max - v_min) - 1``):

- regressor at step k: ``x_k = [u_{k-d_1}, ..., u_{k-d_n}]`` (delays ``d_i``, default 1..n as
  MATLAB's ``timedelaynet``); the NOE appends its own past outputs ``[y^_{k-1}, ..., y^_{k-m}]``.
- hidden layer, normalized RBF, ``a_j = exp(-n_j^2) / sum_l exp(-n_l^2)`` with
  ``"matlab"``: ``n_j = W_j . x + b_j`` (MATLAB ``radbasn``) or
  ``"distance"``: ``n_j = b_j ||x - C_j||``;
- linear output ``y = sum_j c_j a_j + c_0``.

The parameter count is ``H (D + 2) + 1`` (H neurons, D regressor entries): NFIR(70, 35) has 2,521.
The normalized RBF output is bounded by ``max |c_j| + |c_0|``, so an NOE cannot run off to
infinity; an "unstable" NOE shows up as an output far beyond the training range (limit cycles,
saturation), which :meth:`NOE.predict` detects against ``unstable_bound`` and raises.

Initial conditions: every delay line starts at rest (zero physical input and output).
"""

from __future__ import annotations

import warnings
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from functools import partial
from pathlib import Path
from typing import Any

import jax

jax.config.update("jax_enable_x64", True)

import jax.numpy as jnp  # noqa: E402
import numpy as np  # noqa: E402
from jax import lax  # noqa: E402

from sloshrom.fileio import atomic_write  # noqa: E402
from sloshrom.rom.modelfile import (  # noqa: E402
    FORMAT_VERSION,
    HIDDEN_KINDS,
    PARAM_NAMES,
    ModelFileError,
    read_model_file,
    validate_for_save,
)
from sloshrom.rom.modelfile import checksum as _checksum  # noqa: E402

__all__ = [
    "FORMAT_VERSION",
    "NFIR",
    "NOE",
    "EnvelopeWarning",
    "ModelFileError",
    "MinMaxScaler",
    "UnstableModelError",
    "hidden_activations",
    "load_model",
    "n_params",
    "nfir_apply",
    "noe_simulate",
    "rbf_apply",
]

class UnstableModelError(RuntimeError):
    """A recurrent (NOE) simulation became non-finite or left its stability bound."""


class EnvelopeWarning(UserWarning):
    """The input passed to a ROM lies outside the range it was trained on."""


# ---------------------------------------------------------------------------------------------
# Scaling
# ---------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class MinMaxScaler:
    """Min-max scaling of the input and the output to [-1, 1] (MATLAB ``mapminmax``)."""

    in_min: float
    in_max: float
    out_min: float
    out_max: float

    @classmethod
    def fit(cls, u: np.ndarray, y: np.ndarray) -> MinMaxScaler:
        u_min, u_max = float(np.min(u)), float(np.max(u))
        y_min, y_max = float(np.min(y)), float(np.max(y))
        if not u_max > u_min:
            raise ValueError(f"input is constant ({u_min!r}): nothing to identify from")
        if not y_max > y_min:
            raise ValueError(f"output is constant ({y_min!r}): nothing to identify")
        return cls(u_min, u_max, y_min, y_max)

    def u(self, u: Any) -> Any:
        return 2.0 * (u - self.in_min) / (self.in_max - self.in_min) - 1.0

    def y(self, y: Any) -> Any:
        return 2.0 * (y - self.out_min) / (self.out_max - self.out_min) - 1.0

    def y_inverse(self, ys: Any) -> Any:
        return (ys + 1.0) * 0.5 * (self.out_max - self.out_min) + self.out_min

    @property
    def out_half_range(self) -> float:
        """Half the output range: physical MSE = scaled MSE * out_half_range**2."""
        return 0.5 * (self.out_max - self.out_min)

    def to_dict(self) -> dict[str, float]:
        return {k: float(getattr(self, k)) for k in ("in_min", "in_max", "out_min", "out_max")}


# ---------------------------------------------------------------------------------------------
# Pure model functions (scaled units)
# ---------------------------------------------------------------------------------------------


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


def hidden_activations(params: dict[str, Any], X: Any, hidden: str = "matlab") -> jnp.ndarray:
    """Normalized RBF activations ``a`` of shape ``(..., H)`` for regressors ``X`` ``(..., D)``.

    ``"matlab"``: ``n = X W^T + b``; ``"distance"``: ``n_j = b_j ||x - C_j||`` with the centres
    ``C`` stored in ``params["W"]``. ``a = softmax(-n^2)`` (log-sum-exp stable).
    """
    W, b = params["W"], params["b"]
    if hidden == "matlab":
        n2 = (X @ W.T + b) ** 2
    elif hidden == "distance":
        # squared distance without sqrt: differentiable at x = C_j
        d2 = jnp.sum(X**2, axis=-1, keepdims=True) - 2.0 * X @ W.T + jnp.sum(W**2, axis=-1)
        n2 = b**2 * jnp.maximum(d2, 0.0)
    else:
        raise ValueError(f"hidden must be one of {HIDDEN_KINDS}, got {hidden!r}")
    return jax.nn.softmax(-n2, axis=-1)


def rbf_apply(params: dict[str, Any], X: Any, hidden: str = "matlab") -> jnp.ndarray:
    """Network output (scaled) ``y = a(X) . c + c0`` for regressors ``X`` of shape ``(..., D)``."""
    return hidden_activations(params, X, hidden) @ params["c"] + params["c0"]


def nfir_apply(params: dict[str, Any], X: Any, hidden: str = "matlab") -> jnp.ndarray:
    """NFIR output (scaled) for a matrix of delayed-input regressors ``X`` (rows = time steps)."""
    return rbf_apply(params, X, hidden)


def _row_index(rows: jnp.ndarray, delays: np.ndarray) -> jnp.ndarray:
    """Indices into the rest-padded input ``up`` (``up[dmax + k] = u_k``) of rows ``k``."""
    dmax = int(delays.max())
    return rows[:, None] + (dmax - delays)[None, :]


def nfir_rows(theta: Any, up: Any, rows: Any, delays: np.ndarray, neurons: int, hidden: str):
    """NFIR scaled outputs at time indices ``rows`` from the rest-padded scaled input ``up``."""
    X = up[_row_index(rows, delays)]
    return nfir_apply(unpack(theta, len(delays), neurons), X, hidden)


@partial(jax.jit, static_argnames=("delays", "neurons", "hidden", "chunk"))
def _nfir_free_run(theta, u_s, rest_u, delays, neurons, hidden, chunk=8192):
    """NFIR over a whole (scaled) input in chunks of rows (memory bounded), rest before start."""
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


def noe_step(theta, state, u_s, delays, out_delays, neurons, hidden):
    """One NOE step in scaled units: ``state = (u_buf, y_buf)`` most recent first."""
    ubuf, ybuf = state
    d = np.asarray(delays)
    x = jnp.concatenate([ubuf[d - 1], ybuf])
    y = rbf_apply(unpack(theta, len(d) + out_delays, neurons), x, hidden)
    ubuf = jnp.concatenate([jnp.reshape(u_s, (1,)), ubuf[:-1]])
    ybuf = jnp.concatenate([jnp.reshape(y, (1,)), ybuf[:-1]])
    return (ubuf, ybuf), y


def noe_rest_state(rest_u, rest_y, delays, out_delays):
    dmax = int(np.max(delays))
    return (jnp.full(dmax, rest_u, dtype=jnp.float64), jnp.full(out_delays, rest_y, jnp.float64))


def noe_simulate(theta, u_s, state0, delays, out_delays, neurons, hidden):
    """Closed-loop NOE simulation (``lax.scan``) of a scaled input; returns ``(state, y_s)``."""

    def body(state, uk):
        return noe_step(theta, state, uk, delays, out_delays, neurons, hidden)

    return lax.scan(body, state0, u_s)


@partial(jax.jit, static_argnames=("delays", "out_delays", "neurons", "hidden"))
def _noe_free_run(theta, u_s, rest_u, rest_y, delays, out_delays, neurons, hidden):
    state0 = noe_rest_state(rest_u, rest_y, np.asarray(delays), out_delays)
    return noe_simulate(theta, u_s, state0, delays, out_delays, neurons, hidden)[1]


# ---------------------------------------------------------------------------------------------
# Estimators
# ---------------------------------------------------------------------------------------------


def _check_delays(delays: int | Sequence[int], name: str = "delays") -> tuple[int, ...]:
    if isinstance(delays, int | np.integer):
        if delays < 1:
            raise ValueError(f"{name} must be >= 1, got {delays}")
        return tuple(range(1, int(delays) + 1))
    d = tuple(int(x) for x in delays)
    if not d or min(d) < 1 or len(set(d)) != len(d):
        raise ValueError(f"{name} must be distinct integers >= 1, got {delays!r}")
    return d


def _as_signal(name: str, x: Any, allow_batch: bool = False) -> np.ndarray:
    a = np.asarray(x, dtype=np.float64)
    if a.ndim != 1 and not (allow_batch and a.ndim == 2):
        shape = "(n,) or (batch, n)" if allow_batch else "(n,)"
        raise ValueError(f"{name} must have shape {shape}, got {a.shape}")
    if not np.all(np.isfinite(a)):
        raise ValueError(f"{name} contains NaN or inf (first at index {np.argmin(np.isfinite(a))})")
    return a


def _frequency_band(u: np.ndarray, fs: float, lo: float = 0.01, hi: float = 0.99) -> list[float]:
    """Band (Hz) holding the central 98 % of the input's power (mean removed)."""
    p = np.abs(np.fft.rfft(u - u.mean())) ** 2
    f = np.fft.rfftfreq(u.size, 1.0 / fs)
    c = np.cumsum(p)
    if c[-1] <= 0:
        return [0.0, 0.0]
    c /= c[-1]
    return [float(f[np.searchsorted(c, lo)]), float(f[min(np.searchsorted(c, hi), f.size - 1)])]


class _TDNN:
    """Shared code of NFIR and NOE (sklearn-style estimator + sloshing-model contract)."""

    arch = ""

    def __init__(
        self,
        delays: int | Sequence[int],
        neurons: int,
        hidden: str = "matlab",
        max_epochs: int = 1000,
        seed: int = 0,
        trainer: str = "fast",
        out_delays: int = 0,
        unstable_bound: float = 10.0,
        units: tuple[str, str] = ("m/s", "N"),
        names: tuple[str, str] = ("velocity", "dynamic_force"),
    ) -> None:
        self.delays = delays
        self.neurons = neurons
        self.hidden = hidden
        self.max_epochs = max_epochs
        self.seed = seed
        self.trainer = trainer
        self.out_delays = out_delays
        self.unstable_bound = unstable_bound
        self.units = tuple(units)
        self.names = tuple(names)
        self._validate_hyper()

    # -- hyperparameters ----------------------------------------------------------------------
    def _validate_hyper(self) -> None:
        self._delays = _check_delays(self.delays)
        if int(self.neurons) < 1:
            raise ValueError(f"neurons must be >= 1, got {self.neurons}")
        if self.hidden not in HIDDEN_KINDS:
            raise ValueError(f"hidden must be one of {HIDDEN_KINDS}, got {self.hidden!r}")
        if int(self.max_epochs) < 0:
            raise ValueError(f"max_epochs must be >= 0, got {self.max_epochs}")
        if int(self.out_delays) < 0:
            raise ValueError(f"out_delays must be >= 0, got {self.out_delays}")

    def get_params(self) -> dict[str, Any]:
        """Hyperparameters (JSON-serialisable), as given to the constructor."""
        d = self.delays
        return {
            "delays": d if isinstance(d, int | np.integer) else list(d),
            "neurons": int(self.neurons),
            "hidden": self.hidden,
            "max_epochs": int(self.max_epochs),
            "seed": int(self.seed),
            "trainer": self.trainer,
            "out_delays": int(self.out_delays),
            "unstable_bound": float(self.unstable_bound),
            "units": list(self.units),
            "names": list(self.names),
        }

    @property
    def n_inputs(self) -> int:
        """Length D of the regressor."""
        return len(self._delays) + int(self.out_delays)

    @property
    def n_params(self) -> int:
        return n_params(self.n_inputs, int(self.neurons))

    @property
    def max_delay(self) -> int:
        return max(self._delays)

    def _check_fitted(self) -> None:
        if not hasattr(self, "params_"):
            raise RuntimeError(f"this {type(self).__name__} is not fitted: call fit() first")

    @property
    def theta_(self) -> jnp.ndarray:
        self._check_fitted()
        return pack(self.params_)

    # -- training -----------------------------------------------------------------------------
    def fit(
        self,
        u: Any,
        y: Any,
        fs: float,
        validation: tuple[Any, Any] | None = None,
        callback: Callable[..., Any] | None = None,
    ) -> _TDNN:
        """Identify the network from an input/output record.

        Parameters
        ----------
        u : array_like, shape (n,)
            Input (default: tank vertical velocity, m/s), sampled at ``fs``, starting at rest.
        y : array_like, shape (n,)
            Output (default: dynamic sloshing force, N).
        fs : float
            Sample rate, Hz.
        validation : (u_val, y_val), optional
            Validation record at the same rate; used for early stopping (6 failures) and for
            returning the best-validation network.
        callback : callable, optional
            ``callback(epoch, info)`` after every epoch; ``info`` is a dict with ``train_mse``,
            ``val_mse`` (N^2), ``mu``, ``grad``, ``seconds``; returning True stops training
            (the best-validation network so far is kept).

        Returns
        -------
        self
        """
        from sloshrom.rom import training

        self._validate_hyper()
        if not (np.isfinite(fs) and fs > 0):
            raise ValueError(f"fs must be a finite positive sample rate in Hz, got {fs!r}")
        u = _as_signal("u", u)
        y = _as_signal("y", y)
        if u.shape != y.shape:
            raise ValueError(f"u and y must have the same length, got {u.size} and {y.size}")
        need = self.max_delay + max(int(self.out_delays), 0) + 2 * self.n_params // 100 + 10
        if u.size < need:
            raise ValueError(
                f"{u.size} samples are too few for {self.max_delay} delays "
                f"(need at least {need})"
            )
        if validation is not None:
            uv = _as_signal("validation input", validation[0])
            yv = _as_signal("validation output", validation[1])
            if uv.shape != yv.shape:
                raise ValueError("validation input and output must have the same length")
            if uv.size <= self.max_delay:
                raise ValueError(f"validation record too short for {self.max_delay} delays")
            validation = (uv, yv)
        scaler = MinMaxScaler.fit(u, y)
        self.scaler_ = scaler
        self.fs_ = float(fs)
        self.envelope_ = {
            "input_min": scaler.in_min,
            "input_max": scaler.in_max,
            "output_min": scaler.out_min,
            "output_max": scaler.out_max,
            "frequency_band": _frequency_band(u, fs),
        }
        theta, history = training.train(self, u, y, validation, callback)
        self.params_ = {k: np.asarray(v) for k, v in unpack(theta, self.n_inputs,
                                                            int(self.neurons)).items()}
        self.history_ = history
        self._warned = False
        return self

    # -- prediction ---------------------------------------------------------------------------
    @property
    def dt(self) -> float:
        """Model time step = 1/fs_, s."""
        self._check_fitted()
        return 1.0 / self.fs_

    def _check_envelope(self, u: np.ndarray) -> None:
        lo, hi = self.envelope_["input_min"], self.envelope_["input_max"]
        span = hi - lo
        over = max(float(np.max(u)) - hi, lo - float(np.min(u)), 0.0)
        if over > 0 and not getattr(self, "_warned", False):
            self._warned = True
            warnings.warn(
                f"input outside the training envelope [{lo:.4g}, {hi:.4g}] "
                f"{self.units[0]} by {over:.4g} {self.units[0]} ({100 * over / span:.1f} % of "
                "the range): the ROM extrapolates",
                EnvelopeWarning,
                stacklevel=3,
            )

    def predict(self, u: Any) -> np.ndarray:
        """Free-run simulation from rest.

        Parameters
        ----------
        u : array_like, shape (n,) or (batch, n)
            Input sampled at ``fs_`` (physical units, e.g. m/s).

        Returns
        -------
        ndarray, same shape as ``u``
            Output (physical units, e.g. N).
        """
        self._check_fitted()
        u = _as_signal("u", u, allow_batch=True)
        self._check_envelope(u)
        s = self.scaler_
        u_s = jnp.asarray(s.u(u))
        fn = self._free_run_fn()
        y_s = jax.vmap(fn)(u_s) if u_s.ndim == 2 else fn(u_s)
        y_s = np.asarray(y_s)
        self._check_stable(y_s)
        return np.asarray(s.y_inverse(y_s))

    def _check_stable(self, y_s: np.ndarray) -> None:
        pass

    def simulate(self, velocity: Any, acceleration: Any = None) -> np.ndarray:
        """Sloshing-model contract: dynamic force (N) from velocity (m/s); acceleration ignored."""
        return self.predict(velocity)

    def init_state(self):
        """Delay line(s) at rest (scaled units), a pytree of arrays."""
        raise NotImplementedError

    def step(self, state, velocity, acceleration=None):
        raise NotImplementedError

    def _free_run_fn(self) -> Callable:
        raise NotImplementedError

    # -- persistence --------------------------------------------------------------------------
    def save(self, path: str | Path) -> Path:
        """Write the fitted model to a ``.npz`` file atomically (no pickle).

        The file holds the parameter arrays ``W``, ``b``, ``c``, ``c0`` and a JSON string
        ``metadata`` (format version, class, sloshrom version, hyperparameters, fs, units,
        variable names, scaler, envelope, history, checksum); docs/formats.md, "Model files".
        The metadata is checked against the schema :func:`load_model` applies before anything
        is written, so a model that could not be loaded back is never saved.

        Raises
        ------
        ValueError
            A hyperparameter, the sample rate, the scaler or the envelope is outside the bounds of
            the model-file format, or the training history is too long to store; the message names
            the field and nothing is written.
        """
        from sloshrom import __version__

        self._check_fitted()
        p = Path(path)
        if p.suffix != ".npz":
            p = p.with_suffix(p.suffix + ".npz") if p.suffix else p.with_suffix(".npz")
        meta = {
            "format": "sloshrom-rom",
            "format_version": FORMAT_VERSION,
            "class": type(self).__name__,
            "sloshrom_version": __version__,
            "hyperparameters": self.get_params(),
            "fs": self.fs_,
            "units": {"input": self.units[0], "output": self.units[1]},
            "names": {"input": self.names[0], "output": self.names[1]},
            "scaler": self.scaler_.to_dict(),
            "envelope": self.envelope_,
            "history": self.history_,
        }
        arrays = {k: np.asarray(self.params_[k], dtype=np.float64) for k in PARAM_NAMES}
        meta["checksum"] = _checksum(meta, arrays)
        try:
            text = validate_for_save(meta, arrays, str(p))
        except ModelFileError as exc:
            raise ValueError(f"cannot save the model: {exc}") from None

        def write(tmp: str) -> None:
            with open(tmp, "wb") as fh:  # a file object: np.savez adds no ".npz" to the name
                np.savez(fh, metadata=np.array(text), **arrays)

        return atomic_write(p, write, suffix=".npz")


class NFIR(_TDNN):
    """Nonlinear finite-impulse-response network: ``y_k = f(u_{k-1}, ..., u_{k-n})``.

    Parameters
    ----------
    delays : int or sequence of int
        ``n`` for delays 1..n (MATLAB ``timedelaynet``) or an explicit list of delays (samples).
    neurons : int
        Hidden normalized RBF neurons H.
    hidden : {"matlab", "distance"}
        RBF variant (see module docstring).
    max_epochs : int
        Levenberg-Marquardt epochs at most.
    seed : int
        Seeds the initialisation.
    trainer : {"fast", "lm", "adam"}
        ``"lm"``: MATLAB ``trainlm`` on all samples; ``"fast"``: the same algorithm with J^T J
        accumulated on a fixed decimated subset of the samples; ``"adam"`` (default): minibatch
        Adam with the same validation early stopping, which reached a lower validation error
        than both LM variants in less time on the virtual-rig data (see
        :mod:`sloshrom.rom.training` and docs/rom.md).
    """

    arch = "nfir"

    def __init__(
        self,
        delays: int | Sequence[int] = 70,
        neurons: int = 35,
        hidden: str = "matlab",
        max_epochs: int = 1000,
        seed: int = 0,
        trainer: str = "adam",
        units: tuple[str, str] = ("m/s", "N"),
        names: tuple[str, str] = ("velocity", "dynamic_force"),
    ) -> None:
        super().__init__(delays, neurons, hidden, max_epochs, seed, trainer, 0, 10.0, units,
                         names)

    def get_params(self) -> dict[str, Any]:
        p = super().get_params()
        p.pop("out_delays")
        p.pop("unstable_bound")
        return p

    def _free_run_fn(self) -> Callable:
        theta = self.theta_
        rest_u = float(self.scaler_.u(0.0))
        return lambda u_s: _nfir_free_run(theta, u_s, rest_u, self._delays, int(self.neurons),
                                          self.hidden)

    def init_state(self) -> jnp.ndarray:
        """Input delay line at rest, scaled, most recent first: shape (max_delay,)."""
        self._check_fitted()
        return jnp.full(self.max_delay, self.scaler_.u(0.0), dtype=jnp.float64)

    def step(self, state, velocity, acceleration=None):
        """One pure, jax-traceable step: ``(state, dynamic_force)`` at the current sample."""
        s = self.scaler_
        d = np.asarray(self._delays)
        y_s = rbf_apply(self.params_, state[d - 1], self.hidden)
        u_s = s.u(jnp.asarray(velocity, jnp.float64))
        state = jnp.concatenate([jnp.reshape(u_s, (1,)), state[:-1]])
        return state, s.y_inverse(y_s)


class NOE(_TDNN):
    """Nonlinear output-error network: ``y^_k = f(u_{k-1..k-n}, y^_{k-1..k-m})`` (recurrent).

    Parameters
    ----------
    delays : int or sequence of int
        Input delays (default 2 -> 1, 2).
    neurons : int
        Hidden normalized RBF neurons.
    out_delays : int
        Number of fed-back past outputs m (default 2).
    unstable_bound : float
        A simulation whose scaled output exceeds this magnitude (10 = ten half-ranges of the
        training output) or is non-finite is unstable: :meth:`predict` raises
        :class:`UnstableModelError`.
    Other parameters as :class:`NFIR`. Training uses the simulation (output) error with
    forward-mode derivatives through the recurrence.
    """

    arch = "noe"

    def __init__(
        self,
        delays: int | Sequence[int] = 2,
        neurons: int = 10,
        hidden: str = "matlab",
        max_epochs: int = 1000,
        seed: int = 0,
        trainer: str = "lm",
        out_delays: int = 2,
        unstable_bound: float = 10.0,
        units: tuple[str, str] = ("m/s", "N"),
        names: tuple[str, str] = ("velocity", "dynamic_force"),
    ) -> None:
        super().__init__(delays, neurons, hidden, max_epochs, seed, trainer, out_delays,
                         unstable_bound, units, names)

    def _validate_hyper(self) -> None:
        super()._validate_hyper()
        if int(self.out_delays) < 1:
            raise ValueError(f"NOE needs out_delays >= 1, got {self.out_delays}")

    def _rest(self) -> tuple[float, float]:
        return float(self.scaler_.u(0.0)), float(self.scaler_.y(0.0))

    def _free_run_fn(self) -> Callable:
        theta = self.theta_
        ru, ry = self._rest()
        return lambda u_s: _noe_free_run(theta, u_s, ru, ry, self._delays, int(self.out_delays),
                                         int(self.neurons), self.hidden)

    def _check_stable(self, y_s: np.ndarray) -> None:
        bad = ~np.isfinite(y_s) | (np.abs(y_s) > self.unstable_bound)
        if np.any(bad):
            k = int(np.argmax(bad.reshape(-1)) % y_s.shape[-1])
            raise UnstableModelError(
                f"NOE simulation unstable: output non-finite or beyond {self.unstable_bound} "
                f"half-ranges of the training output at sample {k} (t = {k / self.fs_:.3f} s)"
            )

    def init_state(self):
        """``(input delay line, output delay line)`` at rest, scaled, most recent first."""
        self._check_fitted()
        ru, ry = self._rest()
        return noe_rest_state(ru, ry, np.asarray(self._delays), int(self.out_delays))

    def step(self, state, velocity, acceleration=None):
        """One pure, jax-traceable closed-loop step: ``(state, dynamic_force)``."""
        s = self.scaler_
        u_s = s.u(jnp.asarray(velocity, jnp.float64))
        state, y_s = noe_step(self.theta_, state, u_s, self._delays, int(self.out_delays),
                              int(self.neurons), self.hidden)
        return state, s.y_inverse(y_s)


# ---------------------------------------------------------------------------------------------
# Loading
# ---------------------------------------------------------------------------------------------


def load_model(path: str | Path) -> NFIR | NOE:
    """Load a model written by ``save``; never runs code (no pickle).

    Every metadata field is validated against a schema with bounds and the arrays against the
    metadata before the model is built (:mod:`sloshrom.rom.modelfile`; docs/formats.md, "Model
    files"), so a loaded model can be simulated, coupled and exported.

    Parameters
    ----------
    path : str or Path
        A ``.npz`` model file.

    Returns
    -------
    NFIR or NOE

    Raises
    ------
    ModelFileError
        Missing file, not a sloshrom model, other/newer format version, corrupt or truncated file
        (checksum), a metadata field out of bounds or inconsistent (the message names it),
        parameter arrays that do not match the metadata.
    """
    mf = read_model_file(path)
    meta = mf.meta
    cls = NFIR if meta["class"] == "NFIR" else NOE
    try:
        model = cls(**meta["hyperparameters"])
    except (TypeError, ValueError) as exc:  # unreachable after validation; kept as a net
        raise ModelFileError(f"{path}: corrupt metadata ({exc})") from None
    sc = meta["scaler"]
    model.scaler_ = MinMaxScaler(**{k: float(sc[k]) for k in
                                    ("in_min", "in_max", "out_min", "out_max")})
    model.fs_ = float(meta["fs"])
    model.envelope_ = meta["envelope"]
    model.history_ = meta.get("history", {})
    model.params_ = mf.arrays
    model._warned = False
    return model
