"""The shaker programme of the structure's own motion: segments at rest, their kinds and
levels, the shaker check, and the signals' ``to_rest``."""

from __future__ import annotations

import numpy as np
import pytest

from sloshrom.beam.simulation.programme import (
    Programme,
    ProgrammeError,
    Segment,
    concatenate,
    structure_segments,
)
from sloshrom.config import G, Tank
from sloshrom.signals import ShakerLimits, SignalError, to_rest

FS_SIGNAL, FS = 500.0, 2000.0


def integrals(a: np.ndarray, fs: float) -> tuple[np.ndarray, np.ndarray]:
    v = np.concatenate([[0.0], np.cumsum(0.5 * (a[1:] + a[:-1])) / fs])
    x = np.concatenate([[0.0], np.cumsum(0.5 * (v[1:] + v[:-1])) / fs])
    return v, x


@pytest.fixture(scope="module")
def segments(builtin_modal):
    return structure_segments(builtin_modal, Tank(), FS, FS_SIGNAL, [0.1, 0.2], 12.0, 1000,
                              12.0, 4.0, 0.0146, [0.5, 1.0], 4.0)


def test_to_rest_returns_to_rest_and_keeps_the_middle():
    fs = 1000.0
    t = np.arange(20001) / fs
    x = np.sin(2 * np.pi * 10 * t) + 0.3  # an offset: velocity and displacement would drift
    r = to_rest(x, fs, 1.0)
    v, d = integrals(r, fs)
    assert r[0] == r[-1] == 0.0
    # the trapezoid's end values: float64 cumsum round-off over 2e4 samples, ~1e-12
    assert abs(v[-1]) < 1e-9 and abs(d[-1]) < 1e-9
    mid = slice(5000, 15000)  # the fades leave the middle a sine with a smooth correction
    assert np.max(np.abs(r[mid] - np.sin(2 * np.pi * 10 * t[mid]))) < 0.35
    asym = to_rest(x, fs, 1.0, end_fade=0.2)
    assert np.all(asym[-150:-1] != 0) and abs(integrals(asym, fs)[1][-1]) < 1e-9
    with pytest.raises(SignalError, match="fades"):
        to_rest(x[:100], fs, 1.0)


def test_segments_start_and_end_at_rest_at_the_structure_frequency(segments, builtin_modal):
    assert [s.name for s in segments] == ["random 0.1 g", "random 0.2 g", "decay 0.50",
                                          "decay 1.00"]
    assert [s.kind for s in segments] == ["random", "random", "decay", "decay"]
    f1 = builtin_modal.frequencies[0]
    for s in segments:
        a = s.acceleration
        v, x = integrals(a, FS)
        peak = np.max(np.abs(a))
        assert abs(a[0]) <= 1e-9 * peak and abs(a[-1]) <= 1e-9 * peak
        assert abs(v[-1]) < 1e-9 * np.max(np.abs(v)) * a.size
        assert abs(x[-1]) < 1e-9 * np.max(np.abs(x)) * a.size
        spec = np.abs(np.fft.rfft(a))
        f = np.fft.rfftfreq(a.size, 1 / FS)
        # the frozen structure's tank motion: narrow band at its first frequency
        assert abs(f[np.argmax(spec)] / f1 - 1) < 0.1, s.name
    # the frozen structure is linear: twice the release, twice the decay (the random segments
    # have other phases, and 12 s hold a few of the resonance's 0.2 Hz bandwidth: their ratio
    # scatters)
    r1, r2 = (np.sqrt(np.mean(s.acceleration**2)) for s in segments[:2])
    assert r2 > r1
    d1, d2 = (np.max(np.abs(s.acceleration)) for s in segments[2:])
    assert d2 / d1 == pytest.approx(2.0, rel=1e-6)
    # the high-pass keeps the random segments' stroke at the oscillation's, without the drift
    _, x = integrals(segments[1].acceleration, FS)
    osc = np.max(np.abs(segments[1].acceleration)) / (2 * np.pi * f1) ** 2
    assert np.max(np.abs(x)) < 3 * osc


def test_programme_check_names_the_exceeded_limits(segments):
    prog = concatenate(FS, segments, pause=0.5)
    m = prog.motion()
    n_pause = int(0.5 * FS)
    assert prog.acceleration().size == sum(s.acceleration.size for s in segments) \
        + 3 * n_pause
    assert prog.duration == pytest.approx(prog.acceleration().size / FS)
    assert prog.lab_time(60.0) == pytest.approx(prog.duration + 4 * 60.0)
    big = ShakerLimits(2 * m["displacement"], 2 * m["velocity"], 2 * m["acceleration"])
    assert prog.check(big) == []
    small = ShakerLimits(m["displacement"] / 2, 2 * m["velocity"], m["acceleration"] / 2)
    msgs = prog.check(small, max_duration=prog.duration / 2)
    assert len(msgs) == 3
    assert msgs[0].startswith("peak acceleration") and f"{m['acceleration'] / G:.4g} g" in msgs[0]
    assert msgs[1].startswith("peak stroke") and "mm" in msgs[1]
    assert msgs[2].startswith("duration")


def test_bad_programmes_are_refused():
    with pytest.raises(ProgrammeError, match="at least one segment"):
        concatenate(FS, [])
    with pytest.raises(ProgrammeError, match="does not start and end at rest"):
        concatenate(FS, [Segment("step", "random", np.ones(100), 0.1)])
    with pytest.raises(ProgrammeError, match="kind must be one of"):
        Segment("x", "sine", np.zeros(10), 1.0)
    with pytest.raises(ProgrammeError, match="integer multiple"):
        structure_segments(None, Tank(), 1234.0, 500.0, [0.1], 10.0, 0, 12.0, 4.0, 0.01)
    assert isinstance(concatenate(FS, [Segment("z", "vfa", np.zeros(10), 0.0)]), Programme)
