"""The error type of the rig room.

:class:`RigError` is raised for bad input to the virtual rig (its time step, a state, the motion
it is asked to play or to measure). It is a :class:`~sloshrom.errors.SloshromError`, which
command-line tools catch and print in one line. The rig's parameters are configuration and raise
:class:`~sloshrom.config.ConfigError`.
"""

from __future__ import annotations

from sloshrom.errors import SloshromError

__all__ = ["RigError"]


class RigError(SloshromError):
    """Bad input to the virtual rig: time step, state, or the motion to play or measure."""
