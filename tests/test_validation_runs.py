"""The rom stage's validation runs (pipeline.rom._ValidationRuns): a member's runs start as it
has trained, the others' at the validation, a core each; every figure is the model's own."""

from __future__ import annotations

import threading
import warnings

import numpy as np
import pytest

from helpers import smooth_io
from sloshrom._threads import numba_threadsafe
from sloshrom.energy import frame_change, frame_sensitivity
from sloshrom.models import EnvelopeWarning
from sloshrom.pipeline.rom import _ValidationRuns
from sloshrom.rom.ensemble import Ensemble
from sloshrom.rom.tdnn.estimators import NFIR

FS = 500.0


@pytest.fixture(scope="module")
def setting():
    u, y = smooth_io()
    uv, yv = smooth_io(600, 2)
    ens = Ensemble(NFIR(delays=3, neurons=4, max_epochs=3, seed=7), n_members=3).fit(
        u, y, FS, validation=(uv, yv), scheduler="sequential")
    return ens, (u, y, uv, yv)


def _twin(calls: list[str], force: np.ndarray):
    def run() -> tuple[np.ndarray, float]:
        calls.append(threading.current_thread().name)
        return force, 0.25
    return run


@pytest.mark.parametrize("early", [[], [1], [2, 0], [0, 1, 2]])
def test_the_runs_give_the_ensembles_own_figures_to_the_bit(setting, early):
    ens, records = setting
    u, _, uv, yv = records
    calls: list[str] = []
    runs = _ValidationRuns(records, FS, _twin(calls, yv))
    try:
        for k in early:  # members that have trained while the others still train
            runs.start(k, ens.members_[k])
        with warnings.catch_warnings():
            # the frame probes leave the envelope on purpose: the runs say nothing of it
            warnings.simplefilter("error", EnvelopeWarning)
            res = runs.results(ens.members_)
        twin = runs.twin()
    finally:
        runs.close()
    assert len(res) == 3
    for k, m in enumerate(ens.members_):
        np.testing.assert_array_equal(res[k]["validation"], m.predict(uv))
        np.testing.assert_array_equal(res[k]["training"], m.predict(u))

    def mean(key: str) -> np.ndarray:
        return np.stack([r[key] for r in res]).mean(axis=0)

    np.testing.assert_array_equal(mean("validation"), ens.predict(uv))
    np.testing.assert_array_equal(mean("training"), ens.predict(u))
    frame = frame_change(runs.probes, FS, [mean(f"frame {i}") for i in range(5)])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", EnvelopeWarning)
        assert frame == frame_sensitivity(ens, uv, FS)
    # the twin run once, beside the first member's runs (or at the validation; in this thread
    # where numba's workqueue layer forbids two parallel kernels at once)
    assert len(calls) == 1 and twin[1] == 0.25
    assert calls[0] == ("sloshrom-twin-run" if numba_threadsafe()
                        else threading.current_thread().name)


def test_one_model_alone_and_a_member_that_fails(setting):
    ens, records = setting
    u, _, uv, yv = records
    member = ens.members_[0]
    runs = _ValidationRuns(records, FS, _twin([], yv))
    try:
        (res,) = runs.results([member])
    finally:
        runs.close()
    np.testing.assert_array_equal(res["validation"], member.predict(uv))
    np.testing.assert_array_equal(res["frame 0"], res["validation"])

    class Broken:
        def predict(self, x):
            raise RuntimeError("this member cannot run")

        def simulate(self, v, a):
            raise RuntimeError("this member cannot run")

    runs = _ValidationRuns(records, FS, _twin([], yv))
    try:
        runs.start(1, Broken())
        with pytest.raises(RuntimeError, match="cannot run"):
            runs.results([member, Broken()])
    finally:
        runs.close()
