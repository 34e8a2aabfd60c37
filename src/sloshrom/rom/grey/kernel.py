"""The grey box's training step in C: its network's shooting window as an XLA FFI kernel.

:func:`grey_window` is :func:`sloshrom.rom.grey.network.grey_simulate` over a batch of
sub-sequences (the state steps and the output map, the column's features given), with its
gradient by a custom VJP whose reverse pass (backpropagation through time) is a second
kernel. Both are C++ (``window.cc``, built with the package as the extension
``sloshrom.rom.grey._window``, float64 and float32), registered with JAX when this module is
imported; they run inside the compiled epoch like any XLA operation, on XLA's threads, with no
Python (a Dask worker with one thread cannot deadlock on them). The batch's blocks of rows are
shared among XLA's intra-op threads (as many as the process's cores; one in a worker that owns
one core), with the same results to the bit on any number of them.

The same extension runs the network's free run of a few long rows outside XLA
(:func:`free_run_rows`: the validation run of every epoch, a fitted model's predictions), one
row at a time with the neurons as the vector axis, where a block of rows would run one row in
its lanes and ``lax.scan`` pays its loop's overhead at every sample.

Where the extension was not built (no C++ compiler, or a build without jaxlib's headers), or
with ``SLOSHROM_GREY_KERNEL=jax`` in the environment, :func:`kernel_available` is False and the
grey box trains and runs by the pure-JAX path, which stays the reference.
"""

from __future__ import annotations

import importlib
import os
from collections.abc import Callable, Mapping, Sequence
from types import ModuleType

import jax
import jax.numpy as jnp
import numpy as np
from numpy.typing import ArrayLike

from sloshrom.rom.errors import ROMError

__all__ = ["FREE_RUN_ROWS", "KERNEL_ENV", "WEIGHTS", "free_run_rows", "grey_window",
           "kernel_available", "kernel_note"]

#: The environment variable that turns the kernel off (``jax``) for a comparison.
KERNEL_ENV = "SLOSHROM_GREY_KERNEL"
#: The network's arrays the window reads, in the kernel's order.
WEIGHTS = ("A", "W1", "b1", "W2", "C", "V1", "d1", "V2")
#: jax.ShapeDtypeStruct (untyped in jax) as the typed constructor the kernel's results use
_Struct: Callable[[tuple[int, ...], np.dtype], jax.ShapeDtypeStruct] = jax.ShapeDtypeStruct
#: The batch is padded to a multiple of this (64 bytes of float32 rows: the kernel's blocks).
_LANES = 16
#: The most rows a free run takes by :func:`free_run_rows`; more go by ``lax.scan``, whose
#: products over the rows are then as fast (one core, 20,000 samples: 1 row 5.8x faster than
#: ``lax.scan``, 4 rows 3.8x, 32 rows 1.2x, 64 rows 1.1x; ``benchmarks/grey_free_run.py``).
FREE_RUN_ROWS = 32


def _load() -> ModuleType | None:
    try:
        mod = importlib.import_module("sloshrom.rom.grey._window")
    except ImportError:
        return None
    for name, capsule in mod.handlers().items():
        jax.ffi.register_ffi_target(name, capsule, platform="cpu")
    return mod


_MODULE = _load()


def kernel_available() -> bool:
    """Whether the grey box trains with the C kernel (built, and not turned off by
    ``SLOSHROM_GREY_KERNEL=jax``)."""
    return _MODULE is not None and os.environ.get(KERNEL_ENV, "").lower() != "jax"


def kernel_note() -> str | None:
    """One line on why the pure-JAX path trains, or None when the kernel does (logged once a
    training by :func:`sloshrom.rom.grey.training.fit_greybox`)."""
    if _MODULE is None:
        return ("the grey box's compiled training kernel was not built (no C++ compiler or "
                "no jaxlib headers when sloshrom was installed): training by the pure-JAX "
                "path (slower, same model)")
    if not kernel_available():
        return f"{KERNEL_ENV}=jax: the grey box trains by the pure-JAX path"
    return None


def _suffix(dtype: np.dtype) -> str:
    if dtype == np.float64:
        return "f64"
    if dtype == np.float32:
        return "f32"
    raise TypeError(f"the grey window's kernel runs float64 or float32, not {dtype}")


def _forward(w: Sequence[jax.Array], x0: jax.Array, seq: jax.Array
             ) -> tuple[jax.Array, jax.Array, jax.Array, jax.Array]:
    t, _, b = seq.shape
    nx, n = w[0].shape[1], w[1].shape[1]
    dt = seq.dtype
    out = (_Struct((t, b), dt), _Struct((t, nx, b), dt),
           _Struct((t, n, b), dt), _Struct((t, n, b), dt))
    call = jax.ffi.ffi_call(f"sloshrom_grey_forward_{_suffix(dt)}", out,
                            vmap_method="sequential")
    y, xs, hs, gs = call(*w, x0, seq)
    return y, xs, hs, gs


@jax.custom_vjp
def _window(w: tuple[jax.Array, ...], x0: jax.Array, seq: jax.Array) -> jax.Array:
    return _forward(w, x0, seq)[0]


def _window_fwd(w: tuple[jax.Array, ...], x0: jax.Array, seq: jax.Array
                ) -> tuple[jax.Array, tuple[jax.Array, ...]]:
    y, xs, hs, gs = _forward(w, x0, seq)
    return y, (*w, seq, xs, hs, gs)


def _window_bwd(res: tuple[jax.Array, ...], dy: jax.Array
                ) -> tuple[tuple[jax.Array, ...], jax.Array, jax.Array]:
    w, (seq, xs, hs, gs) = res[:8], res[8:]
    dt = seq.dtype
    out = (*(_Struct(a.shape, dt) for a in w), _Struct((xs.shape[1], seq.shape[2]), dt))
    call = jax.ffi.ffi_call(f"sloshrom_grey_backward_{_suffix(dt)}", out,
                            vmap_method="sequential")
    grads = call(*w, seq, xs, hs, gs, dy)
    # the inputs and the features are data, not trained: their cotangent is not computed
    return tuple(grads[:8]), grads[8], jnp.zeros_like(seq)


_window.defvjp(_window_fwd, _window_bwd)


def grey_window(p: Mapping[str, jax.Array], x0: jax.Array, seq: jax.Array,
                r_u: float | jax.Array, r_y: float | jax.Array) -> jax.Array:
    """:func:`~sloshrom.rom.grey.network.grey_simulate` by the C kernel, batch first.

    Parameters
    ----------
    p : mapping
        The network's arrays (:data:`WEIGHTS`; others are ignored), float64 or float32.
    x0 : jax.Array, shape (B, nx)
        The states at the window's start.
    seq : jax.Array, shape (B, T, 1 + 4)
        The scaled input and the scaled features of each sample.
    r_u, r_y : float
        The scaled rest input and output.

    Returns
    -------
    jax.Array, shape (B, T)
        The scaled outputs. Differentiable in ``p`` and ``x0`` (not in ``seq``: its cotangent
        is zero).
    """
    dt = seq.dtype
    w = tuple(jnp.asarray(p[k], dt) for k in WEIGHTS)
    b = seq.shape[0]
    pad = -b % _LANES
    s = jnp.transpose(seq, (1, 2, 0))  # (T, 1 + 4, B): the batch is the kernel's vector axis
    s = s.at[:, 0].add(-jnp.asarray(r_u, dt))
    x = jnp.asarray(x0, dt).T
    if pad:
        # rows of zeros: at rest, output phi[0] = 0, no gradient from them (their dy is 0)
        s = jnp.pad(s, ((0, 0), (0, 0), (0, pad)))
        x = jnp.pad(x, ((0, 0), (0, pad)))
    y = _window(w, x, s)
    return (y[:, :b] + jnp.asarray(r_y, dt)).T


def free_run_rows(p: Mapping[str, ArrayLike], u_s: ArrayLike, phi_s: ArrayLike, x0: ArrayLike,
                  r_u: float, r_y: float) -> np.ndarray | None:
    """:func:`~sloshrom.rom.grey.network.grey_run` in C, float64, one row at a time (the
    neurons as the vector axis): a validation run or a prediction, where a block of rows would
    run one row in its lanes. Not differentiable (NumPy in and out); the GIL is released.

    Parameters
    ----------
    p : mapping
        The network's arrays (:data:`WEIGHTS`; others are ignored).
    u_s : array_like, shape (n, B)
        The scaled inputs.
    phi_s : array_like, shape (n, B, 4)
        The scaled features (the column's, computed before).
    x0 : array_like, shape (B, nx)
        The states at the start.
    r_u, r_y : float
        The scaled rest input and output.

    Returns
    -------
    ndarray, shape (n, B), or None
        The scaled outputs, float64; None where the kernel is not available
        (:func:`kernel_available`) or for more than :data:`FREE_RUN_ROWS` rows: the caller
        runs ``grey_run``.

    Raises
    ------
    ROMError
        Shapes that do not match; a weight whose size does not match ``A``'s and ``W1``'s.
    """
    u = np.asarray(u_s, dtype=np.float64)
    if _MODULE is None or not kernel_available() or u.ndim != 2 or u.shape[1] > FREE_RUN_ROWS:
        return None
    n, b = u.shape
    phi = np.asarray(phi_s, dtype=np.float64)
    w = [np.ascontiguousarray(p[k], dtype=np.float64) for k in WEIGHTS]
    nx, nn = w[0].shape[1], w[1].shape[1]
    x = np.ascontiguousarray(x0, dtype=np.float64)
    if phi.ndim != 3 or phi.shape[:2] != (n, b) or phi.shape[2] < 1 or x.shape != (b, nx):
        raise ROMError(f"free_run_rows: inputs {u.shape}, features {phi.shape} and states "
                       f"{x.shape} do not match (n, B), (n, B, f >= 1) and (B, {nx})")
    nf = 1 + phi.shape[2]
    nz, no = nx + nf, nx + nf - 1
    want = {"A": (nz, nx), "W1": (nz, nn), "b1": (nn,), "W2": (nn, nx), "C": (no,),
            "V1": (no, nn), "d1": (nn,), "V2": (nn,)}
    for k, a in zip(WEIGHTS, w, strict=True):
        if a.shape != want[k]:
            raise ROMError(f"free_run_rows: {k} has shape {a.shape}, not {want[k]} (from "
                           f"{nx} states, {nn} neurons and {nf - 1} features)")
    seq = np.empty((b, n, nf))
    seq[..., 0] = u.T - float(r_u)
    seq[..., 1:] = np.swapaxes(phi, 0, 1)
    y = np.empty((b, n))
    _MODULE.free_run(*w, x, seq, y, nx, nf, nn, n, b)
    return (y + float(r_y)).T
