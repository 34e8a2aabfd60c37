"""The registry entry of the linear state-space baseline (LSS): what it is, without JAX.

Its hyperparameters (defaults, bounds, help), the shapes of its matrices, the fewest training
samples and the history a start reads, as the :class:`~sloshrom.rom.registry.ModelClass`
:data:`LSS_CLASS` that the command line, the settings and the model files read. The model and
its estimator are in :mod:`sloshrom.rom.lss.estimator`, the numerics in
:mod:`sloshrom.rom.lss.core`.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from sloshrom.rom.errors import ROMError
from sloshrom.rom.registry import Hyper, ModelClass, Naming

__all__ = ["LSS_CLASS", "lss_min_samples"]


def _lss_shapes(h: Mapping[str, Any]) -> dict[str, tuple[int, ...]]:
    n = int(h["n_states"])
    return {"A": (n, n), "B": (n,), "C": (n,), "D": ()}


def lss_min_samples(h: Mapping[str, Any]) -> int:
    """The fewest training samples: the block Hankel matrices need 2 i samples per column and
    8 i columns (i block rows)."""
    return 10 * int(h["block_rows"]) - 1


def _relations(h: Mapping[str, Any], naming: Naming) -> None:
    if h["block_rows"] <= h["n_states"]:
        raise ROMError(f"{naming.key('block_rows')} ({h['block_rows']}) must be more than "
                       f"{naming.key('n_states')} ({h['n_states']}): the Hankel matrices must "
                       "see the whole state")


LSS_CLASS = ModelClass(
    name="lss", class_name="LSS", estimator="sloshrom.rom.lss.estimator:LSS",
    summary="the best linear model: a linear state-space model identified by a subspace "
            "method (N4SID) and refined on its simulation error",
    hyper=(Hyper("n_states", 8, "int", 1, 64, help="order of the linear model",
                 what="a state dimension"),
           Hyper("block_rows", 20, "int", 2, 1000,
                 help="block rows of the subspace method's Hankel matrices (> n_states)",
                 what="a number of samples"),
           Hyper("max_epochs", 20, "int", 0, 10_000,
                 help="iterations of the output-error refinement (0 = the subspace estimate)",
                 what="an integer")),
    label=lambda h: f"LSS({h['n_states']} states)",
    shapes=_lss_shapes, history=lambda h: 0,
    min_samples=lss_min_samples,
    start_history=lambda h: int(h["n_states"]),
    format_version=4, exports=frozenset({"fmu"}), width=lambda h: int(h["n_states"]),
    sizes=("n_states",), ensemble=False, relations=_relations,
    report="the best linear model of the records (N4SID refined on its simulation error): "
           "what any nonlinear ROM buys is measured against it.",
)
