"""The neural state-space ROM's training: multiple shooting from the encoder.

:func:`fit_statespace` (epochs run by :func:`sloshrom.rom.engine.adam_epochs`):
minibatch Adam (``optax``) on the simulation error of
``batch`` sub-sequences of ``horizon`` samples drawn at random from the record, each started by
the encoder; early stopping on the free run of the whole validation record from rest (the same
test as the NFIR's). The loss terms of the passive recipe carry over: amplitude weights
(:func:`sloshrom.rom.tdnn.training.amplitude_weights`), the error of the energy each sub-sequence
exchanges with the liquid (the state-space form of the cycle-energy term) and a passivity
penalty on harmonic probes run from rest inside the training envelope, simulated in the same
batch as the data.

Everything here is a pure function of explicit arguments; the model is
:mod:`sloshrom.rom.nss.network`, the estimator :class:`sloshrom.rom.NSS`.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import fields
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np

from sloshrom._x64 import float64
from sloshrom.rom.engine import AdamProblem, adam_epochs
from sloshrom.rom.errors import ROMError
from sloshrom.rom.losses import TRAIN_DTYPE, windows
from sloshrom.rom.network import MinMaxScaler
from sloshrom.rom.nss.entry import NSS_CLASS
from sloshrom.rom.nss.network import (
    StateSpaceSpec,
    param_shapes,
    ss_free_run,
    ss_history_run,
    ss_simulate,
    strictly_proper,
)
from sloshrom.rom.registry import state_space_min_samples
from sloshrom.rom.shooting import PyTree, Recurrence, ShootingOptions, ss_encode
from sloshrom.rom.shooting import shooting_problem as shooting

__all__ = ["NSS_SHOOTING", "fit_statespace", "init_params", "shooting_problem"]

#: The state-space ROM's multiple-shooting recipe by default (its estimator passes its own):
#: its entry's defaults
NSS_SHOOTING = ShootingOptions(**{f.name: NSS_CLASS.defaults()[f.name]
                                  for f in fields(ShootingOptions)
                                  if f.name in NSS_CLASS.defaults()})


def init_params(spec: StateSpaceSpec, seed: int) -> dict[str, np.ndarray]:
    """Seeded initial parameters: tanh layers scaled by 1/sqrt(fan-in), small linear parts and
    output layers so that the untrained model is a slow, nearly linear system."""
    rng = np.random.default_rng(seed)
    out = {}
    for name, shape in param_shapes(spec).items():
        if name in ("b1", "d1", "e1"):
            out[name] = np.zeros(shape)
            continue
        fan_in = shape[0]
        small = 0.1 if name in ("A", "W2", "C", "V2", "E2") else 1.0
        out[name] = small * rng.standard_normal(shape) / math.sqrt(fan_in)
    # a slowly decaying linear part: the untrained model is stable over a whole horizon
    out["A"][: spec.n_states] -= 0.05 * np.eye(spec.n_states)
    return out


# ---------------------------------------------------------------------------------------------
# Training: multiple shooting with the passive recipe's loss terms
# ---------------------------------------------------------------------------------------------


def _as64(p: dict[str, Any]) -> dict[str, Any]:
    return {k: jnp.asarray(v, jnp.float64) for k, v in p.items()}


def shooting_problem(
    spec: StateSpaceSpec,
    u: np.ndarray,
    y: np.ndarray,
    fs: float,
    scaler: MinMaxScaler,
    validation: tuple[np.ndarray, np.ndarray] | None = None,
    options: ShootingOptions = NSS_SHOOTING,
    seed: int = 0,
    validation_history: int = 0,
) -> AdamProblem:
    """The multiple-shooting problem of :func:`fit_statespace` for the training engine
    (:func:`sloshrom.rom.engine.adam_epochs`); the parameters are :func:`fit_statespace`'s.

    Call it inside ``jax.enable_x64(True)``: the validation runs in float64, the Adam steps in
    :data:`~sloshrom.rom.tdnn.training.TRAIN_DTYPE`.
    """
    n, w, T = np.size(u), spec.window, int(options.horizon)
    need = state_space_min_samples({"window": w, "horizon": T})
    if n < need:
        raise ROMError(f"{n} samples are too few for an encoder window of {w} and a horizon "
                       f"of {T} samples (need at least {need})")
    ru, ry = float(scaler.u(0.0)), float(scaler.y(0.0))
    f32 = TRAIN_DTYPE
    u_s = jnp.asarray(scaler.u(np.asarray(u, dtype=np.float64)), f32)
    y_s = jnp.asarray(scaler.y(np.asarray(y, dtype=np.float64)), f32)

    def start(p: PyTree, d: PyTree, starts: jax.Array, shift: jax.Array) -> jax.Array:
        # the state encoded from the window of measured input and output before the start
        return ss_encode(p, windows(d["u_s"], starts, w) + shift[:, None],
                         windows(d["y_s"], starts, w), ru, ry)

    out_map = strictly_proper if spec.proper else (lambda p: p)

    def simulate(p: PyTree, d: PyTree, x0: jax.Array, uf: jax.Array) -> jax.Array:
        return ss_simulate(out_map(p), x0, uf.T, ru, ry)[1].T

    def free_run(p: PyTree, uv: np.ndarray) -> np.ndarray:
        return np.asarray(ss_free_run(_as64(out_map(p)), jnp.asarray(uv)[:, None], ru,
                                      ry))[:, 0]

    def history_run(p: PyTree, up: np.ndarray, yp: np.ndarray, uv: np.ndarray) -> np.ndarray:
        return np.asarray(ss_history_run(_as64(out_map(p)), jnp.asarray(up), jnp.asarray(yp),
                                         jnp.asarray(uv), ru, ry))

    rec = Recurrence(offset=w, n_starts=n - w - T, start=start,
                     rest=lambda k: jnp.zeros((k, spec.n_states), f32), simulate=simulate,
                     free_run=free_run, history_run=history_run,
                     data={"u_s": u_s, "y_s": y_s})
    params0 = out_map({k: jnp.asarray(v, f32) for k, v in init_params(spec, seed).items()})
    return shooting(rec, params0, u, y, fs, scaler, validation, options, validation_history)


@float64
def fit_statespace(
    spec: StateSpaceSpec,
    u: np.ndarray,
    y: np.ndarray,
    fs: float,
    scaler: MinMaxScaler,
    validation: tuple[np.ndarray, np.ndarray] | None = None,
    options: ShootingOptions = NSS_SHOOTING,
    *,
    max_fail: int = 6,
    seed: int = 0,
    callback: Callable[[int, dict], Any] | None = None,
    validation_history: int = 0,
) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
    """Identify a state-space network by multiple shooting (see the module docstring).

    Parameters
    ----------
    spec : StateSpaceSpec
    u, y : ndarray, shape (n,)
        Input (m/s) and output (N) records at ``fs``, physical units.
    fs : float
        Sample rate, Hz.
    scaler : MinMaxScaler
        Scaling of input and output (normally fitted on ``u``, ``y``).
    validation : (u_val, y_val), optional
        Early stopping: the free run of the whole record from rest; the best parameters are
        returned. Without it, the epoch of the lowest training MSE.
    validation_history : int
        The validation record's first samples (>= ``spec.window``) taken as measured history:
        the run starts from the state the encoder gives for them and is scored after them
        (a validation record that does not start at rest); 0: from rest.
    options : ShootingOptions
        The recipe (:class:`sloshrom.rom.shooting.ShootingOptions`): horizon (samples simulated
        from each encoded start), batch, epochs of ``steps_per_epoch`` Adam steps at most, the
        learning rate, the passive recipe's weights (0 = off), the probes.
    max_fail : int
        Epochs without a new best validation objective before stopping, once half of
        ``options.max_epochs`` have run.
    seed : int
        Seeds the initialisation and the draws of sub-sequences and probes.
    callback : callable, optional
        ``callback(epoch, info)`` after every epoch; True stops the training.

    Returns
    -------
    params : dict of ndarray
        The parameters (scaled units).
    history : dict
        Per-epoch ``train_mse``, ``val_mse`` (N^2), ``val_objective``, ``seconds``,
        ``step_seconds``, ``validation_seconds`` (:func:`sloshrom.rom.engine.adam_epochs`);
        ``stop_reason``, ``best_epoch``, ``trainer`` ("shooting"), ``n_rows``,
        ``train_seconds``.
    """
    problem = shooting_problem(spec, u, y, fs, scaler, validation, options, seed,
                               validation_history)
    t0 = time.perf_counter()
    # no early stop in the first half of the cosine schedule, and a blow-up (validation 10x
    # the best) continues from the best epoch: on a CPU with another instruction set a member
    # blew up twice and stopped at epoch 15 of 60 (map error 64 %, its twin's 9 %)
    res = adam_epochs(problem, max_epochs=int(options.max_epochs), max_fail=max_fail,
                      min_epochs=int(options.max_epochs) // 2, rollback=10.0, seed=seed,
                      mse_scale=scaler.out_half_range**2, callback=callback)
    history: dict[str, Any] = dict(res.history)
    history.update(stop_reason=res.stop_reason, best_epoch=res.best_epoch, trainer="shooting",
                   n_rows=int(np.asarray(u).size), train_seconds=time.perf_counter() - t0)
    params = strictly_proper(res.params) if spec.proper else res.params
    return {k: np.asarray(v, dtype=np.float64) for k, v in params.items()}, history
