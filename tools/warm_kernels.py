"""Compile the numba kernels of a default run into numba's on-disk cache, once per machine.

`make` runs this while the grey box's C++ kernel builds (one core each), so that the first
`sloshrom reproduce` of a fresh clone loads the virtual rig's, the column's (window by window,
and the search's with the windows as lanes) and the coupled beam's kernels from the cache
instead of compiling them in its stages (about 8 s of compilation: the data stage
16.5 -> 12.1 s, the ROM stage's workers and the beam stage a few seconds each, measured on the
2-core machine, before the lanes' kernel added about 10 s of its own). Each kernel is called
once on a tiny input of the types the run gives it, which compiles exactly the signature the
run uses.

Run: ``.venv/bin/python tools/warm_kernels.py`` (``-v``: the time of each). A kernel whose cache
cannot be written (a read-only install) compiles in memory and is lost: harmless, and said.
"""

from __future__ import annotations

import argparse
import time
from collections.abc import Callable


def _rig() -> object:
    import numpy as np

    from sloshrom.rig import VirtualRig
    from sloshrom.rig.physics import _simulate_batch

    rig = VirtualRig(seed=0)
    t = np.arange(2000) * rig.dt
    rig.measure(30.0 * np.sin(2.0 * np.pi * 20.0 * t))  # above 1 g: impacts
    return _simulate_batch


def _column(lanes: bool) -> object:
    import numpy as np

    from sloshrom.rom.grey.physics import (
        LANES_FROM,
        _causal_batch,
        _causal_lanes,
        causal_intervals,
    )

    phys = np.array([[0.01, 1e6, 100.0, 0.01, 10.0, 0.01, 7.0]])
    causal_intervals(phys, np.zeros((LANES_FROM if lanes else 2, 50)), 500.0, 10, 8)
    return _causal_lanes if lanes else _causal_batch


def _beam() -> object:
    from sloshrom.beam.simulation.coupled import _numba_loop

    return _numba_loop()


#: The kernels of a default run: (name, a call that compiles it and returns its dispatcher).
KERNELS: tuple[tuple[str, Callable[[], object]], ...] = (
    ("virtual rig", _rig), ("grey box's column", lambda: _column(lanes=False)),
    ("grey box's column, windows as lanes", lambda: _column(lanes=True)),
    ("coupled beam loop", _beam))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("-v", "--verbose", action="store_true", help="print each kernel's time")
    args = ap.parse_args()
    for name, warm in KERNELS:
        t0 = time.perf_counter()
        kernel = warm()
        if not getattr(kernel, "_cache", None) or type(kernel._cache).__name__ == "NullCache":
            print(f"warm_kernels: {name}: no on-disk cache here (compiled in memory only)")
        elif args.verbose:
            print(f"warm_kernels: {name}: {time.perf_counter() - t0:.1f} s")


if __name__ == "__main__":
    main()
