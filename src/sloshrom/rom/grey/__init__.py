"""The grey-box ROM: an impacting liquid column (physics) and a network that corrects it.

One package, as every class of the registry: ``entry`` (its registry entry, no JAX),
``physics`` (the column: numba for its identification and features, JAX for the fitted
model's step), ``network`` (the model and the fitted :class:`GreyBoxNetwork`), ``training``
(the column's differential evolution, then the network's multiple shooting) and ``estimator``
(:class:`GreyBox`). The names below are resolved on first use, so that the entry loads without
JAX.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from sloshrom.rom.lazy import exports

if TYPE_CHECKING:
    from sloshrom.rom.grey.entry import GREY_CLASS as GREY_CLASS
    from sloshrom.rom.grey.estimator import GreyBox as GreyBox
    from sloshrom.rom.grey.network import GreyBoxNetwork as GreyBoxNetwork
    from sloshrom.rom.grey.network import GreySpec as GreySpec

_NAMES = {"GREY_CLASS": "entry", "GreyBox": "estimator", "GreyBoxNetwork": "network",
          "GreySpec": "network"}
__all__ = sorted(_NAMES)
__getattr__, __dir__ = exports(__name__, _NAMES)
