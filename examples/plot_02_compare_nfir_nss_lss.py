"""
Compare NFIR, NSS and LSS on one record
=======================================

Three model classes identified on the same training record and scored on the same validation
record: the paper's NFIR (a time-delay network), the neural state-space NSS (a state that
carries where the liquid is) and the best linear model LSS (N4SID refined on its simulation
error), which shows what the nonlinearity buys. Each class is one entry of
:mod:`sloshrom.rom.registry`; the sizes here are small, ``sloshrom train --arch ...`` and
``sloshrom reproduce`` use larger ones.
"""

# %%
# One training and one validation record from the virtual rig
# -----------------------------------------------------------
import time

import matplotlib.pyplot as plt
import numpy as np

import sloshrom
from sloshrom import signals
from sloshrom.io import record_from_measurement
from sloshrom.rig import VirtualRig

tank = sloshrom.Tank(fill=0.5)
rig = VirtualRig(tank)
rec = {}
for split, seed in (("train", 1), ("validation", 2)):
    vfa = signals.vfa(1 / rig.dt, split, duration=20.0, tank=tank, seed=seed)
    rec[split] = record_from_measurement(rig.measure(vfa.acceleration), tank)
train, val = rec["train"], rec["validation"]

# %%
# Three classes, one fit each
# ---------------------------
from sloshrom.rom import LSS, NFIR, NSS

models = {
    "NFIR": NFIR(delays=20, neurons=8, max_epochs=30, seed=0),
    "NSS": NSS(max_epochs=3, seed=0),
    "LSS": LSS(),
}
fits = {}
for name, model in models.items():
    start = time.perf_counter()
    model.fit(train["velocity"], train["dynamic_force"], fs=train.fs,
              validation=(val["velocity"], val["dynamic_force"]))
    y = model.predict(val["velocity"])
    fit = 100 * (1 - np.linalg.norm(y - val["dynamic_force"])
                 / np.linalg.norm(val["dynamic_force"] - val["dynamic_force"].mean()))
    fits[name] = y
    print(f"{name}: validation fit {fit:5.1f} %, identified in {time.perf_counter() - start:.1f} s")

# %%
# The validation record and the three free runs
# ---------------------------------------------
fig, ax = plt.subplots(figsize=(7, 3.5), layout="constrained")
t = np.arange(len(val["dynamic_force"])) / val.fs
ax.plot(t, val["dynamic_force"], color="k", lw=1.2, label="rig")
for name, y in fits.items():
    ax.plot(t, y, lw=0.8, label=name)
ax.set(xlim=(12, 15), xlabel="time [s]", ylabel="dynamic force [N]")
ax.legend(ncols=4)
plt.show()
