"""A small resumable stage cache for long pipelines.

A stage is skipped when its *key* (a hash of its configuration, the keys of the stages it depends
on and the package version) matches the one recorded when it last finished and all the files it
produced still exist. The record is written only after the stage has finished, so an interrupted
run redoes the interrupted stage and nothing before it.
"""

from __future__ import annotations

import hashlib
import json
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from sloshrom.fileio import atomic_write_text as atomic_write_text  # re-exported


def stable_hash(obj: Any) -> str:
    """SHA-256 of the canonical JSON form of ``obj`` (dicts sorted, floats repr'd)."""
    text = json.dumps(obj, sort_keys=True, default=str, separators=(",", ":"))
    return hashlib.sha256(text.encode()).hexdigest()[:16]


@dataclass
class StageResult:
    name: str
    key: str
    outputs: dict[str, Any]
    reused: bool


class StageCache:
    """Records of finished stages under ``root/.stages/``."""

    def __init__(self, root: str | Path) -> None:
        self.root = Path(root)
        self.dir = self.root / ".stages"

    def _record(self, name: str) -> Path:
        return self.dir / f"{name}.json"

    def lookup(self, name: str, key: str) -> dict[str, Any] | None:
        p = self._record(name)
        if not p.is_file():
            return None
        try:
            rec = json.loads(p.read_text())
        except (OSError, json.JSONDecodeError):
            return None
        if rec.get("key") != key:
            return None
        files = rec.get("files", [])
        if not all((self.root / f).exists() for f in files):
            return None
        return rec.get("outputs", {})

    def store(self, name: str, key: str, outputs: dict[str, Any], files: Iterable[str]) -> None:
        rec = {"name": name, "key": key, "outputs": outputs, "files": sorted(set(files))}
        atomic_write_text(self._record(name), json.dumps(rec, indent=1, default=str))

    def run(
        self,
        name: str,
        config: Any,
        depends: Iterable[StageResult],
        func: Callable[[], tuple[dict[str, Any], Iterable[str]]],
        version: str = "",
    ) -> StageResult:
        """Run ``func`` unless an identical finished run is recorded.

        ``func`` returns ``(outputs, files)``: a JSON-able summary and the paths (relative to the
        cache root) of the files it wrote.
        """
        key = stable_hash({"config": config, "deps": [d.key for d in depends], "v": version})
        cached = self.lookup(name, key)
        if cached is not None:
            return StageResult(name, key, cached, reused=True)
        outputs, files = func()
        self.store(name, key, outputs, files)
        return StageResult(name, key, outputs, reused=False)
