"""The registry entry of the neural state-space ROM (NSS): what it is, without JAX.

Its hyperparameters (defaults, bounds, help), the shapes of its arrays (:func:`nss_shapes`,
:data:`NSS_PARAM_NAMES`), its limits (the largest state, the work of a training epoch), the
fewest training samples and its size rule for short records (:func:`nss_size`), as the
:class:`~sloshrom.rom.registry.ModelClass` :data:`NSS_CLASS` that the command line, the
settings and the model files read. The model is in :mod:`sloshrom.rom.nss.network`, its
training in :mod:`sloshrom.rom.nss.training`, its estimator in :mod:`sloshrom.rom.nss.estimator`.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

from sloshrom.limits import MAX_DELAY, MAX_EPOCHS
from sloshrom.rom.registry import (
    EPOCH_WORK_SECONDS,
    LOSS_HYPERS,
    LOSS_TERMS,
    MAX_EPOCH_WORK,
    MAX_STATES,
    SEED,
    SHOOTING_HYPERS,
    EpochWork,
    Hyper,
    ModelClass,
    neurons,
    required,
    state_space_min_samples,
)

__all__ = ["NSS_CLASS",
           "NSS_FULL_SIZE_SAMPLES", "NSS_PARAM_NAMES", "NSS_SHORT_SAMPLES", "NSS_SHORT_SIZE",
           "nss_shapes", "nss_size"]

#: Training samples from which an NSS keeps the size of its defaults exactly (8 states, 64
#: neurons, window 50): the sloshing records they were sized for have 240,000.
NSS_FULL_SIZE_SAMPLES = 100_000
#: Training samples of the short-record anchor: the Cascaded Tanks sweep's 819
#: (docs/rom.md, "Short records").
NSS_SHORT_SAMPLES = 1_000
#: The NSS's size on a record of :data:`NSS_SHORT_SAMPLES` samples or fewer: the best of the
#: short-record sweep (benchmarks/short_record.py, docs/rom.md, "Short records"). The shooting
#: recipe (horizon 200, batch 128, 200 steps per epoch) stays: on the short record it was worth more
#: than any smaller one.
NSS_SHORT_SIZE: dict[str, int] = {"n_states": 4, "neurons": 16, "window": 10}


def nss_shapes(h: Mapping[str, Any]) -> dict[str, tuple[int, ...]]:
    """Every array of a state-space network: state map ``A``, ``W1``, ``b1``, ``W2``, output
    map ``C``, ``V1``, ``d1``, ``V2``, encoder ``E1``, ``e1``, ``E2``."""
    nx, n, w = int(h["n_states"]), int(h["neurons"]), int(h["window"])
    nz = nx + 1
    return {"A": (nz, nx), "W1": (nz, n), "b1": (n,), "W2": (n, nx),
            "C": (nz,), "V1": (nz, n), "d1": (n,), "V2": (n,),
            "E1": (2 * w, n), "e1": (n,), "E2": (n, nx)}


def nss_size(n_samples: int, given: Mapping[str, int]) -> dict[str, int]:
    """The NSS's size rule: the values of ``n_states``, ``neurons``, ``window`` and
    ``horizon`` not in ``given`` (the user's values) for a training record of ``n_samples``
    samples.

    From :data:`NSS_FULL_SIZE_SAMPLES` samples on, the defaults (those the sloshing pipeline
    depends on); at :data:`NSS_SHORT_SAMPLES` and below, the sweep's best size
    (:data:`NSS_SHORT_SIZE`); in between, each value interpolated geometrically in the
    record's length (a straight line on log-log axes between the two measured anchors;
    nothing between them was measured). The horizon is the default's, shortened on a record
    too short for it so that at least half of the record's samples start a sub-sequence.
    """
    n = int(n_samples)
    names = (*NSS_SHORT_SIZE, "horizon")
    default = {k: int(NSS_CLASS.hyper_named(k).default) for k in names}
    out = {k: v for k, v in default.items() if k not in given}
    if n >= NSS_FULL_SIZE_SAMPLES:
        return out
    t = min(1.0, max(0.0, math.log(max(n, 1) / NSS_SHORT_SAMPLES)
                     / math.log(NSS_FULL_SIZE_SAMPLES / NSS_SHORT_SAMPLES)))
    for k, small in NSS_SHORT_SIZE.items():
        if k in out:
            out[k] = max(1, round(small * (default[k] / small) ** t))
    if "horizon" in out:
        # a horizon near the record's length leaves a handful of distinct sub-sequences
        window = int(given.get("window", out.get("window", default["window"])))
        out["horizon"] = max(8, min(out["horizon"], (n - window) // 2))
    return out


NSS_CLASS = ModelClass(
    name="nss", class_name="NSS", estimator="sloshrom.rom.nss.estimator:NSS",
    summary="a neural state-space model: a state that carries where the liquid is and how "
            "it moves, identified by multiple shooting from an encoder",
    hyper=(Hyper("n_states", 8, "int", 1, MAX_STATES, help="dimension of the state",
                 what="a state dimension"),
           neurons(64, "tanh units of each of the state map, output map and encoder"),
           Hyper("window", 50, "int", 1, MAX_DELAY,
                 help="samples of past input and output the encoder reads",
                 what="a number of samples"),
           Hyper("horizon", 200, "int", 8, MAX_DELAY,
                 help="samples simulated from each encoded start in training",
                 what="a number of samples"),
           required(SHOOTING_HYPERS[0]),
           Hyper("max_epochs", 60, "int", 0, MAX_EPOCHS,
                 help="epochs of steps_per_epoch Adam steps at most", what="an integer"),
           required(SHOOTING_HYPERS[1]), required(SHOOTING_HYPERS[2]),
           SEED, *LOSS_HYPERS,
           Hyper("feedthrough", "yes", "choice", choices=("yes", "no"),
                 help="whether the force reads the current velocity directly; 'no': a "
                      "strictly proper model (the force from the state alone): no algebraic "
                      "loop in a coupling, and a co-simulation master that reads outputs "
                      "before setting inputs gets the same force",
                 what="'yes' or 'no'", file_default="yes"),
           Hyper("velocity_offset", 0.0, "float", 0.0, 10.0,
                 help="Galilean augmentation, m/s: each training sub-sequence's velocity "
                      "shifted by a uniform draw in +-this, its force kept (0 = off)",
                 what="a velocity in m/s", file_default=0.0),
           Hyper("weight_decay", 0.0, "float", 0.0, 100.0,
                 help="AdamW's decoupled weight decay per unit learning rate: each Adam step "
                      "also shrinks every weight by learning_rate x this (0 = plain Adam)",
                 what="a decay rate (0 = off)", file_default=0.0)),
    label=lambda h: (f"NSS({h['n_states']} states, {h['neurons']} neurons"
                     + (", strictly proper)" if h.get("feedthrough", "yes") == "no" else ")")),
    shapes=nss_shapes, history=lambda h: int(h["window"]),
    min_samples=state_space_min_samples,
    # the coupled beam hands a model the acceleration of the previous step: a state driven by
    # it would run one sample behind its training
    inputs=("velocity",),
    loss_terms=LOSS_TERMS,
    recipe={"amplitude_weighting": 0.0, "passivity": 1.0, "cycle_energy": 0.1},
    # version 5 added feedthrough and velocity_offset, version 6 weight_decay; version 3 and 5
    # files read with their defaults
    format_version=6, read_versions=(3, 5), exports=frozenset({"fmu"}),
    width=lambda h: int(h["n_states"]) + 1,
    sizes=("neurons", "n_states", "window"),
    report="a neural state-space model, not the paper's NFIR class. Why: the force depends "
           "on where the liquid is, how fast it moves and when it lands, a state that a "
           "finite-memory NFIR (70 samples, 0.14 s) cannot carry; the state-space model "
           "does, and with it predicts some of the impacts the NFIR misses (not their size: "
           "the waveform figures say how many) while its dissipation map stays at least as "
           "close to the rig's (docs/rom.md, \"A ROM with state\", with the figures of both "
           "classes).",
    size_rule=nss_size, sized_by_record=(*NSS_SHORT_SIZE, "horizon"),
    size_words={"n_states": "{} states", "neurons": "{} neurons", "window": "window {}",
                "horizon": "horizon {}"},
    epoch_work=EpochWork(("steps_per_epoch", "batch", ("window", "horizon"), "neurons"),
                         MAX_EPOCH_WORK, EPOCH_WORK_SECONDS),
    # it keeps its sizes and trains 4 epochs: about 20 s each here (measured at the default
    # sizes, 2026-11-25)
    quick={"max_epochs": 4},
    former_keys={"nss_states": "n_states",
                 **{f"nss_{k}": k for k in ("neurons", "window", "horizon", "batch", "max_epochs",
                                            "steps_per_epoch", "learning_rate")}},
)

#: The arrays of a neural state-space network, in file order.
NSS_PARAM_NAMES = NSS_CLASS.param_names()
