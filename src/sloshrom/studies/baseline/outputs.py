"""The outputs of the bouncing-ball baseline: what the report section and the summary read.

:class:`BaselineOutputs` is the stage's JSON record (``summary.json``, the stage cache) as a
typed, frozen object (:meth:`~BaselineOutputs.as_record`, :meth:`~BaselineOutputs.from_record`).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, fields
from typing import Any

from sloshrom.beam.damping.registry import REFERENCE

__all__ = ["REFERENCE_KEY", "BaselineOutputs"]

#: The key of a :attr:`BaselineOutputs.comparison` row that holds the reference estimator's
#: first-mode damping by RMS level (``"table2_lscf_h1"``: a ``summary.json`` contract).
REFERENCE_KEY = f"table2_{REFERENCE}"


@dataclass(frozen=True, kw_only=True)
class BaselineOutputs:
    """The bouncing ball beside the ROM (JSON-able values; units in the key names).

    The fields the report section needs are required; the others are None when a record lacks
    them (and then left out of :meth:`as_record`).

    Attributes
    ----------
    fit_seconds : float
        Wall time of the fit, s.
    parameters : dict
        :meth:`~sloshrom.rom.ball.model.BouncingBall.parameters`.
    fit : dict
        The fit's history: objective, NRMSE, validation errors, cutoff, seconds.
    rig_mass_fraction : float
        The rig physics' impacting fraction ``beta`` (-).
    validation_nrmse_lowpassed : dict
        Ball and ROM on the validation record, both low-passed at the ball's cutoff (-).
    map_seconds : float
        Wall time of the ball's map, s.
    ball_maximum : dict
        :func:`sloshrom.energy.map_maximum` of the ball's map.
    ball_fidelity, rom_fidelity : dict
        :func:`sloshrom.energy.map_fidelity` against the rig's map (the ROM's: when its map
        exists).
    frequency_bands : dict
        Model -> :func:`~sloshrom.studies.baseline.stage.frequency_band_errors`.
    f1_frozen_hz : float
        First frozen-liquid mode of the beam, Hz.
    instantaneous_damping, table2 : dict, list of dict
        The ball's free-response damping per band and Table 2 rows.
    envelope : list of dict
        The ball's beam runs against its training envelope.
    table2_all, instantaneous_damping_all : list of dict, dict
        The same for every case (ball, ROM, rig, frozen).
    comparison : list of dict
        :func:`~sloshrom.studies.baseline.stage.comparison_rows` (the reference estimator's
        Table 2 by level under :data:`REFERENCE_KEY`).
    experiment : dict
        The ball beside the rig playing the laboratory
        (:func:`~sloshrom.studies.baseline.stage.ball_against_experiment`), when the ``beam``
        stage had one.
    """

    fit_seconds: float | None = None
    parameters: dict[str, Any]
    fit: dict[str, Any]
    rig_mass_fraction: float | None = None
    validation_nrmse_lowpassed: dict[str, float] | None = None
    map_seconds: float | None = None
    ball_maximum: dict[str, Any] | None = None
    ball_fidelity: dict[str, Any]
    rom_fidelity: dict[str, Any] | None = None
    frequency_bands: dict[str, Any] | None = None
    f1_frozen_hz: float | None = None
    instantaneous_damping: dict[str, Any] | None = None
    table2: list[dict[str, Any]] | None = None
    envelope: list[dict[str, Any]] | None = None
    table2_all: list[dict[str, Any]]
    instantaneous_damping_all: dict[str, Any]
    comparison: list[dict[str, Any]]
    experiment: dict[str, Any] | None = None

    def as_record(self) -> dict[str, Any]:
        """The JSON-able record, keys in the order of the fields, absent ones left out."""
        return {f.name: getattr(self, f.name) for f in fields(self)
                if getattr(self, f.name) is not None}

    @classmethod
    def from_record(cls, record: Mapping[str, Any]) -> BaselineOutputs:
        """The outputs of a stage record (``summary.json``: ``stages.baseline``); other keys of
        the record (``reused``) are ignored."""
        names = {f.name for f in fields(cls)}
        return cls(**{k: v for k, v in record.items() if k in names})
