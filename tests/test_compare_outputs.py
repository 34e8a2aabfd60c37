"""tools/compare_outputs.py: the same results are the same, whatever the stage records' digests."""

from __future__ import annotations

import json
import subprocess
import sys

from helpers import REPO

TOOL = REPO / "tools" / "compare_outputs.py"


def _tree(root, digest: str, value: float) -> None:
    (root / ".stages").mkdir(parents=True)
    (root / ".stages" / "rom.json").write_text(json.dumps(
        {"key": digest[:16], "files": {"models/x.npz": {"sha256": digest, "size": len(digest)}},
         "outputs": {"val_fit": 40.0}}))
    (root / "summary.json").write_text(json.dumps({"val_fit": value}))


def _run(a, b) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, str(TOOL), str(a), str(b)], capture_output=True,
                          text=True, check=False)


def test_stage_digests_are_not_results(tmp_path):
    _tree(tmp_path / "a", "a" * 64, 1.0)
    _tree(tmp_path / "b", "b" * 80, 1.0)
    out = _run(tmp_path / "a", tmp_path / "b")
    assert out.returncode == 0, out.stdout
    assert "0 differ" in out.stdout


def test_a_result_that_changed_differs(tmp_path):
    _tree(tmp_path / "a", "a" * 64, 1.0)
    _tree(tmp_path / "b", "a" * 64, 1.5)
    out = _run(tmp_path / "a", tmp_path / "b")
    assert out.returncode == 1
    assert "DIFFERS: summary.json" in out.stdout
