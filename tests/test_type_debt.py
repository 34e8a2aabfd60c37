"""tools/type_debt.py: the counts of ``Any`` annotations, ``type: ignore`` comments and relaxed
mypy codes can only go down (CI runs it after the tests)."""

from __future__ import annotations

import json
import shutil
import subprocess
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
TOOL = REPO / "tools" / "type_debt.py"


def _run(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, str(TOOL), *args], capture_output=True, text=True,
                          check=False)


def test_repo_within_ceilings():
    out = _run()
    assert out.returncode == 0, out.stdout + out.stderr
    assert "type debt: any = " in out.stdout


def test_one_more_any_fails(tmp_path):
    root = tmp_path / "sloshrom"
    shutil.copytree(REPO / "src" / "sloshrom", root,
                    ignore=shutil.ignore_patterns("__pycache__"))
    # the tree as it is: within the ceilings
    assert _run("--root", str(root)).returncode == 0
    with open(root / "models.py", "a", encoding="utf-8") as f:
        f.write("\n\ndef _extra(x: Any) -> None:\n    pass\n")
    out = _run("--root", str(root))
    assert out.returncode == 1
    assert "type debt rose: any" in out.stderr


def test_fewer_says_how_to_lower(tmp_path):
    ceilings = json.loads((REPO / "tools" / "type_debt.json").read_text())
    ceilings["type_ignore"] += 1
    path = tmp_path / "ceilings.json"
    path.write_text(json.dumps(ceilings))
    out = _run("--ceilings", str(path))
    assert out.returncode == 0
    assert "type debt fell (type_ignore): lower the ceilings" in out.stdout


def test_counts_on_small_sources():
    sys.path.insert(0, str(TOOL.parent))
    try:
        import type_debt
    finally:
        sys.path.remove(str(TOOL.parent))
    src = ("from typing import Any\n"
           "def f(a: Any, b: int, *c: 'list[Any]') -> dict[str, Any]:\n"
           "    x: Any = 1  # type: ignore[assignment]\n"
           "    return {}  # Any in a comment is not counted\n")
    assert type_debt.count_any(src) == 4
    assert type_debt.count_type_ignores(src) == 1
