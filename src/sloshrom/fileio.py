"""Atomic file writes, all-or-nothing batches of files, and output-path checks.

A reader never sees a half-written file (a temporary file in the target's directory, then
``os.replace``), an interrupted or failed write leaves the previous file (if any) untouched and no
temporary behind, and :class:`OutputBatch` makes several files appear together or not at all (a
failed batch also removes the directories it created). :func:`check_output` tells, before any
work starts, whether a path can be written at all and that no input of the command is among what
it writes; :func:`not_a_regular_file` tells why an input path cannot be read as a file.

Failures and kills
------------------
- A write that fails (a full disk: ``ENOSPC``; the file-size limit: ``EFBIG``; a read-only
  folder: ``EROFS``/``EACCES``) raises :class:`OutputWriteError`, one line naming the file, the
  reason and that the previous result is intact. NetCDF files are made in memory
  (:func:`netcdf_writer`) and written with plain Python I/O, so that such an error reaches us as
  an ``OSError`` instead of inside the HDF5 library (which crashed after a failed write).
- A temporary is named ``.{name}.{pid}.{random}{suffix}``: the writer's process id. A process
  killed with ``kill -9`` leaves its temporaries; the next completed write or batch of the same
  target removes those whose process is no longer alive (never another live process's).
- A batch commits through a roll-forward journal: every file is first written completely to its
  temporary; then ``.sloshrom-commit.{pid}.{random}.commit`` is written (atomically) in the
  folder common to the batch's targets, listing the renames; then the temporaries are renamed
  onto their targets and the journal is removed. A commit stopped part-way (killed; or a rename
  that failed, whose journal is then handed to any process: pid 0) leaves its journal: the next
  write whose file lies in that folder or one level below it, and :func:`complete_commits`
  (which ``reproduce`` calls on its whole output tree), perform the remaining renames. A reader
  that calls :func:`complete_commits` first (or any later sloshrom run) sees either the old set
  of files or the new set, complete; a kill before the journal exists leaves the old set. A
  journal of a live process is left to that process. The guarantee covers processes that stop,
  not a power loss (nothing is ``fsync``-ed).
- :func:`folder_lock`: one run at a time in an output folder (``reproduce``).

Files a command did not write
-----------------------------
A command that writes fixed names into a folder the user names (``sloshrom design``'s
``train.csv``, ``analyse example``'s ``decay.uff``) must not replace a file of the same name
that it did not write (a laboratory's own data). A batch made with ``OutputBatch(owner=...)``
records what it wrote in the folder's :data:`WRITTEN` file (name, command, size and SHA-256 of
each file), in the same commit as the files; :func:`check_output` with ``owner`` refuses a
folder where one of the command's files exists but is not recorded as that command's, or has
changed since (:func:`foreign_files`), unless ``overwrite``.

Tests stop a write at a named step: :data:`FAULT_ENV` (``SLOSHROM_FAULT_KILL``, a glob of step
names) kills the process with ``SIGKILL`` at the first matching step, and ``_fault_hook`` is
called with every step name (an in-process test raises from it). Steps: ``written:{name}`` (a
temporary is complete), ``replace:{name}`` (before an atomic write's rename), ``journal`` (the
journal is written), ``rename:{k}`` (before the ``k``-th rename of a commit, from 0),
``renamed`` (every rename done, the journal not yet removed).
"""

from __future__ import annotations

import errno
import fcntl
import fnmatch
import hashlib
import json
import os
import re
import signal
import stat
import tempfile
import time
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from pathlib import Path
from typing import TYPE_CHECKING

from sloshrom.errors import SloshromError

if TYPE_CHECKING:
    import xarray as xr

__all__ = [
    "FAULT_ENV", "WRITTEN", "FolderBusyError", "OutputBatch", "OutputPathError",
    "OutputWriteError", "atomic_write", "atomic_write_text", "check_output", "complete_commits",
    "folder_lock", "foreign_files", "netcdf_writer", "not_a_regular_file", "pid_alive",
    "same_file",
]

# Bytes of a temporary name beyond the (possibly shortened) target name: "." + name + "." +
# the process id (at most 7 digits: pid_max is 4194304) + "." + mkstemp's 8 random characters +
# the suffix.
_TMP_EXTRA = 2 + 8 + 8
_NAME_MAX = 255
_JOURNAL = re.compile(r"^\.sloshrom-commit\.(\d+)\.[^.]+\.(commit|tmp)$")

#: The record, in an output folder, of the files that sloshrom commands wrote there (JSON:
#: ``{"files": {name: {"command", "size", "sha256"}}}``; :func:`foreign_files`).
WRITTEN = ".sloshrom-written.json"

#: Environment variable naming (a glob of) the step at which a test kills the writing process.
FAULT_ENV = "SLOSHROM_FAULT_KILL"
#: Called with the name of every step of a write or a commit (tests only; see the module).
_fault_hook: Callable[[str], None] | None = None

# Why a write failed, in the user's words (the errno's strerror otherwise).
_REASONS = {
    errno.ENOSPC: "no space left on device",
    errno.EFBIG: "file too large (beyond the file-size limit)",
    errno.EDQUOT: "disk quota exceeded",
    errno.EROFS: "read-only file system",
    errno.EACCES: "permission denied",
    errno.EPERM: "operation not permitted",
}


class OutputPathError(SloshromError):
    """An output path cannot be written (the message names the path and the reason)."""


class OutputWriteError(OutputPathError, OSError):
    """Writing an output failed (full disk, file-size limit, read-only folder, ...).

    Both a :class:`~sloshrom.errors.SloshromError` (the command line prints it as one line) and
    an ``OSError`` (``errno`` is the system's); the previous result is intact.
    """


class FolderBusyError(OutputPathError):
    """Another live process holds the lock of an output folder (the message names it)."""


def _step(name: str) -> None:
    """A named step of a write: the tests' fault injection (nothing happens otherwise)."""
    if _fault_hook is not None:
        _fault_hook(name)
    pattern = os.environ.get(FAULT_ENV)
    if pattern and fnmatch.fnmatchcase(name, pattern):
        os.kill(os.getpid(), signal.SIGKILL)


def _write_error(exc: OSError, path: Path, intact: str) -> OutputWriteError:
    """``exc`` (raised while writing ``path``) as one line: the file, the reason, what is intact."""
    if isinstance(exc, OutputWriteError):
        return exc
    reason = _REASONS.get(exc.errno or 0) or exc.strerror or str(exc) or type(exc).__name__
    # name the target, not our temporary (a folder that could not be made keeps its own name)
    named = exc.filename and not os.path.basename(os.fsdecode(exc.filename)).startswith(".")
    where = os.fsdecode(exc.filename) if named else path
    err = OutputWriteError(f"{where}: cannot write: {reason}; {intact}")
    err.errno = exc.errno
    return err


def _intact(p: Path) -> str:
    return f"the previous {p.name} is intact" if p.exists() else f"no {p.name} was written"


def pid_alive(pid: int) -> bool:
    """True if a process ``pid`` exists (one of another user counts as alive)."""
    if pid <= 0:
        return False
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


def atomic_write(
    path: str | Path, write: Callable[[str], None], suffix: str | None = None
) -> Path:
    """Write ``path`` atomically through a temporary file in the same directory.

    The parent directory is created if needed. A temporary file named
    ``.{name}.{pid}.<random>{suffix}`` is created beside the target (so the final ``os.replace``
    stays on one file system), its descriptor is closed and ``write`` is called with its path;
    the temporary then replaces the target, and temporaries of the same target left by killed
    processes are removed. On any exception (including ``KeyboardInterrupt``) the temporary (and
    any directory the call created) is removed and the exception re-raised (an ``OSError`` as
    :class:`OutputWriteError`), leaving a previous version of the target intact.

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

    Raises
    ------
    OutputWriteError
        The file system refused the write (the message names the file and the reason).
    """
    p = Path(path)
    made = _missing_dirs(p.parent)
    intact = _intact(p)
    try:
        complete_commits(p.parent, recursive=False)
        tmp = _write_temporary(p, write, suffix)
        try:
            _step(f"replace:{p.name}")
            os.replace(tmp, p)
        except BaseException:
            Path(tmp).unlink(missing_ok=True)
            raise
    except BaseException as exc:
        for d in reversed(made):  # a failed write leaves no empty directory behind
            try:
                d.rmdir()
            except OSError:
                pass
        if isinstance(exc, OSError):
            raise _write_error(exc, p, intact) from exc
        raise
    _remove_stale(p)
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
    prefix = f"{_temporary_prefix(p.name, sfx)}{os.getpid()}."
    fd, tmp = tempfile.mkstemp(dir=p.parent, prefix=prefix, suffix=sfx)
    os.close(fd)
    try:
        write(tmp)
        # mkstemp makes the file 0600; a result file gets the permissions of an ordinary one
        os.chmod(tmp, 0o666 & ~_umask())
        _step(f"written:{p.name}")
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
    return tmp


def _remove_stale(p: Path) -> None:
    """Remove the temporaries of target ``p`` whose writing process is no longer alive.

    Temporaries of the current process (its own pending batch) and of live processes stay, and
    so do old temporaries without a process id (nothing tells whether their writer still runs).
    """
    # the copy of the name in a temporary is shortened by the suffix's length (long names only)
    prefixes = {_temporary_prefix(p.name, "x" * k) for k in range(33)}
    alternatives = "|".join(re.escape(s) for s in sorted(prefixes))
    pattern = re.compile(rf"^(?:{alternatives})(\d+)\.[a-z0-9_]{{8}}")
    try:
        entries = list(os.scandir(p.parent))
    except OSError:
        return
    for entry in entries:
        m = pattern.match(entry.name)
        if m is None:
            continue
        pid = int(m.group(1))
        if pid == os.getpid() or pid_alive(pid):
            continue
        try:
            os.unlink(entry.path)
        except OSError:
            pass


def complete_commits(folder: str | Path, *, recursive: bool = True) -> list[Path]:
    """Finish the batch commits that stopped part-way in ``folder`` (roll forward).

    Each journal ``.sloshrom-commit.{pid}.{random}.commit`` whose process is no longer alive
    lists the renames of one batch; those not done yet are done now (every temporary was
    complete before its journal was written), then the journal is removed. Half-written journals
    (``.tmp``: the commit had not started) of dead processes are removed with the temporaries
    they would have listed left to :func:`atomic_write`'s clean-up.

    Parameters
    ----------
    folder : str or Path
        A results folder.
    recursive : bool
        Also the folders under it.

    Returns
    -------
    list of Path
        The targets renamed into place now.
    """
    done: list[Path] = []
    root = Path(folder)
    if not root.is_dir():
        return done
    walk = os.walk(root) if recursive else [(str(root), [], [])]
    for d, _, _ in walk:
        try:
            names = sorted(e.name for e in os.scandir(d) if _JOURNAL.match(e.name))
        except OSError:
            continue
        for name in names:
            m = _JOURNAL.match(name)
            assert m is not None
            pid = int(m.group(1))
            if pid == os.getpid() or pid_alive(pid):
                continue
            journal = Path(d) / name
            if m.group(2) == "commit":
                done += _roll_forward(journal)
            journal.unlink(missing_ok=True)
    return done


def _roll_forward(journal: Path) -> list[Path]:
    """The renames that ``journal`` lists and that are not done yet, done."""
    try:
        renames = json.loads(journal.read_text(encoding="utf-8"))["renames"]
    except (OSError, ValueError, KeyError, TypeError):
        return []  # unreadable: leave the files as they are
    done = []
    for tmp, target in renames:
        src, dst = journal.parent / tmp, journal.parent / target
        if src.exists():
            os.replace(src, dst)
            done.append(dst)
    return done


class OutputBatch:
    """Several files that appear together or not at all.

    Each :meth:`write` writes its file completely to a temporary beside the target; leaving the
    ``with`` block without an exception commits: a journal listing the renames is written, every
    temporary is moved onto its target and the journal removed (a commit stopped part-way is
    finished by the next run: :func:`complete_commits`). An exception removes the temporaries
    and leaves every target as it was. A command that writes a result directory uses one batch,
    so that a failure half-way leaves no partial set of results.

    Parameters
    ----------
    owner : str, optional
        The command that writes the batch (``"sloshrom design"``): the commit also records
        its files in each folder's :data:`WRITTEN` file, so that a later run of the command
        may replace them and another file of the same name is refused (:func:`check_output`).

    Examples
    --------
    >>> with OutputBatch() as batch:                                    # doctest: +SKIP
    ...     batch.write("out/a.nc", netcdf_writer(ds))
    ...     batch.write_text("out/a.md", "| table |")
    """

    def __init__(self, owner: str | None = None) -> None:
        self.owner = owner
        self._pending: list[tuple[str, Path]] = []
        self._made: list[Path] = []  # directories this batch created, outermost first
        self._seen: set[Path] = set()  # folders whose unfinished commits were completed

    def write(
        self, path: str | Path, write: Callable[[str], None], suffix: str | None = None
    ) -> Path:
        """Write ``path``'s content now (to a temporary); it appears when the batch commits.

        Raises
        ------
        OutputWriteError
            The file system refused the write (full disk, read-only folder, ...).
        """
        p = Path(path)
        for d in (p.parent, p.parent.parent):  # a journal sits in the batch's common folder
            if d not in self._seen:
                self._seen.add(d)
                try:
                    complete_commits(d, recursive=False)
                except OSError as exc:
                    raise _write_error(exc, p, _intact(p)) from exc
        self._made += _missing_dirs(p.parent)
        try:
            self._pending.append((_write_temporary(p, write, suffix), p))
        except OSError as exc:
            raise _write_error(exc, p, "the previous results are intact") from exc
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
        """Move every pending temporary onto its path, all or nothing (through a journal).

        Raises
        ------
        OutputWriteError
            The journal could not be written (nothing changed: the temporaries are removed),
            or a rename failed part-way (the journal stays: the next run completes the batch).
        """
        if not self._pending:
            self.discard()
            return
        if self.owner is not None:
            try:
                self._record_written(self.owner)
            except BaseException as exc:
                self.discard()
                if isinstance(exc, OSError):
                    raise _write_error(exc, self._pending[0][1],
                                       "the previous results are intact") from exc
                raise
        targets = [p for _, p in self._pending]
        try:
            journal = self._write_journal()
        except BaseException as exc:
            self.discard()
            if isinstance(exc, OSError):
                raise _write_error(exc, targets[0], "the previous results are intact") from exc
            raise
        _step("journal")
        try:
            for k, (tmp, p) in enumerate(self._pending):
                _step(f"rename:{k}")
                os.replace(tmp, p)
        except OSError as exc:
            self._pending.clear()  # listed in the journal: the next run completes them
            self._made.clear()
            journal = _abandon(journal)
            raise _write_error(exc, p, f"the batch's journal {journal} lists the files still to "
                                       "move: the next sloshrom run writing there completes it") \
                from exc
        _step("renamed")
        journal.unlink(missing_ok=True)
        self._pending.clear()
        self._made.clear()  # committed: the directories hold results now
        for p in targets:
            _remove_stale(p)

    def _record_written(self, owner: str) -> None:
        """Add the updated :data:`WRITTEN` record of each folder of the batch to the batch:
        its files as ``owner``'s, with the size and digest of their complete temporaries (the
        record commits with them, all or nothing)."""
        folders: dict[Path, list[tuple[str, Path]]] = {}
        for tmp, p in self._pending:
            folders.setdefault(p.parent, []).append((tmp, p))
        for folder, files in folders.items():
            record = {name: entry for name, entry in _read_written(folder).items()
                      if (folder / name).exists()}  # a file removed since is forgotten
            for tmp, p in files:
                record[p.name] = {"command": owner, "size": os.path.getsize(tmp),
                                  "sha256": _digest(tmp)}
            self.write_text(folder / WRITTEN, json.dumps({"files": record}, indent=1) + "\n")

    def _write_journal(self) -> Path:
        """Write the commit journal (atomically) in the folder common to every target."""
        folder = Path(os.path.commonpath([os.path.abspath(p.parent) for _, p in self._pending]))
        renames = [[os.path.relpath(os.path.abspath(t), folder),
                    os.path.relpath(os.path.abspath(p), folder)] for t, p in self._pending]
        text = json.dumps({"pid": os.getpid(), "renames": renames}, indent=1)
        fd, tmp = tempfile.mkstemp(dir=folder, prefix=f".sloshrom-commit.{os.getpid()}.",
                                   suffix=".tmp")
        try:
            with os.fdopen(fd, "w", encoding="utf-8") as fh:
                fh.write(text)
            journal = Path(tmp).with_suffix(".commit")
            os.replace(tmp, journal)
        except BaseException:
            Path(tmp).unlink(missing_ok=True)
            raise
        return journal

    def __enter__(self) -> OutputBatch:
        return self

    def __exit__(self, exc_type, exc, tb) -> None:
        if exc_type is None:
            self.commit()
        else:
            self.discard()


def _abandon(journal: Path) -> Path:
    """Hand an unfinished commit's journal to any process: process id 0, never alive."""
    left = journal.with_name(re.sub(r"^(\.sloshrom-commit\.)\d+\.", r"\g<1>0.", journal.name))
    try:
        os.replace(journal, left)
    except OSError:
        return journal  # then it is completed once this process has ended
    return left


def netcdf_writer(ds: xr.Dataset) -> Callable[[str], None]:
    """A ``write(tmp)`` for :func:`atomic_write`/:meth:`OutputBatch.write`: ``ds`` as NetCDF-4.

    The file's bytes are made in memory now (h5netcdf: the peak memory grows by the file's size,
    +32 MB for a 32 MB file; results are a few MB) and written by plain Python I/O, so that a
    full disk or the file-size limit is an ``OSError`` here, not a failure inside HDF5 (which
    crashed the process after a failed write).

    Parameters
    ----------
    ds : xarray.Dataset
        What to write.

    Returns
    -------
    callable
        ``write(tmp_path)``, writing the bytes to the file named ``tmp_path``.
    """
    data = ds.to_netcdf(engine="h5netcdf")

    def write(tmp: str) -> None:
        with open(tmp, "wb") as fh:
            fh.write(data)

    return write


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


def _digest(path: str | Path) -> str:
    """SHA-256 of a file's bytes (hex), read in chunks."""
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        for chunk in iter(lambda: fh.read(1 << 20), b""):
            h.update(chunk)
    return h.hexdigest()


def _read_written(folder: Path) -> dict[str, dict[str, object]]:
    """A folder's :data:`WRITTEN` record (empty when missing or unreadable: then nothing in
    the folder counts as written by sloshrom)."""
    try:
        files = json.loads((folder / WRITTEN).read_text(encoding="utf-8"))["files"]
    except (OSError, ValueError, KeyError, TypeError):
        return {}
    if not isinstance(files, dict):
        return {}
    return {str(k): v for k, v in files.items() if isinstance(v, dict)}


def foreign_files(folder: str | Path, names: Sequence[str], owner: str) -> list[str]:
    """The entries among ``names`` that exist in ``folder`` and that ``owner`` did not write.

    A file is ``owner``'s when the folder's :data:`WRITTEN` record lists it as written by
    ``owner`` with its present size and SHA-256 (a file edited or replaced since is not); a
    directory where a file goes is never.

    Parameters
    ----------
    folder : str or Path
        The output folder.
    names : sequence of str
        What the command writes there (relative names; a trailing ``/`` is ignored).
    owner : str
        The command, as its :class:`OutputBatch` records it (``"sloshrom design"``).

    Returns
    -------
    list of str
        The names of the files the command would replace without having written them.
    """
    d = Path(folder)
    record = _read_written(d) if d.is_dir() else {}
    out = []
    for name in names:
        f = d / name.rstrip("/")
        if not (f.exists() or f.is_symlink()):
            continue
        entry = record.get(name.rstrip("/"))
        mine = (entry is not None and entry.get("command") == owner and f.is_file()
                and not f.is_symlink() and entry.get("size") == f.stat().st_size
                and entry.get("sha256") == _digest(f))
        if not mine:
            out.append(name.rstrip("/"))
    return out


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
    owner: str | None = None,
    overwrite: bool = False,
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
    owner : str, optional
        With ``directory``: the command, as its :class:`OutputBatch` records its files. A file
        of ``contents`` that exists and that it did not write (:func:`foreign_files`) is
        refused, named, unless ``overwrite``.
    overwrite : bool
        Replace such files (the command line's ``--overwrite``).

    Returns
    -------
    Path

    Raises
    ------
    OutputPathError
        Unknown suffix, a name too long for the file system, a directory where a file is
        expected (or the reverse), a parent that is a file or not writable, or an input file
        (the output itself or, for a directory, anything the command writes in it), or files
        of ``contents`` that ``owner`` did not write.
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
    if directory and owner is not None and not overwrite:
        foreign = foreign_files(p, contents, owner)
        if foreign:
            them = "it" if len(foreign) == 1 else "them"
            raise OutputPathError(
                f"{what} {p}: holds {', '.join(foreign)}, which {owner} did not write (or "
                f"that changed since): refusing to replace {them} (--overwrite replaces "
                f"{them}; or choose another folder)")
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


def _lock_holder(fd: int) -> tuple[int, str] | None:
    """The process id and start time a lock file holds (``None``: empty or unreadable)."""
    try:
        os.lseek(fd, 0, os.SEEK_SET)
        info = json.loads(os.read(fd, 4096).decode("utf-8"))
        return int(info["pid"]), str(info.get("started", "?"))
    except (OSError, ValueError, KeyError, TypeError):
        return None


@contextmanager
def folder_lock(path: str | Path, what: str = "output folder") -> Iterator[str | None]:
    """Hold the lock file ``path`` of an output folder while the block runs.

    The lock is an ``fcntl.flock`` on ``path`` (released by the kernel when the process ends,
    however it ends), and the file holds the holder's process id and start time for the
    message. A lock file that names another live process is held too (a lock planted by hand,
    or held on another machine); one that names a dead process is taken over. The file is
    removed when the block ends.

    Parameters
    ----------
    path : str or Path
        The lock file (its folder exists).
    what : str
        How to name the folder in the message (e.g. ``"--out results"``).

    Yields
    ------
    str or None
        A note when a stale lock (of a process no longer alive) was taken over, else ``None``.

    Raises
    ------
    FolderBusyError
        Another live process holds the lock: the message names its process id, start time and
        the file to delete if no such run exists.
    """
    p = Path(path)
    for _ in range(3):  # the holder may remove the file between our open and our flock
        fd = os.open(p, os.O_RDWR | os.O_CREAT, 0o666 & ~_umask())
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            locked = True
        except BlockingIOError:
            locked = False
        holder = _lock_holder(fd)
        try:
            same = os.fstat(fd).st_ino == os.stat(p).st_ino
        except FileNotFoundError:
            same = False
        if locked and not same:
            os.close(fd)
            continue
        if not locked or (holder is not None and holder[0] != os.getpid()
                          and pid_alive(holder[0])):
            os.close(fd)
            pid, started = holder if holder is not None else ("unknown", "?")
            raise FolderBusyError(
                f"{what}: another sloshrom run (process {pid}, started {started}) is writing "
                f"there; wait for it to end or choose another folder (if no such run exists, "
                f"delete {p})")
        break
    else:
        raise FolderBusyError(f"{what}: the lock {p} keeps changing; try again")
    note = (None if holder is None else
            f"{p}: took over the lock of process {holder[0]} (started {holder[1]}), which no "
            "longer runs")
    try:
        os.ftruncate(fd, 0)
        started = time.strftime("%Y-%m-%dT%H:%M:%S%z")
        os.pwrite(fd, json.dumps({"pid": os.getpid(), "started": started}).encode(), 0)
        yield note
    finally:
        try:
            p.unlink(missing_ok=True)  # while still locked: a waiting open finds a new file
        finally:
            os.close(fd)
