"""The sloshing-model step contract, and the frozen-liquid model.

A *sloshing model* maps the history of the tank's vertical motion to the dynamic sloshing force
``dF = f_S + m_l * acc`` (N, paper Eq. 2, w up positive). Every model (frozen liquid, virtual rig,
NFIR/NOE ROMs) implements the same contract, so the coupled beam simulation does not care which it
gets:

``dt``
    The model's time step, s (ROM: 1/fs of its training data; rig: its fine integration step).
``init_state()``
    The state at rest (an array or a pytree of arrays).
``step(state, velocity, acceleration) -> (state, dynamic_force)``
    One pure step: tank vertical velocity (m/s) and acceleration (m/s^2) at the current sample in,
    the new state and the dynamic force (N) at the current sample out. Models that need only one of
    the inputs ignore the other.
``simulate(velocity, acceleration) -> dynamic_force``
    The same over whole records sampled at ``1/dt``; arrays of shape ``(..., n)``, leading axes are
    independent runs (batched).
"""

from __future__ import annotations

from typing import Any, Protocol, runtime_checkable

import numpy as np


@runtime_checkable
class SloshingModel(Protocol):
    dt: float

    def init_state(self) -> Any: ...

    def step(self, state: Any, velocity: Any, acceleration: Any) -> tuple[Any, Any]: ...

    def simulate(self, velocity: Any, acceleration: Any) -> np.ndarray: ...


class FrozenLiquid:
    """Liquid frozen in the tank: a rigid mass, no dynamic force (``dF = 0``).

    Parameters
    ----------
    dt : float
        Time step, s.
    """

    def __init__(self, dt: float) -> None:
        if not (np.isfinite(dt) and dt > 0):
            raise ValueError(f"dt must be a finite positive time step in s, got {dt!r}")
        self.dt = float(dt)

    def init_state(self) -> np.ndarray:
        return np.zeros(0)

    def step(self, state: Any, velocity: Any, acceleration: Any) -> tuple[Any, Any]:
        return state, 0.0 * velocity

    def simulate(self, velocity: Any, acceleration: Any) -> np.ndarray:
        return np.zeros(np.broadcast_shapes(np.shape(velocity), np.shape(acceleration)))
