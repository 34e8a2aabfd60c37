"""
Analyse a laboratory campaign and compare it with a prediction
==============================================================

A test laboratory hands over a folder of UFF 58 files (free decays and random base excitation
of the sloshing beam, each channel in its own unit) and a channel map that says which channel is
which. ``sloshrom analyse campaign`` reads every file, finds every mode in the data and
estimates the damping of each with its 95 % interval; ``sloshrom compare`` puts a measured test
beside a predicted one with a verdict per level.

``sloshrom analyse example`` writes such a campaign (the virtual rig played as the laboratory):
replace its folder with yours. The command-line app is called from Python here; in a terminal
the same commands are ``sloshrom analyse ...`` (see the command-line reference).
"""

# %%
# The laboratory's folder
# -----------------------
import tempfile
from pathlib import Path

from sloshrom.cli import app

folder = Path(tempfile.mkdtemp())
lab = folder / "lab"


def sloshrom(*args: str) -> None:
    """Run one ``sloshrom`` command as in a terminal."""
    app([str(a) for a in args], standalone_mode=False)


sloshrom("analyse", "example", lab, "--duration", "34")  # random runs of 34 s (default 120)
for f in sorted(lab.iterdir()):
    print(f.name)
print((lab / "channels.toml").read_text()[:600])

# %%
# Every test of the campaign, every mode
# --------------------------------------
sloshrom("analyse", "campaign", lab, "--channels", lab / "channels.toml",
         "--out", lab / "results")
for f in sorted((lab / "results").rglob("*.md"))[:3]:
    print(f"--- {f.relative_to(lab)}")
    print(f.read_text()[:1200])

# %%
# The figures of a test
# ---------------------
import matplotlib.image as mpimg
import matplotlib.pyplot as plt

pngs = sorted((lab / "results").rglob("*.png"))
print([p.name for p in pngs])
fig, ax = plt.subplots(figsize=(7, 5), layout="constrained")
ax.imshow(mpimg.imread(pngs[0]))
ax.set_axis_off()

# %%
# Measured against predicted
# --------------------------
# ``sloshrom compare`` sets predictions beside one measured result (any NetCDF of
# ``sloshrom analyse``, ``sloshrom beam`` or ``reproduce``'s ``beam/``). Here the sloshing beam's
# free decay with the virtual rig as the liquid plays the measurement (with your laboratory's
# decay: ``sloshrom analyse free decay.uff --channels channels.toml --out lab``), and the
# prediction is the beam with the liquid frozen: per amplitude band, the measured damping with
# its interval, the predicted one, and the verdict. The frozen liquid misses the damping that
# sloshing adds.
sloshrom("beam", "free", "--sloshing", "rig", "--sloshing", "frozen", "--duration", "6",
         "--out", folder / "sim")
sloshrom("compare", folder / "sim" / "free_rig.nc", folder / "sim" / "free_frozen.nc",
         "--out", folder / "comparison")
print((folder / "comparison" / "comparison.md").read_text())

png = sorted((folder / "comparison").glob("*.png"))[0]
fig, ax = plt.subplots(figsize=(7, 5), layout="constrained")
ax.imshow(mpimg.imread(png))
ax.set_axis_off()
plt.show()
