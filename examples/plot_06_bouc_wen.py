"""
Identify another system: the Bouc–Wen hysteresis benchmark
==========================================================

The identification engine is not tied to sloshing: any input and output, with their names and
units. :mod:`sloshrom.systems` holds benchmark systems to try it on; here the Bouc–Wen
hysteretic oscillator (force in, displacement out, 750 Hz) is identified by the neural
state-space NSS and by the best linear model LSS, on short records (the benchmark's are longer:
``sloshrom system bouc-wen``).
"""

# %%
# The benchmark's records
# -----------------------
import matplotlib.pyplot as plt
import numpy as np

from sloshrom.systems.boucwen import benchmark_records

records = benchmark_records(seed=0, periods=2, samples=2048, validation_periods=1,
                            sweep=False)
for name, rec in records.items():
    print(f"{name}: {len(rec['force'])} samples, units {rec.units}")
train, val = records["train"], records["validation"]

# %%
# NSS and LSS on force -> displacement
# ------------------------------------
from sloshrom.rom import LSS, NSS

u, y = train["force"], train["displacement"]
fits = {}
# the units and names of this system (the defaults are the sloshing ROM's: m/s in, N out)
io = {"units": ("N", "m"), "names": ("force", "displacement")}
for name, model in {"NSS": NSS(max_epochs=3, seed=0, **io), "LSS": LSS(**io)}.items():
    model.fit(u, y, fs=train.fs, validation=(val["force"], val["displacement"]))
    pred = model.predict(val["force"])
    rmse = np.sqrt(np.mean((pred - val["displacement"]) ** 2))
    fits[name] = pred
    print(f"{name}: validation RMS error {rmse * 1e3:.3f} mm")

fig, ax = plt.subplots(figsize=(7, 3.5), layout="constrained")
t = np.arange(len(val["displacement"])) / val.fs
ax.plot(t, val["displacement"] * 1e3, color="k", lw=1.2, label="Bouc–Wen")
for name, pred in fits.items():
    ax.plot(t, pred * 1e3, lw=0.8, label=name)
ax.set(xlim=(0, 1.5), xlabel="time [s]", ylabel="displacement [mm]")
ax.legend()
plt.show()
