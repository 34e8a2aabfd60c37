"""The grey box's C kernel in Dask workers of one XLA thread each: an ensemble trains 20 times
without a deadlock (the kernel runs on XLA's thread, with no Python in it: the compiled loops of
a previous round, called back through Python, deadlocked such a worker)."""

from __future__ import annotations

import os

import dask
import numpy as np
import pytest
from dask.distributed import Client, LocalCluster

from sloshrom.config import Tank
from sloshrom.io import record_from_measurement
from sloshrom.rig import VirtualRig
from sloshrom.rom import GreyBox
from sloshrom.rom.ensemble import Ensemble
from sloshrom.rom.grey.kernel import kernel_available
from sloshrom.rom.parallel import XLA_ONE_THREAD, worker_environ
from sloshrom.signals import vfa

FS = 500.0


def _worker_state() -> tuple[str, bool]:
    return os.environ.get("XLA_FLAGS", ""), kernel_available()


@pytest.mark.slow
@pytest.mark.timeout(1800)
@pytest.mark.skipif(not kernel_available(), reason="the grey kernel is not built here")
def test_ensemble_trains_20_times_in_single_threaded_workers():
    tank = Tank(fill=0.5)
    rig = VirtualRig(tank)
    path = vfa(1 / rig.dt, "train", duration=12.0, tank=tank, seed=1)
    rec = record_from_measurement(rig.measure(path.acceleration), tank)
    u, y = rec["velocity"], rec["dynamic_force"]
    n = u.size // 2
    template = GreyBox(n_states=3, neurons=8, window=10, horizon=40, batch=16, max_epochs=2,
                       steps_per_epoch=5, physics_generations=1, physics_population=2,
                       physics_windows=2, passivity=1.0, cycle_energy=0.1)
    env = worker_environ(1)
    spawn = "distributed.nanny.pre-spawn-environ"
    with dask.config.set({f"{spawn}.{k}": v for k, v in env.items()}), \
            LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                         dashboard_address=None) as cluster, Client(cluster) as client:
        states = client.run(_worker_state)
        assert len(states) == 2
        assert all(XLA_ONE_THREAD in flags and ok for flags, ok in states.values()), states
        for k in range(20):
            ens = Ensemble(template, n_members=2, seeds=[2 * k, 2 * k + 1]).fit(
                u[:n], y[:n], rec.fs, validation=(u[n:], y[n:]),
                scheduler=cluster.scheduler_address, fill=0.5)
            # every epoch of both members ran (a tiny model on 6 s may leave its start for the
            # worse: the best epoch is kept, and it predicts)
            assert [len(h["val_mse"]) for h in ens.history_] == [3, 3], k
            assert np.all(np.isfinite(ens.predict(u[n:]))), k
