"""sloshrom: neural-network reduced-order models of vertical sloshing and the sloshing beam."""

from importlib.metadata import PackageNotFoundError, version

from sloshrom.config import ConfigError, G, Tank
from sloshrom.models import FrozenLiquid, SloshingModel

try:
    __version__ = version("sloshrom")
except PackageNotFoundError:  # pragma: no cover - running from a source tree
    __version__ = "0.0.0+unknown"

__all__ = ["G", "ConfigError", "FrozenLiquid", "SloshingModel", "Tank", "__version__"]
