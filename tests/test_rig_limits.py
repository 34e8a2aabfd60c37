"""One definition of the virtual rig's integration rate (``sloshrom.rig.limits.RIG_RATE``): the
rig's default step, the record rates the settings accept and the drive files of ``sloshrom
design`` read it; the rig's light modules load without numba."""

from __future__ import annotations

import subprocess
import sys

import pytest

from sloshrom.config import ConfigError
from sloshrom.rig.limits import RIG_RATE, check_record_rate
from sloshrom.rig.virtual import VirtualRig


def test_the_rig_steps_at_its_rate():
    assert VirtualRig().dt == 1.0 / RIG_RATE == 1e-4


def test_a_record_rate_divides_the_rig_rate():
    for fs in (250.0, 500.0, 1000.0, 2000.0):
        check_record_rate(fs)
    with pytest.raises(ConfigError, match=r"'rig\.fs' = 300 Hz must divide the rig's 10000 Hz"):
        check_record_rate(300.0, "'rig.fs'")


def test_the_limits_load_without_numba():
    code = ("import sys, sloshrom.rig.limits; "
            "print('numba' in sys.modules, 'sloshrom.rig.physics' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True)
    assert out.stdout.split() == ["False", "False"]
