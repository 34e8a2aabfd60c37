"""The registry entries of the time-delay networks NFIR and NOE: what they are, without JAX.

Their hyperparameters (defaults, bounds, help), the shapes of their arrays, the fewest
training samples, the history a prediction reads and the sensitivity analysis's grid (paper
Fig. 8), as :class:`~sloshrom.rom.registry.ModelClass` entries that the command line, the
settings and the model files read. The networks themselves are in
:mod:`sloshrom.rom.tdnn.network`, their estimators in :mod:`sloshrom.rom.tdnn.estimators`.
"""

from __future__ import annotations

import math
import operator
from collections.abc import Mapping, Sequence
from typing import Any

from sloshrom.limits import HIDDEN_KINDS, MAX_DELAY, MAX_EPOCHS, MAX_OUT_DELAYS
from sloshrom.rom.errors import ROMError
from sloshrom.rom.registry import (
    LOSS_HYPERS,
    LOSS_TERMS,
    SEED,
    SHOOTING_HYPERS,
    Hyper,
    ModelClass,
    adam_only,
    neurons,
    precision,
)

__all__ = ["NFIR_CLASS", "NOE_CLASS", "PARAM_NAMES", "check_delays", "shooting_samples"]


def check_delays(delays: int | Sequence[int], name: str = "delays") -> tuple[int, ...]:
    """Delays (samples) as a tuple: ``n`` means ``1..n`` (MATLAB ``timedelaynet``).

    Raises
    ------
    ROMError
        ``n < 1``, an empty list, a delay < 1 or a repeated delay.
    """
    try:
        n = operator.index(delays)  # type: ignore[arg-type]
    except TypeError:
        d = tuple(int(x) for x in delays)  # type: ignore[union-attr]
        if not d or min(d) < 1 or len(set(d)) != len(d):
            raise ROMError(f"{name} must be distinct integers >= 1, got {delays!r}") from None
        return d
    if n < 1:
        raise ROMError(f"{name} must be >= 1, got {delays}")
    return tuple(range(1, n + 1))


def _delays(default: int, help: str) -> Hyper:
    return Hyper("delays", default, "delays", 1, MAX_DELAY, help=help, what="delays")


_HIDDEN = Hyper("hidden", "matlab", "choice", choices=HIDDEN_KINDS,
                help="normalized-RBF variant: matlab (radbasn, W x + b) or distance")
_EPOCHS = "training epochs at most"


def _rbf_shapes(h: Mapping[str, Any]) -> dict[str, tuple[int, ...]]:
    d = _rbf_width(h)
    n = int(h["neurons"])
    return {"W": (n, d), "b": (n,), "c": (n,), "c0": ()}


def _max_delay(h: Mapping[str, Any]) -> int:
    return max(check_delays(h["delays"]))


def _rbf_width(h: Mapping[str, Any]) -> int:
    # the regressor: the input delays, and an NOE's fed-back outputs
    return len(check_delays(h["delays"])) + int(h.get("out_delays", 0))


def _rbf_weights(h: Mapping[str, Any]) -> int:
    return int(h["neurons"]) * _rbf_width(h)


def shooting_samples(horizon: int) -> int:
    """The fewest samples of a multiple-shooting training (an NOE's by Adam): one sub-sequence,
    ``horizon`` samples after the sample it starts from."""
    return int(horizon) + 1


def _min_samples(h: Mapping[str, Any]) -> int:
    """The fewest training samples of a time-delay network: the delay lines and two samples
    per hundred parameters; an NOE trained by Adam (multiple shooting) also one sub-sequence
    (:func:`shooting_samples`)."""
    n_params = sum(math.prod(s) for s in _rbf_shapes(h).values())
    need = _max_delay(h) + int(h.get("out_delays", 0)) + 2 * n_params // 100 + 10
    if "horizon" in h and h.get("trainer") == "adam":
        need = max(need, shooting_samples(h["horizon"]))
    return need


NFIR_CLASS = ModelClass(
    name="nfir", class_name="NFIR", estimator="sloshrom.rom.tdnn.estimators:NFIR",
    summary="the paper's time-delay network: the force from a delay line of past inputs "
            "through a normalized radial-basis layer",
    hyper=(_delays(70, "input delays: n for 1..n (MATLAB timedelaynet) or a list"),
           neurons(35, "hidden normalized-RBF neurons"), _HIDDEN,
           Hyper("max_epochs", 1000, "int", 0, MAX_EPOCHS, help=_EPOCHS, what="an integer"),
           SEED,
           Hyper("trainer", "adam", "choice", choices=("adam", "fast", "lm"),
                 help="adam (minibatch, the loss terms), fast (subsampled LM) or lm (trainlm)"),
           *LOSS_HYPERS,
           precision("precision of the Adam steps: float32 is 1.7x faster and moves the "
                     "model by about 1e-4 of its force from one CPU to another, float64 by "
                     "1e-12 (adam; the LM trainers run float64)")),
    label=lambda h: f"NFIR({h['delays']}, {h['neurons']})",
    shapes=_rbf_shapes, history=_max_delay, min_samples=_min_samples,
    inputs=("velocity", "acceleration"), loss_terms=LOSS_TERMS,
    recipe={"amplitude_weighting": 0.05, "passivity": 1.0, "cycle_energy": 0.1},
    recipe_needs=adam_only, format_version=1, exports=frozenset({"fmu", "onnx"}),
    width=_rbf_width, weights=_rbf_weights, sizes=("neurons", "delays"),
    weights_text=lambda h: f"{int(h['neurons'])} neurons x {_rbf_width(h)} regressor entries",
    width_text="delays + output delays",
    paper=True, report="the paper's class, a network of the last samples of the tank velocity.",
    sweep=((50, 60, 70), (5, 10, 15, 20, 25, 30, 35, 40)),
    # the quick ROM (NFIR(40, 15), 60 epochs, 120 s) cannot represent the ~20 g
    # structure-designed training: its 6 g map error measured 88 % (14.7 % on the paper's
    # shaker VFA), so --quick keeps the shaker
    quick={"delays": 40, "neurons": 15, "max_epochs": 60},
)

NOE_CLASS = ModelClass(
    name="noe", class_name="NOE", estimator="sloshrom.rom.tdnn.estimators:NOE",
    summary="the paper's recurrent network: the force from the last inputs and its own last "
            "outputs",
    hyper=(_delays(2, "input delays: n for 1..n or a list"),
           neurons(10, "hidden normalized-RBF neurons"), _HIDDEN,
           Hyper("max_epochs", 1000, "int", 0, MAX_EPOCHS, help=_EPOCHS, what="an integer"),
           SEED,
           Hyper("trainer", "lm", "choice", choices=("lm", "fast", "adam"),
                 help="lm (Levenberg-Marquardt on the simulation error) or adam (multiple "
                      "shooting, the loss terms)"),
           Hyper("out_delays", 2, "int", 1, MAX_OUT_DELAYS, help="fed-back past outputs",
                 what="a number of outputs"),
           Hyper("unstable_bound", 10.0, "float", 0.0, 1e12, lo_open=True,
                 help="|scaled output| beyond which a simulation is unstable",
                 what="a bound"),
           *LOSS_HYPERS,
           Hyper("horizon", 300, "int", 8, MAX_DELAY,
                 help="adam: samples simulated from each start", what="a number of samples",
                 file_default=300),
           *SHOOTING_HYPERS),
    label=lambda h: f"NOE({h['delays']}, {h['neurons']})",
    shapes=_rbf_shapes, history=_max_delay, min_samples=_min_samples,
    start_history=lambda h: int(h["out_delays"]),
    loss_terms=LOSS_TERMS, recipe=dict.fromkeys(LOSS_TERMS, 0.0), recipe_needs=adam_only,
    format_version=1, exports=frozenset({"fmu", "onnx"}), width=_rbf_width,
    weights=_rbf_weights, sizes=("neurons", "delays", "out_delays"),
    weights_text=lambda h: f"{int(h['neurons'])} neurons x {_rbf_width(h)} regressor entries",
    width_text="delays + output delays",
    paper=True,
    report="the paper's recurrent class, a network of the last samples of the tank velocity "
           "and of its own last outputs.",
    sweep=((2,), (10, 15, 20)), sweep_first=True,
)

#: The arrays of a time-delay network, in file order.
PARAM_NAMES = NFIR_CLASS.param_names()
