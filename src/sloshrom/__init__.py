"""sloshrom: neural-network reduced-order models of vertical sloshing and the sloshing beam."""

from importlib.metadata import PackageNotFoundError, version

from sloshrom.config import ConfigError, G, Tank
from sloshrom.models import FrozenLiquid, SloshingModel

try:
    __version__ = version("sloshrom")
except PackageNotFoundError:  # pragma: no cover - running from a source tree
    __version__ = "0.0.0+unknown"

__all__ = [
    "G", "NFIR", "NOE", "ConfigError", "FrozenLiquid", "SloshingModel", "Tank", "__version__",
    "load_model",
]

_LAZY = {"NFIR": "sloshrom.rom", "NOE": "sloshrom.rom", "load_model": "sloshrom.rom"}


def __getattr__(name: str):
    # ROMs import JAX: load them on first use so that `import sloshrom` and the CLI stay fast.
    if name in _LAZY:
        import importlib

        return getattr(importlib.import_module(_LAZY[name]), name)
    raise AttributeError(f"module 'sloshrom' has no attribute {name!r}")
