"""
Export a ROM as an FMU and run it with FMPy
===========================================

An FMI 2.0 co-simulation FMU runs the ROM in any tool that imports FMUs (Simulink,
OpenModelica, Dymola, Amesim, Adams, libcosim) as native code, with no Python at run time.
:func:`sloshrom.rom.fmu.export_fmu` generates and compiles its C sources (a C compiler and CMake
are needed to export, not to run); here FMPy plays the simulator and the FMU's force is compared
with the ROM's own prediction.
"""

# %%
# A small ROM
# -----------
import tempfile
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np

import sloshrom
from sloshrom import signals
from sloshrom.io import record_from_measurement
from sloshrom.rig import VirtualRig
from sloshrom.rom import NFIR

tank = sloshrom.Tank(fill=0.5)
rig = VirtualRig(tank)
records = []
for split, seed in (("train", 1), ("validation", 2)):
    vfa = signals.vfa(1 / rig.dt, split, duration=20.0, tank=tank, seed=seed)
    records.append(record_from_measurement(rig.measure(vfa.acceleration), tank))
train, val = records
rom = NFIR(delays=20, neurons=8, max_epochs=30, seed=0).fit(
    train["velocity"], train["dynamic_force"], fs=train.fs)

# %%
# Export
# ------
from sloshrom.rom.fmu import export_fmu

folder = Path(tempfile.mkdtemp())
fmu = export_fmu(rom, folder / "slosh.fmu")
print(f"{fmu.name}: {fmu.stat().st_size / 1024:.0f} kB")

# %%
# Run it with FMPy
# ----------------
# The input ``velocity`` is given as a table; the communication step is the model's ``dt``.
import fmpy

description = fmpy.read_model_description(str(fmu))
print([(v.name, v.causality) for v in description.modelVariables][:6])
n = 2000
u = val["velocity"][:n]
signal = np.zeros(n, dtype=[("time", np.float64), ("velocity", np.float64)])
signal["time"] = np.arange(n) * rom.dt
signal["velocity"] = u
result = fmpy.simulate_fmu(str(fmu), start_time=0.0, stop_time=(n - 1) * rom.dt,
                           step_size=rom.dt, output_interval=rom.dt, input=signal,
                           output=["dynamic_force"])
reference = rom.predict(u)
m = min(len(result), n)
difference = np.max(np.abs(result["dynamic_force"][:m] - reference[:m]))
print(f"largest difference FMU - Python: {difference:.2e} N")

fig, ax = plt.subplots(figsize=(7, 3), layout="constrained")
ax.plot(result["time"][:m], reference[:m], lw=2, alpha=0.5, label="ROM in Python")
ax.plot(result["time"][:m], result["dynamic_force"][:m], lw=0.8, label="FMU in FMPy")
ax.set(xlabel="time [s]", ylabel="dynamic force [N]")
ax.legend()
plt.show()
