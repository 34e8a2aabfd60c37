"""The toy's fitted model: ``y_k = sum_i w_i u_{k-i} + bias`` (physical units), a JAX pytree."""

from __future__ import annotations

from dataclasses import dataclass
from functools import partial
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np
from toyrom.entry import TOY_CLASS

from sloshrom.models import model_input
from sloshrom.rom.network import FittedNetwork, MinMaxScaler
from sloshrom.rom.registry import ModelClass


@dataclass(frozen=True)
class ToySpec:
    taps: int

    @property
    def n_params(self) -> int:
        return self.taps + 1

    @property
    def max_delay(self) -> int:
        return self.taps - 1

    @property
    def n_inputs(self) -> int:
        return self.taps


@partial(jax.tree_util.register_dataclass, data_fields=["params", "scaler"],
         meta_fields=["spec", "input", "fs", "unstable_bound"])
@dataclass(frozen=True, eq=False)
class ToyModel(FittedNetwork):
    params: dict[str, Any]
    scaler: MinMaxScaler
    spec: ToySpec
    input: str = "velocity"
    fs: float = 1.0
    unstable_bound: float = 1e6

    @property
    def feedthrough(self) -> bool:
        return True

    @property
    def model_class(self) -> ModelClass:
        return TOY_CLASS

    def describe(self) -> str:
        return f"Toy ({self.spec.taps} taps)"

    def init_state(self) -> Any:
        return np.zeros(self.spec.taps - 1)

    def step(self, state: Any, velocity: Any, acceleration: Any = None) -> tuple[Any, Any]:
        v = jnp.asarray(model_input(self, velocity, acceleration), jnp.float64)
        line = jnp.concatenate([jnp.reshape(v, (1,)), jnp.asarray(state, jnp.float64)])
        y = line @ self.params["w"] + self.params["bias"]
        return line[:-1], y

    def free_run(self, u: Any) -> np.ndarray:
        u = np.asarray(u, dtype=np.float64)
        w = np.asarray(self.params["w"])
        y = np.apply_along_axis(lambda x: np.convolve(x, w)[: x.size], -1, u)
        return y + float(self.params["bias"])

    @property
    def history_samples(self) -> int:
        return self.spec.taps - 1

    def _history_run(self, u_past: np.ndarray, y_past: np.ndarray, u: np.ndarray
                     ) -> np.ndarray:
        n = self.spec.taps - 1
        return self.free_run(np.concatenate([u_past[u_past.size - n:], u]))[n:]
