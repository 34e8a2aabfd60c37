"""No behaviour change across refactorings: rerun the stored cases (see ``behaviour_cases``).

The stored arrays were written on one CPU; another rounds differently in the last bits (NumPy's
AVX-512 transcendental functions, glibc's FMA variants of ``exp``/``log``, XLA's and OpenBLAS's
kernels are chosen by the CPU at run time), and the rig and the recurrent ROMs amplify those
bits. So each array is compared with its own tolerance: its largest relative change when every
input is perturbed by a relative 1e-13 (``tests/data/behaviour_tolerance.json``). Bit-identity
is a property of one machine: tested here between two runs and two processes.
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from behaviour_cases import EPS, cases, tolerances
from helpers import assert_bit_identical, relative_change

DATA = Path(__file__).parent / "data"
FIXTURE = DATA / "behaviour.npz"
TOLERANCE = json.loads((DATA / "behaviour_tolerance.json").read_text())["tolerance"]

pytestmark = pytest.mark.reference


@pytest.fixture(scope="module")
def now() -> dict[str, np.ndarray]:
    return cases()


@pytest.fixture(scope="module")
def before() -> dict[str, np.ndarray]:
    with np.load(FIXTURE, allow_pickle=False) as f:
        return {k: f[k] for k in f.files}


def test_same_cases(now, before):
    assert sorted(now) == sorted(before) == sorted(TOLERANCE)


@pytest.mark.parametrize("name", sorted(TOLERANCE))
def test_case_unchanged(name, now, before):
    a, b = np.asarray(now[name]), before[name]
    assert a.shape == b.shape, name
    # map points outside the shaker envelope are NaN: in the same places
    assert np.array_equal(np.isnan(a), np.isnan(b)), f"{name}: NaN pattern changed"
    err, tol = relative_change(a, b), TOLERANCE[name]
    assert err <= tol, (f"{name}: relative change {err:.3g} > {tol:.3g}, its change when every "
                        f"input moves by a relative {EPS:g}")


def test_tolerances_are_far_below_a_behaviour_change():
    # the loosest tolerance (the rig's force: impacts shift in time) still fails a change of
    # one part in a million, e.g. a constant rounded to 6 digits
    assert max(TOLERANCE.values()) < 1e-6


def test_a_change_of_one_part_in_a_million_fails(now, before):
    # the comparison is not vacuous: a relative 1e-6 error in one array fails its case
    name = "rig_true_dynamic_force"
    bad = now[name] * (1.0 + 1e-6)
    assert relative_change(bad, before[name]) > TOLERANCE[name]


@pytest.mark.slow
def test_deterministic_within_one_process(now):
    again = cases()
    for k in now:
        assert_bit_identical(again[k], now[k], k)


@pytest.mark.slow
def test_deterministic_across_processes(now, tmp_path):
    code = ("import sys, numpy as np; sys.path.insert(0, sys.argv[1]); "
            "from behaviour_cases import cases; np.savez(sys.argv[2], **cases())")
    out = tmp_path / "other.npz"
    subprocess.run([sys.executable, "-c", code, str(Path(__file__).parent), str(out)],
                   check=True, capture_output=True)
    with np.load(out, allow_pickle=False) as f:
        for k in now:
            assert_bit_identical(f[k], now[k], k)


@pytest.mark.slow
def test_stored_tolerances_are_this_machines_sensitivity():
    """The stored tolerances are not stale: remeasured here, each is within a factor 3."""
    fresh = tolerances()
    for k, tol in TOLERANCE.items():
        assert fresh[k] / 3 <= tol <= 3 * fresh[k], (k, tol, fresh[k])
