"""The grey-box ROM's model: the impacting column (:mod:`sloshrom.rom.grey.physics`) and a
neural state-space network that sees it.

Scaled units of :class:`~sloshrom.rom.network.MinMaxScaler` (``u_s``, ``y_s``; ``r_u``, ``r_y``
the scaled rest input and output); ``phi_k`` the physical part's features at sample ``k``
(its filtered force and the mean forces of its last and next intervals, N) divided by the
output's half range ``c``, so that ``phi = 0`` at rest::

    z_k     = [x_k, u_s,k - r_u, phi_k]
    x_{k+1} = x_k + F(z_k) - F(0),        F(z) = z A + tanh(z W1 + b1) W2
    o_k     = [x_k, phi_k]
    y_s,k   = r_y + phi_k[0] + H(o_k) - H(0),   H(o) = o C + tanh(o V1 + d1) V2

The force is the physics' force plus the network's correction: with the network's output
layer at zero (``C = 0``, ``V2 = 0``, its start) the model *is* the physical model; the network
corrects what the column does not hold (the surface waves below the impacts, the force's
smooth part, the frequency dependence the gate misses) and may use the column's state (the
features) to do it. The output reads the state and the features, never ``u_k``: the model is
strictly proper. The state ``x = 0`` with the physics at rest is an equilibrium of zero force.

An encoder starts the network's state from the measured past, as the NSS's
(:func:`sloshrom.rom.shooting.ss_encode`); the physics starts from rest at the start of a
run (its memory is short: a ball that lands under gravity re-attaches).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from functools import partial

import jax
import jax.numpy as jnp
import numpy as np
from jax import lax
from numpy.typing import ArrayLike

from sloshrom._x64 import float64
from sloshrom.config import G
from sloshrom.models import model_input
from sloshrom.rom.errors import ROMError
from sloshrom.rom.grey.entry import GREY_CLASS
from sloshrom.rom.grey.kernel import free_run_rows
from sloshrom.rom.grey.physics import (
    COHERENCE_TIME,
    PHYS_NAMES,
    PhysicsState,
    grey_features,
    physics_step,
)
from sloshrom.rom.network import FittedNetwork, MinMaxScaler
from sloshrom.rom.registry import ModelClass
from sloshrom.rom.shooting import ss_encode

__all__ = ["N_FEATURES", "GreyBoxNetwork", "GreySpec", "grey_output", "grey_run",
           "grey_simulate", "grey_state_update"]

#: Features of the physical part the network reads.
N_FEATURES = 4
#: The network's parameters by name (arrays; the physics' among them, read by the step).
Params = Mapping[str, jax.Array | np.ndarray]
#: The model's state: the column's (:data:`~sloshrom.rom.grey.physics.PhysicsState`) and the
#: network's state vector.
GreyState = tuple[PhysicsState, jax.Array]


@dataclass(frozen=True)
class GreySpec:
    """The static architecture of a grey-box ROM (hashable: a jit static argument).

    Parameters
    ----------
    n_states, neurons, window : int
        The network's state dimension, tanh units of each map, and the encoder's window
        (samples).
    n_balls, n_substeps, n_past : int
        The column's balls, the sub-steps of a sample interval, and the intervals its output
        filter reads at and before the output sample.
    """

    n_states: int
    neurons: int
    window: int
    n_balls: int
    n_substeps: int
    n_past: int

    @property
    def n_taps(self) -> int:
        """Taps of the physical part's output filter."""
        return (self.n_past + 1) * self.n_substeps

    @property
    def max_delay(self) -> int:
        """The longest history the model reads from a record: the encoder window, samples."""
        return self.window

    @property
    def n_inputs(self) -> int:
        """Inputs of the state map: the state, the input and the features."""
        return self.n_states + 1 + N_FEATURES

    @property
    def n_params(self) -> int:
        """The parameters of the model: the network's, the physics' and the filter's."""
        return int(sum(int(np.prod(s)) for s in GREY_CLASS.shapes(self.hyper()).values()))

    def hyper(self) -> dict[str, int]:
        """The sizes as hyperparameters (the registry entry's shapes read them)."""
        return {"n_states": self.n_states, "neurons": self.neurons, "window": self.window,
                "n_balls": self.n_balls, "n_substeps": self.n_substeps, "n_past": self.n_past}


def _f(p: Params, z: jax.Array) -> jax.Array:
    return z @ p["A"] + jnp.tanh(z @ p["W1"] + p["b1"]) @ p["W2"]


def _h(p: Params, o: jax.Array) -> jax.Array:
    return o @ p["C"] + jnp.tanh(o @ p["V1"] + p["d1"]) @ p["V2"]


def grey_output(p: Params, x: jax.Array, phi_s: jax.Array, r_y: float | jax.Array) -> jax.Array:
    """The scaled output ``y_s`` (...) from the state ``x`` (..., nx) and the scaled features
    ``phi_s`` (..., 4)."""
    o = jnp.concatenate([x, phi_s], axis=-1)
    zero = jnp.zeros(o.shape[-1], o.dtype)
    return r_y + phi_s[..., 0] + _h(p, o) - _h(p, zero)


def grey_state_update(p: Params, x: jax.Array, du_s: jax.Array, phi_s: jax.Array
                      ) -> jax.Array:
    """``x_{k+1}`` from ``x_k`` (..., nx), the scaled input relative to rest ``du_s`` (...)
    and the scaled features (..., 4)."""
    z = jnp.concatenate([x, du_s[..., None], phi_s], axis=-1)
    zero = jnp.zeros(z.shape[-1], z.dtype)
    return x + _f(p, z) - _f(p, zero)


def grey_simulate(p: Params, x0: jax.Array, seq: jax.Array, r_u: float | jax.Array,
                  r_y: float | jax.Array) -> jax.Array:
    """The network over known features: ``seq`` (T, B, 1 + 4) holds the scaled input and the
    scaled features of each sample; returns the scaled outputs (T, B). Training runs this (the
    features precomputed from the record); the fitted model's step computes them as it goes."""

    def body(x: jax.Array, sk: jax.Array) -> tuple[jax.Array, jax.Array]:
        phi = sk[..., 1:]
        y = grey_output(p, x, phi, r_y)
        return grey_state_update(p, x, sk[..., 0] - r_u, phi), y

    return lax.scan(body, x0, seq)[1]


@jax.jit
def grey_run(p: Params, u_s: jax.Array, phi_s: jax.Array, x0: jax.Array,
             r_u: float | jax.Array,
             r_y: float | jax.Array) -> jax.Array:
    """The network from the state ``x0`` (B, nx) over scaled inputs ``u_s`` (n, B) and scaled
    features ``phi_s`` (n, B, 4) (the column's, computed before); the scaled outputs (n, B)."""
    return grey_simulate(p, x0, jnp.concatenate([u_s[..., None], phi_s], axis=-1), r_u, r_y)


@float64
def grey_free_run(p: Mapping[str, ArrayLike], u_s: ArrayLike, phi_s: ArrayLike,
                  x0: ArrayLike, r_u: float, r_y: float) -> np.ndarray:
    """:func:`grey_run` evaluated, in float64 (NumPy out): by the C kernel one row at a time
    (:func:`sloshrom.rom.grey.kernel.free_run_rows`: a validation run or a prediction of a few
    rows; one row 5.8x faster than ``lax.scan``, 32 rows 1.2x) where it was built, else by
    ``lax.scan``. The two agree to round-off (tested)."""
    y = free_run_rows(p, u_s, phi_s, x0, r_u, r_y)
    if y is None:
        y = np.asarray(grey_run({k: jnp.asarray(v, jnp.float64) for k, v in p.items()},
                                jnp.asarray(u_s, jnp.float64), jnp.asarray(phi_s, jnp.float64),
                                jnp.asarray(x0, jnp.float64), r_u, r_y))
    return y


@partial(jax.tree_util.register_dataclass,
         data_fields=["params", "scaler"],
         meta_fields=["spec", "input", "fs", "unstable_bound"])
@dataclass(frozen=True, eq=False)
class GreyBoxNetwork(FittedNetwork):
    """A fitted grey-box ROM: an immutable sloshing model and a JAX pytree.

    Parameters
    ----------
    params : dict
        The arrays of the registry entry's shapes: the network's (``A`` ... ``E2``), the
        physical parameters ``physics`` (:data:`~sloshrom.rom.grey.physics.PHYS_NAMES`) and
        the output filter ``taps``.
    scaler : MinMaxScaler
        Bounds of the training input and output (physical units).
    spec : GreySpec
        The architecture.
    input : {"velocity"}
        The tank signal the model reads.
    fs : float
        Sample rate of the training record, Hz; the model's step is ``dt = 1 / fs``.
    unstable_bound : float
        A run whose scaled output exceeds this magnitude (or is not finite) is unstable.
    """

    params: dict[str, jax.Array | np.ndarray]
    scaler: MinMaxScaler
    spec: GreySpec
    input: str = "velocity"
    fs: float = 1.0
    unstable_bound: float = 10.0

    _simulation = "grey-box simulation"

    @property
    def model_class(self) -> ModelClass:
        """The class's registry entry."""
        return GREY_CLASS

    def describe(self) -> str:
        """A one-line description of the model."""
        s = self.spec
        return (f"grey box ({s.n_balls}-ball column + network of {s.n_states} states, "
                f"{s.neurons} neurons)")

    def physics(self) -> dict[str, float]:
        """The identified physical parameters by name (:data:`PHYS_NAMES`, SI units)."""
        return {k: float(v) for k, v in zip(PHYS_NAMES, np.asarray(self.params["physics"]),
                                            strict=True)}

    def fmu_member(self) -> tuple[str, dict[str, np.ndarray], dict[str, float | int | str]]:
        """The FMU's C data of this model: member kind, arrays and constants (the column's
        step reads the sample rate, gravity and the coherence factor's time constant as
        :meth:`step` does; the scaler's bounds, which give the features' scale, are every
        member's)."""
        p = {k: np.asarray(v, dtype=np.float64) for k, v in self.params.items()}
        s = self.spec
        return ("SL_GREY", {k: p[k] for k in ("A", "W1", "b1", "W2", "C", "V1", "d1", "V2",
                                               "physics", "taps")},
                {"hidden": "SL_HIDDEN_MATLAB", "n_states": s.n_states, "neurons": s.neurons,
                 "n_balls": s.n_balls, "n_substeps": s.n_substeps, "n_past": s.n_past,
                 "fs": float(self.fs), "g": float(G), "coherence_time": float(COHERENCE_TIME)})

    def _half(self) -> float:
        return self.scaler.out_half_range

    def init_state(self) -> tuple[tuple[np.ndarray, ...], np.ndarray]:
        """The rest state: the column at rest and the network's state at zero (NumPy float64:
        the precision of the caller's JAX configuration once traced)."""
        s = self.spec
        zb = np.zeros(s.n_balls)
        z = np.zeros(())
        # NumPy, not JAX: the coupled beam calls this inside its traced function
        ps = (zb, zb.copy(), np.ones(s.n_balls), z, z.copy(), z.copy(), z.copy(),
              np.zeros((s.n_past - 1) * s.n_substeps), np.zeros(4))
        return ps, np.zeros(s.n_states)

    def step(self, state: GreyState, velocity: ArrayLike, acceleration: ArrayLike | None = None
             ) -> tuple[GreyState, jax.Array]:
        """One pure, jax-traceable step: ``(state, dynamic_force_k)`` from the velocity v_k
        (m/s). The force at k reads the state only (strictly proper): it is known before v_k
        is."""
        ps, x = state
        ru, ry = self._rest()
        v = jnp.asarray(model_input(self, velocity, acceleration), jnp.float64)
        phi = ps[-1] / self._half()
        y_s = grey_output(self.params, x, phi, ry)
        x = grey_state_update(self.params, x, self.scaler.u(v) - ru, phi)
        ps = physics_step(jnp.asarray(self.params["physics"]), jnp.asarray(self.params["taps"]),
                          ps, v, self.fs,
                          self.spec.n_substeps, self.spec.n_past)
        return (ps, x), self.scaler.y_inverse(y_s)

    @float64
    def free_run(self, u: ArrayLike) -> np.ndarray:
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
        return self._checked_free_run(
            u, lambda u2: self._run(u2, np.zeros((u2.shape[0], self.spec.n_states))).T)

    @property
    def history_samples(self) -> int:
        """The encoder's window."""
        return int(self.spec.window)

    def _run(self, u2: np.ndarray, x0: np.ndarray, skip: int = 0) -> np.ndarray:
        """Scaled outputs (n - skip, B) of records ``u2`` (B, n) from rest, the network's
        state set to ``x0`` at sample ``skip`` (the column runs from rest throughout: its
        features are computed by its numba kernel, the same arithmetic as :meth:`step`)."""
        s = self.spec
        ru, ry = (float(r) for r in self._rest())
        phi = grey_features(np.asarray(self.params["physics"]), np.asarray(self.params["taps"]),
                            u2, self.fs, s.n_balls, s.n_substeps, s.n_past) / self._half()
        u_s = np.asarray(self.scaler.u(u2), dtype=np.float64)
        return grey_free_run(self.params, u_s[:, skip:].T, np.swapaxes(phi[:, skip:], 0, 1),
                             x0, ru, ry)

    def _history_run(self, u_past: np.ndarray, y_past: np.ndarray, u: np.ndarray
                     ) -> np.ndarray:
        # the column runs from rest through the history (its memory is short: a ball that
        # lands under gravity re-attaches); the network's state is encoded from the history's
        # last window
        w = self.spec.window
        n_h = u_past.size
        x0 = self.encode(u_past[n_h - w:], y_past[n_h - w:])
        y_s = self._run(np.concatenate([u_past, u])[None], x0[None], skip=n_h)[:, 0]
        self._check_stable(y_s)
        return np.asarray(self.scaler.y_inverse(y_s))

    @float64
    def encode(self, u_past: ArrayLike, y_past: ArrayLike) -> np.ndarray:
        """The network's state at the sample after measured history (physical units, oldest
        first); the physics starts at rest.

        Parameters
        ----------
        u_past, y_past : array_like, shape (window,)
            The ``spec.window`` input (m/s) and output (N) samples before the start.

        Returns
        -------
        ndarray, shape (n_states,)

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
