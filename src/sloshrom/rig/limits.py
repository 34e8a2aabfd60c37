"""What the virtual rig can run: its integration rate and the longest and shortest runs, one
definition read by the command line (``sloshrom rig``, ``sloshrom design``) and the settings of
``sloshrom reproduce`` alike.

Numbers and a check only (no numerical library): the command line reads them when it starts.
"""

from __future__ import annotations

from sloshrom.config import ConfigError

__all__ = ["MAX_FINE_SECONDS", "MIN_VFA_DURATION", "RIG_RATE", "check_record_rate"]

#: The virtual rig's integration rate, Hz (its fine step ``VirtualRig.dt`` = 1 / RIG_RATE =
#: 1e-4 s): a record rate must divide it.
RIG_RATE = 10_000.0
#: Longest run at the virtual rig's fine step (10 kHz), s. A VFA record holds about 20 float64
#: arrays per fine sample at its peak (path, derivatives, filtered sensor channels): measured
#: 1.6 MB per second of record, so one hour needs about 6 GB of memory and a minute of CPU.
MAX_FINE_SECONDS = 3600.0
#: Shortest VFA path, s (``sloshrom.signals.vfa``: 2 s fade in and out plus the sweep).
MIN_VFA_DURATION = 10.0


def check_record_rate(fs: float, name: str = "fs", error: type[ValueError] = ConfigError) -> None:
    """A record rate ``fs`` (Hz) of the rig's sensors must divide its integration rate
    :data:`RIG_RATE`: the beam's random excitation is made at ``fs`` and upsampled exactly for
    the rig. ``name`` is the option's or the key's name in the message, ``error`` its type."""
    if abs(RIG_RATE / fs - round(RIG_RATE / fs)) > 1e-9:
        raise error(
            f"{name} = {fs:g} Hz must divide the rig's {RIG_RATE:g} Hz integration "
            "rate (e.g. 250, 500, 1000, 2000 Hz): the beam's random excitation is made at "
            "fs and upsampled exactly for the rig")
