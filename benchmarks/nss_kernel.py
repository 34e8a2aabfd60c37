"""A lever measured and not adopted: the state-space ROM's training simulation as two compiled
loops (numba), the forward run and its gradient by back-propagation through time, written out,
called from JAX through ``jax.pure_callback`` with a custom VJP (``benchmarks/nss_step.py``
times it against the trainer's XLA simulation).

Not adopted (docs/performance.md, "The NSS step, lever by lever"): 1.45-1.6x faster steps, but
a Python callback inside the compiled epoch deadlocks in a Dask worker whose XLA client has one
thread (JAX puts the callback's arguments on the CPU device, a transfer queued behind the
program that waits for the callback). Safe only as a compiled XLA custom call (FFI), without
Python in the step.

A training step of the NSS simulates a batch of about 150 sub-sequences over
200 samples and differentiates the simulation. XLA runs each sample of that recurrence as some
thirty small products (152 x 9 by 9 x 64 and the like) at about 15 GFLOP/s on one core; these
loops run the same arithmetic with the batch as the innermost, vectorised axis and no per-op
dispatch: the simulation and its gradient in about half the time, the whole Adam step 1.45-1.6x
faster.

The model is the one of :mod:`sloshrom.rom.nss.network` (scaled units, ``z = [x, u]``)::

    x_{k+1} = x_k + z_k A + tanh(z_k W1 + b1) W2 - f0
    y_k     = z_k C + tanh(z_k V1 + d1) V2 + c0

where the rest terms ``f0`` (the state map at rest) and ``c0`` (the output's offset) are computed
by the caller, in JAX, from the parameters: their gradients flow back through it.
:func:`simulate` is a JAX function with its own gradient (``jax.custom_vjp``); both directions
call the loops through ``jax.pure_callback``. Float32 only: the training's precision. The
float64 free runs (validation, maps, the beam) stay in XLA.

``tanh`` is the rational approximation Eigen and XLA use for float32 (maximum error 2.5e-7 on
``[-8, 8]``, saturated beyond), so that the loops vectorise.
"""

from __future__ import annotations

import itertools
import threading
from collections import OrderedDict
from typing import TYPE_CHECKING

import jax
import jax.numpy as jnp
import numpy as np
from numba import njit

if TYPE_CHECKING:
    from collections.abc import Sequence

__all__ = ["WEIGHT_NAMES", "simulate", "tanh32"]

#: The parameter arrays the loops read, in the order :func:`simulate` takes them.
WEIGHT_NAMES = ("A", "W1", "b1", "W2", "C", "V1", "d1", "V2")

F32 = np.float32
_A = tuple(F32(c) for c in (4.89352455891786e-03, 6.37261928875436e-04, 1.48572235717979e-05,
                            5.12229709037114e-08, -8.60467152213735e-11,
                            2.00018790482477e-13, -2.76076847742355e-16))
_B = tuple(F32(c) for c in (4.89352518554385e-03, 2.26843463243900e-03, 1.18534705686654e-04,
                            1.19825839466702e-06))
A1, A3, A5, A7, A9, A11, A13 = _A
B0, B2, B4, B6 = _B
CLAMP = F32(7.90531110763549805)
ONE = F32(1.0)
ZERO = F32(0.0)


# error_model="numpy": no ZeroDivisionError check in the division, which would keep the loops
# from vectorising; fastmath: sums over the batch may be reassociated into vector lanes
@njit(fastmath=True, error_model="numpy", inline="always", cache=True)
def tanh32(x: np.float32) -> np.float32:
    """tanh of a float32 (rational approximation, absolute error <= 2.5e-7)."""
    x = x if x < CLAMP else CLAMP
    x = x if x > -CLAMP else -CLAMP
    x2 = x * x
    p = ((((((A13 * x2 + A11) * x2 + A9) * x2 + A7) * x2 + A5) * x2 + A3) * x2 + A1) * x
    q = ((B6 * x2 + B4) * x2 + B2) * x2 + B0
    return p / q


@njit(fastmath=True, error_model="numpy", boundscheck=False, cache=True)
def _forward(A: np.ndarray, W1: np.ndarray, b1: np.ndarray, W2: np.ndarray, C: np.ndarray,
             V1: np.ndarray, d1: np.ndarray, V2: np.ndarray, f0: np.ndarray, c0: float,
             x0: np.ndarray, u: np.ndarray, Z: np.ndarray, H: np.ndarray, G: np.ndarray,
             Y: np.ndarray) -> None:
    # x0 (nx, B), u (T, B); fills Z (T, nx + 1, B), H and G (T, n, B), Y (T, B). Loops of
    # two or three arrays each, the batch innermost: with more arrays in one loop the compiler
    # no longer proves them apart and stops vectorising
    T, nb = u.shape
    nx = x0.shape[0]
    ni, n = nx + 1, b1.shape[0]
    for t in range(T):
        z = Z[t]
        if t == 0:
            for k in range(nx):
                for b in range(nb):
                    z[k, b] = x0[k, b]
        else:
            zp, hp = Z[t - 1], H[t - 1]
            for k in range(nx):
                xk = z[k]
                for b in range(nb):
                    xk[b] = zp[k, b] - f0[k]
                for i in range(ni):
                    a = A[i, k]
                    for b in range(nb):
                        xk[b] += a * zp[i, b]
                for j in range(n):
                    w = W2[j, k]
                    for b in range(nb):
                        xk[b] += w * hp[j, b]
        for b in range(nb):
            z[nx, b] = u[t, b]
        h, g, y = H[t], G[t], Y[t]
        for b in range(nb):
            y[b] = c0
        for i in range(ni):
            c = C[i]
            for b in range(nb):
                y[b] += c * z[i, b]
        for j in range(n):
            hj, gj = h[j], g[j]
            bj, dj = b1[j], d1[j]
            for b in range(nb):
                hj[b] = bj
                gj[b] = dj
            for i in range(ni):
                w, v = W1[i, j], V1[i, j]
                for b in range(nb):
                    hj[b] += w * z[i, b]
                    gj[b] += v * z[i, b]
            v2 = V2[j]
            for b in range(nb):
                hj[b] = tanh32(hj[b])
                gv = tanh32(gj[b])
                gj[b] = gv
                y[b] += v2 * gv


@njit(fastmath=True, error_model="numpy", boundscheck=False, cache=True)
def _backward(A: np.ndarray, W1: np.ndarray, W2: np.ndarray, C: np.ndarray, V1: np.ndarray,
              V2: np.ndarray, Z: np.ndarray, H: np.ndarray, G: np.ndarray, dY: np.ndarray,
              gA: np.ndarray, gW1: np.ndarray, gb1: np.ndarray, gW2: np.ndarray,
              gC: np.ndarray, gV1: np.ndarray, gd1: np.ndarray, gV2: np.ndarray,
              gf0: np.ndarray, dx0: np.ndarray, du: np.ndarray) -> None:
    # dY (T, B): the outputs' cotangents; accumulates the parameters' (zeroed by the caller)
    # and writes dx0 (nx, B) and du (T, B)
    T, ni, nb = Z.shape
    nx, n = ni - 1, W1.shape[1]
    dx = np.zeros((nx, nb), F32)  # cotangent of x_{t+1}
    dz = np.zeros((ni, nb), F32)
    da = np.zeros(nb, F32)
    dc = np.zeros(nb, F32)
    for t in range(T - 1, -1, -1):
        z, h, g, dy = Z[t], H[t], G[t], dY[t]
        for i in range(ni):
            c = C[i]
            s = ZERO
            for b in range(nb):
                dz[i, b] = c * dy[b]
                s += dy[b] * z[i, b]
            gC[i] += s
        last = t == T - 1  # x_T is not an output: no cotangent
        if not last:
            for k in range(nx):
                s = ZERO
                for b in range(nb):
                    dz[k, b] += dx[k, b]
                    s += dx[k, b]
                gf0[k] -= s
                for i in range(ni):
                    a = A[i, k]
                    s = ZERO
                    for b in range(nb):
                        s += z[i, b] * dx[k, b]
                        dz[i, b] += a * dx[k, b]
                    gA[i, k] += s
        for j in range(n):
            hj, gj = h[j], g[j]
            v2 = V2[j]
            s = ZERO
            for b in range(nb):
                s += dy[b] * gj[b]
                dc[b] = dy[b] * v2 * (ONE - gj[b] * gj[b])
            gV2[j] += s
            for b in range(nb):
                da[b] = ZERO
            if not last:
                for k in range(nx):
                    w = W2[j, k]
                    s = ZERO
                    for b in range(nb):
                        s += hj[b] * dx[k, b]
                        da[b] += w * dx[k, b]
                    gW2[j, k] += s
            s1, s2 = ZERO, ZERO
            for b in range(nb):
                da[b] *= ONE - hj[b] * hj[b]
                s1 += da[b]
                s2 += dc[b]
            gb1[j] += s1
            gd1[j] += s2
            for i in range(ni):
                w, v = W1[i, j], V1[i, j]
                s1, s2 = ZERO, ZERO
                for b in range(nb):
                    zi = z[i, b]
                    s1 += zi * da[b]
                    s2 += zi * dc[b]
                    dz[i, b] += w * da[b] + v * dc[b]
                gW1[i, j] += s1
                gV1[i, j] += s2
        for b in range(nb):
            du[t, b] = dz[nx, b]
        for k in range(nx):
            for b in range(nb):
                dx[k, b] = dz[k, b]
    for k in range(nx):
        for b in range(nb):
            dx0[k, b] = dx[k, b]


# ---------------------------------------------------------------------------------------------
# JAX side
# ---------------------------------------------------------------------------------------------

# The forward run's intermediates (16 MB for the default batch) stay on this side, keyed by a
# ticket the backward pass hands back: they never cross into XLA. A ticket not found (evicted,
# another thread's, a re-executed program) is recomputed, so the result never depends on it.
# Their buffers are reused: allocating 16 MB afresh at every step cost as much as the forward
# run itself (page faults).
_KEEP = 4
Buffers = tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]  # Z, H, G, Y
_kept: OrderedDict[int, Buffers] = OrderedDict()
_free: dict[tuple[int, int, int, int], list[Buffers]] = {}
_lock = threading.Lock()
_tickets = itertools.count(1)


def _arrays(w: Sequence[np.ndarray]) -> list[np.ndarray]:
    return [np.ascontiguousarray(a, dtype=F32) for a in w]


def _take(T: int, ni: int, n: int, nb: int) -> Buffers:
    with _lock:
        free = _free.get((T, ni, n, nb))
        if free:
            return free.pop()
    return (np.empty((T, ni, nb), F32), np.empty((T, n, nb), F32), np.empty((T, n, nb), F32),
            np.empty((T, nb), F32))


def _give(bufs: Buffers) -> None:
    Z, H = bufs[0], bufs[1]
    key = (Z.shape[0], Z.shape[1], H.shape[1], Z.shape[2])
    with _lock:
        free = _free.setdefault(key, [])
        if len(free) < _KEEP:
            free.append(bufs)


def _run(w: Sequence[np.ndarray], f0: np.ndarray, c0: np.ndarray, x0: np.ndarray,
         u: np.ndarray) -> Buffers:
    A, W1, b1, W2, C, V1, d1, V2 = _arrays(w)
    nb, T = u.shape
    bufs = _take(T, A.shape[0], b1.shape[0], nb)
    Z, H, G, Y = bufs
    _forward(A, W1, b1, W2, C, V1, d1, V2, np.ascontiguousarray(f0, F32), F32(c0),
             np.ascontiguousarray(np.asarray(x0, F32).T),
             np.ascontiguousarray(np.asarray(u, F32).T), Z, H, G, Y)
    return bufs


def _forward_host(*args: np.ndarray) -> np.ndarray:
    bufs = _run(args[:8], *args[8:])
    y = np.ascontiguousarray(bufs[3].T)
    _give(bufs)
    return y


def _forward_kept(*args: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    bufs = _run(args[:8], *args[8:])
    ticket = next(_tickets) % 2**31
    with _lock:
        _kept[ticket] = bufs
        old = _kept.popitem(last=False)[1] if len(_kept) > _KEEP else None
    if old is not None:
        _give(old)
    return np.ascontiguousarray(bufs[3].T), np.asarray(ticket, np.int32)


def _backward_host(*args: np.ndarray) -> tuple[np.ndarray, ...]:
    w, (f0, c0, x0, u, ticket, dy) = args[:8], args[8:]
    with _lock:
        bufs = _kept.pop(int(ticket), None)
    if bufs is None:
        bufs = _run(w, f0, c0, x0, u)
    Z, H, G, _ = bufs
    A, W1, b1, W2, C, V1, d1, V2 = _arrays(w)
    nb_, T = np.shape(u)
    nx = A.shape[1]
    grads = [np.zeros_like(a) for a in (A, W1, b1, W2, C, V1, d1, V2)]
    gA, gW1, gb1, gW2, gC, gV1, gd1, gV2 = grads
    gf0 = np.zeros(nx, F32)
    dx0 = np.empty((nx, nb_), F32)
    du = np.empty((T, nb_), F32)
    dyT = np.ascontiguousarray(np.asarray(dy, F32).T)
    _backward(A, W1, W2, C, V1, V2, Z, H, G, dyT, gA, gW1, gb1, gW2, gC, gV1, gd1, gV2, gf0,
              dx0, du)
    _give(bufs)
    return (*grads, gf0, np.asarray(dyT.sum(), F32), np.ascontiguousarray(dx0.T),
            np.ascontiguousarray(du.T))


#: what the backward pass keeps of the forward: weights, f0, c0, x0, u and the ticket
Residuals = tuple[tuple[jax.Array, ...], jax.Array, jax.Array, jax.Array, jax.Array, jax.Array]


def _spec(a: jax.Array) -> jax.ShapeDtypeStruct:
    return jax.ShapeDtypeStruct(np.shape(a), jnp.float32)


@jax.custom_vjp
def _simulate(w: tuple[jax.Array, ...], f0: jax.Array, c0: jax.Array, x0: jax.Array,
              u: jax.Array) -> jax.Array:
    return jax.pure_callback(_forward_host, _spec(u), *w, f0, c0, x0, u)


def _simulate_fwd(w: tuple[jax.Array, ...], f0: jax.Array, c0: jax.Array, x0: jax.Array,
                  u: jax.Array) -> tuple[jax.Array, Residuals]:
    y, ticket = jax.pure_callback(
        _forward_kept, (_spec(u), jax.ShapeDtypeStruct((), jnp.int32)), *w, f0, c0, x0, u)
    return y, (w, f0, c0, x0, u, ticket)


def _simulate_bwd(res: Residuals, dy: jax.Array) -> tuple[object, ...]:
    w, f0, c0, x0, u, ticket = res
    shapes = (*(_spec(a) for a in w), _spec(f0), _spec(c0), _spec(x0), _spec(u))
    out = jax.pure_callback(_backward_host, shapes, *w, f0, c0, x0, u, ticket, dy)
    return tuple(out[:8]), *out[8:]


_simulate.defvjp(_simulate_fwd, _simulate_bwd)


def simulate(weights: Sequence[jax.Array], f0: jax.Array, c0: jax.Array, x0: jax.Array,
             u: jax.Array) -> jax.Array:
    """Outputs of a batch of state-space simulations (float32, scaled units), differentiable.

    Parameters
    ----------
    weights : sequence of jax.Array
        The arrays :data:`WEIGHT_NAMES`: ``A`` (nx + 1, nx), ``W1`` (nx + 1, n), ``b1`` (n,),
        ``W2`` (n, nx), ``C`` (nx + 1,), ``V1`` (nx + 1, n), ``d1`` (n,), ``V2`` (n,).
    f0 : jax.Array, shape (nx,)
        Subtracted from every state increment (the state map at rest).
    c0 : jax.Array, shape ()
        Added to every output.
    x0 : jax.Array, shape (B, nx)
        Initial states.
    u : jax.Array, shape (B, T)
        Scaled inputs.

    Returns
    -------
    jax.Array, shape (B, T)
        The outputs ``y_0 .. y_{T-1}``.
    """
    w = tuple(jnp.asarray(a, jnp.float32) for a in weights)
    return _simulate(w, jnp.asarray(f0, jnp.float32), jnp.asarray(c0, jnp.float32),
                     jnp.asarray(x0, jnp.float32), jnp.asarray(u, jnp.float32))
