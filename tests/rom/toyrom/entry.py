"""The toy class's registry entry: a FIR filter of ``taps`` input samples, fitted by ridge least
squares. What the command line, the settings and the model files read of it."""

from __future__ import annotations

from sloshrom.rom.errors import ROMError
from sloshrom.rom.registry import Hyper, ModelClass, Naming


def _relations(h, naming: Naming) -> None:
    # a rule between values, checked by the one rules path like any class's
    if h["taps"] > 8 and h["ridge"] == 0.0:
        raise ROMError(f"{naming.key('taps')} > 8 needs {naming.key('ridge')} > 0")


TOY_CLASS = ModelClass(
    name="toy", class_name="Toy", estimator="toyrom.estimator:Toy",
    summary="a toy: the force a FIR filter of the last velocity samples",
    hyper=(Hyper("taps", 2, "int", 1, 16, help="input samples the filter reads",
                 what="a number of samples"),
           Hyper("ridge", 1e-9, "float", 0.0, 1.0, help="ridge of the least squares",
                 what="a ridge")),
    label=lambda h: f"Toy({h['taps']} taps)",
    shapes=lambda h: {"w": (int(h["taps"]),), "bias": ()},
    history=lambda h: int(h["taps"]) - 1,
    min_samples=lambda h: 10 * int(h["taps"]),
    width=lambda h: int(h["taps"]), sizes=("taps",), ensemble=False,
    relations=_relations,
    report="a toy of the tests, not a model of sloshing.",
)
