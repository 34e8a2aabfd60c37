"""Print the installed packages whose version differs from requirements.lock.

Run by ``make test-latest`` before the tests: when the newest releases allowed by
pyproject.toml's ranges break a test, this list names the suspects.

Usage: ``python tools/lock_diff.py requirements.lock``
"""

from __future__ import annotations

import re
import sys
from importlib import metadata
from pathlib import Path

_PIN = re.compile(r"^([A-Za-z0-9_.\-]+)==([^\s;\\]+)")


def _norm(name: str) -> str:
    return re.sub(r"[-_.]+", "-", name).lower()


def locked(path: Path) -> dict[str, str]:
    pins: dict[str, str] = {}
    for line in path.read_text(encoding="utf-8").splitlines():
        m = _PIN.match(line.strip())
        if m:
            pins.setdefault(_norm(m.group(1)), m.group(2))
    return pins


def main(argv: list[str]) -> int:
    if len(argv) != 2:
        print(__doc__.strip().splitlines()[-1], file=sys.stderr)
        return 2
    pins = locked(Path(argv[1]))
    installed = {_norm(d.metadata["Name"]): d.version for d in metadata.distributions()}
    rows = [(n, pins[n], installed[n]) for n in sorted(pins) if n in installed
            and installed[n] != pins[n]]
    rows += [(n, "-", v) for n, v in sorted(installed.items())
             if n not in pins and n not in ("pip", "sloshrom")]
    if not rows:
        print("newest allowed releases = the lock: nothing differs")
        return 0
    print(f"{len(rows)} package(s) differ from {argv[1]} (name: locked -> installed):")
    for name, old, new in rows:
        print(f"  {name}: {old} -> {new}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
