"""The neural state-space ROM (NSS): a network with a state, identified by multiple shooting.

One package, as every class of the registry: ``entry`` (its registry entry, its limits and its
size rule for short records, no JAX), ``network`` (the model, its encoder and the fitted
:class:`StateSpaceNetwork`, with its FMU kernel's data), ``training`` (multiple shooting from
the encoder) and ``estimator`` (:class:`NSS`). The names below are resolved on first use, so
that the entry loads without JAX.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from sloshrom.rom.lazy import exports

if TYPE_CHECKING:
    from sloshrom.rom.nss.entry import (
        NSS_CLASS as NSS_CLASS,
    )
    from sloshrom.rom.nss.entry import (
        NSS_PARAM_NAMES as NSS_PARAM_NAMES,
    )
    from sloshrom.rom.nss.entry import (
        nss_size as nss_size,
    )
    from sloshrom.rom.nss.estimator import (
        NSS as NSS,
    )
    from sloshrom.rom.nss.network import (
        StateSpaceNetwork as StateSpaceNetwork,
    )
    from sloshrom.rom.nss.network import (
        StateSpaceSpec as StateSpaceSpec,
    )
    from sloshrom.rom.nss.training import (
        fit_statespace as fit_statespace,
    )

_NAMES = {"NSS_CLASS": "entry", "NSS_PARAM_NAMES": "entry", "nss_size": "entry",
          "NSS": "estimator", "StateSpaceNetwork": "network", "StateSpaceSpec": "network",
          "fit_statespace": "training"}
__all__ = sorted(_NAMES)
__getattr__, __dir__ = exports(__name__, _NAMES)
