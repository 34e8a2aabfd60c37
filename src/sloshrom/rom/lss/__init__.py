"""The linear state-space baseline ROM (LSS): the best linear model of the tank.

``x_{k+1} = A x_k + B u_k``, ``y_k = C x_k + D u_k`` from rest, with the tank velocity u (m/s)
in and the dynamic sloshing force y (N) out, identified by a subspace method (N4SID) and
refined on its simulation error. It answers the question every report should: how much does
the nonlinear ROM buy over the best linear model of the same records?

One package, as every class of the registry: ``entry`` (its registry entry, no JAX),
``estimator`` (the fitted model :class:`LinearStateSpace` and the estimator :class:`LSS`),
``core`` (the numerics: N4SID, the output-error refinement, the simulation). The names below
are resolved on first use, so that the entry loads without JAX.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from sloshrom.rom.lazy import exports

if TYPE_CHECKING:
    from sloshrom.rom.lss.entry import (
        LSS_CLASS as LSS_CLASS,
    )
    from sloshrom.rom.lss.estimator import (
        LSS as LSS,
    )
    from sloshrom.rom.lss.estimator import (
        LinearSpec as LinearSpec,
    )
    from sloshrom.rom.lss.estimator import (
        LinearStateSpace as LinearStateSpace,
    )

_NAMES = {"LSS": "estimator", "LinearSpec": "estimator", "LinearStateSpace": "estimator",
          "LSS_CLASS": "entry"}
__all__ = sorted(_NAMES)
__getattr__, __dir__ = exports(__name__, _NAMES)
