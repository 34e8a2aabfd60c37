"""sloshrom: neural-network reduced-order models of vertical sloshing and the sloshing beam.

The top level holds what every part of the package shares: the tank (:class:`Tank`, ``G``,
:class:`ConfigError`), the base of every user error (:class:`SloshromError`) and the
sloshing-model contract (:class:`SloshingModel`, :class:`FrozenLiquid`). The ROMs (``NFIR``,
``NOE``, ``Ensemble``, ``load_model``) are re-exported lazily.
"""

from importlib.metadata import PackageNotFoundError, version

from sloshrom.config import ConfigError, G, Tank
from sloshrom.errors import SloshromError
from sloshrom.models import FrozenLiquid, SloshingModel

try:
    __version__ = version("sloshrom")
except PackageNotFoundError:  # pragma: no cover - running from a source tree
    __version__ = "0.0.0+unknown"

__all__ = [
    "G", "NFIR", "NOE", "ConfigError", "Ensemble", "FrozenLiquid", "SloshingModel",
    "SloshromError", "Tank", "__version__", "load_model",
]

# Lazy on purpose: sloshrom.rom imports JAX (about 0.5 s warm, seconds from a cold disk cache,
# against 0.2 s for `import sloshrom`), which the CLI's readers, the virtual rig and the energy
# maps never need. Resolved on first attribute access (PEP 562).
_LAZY = {"NFIR": "sloshrom.rom", "NOE": "sloshrom.rom", "Ensemble": "sloshrom.rom",
         "load_model": "sloshrom.rom"}


def __getattr__(name: str):
    if name in _LAZY:
        import importlib

        return getattr(importlib.import_module(_LAZY[name]), name)
    raise AttributeError(f"module 'sloshrom' has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted({*globals(), *_LAZY})
