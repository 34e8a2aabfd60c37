"""The paper's time-delay networks: NFIR and NOE with a normalized radial-basis layer.

One package, as every class of the registry: ``entry`` (their registry entries, no JAX),
``network`` (the pure network functions and the fitted :class:`NFIRNetwork`/:class:`NOENetwork`),
``training`` (Levenberg-Marquardt, minibatch Adam, the NOE's multiple shooting)
and ``estimators`` (:class:`NFIR`, :class:`NOE`). The names below
are resolved on first use, so that the entries load without JAX.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from sloshrom.rom.lazy import exports

if TYPE_CHECKING:
    from sloshrom.rom.tdnn.entry import (
        NFIR_CLASS as NFIR_CLASS,
    )
    from sloshrom.rom.tdnn.entry import (
        NOE_CLASS as NOE_CLASS,
    )
    from sloshrom.rom.tdnn.entry import (
        check_delays as check_delays,
    )
    from sloshrom.rom.tdnn.estimators import (
        NFIR as NFIR,
    )
    from sloshrom.rom.tdnn.estimators import (
        NOE as NOE,
    )
    from sloshrom.rom.tdnn.estimators import (
        TimeDelayEstimator as TimeDelayEstimator,
    )
    from sloshrom.rom.tdnn.network import (
        Network as Network,
    )
    from sloshrom.rom.tdnn.network import (
        NetworkSpec as NetworkSpec,
    )
    from sloshrom.rom.tdnn.network import (
        NFIRNetwork as NFIRNetwork,
    )
    from sloshrom.rom.tdnn.network import (
        NOENetwork as NOENetwork,
    )
    from sloshrom.rom.tdnn.network import (
        hidden_activations as hidden_activations,
    )
    from sloshrom.rom.tdnn.network import (
        n_params as n_params,
    )
    from sloshrom.rom.tdnn.network import (
        noe_simulate as noe_simulate,
    )
    from sloshrom.rom.tdnn.network import (
        pack as pack,
    )
    from sloshrom.rom.tdnn.network import (
        rbf_apply as rbf_apply,
    )
    from sloshrom.rom.tdnn.network import (
        unpack as unpack,
    )

_NAMES = {"NFIR_CLASS": "entry", "NOE_CLASS": "entry", "check_delays": "entry",
          "NFIR": "estimators", "NOE": "estimators", "TimeDelayEstimator": "estimators",
          **dict.fromkeys(("Network", "NetworkSpec", "NFIRNetwork", "NOENetwork",
                           "hidden_activations", "n_params", "noe_simulate", "pack",
                           "rbf_apply", "unpack"), "network")}
__all__ = sorted(_NAMES)
__getattr__, __dir__ = exports(__name__, _NAMES)
