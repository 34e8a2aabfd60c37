"""Configuration of the two-mode wing study: the ``[multimode]`` table and the study's design.

The table's keys, defaults and checks are the study's own
(:class:`sloshrom.studies.multimode.table.MultimodeTable`, ``defaults.toml`` of this package;
the wing's own checks, those of :class:`~sloshrom.beam.simulation.wing.WingDesign`, by
:func:`wing_design` before any stage). The constants here are the study's design, not
settings: the cases of the random tests, the signal each ROM reads and the records it learns.
"""

from __future__ import annotations

from typing import Any

from sloshrom.beam.simulation.structure import ModalDataError
from sloshrom.beam.simulation.wing import WingDesign
from sloshrom.config import ConfigError
from sloshrom.pipeline.settings import ReproduceConfig
from sloshrom.rom.registry import LOSS_TERMS
from sloshrom.studies.multimode.table import MultimodeTable

__all__ = ["CASES", "DATA_SETS", "JUDGED_ROM", "RECIPE_KEYS", "ROM_INPUTS", "WING_KEYS",
           "cache_config", "rom_params", "wing_design"]

#: the NFIR recipe keys of the table (the NFIR's passive recipe, as the registry's); the ROM
#: on the acceleration trains with its loss terms off
RECIPE_KEYS = ("delays", "neurons", "hidden", "amplitude_weighting", "passivity", "cycle_energy",
               "max_epochs")
#: the keys of :class:`~sloshrom.beam.simulation.wing.WingDesign`
WING_KEYS = ("span", "chord", "ea_chord_fraction", "mass_per_span", "cg_offset",
             "gyration_radius", "tank_offset", "f_bending", "f_torsion", "damping", "stations")
#: the cases of the random tests, in the order of the table
CASES = ("rig", "vfa_rom", "broadband_rom", "broadband_acc_rom", "frozen")
#: the ROM cases and the signal each reads (``NFIR.names[0]``)
ROM_INPUTS = {"vfa_rom": "velocity", "broadband_rom": "velocity",
              "broadband_acc_rom": "acceleration"}
#: the ROM the two-mode target is judged on
JUDGED_ROM = "broadband_acc_rom"
#: training and validation records of each ROM (concatenated: each record ends at rest)
DATA_SETS = {
    "vfa_rom": (("vfa_train",), ("vfa_validation",)),
    "broadband_rom": (("vfa_train", "broadband_train"),
                      ("vfa_validation", "broadband_validation")),
    "broadband_acc_rom": (("vfa_train", "broadband_train"),
                          ("vfa_validation", "broadband_validation")),
}


def wing_design(s: MultimodeTable) -> WingDesign:
    """The wing of the table.

    Raises
    ------
    ConfigError
        The wing's own checks (positive sizes, ``f_torsion > f_bending``, stations on the
        span, ...), naming the table.
    """
    kw = {k: getattr(s, k) for k in WING_KEYS}
    kw["damping"] = tuple(kw["damping"])
    kw["stations"] = tuple(kw["stations"])
    try:
        return WingDesign(**kw)
    except ModalDataError as exc:
        raise ConfigError(f"[multimode]: {exc}") from None


def cache_config(cfg: ReproduceConfig) -> dict[str, Any]:
    """What the stage's cache key depends on: the tank, the rig and the table, with the cases
    (code, not configuration: a run made before they changed is redone). The table sits under
    ``"defaults"``, its name when it was code: records of those runs stay valid."""
    return {**cfg.tables("tank", "rig"),
            "multimode": {"defaults": cfg.tables("multimode")["multimode"],
                          "cases": list(CASES)}}


def rom_params(s: MultimodeTable, var: str) -> dict[str, Any]:
    """NFIR parameters of a ROM reading ``var``: the recipe, its loss terms off for the
    acceleration."""
    params = {**{k: getattr(s, k) for k in RECIPE_KEYS}, "seed": int(s.rom_seed)}
    if var == "acceleration":
        params.update({k: 0.0 for k in LOSS_TERMS},
                      names=("acceleration", "dynamic_force"), units=("m/s^2", "N"))
    return params
