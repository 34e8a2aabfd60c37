"""Atomic file writes: write a temporary file in the target's directory, then ``os.replace``.

A reader never sees a half-written file and an interrupted or failed write leaves the previous
file (if any) untouched and no temporary behind.
"""

from __future__ import annotations

import os
import tempfile
from collections.abc import Callable
from pathlib import Path

__all__ = ["atomic_write", "atomic_write_text"]


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


def atomic_write(
    path: str | Path, write: Callable[[str], None], suffix: str | None = None
) -> Path:
    """Write ``path`` atomically through a temporary file in the same directory.

    The parent directory is created if needed. A temporary file named ``.{name}.<random>{suffix}``
    is created beside the target (so the final ``os.replace`` stays on one file system), its
    descriptor is closed and ``write`` is called with its path; the temporary then replaces the
    target. On any exception (including ``KeyboardInterrupt``) the temporary is removed and the
    exception re-raised, leaving a previous version of the target intact.

    Parameters
    ----------
    path : str or Path
        The file to write.
    write : callable
        ``write(tmp_path)`` writes the complete content to the file named ``tmp_path`` (a
        ``str``); it may open the file itself or pass the name to a library writer.
    suffix : str, optional
        Suffix of the temporary file. Defaults to the suffix of ``path``; writers that choose the
        format from the file name (``savefig``, ``np.savez``, ``savemat``, ...) need it.

    Returns
    -------
    Path
        ``path`` as a :class:`~pathlib.Path`.
    """
    p = Path(path)
    p.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(
        dir=p.parent, prefix=f".{p.name}.", suffix=p.suffix if suffix is None else suffix
    )
    os.close(fd)
    try:
        write(tmp)
        # mkstemp makes the file 0600; a result file gets the permissions of an ordinary one
        os.chmod(tmp, 0o666 & ~_umask())
        os.replace(tmp, p)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
    return p


def atomic_write_text(path: str | Path, text: str) -> Path:
    """Write a UTF-8 text file atomically (see :func:`atomic_write`).

    The temporary file ends in ``.tmp`` so that a concurrent ``glob("*.json")`` and the like
    never picks it up.

    Parameters
    ----------
    path : str or Path
        The file to write.
    text : str
        Its complete content.

    Returns
    -------
    Path
        ``path`` as a :class:`~pathlib.Path`.
    """

    def write(tmp: str) -> None:
        with open(tmp, "w", encoding="utf-8") as fh:
            fh.write(text)

    return atomic_write(path, write, suffix=".tmp")
