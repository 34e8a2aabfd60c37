"""The linear state-space baseline ROM (LSS): its fitted model and its estimator.

``x_{k+1} = A x_k + B u_k``, ``y_k = C x_k + D u_k`` from rest, with the tank velocity u (m/s)
in and the dynamic sloshing force y (N) out, identified by a subspace method (N4SID) and
refined on its simulation error (output error, :mod:`sloshrom.rom.lss.core`).

A class of the registry (:data:`sloshrom.rom.lss.entry.LSS_CLASS`, ``"lss"``) like the networks:
the fitted model :class:`LinearStateSpace` is an immutable JAX pytree implementing the
sloshing-model contract (it runs in the maps and the coupled beam), the estimator :class:`LSS`
fits it (scikit-learn style), model files hold ``A``, ``B``, ``C``, ``D`` (physical units) and
an FMU holds it as a state-space member without hidden units (:meth:`LinearStateSpace.fmu_member`).
"""

from __future__ import annotations

import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from functools import partial
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np

from sloshrom.models import model_input
from sloshrom.rom.base import Estimator, checked_history, checked_records, record_envelope
from sloshrom.rom.lss.core import lss_history_run, lss_simulate, n4sid, pem_refine
from sloshrom.rom.lss.entry import LSS_CLASS
from sloshrom.rom.network import FittedNetwork, MinMaxScaler
from sloshrom.rom.registry import ModelClass
from sloshrom.signals import power_band

__all__ = ["LSS", "LinearSpec", "LinearStateSpace"]

#: The hyperparameters by default: the registry entry's, the one place they are written
_LSS = LSS_CLASS.defaults()


@dataclass(frozen=True)
class LinearSpec:
    """The static architecture of a linear state-space model: its order ``n_states``."""

    n_states: int

    @property
    def n_params(self) -> int:
        """The number of parameters of the state-space matrices."""
        return self.n_states * (self.n_states + 2) + 1

    @property
    def max_delay(self) -> int:
        """Samples of past record a prediction reads: none (it starts from rest)."""
        return 0

    @property
    def n_inputs(self) -> int:
        """Entries its maps read at each step: the state and the input."""
        return self.n_states + 1


@partial(jax.tree_util.register_dataclass, data_fields=["params", "scaler"],
         meta_fields=["spec", "input", "fs", "unstable_bound"])
@dataclass(frozen=True, eq=False)
class LinearStateSpace(FittedNetwork):
    """A fitted linear state-space model: an immutable sloshing model and a JAX pytree.

    Parameters
    ----------
    params : dict
        ``A`` (n, n), ``B`` (n,), ``C`` (n,), ``D`` () in physical units (m/s in, N out).
    scaler : MinMaxScaler
        Bounds of the training input and output (the envelope; an FMU's scaled form).
    spec : LinearSpec
    input : {"velocity"}
    fs : float
        Sample rate of the training record, Hz; the model's step is ``dt = 1 / fs``.
    unstable_bound : float
        |scaled output| an FMU of it treats as unstable: a stable linear model can reach
        any multiple of its training range when driven beyond it, so the bound is wide.
    """

    params: dict[str, Any]
    scaler: MinMaxScaler
    spec: LinearSpec
    input: str = "velocity"
    fs: float = 1.0
    unstable_bound: float = 1e6

    @property
    def feedthrough(self) -> bool:
        """The output reads the current input (``D``)."""
        return True

    @property
    def model_class(self) -> ModelClass:
        """The class's registry entry."""
        return LSS_CLASS

    def describe(self) -> str:
        """A one-line description of the model."""
        return f"LSS ({self.spec.n_states} states, linear)"

    def init_state(self) -> Any:
        """The rest state: zeros, shape (n_states,)."""
        return np.zeros(self.spec.n_states)

    def step(self, state: Any, velocity: Any, acceleration: Any = None) -> tuple[Any, Any]:
        """One pure, jax-traceable step: ``(x_{k+1}, dynamic_force_k)`` from v_k (m/s)."""
        p = self.params
        v = jnp.asarray(model_input(self, velocity, acceleration), jnp.float64)
        x = jnp.asarray(state, jnp.float64)
        return p["A"] @ x + p["B"] * v, p["C"] @ x + p["D"] * v

    def free_run(self, u: Any) -> np.ndarray:
        """Output from rest (N) for an input record at ``fs`` (m/s), shape (n,) or (batch, n)."""
        p = {k: np.asarray(v, dtype=np.float64) for k, v in self.params.items()}
        n = self.spec.n_states
        return lss_simulate(p["A"], p["B"].reshape(n, 1), p["C"].reshape(1, n),
                            p["D"].reshape(1, 1), np.asarray(u, dtype=np.float64))

    @property
    def history_samples(self) -> int:
        """The order: the least a least-squares state needs (more samples average noise)."""
        return int(self.spec.n_states)

    def _history_run(self, u_past: np.ndarray, y_past: np.ndarray, u: np.ndarray
                     ) -> np.ndarray:
        p = {k: np.asarray(v, dtype=np.float64) for k, v in self.params.items()}
        n = self.spec.n_states
        return lss_history_run(p["A"], p["B"].reshape(n, 1), p["C"].reshape(1, n),
                               p["D"].reshape(1, 1), u_past, y_past, u)

    def fmu_member(self) -> tuple[str, dict[str, np.ndarray], dict[str, float | int | str]]:
        """The model as an FMU's state-space member without hidden units.

        The FMU's state-space kernel runs ``x_{k+1} = x_k + z A' - z_rest A'`` and
        ``y_s = z C' - z_rest C' + r_y`` on ``z = [x, s(u)]`` with the scaled input
        ``s(u) = 2 (u - u_min) / (u_max - u_min) - 1`` and output (``z`` a row vector); so
        ``A' = [(A - I)^T; s_u B^T]``,
        ``C' = [s_y C, s_y s_u D]`` with ``s_u = (u_max - u_min) / 2`` and
        ``s_y = 2 / (y_max - y_min)`` give this model's force to rounding.
        """
        p = {k: np.asarray(v, dtype=np.float64) for k, v in self.params.items()}
        s = self.scaler
        su = (s.in_max - s.in_min) / 2.0
        sy = 2.0 / (s.out_max - s.out_min)
        n = self.spec.n_states
        a = np.vstack([(p["A"] - np.eye(n)).T, su * p["B"][None, :]])
        c = np.concatenate([sy * p["C"], [sy * su * float(p["D"])]])
        empty = np.zeros((n + 1, 0))
        arrays = {"A": a, "W1": empty, "b1": np.zeros(0), "W2": np.zeros((0, n)), "C": c,
                  "V1": empty, "d1": np.zeros(0), "V2": np.zeros(0)}
        return "SL_NSS", arrays, {"n_states": n, "neurons": 0}


@jax.tree_util.register_pytree_node_class
class LSS(Estimator):
    """Linear state-space ROM identified by N4SID and refined on its simulation error.

    Parameters
    ----------
    n_states : int
        Order of the model.
    block_rows : int
        Block rows of the subspace method's Hankel matrices (past and future horizon,
        samples), > ``n_states``.
    max_epochs : int
        Iterations of the output-error refinement (0 = the subspace estimate alone); with a
        validation record, the iterate of the lowest validation error is kept.
    units, names
        Units and variable names of the input and the output; the input is the tank velocity
        (the coupled beam hands a model the velocity of the current sample).

    Parameters are checked by :meth:`fit` (and by :func:`~sloshrom.rom.load_model`).
    """

    model_class = LSS_CLASS

    def __init__(  # the defaults: its registry entry's
        self,
        n_states: int = _LSS["n_states"],
        block_rows: int = _LSS["block_rows"],
        max_epochs: int = _LSS["max_epochs"],
        units: Sequence[str] = ("m/s", "N"),
        names: Sequence[str] = ("velocity", "dynamic_force"),
    ) -> None:
        self.n_states = n_states
        self.block_rows = block_rows
        self.max_epochs = max_epochs
        self.units = units
        self.names = names

    def _check_hyperparameters(self) -> LinearSpec:
        h = self.model_class.check(self._arguments(), input=self.input, training=False)
        return LinearSpec(h["n_states"])

    def _model(self, params: Mapping[str, Any], scaler: MinMaxScaler, spec: Any,
               fs: float) -> LinearStateSpace:
        return LinearStateSpace(dict(params), scaler, spec, self.input, fs)

    def fit(
        self,
        u: Any,
        y: Any,
        fs: float,
        validation: tuple[Any, Any] | None = None,
        callback: Callable[..., Any] | None = None,
        *,
        fill: float | None = None,
        validation_history: int = 0,
    ) -> LSS:
        """Identify the linear model from an input/output record that starts at rest.

        Parameters
        ----------
        u : array_like, shape (n,)
            Tank vertical velocity (m/s), sampled at ``fs``.
        y : array_like, shape (n,)
            Dynamic sloshing force (N).
        fs : float
            Sample rate, Hz.
        validation : (u_val, y_val), optional
            Validation record at the same rate, starting at rest: the refinement keeps the
            iterate with its lowest error.
        callback : callable, optional
            ``callback(epoch, info)`` once, after the refinement (``train_mse``, ``val_mse``
            in N^2).
        fill : float, optional
            Fill level d/h (-) of the training record, as :meth:`sloshrom.rom.NFIR.fit`.
        validation_history : int
            The validation record's first samples taken as measured history (at least ``n_states``:
            the state is their least-squares fit): the validation run starts from them instead of
            from rest and is scored after them, for a validation record that does not start at rest.
            0 (default): from rest, every sample scored.

        Returns
        -------
        self

        Raises
        ------
        ROMError
            A hyperparameter out of its domain, a bad record (shape, NaN, constant, too short)
            or sample rate.
        """
        # the class's rules (the fewest samples among them) before anything else
        spec = LinearSpec(self.check_training(int(np.size(u)))["n_states"])
        u, y, validation, fill = checked_records(u, y, fs, validation, fill, 0, 0)
        hv = checked_history(validation_history, validation, spec.n_states, "LSS")
        t0 = time.perf_counter()
        a, b, c, d = n4sid(u, y, spec.n_states, int(self.block_rows))
        # the subspace estimate's validation error: the history's epoch 0
        val0 = None
        if validation is not None:
            uv, yv = validation
            yh = (lss_history_run(a, b, c, d, uv[:hv], yv[:hv], uv[hv:]) if hv
                  else lss_simulate(a, b, c, d, uv))
            val0 = float(np.mean((yh - yv[hv:]) ** 2))
        a, b, c, d, info = pem_refine(a, b, c, d, u, y, int(self.max_epochs),
                                      validation=validation, validation_history=hv)
        seconds = time.perf_counter() - t0
        n = spec.n_states
        scaler = MinMaxScaler.fit(u, y)
        self.model_ = LinearStateSpace(
            {"A": np.asarray(a, dtype=np.float64), "B": np.asarray(b, np.float64).reshape(n),
             "C": np.asarray(c, np.float64).reshape(n),
             "D": np.asarray(d, np.float64).reshape(())},
            scaler, spec, self.input, float(fs))
        self.envelope_ = record_envelope(u, fs, scaler, power_band(u, fs), self.input, fill)
        val_mse = info.get("validation_mse")
        nan = float("nan")
        self.history_ = {
            "train_mse": [float(info["initial_mse"]), float(info["final_mse"])],
            "val_mse": [nan if val0 is None else val0,
                        nan if val_mse is None else float(val_mse)],
            "best_epoch": 1, "stop_reason": str(info["stop_reason"])[:64],
            "train_seconds": seconds,
        }
        if callback is not None:
            callback(int(self.max_epochs), {"train_mse": info["final_mse"],
                                            "val_mse": self.history_["val_mse"][1]})
        return self
