"""Installs that work anywhere: a read-only package with no writable home imports and runs."""

from __future__ import annotations

import os
import shutil
import stat
import subprocess
import sys
import tempfile
from pathlib import Path

import pytest

import sloshrom

PACKAGE = Path(sloshrom.__file__).parent

# every numba kernel is decorated at import, where numba refuses a cache it cannot write
IMPORT = """
import sys, warnings
warnings.simplefilter("error")  # a cache warning is a failure too
sys.path.insert(0, sys.argv[1])
import sloshrom
assert sloshrom.__file__.startswith(sys.argv[1]), sloshrom.__file__
import sloshrom.beam.coupled, sloshrom.rig.physics, sloshrom.rom.bouncing
print(1.0)
"""
# the rig's kernels compiled (in memory) and run on a harmonic test
RIG = IMPORT.replace("print(1.0)", """import numpy as np
from sloshrom import Tank
from sloshrom.rig.virtual import VirtualRig
from sloshrom.signals import harmonic
rig = VirtualRig(Tank())
h = harmonic(1 / rig.dt, 12.0, 0.005, n_cycles=3)
print(float(np.abs(rig.simulate(h.velocity, h.acceleration)).max()))""")


def _read_only_copy(root: Path) -> Path:
    """The package copied under ``root`` (no caches), every file and folder read-only."""
    dest = root / "site"
    shutil.copytree(PACKAGE, dest / "sloshrom", ignore=shutil.ignore_patterns("__pycache__"))
    for p in [dest, *dest.rglob("*")]:
        mode = stat.S_IRUSR | stat.S_IRGRP | stat.S_IROTH
        p.chmod(mode | (stat.S_IXUSR | stat.S_IXGRP | stat.S_IXOTH if p.is_dir() else 0))
    return dest


@pytest.mark.parametrize("script", [IMPORT, pytest.param(RIG, marks=pytest.mark.slow)],
                         ids=["import", "rig"])
def test_read_only_install_without_a_writable_home(script):
    """numba cannot cache anywhere: the kernels compile in memory, with no warning or error."""
    as_root = os.geteuid() == 0 if hasattr(os, "geteuid") else False
    prefix: list[str] = []
    if as_root:  # root writes through read-only modes: run as nobody
        setpriv = shutil.which("setpriv")
        if setpriv is None:
            pytest.skip("running as root without setpriv: cannot drop to an unprivileged user")
        prefix = [setpriv, "--reuid=65534", "--regid=65534", "--clear-groups"]
    root = Path(tempfile.mkdtemp(prefix="sloshrom-ro-"))
    try:
        root.chmod(0o755)  # readable by the unprivileged user
        site = _read_only_copy(root)
        env = {k: v for k, v in os.environ.items() if not k.startswith(("NUMBA_CACHE", "HOME"))}
        env["HOME"] = str(root / "no-such-home")
        res = subprocess.run([*prefix, sys.executable, "-c", script, str(site)], env=env,
                             capture_output=True, text=True, timeout=300)
        assert res.returncode == 0, res.stderr[-3000:]
        assert float(res.stdout.strip().splitlines()[-1]) > 0
        assert not list(site.rglob("__pycache__")), "wrote into the read-only package"
    finally:
        for p in [root, *root.rglob("*")]:
            if p.is_dir():
                p.chmod(0o755)
        shutil.rmtree(root)
