"""Write the behaviour fixture of ``tests/test_behaviour.py``.

``python tools/write_behaviour_fixture.py`` writes ``tests/data/behaviour.npz`` from the current
code (run it once, before a refactoring) and then its tolerances; ``--tolerances`` writes only
the tolerances (``tests/data/behaviour_tolerance.json``): for every case, the largest relative
change ``max|x' - x| / max|x|`` over ``DRAWS`` runs with every input perturbed by a relative
``EPS``, and never below ``FLOOR`` (a few roundings; ``tests/behaviour_cases.py``).
"""

from __future__ import annotations

import argparse
import json
import platform
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))

from behaviour_cases import DRAWS, EPS, FLOOR, cases, tolerances  # noqa: E402

DATA = ROOT / "tests" / "data"


def _cpu() -> str:
    """The CPU's model name (Linux), else what the platform module says."""
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor()


def tolerance_file() -> dict:
    """The tolerance file's content: the rule, where it was measured, a value per case."""
    return {
        "rule": f"max relative change over {DRAWS} draws of every input perturbed by a "
                f"relative {EPS:g}, at least {FLOOR:.3g}",
        "eps": EPS,
        "draws": DRAWS,
        "measured_on": {"machine": platform.machine(), "cpu": _cpu(), "numpy": np.__version__},
        "tolerance": dict(sorted(tolerances().items())),
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--tolerances", action="store_true",
                    help="write only the tolerances, keep the stored arrays")
    args = ap.parse_args()
    if not args.tolerances:
        arrays = cases()
        np.savez_compressed(DATA / "behaviour.npz", **arrays)
        print(f"{DATA / 'behaviour.npz'}: {len(arrays)} arrays")
    target = DATA / "behaviour_tolerance.json"
    target.write_text(json.dumps(tolerance_file(), indent=1) + "\n")
    print(f"{target}: written")


if __name__ == "__main__":
    main()
