"""No behaviour change across refactorings: rerun the stored cases (see ``behaviour_cases``)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from behaviour_cases import EXACT, cases

FIXTURE = Path(__file__).parent / "data" / "behaviour.npz"


@pytest.fixture(scope="module")
def now() -> dict[str, np.ndarray]:
    return cases()


@pytest.fixture(scope="module")
def before() -> dict[str, np.ndarray]:
    with np.load(FIXTURE, allow_pickle=False) as f:
        return {k: f[k] for k in f.files}


def test_same_cases(now, before):
    assert sorted(now) == sorted(before)


@pytest.mark.parametrize("name", sorted(np.load(FIXTURE, allow_pickle=False).files))
def test_case_unchanged(name, now, before):
    a, b = np.asarray(now[name]), before[name]
    assert a.shape == b.shape, name
    if name.startswith(EXACT):
        assert a.tobytes() == b.tobytes(), f"{name} is no longer bit-identical"
    else:
        # map points outside the shaker envelope are NaN: in the same places
        assert np.array_equal(np.isnan(a), np.isnan(b)), f"{name}: NaN pattern changed"
        scale = max(float(np.nanmax(np.abs(b))), 1e-300)
        err = float(np.nanmax(np.abs(a - b))) / scale
        assert err < 1e-9, f"{name}: relative change {err:.3g}"
