"""A small resumable stage cache for long pipelines.

A stage is skipped when its *key* matches the one recorded when it last finished and every file it
produced is still there **with the same content**: the record holds the size and SHA-256 of each
output file, and :meth:`StageCache.lookup` re-hashes them. A stage's key is a hash of its
configuration, the package version and, for each stage it depends on, that stage's key and the
digest of its outputs (summary and file hashes), so a stage whose upstream was redone with a
different result is redone too. The record is written only after the stage has finished, so an
interrupted run redoes the interrupted stage and nothing before it.

The hashes detect outputs that were deleted, emptied, truncated, replaced or edited; they do not
stop someone who also rewrites the record under ``.stages/``.
"""

from __future__ import annotations

import hashlib
import json
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from pathlib import Path, PurePosixPath
from typing import Any

from sloshrom.fileio import OutputPathError
from sloshrom.fileio import atomic_write_text as atomic_write_text  # re-exported

#: Layout of the records under ``.stages/``; records of another (e.g. the old, hash-less) layout
#: are not trusted: the stage is redone.
RECORD_VERSION = 2
_CHUNK = 1 << 20  # bytes hashed per read: constant memory for files of any size


def stable_hash(obj: Any) -> str:
    """SHA-256 of the canonical JSON form of ``obj`` (dicts sorted, floats repr'd)."""
    text = json.dumps(obj, sort_keys=True, default=str, separators=(",", ":"))
    return hashlib.sha256(text.encode()).hexdigest()[:16]


def file_sha256(path: str | Path) -> str:
    """SHA-256 (hex) of a file's content, read in 1 MiB chunks."""
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        while chunk := fh.read(_CHUNK):
            h.update(chunk)
    return h.hexdigest()


@dataclass
class StageResult:
    """A finished stage: its key, JSON-able outputs, whether it was reused, and ``digest``, a hash
    of its outputs and output-file contents (what downstream keys depend on).

    ``files`` are the paths (relative to ``root``, the cache root) of the files the stage wrote,
    as its record lists them: a later stage finds its inputs there (:meth:`output`) instead of
    assuming where an upstream stage wrote them.
    """

    name: str
    key: str
    outputs: dict[str, Any]
    reused: bool
    digest: str = ""
    files: tuple[str, ...] = ()
    root: Path | None = None

    def output(self, rel: str) -> Path:
        """The recorded file ``rel`` (relative to the cache root, e.g. ``"data/train.nc"``).

        Raises
        ------
        KeyError
            The stage recorded no such file (it did not write it).
        """
        if rel not in self.files or self.root is None:
            raise KeyError(f"stage {self.name!r} recorded no file {rel!r}")
        return self.root / rel

    def optional_output(self, rel: str) -> Path | None:
        """:meth:`output`, or None when the stage recorded no such file."""
        return self.root / rel if rel in self.files and self.root is not None else None


def _digest(outputs: dict[str, Any], files: dict[str, dict[str, Any]]) -> str:
    return stable_hash({"outputs": outputs, "files": {f: v["sha256"] for f, v in files.items()}})


class StageCache:
    """Records of finished stages under ``root/.stages/``."""

    def __init__(self, root: str | Path) -> None:
        self.root = Path(root)
        self.dir = self.root / ".stages"

    def _record(self, name: str) -> Path:
        return self.dir / f"{name}.json"

    def _inside(self, rel: Any) -> Path | None:
        """``root / rel`` for a relative path that stays under the root, else None."""
        if not isinstance(rel, str) or not rel:
            return None
        pp = PurePosixPath(rel.replace("\\", "/"))
        if pp.is_absolute() or ".." in pp.parts:
            return None
        return self.root / pp

    def _unchanged(self, rel: Any, entry: Any) -> bool:
        """True if the file ``rel`` still has the recorded size and SHA-256."""
        p = self._inside(rel)
        if p is None or not isinstance(entry, dict):
            return False
        size, digest = entry.get("size"), entry.get("sha256")
        if type(size) is not int or not isinstance(digest, str):
            return False
        try:
            # the size first: an emptied or truncated file is caught without reading it
            return p.is_file() and p.stat().st_size == size and file_sha256(p) == digest
        except OSError:
            return False

    def lookup_result(self, name: str, key: str) -> StageResult | None:
        """The recorded result of stage ``name`` if its key matches and its files are intact."""
        return self._read(name, key)

    def recorded(self, name: str) -> StageResult | None:
        """The last recorded result of stage ``name`` whatever its key, if its files are intact
        (a finished run's stage, read back by a tool that does not rebuild the stage's key)."""
        return self._read(name, None)

    def _read(self, name: str, key: str | None) -> StageResult | None:
        p = self._record(name)
        if not p.is_file():
            return None
        try:
            rec = json.loads(p.read_text(encoding="utf-8"))
        except (OSError, ValueError, RecursionError):
            return None
        if not isinstance(rec, dict) or rec.get("record_version") != RECORD_VERSION:
            return None  # e.g. the old layout with file names but no hashes: not trusted
        if key is not None and rec.get("key") != key:
            return None
        files, outputs = rec.get("files"), rec.get("outputs", {})
        if not isinstance(files, dict) or not isinstance(outputs, dict):
            return None
        if not all(self._unchanged(f, entry) for f, entry in files.items()):
            return None
        return StageResult(name, rec.get("key", ""), outputs, reused=True,
                           digest=_digest(outputs, files), files=tuple(files), root=self.root)

    def lookup(self, name: str, key: str) -> dict[str, Any] | None:
        """Recorded outputs of stage ``name`` if it can be reused (see :meth:`lookup_result`)."""
        res = self.lookup_result(name, key)
        return None if res is None else res.outputs

    def store(self, name: str, key: str, outputs: dict[str, Any], files: Iterable[str]) -> str:
        """Record a finished stage with the size and SHA-256 of each of its files.

        Parameters
        ----------
        name, key : str
            Stage name and key.
        outputs : dict
            JSON-able summary of the stage.
        files : iterable of str
            Paths, relative to the cache root, of the files the stage wrote (all must exist).

        Returns
        -------
        str
            The stage's digest (see :class:`StageResult`).
        """
        entries = {}
        for f in sorted(set(files)):
            p = self._inside(f)
            if p is None:
                raise OutputPathError(f"stage {name}: output {f!r} is not a path inside "
                                      f"{self.root}")
            entries[f] = {"size": p.stat().st_size, "sha256": file_sha256(p)}
        # JSON round trip: the digest of a reused stage is computed from the record, so it must
        # see the outputs exactly as they will be read back
        outputs = json.loads(json.dumps(outputs, default=str))
        rec = {"record_version": RECORD_VERSION, "name": name, "key": key, "outputs": outputs,
               "files": entries}
        atomic_write_text(self._record(name), json.dumps(rec, indent=1))
        return _digest(outputs, entries)

    def run(
        self,
        name: str,
        config: Any,
        depends: Iterable[StageResult],
        func: Callable[[], tuple[dict[str, Any], Iterable[str]]],
        version: str = "",
    ) -> StageResult:
        """Run ``func`` unless an identical finished run is recorded with intact files.

        ``func`` returns ``(outputs, files)``: a JSON-able summary and the paths (relative to the
        cache root) of the files it wrote.
        """
        deps = [[d.key, d.digest] for d in depends]
        key = stable_hash({"config": config, "deps": deps, "v": version})
        cached = self.lookup_result(name, key)
        if cached is not None:
            return cached
        outputs, files = func()
        files = sorted(set(files))
        digest = self.store(name, key, outputs, files)
        return StageResult(name, key, outputs, reused=False, digest=digest, files=tuple(files),
                           root=self.root)
