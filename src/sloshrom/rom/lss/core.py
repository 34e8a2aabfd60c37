"""The numerical core of the linear state-space baseline ROM (LSS): identification and simulation.

The model maps a scalar input ``u`` (the tank's vertical velocity, m/s) to a scalar output ``y``
(the dynamic sloshing force, N) at the sample rate of its training record::

    x[k+1] = A x[k] + B u[k],        y[k] = C x[k] + D u[k],        x[0] = 0

It starts at rest and has no offset (``u = 0`` for ever gives ``y = 0``). Shapes are
``A (n, n)``, ``B (n, 1)``, ``C (1, n)``, ``D (1, 1)``; time is the last axis of every signal.

Three pure functions (NumPy/SciPy only, no I/O):

* :func:`n4sid`: subspace identification (PO-MOESP: LQ factor of the block Hankel matrices of
  past and future inputs and outputs, SVD of the projection of the future outputs, Verhaegen
  1994; Van Overschee & De Moor 1996) on the record decimated to its input's band, ``A`` from
  the shift invariance of the extended observability matrix; its eigenvalues, back at the full
  rate and made stable (modulus at most :data:`MAX_SPECTRAL_RADIUS`), give a real modal
  ``A, C``; then ``B, D`` by linear least squares on the simulated response from rest.
* :func:`lss_simulate`: the response from rest, through the real Schur form of ``A`` (an
  orthogonal change of coordinates, so as accurate as the plain recursion) and one first-order
  ``scipy.signal.lfilter`` per real eigenvalue or complex pair.
* :func:`pem_refine`: output-error refinement (least squares on the simulation error, analytic
  Jacobian, the problem compressed to its R factor) in a modal parameterisation whose
  eigenvalues are bounded inside the unit circle.

:func:`n4sid` and :func:`pem_refine` run BLAS on one thread (``threadpoolctl``), the rest of
the process keeps its setting.

Bad input raises :class:`~sloshrom.rom.errors.ROMError` with a message that names the problem.
"""

from __future__ import annotations

import math
import numbers
from typing import Any, cast

import numpy as np
import scipy.linalg
from numpy.lib.stride_tricks import sliding_window_view
from numpy.typing import ArrayLike
from scipy.signal import lfilter, resample_poly, welch
from threadpoolctl import threadpool_limits

from sloshrom.rom.errors import ROMError
from sloshrom.rom.lss.entry import lss_min_samples

__all__ = ["MAX_SPECTRAL_RADIUS", "lss_history_run", "lss_simulate", "min_samples", "n4sid",
           "pem_refine"]

#: Samples of measured history a start from history fits its state to, at most (the last
#: ones): enough for any order the class allows, and a bounded cost.
HISTORY_FIT_SAMPLES = 2000

#: Largest eigenvalue modulus an identified ``A`` may have: a time constant of 1e4 samples
#: (20 s at 500 Hz), far slower than any sloshing dynamics, yet a margin of 1e-4 from the unit
#: circle, so that rounding can never make the model unstable.
MAX_SPECTRAL_RADIUS = 0.9999

#: Hankel columns per block of the incremental QR factorisation (n4sid): a block is
#: ``8192 x 4 block_rows`` floats (2.6 MB for block_rows = 10), whatever the record length.
_QR_BLOCK = 8192

#: Share of the input power that the decimated rate must keep (n4sid), and the slow Nyquist
#: frequency's margin above the frequency that bounds it: ``q = floor(0.4 / nu)``.
_BAND_POWER = 0.999
_DECIMATION_MARGIN = 0.4

#: A modal form whose eigenvector matrix is worse conditioned than this is not used by
#: :func:`pem_refine` (the modal residues would cancel each other in rounding).
_MAX_MODAL_CONDITION = 1e8


# ---------------------------------------------------------------------------------------------
# input checks
def _as_record(name: str, values: Any) -> np.ndarray:
    """A 1-D finite float64 copy of one signal, or a ROMError naming it."""
    try:
        arr = np.array(values, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise ROMError(f"{name} must be an array of numbers: {exc}") from None
    if arr.ndim != 1:
        raise ROMError(f"{name} must be 1-D (one scalar signal, time on the only axis), "
                       f"got shape {arr.shape}")
    if not np.all(np.isfinite(arr)):
        bad = int(np.count_nonzero(~np.isfinite(arr)))
        raise ROMError(f"{name} contains {bad} NaN or inf value(s) "
                       f"(first at sample {int(np.argmax(~np.isfinite(arr)))})")
    return arr


def _check_record(u: Any, y: Any, uname: str = "u", yname: str = "y"
                  ) -> tuple[np.ndarray, np.ndarray]:
    """Input and output as 1-D finite float64 arrays of one length; the input not constant."""
    u = _as_record(uname, u)
    y = _as_record(yname, y)
    if u.size != y.size:
        raise ROMError(f"lengths differ: {uname} has {u.size} samples, {yname} has {y.size}")
    if u.size < 2 or np.ptp(u) == 0.0:
        raise ROMError(f"input {uname} is constant: it excites no dynamics to identify")
    return u, y


def _check_int(name: str, value: Any, minimum: int) -> int:
    if isinstance(value, bool) or not isinstance(value, numbers.Integral):
        raise ROMError(f"{name} must be an integer, got {value!r}")
    if value < minimum:
        raise ROMError(f"{name} must be >= {minimum}, got {value}")
    return int(value)


def _check_system(A: Any, B: Any, C: Any, D: Any
                  ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The four matrices as float64 ``(n, n), (n, 1), (1, n), (1, 1)``, finite, or a ROMError."""
    try:
        A, B, C, D = (np.array(m, dtype=np.float64) for m in (A, B, C, D))
    except (TypeError, ValueError) as exc:
        raise ROMError(f"A, B, C, D must be arrays of numbers: {exc}") from None
    if A.ndim != 2 or A.shape[0] != A.shape[1] or A.shape[0] < 1:
        raise ROMError(f"A must be a square (n, n) matrix with n >= 1, got shape {A.shape}")
    n = A.shape[0]
    if B.size != n or B.ndim > 2 or (B.ndim == 2 and B.shape != (n, 1)):
        raise ROMError(f"B must have shape ({n}, 1) (one input), got {B.shape}")
    if C.size != n or C.ndim > 2 or (C.ndim == 2 and C.shape != (1, n)):
        raise ROMError(f"C must have shape (1, {n}) (one output), got {C.shape}")
    if D.size != 1 or D.ndim > 2:
        raise ROMError(f"D must have shape (1, 1), got {D.shape}")
    for name, m in zip("ABCD", (A, B, C, D), strict=True):
        if not np.all(np.isfinite(m)):
            raise ROMError(f"{name} contains NaN or inf")
    return A, B.reshape(n, 1), C.reshape(1, n), D.reshape(1, 1)


def min_samples(block_rows: int) -> int:
    """Shortest record :func:`n4sid` accepts with ``block_rows`` block rows.

    The block Hankel matrices need ``2 block_rows`` samples per column and
    ``8 block_rows`` columns: ``N >= 10 block_rows - 1``.
    """
    return lss_min_samples({"block_rows": block_rows})


# ---------------------------------------------------------------------------------------------
# simulation
def _first_order(lam: complex | float, v: np.ndarray) -> np.ndarray:
    """``s[k+1] = lam s[k] + v[k]``, ``s[0] = 0`` along the last axis (transfer ``1/(z - lam)``)."""
    s: np.ndarray = lfilter(np.array([0.0, 1.0]), np.array([1.0, -lam]), v, axis=-1)
    return s


def _schur_states(A: np.ndarray, b: np.ndarray, u: np.ndarray
                  ) -> tuple[np.ndarray, np.ndarray]:
    """States from rest of ``x[k+1] = A x[k] + b u[k]`` in real Schur coordinates.

    Returns ``(Q, xt)``: ``A = Q T Q^T`` (``Q`` orthogonal) and the states ``xt = Q^T x`` with
    shape ``(n, *u.shape)``. ``T`` is quasi upper triangular, so the blocks are solved from the
    last up, each driven by the input and the blocks below it: a real eigenvalue is one real
    first-order filter, a complex pair one complex first-order filter in the eigenvector
    coordinates of its 2 x 2 block. Why: an orthogonal transform does not amplify rounding (a
    full eigendecomposition could, for a non-normal ``A``), and a C-coded ``lfilter`` per
    eigenvalue is ~100x faster than a Python loop over samples.
    """
    n = A.shape[0]
    T, Q = scipy.linalg.schur(A, output="real")
    bt = Q.T @ b.reshape(n)
    xt = np.empty((n, *u.shape))
    k = n
    while k > 0:
        size = 2 if k >= 2 and T[k - 1, k - 2] != 0.0 else 1
        lo = k - size
        # input of the block: its share of b u plus the coupling to the blocks below
        v = bt[lo:k].reshape((size,) + (1,) * u.ndim) * u
        for c in range(k, n):  # axpy, not BLAS: a (2, n) x (n, N) product is slower threaded
            v += T[lo:k, c].reshape((size,) + (1,) * u.ndim) * xt[c]
        if size == 1:
            xt[lo] = _first_order(T[lo, lo], v[0])
        else:
            lam, vec = np.linalg.eig(T[lo:k, lo:k])
            j = int(np.argmax(lam.imag))
            W = np.column_stack([vec[:, j], vec[:, j].conj()])
            left = np.linalg.inv(W)[0]
            # the pair's modal coordinate m = F_lam(left . v); the block's states 2 Re(w m).
            # Real and imaginary parts are formed apart: NumPy's complex-scalar times
            # real-array loop is ~20x slower than two real products.
            drive = np.empty(u.shape, dtype=np.complex128)
            drive.real = left[0].real * v[0] + left[1].real * v[1]
            drive.imag = left[0].imag * v[0] + left[1].imag * v[1]
            m = _first_order(lam[j], drive)
            for row in (0, 1):
                w = 2.0 * W[row, 0]
                xt[lo + row] = w.real * m.real - w.imag * m.imag
        k = lo
    return Q, xt


def lss_simulate(A: Any, B: Any, C: Any, D: Any, u: Any) -> np.ndarray:
    """Response of the linear state-space model from rest (``x[0] = 0``).

    Parameters
    ----------
    A, B, C, D : array_like
        The model, shapes ``(n, n)``, ``(n, 1)``, ``(1, n)``, ``(1, 1)`` (``B``, ``C`` may be
        1-D, ``D`` a scalar); ``u`` in the units of the training input (m/s), ``y`` in those of
        the training output (N).
    u : array_like, shape ``(N,)`` or ``(..., N)``
        Input, time on the last axis; leading axes are independent runs (a batch).

    Returns
    -------
    y : ndarray, same shape as ``u``
        Output, N.

    Notes
    -----
    Runs in the real Schur coordinates of ``A`` with one first-order ``lfilter`` per real
    eigenvalue or complex pair: it agrees with the plain recursion to ~1e-13 relative for a
    well-conditioned stable model, and takes ~20 ms for n = 8 and 240 000 samples. An unstable
    ``A`` is simulated as it is (its response grows).

    Raises
    ------
    ROMError
        Wrong shapes, NaN or inf in the model or the input.
    """
    A, B, C, D = _check_system(A, B, C, D)
    try:
        u = np.asarray(u, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise ROMError(f"u must be an array of numbers: {exc}") from None
    if u.ndim < 1:
        raise ROMError("u must have a time axis (shape (N,) or (batch, N)), got a scalar")
    if not np.all(np.isfinite(u)):
        raise ROMError("u contains NaN or inf")
    if u.shape[-1] == 0:
        return np.zeros(u.shape)
    Q, xt = _schur_states(A, B, u)
    y: np.ndarray = D[0, 0] * u
    for c, x in zip((C @ Q)[0], xt, strict=True):
        y += c * x
    return y


def lss_history_run(A: ArrayLike, B: ArrayLike, C: ArrayLike, D: ArrayLike,
                    u_past: ArrayLike, y_past: ArrayLike, u: ArrayLike) -> np.ndarray:
    """Response to ``u`` from the state that the measured history before it gives.

    The state at the history's start is the least-squares fit of the history's output (the
    model's free response from it plus its forced response from rest) over the last
    :data:`HISTORY_FIT_SAMPLES` samples at most, carried to the end of the history by the
    model: for the system the model is, and an output without noise, the start is exact once
    the history holds ``n`` samples (an observable model).

    Parameters
    ----------
    A, B, C, D : array_like
        The model, as :func:`lss_simulate`.
    u_past, y_past : array_like, shape (h,)
        Measured input and output of the ``h >= n`` samples before ``u``, oldest first.
    u : array_like, shape (N,)
        Input from the start on.

    Returns
    -------
    y : ndarray, shape (N,)
        Output.

    Raises
    ------
    ROMError
        Wrong shapes, NaN or inf, a history shorter than the order.
    """
    A, B, C, D = _check_system(A, B, C, D)
    n = A.shape[0]
    # a history at rest is a history: no check of the input's variation
    up, yp = _as_record("history input", u_past), _as_record("history output", y_past)
    if up.size != yp.size:
        raise ROMError(f"lengths differ: the history input has {up.size} samples, its output "
                       f"{yp.size}")
    if up.size < n:
        raise ROMError(f"a start from history needs at least {n} samples (the order), "
                       f"got {up.size}")
    up, yp = up[up.size - min(up.size, HISTORY_FIT_SAMPLES):], \
        yp[yp.size - min(yp.size, HISTORY_FIT_SAMPLES):]
    m = up.size

    def free(x0: np.ndarray, length: int) -> np.ndarray:
        # C A^k x0, k = 0 .. length - 1: the response to a unit pulse through "B" = x0
        pulse = np.zeros(length + 1)
        pulse[0] = 1.0
        return lss_simulate(A, x0.reshape(n, 1), C, np.zeros((1, 1)), pulse)[1:]

    obs = np.stack([free(e, m) for e in np.eye(n)], axis=1)
    x0 = np.linalg.lstsq(obs, yp - lss_simulate(A, B, C, D, up), rcond=None)[0]
    b = B[:, 0]
    for uk in up:  # the state at the end of the history
        x0 = A @ x0 + b * uk
    return np.asarray(lss_simulate(A, B, C, D, u) + free(x0, np.size(u)))


# ---------------------------------------------------------------------------------------------
# subspace identification
def _hankel_r(us: np.ndarray, ys: np.ndarray, i: int) -> np.ndarray:
    """Triangular factor ``R`` of ``H^T = Q R``, ``H = [U_f; U_p; Y_p; Y_f]`` (``4i x j``).

    ``H`` is the stacked block Hankel matrix (``i`` rows each, ``j = N - 2i + 1`` columns); its
    LQ factor is ``L = R^T``. Built block by block (``_QR_BLOCK`` columns at a time, each block
    stacked under the previous ``R``) so memory stays at a few MB on any record length.
    """
    rows = 4 * i
    wu = sliding_window_view(us, 2 * i)  # row c is u[c : c + 2i]: a view, no copy
    wy = sliding_window_view(ys, 2 * i)
    j = wu.shape[0]
    R = np.zeros((0, rows))
    for c0 in range(0, j, _QR_BLOCK):
        c1 = min(c0 + _QR_BLOCK, j)
        top = R.shape[0]
        H = np.empty((top + c1 - c0, rows))
        H[:top] = R
        H[top:, :i] = wu[c0:c1, i:]         # future inputs U_f
        H[top:, i:2 * i] = wu[c0:c1, :i]    # past inputs U_p
        H[top:, 2 * i:3 * i] = wy[c0:c1, :i]  # past outputs Y_p
        H[top:, 3 * i:] = wy[c0:c1, i:]     # future outputs Y_f
        (R,) = scipy.linalg.qr(H, mode="r", overwrite_a=True, check_finite=False)
        R = R[:min(H.shape[0], rows)]
    return R


def _decimation_for(u: np.ndarray, block_rows: int) -> int:
    """Decimation factor that brings the input's band to the slow rate's Nyquist band.

    ``q = floor(0.4 / nu)``, ``nu`` (cycles/sample) the frequency below which 99.9 % of the
    input power lies (Welch): the slow Nyquist frequency ``0.5 / q`` is >= 1.25 ``nu``. 1 for a
    white input; capped so that the decimated record keeps :func:`min_samples` samples.
    """
    f, p = welch(u, nperseg=min(u.size, 4096))
    cum = np.cumsum(p)
    if cum[-1] <= 0.0:
        return 1
    nu = float(f[min(int(np.searchsorted(cum, _BAND_POWER * cum[-1])), f.size - 1)])
    q = int(_DECIMATION_MARGIN / nu) if nu > 0.0 else u.size
    return max(1, min(q, u.size // min_samples(block_rows)))


def _fast_stable_eigenvalues(mu: np.ndarray, q: int, r_max: float = MAX_SPECTRAL_RADIUS
                             ) -> tuple[np.ndarray, np.ndarray]:
    """Eigenvalues at the full rate from those at the rate decimated by ``q``, made stable.

    Returns the real eigenvalues and one of each complex pair (positive imaginary part). A pair
    takes the principal ``q``-th root (angle in ``(0, pi/q)``: inside the slow Nyquist band); a
    real eigenvalue its real root (for a negative one and an even ``q``, which has none, the
    root of its modulus: such a mode sits at the slow Nyquist frequency, which the anti-alias
    filter removed, so it carries no identified dynamics). Then every ``|lambda| >= 1`` is
    reflected to ``1/conj(lambda)`` (same frequency, decay rate equal to the growth rate it
    had), and moduli are capped at ``r_max``.
    """
    real = mu[mu.imag == 0.0].real  # LAPACK: real eigenvalues have an exact zero imaginary part
    pair = mu[mu.imag > 0.0]
    root_r = np.abs(real) ** (1.0 / q)
    lam_r = np.where((real < 0.0) & (q % 2 == 1), -root_r, root_r) if q > 1 else real.copy()
    lam_p = np.abs(pair) ** (1.0 / q) * np.exp(1j * np.angle(pair) / q)

    def inside(lam: np.ndarray) -> np.ndarray:
        mod = np.abs(lam)
        target = np.minimum(np.where(mod >= 1.0, 1.0 / np.maximum(mod, 1.0), mod), r_max)
        return np.where(mod > target, lam * (target / np.where(mod > 0, mod, 1.0)), lam)

    return inside(lam_r).real, inside(lam_p)


def _modal_ac(lam_r: np.ndarray, lam_p: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Real modal ``A`` (1 x 1 and ``[[Re, -Im], [Im, Re]]`` blocks) and an observable ``C``."""
    n = lam_r.size + 2 * lam_p.size
    A, C = np.zeros((n, n)), np.zeros((1, n))
    for m, lam in enumerate(lam_r):
        A[m, m], C[0, m] = lam, 1.0
    for m, lam in enumerate(lam_p):
        k = lam_r.size + 2 * m
        A[k:k + 2, k:k + 2] = [[lam.real, -lam.imag], [lam.imag, lam.real]]
        C[0, k] = 1.0
    return A, C


def _balance_blocks(B: np.ndarray, C: np.ndarray, n_real: int) -> tuple[np.ndarray, np.ndarray]:
    """Scale each modal block's state so that its parts of ``B`` and ``C`` have one norm.

    A scalar scaling of a block commutes with it: the transfer function is unchanged, and the
    states get the size ``sqrt(|input| |output|)`` instead of an arbitrary one.
    """
    B, C = B.copy(), C.copy()
    n = B.shape[0]
    blocks = [slice(m, m + 1) for m in range(n_real)]
    blocks += [slice(k, k + 2) for k in range(n_real, n, 2)]
    for blk in blocks:
        nb, nc = np.linalg.norm(B[blk]), np.linalg.norm(C[0, blk])
        if nb > 0.0 and nc > 0.0:
            s = math.sqrt(nc / nb)
            B[blk] *= s
            C[0, blk] /= s
    return B, C


def _fit_bd(A: np.ndarray, C: np.ndarray, u: np.ndarray, y: np.ndarray
            ) -> tuple[np.ndarray, np.ndarray]:
    """``B, D`` minimising ``sum (y - simulate(A, B, C, D, u))^2`` from rest, ``A, C`` fixed.

    ``y[k] = phi[k] . B + D u[k]`` with ``phi[k] = sum_{m<k} (C A^(k-1-m))^T u[m]``, the state of
    the dual system ``phi[k+1] = A^T phi[k] + C^T u[k]``: one simulation gives all ``n``
    regressors, and the problem is linear.
    """
    n = A.shape[0]
    Q, xt = _schur_states(A.T, C.reshape(n), u)
    M = np.empty((u.size, n + 1))
    M[:, :n] = (Q @ xt).T
    M[:, n] = u
    # equilibrate the columns: the regressors of slow and fast modes differ by orders of size
    scale = np.sqrt(np.mean(M**2, axis=0))
    scale[scale == 0.0] = 1.0
    theta = scipy.linalg.lstsq(M / scale, y, check_finite=False)[0] / scale
    return theta[:n].reshape(n, 1), theta[n:].reshape(1, 1)


# BLAS on one thread (n4sid, pem_refine): their QR and SVD are of tall, thin matrices (a few
# dozen columns); on a loaded 2-core machine a multithreaded BLAS made them 2-10x slower
@threadpool_limits.wrap(limits=1, user_api="blas")  # type: ignore[untyped-decorator]  # no types
def n4sid(u: Any, y: Any, n_states: int, block_rows: int, *, decimation: int | None = None
          ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Identify a stable SISO linear state-space model from one record that starts at rest.

    1. Decimation (why: at 500 Hz a sloshing record is heavily oversampled; a horizon of
       ``block_rows`` samples then spans a small part of a period, the Hankel rows are nearly
       collinear and the subspace estimate drowns in the nonlinear distortion: on the
       240 000-sample toy of the tests, simulation NRMSE 0.89 without, 0.37 with). Input and
       output are low-passed by one FIR filter and decimated by ``q``
       (``scipy.signal.resample_poly``); filtering both by the same filter leaves the
       input-output relation of a linear system unchanged.
    2. Subspace step, PO-MOESP (Verhaegen 1994; Van Overschee & De Moor 1996, ch. 4): the block
       Hankel matrices of future inputs, past inputs and outputs, and future outputs are
       triangularised (the LQ factor, by an incremental QR of their transpose: memory
       independent of the record length); the SVD of the part of the future outputs that the
       past explains beyond the future inputs gives the extended observability matrix (its
       ``n_states`` leading left singular vectors), and ``A`` is the least-squares solution of
       its shift invariance.
    3. Eigenvalues: those of ``A`` are brought back to the full rate (``q``-th roots); every
       ``|lambda| >= 1`` is reflected to ``1/conj(lambda)`` and moduli are capped at
       :data:`MAX_SPECTRAL_RADIUS`. ``A`` is built in real modal form from them (1 x 1 blocks,
       ``[[Re, -Im], [Im, Re]]`` blocks for pairs) with ``C`` selecting each block.
    4. ``B, D`` by linear least squares on the simulated response from rest at the full rate
       (``x0 = 0``: the record starts at rest), more accurate than the subspace ``B, D``; each
       block's state is then scaled so its parts of ``B`` and ``C`` have one norm.

    Parameters
    ----------
    u : array_like, shape ``(N,)``
        Input (tank vertical velocity, m/s), uniformly sampled.
    y : array_like, shape ``(N,)``
        Output (dynamic force, N), same samples.
    n_states : int
        Model order ``n >= 1``.
    block_rows : int
        Block rows ``i`` of each Hankel matrix, ``i > n_states``, typically 10-40 (a horizon of
        ``i q`` samples). Cost ~ ``(N / q) (4 i)^2`` flops; memory ~ ``8192 x 4 i`` floats
        besides the signals.
    decimation : int, optional
        ``q``; by default chosen from the input's spectrum: ``q = floor(0.4 / nu)``, ``nu``
        (cycles/sample) the frequency below which 99.9 % of the input power lies (1 for a white
        input), at most ``N // min_samples(block_rows)``. 1 turns decimation off.

    Returns
    -------
    A : ndarray, shape ``(n, n)``
        State matrix in real modal form, spectral radius <= :data:`MAX_SPECTRAL_RADIUS`.
    B : ndarray, shape ``(n, 1)``
        Input matrix (state per m/s).
    C : ndarray, shape ``(1, n)``
        Output matrix (N per state).
    D : ndarray, shape ``(1, 1)``
        Feedthrough (N s/m).

    Raises
    ------
    ROMError
        NaN or inf in ``u`` or ``y``; lengths differ; not 1-D; ``n_states < 1``;
        ``block_rows <= n_states``; a record shorter than :func:`min_samples` (``10 i - 1``
        samples, ``q`` times more with decimation ``q``); a constant input or output.

    Notes
    -----
    Without decimation, exact (to rounding) on noise-free data of a linear system of order
    <= ``n_states`` with distinct eigenvalues, excited persistently; consistent with white
    output noise. With decimation the slow-rate model approximates the system in the input's
    band, and only its eigenvalues are kept. Signals are scaled to unit RMS inside (without
    removing a mean: the model has no offset). A system with a repeated eigenvalue (a Jordan
    block) is represented by distinct modes only.
    """
    u, y = _check_record(u, y)
    n = _check_int("n_states", n_states, 1)
    i = _check_int("block_rows", block_rows, 2)
    if i <= n:
        raise ROMError(f"block_rows ({i}) must be > n_states ({n}): the shift invariance of "
                       f"the {i}-row observability matrix determines at most {i - 1} states")
    need = min_samples(i)
    if u.size < need:
        raise ROMError(f"record too short: {u.size} samples; block_rows = {i} needs at least "
                       f"{need} (10 * block_rows - 1)")
    if np.ptp(y) == 0.0:
        raise ROMError("output y is constant: there is nothing to identify")
    if decimation is None:
        q = _decimation_for(u, i)
    else:
        q = _check_int("decimation", decimation, 1)
        if u.size // q < need:
            raise ROMError(f"record too short for decimation {q}: {u.size} samples give "
                           f"{u.size // q} after decimation; block_rows = {i} needs {need}")
    # unit RMS keeps the Hankel columns of input and output of one size (force in N is ~1e3
    # times velocity in m/s); no mean is removed, the model has no offset
    su = math.sqrt(float(np.mean(u**2)))
    sy = math.sqrt(float(np.mean(y**2)))
    us, ys = u / su, y / sy
    if q > 1:
        ud, yd = resample_poly(us, 1, q), resample_poly(ys, 1, q)
    else:
        ud, yd = us, ys

    R = _hankel_r(ud, yd, i)
    # L = R^T; L32 = rows of Y_f, columns of the past (U_p, Y_p)
    L32 = R[i:3 * i, 3 * i:4 * i].T
    U, s, _ = scipy.linalg.svd(L32, full_matrices=False, check_finite=False)
    if s[0] == 0.0:
        raise ROMError("the past of the record explains none of its future output: no dynamics "
                       "to identify")
    G = U[:, :n]  # extended observability matrix, orthonormal columns (well conditioned)
    A_slow = scipy.linalg.lstsq(G[:-1], G[1:], check_finite=False)[0]
    lam_r, lam_p = _fast_stable_eigenvalues(np.linalg.eigvals(A_slow), q)
    A, C = _modal_ac(lam_r, lam_p)
    B, D = _fit_bd(A, C, us, ys)
    # back to physical units: u_s = u / su, y = sy y_s
    B, C = _balance_blocks(B / su, C * sy, lam_r.size)
    return A, B, C, D * (sy / su)


# ---------------------------------------------------------------------------------------------
# output-error refinement
class _Modal:
    """Modal parameters: ``H(z) = D + sum_r rho_r/(z - lam_r) + sum_p 2 Re(rho_p/(z - lam_p))``.

    Real modes carry ``(lam, rho)``, complex pairs ``(r, theta, Re rho, Im rho)`` with
    ``lam = r e^(i theta)``, ``theta`` in ``[0, pi]``; then ``D``. The transfer function's
    residues are the identifiable parameters (no state-scaling redundancy); the moduli are
    bounded by ``r_max`` so every iterate is stable. Eigenvalues do not change between real and
    complex during the refinement.
    """

    def __init__(self, n_real: int, n_pair: int, r_max: float) -> None:
        self.n_real, self.n_pair, self.r_max = n_real, n_pair, r_max
        self.size = 2 * n_real + 4 * n_pair + 1

    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        lo = np.full(self.size, -np.inf)
        hi = np.full(self.size, np.inf)
        nr = self.n_real
        lo[0:2 * nr:2], hi[0:2 * nr:2] = -self.r_max, self.r_max
        p0 = 2 * nr
        lo[p0::4][:self.n_pair], hi[p0::4][:self.n_pair] = 0.0, self.r_max
        lo[p0 + 1::4][:self.n_pair], hi[p0 + 1::4][:self.n_pair] = 0.0, np.pi
        return lo, hi

    def unpack(self, p: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray,
                                             float]:
        nr, npair = self.n_real, self.n_pair
        lam_r, rho_r = p[0:2 * nr:2], p[1:2 * nr:2]
        q = p[2 * nr:2 * nr + 4 * npair].reshape(npair, 4)
        lam_p = q[:, 0] * np.exp(1j * q[:, 1])
        rho_p = q[:, 2] + 1j * q[:, 3]
        return lam_r, rho_r, lam_p, rho_p, float(p[-1])

    def filters(self, p: np.ndarray, u: np.ndarray, uc: np.ndarray
                ) -> tuple[list[np.ndarray], list[np.ndarray]]:
        lam_r, _, lam_p, _, _ = self.unpack(p)
        return ([_first_order(lam, u) for lam in lam_r],
                [_first_order(lam, uc) for lam in lam_p])

    def output(self, p: np.ndarray, u: np.ndarray, s_r: list[np.ndarray],
               s_p: list[np.ndarray]) -> np.ndarray:
        _, rho_r, _, rho_p, d = self.unpack(p)
        y = d * u
        for rho, s in zip(rho_r, s_r, strict=True):
            y = y + rho * s
        for rho, s in zip(rho_p, s_p, strict=True):
            y = y + 2.0 * (rho * s).real
        return y

    def simulate(self, p: np.ndarray, u: np.ndarray) -> np.ndarray:
        return self.output(p, u, *self.filters(p, u, u.astype(np.complex128)))

    def jacobian(self, p: np.ndarray, u: np.ndarray, s_r: list[np.ndarray],
                 s_p: list[np.ndarray]) -> np.ndarray:
        """``d y / d p``, shape ``(N, size)``: each sensitivity is itself a filter output.

        ``d s / d lam = F_lam(s)`` for ``s = F_lam(u)`` (``F_lam = 1/(z - lam)``), so one more
        first-order filter per mode gives the derivatives by its eigenvalue.
        """
        lam_r, rho_r, lam_p, rho_p, _ = self.unpack(p)
        J = np.empty((u.size, self.size), order="F")
        for m, (lam, rho, s) in enumerate(zip(lam_r, rho_r, s_r, strict=True)):
            J[:, 2 * m] = rho * _first_order(lam, s)
            J[:, 2 * m + 1] = s
        base = 2 * self.n_real
        theta = p[base + 1:base + 4 * self.n_pair:4]
        for m, (lam, rho, s) in enumerate(zip(lam_p, rho_p, s_p, strict=True)):
            ds = rho * _first_order(lam, s)  # rho d s / d lam
            c = base + 4 * m
            J[:, c] = 2.0 * (ds * np.exp(1j * theta[m])).real  # d lam / d r = e^(i theta)
            J[:, c + 1] = 2.0 * (ds * 1j * lam).real           # d lam / d theta = i lam
            J[:, c + 2] = 2.0 * s.real
            J[:, c + 3] = -2.0 * s.imag
        J[:, -1] = u
        return J

    def realisation(self, p: np.ndarray, gain: float
                    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Real block-diagonal ``(A, B, C, D)``, residues and ``D`` multiplied by ``gain``.

        A real mode is ``A = lam``, a pair the block ``[[Re lam, -Im lam], [Im lam, Re lam]]``
        with ``B = [beta, 0]``, ``C = [2 Re rho, -2 Im rho] / beta``; ``beta`` splits the
        residue evenly between ``B`` and ``C`` (states of the size of the input).
        """
        lam_r, rho_r, lam_p, rho_p, d = self.unpack(p)
        n = self.n_real + 2 * self.n_pair
        A, B, C = np.zeros((n, n)), np.zeros((n, 1)), np.zeros((1, n))
        for m, (lam, rho) in enumerate(zip(lam_r, rho_r * gain, strict=True)):
            beta = math.sqrt(abs(rho)) or 1.0
            A[m, m], B[m, 0], C[0, m] = lam, beta, rho / beta
        for m, (lam, rho) in enumerate(zip(lam_p, rho_p * gain, strict=True)):
            k = self.n_real + 2 * m
            beta = math.sqrt(2.0 * abs(rho)) or 1.0
            A[k:k + 2, k:k + 2] = [[lam.real, -lam.imag], [lam.imag, lam.real]]
            B[k, 0] = beta
            C[0, k], C[0, k + 1] = 2.0 * rho.real / beta, -2.0 * rho.imag / beta
        return A, B, C, np.array([[d * gain]])


def _to_modal(A: np.ndarray, B: np.ndarray, C: np.ndarray, D: np.ndarray, gain: float,
              r_max: float) -> tuple[_Modal, np.ndarray] | None:
    """The modal parameters of ``(A, B, C, D)`` (residues and ``D`` divided by ``gain``).

    None when ``A``'s eigenvectors are too ill-conditioned (near-defective ``A``).
    """
    lam, V = np.linalg.eig(A)
    if not np.isfinite(np.linalg.cond(V)) or np.linalg.cond(V) > _MAX_MODAL_CONDITION:
        return None
    rho = (C @ V)[0] * np.linalg.solve(V, B.astype(np.complex128))[:, 0] / gain
    # LAPACK returns real eigenvalues with a zero imaginary part and pairs exactly conjugate
    real = lam.imag == 0.0
    upper = lam.imag > 0.0
    model = _Modal(int(np.count_nonzero(real)), int(np.count_nonzero(upper)), r_max)
    parts: list[float] = []
    for la, rh in zip(lam[real].real, rho[real].real, strict=True):
        parts += [la, rh]
    for la, rh in zip(lam[upper], rho[upper], strict=True):
        parts += [abs(la), float(np.angle(la)), rh.real, rh.imag]
    parts.append(float(D[0, 0]) / gain)
    lo, hi = model.bounds()
    return model, np.clip(np.array(parts), lo, hi)


def _mse(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.mean((a - b) ** 2))


def _r_factor(J: np.ndarray, r: np.ndarray, chunk: int = 4096) -> np.ndarray:
    """The R factor of the QR decomposition of ``[J r]`` (``N x (n + 1)``), shape
    ``(n + 1, n + 1)`` (zero rows below the ``N``-th when ``N < n + 1``).

    Householder QR of blocks of ``chunk`` rows, then of their stacked R factors (TSQR): each
    block stays in the cache, where LAPACK's QR of the whole tall matrix reads it from memory
    once a column (65 ms against 300 ms for 487,500 x 18 on one core; the same R to 1e-15 of
    its largest entry, up to the signs of its rows).
    """
    A = np.empty((r.size, J.shape[1] + 1))
    A[:, :-1], A[:, -1] = J, r
    m = A.shape[1]
    whole = A.shape[0] // chunk * chunk
    # (NumPy's stubs type mode="r" as the full result)
    blocks = cast("np.ndarray", np.linalg.qr(A[:whole].reshape(-1, chunk, m), mode="r"))
    R = cast("np.ndarray", np.linalg.qr(np.vstack([blocks.reshape(-1, m), A[whole:]]),
                                        mode="r"))
    out = np.zeros((m, m))
    out[:R.shape[0]] = R
    return out


@threadpool_limits.wrap(limits=1, user_api="blas")  # type: ignore[untyped-decorator]  # no types
def pem_refine(A: Any, B: Any, C: Any, D: Any, u: Any, y: Any, max_iter: int,
               validation: tuple[ArrayLike, ArrayLike] | None = None,
               validation_history: int = 0
               ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, dict[str, Any]]:
    """Refine a stable model by minimising its simulation error (output-error method).

    Minimises ``sum (y - lss_simulate(A, B, C, D, u))^2`` (from rest) with
    ``scipy.optimize.least_squares`` (trust-region reflective, analytic Jacobian: the
    sensitivity of ``y`` to each parameter is a first-order filter output) over the modal
    parameters: each real eigenvalue and its residue, each complex pair as modulus, angle and
    complex residue, and ``D``. Moduli are bounded by :data:`MAX_SPECTRAL_RADIUS`, so every
    iterate is stable. Signals are scaled to unit RMS inside.

    Parameters
    ----------
    A, B, C, D : array_like
        Start, shapes ``(n, n)``, ``(n, 1)``, ``(1, n)``, ``(1, 1)``; ``A`` stable.
    u, y : array_like, shape ``(N,)``
        Training input (m/s) and output (N); the record starts at rest.
    max_iter : int
        Most trust-region iterations (trial steps, each one simulation; an accepted one also
        its Jacobian); 0 returns the start.
    validation : (uv, yv), optional
        A validation record: then the accepted iterate (or the start) with the lowest
        validation error is returned (early stopping by selection).
    validation_history : int
        The validation record's first samples taken as measured history
        (:func:`lss_history_run`), not scored; 0: its run starts from rest.

    Returns
    -------
    A, B, C, D : ndarray
        The refined model in real modal form (block-diagonal ``A``: 1 x 1 blocks for real
        eigenvalues, 2 x 2 for pairs), or the start unchanged (a copy) when no iterate beats it.
        Its training error is never above the start's.
    info : dict
        ``initial_mse`` and ``final_mse`` (training, N^2), ``iterations`` (trial steps taken),
        ``validation_mse`` (of the returned model, N^2, or None), ``stop_reason``.

    Raises
    ------
    ROMError
        Bad shapes, NaN or inf, lengths differ, a constant input, ``max_iter < 0``, an unstable
        start (spectral radius >= 1).

    Notes
    -----
    Eigenvalues keep their kind (real or complex pair) from the start; a start whose
    eigenvector matrix is near-singular (condition > 1e8) is returned unrefined, with
    ``stop_reason`` saying so. ``least_squares`` is handed the problem compressed to the R
    factor of ``[J r]`` (``2n + 2`` rows, :func:`_r_factor`): the same cost, gradient and
    Gauss-Newton matrix as the ``N`` residuals, so the same steps up to round-off, without the
    SVD of the ``N x (2n + 1)`` Jacobian at every iteration. Each evaluation (a trial step)
    then costs about ``2n`` first-order filters over the record, its Jacobian and that QR
    factor (~0.2 s for n = 8, 487 500 samples; the SVD alone took 0.26 s).
    """
    from scipy.optimize import least_squares  # scipy's optimisers are imported where used

    A, B, C, D = _check_system(A, B, C, D)
    u, y = _check_record(u, y)
    max_iter = _check_int("max_iter", max_iter, 0)
    val = None
    if validation is not None:
        if not isinstance(validation, tuple | list) or len(validation) != 2:
            raise ROMError("validation must be a pair (uv, yv)")
        val = _check_record(validation[0], validation[1], "validation u", "validation y")
    radius = float(np.max(np.abs(np.linalg.eigvals(A))))
    if radius >= 1.0:
        raise ROMError(f"pem_refine needs a stable start: A has spectral radius {radius:.6g} "
                       ">= 1 (n4sid returns a stable A)")

    start = (A.copy(), B.copy(), C.copy(), D.copy())
    initial_mse = _mse(lss_simulate(A, B, C, D, u), y)
    hv = _check_int("validation_history", validation_history, 0)

    def val_error(a: np.ndarray, b: np.ndarray, c: np.ndarray, d: np.ndarray) -> float:
        uv, yv = cast("tuple[np.ndarray, np.ndarray]", val)
        if hv:
            return _mse(lss_history_run(a, b, c, d, uv[:hv], yv[:hv], uv[hv:]), yv[hv:])
        return _mse(lss_simulate(a, b, c, d, uv), yv)

    start_val = None if val is None else val_error(A, B, C, D)
    info: dict[str, Any] = {"initial_mse": initial_mse, "final_mse": initial_mse,
                            "iterations": 0, "validation_mse": start_val,
                            "stop_reason": "max_iter = 0"}
    if max_iter == 0:
        return (*start, info)
    su = math.sqrt(float(np.mean(u**2)))
    sy = math.sqrt(float(np.mean(y**2))) or 1.0
    gain = sy / su  # residues and D are fitted for unit-RMS signals
    modal = _to_modal(A, B, C, D, gain, MAX_SPECTRAL_RADIUS)
    if modal is None:
        info["stop_reason"] = "start not refined: its eigenvectors are near-singular"
        return (*start, info)
    model, p0 = modal
    us, ys = u / su, y / sy
    usc = us.astype(np.complex128)
    root_n = math.sqrt(us.size)

    # least_squares sees the problem compressed to its R factor: with [J r] = Q [[R, z], [0,
    # rho]], the residual [z, rho] and the Jacobian [R; 0] ((n_p + 1) rows) have the cost,
    # gradient, Gauss-Newton matrix and column norms of r and J (N rows), so the trust-region
    # steps are the same up to round-off, and its SVD of each Jacobian is of n_p + 1 rows
    # instead of N (0.26 s an iteration on a 975 s record, more than its filters and its
    # Jacobian together). Each evaluation then computes its Jacobian too (the one that
    # least_squares asks for next, if it accepts the point).
    cache: dict[str, Any] = {"key": None}
    accepted: list[tuple[np.ndarray, float]] = []  # (params, training mse in N^2)
    best = {"cost": math.inf}
    trials = {"n": -1}  # the first evaluation is the start, not a step

    def residual(p: np.ndarray) -> np.ndarray:
        s_r, s_p = model.filters(p, us, usc)
        r = (model.output(p, us, s_r, s_p) - ys) / root_n
        J = model.jacobian(p, us, s_r, s_p)
        J /= root_n
        R = _r_factor(J, r)
        cache.update(key=p.tobytes(), jac=R[:, :-1])
        f: np.ndarray = R[:, -1]
        cost = float(f @ f)
        trials["n"] += 1
        # the trust-region method accepts a step exactly when it lowers this cost
        if cost < best["cost"]:
            best["cost"] = cost
            if trials["n"] > 0:
                accepted.append((p.copy(), cost * sy**2))
        return f

    def jacobian(p: np.ndarray) -> np.ndarray:
        if cache["key"] != p.tobytes():
            residual(p)
        jac: np.ndarray = cache["jac"]
        return jac

    lo, hi = model.bounds()
    result = least_squares(residual, p0, jac=jacobian, bounds=(lo, hi), method="trf",
                           x_scale="jac", tr_solver="exact", max_nfev=max_iter + 1)
    info["iterations"] = max(trials["n"], 0)
    # least_squares' status in a word: a model file keeps 64 characters of a stop reason
    reason = {0: "max_iter", 1: "gtol", 2: "ftol", 3: "xtol", 4: "ftol and xtol"}.get(
        int(result.status), f"status {result.status}")

    candidates = [(p, mse) for p, mse in accepted if mse < initial_mse]
    if not candidates:
        info["stop_reason"] = f"start kept: no step improved its fit ({reason})"
        return (*start, info)
    if val is None:
        p_best, mse_best = candidates[-1]
        info["stop_reason"] = reason
    else:
        uv, yv = val
        scored = [(val_error(*model.realisation(p, gain)) if hv else
                   _mse(model.simulate(p, uv / su) * sy, yv), p, mse) for p, mse in candidates]
        val_mse, p_best, mse_best = min(scored, key=lambda t: t[0])
        if val_mse >= cast(float, start_val):  # set whenever val is
            info["stop_reason"] = f"start kept: no step improved validation ({reason})"
            return (*start, info)
        info["validation_mse"] = val_mse
        at = next(k for k, c in enumerate(candidates) if c[0] is p_best) + 1
        info["stop_reason"] = f"{reason}; best validation at step {at} of {len(candidates)}"
    info["final_mse"] = mse_best
    return (*model.realisation(p_best, gain), info)
