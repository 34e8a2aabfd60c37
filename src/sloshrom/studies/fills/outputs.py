"""The outputs of the fill-level study: what the report section and the summary read.

:class:`FillsOutputs` is the stage's JSON record (``summary.json``, the stage cache) as a typed,
frozen object (:meth:`~FillsOutputs.as_record`, :meth:`~FillsOutputs.from_record`).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, fields
from typing import Any

__all__ = ["FillsOutputs"]


@dataclass(frozen=True)
class FillsOutputs:
    """The fill family's results (JSON-able values).

    Attributes
    ----------
    fills, unseen_fills : list of float
        The members' fills and the fills no member saw, d/h (-), sorted.
    targets : dict
        :data:`~sloshrom.studies.fills.config.FILL_TARGETS`.
    members : dict
        Fill label (per cent) -> model file (relative to the output directory), ``main_rom``
        and, for the members identified here, ``reused``, ``train_seconds`` (s), ``val_fit``
        (%) and ``val_mse_members`` (an ensemble's: :func:`sloshrom.rom.ensemble.spread` of
        its members' validation MSE, N^2; None or absent for a single network).
    family : str
        The family's manifest, relative to the output directory.
    maps : list of dict
        One row per fill: ``fill``, ``unseen`` and :func:`sloshrom.energy.map_fidelity` of the
        family's map against the rig's at that fill.
    damping : list of dict
        Case, fill, RMS level and the Table 2 estimators of the beam's first mode.
    beam_errors : list of dict
        Per beam fill and level: the family's first-mode damping relative to the rig's.
    seconds : dict
        Wall time of the members, the maps and the beam tests, s.
    """

    fills: list[float]
    unseen_fills: list[float]
    targets: dict[str, Any]
    members: dict[str, Any]
    family: str
    maps: list[dict[str, Any]]
    damping: list[dict[str, Any]]
    beam_errors: list[dict[str, Any]]
    seconds: dict[str, float]

    def as_record(self) -> dict[str, Any]:
        """The JSON-able record, keys in the order of the fields."""
        return {f.name: getattr(self, f.name) for f in fields(self)}

    @classmethod
    def from_record(cls, record: Mapping[str, Any]) -> FillsOutputs:
        """The outputs of a stage record (``summary.json``: ``stages.fills``); other keys of the
        record (``reused``) are ignored."""
        names = {f.name for f in fields(cls)}
        return cls(**{k: v for k, v in record.items() if k in names})
