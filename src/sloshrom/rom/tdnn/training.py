"""Training of the NFIR/NOE networks: MATLAB ``trainlm`` Levenberg-Marquardt (paper section 3).

Algorithm (as ``trainlm``): at each epoch the Jacobian ``J = d y^/d theta`` and the error
``e = y^ - y`` (scaled units) give ``J^T J`` and ``J^T e``; the step
``d theta = -(J^T J + mu I)^{-1} J^T e`` (Cholesky) is tried with mu = 1e-3 initially; if the
training error falls the step is taken and ``mu *= 0.1``, otherwise ``mu *= 10`` and the step
is retried within the epoch until success or mu > mu_max = 1e10. Training stops at
``max_epochs``, when the gradient norm ``||d MSE/d theta|| = 2 ||J^T e|| / N`` < 1e-7, when
mu > mu_max, or when the validation error has been above its best for ``max_fail = 6``
consecutive epochs; the best-validation parameters are returned.

``J^T J`` and ``J^T e`` are accumulated over chunks of samples (memory bounded, float64); each
chunk's Jacobian comes from ``jax.vmap(jax.grad)`` (NFIR, per-sample reverse mode; NOE: the
output error, the network's partial derivatives at every simulated sample, then their
recurrence through the fed-back outputs, carried from chunk to chunk), inside ``jax.jit``. The
accumulation itself is a NumPy ``J.T @ J`` (BLAS ``syrk``), measured 2x faster than XLA's float64
matmul on this machine.

Trainers: ``"lm"`` is ``trainlm`` on every sample. ``"fast"`` is the same
algorithm with the normal equations (and the step acceptance) on a fixed, uniformly decimated
subset of the training samples (at most ``FAST_MAX_ROWS`` rows; neighbouring samples at 500 Hz
are nearly collinear regressors, so a subset carries almost the same information for ~10x less
work); the validation error (early stopping, best network) is always on the whole validation
record. The NOE's LM always trains on the whole record (``"fast"`` = ``"lm"``). ``"adam"``
(the NFIR default) is, for the NFIR, minibatch Adam (``optax.adam``: lr 1e-3, b1 0.9,
b2 0.999, eps 1e-8; 4096 samples per step, 200 steps per "epoch") with the same validation
early stopping: on the virtual-rig data it reached a lower validation error than LM in far less
time (see docs/rom.md), but it is not the paper's algorithm. Adam also takes two physics terms
(off by default): per-sample weights ``1/(a^2 + eps^2)`` of the local input amplitude a
(:func:`amplitude_weights`) and a passivity penalty on the dissipated energy of harmonic probes
inside the training envelope (:func:`harmonic_probes`, :func:`passivity_penalty`), and a
cycle-energy term: the error of the energy each cycle of the record exchanges with the liquid
(:func:`energy_cycles`, :func:`cycle_energy_error`).

``"adam"`` for an NOE (:func:`adam_noe`) is multiple shooting: minibatch Adam (float32) on the
simulation error of short sub-sequences drawn from the record, each started from the NOE's delay
lines filled with the measured past inputs and outputs (its exact state there), with the same
three loss terms in the form of the neural state-space ROM's trainer
(:func:`sloshrom.rom.nss.training.fit_statespace`) and early stopping on the free run of the
validation record from rest.

Initialisation (seeded): RBF centres are training regressors drawn at random; ``"matlab"``
weights are random unit directions scaled by the spread of the data along them (Nguyen-Widrow
like), with biases putting ``n_j = 0`` at the centre; ``"distance"`` widths from the median
centre spacing; the linear output layer is then solved by least squares.

The network itself (:mod:`sloshrom.rom.tdnn.network`) and its architecture
(:class:`NetworkSpec`) are explicit arguments: this module knows nothing of the estimator
classes (their rules come from the registry entries). :func:`train` runs in float64
(``jax.enable_x64`` around the call) without changing the process's JAX configuration.
"""

from __future__ import annotations

import dataclasses
import math
import time
import warnings
from collections.abc import Callable, Sequence
from functools import partial
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np
import optax

from sloshrom._x64 import float64
from sloshrom.limits import TRAINERS
from sloshrom.rom.engine import AdamProblem, adam_epochs
from sloshrom.rom.errors import (
    HistoryError,
    ROMError,
    TrainingWarning,
    UnstableModelError,
    members_quiet,
)
from sloshrom.rom.lm import LMProblem, LMResult, levenberg_marquardt, stop_message
from sloshrom.rom.losses import (
    MAX_CYCLE,
    TRAIN_DTYPE,
    EnergyCycles,
    HarmonicProbes,
    ShootingProbes,
    amplitude_weights,
    cycle_slots,
    cycles_per_window,
    energy_cycles,
    harmonic_probes,
    pack_cycles,
    shooting_probes,
    window_energy_weights,
)
from sloshrom.rom.network import MinMaxScaler
from sloshrom.rom.registry import model_class
from sloshrom.rom.shooting import PyTree, Recurrence, ShootingOptions
from sloshrom.rom.shooting import shooting_problem as shooting
from sloshrom.rom.tdnn.entry import NOE_CLASS, shooting_samples
from sloshrom.rom.tdnn.network import (
    NetworkSpec,
    hidden_activations,
    n_params,
    nfir_free_run,
    nfir_rows,
    noe_free_run,
    noe_history_run,
    noe_rest_state,
    noe_simulate,
    rbf_apply,
    rbf_rows,
    regressors,
    unpack,
)

__all__ = [
    "FAST_MAX_ROWS",
    "MAX_CYCLE",
    "TRAINERS",
    "HarmonicProbes",
    "LMProblem",
    "LMResult",
    "adam_nfir",
    "adam_noe",
    "nfir_adam_problem",
    "noe_shooting_problem",
    "ShootingProbes",
    "TRAIN_DTYPE",
    "cycles_per_window",
    "shooting_probes",
    "window_energy_weights",
    "EnergyCycles",
    "amplitude_weights",
    "cycle_energy_error",
    "energy_cycles",
    "harmonic_probes",
    "init_theta",
    "levenberg_marquardt",
    "mu_max_message",
    "nfir_problem",
    "nfir_validation",
    "noe_shoot",
    "noe_problem",
    "noe_validation_run",
    "passivity_penalty",
    "probe_dissipation",
    "run_cycle_error",
    "train",
]

FAST_MAX_ROWS = 16384
#: The NOE's hyperparameters by default (its registry entry's)
_NOE = NOE_CLASS.defaults()
#: The NOE's multiple-shooting recipe by default (its estimator passes its own): its entry's,
#: 40 epochs, and neither a Galilean augmentation nor a weight decay (options of the NSS)
NOE_SHOOTING = ShootingOptions(**{k: _NOE[k] for k in ("horizon", "batch", "steps_per_epoch",
                                                       "learning_rate")},
                               max_epochs=40, velocity_offset=0.0, weight_decay=0.0)
CHUNK = 4096


#: The NFIR's Adam steps' precisions (``precision``) and their dtypes.
_STEP_DTYPES = {"float64": np.float64, "float32": np.float32}


def init_theta(
    X: np.ndarray, y_s: np.ndarray, neurons: int, hidden: str, seed: int, kappa: float = 1.0
) -> np.ndarray:
    """Seeded initial parameters from scaled regressors ``X`` (N, D) and outputs ``y_s`` (N,)."""
    rng = np.random.default_rng(seed)
    n, d = X.shape
    h = int(neurons)
    centres = X[rng.choice(n, size=h, replace=n < h)]
    if hidden == "matlab":
        v = rng.standard_normal((h, d))
        v /= np.linalg.norm(v, axis=1, keepdims=True)
        spread = np.std(X @ v.T, axis=0) + 1e-12
        W = kappa * v / spread[:, None]
        b = -np.sum(W * centres, axis=1)
    else:
        W = centres
        dist = np.sqrt(((centres[:, None, :] - centres[None, :, :]) ** 2).sum(-1))
        m = np.median(dist[np.triu_indices(h, 1)]) if h > 1 else 1.0
        b = np.full(h, kappa / max(m, 1e-6))
    A = np.asarray(hidden_activations({"W": W, "b": b}, X, hidden))
    coef, *_ = np.linalg.lstsq(np.column_stack([A, np.ones(n)]), y_s, rcond=None)
    return np.concatenate([W.ravel(), b, coef[:h], coef[h:]])


# ---------------------------------------------------------------------------------------------
# NFIR
# ---------------------------------------------------------------------------------------------


@partial(jax.jit, static_argnames=("delays", "neurons", "hidden"))
def _nfir_jac_chunk(theta, up, ys, rows, w, delays, neurons, hidden):
    d = np.asarray(delays)
    X = regressors(up, rows, d)

    def f(th, x):
        return rbf_apply(unpack(th, len(d), neurons), x, hidden)

    J = jax.vmap(jax.grad(f), in_axes=(None, 0))(theta, X)
    e = jax.vmap(f, in_axes=(None, 0))(theta, X) - ys[rows]
    return J * w[:, None], e * w


@partial(jax.jit, static_argnames=("delays", "neurons", "hidden"))
def _nfir_sse(theta, up, ys, rows2d, w2d, delays, neurons, hidden):
    d = np.asarray(delays)

    def one(args):
        rows, w = args
        e = nfir_rows(theta, up, rows, d, neurons, hidden) - ys[rows]
        return jnp.sum((e * w) ** 2)

    return jnp.sum(jax.lax.map(one, (rows2d, w2d)))


def _padded_rows(rows: np.ndarray, chunk: int) -> tuple[np.ndarray, np.ndarray]:
    m = -(-rows.size // chunk) * chunk
    r = np.zeros(m, dtype=np.int64)
    w = np.zeros(m)
    r[: rows.size] = rows
    w[: rows.size] = 1.0
    return r.reshape(-1, chunk), w.reshape(-1, chunk)


def nfir_problem(
    u_s: np.ndarray,
    y_s: np.ndarray,
    delays: tuple[int, ...],
    neurons: int,
    hidden: str,
    rest_u: float,
    rows: np.ndarray | None = None,
    validation: tuple[np.ndarray, np.ndarray] | None = None,
    chunk: int = CHUNK,
    validation_history: int = 0,
) -> LMProblem:
    """NFIR least-squares problem in scaled units on the time indices ``rows`` (default all);
    the validation record's first ``validation_history`` samples are measured history (they
    fill the delay line, and are not scored)."""
    d = np.asarray(delays)
    dmax = int(d.max())
    up = jnp.asarray(np.concatenate([np.full(dmax, rest_u), u_s]))
    ys = jnp.asarray(y_s)
    rows = np.arange(u_s.size) if rows is None else np.asarray(rows)
    chunk = min(chunk, rows.size)
    r2, w2 = _padded_rows(rows, chunk)
    r2j, w2j = jnp.asarray(r2), jnp.asarray(w2)
    # the chunks as device arrays of their own, made once (as the NOE's below)
    r2c, w2c = [jnp.asarray(r) for r in r2], [jnp.asarray(w) for w in w2]
    p = n_params(d.size, neurons)

    def normal_eq(theta):
        th = jnp.asarray(theta)
        jtj = np.zeros((p, p))
        jte = np.zeros(p)
        sse = 0.0
        for r, w in zip(r2c, w2c, strict=True):
            J, e = _nfir_jac_chunk(th, up, ys, r, w, delays, neurons, hidden)
            J, e = np.asarray(J), np.asarray(e)
            jtj += J.T @ J  # NumPy detects A.T @ A -> BLAS syrk
            jte += J.T @ e
            sse += float(e @ e)
        return jtj, jte, sse, rows.size

    def sse(theta):
        v = float(_nfir_sse(jnp.asarray(theta), up, ys, r2j, w2j, delays, neurons, hidden))
        return v if np.isfinite(v) else math.inf

    val = None
    if validation is not None:
        uv, yv, lead = nfir_validation(validation, dmax, validation_history)

        def val(theta):
            yh = np.asarray(nfir_free_run(jnp.asarray(theta), uv, rest_u, delays, neurons,
                                          hidden))[lead:]
            m = float(np.mean((yh - yv) ** 2))
            return m if np.isfinite(m) else math.inf

    return LMProblem(normal_eq, sse, val)


def nfir_validation(validation: tuple[np.ndarray, np.ndarray], max_delay: int,
                    history: int = 0) -> tuple[jnp.ndarray, np.ndarray, int]:
    """An NFIR's validation run: ``(input, scored output, lead)``, the run's first ``lead``
    outputs not scored. With ``history`` samples of measured history (>= ``max_delay``), the
    input starts ``max_delay`` samples before the scored part, so that those measured samples
    fill the delay line in place of rest."""
    u, y = np.asarray(validation[0]), np.asarray(validation[1])
    if not history:
        return jnp.asarray(u), y, 0
    return jnp.asarray(u[history - max_delay:]), y[history:], max_delay


# ---------------------------------------------------------------------------------------------
# NOE (output error, derivatives through time)
# ---------------------------------------------------------------------------------------------


@partial(jax.jit, static_argnames=("delays", "out_delays", "neurons", "hidden"))
def _noe_jac_chunk(theta, state, lines, u_chunk, y_chunk, w, delays, out_delays, neurons,
                   hidden, y_sim=None):
    """Simulate one chunk, and the Jacobian of its outputs, from the state and the output
    sensitivities ``lines`` (out_delays, P: those of the last outputs, most recent first)
    carried in and out. ``y_sim``: the chunk's outputs from the state, already simulated (a
    trial step's free run); they are not simulated again.

    ``y_k = f(theta, x_k)`` with ``x_k`` the delay lines (inputs, then the fed-back outputs), so
    ``dy_k/dtheta = df/dtheta + sum_i df/dy_{k-1-i} dy_{k-1-i}/dtheta``: the partial
    derivatives at every sample at once (the regressors are known once the chunk is
    simulated), then a recurrence of P-vectors with out_delays scalar weights a sample. The
    derivatives are those of the forward-mode tangents through the loop (one per parameter),
    which cost the network's whole tangent at every sample: 4.7x the time.
    """
    d = np.asarray(delays)
    dmax, n_in = int(d.max()), d.size
    ubuf, ybuf = state
    if y_sim is None:
        st_end, y = noe_simulate(theta, u_chunk, state, delays, out_delays, neurons, hidden)
    else:
        y = y_sim
    # the regressor of each sample, as noe_step reads it from its delay lines
    u_ext = jnp.concatenate([jnp.flip(ubuf), u_chunk])
    y_ext = jnp.concatenate([jnp.flip(ybuf), y])
    if y_sim is not None:  # the delay lines as noe_step leaves them: most recent first
        st_end = (jnp.flip(u_ext[-dmax:]), jnp.flip(y_ext[-out_delays:]))
    k = jnp.arange(u_chunk.shape[0])
    X = jnp.concatenate([regressors(u_ext, k, delays),
                         regressors(y_ext, k, tuple(range(1, out_delays + 1)))], axis=1)

    def f(th, x):
        return rbf_apply(unpack(th, n_in + out_delays, neurons), x, hidden, single=True)

    G, S = jax.vmap(jax.grad(f, argnums=(0, 1)), in_axes=(None, 0))(theta, X)
    S = S[:, n_in:]

    def step(lines, gs):
        g, s = gs
        j = g + s @ lines
        return jnp.concatenate([j[None], lines[:-1]]), j

    # not unrolled: the same arithmetic, and an LM epoch's normal equations 0.78 -> 0.60 s
    # (NOE(2, 15), 487,501 samples; unrolled by 8 before)
    lines_end, J = jax.lax.scan(step, lines, (G, S))
    e = (y - y_chunk) * w
    return st_end, lines_end, J * w[:, None], e, y


def noe_problem(
    u_s: np.ndarray,
    y_s: np.ndarray,
    delays: tuple[int, ...],
    out_delays: int,
    neurons: int,
    hidden: str,
    rest_u: float,
    rest_y: float,
    bound: float,
    validation: tuple[np.ndarray, np.ndarray] | None = None,
    chunk: int = 8192,
    validation_history: int = 0,
) -> LMProblem:
    """NOE simulation-error least-squares problem (scaled units), closed loop from rest; the
    validation record's first ``validation_history`` samples are measured history (they fill
    the delay lines, and are not scored)."""
    d = np.asarray(delays)
    n = u_s.size
    chunk = min(chunk, n)
    m = -(-n // chunk) * chunk
    up = np.full(m, rest_u)
    up[:n] = u_s
    yp = np.zeros(m)
    yp[:n] = y_s
    w = np.zeros(m)
    w[:n] = 1.0
    # each chunk a device array of its own, made once: slicing a (chunks, chunk) array at
    # every epoch dispatched 3 x 60 slices (NOE(2, 15)'s normal equations 0.68 -> 0.61 s)
    up, yp, w = ([jnp.asarray(r) for r in a.reshape(-1, chunk)] for a in (up, yp, w))
    p = n_params(d.size + out_delays, neurons)
    uj, ysj = jnp.asarray(u_s), np.asarray(y_s)

    # the last free run: Levenberg-Marquardt asks for the normal equations at a trial step
    # it has just simulated (0.15 s of an epoch's 1.0 s, NOE(2, 15) on 487,501 samples)
    last: dict[str, np.ndarray] = {}

    def simulate(theta):
        y = np.asarray(noe_free_run(jnp.asarray(theta), uj, rest_u, rest_y, delays,
                                    out_delays, neurons, hidden))
        last.update(theta=np.array(theta, dtype=np.float64), y=y)
        return y

    def normal_eq(theta):
        th = jnp.asarray(theta)
        state = noe_rest_state(rest_u, rest_y, d, out_delays)
        lines = jnp.zeros((out_delays, p))  # the rest's outputs do not depend on theta
        jtj, jte, sse = np.zeros((p, p)), np.zeros(p), 0.0
        run = last.get("y") if np.array_equal(last.get("theta"), theta) else None
        for i in range(len(up)):
            # the free run's outputs (the chunks' own simulation gives the same bits); the
            # padded end of the last chunk is simulated
            y_sim = (None if run is None or (i + 1) * chunk > n
                     else jnp.asarray(run[i * chunk:(i + 1) * chunk]))
            state, lines, J, e, _ = _noe_jac_chunk(th, state, lines, up[i], yp[i], w[i],
                                                   delays, out_delays, neurons, hidden,
                                                   y_sim=y_sim)
            J, e = np.asarray(J), np.asarray(e)
            jtj += J.T @ J
            jte += J.T @ e
            sse += float(e @ e)
        return jtj, jte, sse, n

    def sse(theta):
        yh = simulate(theta)
        if not np.all(np.isfinite(yh)) or np.max(np.abs(yh)) > bound:
            return math.inf  # unstable trial step: rejected like a failed step
        return float(np.sum((yh - ysj) ** 2))

    val = None
    if validation is not None:
        run = noe_validation_run(validation, rest_u, rest_y, delays, out_delays, neurons,
                                 hidden, validation_history)
        yv = np.asarray(validation[1])[validation_history:]

        def val(theta):
            yh = run(theta)
            if not np.all(np.isfinite(yh)) or np.max(np.abs(yh)) > bound:
                return math.inf
            return float(np.mean((yh - yv) ** 2))

    return LMProblem(normal_eq, sse, val)


def noe_validation_run(validation: tuple[np.ndarray, np.ndarray], rest_u: float, rest_y: float,
                       delays: tuple[int, ...], out_delays: int, neurons: int, hidden: str,
                       history: int = 0) -> Callable[[np.ndarray], np.ndarray]:
    """``run(theta)``: an NOE's scaled outputs on a scaled validation record, from rest or,
    after its first ``history`` samples of measured history, from delay lines holding them
    (the scored part only)."""
    uv, yv = jnp.asarray(validation[0]), jnp.asarray(validation[1])
    if not history:
        return lambda theta: np.asarray(noe_free_run(jnp.asarray(theta, jnp.float64), uv,
                                                     rest_u, rest_y, delays, out_delays,
                                                     neurons, hidden))
    up, yp, uf = uv[:history], yv[:history], uv[history:]
    return lambda theta: np.asarray(noe_history_run(jnp.asarray(theta, jnp.float64), up, yp,
                                                    uf, delays, out_delays, neurons, hidden))


# ---------------------------------------------------------------------------------------------
# Physics in the loss (NFIR): passivity on harmonic probes, the energy of each cycle
# (their data: sloshrom.rom.losses)
# ---------------------------------------------------------------------------------------------


def _loss_rows(theta: jax.Array, up: jax.Array, rows: jax.Array, delays: Sequence[int],
               neurons: int, hidden: str) -> jax.Array:
    """:func:`sloshrom.rom.tdnn.network.nfir_rows` computed for reverse mode (:func:`rbf_rows`):
    the rows of an Adam step's loss terms."""
    return rbf_rows(unpack(theta, len(delays), neurons), regressors(up, rows, delays), hidden)


def probe_dissipation(theta: Any, probes: HarmonicProbes, idx: Any, delays: Any,
                      neurons: int, hidden: str) -> jnp.ndarray:
    """Normalised dissipated energy per cycle of the NFIR ``theta`` at the probes ``idx``.

    The output's offset drops out: a whole period of a sine sums to zero.
    """
    d = np.asarray(delays)
    dmax = int(d.max())
    rows = jnp.arange(probes.weight.shape[1]) + dmax
    X = probes.windows[idx][:, rows[:, None] - d[None, :]]
    y = rbf_rows(unpack(theta, len(d), neurons), X, hidden)
    return jnp.sum(y * probes.weight[idx], axis=-1)


def passivity_penalty(theta: Any, probes: HarmonicProbes, idx: Any, delays: Any,
                      neurons: int, hidden: str) -> jnp.ndarray:
    """Mean squared negative part of :func:`probe_dissipation`: zero for a passive network."""
    phi = probe_dissipation(theta, probes, idx, delays, neurons, hidden)
    return jnp.mean(jnp.minimum(phi, 0.0) ** 2)


def cycle_energy_error(theta: jax.Array, up: jax.Array, ys: jax.Array, rows: jax.Array,
                       weight: jax.Array, segment: jax.Array, k: int, delays: Sequence[int],
                       neurons: int, hidden: str) -> jax.Array:
    """Mean squared error of the normalised energy of ``k`` cycles (NFIR ``theta``), their
    samples packed one cycle after the other (``rows``, ``weight``, ``segment`` of a step of
    :func:`sloshrom.rom.losses.pack_cycles`: the network runs on the cycles' samples alone,
    not on each cycle padded to the longest).

    ``up``: scaled input padded in front with ``max(delays)`` rest samples; ``ys``: scaled
    output. Only the part of the error in phase with the velocity counts: the part that
    changes the damping the liquid adds.
    """
    e = _loss_rows(theta, up, rows, np.asarray(delays), neurons, hidden)
    per = jax.ops.segment_sum((e - ys[rows]) * weight, segment, num_segments=k + 1)
    return jnp.mean(per[:k] ** 2)


def run_cycle_error(e: np.ndarray, cycles: EnergyCycles, chunk: int = 256) -> float:
    """:func:`cycle_energy_error` of every cycle of a record, from an NFIR's run over it.

    An NFIR's output at a sample is its run's at that sample, so each cycle's energy error is
    read from the run's error instead of evaluating the network again on the cycles (padded to
    the longest: three times the samples of the run).

    Parameters
    ----------
    e : ndarray, shape (n,)
        The run's error (output - measured), scaled units, at the samples ``cycles`` index.
    cycles : EnergyCycles
        The record's cycles.
    chunk : int
        The mean is over chunks of ``chunk`` cycles, the last one wrapped around to the first
        cycles (their repeats weigh a little), as the term was first evaluated chunk by chunk.

    Returns
    -------
    float
        The mean squared normalised energy error; inf if it is not finite.
    """
    rows, weight = np.asarray(cycles.rows), np.asarray(cycles.weight)
    per = np.sum(np.asarray(e)[rows] * weight, axis=-1) ** 2
    idx = np.arange(-(-cycles.n // chunk) * chunk) % cycles.n
    value = float(np.mean(per[idx].reshape(-1, chunk).mean(axis=1)))
    return value if math.isfinite(value) else math.inf


# ---------------------------------------------------------------------------------------------
# First-order alternative (NFIR): minibatch Adam with the same stopping rules
# ---------------------------------------------------------------------------------------------



def nfir_adam_problem(
    u_s: np.ndarray,
    y_s: np.ndarray,
    theta0: np.ndarray,
    delays: tuple[int, ...],
    neurons: int,
    hidden: str,
    rest_u: float,
    problem: LMProblem,
    n_rows: int,
    steps_per_epoch: int = 200,
    lr: float = 1e-3,
    batch: int = 4096,
    b1: float = 0.9,
    b2: float = 0.999,
    eps: float = 1e-8,
    weights: np.ndarray | None = None,
    validation: tuple[np.ndarray, np.ndarray] | None = None,
    val_weights: np.ndarray | None = None,
    probes: HarmonicProbes | None = None,
    passivity: float = 0.0,
    probes_per_step: int = 24,
    cycles: EnergyCycles | None = None,
    cycle_energy: float = 0.0,
    cycles_per_step: int = 32,
    val_cycle_error: Callable[[np.ndarray], float] | None = None,
    val_lead: int = 0,
    precision: str = "float64",
) -> AdamProblem:
    """The minibatch-Adam problem of :func:`adam_nfir` for the training engine; the parameters
    are :func:`adam_nfir`'s."""
    d = np.asarray(delays)
    # the steps' data in the steps' precision (a float64 array would promote them back); the
    # validation runs in float64 whatever it is
    dt = _STEP_DTYPES[precision]
    theta0 = np.asarray(theta0, dt)
    up = jnp.asarray(np.concatenate([np.full(int(d.max()), rest_u), u_s]), dt)
    ysj = jnp.asarray(y_s, dt)
    n = u_s.size
    wj = jnp.ones(n, dt) if weights is None else jnp.asarray(weights, dt)
    probes64 = probes
    if probes is not None:
        probes = dataclasses.replace(probes, windows=jnp.asarray(probes.windows, dt),
                                     weight=jnp.asarray(probes.weight, dt))
    opt = optax.adam(lr, b1=b1, b2=b2, eps=eps)
    n_probes = 0 if probes is None or passivity <= 0 else probes.n
    n_draw = min(probes_per_step, n_probes)
    n_cycles = 0 if cycles is None or cycle_energy <= 0 else cycles.n
    c_draw = min(cycles_per_step, n_cycles)

    slots = cycle_slots(cycles, c_draw) if c_draw else 0

    def loss(th: jax.Array, data: PyTree, rows: jax.Array, pidx: jax.Array, crows: jax.Array,
             cweight: jax.Array, cseg: jax.Array) -> tuple[jax.Array, jax.Array]:
        up, ysj, wj, probes = data
        e = _loss_rows(th, up, rows, d, neurons, hidden) - ysj[rows]
        value = jnp.mean(wj[rows] * e**2)
        if n_draw:
            value += passivity * passivity_penalty(th, probes, pidx, d, neurons, hidden)
        if c_draw:
            value += cycle_energy * cycle_energy_error(th, up, ysj, crows, cweight, cseg,
                                                       c_draw, d, neurons, hidden)
        return value, jnp.mean(e**2)

    def draw(rng: np.random.Generator) -> tuple[np.ndarray, ...]:
        rows = rng.integers(0, n, (steps_per_epoch, batch))
        pidx = rng.integers(0, max(n_probes, 1), (steps_per_epoch, n_draw))
        if not c_draw:
            # no draw when the term is off: the minibatch sequence stays that of the paper
            none = np.zeros((steps_per_epoch, 0), dtype=np.int32)
            return rows, pidx, none, none.astype(dt), none
        c = pack_cycles(cycles, rng.integers(0, n_cycles, (steps_per_epoch, c_draw)), slots,
                        dt)
        return rows, pidx, c.rows, c.weight, c.segment

    every_probe = jnp.arange(n_probes)

    @jax.jit
    def penalty_all(th: Any) -> Any:
        return passivity_penalty(jnp.asarray(th, jnp.float64), probes64, every_probe, d,
                                 neurons, hidden)

    def train_mse(th: Any) -> float:
        return problem.sse(np.asarray(th, np.float64)) / n_rows

    if validation is not None:
        uvj, yv = jnp.asarray(validation[0]), np.asarray(validation[1])
        wv = None if val_weights is None else np.asarray(val_weights)

    def validate(th: Any) -> tuple[float, float]:
        # early stopping on the loss being minimised: weighted error + physics terms
        if validation is None:
            vmse = value = train_mse(th)
        else:
            e = np.asarray(nfir_free_run(jnp.asarray(th, jnp.float64), uvj, rest_u, delays, neurons,
                                         hidden))[val_lead:] - yv
            vmse = float(np.mean(e**2))
            value = vmse if wv is None else float(np.mean(wv * e**2))
            vmse, value = (v if math.isfinite(v) else math.inf for v in (vmse, value))
            if c_draw and val_cycle_error is not None:
                value += cycle_energy * val_cycle_error(e)
        return vmse, value + (passivity * float(penalty_all(th)) if n_draw else 0.0)

    return AdamProblem(loss, jnp.asarray(theta0), opt, draw, validate, train_mse,
                       data=(up, ysj, wj, probes if n_draw else None))


def adam_nfir(
    u_s: np.ndarray,
    y_s: np.ndarray,
    theta0: np.ndarray,
    delays: tuple[int, ...],
    neurons: int,
    hidden: str,
    rest_u: float,
    problem: LMProblem,
    n_rows: int,
    max_epochs: int = 1000,
    steps_per_epoch: int = 200,
    lr: float = 1e-3,
    batch: int = 4096,
    max_fail: int = 6,
    seed: int = 0,
    callback: Callable[[int, dict], Any] | None = None,
    mse_scale: float = 1.0,
    b1: float = 0.9,
    b2: float = 0.999,
    eps: float = 1e-8,
    weights: np.ndarray | None = None,
    validation: tuple[np.ndarray, np.ndarray] | None = None,
    val_weights: np.ndarray | None = None,
    probes: HarmonicProbes | None = None,
    passivity: float = 0.0,
    probes_per_step: int = 24,
    cycles: EnergyCycles | None = None,
    cycle_energy: float = 0.0,
    cycles_per_step: int = 32,
    val_cycle_error: Callable[[np.ndarray], float] | None = None,
    val_lead: int = 0,
    precision: str = "float64",
) -> LMResult:
    """Minibatch Adam (``optax.adam``) on the NFIR MSE (scaled units); an "epoch" is
    ``steps_per_epoch`` steps of ``batch`` samples drawn (seeded) from every sample.

    The loss is the MSE, each sample weighted by ``weights`` (default 1), plus ``passivity``
    times :func:`passivity_penalty` on ``probes_per_step`` probes drawn from ``probes`` at every
    step, plus ``cycle_energy`` times :func:`cycle_energy_error` on ``cycles_per_step`` cycles
    drawn from ``cycles``. Stops at ``max_epochs`` or after ``max_fail`` epochs without a new
    best objective (best parameters returned): the MSE of the free run of the scaled
    ``validation`` record (input, output), each sample weighted by ``val_weights`` if given
    (one run scores both), or without validation the training MSE; plus the passivity term
    on every probe, plus ``cycle_energy * val_cycle_error(e)`` (the cycle-energy error of
    the validation record, from ``e``, the validation run's scored error) if given.
    ``problem`` supplies the training SSE (on its ``n_rows`` rows) reported in the history.
    ``lr``, ``b1``, ``b2``, ``eps`` as :func:`optax.adam` (``eps`` outside the square root).
    ``val_lead``: the validation run's first outputs not scored (its input starts with measured
    history: :func:`nfir_validation`). ``precision``: the steps' (``"float64"`` or
    ``"float32"``: the parameters, Adam's moments and the steps' data); the validation and the
    parameters returned are float64. The epochs run in the training engine
    (:func:`sloshrom.rom.engine.adam_epochs`).
    """
    adam_problem = nfir_adam_problem(
        u_s, y_s, theta0, delays, neurons, hidden, rest_u, problem, n_rows,
        steps_per_epoch=steps_per_epoch, lr=lr, batch=batch, b1=b1, b2=b2, eps=eps,
        weights=weights, validation=validation, val_weights=val_weights, probes=probes,
        passivity=passivity, probes_per_step=probes_per_step, cycles=cycles,
        cycle_energy=cycle_energy, cycles_per_step=cycles_per_step,
        val_cycle_error=val_cycle_error, val_lead=val_lead, precision=precision)
    res = adam_epochs(adam_problem, max_epochs=int(max_epochs), max_fail=max_fail, seed=seed,
                      mse_scale=mse_scale, patience_without_validation=True,
                      constant_history={"mu": math.nan, "grad": math.nan}, callback=callback)
    return LMResult(np.asarray(res.params, np.float64), res.stop_reason, res.history,
                    res.best_epoch)


# ---------------------------------------------------------------------------------------------
# NOE by multiple shooting: minibatch Adam on the simulation error of short sub-sequences
# ---------------------------------------------------------------------------------------------


def noe_shoot(theta: Any, ubuf0: Any, ybuf0: Any, u_s: Any, delays: tuple[int, ...],
              out_delays: int, neurons: int, hidden: str) -> Any:
    """Closed-loop NOE simulations of a batch from given delay lines (scaled units).

    Parameters
    ----------
    theta : array, shape (P,)
        Packed parameters (:func:`~sloshrom.rom.tdnn.network.pack`); their dtype sets the precision.
    ubuf0 : array, shape (b, max_delay)
        Input delay lines at the start, most recent first.
    ybuf0 : array, shape (b, out_delays)
        Output delay lines at the start, most recent first.
    u_s : array, shape (b, T)
        Scaled inputs of the ``T`` samples simulated.

    Returns
    -------
    array, shape (b, T)
        Scaled outputs: :func:`~sloshrom.rom.tdnn.network.noe_simulate` of each row.
    """

    def one(ub: Any, yb: Any, u: Any) -> Any:
        return noe_simulate(theta, u, (ub, yb), delays, out_delays, neurons, hidden)[1]

    return jax.vmap(one)(ubuf0, ybuf0, u_s)


def noe_shooting_problem(
    u: np.ndarray,
    y: np.ndarray,
    fs: float,
    scaler: MinMaxScaler,
    theta0: np.ndarray,
    delays: tuple[int, ...],
    out_delays: int,
    neurons: int,
    hidden: str,
    validation: tuple[np.ndarray, np.ndarray] | None = None,
    options: ShootingOptions = NOE_SHOOTING,
    *,
    bound: float = 10.0,
    validation_history: int = 0,
) -> AdamProblem:
    """The multiple-shooting problem of :func:`adam_noe` for the training engine; the
    parameters are :func:`adam_noe`'s (``max_epochs`` sets the learning-rate schedule's
    length; the draws' seed is the engine's)."""
    d = np.asarray(delays)
    dmax, m, T = int(d.max()), int(out_delays), int(options.horizon)
    n = np.size(u)
    if n < shooting_samples(T):
        raise ROMError(f"{n} samples are too few for a horizon of {T} samples "
                       f"(need at least {shooting_samples(T)})")
    sc = scaler
    ru, ry = float(sc.u(0.0)), float(sc.y(0.0))
    f32 = TRAIN_DTYPE
    lag = max(dmax, m)
    # the record padded in front with rest: every start has its measured (or rest) history
    up = jnp.asarray(np.concatenate([np.full(lag, ru), sc.u(np.asarray(u, np.float64))]), f32)
    yp = jnp.asarray(np.concatenate([np.full(lag, ry), sc.y(np.asarray(y, np.float64))]), f32)
    shoot = partial(noe_shoot, delays=tuple(int(x) for x in d), out_delays=m, neurons=neurons,
                    hidden=hidden)

    def start(th: PyTree, data: PyTree, starts: jax.Array, shift: jax.Array) -> PyTree:
        # delay lines at start s (padded index s + lag): measured samples s-1, s-2, ...
        up, yp = data
        u_lags = jnp.arange(1, dmax + 1)
        y_lags = jnp.arange(1, m + 1)
        return (up[starts[:, None] + lag - u_lags[None, :]] + shift[:, None],
                yp[starts[:, None] + lag - y_lags[None, :]])

    def rest(k: int) -> PyTree:
        return jnp.full((k, dmax), ru, f32), jnp.full((k, m), ry, f32)

    def free_run(th: PyTree, uv: np.ndarray) -> np.ndarray:
        return np.asarray(noe_free_run(jnp.asarray(th, jnp.float64), jnp.asarray(uv), ru, ry,
                                       delays, m, neurons, hidden))

    def history_run(th: PyTree, up: np.ndarray, yp: np.ndarray, uv: np.ndarray) -> np.ndarray:
        return np.asarray(noe_history_run(jnp.asarray(th, jnp.float64), jnp.asarray(up),
                                          jnp.asarray(yp), jnp.asarray(uv), delays, m, neurons,
                                          hidden))

    rec = Recurrence(offset=0, n_starts=n - T + 1, start=start, rest=rest,
                     simulate=lambda th, _, b, uf: shoot(th, b[0], b[1], uf),
                     free_run=free_run, bound=bound, history_run=history_run, data=(up, yp))
    return shooting(rec, jnp.asarray(theta0, f32), u, y, fs, scaler, validation, options,
                    validation_history)


def adam_noe(
    u: np.ndarray,
    y: np.ndarray,
    fs: float,
    scaler: MinMaxScaler,
    theta0: np.ndarray,
    delays: tuple[int, ...],
    out_delays: int,
    neurons: int,
    hidden: str,
    validation: tuple[np.ndarray, np.ndarray] | None = None,
    options: ShootingOptions = NOE_SHOOTING,
    *,
    bound: float = 10.0,
    max_fail: int = 6,
    seed: int = 0,
    callback: Callable[[int, dict], Any] | None = None,
    validation_history: int = 0,
) -> LMResult:
    """Train an NOE by multiple shooting with the passive recipe's loss terms.

    Each Adam step (``optax``, float32, gradients clipped to a global norm of 1, learning rate
    decaying from ``learning_rate`` to 5 % of it over the run, cosine) draws ``batch`` starts
    ``s`` in the record, fills the NOE's delay lines with the *measured* inputs and outputs
    before ``s`` (its exact state there: the record is taken at rest before its first sample)
    and simulates ``horizon`` samples in closed loop. The loss, as
    :func:`sloshrom.rom.nss.training.fit_statespace`'s:

    - the mean squared simulation error, each sample weighted by :func:`amplitude_weights`
      when ``amplitude_weighting > 0``;
    - ``cycle_energy`` times the mean squared error of the energy each sub-sequence exchanges
      with the liquid, over ``m_ref V^2`` (``V`` its peak velocity) and per input cycle in it;
    - ``passivity`` times the mean squared negative part of the dissipated energy of
      ``probes_per_step`` harmonic probes run from rest in the same batch.

    Early stopping: after every epoch of ``steps_per_epoch`` steps, the free run of the whole
    validation record from rest (float64) is scored with the same terms (every probe); after
    ``max_fail`` epochs without a new best the training stops, and the best parameters are
    returned (without validation, those of the epoch of the lowest training error). The epochs
    run in the training engine (:func:`sloshrom.rom.engine.adam_epochs`).

    Parameters
    ----------
    u, y : ndarray, shape (n,)
        Input (m/s) and output (N) records at ``fs``, physical units, starting at rest.
    fs : float
        Sample rate, Hz.
    scaler : MinMaxScaler
        Scaling of input and output.
    theta0 : ndarray
        Initial packed parameters (:func:`init_theta`).
    delays, out_delays, neurons, hidden
        The NOE's architecture.
    validation : (u_val, y_val), optional
        Validation record, physical units, starting at rest (or after its first
        ``validation_history`` samples, which then fill the delay lines and are not scored).
    options : ShootingOptions
        The recipe (:class:`sloshrom.rom.shooting.ShootingOptions`): horizon (samples
        simulated from each start, and the length of the probes), batch, epochs at most, Adam
        steps per epoch, initial step size, the passive recipe's weights (0 = off), the probes.
    bound : float
        A validation run whose scaled output exceeds this magnitude is unstable (objective inf).
    max_fail, seed
        Patience (epochs), seed of the draws of starts and probes.
    callback : callable, optional
        ``callback(epoch, info)`` after every epoch; True stops the training.

    Returns
    -------
    LMResult
        Parameters, stop reason, history (per epoch ``train_mse``: the unweighted MSE of the
        epoch's sub-sequences, N^2; ``val_mse`` N^2; ``val_objective``; ``mu``, ``grad``
        (NaN: no such quantity); ``seconds``) and best epoch.
    """
    problem = noe_shooting_problem(u, y, fs, scaler, theta0, delays, out_delays, neurons,
                                   hidden, validation, options, bound=bound,
                                   validation_history=validation_history)
    res = adam_epochs(problem, max_epochs=int(options.max_epochs), max_fail=max_fail, seed=seed,
                      mse_scale=scaler.out_half_range**2,
                      constant_history={"mu": math.nan, "grad": math.nan}, callback=callback)
    return LMResult(np.asarray(res.params, dtype=np.float64), res.stop_reason, res.history,
                    res.best_epoch)


# ---------------------------------------------------------------------------------------------
# Entry point used by the estimators
# ---------------------------------------------------------------------------------------------


def _regressors(u_s, y_s, rows, delays, out_delays, rest_u, rest_y):
    """Regressors at ``rows`` with measured past outputs (series-parallel, for initialisation)."""
    d = np.asarray(delays)
    dmax = max(int(d.max()), out_delays)
    up = np.concatenate([np.full(dmax, rest_u), u_s])
    X = up[rows[:, None] + dmax - d[None, :]]
    if out_delays:
        ypad = np.concatenate([np.full(dmax, rest_y), y_s])
        X = np.hstack([X, ypad[rows[:, None] + dmax - np.arange(1, out_delays + 1)[None, :]]])
    return X


@float64
def train(
    spec: NetworkSpec,
    u: np.ndarray,
    y: np.ndarray,
    scaler: MinMaxScaler,
    validation: tuple[np.ndarray, np.ndarray] | None = None,
    *,
    trainer: str = "fast",
    max_epochs: int = 1000,
    seed: int = 0,
    unstable_bound: float = 10.0,
    callback: Callable[[int, dict], Any] | None = None,
    fs: float | None = None,
    amplitude_weighting: float = 0.0,
    passivity: float = 0.0,
    frequency_band: tuple[float, float] | None = None,
    cycle_energy: float = 0.0,
    horizon: int = _NOE["horizon"],
    batch: int = _NOE["batch"],
    steps_per_epoch: int = _NOE["steps_per_epoch"],
    learning_rate: float = _NOE["learning_rate"],
    validation_history: int = 0,
    precision: str = "float64",
) -> tuple[np.ndarray, dict[str, Any]]:
    """Train the network ``spec`` on a record (physical units, scaled here by ``scaler``).

    Parameters
    ----------
    spec : NetworkSpec
        Architecture (NFIR or NOE, delays, neurons, hidden kind, output delays).
    u, y : ndarray, shape (n,)
        Input and output records (physical units), starting at rest.
    scaler : MinMaxScaler
        Scaling of the input and output (normally fitted on ``u``, ``y``).
    validation : (u_val, y_val), optional
        Validation record (early stopping, best network).
    validation_history : int
        The validation record's first samples taken as measured history (at least the delay
        lines' length): they fill the delay lines and are not scored; 0: the run starts from
        rest, every sample scored.
    trainer : {"fast", "lm", "adam"}
        See the module docstring; ``"adam"`` for an NOE is :func:`adam_noe` (multiple
        shooting).
    max_epochs, seed : int
        Epochs at most; seed of the initialisation (and of the Adam minibatches).
    unstable_bound : float
        NOE: a scaled output beyond this magnitude is unstable (the trial step is rejected).
    callback : callable, optional
        ``callback(epoch, info)`` after every epoch; True stops the training.
    fs : float, optional
        Sample rate, Hz; needed by ``amplitude_weighting`` and ``passivity``.
    amplitude_weighting : float
        ``eps`` of :func:`amplitude_weights` (units of ``u``); 0 = plain MSE. Adam only (as
        the two terms below).
    passivity : float
        Weight of :func:`passivity_penalty` on :func:`harmonic_probes` over
        ``frequency_band`` (Hz); 0 = none. Adam only.
    cycle_energy : float
        Weight of :func:`cycle_energy_error` on the :func:`energy_cycles` of the record
        (cycles within ``frequency_band``); 0 = none. Adam only. For an NOE, the energy error
        of each simulated sub-sequence per input cycle (:func:`adam_noe`).
    horizon, batch, steps_per_epoch, learning_rate
        NOE trained by Adam only (:func:`adam_noe`): samples simulated from each start,
        sub-sequences per step, steps per epoch, initial step size.
    precision : {"float64", "float32"}
        NFIR trained by Adam only: the precision of its steps (:func:`adam_nfir`); the other
        trainers run float64.

    Returns
    -------
    theta : ndarray
        The best parameters, packed (:func:`~sloshrom.rom.tdnn.network.pack`), scaled units.
    history : dict
        JSON-serialisable: per-epoch ``train_mse``, ``val_mse`` (physical units squared),
        ``mu``, ``grad``, ``seconds``; ``stop_reason``, ``best_epoch``, ``trainer``,
        ``n_rows``, ``train_seconds``; after a stop at mu_max, ``stop_message``
        (:func:`mu_max_message`).

    Raises
    ------
    ROMError
        Unknown trainer, or a loss term with a trainer other than Adam.
    UnstableModelError
        An NOE unstable at its initial parameters.

    Warns
    -----
    TrainingWarning
        Levenberg-Marquardt stopped at mu_max (the text of ``stop_message``).
    """
    sc = scaler
    u_s, y_s = sc.u(u), sc.y(y)
    rest_u, rest_y = float(sc.u(0.0)), float(sc.y(0.0))
    val = None if validation is None else (sc.u(validation[0]), sc.y(validation[1]))
    delays, h, hidden, out_delays = spec.delays, spec.neurons, spec.hidden, spec.out_delays
    if trainer not in TRAINERS:
        raise ROMError(f"trainer must be 'fast', 'lm' or 'adam', got {trainer!r}")
    # the class's rules (what its loss terms need among them), as its estimator's fit
    mc = model_class(spec.arch)
    given = {"delays": list(delays), "neurons": h, "hidden": hidden, "trainer": trainer,
             "out_delays": out_delays, "amplitude_weighting": amplitude_weighting,
             "passivity": passivity, "cycle_energy": cycle_energy, "horizon": horizon,
             "batch": batch, "steps_per_epoch": steps_per_epoch,
             "learning_rate": learning_rate, "precision": precision}
    mc.check({k: v for k, v in given.items() if any(p.name == k for p in mc.hyper)})
    physics = amplitude_weighting > 0 or passivity > 0 or cycle_energy > 0
    if physics and not (fs is not None and fs > 0):
        raise ROMError("amplitude_weighting, passivity and cycle_energy need the sample rate fs")
    n = u_s.size
    if spec.arch == "nfir" and trainer in ("fast", "adam") and n > FAST_MAX_ROWS:
        stride = -(-n // FAST_MAX_ROWS)
        rows = np.arange(stride // 2, n, stride)
    else:
        rows = np.arange(n)
    init_rows = rows if rows.size <= FAST_MAX_ROWS else rows[:: -(-rows.size // FAST_MAX_ROWS)]
    X0 = _regressors(u_s, y_s, init_rows, delays, out_delays, rest_u, rest_y)
    theta0 = init_theta(X0, y_s[init_rows], h, hidden, int(seed))
    hv = int(validation_history)
    if spec.arch == "nfir":
        problem = nfir_problem(u_s, y_s, delays, h, hidden, rest_u, rows, val,
                               validation_history=hv)
    else:
        problem = noe_problem(u_s, y_s, delays, out_delays, h, hidden, rest_u, rest_y,
                              float(unstable_bound), val, validation_history=hv)
        if not np.isfinite(problem.sse(theta0)):
            raise UnstableModelError("NOE unstable at its initial parameters")
    t0 = time.perf_counter()
    if trainer == "adam" and spec.arch == "noe":
        band = frequency_band if frequency_band is not None else (0.0, math.inf)
        options = ShootingOptions(
            horizon=int(horizon), batch=int(batch), max_epochs=int(max_epochs),
            steps_per_epoch=int(steps_per_epoch), learning_rate=float(learning_rate),
            amplitude_weighting=float(amplitude_weighting), passivity=float(passivity),
            cycle_energy=float(cycle_energy), frequency_band=band, velocity_offset=0.0,
            weight_decay=0.0)
        res = adam_noe(u, y, float(fs) if fs is not None else 1.0, sc, theta0, delays,
                       out_delays, h, hidden, validation, options,
                       bound=float(unstable_bound), seed=int(seed), callback=callback,
                       validation_history=hv)
    elif trainer == "adam":
        weights = val_weights = probes = None
        dmax = int(max(delays))
        # with measured history: the validation run from the history's last max(delays)
        # samples, scored after them
        val_run = lead = None
        if val is not None:
            uvl, yvl, lead = nfir_validation(val, dmax, hv)
            val_run = (np.asarray(uvl), yvl)
        if amplitude_weighting > 0:
            weights = amplitude_weights(u, fs, amplitude_weighting)
            if validation is not None:
                val_weights = amplitude_weights(validation[0], fs, amplitude_weighting)[hv:]
        band = frequency_band if frequency_band is not None else (0.0, math.inf)
        if passivity > 0:
            probes = harmonic_probes(u, fs, sc, delays, band)
        cycles = val_cycle_error = None
        if cycle_energy > 0:
            cycles = energy_cycles(u, fs, band)
            if validation is not None and val is not None:
                try:
                    cv = energy_cycles(validation[0][hv:], fs, band)
                except ROMError:
                    if not hv:
                        raise
                    # the history left too short a record to score: say so in its words
                    raise HistoryError(hv, f"the {validation[0].size - hv} sample(s) of the "
                                           "validation record after it hold no whole input "
                                           "cycle for the cycle-energy term; take fewer "
                                           "samples of history") from None
                val_cycle_error = partial(run_cycle_error, cycles=cv)
        # minibatches from every sample; the reported training MSE on the decimated rows
        res = adam_nfir(u_s, y_s, theta0, delays, h, hidden, rest_u, problem, int(rows.size),
                        max_epochs=int(max_epochs), seed=int(seed),
                        callback=callback, mse_scale=sc.out_half_range**2, weights=weights,
                        validation=val_run, val_weights=val_weights, probes=probes,
                        passivity=float(passivity),
                        cycles=cycles, cycle_energy=float(cycle_energy),
                        val_cycle_error=val_cycle_error, val_lead=int(lead or 0),
                        precision=precision)
    else:
        res = levenberg_marquardt(problem, theta0, max_epochs=int(max_epochs),
                                  callback=callback, mse_scale=sc.out_half_range**2)
    history = dict(res.history)
    history.update(
        stop_reason=res.stop_reason,
        best_epoch=res.best_epoch,
        trainer=trainer,
        n_rows=int(rows.size),
        train_seconds=time.perf_counter() - t0,
    )
    if res.stop_reason == "mu_max":
        # not silent: the network kept may be no better than its initialisation
        history["stop_message"] = mu_max_message(res.stop_info, spec.arch)
        if not members_quiet.get():  # (an ensemble's member: the ensemble says it)
            warnings.warn(TrainingWarning(history["stop_message"]), stacklevel=3)
    return res.theta, history


def mu_max_message(info: dict[str, float], arch: str) -> str:
    """:func:`~sloshrom.rom.lm.stop_message` of a network's stop at ``mu_max``, with what to
    try.

    Parameters
    ----------
    info : dict
        :attr:`~sloshrom.rom.lm.LMResult.stop_info`.
    arch : {"nfir", "noe"}
        The network: for an NOE whose ``J^T J`` is beyond any damping, the cause is named (its
        derivatives run through its closed loop over the whole record).

    Returns
    -------
    str
        One paragraph: the stop, its cause, the advice (trainer ``"adam"``, a smaller network,
        another seed).
    """
    text = stop_message(info)
    beyond = info.get("jtj_max", 0.0) * np.finfo(np.float64).eps > info.get("mu_max", math.inf)
    if arch == "noe" and beyond:
        text += (" The NOE's derivatives run through its fed-back outputs over the whole record "
                 "and grow wherever the loop amplifies a change of its weights.")
    how = ("multiple shooting on short sub-sequences" if arch == "noe" else "minibatch Adam")
    return (f"{text} Try trainer 'adam' ({how}), fewer neurons or delays, or another seed "
            "(an ensemble of seeds shows how much is the draw).")
