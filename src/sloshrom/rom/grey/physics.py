"""The physical part of the grey-box ROM: an impacting liquid column behind a release gate.

The liquid that takes part in the impacts is ``n_balls`` equal point masses ("balls") of total
mass ``mass`` (kg), each moving vertically in the gap between the liquid surface at rest
(``z = 0``) and the lid (``z = gap``, m), relative to the tank, up positive; the rest of the
liquid moves with the tank. ``g_eff = g + w''`` (``w''`` the tank's vertical acceleration):

* **Release gate** (Rayleigh-Taylor): a bubble-front fraction ``s`` in [0, 1] grows while the
  tank pulls the liquid down faster than gravity (``g_eff < 0``) as
  ``s' = gate_rate (|g_eff| / g)^(1/4)`` (the growth of the fastest capillary-gravity
  wavelength scales so) and relaxes as ``s' = -s / gate_relaxation`` otherwise; ball ``i`` is
  released while ``g_eff < 0`` once ``s >= (i + 1/2) / n_balls``. This finite detachment time is
  what makes the dissipation depend on frequency (a single ball released at once is the
  classical bouncing-ball model, which fits one frequency only).
* **Flight and contacts**: a released ball flies with ``z'' = -g_eff``; against the floor
  (``z < 0``) or the lid (``z > gap``) a compressive-only spring-dashpot acts (per unit mass:
  ``stiffness`` 1/s^2, ``damping`` 1/s); a ball that lands on the floor and starts to rebound
  while ``g_eff > 0`` re-attaches (the rest of its energy is lost).
* **Coherence**: above a few g the fragmented column transmits less momentum: the force is
  multiplied by ``chi = 1 / (1 + (Gamma_lp / coherence_g)^2)``, ``Gamma_lp`` the acceleration
  level ``(pi / 2) |w''| / g`` low-passed with a 0.2 s time constant.
* **Force**: ``dF = -chi m_b sum(z_i'')``: minus the balls' mass times their acceleration
  relative to the tank (N, the package's dynamic force).

Time: each sample interval is ``n_substeps`` semi-implicit Euler sub-steps with the tank
acceleration held (a contact lasts a few ms; the sub-steps resolve it, and the gate's release
instants to a sub-step).

**Strictly proper, with a look-ahead.** The output at sample ``k`` may not read the input at
``k``. After the input ``u_k`` arrives, the interval ``[t_{k-1}, t_k]`` is *committed* with its
exact mean acceleration ``a = (u_k - u_{k-1}) fs`` (the state goes on from there), and the two
next intervals are *predicted* from the committed state with the acceleration extrapolated
linearly (``2 a - a_prev`` and ``3 a - 2 a_prev``). The output at ``k + 1`` is a linear filter
(``taps``, fitted by least squares) of the sub-step forces of the predicted interval around
``t_{k+1}``, the one after it, and the ``n_past - 1`` committed intervals before: a measured
impact is spread by the sensors' zero-phase filters on both sides of its instant, and only a
model that knows it a sample ahead can put the force where the record has it (the record's own
physics, a causal average of the force over the last sample, fits it to 28 %, docs/rom.md).

Three implementations of one step, the same operations in the same order: numba for the
identification and for whole records (:func:`causal_intervals`: many candidate parameter sets
and windows at once, in parallel; the fitted model's ``predict`` and the maps; from
:data:`LANES_FROM` windows on, the windows are the vector axis of one loop, with the same bits
as window by window), JAX for the
fitted model's step (:func:`physics_step`, traced into the coupled beam), and C for the FMU
(``rom/fmu_c/``). The numba and C columns agree to the last bit; XLA's ``exp`` differs from
glibc's in the last bit of some arguments, so the JAX step agrees to about 1e-10 of the force
(the contacts are thresholds). Parameter layout: :data:`PHYS_NAMES`.
"""

from __future__ import annotations

import math

import jax
import jax.numpy as jnp
import numba as nb
import numpy as np
from jax import lax
from numpy.typing import ArrayLike

from sloshrom._jit import njit
from sloshrom.config import G
from sloshrom.rom.errors import ROMError

__all__ = ["COHERENCE_TIME", "PHYS_NAMES", "PhysicsState", "causal_intervals", "design_rows",
           "filter_normal_equations", "filter_output", "grey_features", "interval_forces",
           "physical_parameters", "physics_features", "physics_rest", "physics_step"]

#: The physical parameters, in the order of their array: mass of the balls (kg), contact
#: stiffness and damping per unit mass (1/s^2, 1/s), gap (m), gate rate at |g_eff| = g (1/s),
#: gate relaxation time (s), coherence level (g).
PHYS_NAMES = ("mass", "stiffness", "damping", "gap", "gate_rate", "gate_relaxation",
              "coherence_g")
#: Time constant of the low-passed acceleration level of the coherence factor, s.
COHERENCE_TIME = 0.2


@njit(inline="always")
def _interval(z: np.ndarray, v: np.ndarray, att: np.ndarray, gate: np.ndarray, a: float,
              phys: np.ndarray, h: float, n_sub: int, out: np.ndarray) -> None:
    """One sample interval with the tank acceleration ``a`` held: ``n_sub`` sub-steps of
    length ``h``; updates the balls (``z``, ``v``, ``att``) and ``gate[0]`` in place and writes
    each sub-step's force per unit ball mass (m/s^2, before chi and the mass) into ``out``."""
    n = z.size
    stiff = phys[1]
    damp = phys[2]
    gap = phys[3]
    geff = G + a
    neg = geff < 0.0
    # the gate grows or relaxes: only one of the two rates is needed (the power is costly)
    sdot = phys[4] * (abs(geff) / G) ** 0.25 if neg else 0.0
    decay = 1.0 if neg else math.exp(-h / phys[5])
    alpha = -geff
    s = gate[0]
    first = 0.5 / n  # the gate's level that releases ball 0
    resting = True  # every ball attached (at rest on the floor: no force)
    for i in range(n):
        if att[i] == 0.0:
            resting = False
    for j in range(n_sub):
        if neg:
            s = min(s + sdot * h, 1.0)
        else:
            s *= decay
        if resting and not (neg and s >= first):
            out[j] = -0.0 / (n * h)  # the loop below would find each ball attached
            continue
        resting = True
        dv_sum = 0.0
        for i in range(n):
            if att[i] > 0.0:
                if neg and s >= (i + 0.5) / n:
                    att[i] = 0.0
                else:
                    continue
            zi = z[i]
            vi = v[i]
            f = 0.0
            if zi < 0.0:
                f = max(-stiff * zi - damp * vi, 0.0)
            elif zi > gap:
                f = min(-stiff * (zi - gap) - damp * vi, 0.0)
            vn = vi + h * (alpha + f)
            zn = zi + h * vn
            if zn <= 0.0 and vn >= 0.0 and alpha < 0.0:
                vn = 0.0
                zn = 0.0
                att[i] = 1.0
            dv_sum += vn - vi
            z[i] = zn
            v[i] = vn
            if att[i] == 0.0:
                resting = False
        out[j] = -dv_sum / (n * h)
    gate[0] = s


@njit
def _causal_one(ph: np.ndarray, u: np.ndarray, fs: float, n_balls: int, n_sub: int,
                from_rest: bool, predict_from: int, out: np.ndarray) -> None:
    """One parameter set ``ph`` on one record ``u``: ``out`` of shape (n, 3, n_sub)."""
    n = u.shape[0]
    dt = 1.0 / fs
    h = dt / n_sub
    k1 = 1.0 - math.exp(-dt / COHERENCE_TIME)
    z = np.zeros(n_balls)
    v = np.zeros(n_balls)
    att = np.ones(n_balls)
    gate = np.zeros(1)
    zp = np.zeros(n_balls)
    vp = np.zeros(n_balls)
    attp = np.ones(n_balls)
    gatep = np.zeros(1)
    fc = np.zeros(n_sub)
    f1 = np.zeros(n_sub)
    f2 = np.zeros(n_sub)
    glp = 0.0
    a_prev = 0.0
    u_prev = 0.0 if from_rest else u[0]
    for k in range(n):
        a = (u[k] - u_prev) * fs
        _interval(z, v, att, gate, a, ph, h, n_sub, fc)
        glp += (0.5 * math.pi * abs(a) / G - glp) * k1
        scale = ph[0] / (1.0 + (glp / ph[6]) ** 2)
        if k < predict_from:
            for j in range(n_sub):
                out[k, 0, j] = scale * fc[j]
                out[k, 1, j] = 0.0
                out[k, 2, j] = 0.0
            a_prev = a
            u_prev = u[k]
            continue
        for i in range(n_balls):
            zp[i] = z[i]
            vp[i] = v[i]
            attp[i] = att[i]
        gatep[0] = gate[0]
        _interval(zp, vp, attp, gatep, 2.0 * a - a_prev, ph, h, n_sub, f1)
        _interval(zp, vp, attp, gatep, 3.0 * a - 2.0 * a_prev, ph, h, n_sub, f2)
        for j in range(n_sub):
            out[k, 0, j] = scale * fc[j]
            out[k, 1, j] = scale * f1[j]
            out[k, 2, j] = scale * f2[j]
        a_prev = a
        u_prev = u[k]


# the loop over (set, record) pairs alone is parallel: numba's parfor passes on the whole
# column (three inlined intervals) took twice the compilation (6.5 s against 3.6 s)
@njit(parallel=True)
def _causal_batch(phys: np.ndarray, u: np.ndarray, fs: float, n_balls: int, n_sub: int,
                  from_rest: bool, predict_from: int, out: np.ndarray) -> None:
    n_w = u.shape[0]
    for q in nb.prange(phys.shape[0] * n_w):
        p = q // n_w
        w = q % n_w
        _causal_one(phys[p], u[w], fs, n_balls, n_sub, from_rest, predict_from, out[p, w])


#: Windows a block of :func:`_causal_lanes` (its vector axis): 32 windows of a search's candidate
#: in one block.
LANES = 32
#: Fewer windows than this go window by window (:func:`_causal_batch`): LLVM vectorises the lane
#: loops 16 lanes at a time, and a block of 8 ran its lanes one by one, 1.3 times slower than
#: the windows alone (measured on the default search's windows).
LANES_FROM = 16


@njit(inline="always")
def _interval_lanes(z: np.ndarray, v: np.ndarray, att: np.ndarray, s: np.ndarray, a: np.ndarray,
                    phys: np.ndarray, h: float, n_sub: int, decay: float, out: np.ndarray,
                    nfree: np.ndarray, neg: np.ndarray, sdot: np.ndarray, alpha: np.ndarray,
                    dv: np.ndarray, level: np.ndarray) -> None:
    """:func:`_interval` for ``L`` windows at once, the windows as the vector axis: ``z``,
    ``v``, ``att`` of shape (n_balls, L), the gate ``s`` and acceleration ``a`` (L,), the forces
    into ``out`` (n_sub, L); ``nfree[i]``: the windows in which ball ``i`` flies (kept between
    calls). Every lane takes the same operations, in the same order, as :func:`_interval`;
    a ball is skipped only where no window needs it, so the results are the same bits.
    ``neg`` to ``level`` are scratch arrays of length L."""
    n = z.shape[0]
    n_l = a.shape[0]
    stiff = phys[1]
    damp = phys[2]
    gap = phys[3]
    for m in range(n_l):
        geff = G + a[m]
        is_neg = geff < 0.0
        neg[m] = is_neg
        sdot[m] = phys[4] * (abs(geff) / G) ** 0.25 if is_neg else 0.0
        alpha[m] = -geff
    first = 0.5 / n
    nh = n * h
    flying = 0
    for i in range(n):
        flying += nfree[i]
    for j in range(n_sub):
        top = -1.0  # the highest gate level that may release a ball (-1: none may)
        for m in range(n_l):
            s[m] = min(s[m] + sdot[m] * h, 1.0) if neg[m] else s[m] * decay
        for m in range(n_l):
            level[m] = s[m] if neg[m] else -1.0
            top = max(top, level[m])
        if flying == 0 and not top >= first:
            for m in range(n_l):
                out[j, m] = -0.0 / nh
            continue
        for m in range(n_l):
            dv[m] = 0.0
        flying = 0
        for i in range(n):
            release = (i + 0.5) / n
            if nfree[i] == 0 and not top >= release:
                continue  # attached in every window
            count = 0
            # branch-free, so that LLVM vectorises it: a lane whose ball stays attached
            # computes and keeps its old values
            for m in range(n_l):
                at = att[i, m]
                free = (at == 0.0) | (level[m] >= release)
                zi = z[i, m]
                vi = v[i, m]
                am = alpha[m]
                low = -stiff * zi - damp * vi
                high = -stiff * (zi - gap) - damp * vi
                # max(low, 0.0) and min(high, 0.0) as Python's (signed zeros included), both
                # computed: selects, not branches
                floor = 0.0 if 0.0 > low else low
                lid = 0.0 if 0.0 < high else high
                f = floor if zi < 0.0 else (lid if zi > gap else 0.0)
                vn = vi + h * (am + f)
                zn = zi + h * vn
                lands = (zn <= 0.0) & (vn >= 0.0) & (am < 0.0)
                vn = 0.0 if lands else vn
                zn = 0.0 if lands else zn
                z[i, m] = zn if free else zi
                v[i, m] = vn if free else vi
                att[i, m] = (1.0 if lands else 0.0) if free else at
                dv[m] = dv[m] + (vn - vi) if free else dv[m]
                count += 1 if (free and not lands) else 0
            nfree[i] = count
            flying += count
        for m in range(n_l):
            out[j, m] = -dv[m] / nh


@njit
def _causal_block(ph: np.ndarray, u: np.ndarray, fs: float, n_balls: int, n_sub: int,
                  from_rest: bool, predict_from: int, out: np.ndarray) -> None:
    """:func:`_causal_one` for one parameter set on the L records ``u`` (L, n) at once:
    ``out`` of shape (L, n, 3, n_sub)."""
    n_l, n = u.shape
    dt = 1.0 / fs
    h = dt / n_sub
    k1 = 1.0 - math.exp(-dt / COHERENCE_TIME)
    decay = math.exp(-h / ph[5])  # the value _interval computes for every relaxing interval
    z = np.zeros((n_balls, n_l))
    v = np.zeros((n_balls, n_l))
    att = np.ones((n_balls, n_l))
    s = np.zeros(n_l)
    nfree = np.zeros(n_balls, np.int64)
    zp = np.zeros((n_balls, n_l))
    vp = np.zeros((n_balls, n_l))
    attp = np.ones((n_balls, n_l))
    sp = np.zeros(n_l)
    nfreep = np.zeros(n_balls, np.int64)
    fc = np.zeros((n_sub, n_l))
    f1 = np.zeros((n_sub, n_l))
    f2 = np.zeros((n_sub, n_l))
    neg = np.zeros(n_l, np.bool_)
    sdot = np.zeros(n_l)
    alpha = np.zeros(n_l)
    dv = np.zeros(n_l)
    level = np.zeros(n_l)
    a = np.zeros(n_l)
    ap = np.zeros(n_l)
    a_prev = np.zeros(n_l)
    u_prev = np.zeros(n_l)
    glp = np.zeros(n_l)
    scale = np.zeros(n_l)
    if not from_rest:
        for m in range(n_l):
            u_prev[m] = u[m, 0]
    for k in range(n):
        for m in range(n_l):
            a[m] = (u[m, k] - u_prev[m]) * fs
        _interval_lanes(z, v, att, s, a, ph, h, n_sub, decay, fc, nfree, neg, sdot, alpha, dv,
                        level)
        for m in range(n_l):
            glp[m] += (0.5 * math.pi * abs(a[m]) / G - glp[m]) * k1
            scale[m] = ph[0] / (1.0 + (glp[m] / ph[6]) ** 2)
        if k < predict_from:
            for m in range(n_l):
                for j in range(n_sub):
                    out[m, k, 0, j] = scale[m] * fc[j, m]
                    out[m, k, 1, j] = 0.0
                    out[m, k, 2, j] = 0.0
                a_prev[m] = a[m]
                u_prev[m] = u[m, k]
            continue
        zp[:] = z
        vp[:] = v
        attp[:] = att
        sp[:] = s
        nfreep[:] = nfree
        for m in range(n_l):
            ap[m] = 2.0 * a[m] - a_prev[m]
        _interval_lanes(zp, vp, attp, sp, ap, ph, h, n_sub, decay, f1, nfreep, neg, sdot, alpha, dv,
                        level)
        for m in range(n_l):
            ap[m] = 3.0 * a[m] - 2.0 * a_prev[m]
        _interval_lanes(zp, vp, attp, sp, ap, ph, h, n_sub, decay, f2, nfreep, neg, sdot, alpha, dv,
                        level)
        for m in range(n_l):
            for j in range(n_sub):
                out[m, k, 0, j] = scale[m] * fc[j, m]
                out[m, k, 1, j] = scale[m] * f1[j, m]
                out[m, k, 2, j] = scale[m] * f2[j, m]
            a_prev[m] = a[m]
            u_prev[m] = u[m, k]


@njit(parallel=True)
def _causal_lanes(phys: np.ndarray, u: np.ndarray, fs: float, n_balls: int, n_sub: int,
                  from_rest: bool, predict_from: int, out: np.ndarray, block: int) -> None:
    """:func:`_causal_batch` by blocks of ``block`` windows (the same bits)."""
    n_w = u.shape[0]
    n_b = (n_w + block - 1) // block
    for q in nb.prange(phys.shape[0] * n_b):
        p = q // n_b
        w0 = (q % n_b) * block
        w1 = min(n_w, w0 + block)
        _causal_block(phys[p], u[w0:w1], fs, n_balls, n_sub, from_rest, predict_from,
                      out[p, w0:w1])


def causal_intervals(phys: np.ndarray, u: np.ndarray, fs: float, n_balls: int,
                     n_substeps: int, from_rest: bool = True, predict_from: int = 0,
                     out: np.ndarray | None = None) -> np.ndarray:
    """The sub-step forces each step knows, for parameter sets ``phys`` and velocity records.

    Parameters
    ----------
    phys : ndarray, shape (P, 7)
        Physical parameter sets (:data:`PHYS_NAMES`).
    u : ndarray, shape (W, n)
        Tank velocity records at ``fs``, m/s, each starting at rest.
    fs : float
        Sample rate, Hz.
    n_balls, n_substeps : int
        Balls of the column; sub-steps per sample interval.
    from_rest : bool
        The velocity before each record is zero (a run from rest, as the fitted model's);
        False: the record's first sample (a window cut out of a record).
    predict_from : int
        The first step whose predicted intervals are computed; before it they are zero (a
        warm-up whose outputs are not used: the predictions are two thirds of the work).
    out : ndarray, optional
        A C-contiguous float64 array of the result's shape to write it into: a search that
        simulates thousands of candidates reuses one (a new one each time made the kernel
        find fresh pages for it).

    Returns
    -------
    ndarray, shape (P, W, n, 3, n_substeps)
        At step ``k``: the committed interval ``[t_{k-1}, t_k]`` and the two predicted ones
        after it, each sub-step's force (N, with chi and the mass).
    """
    phys = np.ascontiguousarray(phys, dtype=np.float64)
    u = np.ascontiguousarray(u, dtype=np.float64)
    shape = (phys.shape[0], u.shape[0], u.shape[1], 3, int(n_substeps))
    if out is None:
        out = np.empty(shape)
    elif out.shape != shape or out.dtype != np.float64 or not out.flags.c_contiguous:
        raise ROMError(f"out must be a C-contiguous float64 array of shape {shape}, got "
                       f"{out.dtype} {out.shape}")
    args = (phys, u, float(fs), int(n_balls), int(n_substeps), bool(from_rest),
            int(predict_from), out)
    n_w = u.shape[0]
    if n_w < LANES_FROM:
        _causal_batch(*args)
    else:
        # blocks of at most LANES windows, and one for each of numba's threads where the
        # parameter sets alone leave some idle (a search on one thread: one block)
        blocks = max(-(-n_w // LANES), min(nb.get_num_threads() // max(1, phys.shape[0]),
                                          n_w // LANES_FROM))
        _causal_lanes(*args, -(-n_w // blocks))
    return out


def design_rows(o: np.ndarray, n_past: int, skip: int = 0,
                out: np.ndarray | None = None) -> np.ndarray:
    """The rows of the output filter: for each output sample ``k`` (``o`` of shape
    (..., n, 3, ns) from :func:`causal_intervals`: one record or several), the sub-step forces
    (newest first) of the predicted interval after ``t_k``, the one ending at ``t_k`` and
    ``n_past - 1`` committed intervals before; row 0 (no step before it) is zero.

    ``skip``: the rows from sample ``skip`` on only; ``out``: an array of the result's shape
    to write them into (a search that builds them for many candidates reuses one).

    Returns
    -------
    ndarray, shape (..., n - skip, (n_past + 1) * ns)
    """
    n, ns = o.shape[-3], o.shape[-1]
    shape = (*o.shape[:-3], n - skip, (n_past + 1) * ns)
    d = np.empty(shape) if out is None else out
    if d.shape != shape or not d.flags.c_contiguous:
        raise ROMError(f"out must be a C-contiguous array of shape {shape}, got {d.shape}")
    # newest sub-step first: a reversed view, so that each block of a row is one strided copy
    # of a whole column of intervals (a gather row by row took twice as long)
    rev = np.asarray(o, dtype=np.float64)[..., ::-1]
    for blk in range(n_past + 1):
        # the rows of step k serve the output at k + 1: the predictions one step late,
        # committed interval j one more step each
        kind = 2 if blk == 0 else (1 if blk == 1 else 0)
        lag = 1 if blk < 2 else blk - 1
        first = min(max(0, lag - skip), n - skip)  # rows whose interval is before the record
        block = d[..., blk * ns:(blk + 1) * ns]
        block[..., :first, :] = 0.0
        block[..., first:, :] = rev[..., skip + first - lag:n - lag, kind, :]
    return d


def _filter_blocks(n_past: int) -> list[tuple[int, int]]:
    """(kind, lag) of each block of :func:`design_rows`: kind 2 and 1 (the predicted
    intervals) one step late, then the committed ones (kind 0) at lags 1 .. ``n_past - 1``."""
    return [(2, 1), (1, 1)] + [(0, lag) for lag in range(1, n_past)]


def _check_filter_input(o: np.ndarray, n_past: int, skip: int) -> tuple[int, int, int]:
    """``W, n, ns`` of simulations ``o`` whose filter sums can be taken, or a ROMError."""
    if o.ndim != 4 or o.shape[2] != 3 or o.dtype != np.float64 or not o.flags.c_contiguous:
        raise ROMError(f"o must be a C-contiguous float64 array of shape (W, n, 3, ns), got "
                       f"{o.dtype} {o.shape}")
    w, n, _, ns = o.shape
    if skip < 0:
        raise ROMError(f"skip must be >= 0, got {skip}")
    if n <= skip + n_past:
        raise ROMError(f"the filter's sums need more than skip + n_past = {skip + n_past} "
                       f"samples, got {n}")
    return w, n, ns


def filter_normal_equations(o: np.ndarray, y: np.ndarray, n_past: int, skip: int
                            ) -> tuple[np.ndarray, np.ndarray]:
    """``A.T @ A`` and ``A.T @ y`` of ``A = design_rows(o, n_past, skip)`` over windows,
    without ``A`` (equal to round-off: the sums are taken in another order).

    The blocks of a row are lagged copies of three signals, so their products are a few
    lagged products of ``o`` with itself: one per lag difference over a common range of
    samples, then the few samples where a pair's range differs from it added or taken away.
    That is about the operations of ``A.T @ A`` (a little fewer) without the memory ``A``
    fills, which a search would write and read again for every candidate.

    Parameters
    ----------
    o : ndarray, shape (W, n, 3, ns)
        :func:`causal_intervals` of ``W`` windows (C-contiguous float64).
    y : ndarray, shape (W, n - skip)
        The outputs the rows are fitted to.
    n_past, skip : int
        As :func:`design_rows`; ``n > skip + n_past``.

    Returns
    -------
    gram : ndarray, shape ((n_past + 1) ns, (n_past + 1) ns)
    rhs : ndarray, shape ((n_past + 1) ns,)
    """
    w, n, ns = _check_filter_input(o, n_past, skip)
    y = np.asarray(y, dtype=np.float64)
    if y.shape != (w, n - skip):
        raise ROMError(f"y must have shape {(w, n - skip)}, got {y.shape}")
    z = o.reshape(w, n, 3 * ns)  # the three kinds side by side, oldest sub-step first
    zt = z.transpose(0, 2, 1)

    def lagged(a: int, b: int, d: int, width: int, height: int = 3 * ns) -> np.ndarray:
        """sum over windows and j in [a, b] of z[j] (x) z[j - d], the first ``height`` and the
        last ``width`` columns of z (kind 0 first)."""
        if b < a:
            return np.zeros((height, width))
        return np.matmul(zt[:, :height, a:b + 1], z[:, a - d:b + 1 - d, :width]).sum(axis=0)

    # the master product of lag difference d: the pairs whose first block is at lag 1
    master = {d: lagged(max(skip, 1 + d) - 1, n - 2, d, 3 * ns if d == 0 else ns)
              for d in range(max(1, n_past - 1))}
    blocks = _filter_blocks(n_past)
    nb_ = len(blocks)
    g = np.empty((nb_ * ns, nb_ * ns))
    for i, (k1, l1) in enumerate(blocks):
        for j in range(i, nb_):
            k2, l2 = blocks[j]
            d = l2 - l1  # >= 0: the blocks' lags do not fall
            a, e = max(skip, 1 + d) - 1, n - 2  # the master's range
            a1, e1 = max(skip, l2) - l1, n - 1 - l1  # the pair's own range (j index)
            width = 3 * ns if d == 0 else ns
            # from lag 2 on the blocks are of kind 0 alone (k1 = 0): their rows of the master
            p = master[d] if l1 == 1 else (master[d][:ns] + lagged(a1, a - 1, d, width, ns)
                                            - lagged(e1 + 1, e, d, width, ns))
            # (k2 = 0 whenever d > 0: p's columns are then kind 0's alone); newest first
            blk = p[k1 * ns:(k1 + 1) * ns, k2 * ns:(k2 + 1) * ns][::-1, ::-1]
            g[i * ns:(i + 1) * ns, j * ns:(j + 1) * ns] = blk
            g[j * ns:(j + 1) * ns, i * ns:(i + 1) * ns] = blk.T
    # A.T @ y: the samples of every kind against the outputs one to n_past - 1 steps later,
    # in one product (the outputs before ``skip`` are zeros: no row)
    lags = n_past - 1
    s0 = max(0, skip - lags)
    yl = np.zeros((w, n - 1 - s0, lags))
    for lag in range(1, lags + 1):
        j0 = max(s0, skip - lag)  # the first sample whose output lag steps later is fitted
        yl[:, j0 - s0:n - lag - s0, lag - 1] = y[:, j0 + lag - skip:]
    p = np.matmul(zt[:, :, s0:n - 1], yl).sum(axis=0)
    rhs = np.empty(nb_ * ns)
    for i, (kind, lag) in enumerate(blocks):
        rhs[i * ns:(i + 1) * ns] = p[kind * ns:(kind + 1) * ns, lag - 1][::-1]
    return g, rhs


def filter_output(o: np.ndarray, taps: np.ndarray, n_past: int, skip: int) -> np.ndarray:
    """``design_rows(o, n_past, skip) @ taps`` without the rows (equal to round-off).

    Parameters
    ----------
    o : ndarray, shape (W, n, 3, ns)
        :func:`causal_intervals` of ``W`` windows (C-contiguous float64).
    taps : ndarray, shape ((n_past + 1) ns,)
    n_past, skip : int
        As :func:`design_rows`; ``n > skip + n_past``.

    Returns
    -------
    ndarray, shape (W, n - skip)
    """
    w, n, ns = _check_filter_input(o, n_past, skip)
    blocks = _filter_blocks(n_past)
    # every block's taps on its kind's columns, oldest sub-step first: one product gives each
    # block's contribution at every sample, then shifted by its lag
    t = np.zeros((3 * ns, len(blocks)))
    for i, (kind, _) in enumerate(blocks):
        t[kind * ns:(kind + 1) * ns, i] = taps[i * ns:(i + 1) * ns][::-1]
    c = (o.reshape(w * n, 3 * ns) @ t).reshape(w, n, len(blocks))
    out = np.zeros((w, n - skip))
    for i, (_, lag) in enumerate(blocks):
        first = max(skip, lag)
        out[:, first - skip:] += c[:, first - lag:n - lag, i]
    return out


def physics_features(o: np.ndarray, taps: np.ndarray, n_past: int) -> np.ndarray:
    """The physical part's output and features at each output sample ``k`` (N): the filtered
    force (``taps`` on :func:`design_rows`) and the mean force of the committed interval and of
    the two predicted ones (as step ``k - 1`` knows them; zero at ``k = 0``).

    Parameters
    ----------
    o : ndarray, shape (n, 3, ns)
        :func:`causal_intervals` of one record.
    taps : ndarray, shape ((n_past + 1) * ns,)
        The output filter.
    n_past : int
        Intervals the filter reads at and before the output sample.

    Returns
    -------
    ndarray, shape (n, 4)
    """
    means = np.concatenate([np.zeros((1, 3)), o[:-1].mean(axis=-1)])
    return np.concatenate([(design_rows(o, n_past) @ taps)[:, None], means], axis=1)


def interval_forces(phys: ArrayLike, u: np.ndarray, fs: float, n_balls: int,
                    n_substeps: int) -> np.ndarray:
    """:func:`causal_intervals` for one parameter set and one record: shape (n, 3, ns)."""
    return causal_intervals(np.asarray(phys, dtype=np.float64)[None], np.asarray(u)[None], fs,
                            n_balls, n_substeps)[0, 0]


def grey_features(physics: np.ndarray, taps: np.ndarray, u: np.ndarray, fs: float,
                  n_balls: int, n_substeps: int, n_past: int) -> np.ndarray:
    """The column's features at each output sample of velocity records ``u`` (B, n), each
    from rest: shape (B, n, 4), N (:func:`physics_features`)."""
    u2 = np.atleast_2d(np.asarray(u, dtype=np.float64))
    o = causal_intervals(np.asarray(physics)[None], u2, fs, n_balls, n_substeps)[0]
    return np.stack([physics_features(o[b], taps, n_past) for b in range(u2.shape[0])])


def physical_parameters(beta: float, restitution: float, contact_hz: float, gap_factor: float,
                        log_gate_rate: float, gate_relaxation: float, coherence_g: float,
                        liquid_mass: float, ullage: float) -> np.ndarray:
    """The array of :data:`PHYS_NAMES` from the search's variables.

    Parameters
    ----------
    beta : float
        Share of the liquid mass in the balls, -.
    restitution : float
        Coefficient of restitution of a contact, in [0, 1) (its damping ratio
        ``zeta = -ln e / sqrt(pi^2 + ln^2 e)``).
    contact_hz : float
        Contact frequency, Hz.
    gap_factor : float
        Gap over the ullage, -.
    log_gate_rate : float
        Natural logarithm of the gate rate at ``|g_eff| = g`` (1/s).
    gate_relaxation : float
        Relaxation time of the gate, s.
    coherence_g : float
        Acceleration level of the coherence loss, g.
    liquid_mass, ullage : float
        The tank's liquid mass (kg) and ullage (m).
    """
    wc = 2.0 * math.pi * contact_hz
    le = math.log(max(restitution, 1e-9))
    zeta = -le / math.sqrt(math.pi**2 + le * le)
    return np.array([beta * liquid_mass, wc * wc, 2.0 * zeta * wc, gap_factor * ullage,
                     math.exp(log_gate_rate), gate_relaxation, coherence_g])


# --------------------------------------------------------------------------------------------
# JAX: the fitted model's step (the same arithmetic as _interval and _causal_batch)
# --------------------------------------------------------------------------------------------

#: The physical part's state: balls' position (m), velocity (m/s) and attachment (1/0), each
#: (..., n_balls); gate, low-passed acceleration level (g), the last interval's acceleration
#: (m/s^2) and the last velocity (m/s), each (...); the committed sub-step forces of the last
#: ``n_past - 1`` intervals, newest first (..., (n_past - 1) * ns) (N); the features of the next
#: output (..., 4) (N).
PhysicsState = tuple[jax.Array, ...]


def physics_rest(shape: tuple[int, ...], n_balls: int, n_substeps: int, n_past: int,
                 dtype: type[np.floating] = np.float64) -> PhysicsState:
    """The state at rest: every ball attached, gate closed, no force."""
    zb = jnp.zeros((*shape, n_balls), dtype)
    z = jnp.zeros(shape, dtype)
    return (zb, zb, jnp.ones((*shape, n_balls), dtype), z, z, z, z,
            jnp.zeros((*shape, (n_past - 1) * n_substeps), dtype), jnp.zeros((*shape, 4), dtype))


def _interval_jax(z: jax.Array, v: jax.Array, att: jax.Array, gate: jax.Array, a: jax.Array,
                  phys: jax.Array, h: float, n_sub: int) -> tuple[jax.Array, ...]:
    """:func:`_interval` for arrays (balls on the last axis): returns the new balls and gate
    and the sub-step forces per unit ball mass (..., n_sub)."""
    n = z.shape[-1]
    stiff, damp, gap = phys[1], phys[2], phys[3]
    geff = G + a
    neg = (geff < 0.0)[..., None]
    sdot = phys[4] * (jnp.abs(geff) / G) ** 0.25
    decay = jnp.exp(-h / phys[5])
    alpha = -geff[..., None]
    thresholds = (jnp.arange(n, dtype=z.dtype) + 0.5) / n

    Carry = tuple[jax.Array, jax.Array, jax.Array, jax.Array]

    def sub(carry: Carry, _: None) -> tuple[Carry, jax.Array]:
        z, v, att, gate = carry
        gate = jnp.where(neg[..., 0], jnp.minimum(gate + sdot * h, 1.0), gate * decay)
        att = jnp.where((att > 0.0) & neg & (gate[..., None] >= thresholds), 0.0, att)
        free = att == 0.0
        f = jnp.where(z < 0.0, jnp.maximum(-stiff * z - damp * v, 0.0),
                      jnp.where(z > gap, jnp.minimum(-stiff * (z - gap) - damp * v, 0.0), 0.0))
        vn = v + h * (alpha + f)
        zn = z + h * vn
        land = free & (zn <= 0.0) & (vn >= 0.0) & (alpha < 0.0)
        vn = jnp.where(land, 0.0, vn)
        zn = jnp.where(land, 0.0, zn)
        att = jnp.where(land, 1.0, att)
        dv = jnp.where(free, vn - v, 0.0)
        v = jnp.where(free, vn, v)
        z = jnp.where(free, zn, z)
        return (z, v, att, gate), -jnp.sum(dv, axis=-1) / (n * h)

    # a compiled loop over the sub-steps (an unrolled one makes the coupled beam's program
    # minutes to compile)
    (z, v, att, gate), out = lax.scan(sub, (z, v, att, gate), None, length=n_sub)
    return z, v, att, gate, jnp.moveaxis(out, 0, -1)


def physics_step(phys: jax.Array, taps: jax.Array, state: PhysicsState, u: jax.Array, fs: float,
                 n_substeps: int, n_past: int) -> PhysicsState:
    """Advance the physical part with the velocity sample ``u`` (m/s, shape (...)): commit the
    interval ending now, predict the two after it, and compute the next output's features.

    The output of the current sample is ``state[-1]`` *before* this call (strictly proper).
    """
    z, v, att, gate, glp, a_prev, u_prev, hist, _ = state
    dt = 1.0 / fs
    h = dt / n_substeps
    a = (u - u_prev) * fs
    z, v, att, gate, fc = _interval_jax(z, v, att, gate, a, phys, h, n_substeps)
    glp = glp + (0.5 * math.pi * jnp.abs(a) / G - glp) * (1.0 - math.exp(-dt / COHERENCE_TIME))
    scale = (phys[0] / (1.0 + (glp / phys[6]) ** 2))[..., None]
    fc = scale * fc
    zp, vp, ap, gp, f1 = _interval_jax(z, v, att, gate, 2.0 * a - a_prev, phys, h, n_substeps)
    _, _, _, _, f2 = _interval_jax(zp, vp, ap, gp, 3.0 * a - 2.0 * a_prev, phys, h, n_substeps)
    f1 = scale * f1
    f2 = scale * f2
    hist = jnp.concatenate([fc[..., ::-1], hist[..., :(n_past - 2) * n_substeps]], axis=-1)
    rows = jnp.concatenate([f2[..., ::-1], f1[..., ::-1], hist], axis=-1)
    feat = jnp.stack([rows @ taps, jnp.mean(fc, -1), jnp.mean(f1, -1), jnp.mean(f2, -1)], -1)
    return z, v, att, gate, glp, a, u, hist, feat
