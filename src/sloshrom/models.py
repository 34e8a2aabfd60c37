"""The sloshing-model step contract, its optional capabilities, and the frozen-liquid model.

A *sloshing model* maps the history of the tank's vertical motion to the dynamic sloshing force
``dF = f_S + m_l * acc`` (N, paper Eq. 2, w up positive). Every model (frozen liquid, virtual rig,
NFIR/NOE ROMs) implements the same contract, :class:`SloshingModel`, so the coupled beam
simulation and the energy maps do not care which they get:

``dt``
    The model's time step, s (ROM: 1/fs of its training data; rig: its fine integration step).
``force_rule``
    How the force sample k relates to the motion, for energy integrals: ``"trapezoid"`` (the
    force at t_k; integrate by the trapezoid rule) or ``"step"`` (the average over [t_k, t_k+1],
    the rig's integrator).
``init_state()``
    The state at rest (an array or a pytree of arrays).
``step(state, velocity, acceleration) -> (state, dynamic_force)``
    One pure step: tank vertical velocity (m/s) at the current sample k and acceleration
    (m/s^2) in, the new state and the dynamic force (N) at sample k out. The coupled beam passes
    the acceleration of sample k - 1: the one of sample k depends on the force being computed.
    Models that need only one of the inputs ignore the other.
``simulate(velocity, acceleration) -> dynamic_force``
    The same over whole records sampled at ``1/dt``; arrays of shape ``(..., n)``: time on the
    last axis, leading axes are independent runs (batched).
``input_variable`` (optional, default ``"velocity"``)
    The signal an identified model reads: ``"velocity"`` or ``"acceleration"`` (a network
    trained on the tank acceleration). Its training envelope (:class:`Enveloped`) is a range
    of that signal; :func:`model_input` picks it.

Optional capabilities, each a protocol checked with ``isinstance``:

:class:`JaxModel`
    The model is a JAX pytree (learned parameters are leaves) and ``step`` is a pure, traceable
    JAX function: it runs inside ``jit``/``lax.scan`` and ``jax.grad`` flows through it.
:class:`CompiledKernel`
    ``kernel()`` returns a numba-compiled step ``(step_fn, params, state)`` for fast loops.
:class:`Enveloped`
    ``envelope_`` holds the input range the model was identified on (``input_min``,
    ``input_max`` in the input's units): outside it the model extrapolates.
"""

from __future__ import annotations

from typing import Any, ClassVar, Literal, Protocol, runtime_checkable

import numpy as np

__all__ = [
    "CompiledKernel",
    "Enveloped",
    "FrozenLiquid",
    "JaxModel",
    "SloshingModel",
    "input_variable",
    "model_input",
]

ForceRule = Literal["trapezoid", "step"]


@runtime_checkable
class SloshingModel(Protocol):
    """The step contract (see the module docstring)."""

    dt: float
    force_rule: ForceRule

    def init_state(self) -> Any: ...

    def step(self, state: Any, velocity: Any, acceleration: Any) -> tuple[Any, Any]: ...

    def simulate(self, velocity: Any, acceleration: Any) -> np.ndarray: ...


@runtime_checkable
class JaxModel(SloshingModel, Protocol):
    """A sloshing model with a JAX-traceable ``step``; its parameters are pytree leaves."""

    jax_traceable: ClassVar[Literal[True]]


@runtime_checkable
class CompiledKernel(Protocol):
    """A sloshing model with a numba-compiled step for tight loops."""

    def kernel(self) -> tuple[Any, Any, Any]:
        """``(step_fn, params, state)``: ``step_fn(state, params, velocity, acceleration)`` is a
        numba function returning the dynamic force (N) and updating ``state`` in place."""
        ...


@runtime_checkable
class Enveloped(Protocol):
    """A model identified on a bounded input range (``envelope_["input_min"/"input_max"]``)."""

    envelope_: dict[str, Any]


def input_variable(model: Any) -> str:
    """``model.input_variable`` if it has one, else ``"velocity"`` (the default of the contract)."""
    return getattr(model, "input_variable", "velocity")


def model_input(model: Any, velocity: Any, acceleration: Any) -> Any:
    """The signal ``model`` reads as its input: ``acceleration`` if its :func:`input_variable`
    is ``"acceleration"``, else ``velocity``.

    Raises
    ------
    ValueError
        The model reads the acceleration and ``acceleration`` is None.
    """
    if input_variable(model) != "acceleration":
        return velocity
    if acceleration is None:
        raise ValueError(f"this {type(model).__name__} reads the tank acceleration (m/s^2): "
                         "pass acceleration")
    return acceleration


class FrozenLiquid:
    """Liquid frozen in the tank: a rigid mass, no dynamic force (``dF = 0``).

    Parameters
    ----------
    dt : float
        Time step, s.
    """

    force_rule: ForceRule = "trapezoid"
    jax_traceable: ClassVar[Literal[True]] = True

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
