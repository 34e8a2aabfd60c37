"""SSI-cov: covariance-driven stochastic subspace identification of the first mode, output-only.

The damping estimator ``ssi_cov`` of the random beam tests (B. Peeters and G. De Roeck,
"Reference-based stochastic subspace identification for output-only modal analysis", Mech.
Syst. Signal Process. 13(6), 1999), on the one response channel of the tank acceleration:

1. The response is decimated (zero-phase FIR) to about four times the top of the fitting band,
   so that a few block rows span several periods of the mode and the higher modes are gone.
2. Its unbiased correlations ``R_k`` (``analysis.correlation``), ``k = 1 ... 2i - 1``, fill the
   block Toeplitz matrix ``T[a, b] = R_{i + a - b}`` (``i`` block rows: at least the highest
   model order plus two, and ``block_periods`` periods of ``f1``).
3. ``T = U S V^T``; for each model order ``n = 2, 4, ..., n_max`` the observability matrix
   ``O_n = U_n S_n^(1/2)`` gives the state matrix by its shift structure,
   ``A_n = pinv(O_n[:-1]) O_n[1:]``, and its eigenvalues ``mu`` the poles
   ``lambda = fs_d ln(mu)`` (one per complex pair).
4. The poles of all orders go through the same stabilisation as LSCF's
   (``analysis.stable_pole_cluster``: stable across consecutive orders, physical, within 10 %
   of ``f1``, the cluster spanning most orders): the median frequency and damping ratio.

Its standard deviation and interval come from the generic parametric bootstrap of
``sloshrom.beam.damping.uncertainty`` (``uncertainty = "bootstrap"``: the estimator run on records
simulated from the fitted mode, its bias removed). pyOMA-2's ``SSIcov`` follows the same
algorithm (multichannel, with reference channels); none of its code is used here.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy import linalg, signal

from sloshrom.beam.damping.analysis import AnalysisError, correlation, stable_pole_cluster
from sloshrom.beam.damping.estimators import DampingEstimate, RandomTest, Uncertainty

__all__ = ["SsiCov", "ssi_cov_damping", "ssi_cov_poles"]


def ssi_cov_poles(y: Any, fs: float, block_rows: int, max_order: int) -> dict[str, np.ndarray]:
    """Poles of SSI-cov state-space models of one output channel, orders 2 to ``max_order``.

    Parameters
    ----------
    y : array (n,)
        Response (any unit), sampled at ``fs``.
    fs : float
        Sampling frequency, Hz.
    block_rows : int
        Block rows ``i`` of the Toeplitz matrix (lags ``1 ... 2i - 1``); at least
        ``max_order + 1``.
    max_order : int
        Highest model order (even).

    Returns
    -------
    dict
        A pole table as ``analysis.lscf_poles``: flat arrays ``order`` (-), ``pole`` (complex,
        rad/s), ``frequency`` (Hz), ``zeta`` (-), one entry per pole with ``Im > 0``.
    """
    i = int(block_rows)
    if i <= max_order:
        raise AnalysisError(f"block_rows = {i} must exceed the model order {max_order}")
    _, r = correlation(np.asarray(y, dtype=float), fs, (2 * i - 1) / fs)
    t = linalg.toeplitz(r[i:2 * i], r[i:0:-1])
    u, s, _ = linalg.svd(t)
    orders, poles = [], []
    for n in range(2, int(max_order) + 1, 2):
        o = u[:, :n] * np.sqrt(s[:n])
        a = np.linalg.pinv(o[:-1]) @ o[1:]
        mu = np.linalg.eigvals(a).astype(complex)
        with np.errstate(divide="ignore", invalid="ignore"):
            lam = np.log(mu) * fs
        orders.append(np.full(lam.size, n))
        poles.append(lam)
    order, pole = np.concatenate(orders), np.concatenate(poles)
    keep = np.isfinite(pole) & (pole.imag > 0)  # one per complex pair; real poles are no modes
    order, pole = order[keep], pole[keep]
    w = np.abs(pole)
    return {"order": order, "pole": pole, "frequency": w / (2 * np.pi), "zeta": -pole.real / w}


def ssi_cov_damping(
    y: Any,
    fs: float,
    f_approx: float,
    band: tuple[float, float],
    max_order: int = 40,
    block_periods: float = 8.0,
    **cluster: Any,
) -> dict[str, Any]:
    """First-mode frequency and damping of a response by SSI-cov (module docstring).

    Parameters
    ----------
    y : array (n,)
        Response (any unit).
    fs, f_approx : float
        Sampling frequency and expected natural frequency, Hz.
    band : (float, float)
        Band of interest, Hz: the response is decimated to about ``4 band[1]``.
    max_order : int
        Highest model order (models of order 2, 4, ..., ``max_order``).
    block_periods : float
        Lags spanned by the block rows, in periods of ``f_approx`` (at least).
    **cluster
        Tolerances passed to ``analysis.stable_pole_cluster``.

    Returns
    -------
    dict
        As ``analysis.stable_pole_cluster`` (``frequency``, ``zeta``, ``zeta_iqr``,
        ``n_poles``, ``reason``, ...), plus ``fs_decimated`` (Hz) and ``block_rows`` (-).
    """
    y = np.asarray(y, dtype=float)
    q = max(1, int(fs // (4 * band[1])))
    if q > 1:
        y = signal.decimate(y, q, ftype="fir", zero_phase=True)
    fs_d = fs / q
    i = max(int(max_order) + 2, math.ceil(block_periods * fs_d / f_approx))
    if y.size < 20 * i:
        raise AnalysisError(f"record too short for SSI-cov: {y.size} samples at {fs_d:g} Hz, "
                            f"{20 * i} needed for {i} block rows")
    out = stable_pole_cluster(ssi_cov_poles(y, fs_d, i, int(max_order)), f_approx, **cluster)
    out.update(fs_decimated=fs_d, block_rows=i)
    return out


@dataclass(frozen=True)
class SsiCov:
    """SSI-cov on the tank acceleration (output-only; :func:`ssi_cov_damping`); intervals from
    the parametric bootstrap. Model orders up to ``2 test.pol_order_high``."""

    name: str = "ssi_cov"
    label: str = "SSI-cov"
    uncertainty: Uncertainty = "bootstrap"
    efficiency: float = float("nan")
    block_periods: float = 8.0

    def _one(self, y: np.ndarray, test: RandomTest) -> dict[str, Any]:
        try:
            return ssi_cov_damping(y, test.fs, test.f1, test.fit_band, 2 * test.pol_order_high,
                                   self.block_periods)
        except AnalysisError as e:  # a record SSI cannot analyse: the estimate is missing
            nan = float("nan")
            return {"zeta": nan, "frequency": nan, "zeta_iqr": nan, "n_poles": 0,
                    "reason": str(e)}

    def estimate(self, test: RandomTest) -> DampingEstimate:
        """The raw first-mode damping of one record (the protocol's ``estimate``)."""
        r = self._one(test.response, test)
        return DampingEstimate(value=float(r["zeta"]), frequency=float(r["frequency"]),
                               uncorrected=float(r["zeta"]), reason=str(r["reason"]),
                               iqr=float(r["zeta_iqr"]), n_poles=int(r["n_poles"]))

    def estimate_records(self, records: RandomTest) -> np.ndarray:
        """Damping ratio (-) of each record of a stack, NaN where none (the protocol's
        ``estimate_records``)."""
        return np.array([self._one(y, records)["zeta"] for y in records.response])
