"""NumPy's transparent huge pages on and off, side by side: the rig's sensors on a long record
and the grey box's column search (4 generations on the rig's record of the same test), each in
a fresh process, with the kernel's compaction stalls meanwhile (``/proc/vmstat``).

Where the kernel's policy is ``madvise``, NumPy asks for huge pages for every array of 4 MB or
more; on a host where a new huge page is slow to come (memory to compact, or a virtual
machine's memory to back) a process that grows by hundreds of MB waits for seconds. The
command line therefore turns NumPy's advice off (``sloshrom._memory``). The ratio depends on
the host's memory at the time: rerun when comparing. Usage::

    .venv/bin/python benchmarks/huge_pages.py [--seconds 975] [--repeat 2]
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
from pathlib import Path

_CHILD = r"""
import json, sys, time
import numpy as np
seconds = float(sys.argv[1])

def stalls():
    try:
        for line in open("/proc/vmstat"):
            if line.startswith("compact_stall "):
                return int(line.split()[1])
    except OSError:
        pass
    return -1

from sloshrom.rig import VirtualRig
rig = VirtualRig()
fs = 1.0 / rig.dt
t = np.arange(int(seconds * fs)) / fs
acc = 20.0 * np.sin(2 * np.pi * 12.0 * t) * np.sin(np.pi * t / seconds) ** 2
rig.measure(acc[: int(2 * fs)])  # compiled and warm
s0, t0 = stalls(), time.perf_counter()
rig.measure(acc)
rig_s = time.perf_counter() - t0
# the grey box's column search (differential evolution, numba; its one 430 MB buffer) on the
# rig's record of the same test
from sloshrom.rom.grey.network import GreySpec
from sloshrom.rom.grey.training import fit_physics
ts = t[: int(120 * fs)]
m = rig.measure(20.0 * np.sin(2 * np.pi * 12.0 * ts) * np.sin(np.pi * ts / 120.0) ** 2)
spec = GreySpec(8, 32, 50, 10, 8, 6)  # the default grey box's
t1 = time.perf_counter()
fit_physics(m["true_velocity"], m["true_dynamic_force"], m["fs"], spec, rig.tank.liquid_mass,
            rig.tank.ullage, generations=4)
search_s = time.perf_counter() - t1
print(json.dumps({"rig_s": rig_s, "search_s": search_s,
                  "compact_stalls": stalls() - s0 if s0 >= 0 else None}))
"""


def run(advice: str, seconds: float) -> dict[str, float]:
    env = {**os.environ, "NUMPY_MADVISE_HUGEPAGE": advice}
    out = subprocess.run([sys.executable, "-c", _CHILD, str(seconds)], env=env, check=True,
                         capture_output=True, text=True, cwd=Path(__file__).parent)
    return json.loads(out.stdout.strip().splitlines()[-1])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seconds", type=float, default=975.0,
                    help="record length, s (the default training record's)")
    ap.add_argument("--repeat", type=int, default=2, help="pairs, alternated")
    a = ap.parse_args()
    policy = Path("/sys/kernel/mm/transparent_hugepage/enabled")
    print(f"transparent huge pages: {policy.read_text().strip() if policy.exists() else 'n/a'}")
    rows = []
    for _ in range(a.repeat):
        for advice in ("1", "0"):
            r = run(advice, a.seconds)
            rows.append((advice, r))
            print(f"NUMPY_MADVISE_HUGEPAGE={advice}: rig sensors {r['rig_s']:6.2f} s, "
                  f"column search (4 generations) {r['search_s']:5.2f} s, "
                  f"compaction stalls {r['compact_stalls']}")
    for key in ("rig_s", "search_s"):
        on = min(r[key] for adv, r in rows if adv == "1")
        off = min(r[key] for adv, r in rows if adv == "0")
        print(f"{key}: advice on {on:.2f} s, off {off:.2f} s, ratio on/off {on / off:.2f}")


if __name__ == "__main__":
    main()
