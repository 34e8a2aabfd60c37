"""Identification of the grey-box ROM: the column's physics first, then the network on it.

1. **The column** (:func:`fit_physics`): its seven physical parameters (the search variables
   of :func:`sloshrom.rom.grey.physics.physical_parameters`, inside physical bounds) by
   differential evolution (``scipy.optimize.differential_evolution``, seeded, no gradient: the
   force is not smooth in the parameters through the releases and landings) on windows of the
   training record spread over it, each simulated from rest after a half-second warm-up. For
   each candidate the output filter (:func:`~sloshrom.rom.grey.physics.design_rows`) is the
   least-squares fit, and the score is the mean squared error plus ``spectral`` times the
   error of the force's short-time spectral magnitudes (three resolutions, 32-128 ms; a
   timing-free term: a point-wise score alone prefers a column too light to make impacts,
   since an impact a sub-step late is punished twice). The filter is then fitted on the
   whole record.
2. **The network** (:func:`fit_greybox`): the column's features computed over the record once,
   the network trained by multiple shooting (:func:`sloshrom.rom.shooting.shooting_problem`,
   the NSS's recipe: encoder, Adam, early stopping on the validation free run), its output
   layer starting at zero so that the model starts as the physics.
"""

from __future__ import annotations

import functools
import logging
import math
import threading
import time
from collections.abc import Callable, Mapping
from concurrent.futures import ThreadPoolExecutor

import jax
import jax.numpy as jnp
import numba
import numpy as np
from scipy import fft as sp_fft
from scipy import signal as sps
from scipy.optimize import OptimizeResult, differential_evolution
from threadpoolctl import threadpool_limits

from sloshrom._threads import numba_threadsafe, usable_cores
from sloshrom._x64 import float64
from sloshrom.rom.engine import AdamProblem, adam_epochs
from sloshrom.rom.errors import ROMError
from sloshrom.rom.grey.entry import grey_shapes
from sloshrom.rom.grey.kernel import grey_window, kernel_available, kernel_note
from sloshrom.rom.grey.network import GreySpec, grey_free_run, grey_simulate
from sloshrom.rom.grey.physics import (
    causal_intervals,
    design_rows,
    filter_normal_equations,
    filter_output,
    grey_features,
    physical_parameters,
)
from sloshrom.rom.losses import TRAIN_DTYPE, windows
from sloshrom.rom.network import MinMaxScaler
from sloshrom.rom.shooting import PyTree, Recurrence, ShootingOptions, ss_encode
from sloshrom.rom.shooting import shooting_problem as shooting

__all__ = ["PHYSICS_BOUNDS", "PLATEAU", "fit_greybox", "fit_physics", "init_params",
           "shooting_problem"]

#: The column's search variables and their bounds: share of the liquid in the balls (-),
#: restitution (-), contact frequency (Hz), gap over the ullage (-), ln of the gate rate at
#: |g_eff| = g (ln 1/s), gate relaxation (s), coherence level (g).
PHYSICS_BOUNDS: dict[str, tuple[float, float]] = {
    "beta": (0.1, 1.0), "restitution": (0.0, 0.9), "contact_hz": (60.0, 400.0),
    "gap_factor": (0.5, 1.5), "log_gate_rate": (math.log(3.0), math.log(40.0)),
    "gate_relaxation": (0.002, 0.05), "coherence_g": (2.0, 20.0)}
#: The network's training stops on a validation plateau: its best objective fell by less than
#: 1 % over the last 3 epochs (from max_epochs / 2 on). On the default run the objective then
#: falls by 0.1-0.5 % an epoch: the rule saves 8-10 of the 20 epochs for a member's validation
#: error 1-3 % higher, inside the members' spread (12 %).
PLATEAU = (3, 0.01)
#: Length and warm-up of a search window, s.
WINDOW_S, WARM_S = 2.0, 0.5
#: Short-time spectra of the spectral term: (segment, hop) in samples at 500 Hz, scaled to the
#: record's rate.
_STFT = ((16, 4), (32, 8), (64, 16))


def _windows(n: int, fs: float, count: int, seed: int) -> np.ndarray:
    """Start samples of ``count`` search windows, one drawn in each of ``count`` equal parts
    of the record."""
    length = int(round((WINDOW_S + WARM_S) * fs))
    if n < length + 1:
        raise ROMError(f"the column's search needs at least {WINDOW_S + WARM_S:g} s of record "
                       f"({length + 1} samples), got {n}")
    rng = np.random.default_rng([seed, 11])
    edges = np.linspace(0, n - length, count + 1).astype(int)
    return np.array([rng.integers(edges[i], max(edges[i] + 1, edges[i + 1]))
                     for i in range(count)])


def _least_squares(a: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Taps minimising ``|a taps - y|`` (:func:`_solve_normal`)."""
    return _solve_normal(a.T @ a, a.T @ y)


def _solve_normal(ata: np.ndarray, aty: np.ndarray) -> np.ndarray:
    """The least-squares taps from the normal equations ``ata taps = aty``, slightly
    regularised (a sub-step with no force in any window leaves a column of zeros); zero where
    the column gives no force at all (a candidate that releases no ball in any window: no taps
    can fit it)."""
    ridge = 1e-9 * np.trace(ata) / max(1, ata.shape[0])
    if ridge == 0.0:
        return np.zeros(ata.shape[1])
    return np.linalg.solve(ata + ridge * np.eye(ata.shape[0]), aty)


@functools.cache
def _hann(s: int) -> tuple[np.ndarray, float]:
    """``scipy.signal.stft``'s Hann window and "spectrum" scale for segments of ``s`` samples
    (it computes them in complex arithmetic; their imaginary parts are zero)."""
    win = sps.get_window("hann", s).astype(np.complex128)
    return win.real.copy(), float(np.sqrt(1.0 / win.sum() ** 2).real)


def _spectra(x: np.ndarray, fs: float) -> list[np.ndarray]:
    """Short-time spectral magnitudes of ``x`` (..., n) at the :data:`_STFT` resolutions:
    ``abs(scipy.signal.stft(x, nperseg=s, noverlap=s - hop, boundary=None, padded=False))``
    to the bit, in real arithmetic (scipy windows the real segments with a complex window:
    twice the arithmetic and memory)."""
    out = []
    for seg, hop in _STFT:
        s = max(4, int(round(seg * fs / 500.0)))
        h = max(1, int(round(hop * fs / 500.0)))
        if x.shape[-1] >= s:
            win, scale = _hann(s)
            frames = np.lib.stride_tricks.sliding_window_view(x, s, axis=-1)[..., ::h, :]
            r = sp_fft.rfft(win * frames, n=s, axis=-1)
            r *= scale
            out.append(np.abs(np.moveaxis(r, -1, -2)))
    return out


def fit_physics(
    u: np.ndarray,
    y: np.ndarray,
    fs: float,
    spec: GreySpec,
    liquid_mass: float,
    ullage: float,
    *,
    spectral: float = 1.0,
    generations: int = 20,
    population: int = 8,
    windows: int = 32,
    seed: int = 0,
    prune: bool = True,
) -> tuple[np.ndarray, np.ndarray, dict[str, float]]:
    """Identify the column's physical parameters and its output filter (module docstring).

    Parameters
    ----------
    u, y : ndarray, shape (n,)
        Tank velocity (m/s) and dynamic force (N) at ``fs``, starting at rest.
    fs : float
        Sample rate, Hz.
    spec : GreySpec
        The column's balls, sub-steps and filter reach.
    liquid_mass, ullage : float
        The tank's liquid mass (kg) and ullage (m): the scales of the search's bounds.
    spectral : float
        Weight of the spectral term (0: the point-wise error only).
    generations, population, windows : int
        Differential evolution's generations at most and population per variable; the search
        windows of 2 s.
    seed : int
        Seeds the windows and the search.
    prune : bool
        Score in part a trial that cannot replace its target (Notes); False scores every
        trial in full: the same search, for checks and benchmarks.

    Returns
    -------
    physics : ndarray, shape (7,)
        :data:`~sloshrom.rom.grey.physics.PHYS_NAMES`, SI units.
    taps : ndarray
        The output filter, fitted on the whole record.
    history : dict
        The search variables found, by name (:data:`PHYSICS_BOUNDS`), and ``objective``,
        ``generations``, ``evaluations``, ``pruned`` (trials scored in part), ``seconds``,
        ``windows``.

    Notes
    -----
    The candidates of a generation are scored side by side, one a thread, as many threads as
    the usable cores and numba's thread count allow (one in a Dask worker that owns one core),
    and BLAS runs on one thread meanwhile; each candidate is scored alone, so the result is the
    same on any number of threads.

    Differential evolution keeps a trial only if it scores no more than the population member
    it competes with (its target), and uses the score of a trial it discards nowhere. Once a
    trial's filter is fitted, its squared error follows from the filter's normal equations
    (``|A t - y|^2 = t'A'A t - 2 t'A'y + y'y``); where that error alone, less a bound on its
    round-off, exceeds the target's score, the trial is returned that error without its output
    and spectra (a quarter of a candidate's time) and discarded as before: the same search to
    the bit (``tests/rom/grey/test_grey.py``).
    """
    u = np.asarray(u, dtype=np.float64)
    y = np.asarray(y, dtype=np.float64)
    starts = _windows(u.size, fs, int(windows), int(seed))
    warm = int(round(WARM_S * fs))
    length = int(round((WINDOW_S + WARM_S) * fs))
    idx = starts[:, None] + np.arange(length)[None, :]
    uw, yw = u[idx], y[idx][:, warm:]
    target = yw.reshape(-1)
    target_spectra = _spectra(yw, fs) if spectral > 0 else []
    yy = float(target @ target)
    names = list(PHYSICS_BOUNDS)
    evaluations = [0]
    pruned = [0]
    last_cut = [np.empty(0)]  # the scores of the last generation's trials scored in part
    shape = (1, *uw.shape, 3, spec.n_substeps)

    def phys_of(x: np.ndarray) -> np.ndarray:
        v = [float(a) for a in x]
        return physical_parameters(v[0], v[1], v[2], v[3], v[4], v[5], v[6],
                                   liquid_mass=liquid_mass, ullage=ullage)

    def score(x: np.ndarray, sim: np.ndarray, target_score: float) -> tuple[float, bool]:
        """The candidate's score, and whether it was scored in part."""
        # a candidate at a time: its simulations (8 MB, in ``sim``) stay in the cache, where
        # the generation's (430 MB) went through memory; each (set, window) pair is simulated
        # alone either way, so the numbers are the same. The filter's rows after the warm-up
        # read the predictions from the step before it on; its normal equations and output
        # are summed from the simulations, without the rows (14 MB)
        o = causal_intervals(phys_of(x)[None], uw, fs, spec.n_balls, spec.n_substeps,
                             from_rest=False, predict_from=warm - 1, out=sim)[0]
        if not np.all(np.isfinite(o)):
            return math.inf, False
        gram, rhs = filter_normal_equations(o, yw, spec.n_past, warm)
        taps = _solve_normal(gram, rhs)
        if target_score < math.inf:
            # the error from the normal equations, less a bound on its round-off (1e-9 of its
            # terms' magnitudes): above the target's score, the exact score cannot be lower
            quad, lin = float(taps @ gram @ taps), float(taps @ rhs)
            size = float(np.abs(taps) @ np.abs(gram) @ np.abs(taps)) + 2.0 * float(
                np.abs(taps) @ np.abs(rhs)) + yy
            low = (quad - 2.0 * lin + yy - 1e-9 * size) / target.size
            if low > target_score:
                return low, True
        fit = filter_output(o, taps, spec.n_past, warm).reshape(-1)
        out = float(np.mean((fit - target) ** 2))
        if spectral > 0:
            model = _spectra(fit.reshape(yw.shape), fs)
            out += spectral * sum(float(np.mean((m - t) ** 2))
                                  for m, t in zip(model, target_spectra, strict=True))
        return out, False

    # the candidates of a generation side by side, one a usable core (each scored alone: the
    # same numbers in any order); one buffer of simulations a thread, allocated once
    local = threading.local()

    def score_here(x: np.ndarray, target_score: float) -> tuple[float, bool]:
        if not hasattr(local, "sim"):
            local.sim = np.empty(shape)
            # the candidates are the parallel axis: the column's kernel on one thread each
            # (numba's count is the calling thread's own)
            numba.set_num_threads(1)
        return score(x, local.sim, target_score)

    # as many as the cores this process may use and numba's threads allow (a Dask worker's
    # are limited to the cores it owns)
    n_threads = min(len(usable_cores()), numba.get_num_threads(), int(population) * len(names))
    if n_threads > 1 and not numba_threadsafe():
        n_threads = 1  # numba's workqueue layer: its kernels from one thread at a time

    sim = np.empty(shape if n_threads == 1 else (0,))

    # each trial's target's score (Notes): after the initial population, its scores with the
    # best moved to the front (as differential evolution does); after each generation, the
    # population's scores as the callback receives them
    targets: list[np.ndarray | None] = [None]
    pruning = [bool(prune)]

    def search(pool: ThreadPoolExecutor | None) -> OptimizeResult:
        def objective(xs: np.ndarray) -> np.ndarray:
            xs = np.asarray(xs).T  # vectorised: (candidates, variables)
            evaluations[0] += xs.shape[0]
            bound = targets[0]
            if not pruning[0] or bound is None or bound.shape != (xs.shape[0],):
                bound = np.full(xs.shape[0], math.inf)
            if pool is None:  # (the column's kernel on numba's threads, window by window)
                scored = [score(x, sim, float(b)) for x, b in zip(xs, bound, strict=True)]
            else:
                scored = list(pool.map(score_here, xs, bound.tolist()))
            energies = np.array([e for e, _ in scored], dtype=np.float64)
            cut = np.array([c for _, c in scored], dtype=bool)
            pruned[0] += int(cut.sum())
            last_cut[0] = energies[cut]
            if targets[0] is None:  # the initial population
                targets[0] = _best_first(energies)
            return energies

        def follow(intermediate_result: OptimizeResult) -> None:
            population = np.array(intermediate_result.population_energies, dtype=np.float64)
            if pruning[0] and np.isin(last_cut[0], population).any():
                # a trial scored in part entered the population: the targets were not its
                # competitors' (another scipy?); score in full from here on
                pruning[0] = False
                logging.getLogger("sloshrom").warning(
                    "the column's search: a trial scored in part was kept; scoring every "
                    "trial in full from here on")
            targets[0] = population

        return differential_evolution(objective, list(PHYSICS_BOUNDS.values()), seed=int(seed),
                                      maxiter=int(generations), popsize=int(population),
                                      tol=1e-4, polish=False, init="latinhypercube",
                                      updating="deferred", vectorized=True, callback=follow)

    t0 = time.perf_counter()
    # the filter's products are small: BLAS's own threads only wait for each other (a core
    # spent for a search 1.6 times slower, measured)
    with threadpool_limits(limits=1, user_api="blas"):
        if n_threads > 1:
            with ThreadPoolExecutor(n_threads, thread_name_prefix="sloshrom-search") as pool:
                res = search(pool)
        else:
            res = search(None)
    physics = phys_of(res.x)
    o = causal_intervals(physics[None], u[None], fs, spec.n_balls, spec.n_substeps)[0, 0]
    skip = spec.n_past + 1
    taps = _least_squares(design_rows(o, spec.n_past, skip), y[skip:])
    history = {**{k: float(v) for k, v in zip(names, res.x, strict=True)},
               "objective": float(res.fun), "generations": float(res.nit),
               "evaluations": float(evaluations[0]), "pruned": float(pruned[0]),
               "seconds": time.perf_counter() - t0,
               "windows": float(windows)}
    return physics, taps, history


def _best_first(energies: np.ndarray) -> np.ndarray:
    """Scores with the lowest (the first of equals) swapped to the front: where differential
    evolution puts the best member of a population it has scored."""
    out = np.array(energies, dtype=np.float64)
    best = int(np.argmin(out))
    out[[0, best]] = out[[best, 0]]
    return out


def init_params(spec: GreySpec, seed: int, physics: np.ndarray, taps: np.ndarray
                ) -> dict[str, np.ndarray]:
    """Seeded initial parameters: the network's tanh layers scaled by 1/sqrt(fan-in), its
    linear parts and output layer at zero (the model starts as the physics)."""
    rng = np.random.default_rng(seed)
    out: dict[str, np.ndarray] = {}
    for k, shp in grey_shapes(spec.hyper()).items():
        if k in ("W1", "V1", "E1"):
            out[k] = rng.standard_normal(shp) / math.sqrt(shp[0])
        elif k in ("W2", "E2"):
            out[k] = 0.1 * rng.standard_normal(shp) / math.sqrt(shp[0])
        else:
            out[k] = np.zeros(shp)
    out["physics"] = np.asarray(physics, dtype=np.float64)
    out["taps"] = np.asarray(taps, dtype=np.float64)
    return out


@functools.cache
def _note_path() -> None:
    """Say once a process that the grey box trains without its C kernel, and why."""
    note = kernel_note()
    if note is not None:
        logging.getLogger("sloshrom").warning(note)


def shooting_problem(
    spec: GreySpec,
    u: np.ndarray,
    y: np.ndarray,
    fs: float,
    scaler: MinMaxScaler,
    params0: Mapping[str, np.ndarray],
    validation: tuple[np.ndarray, np.ndarray] | None,
    options: ShootingOptions,
    validation_history: int = 0,
    dtype: type = TRAIN_DTYPE,
    kernel: bool | None = None,
) -> AdamProblem:
    """The network's multiple-shooting problem on the column's features (the physics fixed:
    its parameters are carried, not trained), its Adam steps in ``dtype``; ``kernel``: the
    shooting window by the C kernel (:mod:`sloshrom.rom.grey.kernel`; None: where it was
    built) or by ``lax.scan``. Call it inside ``jax.enable_x64(True)``."""
    o = options
    n, w, t = np.size(u), spec.window, int(o.horizon)
    ru, ry = float(scaler.u(0.0)), float(scaler.y(0.0))
    half = float(scaler.out_half_range)
    f32 = dtype
    u_s = jnp.asarray(scaler.u(np.asarray(u, dtype=np.float64)), f32)
    y_s = jnp.asarray(scaler.y(np.asarray(y, dtype=np.float64)), f32)
    physics = np.asarray(params0["physics"])
    taps = np.asarray(params0["taps"])
    fixed = {"physics": jnp.asarray(physics, f32), "taps": jnp.asarray(taps, f32)}

    def features(v: np.ndarray) -> np.ndarray:
        return grey_features(physics, taps, v, fs, spec.n_balls, spec.n_substeps,
                             spec.n_past) / half

    def net(p: PyTree) -> dict[str, jax.Array]:
        # the physics is not trained: its arrays ride along unchanged
        return {**p, **fixed}

    def start(p: PyTree, d: PyTree, starts: jax.Array, shift: jax.Array) -> jax.Array:
        return ss_encode(p, windows(d["u_s"], starts, w) + shift[:, None],
                         windows(d["y_s"], starts, w), ru, ry)

    use_kernel = kernel_available() if kernel is None else bool(kernel)

    def simulate(p: PyTree, d: PyTree, x0: jax.Array, seq: jax.Array) -> jax.Array:
        if use_kernel:
            return grey_window(p, x0, seq, ru, ry)
        return grey_simulate(p, x0, jnp.swapaxes(seq, 0, 1), ru, ry).T

    cache: dict[int, tuple[np.ndarray, np.ndarray]] = {}

    def free_run(p: PyTree, uv: np.ndarray) -> np.ndarray:
        # the validation record's features once (the physics does not train)
        if id(uv) not in cache:
            v = (np.asarray(uv, dtype=np.float64) - ru) / (float(scaler.u(1.0)) - ru)
            cache.clear()
            cache[id(uv)] = (uv, np.swapaxes(features(v[None]), 0, 1))
        phi = cache[id(uv)][1]
        x0 = np.zeros((1, spec.n_states))
        return grey_free_run(net(p), np.asarray(uv, dtype=np.float64)[:, None], phi, x0, ru,
                             ry)[:, 0]

    rec = Recurrence(offset=w, n_starts=n - w - t, start=start,
                     rest=lambda k: jnp.zeros((k, spec.n_states), f32), simulate=simulate,
                     free_run=free_run, features=features, data={"u_s": u_s, "y_s": y_s})
    trained = {k: jnp.asarray(v, f32) for k, v in params0.items()
               if k not in ("physics", "taps")}
    if validation_history:
        raise ROMError("a grey box's validation starts from rest (validation_history = 0)")
    return shooting(rec, trained, u, y, fs, scaler, validation, o, 0, dtype=dtype)


@float64
def fit_greybox(
    spec: GreySpec,
    u: np.ndarray,
    y: np.ndarray,
    fs: float,
    scaler: MinMaxScaler,
    physics: np.ndarray,
    taps: np.ndarray,
    validation: tuple[np.ndarray, np.ndarray] | None,
    options: ShootingOptions,
    *,
    max_fail: int = 6,
    seed: int = 0,
    callback: Callable[[int, dict[str, float]], bool | None] | None = None,
    precision: str = "float32",
) -> tuple[dict[str, np.ndarray], dict[str, object]]:
    """Train the network on the fixed column (module docstring); ``max_epochs = 0`` keeps the
    physics alone (the network's output at zero). ``precision``: the Adam steps' (``"float32"``,
    the NSS's, or ``"float64"``).

    Returns
    -------
    params : dict of ndarray
        Every array of :func:`~sloshrom.rom.grey.entry.grey_shapes` (scaled units for the
        network's; the physics' in SI units).
    history : dict
        As :func:`sloshrom.rom.nss.training.fit_statespace`'s.
    """
    o = options
    params0 = init_params(spec, seed, physics, taps)
    t0 = time.perf_counter()
    if int(o.max_epochs) == 0:
        return params0, {"stop_reason": "max_epochs = 0: the physics alone", "best_epoch": 0,
                         "trainer": "shooting", "n_rows": int(np.size(u)),
                         "train_seconds": 0.0}
    dtype = jnp.float64 if precision == "float64" else TRAIN_DTYPE
    _note_path()
    problem = shooting_problem(spec, u, y, fs, scaler, params0, validation, o, dtype=dtype)
    res = adam_epochs(problem, max_epochs=int(o.max_epochs), max_fail=max_fail,
                      min_epochs=int(o.max_epochs) // 2, rollback=10.0, seed=seed,
                      mse_scale=scaler.out_half_range**2, callback=callback,
                      plateau=PLATEAU)
    history: dict[str, object] = dict(res.history)
    history.update(stop_reason=res.stop_reason, best_epoch=res.best_epoch, trainer="shooting",
                   n_rows=int(np.size(u)), train_seconds=time.perf_counter() - t0)
    params = {k: np.asarray(v, dtype=np.float64) for k, v in res.params.items()}
    params.update(physics=np.asarray(physics, dtype=np.float64),
                  taps=np.asarray(taps, dtype=np.float64))
    return params, history

