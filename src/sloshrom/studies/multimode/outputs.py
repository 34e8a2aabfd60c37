"""The outputs of the two-mode wing study: what the report section and the summary read.

:class:`MultimodeOutputs` is the stage's JSON record (``summary.json``, the stage cache) as a
typed, frozen object: :meth:`~MultimodeOutputs.as_record` gives the record,
:meth:`~MultimodeOutputs.from_record` reads one back (keys absent from runs made before they
existed get empty defaults).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field, fields
from typing import Any

__all__ = ["MultimodeOutputs"]


@dataclass(frozen=True)
class MultimodeOutputs:
    """The two-mode wing study's results (JSON-able values; units in the key names).

    Attributes
    ----------
    settings : dict
        The ``[multimode]`` table the study ran with.
    structure : dict
        The wing, ``EI_n_m2``, ``GJ_n_m2_per_rad``, ``mass_coupling``, masses (kg),
        :func:`~sloshrom.beam.simulation.wing.structure_summary` and the frozen tank shape.
    test : dict
        Levels (g), PSD (Hz), the frozen runs' tank motion and per-mode tank RMS (g).
    data : dict
        Per record: duration, peaks, content; ``broadband_design``: band, top RMS, levels,
        coverage of the frozen tank motion.
    roms : dict
        Per ROM: the input it reads, its loss, records, seconds of data, fit seconds, epochs,
        stop reason, validation NRMSE, training envelope.
    table : list of dict
        :func:`~sloshrom.beam.damping.multimode.modal_damping_table` rows.
    errors : list of dict
        Per ROM (and frozen), mode and level: damping / rig damping - 1, ``within`` tolerance.
    envelope : list of dict
        Per case and level: peak tank acceleration (g) / the ROM's training peak, fraction
        outside.
    open_loop : list of dict
        Per ROM, level and mode: power taken from the mode's band (W) fed the rig's own tank
        motion, against the rig's, and their ratio.
    verdict : dict
        Per ROM: every mode and level within the tolerance.
    judged_rom : str
        The ROM the two-mode target is judged on.
    timings_s : dict
        Wall time of each part, s.
    """

    settings: dict[str, Any]
    structure: dict[str, Any]
    test: dict[str, Any]
    data: dict[str, Any]
    roms: dict[str, Any]
    table: list[dict[str, Any]]
    errors: list[dict[str, Any]]
    envelope: list[dict[str, Any]]
    open_loop: list[dict[str, Any]] = field(default_factory=list)
    verdict: dict[str, bool] = field(default_factory=dict)
    judged_rom: str | None = None
    timings_s: dict[str, float] = field(default_factory=dict)

    def as_record(self) -> dict[str, Any]:
        """The JSON-able record, keys in the order of the fields."""
        return {f.name: getattr(self, f.name) for f in fields(self)}

    @classmethod
    def from_record(cls, record: Mapping[str, Any]) -> MultimodeOutputs:
        """The outputs of a stage record (``summary.json``: ``stages.multimode``); other keys
        of the record (``reused``) are ignored."""
        names = {f.name for f in fields(cls)}
        return cls(**{k: v for k, v in record.items() if k in names})
