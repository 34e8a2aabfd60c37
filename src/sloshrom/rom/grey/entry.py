"""The registry entry of the grey-box ROM: what it is, without JAX.

Its hyperparameters (the network's, as the NSS's; the physical column's: balls, sub-steps, the
output filter's reach, the tank's liquid mass and ullage that scale its search; the search's
effort), the shapes of its arrays (:func:`grey_shapes`) and its rules, as the
:class:`~sloshrom.rom.registry.ModelClass` :data:`GREY_CLASS` that the command line, the
settings and the model files read. The physics is in :mod:`sloshrom.rom.grey.physics`, the
model in :mod:`sloshrom.rom.grey.network`, its identification in
:mod:`sloshrom.rom.grey.training`, its estimator in :mod:`sloshrom.rom.grey.estimator`.
"""

from __future__ import annotations

from collections.abc import Mapping

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
    precision,
    required,
    state_space_min_samples,
)

__all__ = ["GREY_CLASS", "GREY_PARAM_NAMES", "N_PHYS", "grey_min_samples", "grey_shapes"]

#: Physical parameters of the column (:data:`sloshrom.rom.grey.physics.PHYS_NAMES`).
N_PHYS = 7
#: Features of the column the network reads (its filtered force, the mean forces of its last
#: and next two intervals).
_N_FEATURES = 4


def grey_shapes(h: Mapping[str, int | float | str]) -> dict[str, tuple[int, ...]]:
    """Every array of a grey-box ROM: the network's state map ``A``, ``W1``, ``b1``, ``W2``
    (on the state, the input and the column's features), output map ``C``, ``V1``, ``d1``,
    ``V2`` (on the state and the features), encoder ``E1``, ``e1``, ``E2``; the column's
    physical parameters ``physics`` and its output filter ``taps``."""
    nx, n, w = int(h["n_states"]), int(h["neurons"]), int(h["window"])
    nz = nx + 1 + _N_FEATURES
    no = nx + _N_FEATURES
    taps = (int(h["n_past"]) + 1) * int(h["n_substeps"])
    return {"A": (nz, nx), "W1": (nz, n), "b1": (n,), "W2": (n, nx),
            "C": (no,), "V1": (no, n), "d1": (n,), "V2": (n,),
            "E1": (2 * w, n), "e1": (n,), "E2": (n, nx),
            "physics": (N_PHYS,), "taps": (taps,)}


def grey_min_samples(h: Mapping[str, int | float | str]) -> int:
    """The fewest training samples: the network's encoder window and horizon (as an NSS's),
    and at least 2 s of the column's search windows at 500 Hz."""
    return max(state_space_min_samples(h), 1000)


GREY_CLASS = ModelClass(
    name="grey", class_name="GreyBox", estimator="sloshrom.rom.grey.estimator:GreyBox",
    summary="a grey box: an impacting liquid column behind a release gate (physics, "
            "identified by differential evolution) and a neural state-space network that "
            "corrects it",
    hyper=(Hyper("n_states", 8, "int", 1, MAX_STATES, help="dimension of the network's state",
                 what="a state dimension"),
           neurons(32, "tanh units of each of the network's state map, output map and "
                       "encoder"),
           Hyper("window", 50, "int", 1, MAX_DELAY,
                 help="samples of past input and output the network's encoder reads",
                 what="a number of samples"),
           Hyper("horizon", 200, "int", 8, MAX_DELAY,
                 help="samples simulated from each encoded start in training",
                 what="a number of samples"),
           SHOOTING_HYPERS[0],
           Hyper("max_epochs", 20, "int", 0, MAX_EPOCHS,
                 help="epochs of steps_per_epoch Adam steps at most (0: the physics alone)",
                 what="an integer"),
           SHOOTING_HYPERS[1], SHOOTING_HYPERS[2], SEED, *LOSS_HYPERS,
           Hyper("velocity_offset", 0.0, "float", 0.0, 10.0,
                 help="Galilean augmentation, m/s: each training sub-sequence's velocity "
                      "shifted by a uniform draw in +-this, its force kept (0 = off; the "
                      "column reads the acceleration and needs none)",
                 what="a velocity in m/s"),
           Hyper("weight_decay", 0.0, "float", 0.0, 100.0,
                 help="AdamW's decoupled weight decay per unit learning rate (0 = plain Adam)",
                 what="a decay rate (0 = off)"),
           required(precision("precision of the network's Adam steps: float64 makes the "
                              "model the same on every CPU to its members' spread (float32, "
                              "the NSS's, is faster)")),
           Hyper("n_balls", 10, "int", 1, 64,
                 help="balls of the impacting column (released one after the other by the "
                      "gate)", what="a number of balls"),
           Hyper("n_substeps", 8, "int", 2, 64,
                 help="sub-steps of each sample interval (a contact lasts a few ms)",
                 what="a number of sub-steps"),
           Hyper("n_past", 6, "int", 2, 64,
                 help="sample intervals the column's output filter reads at and before the "
                      "output sample (and one after it)", what="a number of intervals"),
           Hyper("liquid_mass", 0.0, "float", 0.0, 1e4,
                 help="the tank's liquid mass, kg (the scale of the column's mass; 0: the "
                      "paper's tank at the record's fill)", what="a mass in kg"),
           Hyper("ullage", 0.0, "float", 0.0, 10.0,
                 help="the tank's ullage (height minus liquid depth), m (the scale of the "
                      "column's gap; 0: the paper's tank at the record's fill)",
                 what="a length in m"),
           Hyper("spectral", 1.0, "float", 0.0, 100.0,
                 help="weight of the spectral (timing-free) term of the column's search: the "
                      "error of its force's short-time spectra beside the point-wise error "
                      "(0 = point-wise only)", what="a weight"),
           Hyper("physics_generations", 20, "int", 1, 1000,
                 help="generations of differential evolution of the column's parameters",
                 what="an integer"),
           Hyper("physics_population", 8, "int", 2, 100,
                 help="population per parameter of the differential evolution",
                 what="an integer"),
           Hyper("physics_windows", 32, "int", 1, 1000,
                 help="windows of 2 s of the training record the column's search scores "
                      "(spread over the record)", what="a number of windows")),
    label=lambda h: (f"GreyBox({h['n_balls']} balls + {h['n_states']} states, "
                     f"{h['neurons']} neurons)"),
    shapes=grey_shapes, history=lambda h: int(h["window"]),
    min_samples=grey_min_samples,
    loss_terms=LOSS_TERMS,
    recipe={"amplitude_weighting": 0.0, "passivity": 1.0, "cycle_energy": 0.1},
    format_version=1, exports=frozenset({"fmu"}),
    export_notes={"onnx": (
        "its column is a sub-stepped simulation with contacts and a release gate: each step "
        "runs three sample intervals of sub-steps whose branches (a ball released, in contact "
        "with the floor or the lid, landed) turn on the column's state, which the ONNX "
        "exporter's graphs (an RBF network over a delay line) do not express. Export it as an "
        "FMU (`sloshrom export fmu`: the column and the network in C) or run it through "
        "sloshrom")},
    width=lambda h: int(h["n_states"]) + 1 + _N_FEATURES,
    sizes=("neurons", "n_states", "window"),
    report="a grey box: a physical model of the impacts (the liquid that takes part in them as "
           "a column of balls released one after the other by a Rayleigh-Taylor gate, "
           "flying through the ullage and landing on soft contacts; its seven parameters "
           "identified by differential evolution) and a neural state-space network that "
           "corrects its force and reads its state. Why: a network alone learns the force's "
           "conditional mean and leaves most impacts out; the column adds impacts timed by "
           "the motion and raises the load the structure feels, though not yet to the rig's "
           "(the figures are in \"At a glance\"; docs/rom.md, \"The force the structure "
           "feels\").",
    epoch_work=EpochWork(("steps_per_epoch", "batch", ("window", "horizon"), "neurons"),
                         MAX_EPOCH_WORK, EPOCH_WORK_SECONDS),
    tank_scales=("liquid_mass", "ullage"), article="a",
    quick={"max_epochs": 2, "physics_generations": 4, "physics_windows": 8},
)

#: The arrays of a grey-box ROM, in file order.
GREY_PARAM_NAMES = GREY_CLASS.param_names()
