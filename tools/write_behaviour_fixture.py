"""Write ``tests/data/behaviour.npz`` from the current code (run once, before a refactoring)."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))

from behaviour_cases import cases  # noqa: E402

if __name__ == "__main__":
    target = ROOT / "tests" / "data" / "behaviour.npz"
    arrays = cases()
    np.savez_compressed(target, **arrays)
    print(f"{target}: {len(arrays)} arrays")
