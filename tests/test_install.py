"""Installs that work anywhere: a read-only package with no writable home imports and runs."""

from __future__ import annotations

import os
import shutil
import stat
import subprocess
import sys
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
import sloshrom.beam.simulation.coupled, sloshrom.rig.physics, sloshrom.rom.ball.model
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


def _read_only_command(site: Path, argv: list[str]) -> list[str]:
    """``argv`` run where ``site`` cannot be written, even by root.

    A normal user: the read-only modes suffice. Root writes through modes, so ``site`` is bind
    mounted read-only in a private mount namespace (``unshare -m``), as on a read-only image.
    """
    if not hasattr(os, "geteuid") or os.geteuid() != 0:
        return argv
    unshare = shutil.which("unshare")
    if unshare is None or subprocess.run([unshare, "-m", "true"], capture_output=True).returncode:
        pytest.skip("running as root without mount namespaces: cannot make a read-only install")
    mount = f"mount --bind {site} {site} && mount -o remount,bind,ro {site} && exec \"$@\""
    return [unshare, "-m", "sh", "-c", mount, "sh", *argv]


@pytest.mark.parametrize("script", [IMPORT, pytest.param(RIG, marks=pytest.mark.slow)],
                         ids=["import", "rig"])
def test_read_only_install_without_a_writable_home(script, tmp_path):
    """numba cannot cache anywhere: the kernels compile in memory, with no warning or error."""
    site = _read_only_copy(tmp_path)
    env = {k: v for k, v in os.environ.items()
           if not k.startswith(("NUMBA_CACHE", "HOME", "XDG_CACHE",
                                "JAX_COMPILATION_CACHE", "JAX_PERSISTENT_CACHE"))}  # conftest.py
    env["HOME"] = str(site / "home")  # does not exist and cannot be made
    try:
        res = subprocess.run(_read_only_command(site, [sys.executable, "-c", script, str(site)]),
                             env=env, capture_output=True, text=True, timeout=300)
        assert res.returncode == 0, res.stderr[-3000:]
        assert float(res.stdout.strip().splitlines()[-1]) > 0
        assert not list(site.rglob("__pycache__")), "wrote into the read-only package"
    finally:
        for p in [site, *site.rglob("*")]:
            if p.is_dir():
                p.chmod(0o755)  # so that pytest can remove tmp_path
