"""Atomic file writes and output-path checks.

A reader never sees a half-written file (a temporary file in the target's directory, then
``os.replace``), an interrupted or failed write leaves the previous file (if any) untouched and no
temporary behind, and :class:`OutputBatch` makes several files appear together or not at all (a
failed batch also removes the directories it created). :func:`check_output` tells, before any
work starts, whether a path can be written at all and that no input of the command is among what
it writes; :func:`not_a_regular_file` tells why an input path cannot be read as a file.
"""

from __future__ import annotations

import os
import stat
import tempfile
from collections.abc import Callable, Sequence
from pathlib import Path

from sloshrom.errors import SloshromError

__all__ = [
    "OutputBatch", "OutputPathError", "atomic_write", "atomic_write_text", "check_output",
    "not_a_regular_file", "same_file",
]

# Bytes of a temporary name beyond the (possibly shortened) target name: "." + name + "." +
# mkstemp's 8 random characters + the suffix.
_TMP_EXTRA = 2 + 8
_NAME_MAX = 255


class OutputPathError(SloshromError):
    """An output path cannot be written (the message names the path and the reason)."""


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
    target. On any exception (including ``KeyboardInterrupt``) the temporary (and any directory
    the call created) is removed and the exception re-raised, leaving a previous version of the
    target intact.

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
    made = _missing_dirs(p.parent)
    try:
        tmp = _write_temporary(p, write, suffix)
        try:
            os.replace(tmp, p)
        except BaseException:
            Path(tmp).unlink(missing_ok=True)
            raise
    except BaseException:
        for d in reversed(made):  # a failed write leaves no empty directory behind
            try:
                d.rmdir()
            except OSError:
                pass
        raise
    return p


def _temporary_prefix(name: str, suffix: str) -> str:
    # a legal 250-byte name must not become an illegal temporary name: shorten the copy of it
    room = _NAME_MAX - _TMP_EXTRA - len(os.fsencode(suffix))
    raw = os.fsencode(name)[: max(room, 0)]
    return "." + raw.decode(errors="ignore") + "."


def _write_temporary(p: Path, write: Callable[[str], None], suffix: str | None) -> str:
    """Write the complete content to a new temporary file beside ``p``; return its name."""
    p.parent.mkdir(parents=True, exist_ok=True)
    sfx = p.suffix if suffix is None else suffix
    fd, tmp = tempfile.mkstemp(dir=p.parent, prefix=_temporary_prefix(p.name, sfx), suffix=sfx)
    os.close(fd)
    try:
        write(tmp)
        # mkstemp makes the file 0600; a result file gets the permissions of an ordinary one
        os.chmod(tmp, 0o666 & ~_umask())
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
    return tmp


class OutputBatch:
    """Several files that appear together or not at all.

    Each :meth:`write` writes its file completely to a temporary beside the target; leaving the
    ``with`` block without an exception moves every temporary onto its target, an exception
    removes them all and leaves every target as it was. A command that writes a result
    directory uses one batch, so that a failure half-way leaves no partial set of results.

    Examples
    --------
    >>> with OutputBatch() as batch:                                    # doctest: +SKIP
    ...     batch.write("out/a.nc", lambda tmp: ds.to_netcdf(tmp))
    ...     batch.write_text("out/a.md", "| table |")
    """

    def __init__(self) -> None:
        self._pending: list[tuple[str, Path]] = []
        self._made: list[Path] = []  # directories this batch created, outermost first

    def write(
        self, path: str | Path, write: Callable[[str], None], suffix: str | None = None
    ) -> Path:
        """Write ``path``'s content now (to a temporary); it appears when the batch commits."""
        p = Path(path)
        self._made += _missing_dirs(p.parent)
        self._pending.append((_write_temporary(p, write, suffix), p))
        return p

    def write_text(self, path: str | Path, text: str) -> Path:
        """Write ``text`` (UTF-8) to a temporary file, renamed to ``path`` on :meth:`commit`."""
        def write(tmp: str) -> None:
            with open(tmp, "w", encoding="utf-8") as fh:
                fh.write(text)

        return self.write(path, write, suffix=".tmp")

    @property
    def paths(self) -> list[Path]:
        """The targets written so far."""
        return [p for _, p in self._pending]

    def discard(self) -> None:
        """Remove every temporary not yet committed, and the directories the batch created
        (when nothing else was put in them): a failed batch leaves no empty result folder."""
        for tmp, _ in self._pending:
            Path(tmp).unlink(missing_ok=True)
        self._pending.clear()
        for d in reversed(self._made):
            try:
                d.rmdir()  # only if empty: never a file that someone else wrote there
            except OSError:
                pass
        self._made.clear()

    def commit(self) -> None:
        """Rename every pending temporary file onto its path, in the order written."""
        try:
            while self._pending:
                tmp, p = self._pending[0]
                os.replace(tmp, p)
                self._pending.pop(0)
            self._made.clear()  # committed: the directories hold results now
        finally:
            self.discard()

    def __enter__(self) -> OutputBatch:
        return self

    def __exit__(self, exc_type, exc, tb) -> None:
        if exc_type is None:
            self.commit()
        else:
            self.discard()


def _missing_dirs(d: Path) -> list[Path]:
    """The ancestors of ``d`` (``d`` included) that do not exist yet, outermost first."""
    out: list[Path] = []
    while not d.exists() and d != d.parent:
        out.append(d)
        d = d.parent
    return out[::-1]


def not_a_regular_file(path: str | Path) -> str | None:
    """Why an existing ``path`` cannot be read as an input file, or ``None``.

    ``None`` for a regular file (or a link to one) and for a path that does not exist (the
    caller says "no such file" in its own words); otherwise the reason: a directory, a named
    pipe (reading it blocks until another program writes to it), a socket or a device.
    """
    p = Path(path)
    try:
        mode = p.stat().st_mode
    except FileNotFoundError:
        return "a broken symbolic link" if p.is_symlink() else None
    except OSError as exc:
        return f"cannot be read ({exc.strerror or type(exc).__name__})"
    if stat.S_ISREG(mode):
        return None
    if stat.S_ISDIR(mode):
        return "is a directory, expected a file"
    kind = ("a named pipe (FIFO)" if stat.S_ISFIFO(mode) else "a socket" if stat.S_ISSOCK(mode)
            else "a device" if stat.S_ISCHR(mode) or stat.S_ISBLK(mode) else "a special file")
    return f"is {kind}, not a regular file (give a file on disk)"


def _inside(path: str | Path, root: str | Path) -> bool:
    """True if ``path`` is ``root`` or lies under it (real paths: links resolved)."""
    rp, rr = os.path.realpath(path), os.path.realpath(root)
    return rp == rr or rp.startswith(rr.rstrip(os.sep) + os.sep)


def same_file(a: str | Path, b: str | Path) -> bool:
    """True if ``a`` and ``b`` name the same file (existing: same inode; else same real path)."""
    pa, pb = Path(a), Path(b)
    try:
        if pa.exists() and pb.exists():
            return os.path.samefile(pa, pb)
    except OSError:
        pass
    return os.path.realpath(pa) == os.path.realpath(pb)


def check_output(
    path: str | Path,
    *,
    suffixes: tuple[str, ...] | None = None,
    inputs: tuple[str | Path, ...] = (),
    directory: bool = False,
    what: str = "output",
    contents: Sequence[str] = (),
) -> Path:
    """Check that ``path`` can be written, before any work is done.

    Parameters
    ----------
    path : str or Path
        The file (or directory, if ``directory``) to write.
    suffixes : tuple of str, optional
        Accepted suffixes (lower case, with the dot), e.g. ``(".nc", ".csv")``.
    inputs : tuple of paths
        Files the command reads: the output must not be one of them.
    directory : bool
        ``path`` is a results directory (created if missing) rather than a file.
    what : str
        How to name the path in messages (e.g. ``"--out"``).
    contents : sequence of str
        With ``directory``: what the command writes in it, relative names; a name ending in
        ``/`` is a directory whose whole tree the command owns. No input may be one of these
        files or lie in one of these directories.

    Returns
    -------
    Path

    Raises
    ------
    OutputPathError
        Unknown suffix, a name too long for the file system, a directory where a file is
        expected (or the reverse), a parent that is a file or not writable, or an input file
        (the output itself or, for a directory, anything the command writes in it).
    """
    p = Path(path)
    if not str(path).strip():
        raise OutputPathError(f"{what}: empty path")
    for part in p.parts:
        if len(os.fsencode(part)) > _NAME_MAX:
            raise OutputPathError(f"{what} {p}: a path component is longer than {_NAME_MAX} bytes")
    if not directory and p.is_dir():
        raise OutputPathError(f"{what} {p}: is a directory, expected a file name")
    if suffixes is not None and not directory and p.suffix.lower() not in suffixes:
        raise OutputPathError(
            f"{what} {p}: unknown format {p.suffix or '(no suffix)'!r} "
            f"(use {', '.join(suffixes)})"
        )
    for src in inputs:
        if src is not None and same_file(p, src):
            raise OutputPathError(
                f"{what} {p} is also an input of this command: refusing to overwrite it "
                "(choose another output name)"
            )
        for entry in contents if directory and src is not None else ():
            target = p / entry.rstrip("/")
            hit = _inside(src, target) if entry.endswith("/") else same_file(target, src)
            if hit:
                where = f"{target}{os.sep}" if entry.endswith("/") else str(target)
                raise OutputPathError(
                    f"{what} {p}: the command writes {where}, and {src} is also an input of "
                    "this command: refusing to overwrite it (choose another output directory "
                    "or move the input)"
                )
    if directory and p.exists() and not p.is_dir():
        raise OutputPathError(f"{what} {p}: exists and is not a directory")
    # the nearest existing ancestor must be a directory we can create entries in
    anc = p if directory and p.exists() else p.parent
    while not anc.exists() and anc != anc.parent:
        if anc.is_symlink():  # dangling link
            raise OutputPathError(f"{what} {p}: {anc} is a broken symbolic link")
        anc = anc.parent
    if not anc.is_dir():
        raise OutputPathError(f"{what} {p}: {anc} is not a directory")
    if not os.access(anc, os.W_OK | os.X_OK):
        raise OutputPathError(f"{what} {p}: directory {anc} is not writable")
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
