"""The toy's estimator: ridge least squares of the FIR filter on the training record."""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from typing import Any

import jax
import numpy as np
from toyrom.entry import TOY_CLASS
from toyrom.model import ToyModel, ToySpec

from sloshrom.rom.base import Estimator, checked_records, record_envelope
from sloshrom.rom.network import MinMaxScaler
from sloshrom.signals import power_band

_TOY = TOY_CLASS.defaults()


@jax.tree_util.register_pytree_node_class
class Toy(Estimator):
    model_class = TOY_CLASS

    def __init__(self, taps: int = _TOY["taps"], ridge: float = _TOY["ridge"],
                 units: Sequence[str] = ("m/s", "N"),
                 names: Sequence[str] = ("velocity", "dynamic_force")) -> None:
        self.taps = taps
        self.ridge = ridge
        self.units = units
        self.names = names

    def _check_hyperparameters(self) -> ToySpec:
        h = self.model_class.check(self._arguments(), input=self.input, training=False)
        return ToySpec(h["taps"])

    def _model(self, params: Any, scaler: MinMaxScaler, spec: Any, fs: float) -> ToyModel:
        return ToyModel(dict(params), scaler, spec, self.input, fs)

    def fit(self, u: Any, y: Any, fs: float, validation: tuple[Any, Any] | None = None,
            callback: Callable[..., Any] | None = None, *, fill: float | None = None,
            validation_history: int = 0) -> Toy:
        h = self.check_training(int(np.size(u)))
        taps = int(h["taps"])
        u, y, validation, fill = checked_records(u, y, fs, validation, fill, 0, taps - 1)
        t0 = time.perf_counter()
        X = np.stack([np.concatenate([np.zeros(i), u[: u.size - i]]) for i in range(taps)]
                     + [np.ones(u.size)], axis=1)
        A = X.T @ X + float(h["ridge"]) * np.eye(taps + 1)
        theta = np.linalg.solve(A, X.T @ y)
        scaler = MinMaxScaler.fit(u, y)
        self.model_ = ToyModel({"w": theta[:taps], "bias": np.asarray(theta[taps])}, scaler,
                               ToySpec(taps), self.input, float(fs))
        mse = float(np.mean((self.model_.free_run(u) - y) ** 2))
        val = mse if validation is None else float(
            np.mean((self.model_.free_run(validation[0]) - validation[1]) ** 2))
        self.envelope_ = record_envelope(u, fs, scaler, power_band(u, fs), self.input, fill)
        self.history_ = {"train_mse": [mse, mse], "val_mse": [val, val], "best_epoch": 1,
                         "stop_reason": "solved", "train_seconds": time.perf_counter() - t0}
        if callback is not None:
            callback(1, {"train_mse": mse, "val_mse": val})
        return self
