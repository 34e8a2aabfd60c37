"""Levenberg–Marquardt, MATLAB ``trainlm``'s algorithm, for any least-squares problem.

A problem (:class:`LMProblem`) gives its normal equations ``J^T J``, ``J^T e`` at a parameter
vector, its sum of squared errors and, optionally, a validation error; :func:`levenberg_marquardt`
runs the damped Gauss-Newton iteration with ``trainlm``'s schedule of the damping ``mu`` and its
stopping rules (maximum epochs, ``mu_max``, gradient, validation failures) and returns the
best-validation parameters with their history. The networks' problems (the NFIR's rows, the
NOE's simulation error with forward-mode derivatives) are built in
:mod:`sloshrom.rom.tdnn.training`.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import scipy.linalg

from sloshrom.limits import MU_MAX

__all__ = ["LMProblem", "LMResult", "levenberg_marquardt", "stop_message"]


@dataclass
class LMProblem:
    """A least-squares problem for :func:`levenberg_marquardt`.

    ``normal_eq(theta) -> (JtJ, Jte, sse, n)`` (NumPy float64); ``sse(theta) -> float`` the
    training sum of squared errors on the same samples (``inf`` if the model is non-finite or
    unstable); ``val_mse(theta) -> float`` or None.
    """

    normal_eq: Callable[[Any], tuple[np.ndarray, np.ndarray, float, int]]
    sse: Callable[[Any], float]
    val_mse: Callable[[Any], float] | None = None


@dataclass
class LMResult:
    """The result of a Levenberg-Marquardt fit: parameters, stop reason, history.

    ``stop_info`` is empty unless the stop reason is ``"mu_max"``; then it describes the epoch
    that failed: ``epoch``, ``mu_max``, ``trials`` (steps tried), ``not_solved`` (``J^T J +
    mu I`` not positive definite in floating point, or a non-finite step), ``not_finite``
    (training error inf: a non-finite trial, an NOE beyond its stability bound), ``worse`` (a
    finite error not below the current one), ``shortest_step`` (norm of the last step tried,
    scaled units; NaN if none was solved), ``jtj_max`` (largest diagonal entry of ``J^T J``),
    ``grad`` (gradient norm of the scaled MSE), ``best_epoch`` and ``validation`` (1.0 if the
    problem had a validation error, else 0.0).
    """
    theta: np.ndarray
    stop_reason: str
    history: dict[str, list[float]] = field(default_factory=dict)
    best_epoch: int = 0
    stop_info: dict[str, float] = field(default_factory=dict)


def levenberg_marquardt(
    problem: LMProblem,
    theta0: Any,
    max_epochs: int = 1000,
    mu: float = 1e-3,
    mu_dec: float = 0.1,
    mu_inc: float = 10.0,
    mu_max: float = MU_MAX,
    min_grad: float = 1e-7,
    max_fail: int = 6,
    callback: Callable[[int, dict[str, float]], Any] | None = None,
    mse_scale: float = 1.0,
) -> LMResult:
    """MATLAB ``trainlm`` Levenberg-Marquardt (see the module docstring).

    Parameters
    ----------
    problem : LMProblem
    theta0 : array_like
        Initial parameters.
    max_epochs, mu, mu_dec, mu_inc, mu_max, min_grad, max_fail
        As ``trainlm`` (``epochs``, ``mu``, ``mu_dec``, ``mu_inc``, ``mu_max``, ``min_grad``,
        ``max_fail``).
    callback : callable, optional
        ``callback(epoch, info)`` after every epoch (and epoch 0 = initial state); returning
        True stops the training (stop reason ``"callback"``).
    mse_scale : float
        Factor from the problem's MSE to the reported MSE (e.g. the output half-range squared).

    Returns
    -------
    LMResult
        Best-validation parameters (last ones without validation), the stop reason, the
        per-epoch history (``train_mse``, ``val_mse``, ``mu``, ``grad``, ``seconds``) and, for a
        stop at ``mu_max``, what the failed epoch's trial steps did (``stop_info``).
    """
    theta = np.asarray(theta0, dtype=np.float64).copy()
    p = theta.size
    t0 = time.perf_counter()
    jtj, jte, sse, n = problem.normal_eq(theta)
    vperf = problem.val_mse(theta) if problem.val_mse else math.nan
    best_theta, best_v, best_epoch, fail = theta.copy(), vperf, 0, 0
    hist: dict[str, list[float]] = {k: [] for k in ("train_mse", "val_mse", "mu", "grad",
                                                   "seconds")}

    def record(epoch: int, grad: float) -> bool:
        info = {
            "train_mse": sse / n * mse_scale,
            "val_mse": vperf * mse_scale,
            "mu": mu,
            "grad": grad,
            "seconds": time.perf_counter() - t0,
        }
        for k, v in info.items():
            hist[k].append(float(v))
        # a callback returning True asks to stop (time caps, user interrupt)
        return bool(callback(epoch, info)) if callback is not None else False

    epoch = 0
    grad = 2.0 * float(np.linalg.norm(jte)) / n
    stop = record(0, grad)
    eye = np.eye(p)
    tried = dict.fromkeys(("trials", "not_solved", "not_finite", "worse"), 0)
    last_step = math.nan
    while True:
        if stop:
            reason = "callback"
        elif epoch >= max_epochs:
            reason = "max_epochs"
        elif grad < min_grad:
            reason = "min_grad"
        elif mu > mu_max:
            reason = "mu_max"
        elif problem.val_mse is not None and fail >= max_fail:
            reason = "validation_stop"
        else:
            reason = ""
        if reason:
            break
        epoch += 1
        accepted = False
        # how this epoch's trials failed: if mu passes mu_max, the stop message says which
        tried = dict.fromkeys(("trials", "not_solved", "not_finite", "worse"), 0)
        last_step = math.nan
        while mu <= mu_max:
            tried["trials"] += 1
            try:
                cf = scipy.linalg.cho_factor(jtj + mu * eye, lower=False, check_finite=False)
                step = scipy.linalg.cho_solve(cf, jte, check_finite=False)
                last_step = float(np.linalg.norm(step))
                trial = theta - step
                if np.all(np.isfinite(trial)):
                    sse2 = problem.sse(trial)
                    failure = "worse" if np.isfinite(sse2) else "not_finite"
                else:  # a non-finite solution: the system was not solved
                    sse2, failure = math.inf, "not_solved"
            except np.linalg.LinAlgError:  # not positive definite at this mu: like a failure
                sse2, failure = math.inf, "not_solved"
            if np.isfinite(sse2) and sse2 < sse:
                theta = trial
                mu *= mu_dec
                accepted = True
                break
            tried[failure] += 1
            mu *= mu_inc
        if accepted:
            jtj, jte, sse, n = problem.normal_eq(theta)
            grad = 2.0 * float(np.linalg.norm(jte)) / n
            if problem.val_mse is not None:
                vperf = problem.val_mse(theta)
        if problem.val_mse is not None:
            if vperf < best_v or not np.isfinite(best_v):
                best_theta, best_v, best_epoch, fail = theta.copy(), vperf, epoch, 0
            elif vperf > best_v:
                fail += 1
        stop = record(epoch, grad)
    if problem.val_mse is None:
        best_theta, best_epoch = theta, epoch
    info: dict[str, float] = {}
    if reason == "mu_max":
        info = {"epoch": epoch, "mu_max": mu_max, **tried, "shortest_step": last_step,
                "jtj_max": float(np.max(np.diag(jtj))) if p else 0.0, "grad": grad,
                "best_epoch": best_epoch, "validation": float(problem.val_mse is not None)}
    return LMResult(best_theta, reason, hist, best_epoch, info)


def stop_message(info: dict[str, float]) -> str:
    """Why Levenberg-Marquardt stopped at ``mu_max``, in one paragraph (no advice).

    Parameters
    ----------
    info : dict
        :attr:`LMResult.stop_info` of a stop at ``mu_max``.

    Returns
    -------
    str
        The epoch, what the trial steps did (each count with its cause) and which parameters
        were kept. ``J^T J`` larger than ``mu_max`` over the float64 rounding unit is said to be
        beyond any damping: adding ``mu_max`` to it changes it by less than its own rounding.
    """
    n, mu_max = int(info["trials"]), info["mu_max"]
    mu_text = f"{mu_max:.0e}".replace("e+", "e")  # 1e10, as trainlm's documentation writes it
    head = (f"Levenberg-Marquardt stopped at epoch {int(info['epoch'])}: its damping mu passed "
            f"mu_max = {mu_text} (MATLAB trainlm's 'Maximum MU reached') without a step that "
            "lowered the training error")
    causes = []
    if info["not_solved"]:
        big = info["jtj_max"] * np.finfo(np.float64).eps > mu_max
        causes.append((int(info["not_solved"]), (
            "could not be solved (J^T J + mu I not positive definite in float64; the largest "
            f"diagonal entry of J^T J is {info['jtj_max']:.2g}"
            + (", so even mu_max is below its rounding error: the output's sensitivity to the "
               "weights is enormous" if big else "") + ")")))
    if info["not_finite"]:
        causes.append((int(info["not_finite"]), "gave a non-finite training error (for an NOE: "
                                                "a simulation beyond its stability bound)"))
    if info["worse"]:
        causes.append((int(info["worse"]), (
            f"raised it, down to the shortest step, of norm {info['shortest_step']:.2g} "
            f"(gradient norm {info['grad']:.2g}): a minimum to within rounding, or an error "
            "rougher than its linearisation")))
    best = int(info["best_epoch"])
    if not info.get("validation", 1.0):
        kept = "the last parameters are kept (no validation record)"
    elif best == 0:
        kept = "the initial parameters are kept (best on validation at epoch 0)"
    else:
        kept = f"the parameters of epoch {best} are kept (best on validation)"
    if not causes:
        return f"{head}; {kept}."
    if len(causes) == 1:
        what = causes[0][1]
        if what.startswith("could not"):  # "none could be solved", not "all could not"
            tried = f"None of the {n} trial steps" if n > 1 else "The one trial step"
            what = what.replace("could not", "could", 1) if n > 1 else what
        else:
            tried = f"All {n} trial steps" if n > 1 else "The one trial step"
        return f"{head}. {tried} {what}; {kept}."
    listed = "; ".join(f"{k} {text}" for k, text in causes)
    return f"{head}. Of {n} trial steps, {listed}; {kept}."
