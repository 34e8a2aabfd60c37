"""tools/warm_kernels.py: what `make` compiles into numba's cache is what a run then loads."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]

# the calls of a run, not the warm-up's own: other lengths, the search's buffer and arguments
RUN = """
import json
import numpy as np
from sloshrom.rig import VirtualRig
from sloshrom.rig.physics import _simulate_batch
from sloshrom.rom.grey.physics import _causal_batch, _causal_lanes, causal_intervals
from sloshrom.beam.simulation.coupled import _numba_loop
rig = VirtualRig(seed=3)
rig.measure(np.cos(np.arange(3000) * 0.02) * 25.0)
phys = np.array([[0.02, 2e6, 50.0, 0.012, 12.0, 0.02, 5.0]])
out = np.empty((1, 3, 40, 3, 8))
causal_intervals(phys, np.ones((3, 40)), 1000.0, 4, 8, from_rest=False, predict_from=9, out=out)
causal_intervals(phys, np.ones((20, 30)), 1000.0, 4, 8, from_rest=False, predict_from=9)
loop = _numba_loop()
print(json.dumps({name: [sum(k.stats.cache_hits.values()), sum(k.stats.cache_misses.values())]
                  for name, k in (("rig", _simulate_batch), ("column", _causal_batch),
                                  ("lanes", _causal_lanes), ("beam", loop))}))
"""


def _run(args: list[str], cache: Path) -> str:
    env = {**os.environ, "NUMBA_CACHE_DIR": str(cache)}
    return subprocess.run([sys.executable, *args], env=env, cwd=ROOT, check=True,
                          capture_output=True, text=True, timeout=300).stdout


@pytest.mark.long
def test_a_run_after_the_warm_up_compiles_no_kernel(tmp_path):
    cold = json.loads(_run(["-c", RUN], tmp_path / "cold").splitlines()[-1])
    assert all(misses > 0 for _, misses in cold.values()), cold  # the control: it compiles
    _run(["tools/warm_kernels.py"], tmp_path / "warm")
    warm = json.loads(_run(["-c", RUN], tmp_path / "warm").splitlines()[-1])
    assert all(hits > 0 and misses == 0 for hits, misses in warm.values()), warm
