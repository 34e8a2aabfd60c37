"""
Couple a ROM with your own structure (UFF 55 modes)
===================================================

Your structure's normal modes come from a finite-element model or a modal test, in a UFF 55
file (``.unv``) with a table of per-mode damping, modal masses and participation factors. This
example reads them (:func:`sloshrom.beam.simulation.modal_files.read_modes`), puts a tank at one
node and releases the structure from a static tip load (paper Sect. 4.3) three times: with the
liquid frozen, with the virtual rig as the liquid, and with an identified ROM.

Here the UFF file is written from the package's built-in cantilever so that the example is self
contained; with your own file, start at ``read_modes``.
"""

# %%
# Your modes as a UFF 55 file and a mode table
# --------------------------------------------
import tempfile
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np

import sloshrom
from sloshrom.beam.simulation.modal_files import read_modes, write_mode_table, write_modes_uff
from sloshrom.beam.simulation.modes import ModeSet

folder = Path(tempfile.mkdtemp())
cantilever = ModeSet.from_cantilever()  # nodes 1..5 at the stations, the tank at node 5
write_modes_uff(cantilever, folder / "structure.unv")
write_mode_table(cantilever, folder / "modes.csv")

modes = read_modes(folder / "structure.unv", mode_table=folder / "modes.csv")
print(f"{len(modes.frequencies)} modes at {len(modes.nodes)} nodes from {modes.source}")
modal = modes.to_modal_model(tanks=5, outputs=[1, 2, 3, 4, 5], direction="+Z")
print("natural frequencies [Hz]:", np.round(modal.frequencies, 2))

# %%
# A ROM of the liquid
# -------------------
# Identified on a short test of the virtual rig (see the first example for your own record).
from sloshrom import signals
from sloshrom.io import record_from_measurement
from sloshrom.rig import VirtualRig
from sloshrom.rom import NFIR

tank = sloshrom.Tank(fill=0.5)
rig = VirtualRig(tank)
vfa = signals.vfa(1 / rig.dt, "train", duration=20.0, tank=tank, seed=1)
train = record_from_measurement(rig.measure(vfa.acceleration), tank)
rom = NFIR(delays=20, neurons=8, max_epochs=30, seed=0).fit(
    train["velocity"], train["dynamic_force"], fs=train.fs)

# %%
# Free responses of the coupled structure
# ---------------------------------------
# Any sloshing model goes in: they share one step contract
# (``step(state, velocity, acceleration) -> (state, dynamic_force)``).
from sloshrom.beam.simulation.coupled import free_response

runs = {"frozen liquid": sloshrom.FrozenLiquid(rom.dt), "virtual rig": rig, "ROM": rom}
fig, ax = plt.subplots(figsize=(7, 3.5), layout="constrained")
for name, model in runs.items():
    out = free_response(model, modal, duration=2.0, tank=tank)
    ax.plot(out["time"], out["tank_acceleration"] / sloshrom.G, lw=0.8, label=name)
ax.set(xlabel="time [s]", ylabel="tank acceleration [g]")
ax.legend()
plt.show()
