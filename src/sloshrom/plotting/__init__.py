"""Figures of the paper, drawn with matplotlib's object-oriented API.

Every figure is a :class:`matplotlib.figure.Figure` made directly (never through
``matplotlib.pyplot``): it needs no backend, is not registered in pyplot's global figure list
(nothing to close) and ``Figure.savefig`` renders PNG by itself. The library therefore never
selects a backend; an interactive user can still show a figure in their own pyplot session.

Sub-modules: :mod:`~sloshrom.plotting.signals` (VFA paths, identification records, the beam's
base excitation), :mod:`~sloshrom.plotting.maps` (Phi_d maps, hysteresis),
:mod:`~sloshrom.plotting.rom` (sensitivity sweep, validation), :mod:`~sloshrom.plotting.beam`
(sloshing-beam responses). This module only saves figures: importing it does not import
matplotlib.
"""

from __future__ import annotations

import io
from pathlib import Path
from typing import TYPE_CHECKING

from sloshrom.fileio import OutputBatch, atomic_write

if TYPE_CHECKING:
    from matplotlib.figure import Figure

__all__ = ["DPI", "render_png", "savefig"]

#: Resolution of every saved figure, dots per inch.
DPI = 120


def render_png(fig: Figure) -> bytes:
    """``fig`` rendered as a PNG file's bytes (at :data:`DPI` dots per inch), for
    :func:`savefig` to write later: the drawing done while the work it waits for goes on."""
    buf = io.BytesIO()
    fig.savefig(buf, dpi=DPI, format="png")
    return buf.getvalue()


def savefig(fig: Figure | bytes, path: str | Path, batch: OutputBatch | None = None) -> Path:
    """Write ``fig`` as a PNG file, atomically.

    Parameters
    ----------
    fig : matplotlib.figure.Figure or bytes
        The figure to render (at :data:`DPI` dots per inch), or one :func:`render_png` has
        rendered.
    path : str or Path
        The PNG file to write; its directory is created if needed.
    batch : OutputBatch, optional
        Write into this batch (the file appears when the batch commits, together with the
        batch's other files); default: write the file now through
        :func:`sloshrom.fileio.atomic_write`.

    Returns
    -------
    Path
        ``path``.
    """
    write = batch.write if batch is not None else atomic_write
    if isinstance(fig, bytes):
        data = fig

        def copy(tmp: str) -> None:
            Path(tmp).write_bytes(data)

        return write(path, copy)
    # format given explicitly: the temporary file's name does not end in .png
    return write(path, lambda tmp: fig.savefig(tmp, dpi=DPI, format="png"))
