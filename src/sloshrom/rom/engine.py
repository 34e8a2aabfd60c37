"""The training engine of every minibatch-Adam ROM: compiled epochs, early stopping, history.

The three first-order trainers (the NFIR's minibatch Adam,
:func:`sloshrom.rom.tdnn.training.adam_nfir`; the NOE's and the state-space ROM's multiple
shooting, :func:`sloshrom.rom.tdnn.training.adam_noe` and
:func:`sloshrom.rom.nss.training.fit_statespace`) differ only in their loss and in what they draw
at random; everything else is :func:`adam_epochs`:

- an epoch is **one compiled program**: ``lax.scan`` over its ``steps_per_epoch`` Adam steps
  (loss, gradient, optimiser update), so the host is visited once per epoch, not once per step.
  The epoch's random draws (sample indices, probe and cycle indices) are made on the host with
  the trainer's seeded NumPy generator and handed over as one set of arrays;
- the arrays the loss reads (the record, its weights, the probes: the problem's ``data``) are
  the program's arguments, not constants in it, so trainings that differ only in them and
  in their draws (an ensemble's members, a model refitted on new data) run **one** compiled
  program (:class:`SharedJit`): XLA would embed a closure's arrays in the program, and each
  training would compile its own;
- after each epoch the trainer's ``validate`` (a function compiled once, on the whole validation
  record) scores the parameters; after ``max_fail`` epochs without a new best objective the
  training stops and the best parameters are returned;
- the history has the same keys for every trainer.

The engine compiles the epoch at most once per training (the shapes of the draws do not
change); it never changes JAX's configuration (the trainers choose their precision by the
dtype of the parameters).
"""

from __future__ import annotations

import hashlib
import math
import threading
import time
from collections import OrderedDict
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np
import optax

__all__ = ["AdamProblem", "EngineResult", "SharedJit", "adam_epochs", "epoch_program"]

#: a loss: ``loss(params, data, *draws_of_one_step) -> (objective, mse)``, both scalars; the
#: gradient is taken of the objective, the mse (the plain squared error of the step's batch)
#: is reported
Loss = Callable[..., tuple[Any, Any]]

#: Compiled programs at most kept for sharing (an ensemble's epochs and validations, a test
#: suite's trainings of one shape)
_SHARED_MAX = 32
_shared: OrderedDict[str, jax.stages.Compiled] = OrderedDict()
_shared_lock = threading.Lock()


def _compile_shared(lowered: jax.stages.Lowered) -> jax.stages.Compiled:
    """The compiled program of ``lowered``: the one compiled before from the same module text,
    if any, else a new compilation (kept for the next). The text holds every operation,
    shape, dtype and constant of the program, so two lowerings with the same text compile to
    the same program."""
    key = hashlib.sha256(lowered.as_text().encode()).hexdigest()
    with _shared_lock:
        hit = _shared.get(key)
        if hit is not None:
            _shared.move_to_end(key)
            return hit
    compiled = lowered.compile()  # outside the lock: another key's compilation goes on
    with _shared_lock:
        _shared[key] = compiled
        while len(_shared) > _SHARED_MAX:
            _shared.popitem(last=False)
    return compiled


class SharedJit:
    """``jax.jit(fun)`` whose compilations are shared with every other :class:`SharedJit` that
    lowers to the same program.

    ``jax.jit`` caches a compilation per function object: a trainer that builds its loss as a
    closure for each training compiles its epoch again each time, even for a program identical
    to the last one (the arrays that differ passed as arguments). This traces and lowers
    ``fun`` once per signature of its arguments (their pytree, shapes and dtypes), then looks
    the program up by its module text.

    Lowering still costs a fraction of a compilation (about a fifth for a training epoch); an
    argument's value never enters the key, only its type, so a closure's array (embedded in
    the program as a constant) makes the program its own. The process keeps the 32 programs
    used last (``jax.clear_caches`` does not drop them).
    """

    def __init__(self, fun: Callable[..., object]) -> None:
        self._jit = jax.jit(fun)
        self._compiled: dict[tuple[object, ...], jax.stages.Compiled] = {}

    def __call__(self, *args: object) -> Any:
        """``fun(*args)`` by the compiled program of the arguments' signature."""
        leaves, tree = jax.tree_util.tree_flatten(args)
        sig = (tree, tuple(jax.typeof(x) for x in leaves),
               jax.config.read("jax_enable_x64"))
        compiled = self._compiled.get(sig)
        if compiled is None:
            compiled = self._compiled[sig] = _compile_shared(self._jit.lower(*args))
        return compiled(*args)


@dataclass(frozen=True)
class AdamProblem:
    """A training problem for :func:`adam_epochs`: what differs from one trainer to another.

    Attributes
    ----------
    loss : callable
        ``loss(params, *draws) -> (objective, mse)`` for one step's draws (jax-traceable).
    params0 : pytree
        Initial parameters; their dtype is the training precision.
    optimizer : optax.GradientTransformation
        E.g. ``optax.adam(lr)``; its schedule counts steps across epochs.
    draw : callable
        ``draw(rng) -> tuple of arrays``, each with the epoch's steps as leading axis: the
        random draws of one epoch from the seeded generator.
    validate : callable or None
        ``validate(params) -> (val_mse, objective)`` (scaled units; ``inf`` for an unstable
        model). None: the objective is the epoch's mean training mse (``inf`` at epoch 0).
    train_mse : callable, optional
        ``train_mse(params) -> float``: the reported training MSE (scaled units) instead of
        the mean mse of the epoch's steps (which has no value at epoch 0).
    data : pytree
        The arrays ``loss`` reads (its second argument), in the steps' precision: arguments
        of the compiled epoch, so trainings on other arrays of the same shapes share it. A
        loss must not close over arrays (each would make the program its own).
    """

    loss: Loss
    params0: Any
    optimizer: optax.GradientTransformation
    draw: Callable[[np.random.Generator], tuple[np.ndarray, ...]]
    validate: Callable[[Any], tuple[float, float]] | None = None
    train_mse: Callable[[Any], float] | None = None
    data: object = ()


@dataclass
class EngineResult:
    """What :func:`adam_epochs` returns.

    Attributes
    ----------
    params : pytree
        The best parameters (lowest objective), as the trainer's arrays.
    stop_reason : str
        ``"max_epochs"``, ``"validation_stop"``, ``"validation_plateau"``, ``"diverged"`` or
        ``"callback"``.
    history : dict of list
        Per epoch (epoch 0 = the initial parameters): ``train_mse``, ``val_mse`` (times
        ``mse_scale``), ``val_objective``, any ``constant_history`` key, ``seconds`` (since
        the start), and the epoch's ``step_seconds`` (its Adam steps, compilation included at
        epoch 1) and ``validation_seconds`` (the reported training MSE and the validation):
        where a training spends its time.
    best_epoch : int
    """

    params: Any
    stop_reason: str
    history: dict[str, list] = field(default_factory=dict)
    best_epoch: int = 0


def epoch_program(loss: Loss, optimizer: optax.GradientTransformation) -> SharedJit:
    """The compiled epoch: ``epoch(params, opt_state, draws, data) -> (params, opt_state,
    mean mse)``.

    ``draws`` is a tuple of arrays whose leading axis is the step: ``lax.scan`` runs one Adam
    step per row (``optimizer`` applied to the gradient of ``loss``'s objective); ``data`` is
    the loss's arrays (:attr:`AdamProblem.data`).
    """

    def epoch(params: Any, state: Any, draws: tuple[Any, ...], data: object
              ) -> tuple[Any, Any, Any]:
        def body(carry: Any, xs: Any) -> tuple[Any, Any]:
            p, s = carry
            (_, mse), g = jax.value_and_grad(loss, has_aux=True)(p, data, *xs)
            upd, s = optimizer.update(g, s, p)
            return (optax.apply_updates(p, upd), s), mse

        (params, state), mses = jax.lax.scan(body, (params, state), draws)
        return params, state, jnp.mean(mses)

    return SharedJit(epoch)


def adam_epochs(
    problem: AdamProblem,
    *,
    max_epochs: int,
    max_fail: int = 6,
    min_epochs: int = 0,
    rollback: float | None = None,
    seed: int = 0,
    mse_scale: float = 1.0,
    patience_without_validation: bool = False,
    constant_history: dict[str, float] | None = None,
    callback: Callable[[int, dict], Any] | None = None,
    plateau: tuple[int, float] | None = None,
) -> EngineResult:
    """Train by epochs of compiled Adam steps with early stopping (module docstring).

    Parameters
    ----------
    problem : AdamProblem
        Loss, initial parameters, optimiser, draws, validation.
    max_epochs : int
        Epochs at most (epoch 0 scores the initial parameters).
    max_fail : int
        Epochs without a new best objective before stopping (with ``problem.validate``, or
        always with ``patience_without_validation``).
    min_epochs : int
        No early stop before this epoch (the best parameters are still the best epoch's).
    rollback : float, optional
        An epoch whose validation objective exceeds ``rollback`` times the best one (a
        blow-up of the training) continues from the best epoch's parameters (the optimiser's
        moments and schedule go on). None: never.
    seed : int
        Seed of the generator passed to ``problem.draw``.
    mse_scale : float
        Factor from scaled to physical MSE in the history (the output half-range squared).
    patience_without_validation : bool
        Stop on ``max_fail`` even when ``problem.validate`` is None.
    constant_history : dict, optional
        Keys recorded with the same value at every epoch (e.g. ``mu``: NaN, for a history
        that must have the keys of the Levenberg-Marquardt trainer).
    callback : callable, optional
        ``callback(epoch, info)`` after every epoch; True stops the training.
    plateau : (int, float), optional
        ``(epochs, gain)``: stop (from ``min_epochs`` on) when the best objective has fallen by
        less than the fraction ``gain`` over the last ``epochs`` epochs (a validation
        plateau: the epochs left would buy less than it). None: only ``max_fail`` stops.

    Returns
    -------
    EngineResult
    """
    validate, train_mse = problem.validate, problem.train_mse
    epoch_run = epoch_program(problem.loss, problem.optimizer)
    rng = np.random.default_rng(seed)
    params = problem.params0
    state = problem.optimizer.init(params)
    keys = ("train_mse", "val_mse", "val_objective", *(constant_history or {}), "seconds",
            "step_seconds", "validation_seconds")
    hist: dict[str, list] = {k: [] for k in keys}
    best, best_obj, best_epoch, fail, reason = params, math.inf, 0, 0, "max_epochs"
    patient = validate is not None or patience_without_validation
    bests: list[float] = []  # the best objective after each epoch
    t0 = time.perf_counter()
    for epoch in range(int(max_epochs) + 1):
        step_mse = math.nan
        t_steps = time.perf_counter()
        if epoch > 0:
            # device_put: half jnp.asarray's time for an NFIR's 6.5 MB of indices (1 ms)
            draws = tuple(jax.device_put(a) for a in problem.draw(rng))
            params, state, m = epoch_run(params, state, draws, problem.data)
            step_mse = float(m)  # waits for the epoch: the time below is the epoch's
            if not math.isfinite(step_mse):
                reason = "diverged"
                break
        t_val = time.perf_counter()
        tr = float(train_mse(params)) if train_mse is not None else step_mse
        if validate is not None:
            vmse, obj = validate(params)
        else:
            vmse, obj = tr, (tr if epoch > 0 or train_mse is not None else math.inf)
        if obj < best_obj:
            best, best_obj, best_epoch, fail = params, obj, epoch, 0
        elif epoch > 0:
            fail += 1
            if rollback is not None and not obj <= rollback * best_obj:
                params = best
        t_end = time.perf_counter()
        info = {"train_mse": tr * mse_scale, "val_mse": vmse * mse_scale,
                "val_objective": obj, **(constant_history or {}), "seconds": t_end - t0,
                "step_seconds": t_val - t_steps, "validation_seconds": t_end - t_val}
        for k, v in info.items():
            hist[k].append(float(v))
        if callback is not None and callback(epoch, info):
            reason = "callback"
            break
        if patient and fail >= max_fail and epoch >= min_epochs:
            reason = "validation_stop"
            break
        bests.append(best_obj)
        if (plateau is not None and patient and epoch >= max(min_epochs, plateau[0])
                and math.isfinite(bests[-1 - plateau[0]])
                and bests[-1] > (1.0 - plateau[1]) * bests[-1 - plateau[0]]):
            reason = "validation_plateau"
            break
    return EngineResult(best, reason, hist, best_epoch)
