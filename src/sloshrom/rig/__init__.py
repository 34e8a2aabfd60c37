"""The virtual shaker rig: a physics-based tank simulator that plays the shaker experiment."""

from sloshrom.rig.virtual import *  # noqa: F403
from sloshrom.rig.virtual import __all__  # noqa: F401
