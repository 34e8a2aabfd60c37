"""
Identify a ROM from your own shaker record
==========================================

You have a shaker test of your tank: the vertical acceleration of the tank and the force of the
load cells, sampled together, in a CSV file with the unit of each column in its header. This
example identifies a neural network ROM of the sloshing force from it and draws the ROM's
dissipated-energy map Φ_d(ω̄, ā).

Here the "measurement" comes from the package's virtual rig, written as a laboratory would
write it (acceleration in g, force in kN), so that the example runs anywhere; with your own
data, start at :func:`sloshrom.io.read_record`. The sizes are small so that the page builds in
seconds: ``sloshrom reproduce`` uses 480 s of training record and the paper's network.
"""

# %%
# A shaker record as a CSV file
# -----------------------------
# Two variable-frequency-amplitude (VFA) tests on the virtual rig: one to train on, one to
# validate on. Their columns are written with the units a laboratory uses.
import tempfile
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np

import sloshrom
from sloshrom import signals
from sloshrom.rig import VirtualRig

tank = sloshrom.Tank(fill=0.5)  # the paper's tank, SI units
rig = VirtualRig(tank)
folder = Path(tempfile.mkdtemp())
for split, seed in (("train", 1), ("validation", 2)):
    path = signals.vfa(1 / rig.dt, split, duration=20.0, tank=tank, seed=seed)
    m = rig.measure(path.acceleration)
    lines = ["time [s],acceleration [g],force [kN]"]
    lines += [f"{t:.6f},{a / sloshrom.G:.8g},{f / 1000:.8g}"
              for t, a, f in zip(m["time"], m["acceleration"], m["force"], strict=True)]
    (folder / f"{split}.csv").write_text("\n".join(lines) + "\n")
print("\n".join((folder / "train.csv").read_text().splitlines()[:4]))

# %%
# Read and preprocess
# -------------------
# :func:`~sloshrom.io.read_record` converts every column to SI units from its header;
# :func:`~sloshrom.io.preprocess` integrates the tank velocity (drift removed by a zero-phase
# high-pass) and computes the dynamic force ``Δf = force + (m_l + m_struct)·acceleration``, the
# ROM's output.
from sloshrom.io import preprocess, read_record

train = preprocess(read_record(folder / "train.csv"), tank)
val = preprocess(read_record(folder / "validation.csv"), tank)
print(f"{len(train['velocity'])} samples at {train.fs:g} Hz:", train.units)

# %%
# Identify the ROM
# ----------------
# The paper's NFIR (a time-delay network with a normalised RBF layer), small and briefly
# trained. Its input is the tank velocity, its output the dynamic force.
from sloshrom.rom import NFIR, load_model

rom = NFIR(delays=20, neurons=8, max_epochs=30, seed=0).fit(
    train["velocity"], train["dynamic_force"], fs=train.fs,
    validation=(val["velocity"], val["dynamic_force"]))
predicted = rom.predict(val["velocity"])  # free run, N
error = np.sqrt(np.mean((predicted - val["dynamic_force"]) ** 2)) / np.std(val["dynamic_force"])
print(f"validation: normalised RMS error {error:.2f}")

model_file = rom.save(folder / "my_rom.npz")  # npz + JSON metadata, no pickle
rom = load_model(model_file)

fig, ax = plt.subplots(figsize=(7, 3), layout="constrained")
t = np.arange(len(predicted)) / val.fs
ax.plot(t, val["dynamic_force"], lw=0.8, label="measured")
ax.plot(t, predicted, lw=0.8, label="ROM")
ax.set(xlim=(10, 14), xlabel="time [s]", ylabel="dynamic force [N]")
ax.legend()

# %%
# The ROM's Φ_d map
# -----------------
# The energy the liquid dissipates per cycle of harmonic tests over the shaker's envelope
# (:func:`~sloshrom.energy.phi_d_map`), on a coarse 6 × 6 grid (the paper's is 30 × 30).
from sloshrom.energy import default_grid, phi_d_map
from sloshrom.plotting.maps import plot_phi_d_map

phi = phi_d_map(rom, *default_grid(6), tank=tank)
print(phi.sizes)
fig, ax = plt.subplots(figsize=(6, 4.5), layout="constrained")
plot_phi_d_map(phi, ax=ax)
ax.set_title("Φ_d of the identified ROM")
plt.show()
