"""Levenberg–Marquardt, MATLAB ``trainlm``'s algorithm, for any least-squares problem.

A problem (:class:`LMProblem`) gives its normal equations ``J^T J``, ``J^T e`` at a parameter
vector, its sum of squared errors and, optionally, a validation error; :func:`levenberg_marquardt`
runs the damped Gauss-Newton iteration with ``trainlm``'s schedule of the damping ``mu`` and its
stopping rules (maximum epochs, ``mu_max``, gradient, validation failures) and returns the
best-validation parameters with their history. The networks' problems (the NFIR's rows, the
NOE's simulation error with forward-mode derivatives) are built in
:mod:`sloshrom.rom.training`.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import scipy.linalg

__all__ = ["LMProblem", "LMResult", "levenberg_marquardt"]


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
    """The result of a Levenberg-Marquardt fit: parameters, stop reason, history."""
    theta: np.ndarray
    stop_reason: str
    history: dict[str, list[float]] = field(default_factory=dict)
    best_epoch: int = 0


def levenberg_marquardt(
    problem: LMProblem,
    theta0: Any,
    max_epochs: int = 1000,
    mu: float = 1e-3,
    mu_dec: float = 0.1,
    mu_inc: float = 10.0,
    mu_max: float = 1e10,
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
        Best-validation parameters (last ones without validation), the stop reason and the
        per-epoch history (``train_mse``, ``val_mse``, ``mu``, ``grad``, ``seconds``).
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
        while mu <= mu_max:
            try:
                cf = scipy.linalg.cho_factor(jtj + mu * eye, lower=False, check_finite=False)
                step = scipy.linalg.cho_solve(cf, jte, check_finite=False)
                trial = theta - step
                sse2 = problem.sse(trial) if np.all(np.isfinite(trial)) else math.inf
            except np.linalg.LinAlgError:  # not positive definite at this mu: like a failure
                sse2 = math.inf
            if np.isfinite(sse2) and sse2 < sse:
                theta = trial
                mu *= mu_dec
                accepted = True
                break
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
    return LMResult(best_theta, reason, hist, best_epoch)


# ---------------------------------------------------------------------------------------------
# Initialisation
# ---------------------------------------------------------------------------------------------
