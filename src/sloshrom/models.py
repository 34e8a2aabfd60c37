"""The sloshing-model contract, its capabilities, the training envelope and the frozen liquid.

A *sloshing model* maps the history of the tank's vertical motion to the dynamic sloshing force
``dF = f_S + m_l * acc`` (N, paper Eq. 2, w up positive). Every model (frozen liquid, virtual rig,
the ROMs, their ensembles and fill blends, the bouncing ball) implements the same contract,
:class:`SloshingModel`, so the coupled beam simulation and the energy maps do not care which they
get:

``dt``
    The model's time step, s: the step of :meth:`step` and the sample interval of
    :meth:`simulate` (a network: 1/fs of its training data; the rig and the bouncing ball: their
    fine step). An estimator's ``predict(u)`` runs at the rate of its training record ``fs_``,
    which is ``1/dt`` for a network and ``1/(dt * n_substeps_)`` for the ball.
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

Optional members, each read through one function of this module (the only places that ask a
model what it is), with the default a model without the member gets:

``input`` (:func:`input_of`, default ``"velocity"``)
    The signal the model reads and its envelope describes: ``"velocity"`` (m/s) or
    ``"acceleration"`` (m/s^2). :func:`model_input` picks it from the two.
``envelope_`` (:func:`envelope_of`, default none)
    The ranges the model was identified on (:class:`Envelope`); outside them it extrapolates and
    :func:`check_envelope` warns with :class:`EnvelopeWarning`.
``tank`` (:func:`tank_of`, default none)
    The :class:`~sloshrom.config.Tank` the model simulates (the rig, the bouncing ball); a
    network does not know its tank, and the energy maps then ask for one.
``jax_traceable`` (:func:`is_jax_model`, default False)
    True when ``step`` is a pure, traceable JAX function and the model a JAX pytree (learned
    parameters are leaves): it runs inside ``jit``/``lax.scan`` and ``jax.grad`` flows through
    it. A combinator (an ensemble, a fill blend) sets it from its members.
``kernel()`` (:func:`has_kernel`)
    A numba-compiled step ``(step_fn, params, state)`` for fast loops (the rig, the ball).
``stepper`` (:func:`stepper_of`, default the model itself)
    The object whose ``init_state`` and ``step`` are the model's, handed to a compiled loop as
    its argument: a fitted estimator's network, without the hyperparameters of its training.
    A pytree's static part is part of ``jit``'s cache key, so two models that differ only there
    (an ensemble's members: their seeds) would each compile the same loop.
"""

from __future__ import annotations

import contextlib
import contextvars
import warnings
from collections.abc import Iterator, Mapping
from dataclasses import dataclass
from typing import Any, Literal, Protocol, runtime_checkable

import numpy as np

from sloshrom.config import Tank
from sloshrom.errors import SloshromError

__all__ = [
    "INPUTS",
    "INPUT_UNITS",
    "CompiledKernel",
    "Envelope",
    "EnvelopeWarning",
    "FrozenLiquid",
    "ModelError",
    "SloshingModel",
    "check_envelope",
    "envelope_of",
    "envelope_quiet",
    "envelope_union",
    "has_kernel",
    "has_no_force",
    "input_of",
    "is_jax_model",
    "model_input",
    "stepper_of",
    "tank_of",
]

ForceRule = Literal["trapezoid", "step"]
Input = Literal["velocity", "acceleration"]
#: The signals a sloshing model may read, and their SI units.
INPUTS: tuple[Input, ...] = ("velocity", "acceleration")
INPUT_UNITS: dict[str, str] = {"velocity": "m/s", "acceleration": "m/s^2"}


class ModelError(SloshromError):
    """A sloshing model asked for something it cannot give (e.g. an input it does not have)."""


class EnvelopeWarning(UserWarning):
    """The input passed to a model lies outside the range it was identified on."""


@runtime_checkable
class SloshingModel(Protocol):
    """The step contract (see the module docstring)."""

    dt: float
    force_rule: ForceRule

    def init_state(self) -> Any:
        """The state at rest (an array or a pytree of arrays)."""

    def step(self, state: Any, velocity: Any, acceleration: Any) -> tuple[Any, Any]:
        """One step at sample k: ``(state, dynamic_force)``, force in N."""

    def simulate(self, velocity: Any, acceleration: Any) -> np.ndarray:
        """The dynamic force (N) over whole records, arrays ``(..., n)``."""


@runtime_checkable
class CompiledKernel(Protocol):
    """A sloshing model with a numba-compiled step for tight loops (for type hints;
    :func:`has_kernel` checks it)."""

    def kernel(self) -> tuple[Any, Any, Any]:
        """``(step_fn, params, state)``: ``step_fn(state, params, velocity, acceleration)`` is a
        numba function returning the dynamic force (N) and updating ``state`` in place."""
        ...


# -- capabilities: the only places that ask a model what it is -----------------------------------
def input_of(model: Any) -> Input:
    """The signal ``model`` reads: its ``input`` member, ``"velocity"`` without one.

    Raises
    ------
    ModelError
        ``input`` is neither ``"velocity"`` nor ``"acceleration"``.
    """
    kind = getattr(model, "input", "velocity")
    if kind not in INPUTS:
        raise ModelError(f"{type(model).__name__}.input must be 'velocity' or 'acceleration', "
                         f"got {kind!r}")
    return kind


def model_input(model: Any, velocity: Any, acceleration: Any) -> Any:
    """The signal ``model`` reads as its input (:func:`input_of`): ``acceleration`` or
    ``velocity``.

    Raises
    ------
    ModelError
        The model reads the acceleration and ``acceleration`` is None.
    """
    if input_of(model) != "acceleration":
        return velocity
    if acceleration is None:
        raise ModelError(f"this {type(model).__name__} reads the tank acceleration (m/s^2): "
                         "pass acceleration")
    return acceleration


def is_jax_model(model: Any) -> bool:
    """True when ``model.jax_traceable`` is True: its ``step`` runs in ``jit``/``lax.scan`` and
    under ``jax.grad`` (the coupled simulation then runs in JAX)."""
    return getattr(model, "jax_traceable", False) is True


def stepper_of(model: SloshingModel) -> SloshingModel:
    """What runs ``model``'s steps in a compiled loop: its ``stepper`` member, or the model
    itself."""
    return getattr(model, "stepper", model)


def has_kernel(model: Any) -> bool:
    """True when ``model.kernel()`` gives a numba step (the coupled simulation's numba
    backend)."""
    return isinstance(model, CompiledKernel)


def has_no_force(model: Any) -> bool:
    """True for the frozen liquid (``dF = 0``): simulations may skip its step."""
    return isinstance(model, FrozenLiquid)


def tank_of(model: Any) -> Tank | None:
    """The tank ``model`` simulates (its ``tank`` member), or None when it does not say."""
    tank = getattr(model, "tank", None)
    return tank if isinstance(tank, Tank) else None


# -- the training envelope ------------------------------------------------------------------------
@dataclass(frozen=True)
class Envelope:
    """The ranges a model was identified on (read-only view of its ``envelope_`` mapping).

    Parameters
    ----------
    input : {"velocity", "acceleration"}
        The signal ``input_min``/``input_max`` are a range of (the model's :func:`input_of`).
    input_min, input_max : float
        Range of the training input (m/s or m/s^2).
    acceleration_max : float or None
        Peak |tank acceleration| of the training record, m/s^2.
    fill_min, fill_max : float or None
        Fill levels d/h (-) of the training records.
    frequency_band : tuple of float or None
        ``(low, high)`` band of the training excitation, Hz.
    """

    input: Input
    input_min: float
    input_max: float
    acceleration_max: float | None = None
    fill_min: float | None = None
    fill_max: float | None = None
    frequency_band: tuple[float, float] | None = None

    @classmethod
    def from_mapping(cls, env: Any, input: Input = "velocity") -> Envelope | None:
        """The envelope an ``envelope_`` mapping describes (None: not a mapping, or no
        ``input_min``); ``input`` names the signal of its input range."""
        if not isinstance(env, Mapping) or "input_min" not in env:
            return None

        def opt(key: str) -> float | None:
            v = env.get(key)
            return None if v is None else float(v)

        band = env.get("frequency_band")
        return cls(input, float(env["input_min"]), float(env["input_max"]),
                   opt("acceleration_max"), opt("fill_min"), opt("fill_max"),
                   None if band is None else (float(band[0]), float(band[1])))

    @property
    def unit(self) -> str:
        """SI unit of the input range."""
        return INPUT_UNITS[self.input]

    def excess(self, u: Any) -> float:
        """How far ``u`` leaves ``[input_min, input_max]`` (input units; 0 inside)."""
        a = np.asarray(u, dtype=np.float64)
        return max(float(np.max(a)) - self.input_max, self.input_min - float(np.min(a)), 0.0)


def _envelope_mapping(model: Any) -> Any:
    """The raw ``envelope_`` mapping of ``model`` (None without one): what
    :func:`envelope_of` and :func:`envelope_union` read."""
    return getattr(model, "envelope_", None)


def envelope_of(model: Any) -> Envelope | None:
    """``model``'s training envelope, or None (no ``envelope_``, an empty one, or a model
    rebuilt from pytree leaves, which carries no training record)."""
    return Envelope.from_mapping(_envelope_mapping(model), input_of(model))


def envelope_union(models: Any) -> dict[str, Any] | None:
    """The envelope of a combination of models (an ensemble, a fill blend): the union of the
    members' ranges, as an ``envelope_`` mapping; None unless every member has one.

    Keys: ``input_min``/``input_max``, ``output_min``/``output_max``, ``frequency_band`` (Hz),
    and ``acceleration_max`` (m/s^2) and ``fill_min``/``fill_max`` (-) when every member has
    them.
    """
    envelopes = [_envelope_mapping(m) for m in models]
    if not envelopes or not all(isinstance(e, Mapping) and "input_min" in e for e in envelopes):
        return None
    out: dict[str, Any] = {
        "input_min": min(e["input_min"] for e in envelopes),
        "input_max": max(e["input_max"] for e in envelopes),
        "output_min": min(e["output_min"] for e in envelopes),
        "output_max": max(e["output_max"] for e in envelopes),
        "frequency_band": [min(e["frequency_band"][0] for e in envelopes),
                           max(e["frequency_band"][1] for e in envelopes)],
    }
    acc = [e.get("acceleration_max") for e in envelopes]
    if all(a is not None for a in acc):
        out["acceleration_max"] = max(acc)
    if all(e.get("fill_min") is not None for e in envelopes):
        out["fill_min"] = min(e["fill_min"] for e in envelopes)
        out["fill_max"] = max(e["fill_max"] for e in envelopes)
    return out


#: True inside :func:`envelope_quiet` (this thread or task, and the calls it hands to
#: :func:`sloshrom._threads.map_threads`)
_ENVELOPE_QUIET: contextvars.ContextVar[bool] = contextvars.ContextVar(
    "sloshrom_envelope_quiet", default=False)


@contextlib.contextmanager
def envelope_quiet() -> Iterator[None]:
    """No :class:`EnvelopeWarning` from :func:`check_envelope` in this block: for a deliberate
    probe outside a model's envelope, or a caller that has checked the union of its models'.

    Unlike a warnings filter, it holds for this thread (or asyncio task) only, and for the
    calls it hands to :func:`sloshrom._threads.map_threads`: other threads' warnings stay
    as they were (Python's filters are one list for the whole process).
    """
    token = _ENVELOPE_QUIET.set(True)
    try:
        yield
    finally:
        _ENVELOPE_QUIET.reset(token)


def check_envelope(model: Any, u: Any, *, what: str = "input", unit: str | None = None,
                   stacklevel: int = 2) -> None:
    """Warn (:class:`EnvelopeWarning`) when ``u`` leaves ``model``'s training input range.

    Every call warns, but inside :func:`envelope_quiet`; the warnings filters decide what is
    shown (once per place by default), so that checking leaves the model as it was.

    Parameters
    ----------
    model : sloshing model
        Without an envelope (:func:`envelope_of`) nothing is checked.
    u : array_like
        The model's input (:func:`model_input`), in its SI unit.
    what : str
        How the message names the signal (e.g. ``"tank velocity of tank 2"``).
    unit : str, optional
        The unit of ``u`` in the message (default the SI unit of the model's input; an
        estimator on other records passes its own).
    stacklevel : int
        As :func:`warnings.warn`, counted from the caller of this function.
    """
    env = envelope_of(model)
    if env is None or _ENVELOPE_QUIET.get():
        return
    over = env.excess(u)
    if over > 0:
        lo, hi = env.input_min, env.input_max
        unit = env.unit if unit is None else unit
        span = hi - lo
        share = f" ({100 * over / span:.1f} % of the range)" if span > 0 else ""
        warnings.warn(
            f"{what} outside the training envelope [{lo:.4g}, {hi:.4g}] {unit} by {over:.4g} "
            f"{unit}{share}: the model extrapolates",
            EnvelopeWarning,
            stacklevel=stacklevel + 1,
        )


class FrozenLiquid:
    """Liquid frozen in the tank: a rigid mass, no dynamic force (``dF = 0``).

    Parameters
    ----------
    dt : float
        Time step, s.
    """

    force_rule: ForceRule = "trapezoid"
    jax_traceable = True

    def __init__(self, dt: float) -> None:
        if not (np.isfinite(dt) and dt > 0):
            raise ModelError(f"dt must be a finite positive time step in s, got {dt!r}")
        self.dt = float(dt)

    # a value: two frozen liquids of one step are the same model, so that a coupled simulation
    # compiled for one (it is compiled in, not an argument) serves the other
    def __eq__(self, other: object) -> bool:
        return type(other) is FrozenLiquid and other.dt == self.dt

    def __hash__(self) -> int:
        return hash((FrozenLiquid, self.dt))

    def __repr__(self) -> str:
        return f"FrozenLiquid(dt={self.dt!r})"

    def init_state(self) -> np.ndarray:
        """No state: an empty array."""
        return np.zeros(0)

    def step(self, state: Any, velocity: Any, acceleration: Any) -> tuple[Any, Any]:
        """No force: ``(state, 0)``, N."""
        return state, 0.0 * velocity

    def simulate(self, velocity: Any, acceleration: Any) -> np.ndarray:
        """No force: zeros of the inputs' broadcast shape, N."""
        return np.zeros(np.broadcast_shapes(np.shape(velocity), np.shape(acceleration)))
