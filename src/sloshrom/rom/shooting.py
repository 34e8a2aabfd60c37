"""Multiple shooting for the recurrent ROM classes: one problem builder for the training engine.

A recurrent model (the NOE's closed loop, the state-space ROM) is trained on sub-sequences of
``horizon`` samples, each started from the measured past (the NOE's delay lines filled with the
record, the NSS's state encoded from a window of it) and simulated freely: the loss is the
simulation error of the sub-sequences, weighted by the amplitude weighting, plus the passive
recipe's cycle-energy term (the error of the energy each sub-sequence exchanges with the
liquid, per input cycle in it) and its passivity penalty (harmonic probes run from rest in the
same batch, no energy created). Early stopping scores the free run from rest of the whole
validation record the same way, or, for a validation record that does not start at rest, its
run started from its first samples as measured history (``validation_history``), scored after
them.

What differs between classes is how a sub-sequence starts, how the model runs, and its free
run: a class hands these to :func:`shooting_problem` as a :class:`Recurrence`, as an ODE
solver takes a vector field. The loss, its schedule, its random draws and its validation are
written once, here.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np
import optax

from sloshrom.rom.engine import AdamProblem, SharedJit
from sloshrom.rom.errors import ROMError
from sloshrom.rom.losses import (
    TRAIN_DTYPE,
    amplitude_weights,
    cycles_per_window,
    shooting_probes,
    window_energy_weights,
    windows,
)
from sloshrom.rom.network import MinMaxScaler

__all__ = ["PyTree", "Recurrence", "ShootingOptions", "adam_optimizer", "shooting_problem",
           "ss_encode"]

#: A JAX pytree (a model's parameters, a batch of its states): a dict of arrays, a tuple of
#: arrays or an array.
PyTree = Any


@dataclass(frozen=True)
class Recurrence:
    """What the multiple-shooting problem needs of a recurrent class (scaled units, float32
    training precision).

    Parameters
    ----------
    offset : int
        Samples between a start and the first simulated sample (the encoder's window; 0 when
        the record is padded in front with rest).
    n_starts : int
        The starts drawn are ``0 .. n_starts - 1``.
    start : callable
        ``start(params, data, starts, shift) -> state``: the states of the sub-sequences
        beginning at ``starts`` (shape ``(B,)``), from the measured past whose scaled input is
        shifted by ``shift`` (shape ``(B,)``: :attr:`ShootingOptions.velocity_offset`);
        ``data`` is :attr:`data`.
    rest : callable
        ``rest(k) -> state``: ``k`` states at rest (the passivity probes').
    simulate : callable
        ``simulate(params, data, state, u) -> y``: the scaled outputs ``(B, T)`` of a batch of
        states driven by scaled inputs ``u`` ``(B, T)``.
    free_run : callable
        ``free_run(params, u) -> y``: the scaled free run from rest (float64, NumPy) of a
        scaled input record ``u`` ``(n,)``.
    bound : float
        A validation free run beyond this scaled magnitude (or not finite) is unstable.
    history_run : callable, optional
        ``history_run(params, u_past, y_past, u) -> y``: the scaled run (float64, NumPy) of
        ``u`` started from the measured history ``u_past``/``y_past`` (scaled, oldest first):
        a validation record that does not start at rest.
    features : callable, optional
        ``features(v) -> phi``: inputs beside the input that the class computes from it by a
        fixed causal map (a grey box's physics): from physical input records ``v`` ``(B, n)``
        the scaled features ``(B, n, m)``. With it, ``simulate`` receives ``(B, T, 1 + m)``:
        the scaled input (shifted by the augmentation) and the features of each sample,
        computed once for the training record and the probes (the augmentation's shift does
        not reach them: they must not depend on the input's uniform offset).
    data : pytree
        The arrays ``start`` and ``simulate`` read (e.g. the scaled record a start is encoded
        from), in the steps' precision: the compiled epoch's arguments
        (:attr:`~sloshrom.rom.engine.AdamProblem.data`). ``start`` and ``simulate`` must not
        close over arrays.
    """

    offset: int
    n_starts: int
    start: Callable[[PyTree, PyTree, jax.Array, jax.Array], PyTree]
    rest: Callable[[int], PyTree]
    simulate: Callable[[PyTree, PyTree, PyTree, jax.Array], jax.Array]
    free_run: Callable[[PyTree, np.ndarray], np.ndarray]
    bound: float = 10.0
    history_run: Callable[[PyTree, np.ndarray, np.ndarray, np.ndarray], np.ndarray] | None = None
    features: Callable[[np.ndarray], np.ndarray] | None = None
    data: PyTree = ()


@dataclass(frozen=True, kw_only=True)
class ShootingOptions:
    """The multiple-shooting recipe of a recurrent class (its estimator's hyperparameters).

    Parameters
    ----------
    horizon : int
        Samples simulated from each start (and the length of the passivity probes).
    batch : int
        Sub-sequences per Adam step.
    max_epochs, steps_per_epoch : int
        Epochs of ``steps_per_epoch`` Adam steps; the learning rate decays from
        ``learning_rate`` to 5 % of it (cosine) over ``max_epochs * steps_per_epoch`` steps.
    learning_rate : float
        Initial Adam step.
    amplitude_weighting, passivity, cycle_energy : float
        The passive recipe's loss weights (0 = off): eps (m/s) of the weights
        ``1 / (a^2 + eps^2)``, the weight of the passivity penalty, of the cycle-energy term.
    frequency_band : (float, float)
        Band of the passivity probes, Hz.
    probes_per_step : int
        Passivity probes per Adam step.
    weight_decay : float
        Decoupled weight decay of AdamW (Loshchilov and Hutter), per unit learning rate: each
        step also moves every parameter by ``-learning_rate * weight_decay * p``; 0 = plain
        Adam (the optimiser of every model before it).
    velocity_offset : float
        Galilean augmentation, m/s (0 = off): each sub-sequence's input (its past and future)
        is shifted by a uniform draw in ``[-velocity_offset, velocity_offset]`` and its output
        kept. The sloshing force does not depend on the tank's uniform velocity (the rig's
        force is invariant to it exactly), but a model of the velocity learns that only from
        data: a beam under random base excitation drifts by a large fraction of its
        oscillation's velocity, a motion no shaker record holds.
    """

    # the recipe's values: each class's own, from its registry entry (no default here)
    horizon: int
    batch: int
    max_epochs: int
    steps_per_epoch: int
    learning_rate: float
    amplitude_weighting: float = 0.0
    passivity: float = 0.0
    cycle_energy: float = 0.0
    frequency_band: tuple[float, float] = (0.0, math.inf)
    probes_per_step: int = 24
    velocity_offset: float
    weight_decay: float


def adam_optimizer(options: ShootingOptions) -> optax.GradientTransformation:
    """The recipe's optimiser: the global gradient norm clipped to 1, then Adam, or AdamW
    with ``options.weight_decay`` > 0, on a cosine schedule from ``learning_rate`` to 5 % of
    it over ``max_epochs * steps_per_epoch`` steps."""
    total = max(1, int(options.max_epochs) * int(options.steps_per_epoch))
    sched = optax.cosine_decay_schedule(float(options.learning_rate), total, 0.05)
    # plain Adam without decay: the same arithmetic as before the option existed
    step = (optax.adamw(sched, weight_decay=float(options.weight_decay))
            if options.weight_decay > 0 else optax.adam(sched))
    return optax.chain(optax.clip_by_global_norm(1.0), step)


def shooting_problem(
    rec: Recurrence,
    params0: PyTree,
    u: np.ndarray,
    y: np.ndarray,
    fs: float,
    scaler: MinMaxScaler,
    validation: tuple[np.ndarray, np.ndarray] | None,
    options: ShootingOptions,
    validation_history: int = 0,
    dtype: type = TRAIN_DTYPE,
) -> AdamProblem:
    """The multiple-shooting problem of a recurrent class for the training engine
    (:func:`sloshrom.rom.engine.adam_epochs`).

    Parameters
    ----------
    rec : Recurrence
        The class's starts, rest states, simulation and free run.
    params0 : pytree
        Initial parameters (float32).
    u, y : ndarray, shape (n,)
        Training input (m/s) and output (N), physical units.
    fs : float
        Sample rate, Hz.
    scaler : MinMaxScaler
        The training record's scaling.
    validation : (uv, yv), optional
        Validation record: its free run from rest, scored like the training loss, decides the
        early stopping.
    options : ShootingOptions
        The recipe: horizon, batch, schedule, loss weights, probes.
    validation_history : int
        The validation record's first samples that are measured history: its run starts from
        them (``rec.history_run``) and is scored on the rest; 0: from rest, all scored.
    dtype : type
        The precision of the Adam steps (:data:`~sloshrom.rom.losses.TRAIN_DTYPE`, float32, by
        default; ``params0`` and the states of ``rec`` in it).

    Returns
    -------
    AdamProblem
        Call it inside ``jax.enable_x64(True)``: the validation runs in float64, the Adam
        steps in :data:`~sloshrom.rom.losses.TRAIN_DTYPE`.
    """
    o = options
    amplitude_weighting, passivity, cycle_energy = (o.amplitude_weighting, o.passivity,
                                                    o.cycle_energy)
    steps_per_epoch, batch = int(o.steps_per_epoch), int(o.batch)
    u = np.asarray(u, dtype=np.float64)
    y = np.asarray(y, dtype=np.float64)
    n, T, off = u.size, int(o.horizon), int(rec.offset)
    sc = scaler
    f32 = dtype
    u_s, y_s = jnp.asarray(sc.u(u), f32), jnp.asarray(sc.y(y), f32)
    wts = jnp.asarray(amplitude_weights(u, fs, amplitude_weighting) if amplitude_weighting > 0
                      else np.ones(n), f32)
    a_max = float(np.max(np.abs(np.gradient(u)))) * fs
    v_floor = float(np.max(np.abs(u))) / 100.0
    vj = jnp.asarray(u, f32)
    # the input cycles in each sub-sequence: its energy error per cycle is the NFIR's cycle term
    ncyc = jnp.asarray(cycles_per_window(u, off, T), f32)
    probes = shooting_probes(u, fs, sc, T, o.frequency_band) if passivity > 0 else None
    n_probe = 0 if probes is None else min(o.probes_per_step, probes.u.shape[0])
    pu = jnp.asarray(probes.u if probes is not None else np.zeros((1, T)), f32)
    pw = jnp.asarray(probes.weight if probes is not None else np.zeros((1, T)), f32)

    # a physical velocity offset in scaled units (the scaling is affine)
    unit = float(sc.u(1.0) - sc.u(0.0))
    shift_scale = unit * float(o.velocity_offset)
    feats = None
    if rec.features is not None:
        # the features beside the input, once: the record's, and the probes' (from rest)
        feats = jnp.asarray(rec.features(u[None])[0], f32)
        pv = (np.asarray(pu, dtype=np.float64) - float(sc.u(0.0))) / unit
        pu = jnp.concatenate([pu[..., None], jnp.asarray(rec.features(pv), f32)], axis=-1)

    # the loss's arrays: the compiled epoch's arguments (members of an ensemble share it)
    data = {"rec": rec.data, "u_s": u_s, "y_s": y_s, "wts": wts, "v": vj, "ncyc": ncyc,
            "pu": pu, "pw": pw, "feats": feats}

    def loss(p: PyTree, d: PyTree, starts: jax.Array, pidx: jax.Array,
             shift: jax.Array) -> tuple[jax.Array, jax.Array]:
        state = rec.start(p, d["rec"], starts, shift)
        fut = starts + off
        uf = windows(d["u_s"], fut, T) + shift[:, None]
        if d["feats"] is not None:
            uf = jnp.concatenate([uf[..., None], windows(d["feats"], fut, T)], axis=-1)
        if n_probe:
            # the probes run from rest in the same batch
            state = jax.tree_util.tree_map(lambda a, b: jnp.concatenate([a, b]), state,
                                           rec.rest(n_probe))
            uf = jnp.concatenate([uf, d["pu"][pidx]])
        yh = rec.simulate(p, d["rec"], state, uf)
        e = yh[: starts.size] - windows(d["y_s"], fut, T)
        mse = jnp.mean(e**2)
        value = jnp.mean(windows(d["wts"], fut, T) * e**2)
        if cycle_energy > 0:
            vw = windows(d["v"], fut, T)
            peak = jnp.maximum(jnp.max(jnp.abs(vw), axis=1), v_floor)
            de = jnp.sum(e * vw, axis=1) * a_max / (fs * peak**2) / d["ncyc"][starts]
            value += cycle_energy * jnp.mean(de**2)
        if n_probe:
            phi = jnp.sum(yh[starts.size:] * d["pw"][pidx], axis=1)
            value += passivity * jnp.mean(jnp.minimum(phi, 0.0) ** 2)
        return value, mse

    opt = adam_optimizer(o)

    def draw(rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        starts = rng.integers(0, rec.n_starts, (steps_per_epoch, batch))
        pidx = rng.integers(0, max(1, pu.shape[0]), (steps_per_epoch, n_probe))
        # drawn after the others: without augmentation the same draws as before
        shift = (rng.uniform(-shift_scale, shift_scale, (steps_per_epoch, batch))
                 if shift_scale > 0 else np.zeros((steps_per_epoch, batch)))
        return starts, pidx, shift.astype(np.dtype(f32))

    # validation: the free run of the whole record from rest (or of the rest of it from its
    # measured history), scored like the training loss
    val = None
    if validation is not None:
        hv = int(validation_history)
        uv = np.asarray(validation[0], dtype=np.float64)
        yv = np.asarray(validation[1], dtype=np.float64)
        uvs = np.asarray(sc.u(uv))
        yvs = np.asarray(sc.y(yv))
        if hv:
            hist_run = rec.history_run
            if hist_run is None:
                raise ROMError("this class has no start from measured history")
            past = (uvs[:hv], yvs[:hv])
            uv, yv, uvs, yvs = uv[hv:], yv[hv:], uvs[hv:], yvs[hv:]

            def run(p: PyTree) -> np.ndarray:
                return hist_run(p, past[0], past[1], uvs)
        else:
            def run(p: PyTree) -> np.ndarray:
                return rec.free_run(p, uvs)
        wv = (amplitude_weights(uv, fs, amplitude_weighting) if amplitude_weighting > 0
              else np.ones(uv.size))
        nwin = uv.size // T
        vstarts = np.arange(nwin) * T
        ew = window_energy_weights(uv, fs, a_max, vstarts, T, v_floor) if nwin else None
        if nwin:
            ew /= cycles_per_window(uv, 0, T)[vstarts][:, None]

        def every_probe(p: PyTree, d: PyTree) -> jax.Array:
            yh = rec.simulate(p, d["rec"], rec.rest(d["pu"].shape[0]), d["pu"])
            phi = jnp.sum(yh * d["pw"], axis=1)
            return jnp.mean(jnp.minimum(phi, 0.0) ** 2)

        penalty_all = SharedJit(every_probe)

        def val(p: PyTree) -> tuple[float, float]:
            yh = run(p)
            if not np.all(np.isfinite(yh)) or np.max(np.abs(yh)) > rec.bound:
                return math.inf, math.inf
            e = yh - yvs
            mse = float(np.mean(e**2))
            obj = float(np.mean(wv * e**2))
            if cycle_energy > 0 and nwin:
                de = np.sum(e[: nwin * T].reshape(nwin, T) * ew, axis=1)
                obj += cycle_energy * float(np.mean(de**2))
            if passivity > 0 and math.isfinite(obj):
                obj += passivity * float(penalty_all(p, data))
            return mse, obj

    return AdamProblem(loss, params0, opt, draw, val, data=data)


def ss_encode(p: dict[str, Any], u_past: Any, y_past: Any, r_u: Any, r_y: Any) -> Any:
    """State (..., nx) from the scaled past ``window`` inputs and outputs (..., window), oldest
    first; a window at rest gives the rest state 0. The encoder of every state-space network
    trained from encoded starts (its arrays ``E1``, ``e1``, ``E2``)."""
    q = jnp.concatenate([u_past - r_u, y_past - r_y], axis=-1)
    e0 = jnp.tanh(p["e1"]) @ p["E2"]
    return jnp.tanh(q @ p["E1"] + p["e1"]) @ p["E2"] - e0
