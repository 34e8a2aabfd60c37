"""What every fitted ROM shares: the min-max scaler and the fitted model's base.

:class:`MinMaxScaler` scales a record's input and output to [-1, 1] (MATLAB ``mapminmax``);
:class:`FittedNetwork` is the base of the fitted model of every class of the registry (the
time-delay networks of :mod:`sloshrom.rom.tdnn`, the state-space networks of
:mod:`sloshrom.rom.nss`, the linear model of :mod:`sloshrom.rom.lss`): the sloshing-model
contract beyond ``init_state``/``step``/``free_run``, the run from measured history and the
hooks the exporters call (``model_class``, ``describe``, ``feedthrough``, ``fmu_member``).
:func:`network_of` is the capability check that finds the fitted model an estimator delegates
to.

Precision follows the caller's JAX configuration; the estimators and trainers call these
functions inside ``jax.enable_x64(True)`` (:mod:`sloshrom._x64`).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from functools import partial
from typing import Any

import jax
import numpy as np
from numpy.typing import ArrayLike

from sloshrom._x64 import float64
from sloshrom.models import model_input
from sloshrom.rom.errors import NotFittedError, ROMError, UnstableModelError
from sloshrom.rom.registry import ModelClass

__all__ = ["FittedNetwork", "MinMaxScaler", "network_of"]


# ---------------------------------------------------------------------------------------------
# Scaling
# ---------------------------------------------------------------------------------------------


@partial(jax.tree_util.register_dataclass,
         data_fields=["in_min", "in_max", "out_min", "out_max"], meta_fields=[])
@dataclass(frozen=True)
class MinMaxScaler:
    """Min-max scaling of the input and the output to [-1, 1] (MATLAB ``mapminmax``).

    A JAX pytree: the four bounds (physical units) are its leaves, so a model passed into a
    jitted function carries its scaler as data, not as compiled-in constants.
    """

    in_min: float
    in_max: float
    out_min: float
    out_max: float

    @classmethod
    def fit(cls, u: np.ndarray, y: np.ndarray) -> MinMaxScaler:
        """Bounds of an input record ``u`` and an output record ``y``.

        Raises
        ------
        ROMError
            The input or the output is constant (nothing to identify).
        """
        u_min, u_max = float(np.min(u)), float(np.max(u))
        y_min, y_max = float(np.min(y)), float(np.max(y))
        if not u_max > u_min:
            raise ROMError(f"input is constant ({u_min!r}): nothing to identify from")
        if not y_max > y_min:
            raise ROMError(f"output is constant ({y_min!r}): nothing to identify")
        return cls(u_min, u_max, y_min, y_max)

    def u(self, u: Any) -> Any:
        """Scaled input."""
        return 2.0 * (u - self.in_min) / (self.in_max - self.in_min) - 1.0

    def y(self, y: Any) -> Any:
        """Scaled output."""
        return 2.0 * (y - self.out_min) / (self.out_max - self.out_min) - 1.0

    def y_inverse(self, ys: Any) -> Any:
        """Physical output from the scaled one."""
        return (ys + 1.0) * 0.5 * (self.out_max - self.out_min) + self.out_min

    @property
    def out_half_range(self) -> float:
        """Half the output range: physical MSE = scaled MSE * out_half_range**2."""
        return 0.5 * (self.out_max - self.out_min)

    def to_dict(self) -> dict[str, float]:
        """The four bounds by name (physical units)."""
        return {k: float(getattr(self, k)) for k in ("in_min", "in_max", "out_min", "out_max")}


class FittedNetwork:
    """Base of the fitted models that an estimator delegates to (the time-delay networks of
    :mod:`sloshrom.rom.tdnn`, the state-space networks of :mod:`sloshrom.rom.nss`, the linear
    model of :mod:`sloshrom.rom.lss`, a class of your own). Each holds
    ``params`` (dict of arrays) and ``scaler`` as pytree leaves, ``spec``, ``input``, ``fs``,
    ``unstable_bound`` static, and implements ``init_state``/``step``/``free_run``; the rest of
    the sloshing-model contract is here."""

    #: the force at sample k is the force at t_k (energy integrals: trapezoid rule)
    force_rule = "trapezoid"
    #: step is a pure JAX function and the network a pytree
    jax_traceable = True
    #: how an unstable run is named in its error
    _simulation = "simulation"
    # the fields every subclass holds (its pytree's leaves and static part)
    scaler: MinMaxScaler
    fs: float
    unstable_bound: float

    @property
    def feedthrough(self) -> bool:
        """Whether the force at sample k reads the input at sample k (a state-space output
        map), not past inputs only (an FMU declares the dependency)."""
        return False

    @property
    def model_class(self) -> ModelClass:
        """The registry entry of the class this network is a fitted model of."""
        raise NotImplementedError

    def describe(self) -> str:
        """The architecture in words, e.g. ``"NSS (8 states, 64 neurons)"``."""
        raise NotImplementedError

    def fmu_member(self) -> tuple[str, dict[str, np.ndarray], dict[str, float | int | str]]:
        """The network as a member of an FMU's C model (``sloshrom_model.h``, ``SlMember``):
        its kernel (``"SL_NFIR"``, ``"SL_NOE"``, ``"SL_NSS"``, ``"SL_GREY"``), its arrays by
        field name (int arrays for delays) and its scalar fields (ints, doubles or C
        enumerators)."""
        raise NotImplementedError

    @property
    def dt(self) -> float:
        """Model time step = 1/fs, s."""
        return 1.0 / self.fs

    def _rest(self) -> tuple[Any, Any]:
        return self.scaler.u(0.0), self.scaler.y(0.0)

    def _check_stable(self, y_s: np.ndarray) -> None:
        bad = ~np.isfinite(y_s) | (np.abs(y_s) > self.unstable_bound)
        if np.any(bad):
            k = int(np.argmax(bad.reshape(-1)) % y_s.shape[-1])
            raise UnstableModelError(
                f"{self._simulation} unstable: output non-finite or beyond "
                f"{self.unstable_bound} half-ranges of the training output at sample {k} "
                f"(t = {k / self.fs:.3f} s)")

    @property
    def history_samples(self) -> int:
        """Samples of measured input and output that a start from history reads (the delay
        lines, the encoder's window, a linear model's order)."""
        raise NotImplementedError

    def _history_run(self, u_past: np.ndarray, y_past: np.ndarray, u: np.ndarray
                     ) -> np.ndarray:
        """:meth:`run_from_history` on checked arrays (physical units)."""
        raise NotImplementedError

    def free_run(self, u: ArrayLike) -> np.ndarray:
        """Output from rest (physical units) for an input record at ``fs``, shape (n,) or
        (batch, n)."""
        raise NotImplementedError

    def _checked_free_run(self, u: ArrayLike,
                          run: Callable[[np.ndarray], np.ndarray]) -> np.ndarray:
        """:meth:`free_run` of a model with a state: ``run(u2)`` gives the scaled outputs
        (batch, n) of the records ``u2`` (batch, n, physical units); they are checked against
        the stability bound and returned in physical units, in the shape of ``u``."""
        u = np.asarray(u, dtype=np.float64)
        y_s = run(np.atleast_2d(u))
        self._check_stable(y_s)
        out = np.asarray(self.scaler.y_inverse(y_s))
        return out if u.ndim == 2 else out[0]

    @float64
    def run_from_history(self, u_past: ArrayLike, y_past: ArrayLike, u: ArrayLike
                         ) -> np.ndarray:
        """Output for an input record started from measured history instead of rest.

        Parameters
        ----------
        u_past, y_past : array_like, shape (h,)
            The measured input and output of the ``h >= history_samples`` samples just before
            ``u`` (physical units, oldest first): they fill the delay lines (NFIR, NOE), are
            encoded into the state (NSS) or give the state by least squares (LSS).
        u : array_like, shape (n,)
            The input from the start on, finite (checked by the caller).

        Returns
        -------
        ndarray, shape (n,)
            Output (physical units), float64.

        Raises
        ------
        ROMError
            Histories of other lengths, or shorter than :attr:`history_samples`.
        UnstableModelError
            The run left the stability bound.
        """
        up = np.asarray(u_past, dtype=np.float64)
        yp = np.asarray(y_past, dtype=np.float64)
        need = self.history_samples
        if up.ndim != 1 or up.shape != yp.shape:
            raise ROMError(f"the history must be two 1-D records of one length, got input "
                           f"{up.shape} and output {yp.shape}")
        if up.size < need:
            raise ROMError(f"a start from history reads {need} samples of input and output "
                           f"({self.describe()}), got {up.size}")
        return self._history_run(up, yp, np.asarray(u, dtype=np.float64))

    def simulate(self, velocity: Any, acceleration: Any = None) -> np.ndarray:
        """Sloshing-model contract: dynamic force (N) from the signal the network reads."""
        return self.free_run(np.asarray(model_input(self, velocity, acceleration),
                                        dtype=np.float64))


def network_of(model: Any) -> FittedNetwork | None:
    """The one fitted network ``model`` is or delegates to (an estimator's ``model_``); None
    for anything else (an ensemble, a fill blend, a physics model).

    Raises
    ------
    NotFittedError
        ``model`` is an estimator of a registered class (it has its entry, ``model_class``)
        that is not fitted yet.
    """
    if isinstance(model, FittedNetwork):
        return model
    net = getattr(model, "model_", None)
    if isinstance(net, FittedNetwork):
        return net
    if getattr(model, "model_class", None) is not None:
        raise NotFittedError(f"this {type(model).__name__} is not fitted: call fit() first")
    return None
