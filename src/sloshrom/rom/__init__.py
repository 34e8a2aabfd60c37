"""Reduced-order models: NFIR and NOE time-delay networks with normalized radial-basis hidden
layers, and the neural state-space ROM (NSS)."""

from sloshrom.rom.estimators import *  # noqa: F403
from sloshrom.rom.estimators import __all__  # noqa: F401
