"""Reduced-order models: NFIR and NOE time-delay networks with normalized RBF hidden layers."""

from sloshrom.rom.estimators import *  # noqa: F403
from sloshrom.rom.estimators import __all__  # noqa: F401
