"""Channel maps of measured beam tests: which channel of a laboratory's files is which
accelerometer, and the structure those accelerometers see.

* :class:`ChannelMap` - the map, a small TOML file (``[channels]``: ``stations`` with their
  ``positions`` on the built-in cantilever or ``ids`` on the user's structure, ``base``,
  ``tank``; ``[units]``: units of channels whose files give none, and ``[units."PATTERN"]``
  those of the files whose names match a pattern), validated on construction;
  read and written by :meth:`ChannelMap.from_toml` and :meth:`ChannelMap.write_toml`.
* :func:`acceleration_unit` - a unit the user gives for an accelerometer channel, checked.
* :func:`station_model` - the modal model seen by the map's stations (modal filtering).

A bad map is a :class:`ChannelMapError`. The readers of the files the map names are in
:mod:`sloshrom.beam.lab.measured`, the writer of such files in :mod:`sloshrom.beam.lab.virtual`.
"""

from __future__ import annotations

import dataclasses
import fnmatch
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from sloshrom.beam.errors import BeamError
from sloshrom.beam.simulation.structure import CantileverBeam, ModalModel
from sloshrom.config import ConfigError, load_toml_table
from sloshrom.fileio import OutputBatch, atomic_write
from sloshrom.io.units import canonical_unit, is_known_unit

__all__ = ["ACCELERATION_UNITS", "ChannelMap", "ChannelMapError", "acceleration_unit",
           "station_model"]

_KEYS = ("stations", "positions", "ids", "base", "tank")
#: The usual spellings of acceleration units, named in messages (docs/formats.md lists all).
ACCELERATION_UNITS = ("g", "m/s^2", "mm/s^2", "cm/s^2", "ft/s^2", "in/s^2")


class ChannelMapError(ConfigError, BeamError):
    """A channel map is invalid (unknown or missing keys, duplicates, wrong types)."""


def acceleration_unit(unit: object) -> str | None:
    """Why ``unit`` cannot be the unit of an accelerometer channel, or ``None`` if it can.

    Parameters
    ----------
    unit : object
        A unit the user gives, e.g. ``"g"``, ``"m/s2"``, ``"mm/s^2"``.

    Returns
    -------
    str or None
        ``None`` for a known acceleration unit (the unit table of :mod:`sloshrom.io.units`);
        else a phrase naming the accepted spellings.
    """
    accepted = ", ".join(ACCELERATION_UNITS)
    if not isinstance(unit, str) or not unit.strip():
        return f"{unit!r} is not a unit (use one of {accepted})"
    if unit.strip() == "G":
        # the unit table reads spellings case-insensitively, but a capital G is giga- in SI
        # (and a gravity unit in some software): the user means one of the two, say which
        return (f"{unit!r} is ambiguous (the SI prefix giga-, or a gravity unit): write 'g' for "
                f"the standard gravity (accepted: {accepted})")
    if not is_known_unit(unit):
        return (f"unknown unit {unit!r} (use one of {accepted}; docs/formats.md lists every "
                "spelling)")
    if canonical_unit(unit)[0] != "m/s^2":
        return f"{unit!r} is not an acceleration unit (use one of {accepted})"
    return None


@dataclass(frozen=True)
class ChannelMap:
    """Which channel of a test's files is which accelerometer.

    Parameters
    ----------
    stations : tuple of str
        Channel names of the beam accelerometers, in order (the label the file gives: UFF ID
        line 1, CSV column, NetCDF/MAT variable; for UFF also ``node:dir``, e.g. ``"101:+Z"``).
    positions : tuple of float, optional
        Their positions along the built-in cantilever, m (from the root).
    ids : tuple of int, optional
        Their grid/node IDs on the user's structure (``--structure``, ``--modal-toml``).
        Exactly one of ``positions`` and ``ids``.
    base : str, optional
        Channel of the base (shaker table) acceleration: required for random tests; a free
        decay without it has a base at rest.
    tank : str, optional
        Channel of the tank acceleration (the amplitude axis of the damping analyses);
        default: the station at the tank (position = beam length, or the tank's grid ID).
    units : dict of str to str, optional
        Units of channels of the map whose files give none (the ``[units]`` table), e.g.
        ``{"acc1": "g"}``: known acceleration units (:func:`acceleration_unit`). A file's own
        non-empty unit that contradicts one is an error.
    file_units : dict of str to dict, optional
        Units of the files whose names match a pattern (``fnmatch``, e.g. ``"random_*.uff"``;
        the ``[units."PATTERN"]`` tables), over ``units``: a laboratory changes sensor set-ups
        between tests (a channel in g in the random runs, in m/s^2 in the decay). Where
        several patterns match a file, the later one wins.
    """

    stations: tuple[str, ...]
    positions: tuple[float, ...] | None = None
    ids: tuple[int, ...] | None = None
    base: str | None = None
    tank: str | None = None
    units: Mapping[str, str] = field(default_factory=dict)
    file_units: Mapping[str, Mapping[str, str]] = field(default_factory=dict)

    def __post_init__(self) -> None:
        st = self.stations
        if isinstance(st, str) or not isinstance(st, Sequence) or not st:
            raise ChannelMapError(f"channels.stations must be a non-empty list of channel "
                                  f"names, got {st!r}")
        st = tuple(st)
        for s in st:
            if not isinstance(s, str) or not s.strip():
                raise ChannelMapError(f"channels.stations: {s!r} is not a channel name")
        dup = [s for s in st if st.count(s) > 1]
        if dup:
            raise ChannelMapError(f"channels.stations: {dup[0]!r} is given twice")
        object.__setattr__(self, "stations", st)
        if (self.positions is None) == (self.ids is None):
            raise ChannelMapError("channels: give exactly one of 'positions' (m, the built-in "
                                  "cantilever) and 'ids' (grid IDs on --structure)")
        if self.positions is not None:
            pos = _list(self.positions, "positions", len(st))
            try:
                x = tuple(float(v) for v in pos)
            except (TypeError, ValueError):
                raise ChannelMapError(f"channels.positions must be numbers (m), got "
                                      f"{list(pos)!r}") from None
            if any(isinstance(v, bool) for v in pos) or not all(
                    math.isfinite(v) and v >= 0 for v in x):
                raise ChannelMapError(f"channels.positions must be finite and >= 0 m, got "
                                      f"{list(pos)!r}")
            if len(set(x)) != len(x):
                raise ChannelMapError(f"channels.positions: {next(v for v in x if x.count(v) > 1)}"
                                      " m is given twice")
            object.__setattr__(self, "positions", x)
        else:
            ids = _list(self.ids, "ids", len(st))
            if not all(isinstance(v, int | np.integer) and not isinstance(v, bool) and v > 0
                       for v in ids):
                raise ChannelMapError(f"channels.ids must be positive integer grid IDs, got "
                                      f"{list(ids)!r}")
            ids = tuple(int(v) for v in ids)
            if len(set(ids)) != len(ids):
                raise ChannelMapError(f"channels.ids: {next(v for v in ids if ids.count(v) > 1)}"
                                      " is given twice")
            object.__setattr__(self, "ids", ids)
        for key in ("base", "tank"):
            v = getattr(self, key)
            if v is not None and (not isinstance(v, str) or not v.strip()):
                raise ChannelMapError(f"channels.{key} must be a channel name, got {v!r}")
        if self.base is not None and self.base in st:
            raise ChannelMapError(f"channels.base {self.base!r} is also a station: the base "
                                  "is the shaker table, not a point of the beam")
        if self.base is not None and self.base == self.tank:
            raise ChannelMapError(f"channels.base and channels.tank are both {self.base!r}")
        if not isinstance(self.units, Mapping):
            raise ChannelMapError(f"[units] must be a table of channel = unit, got "
                                  f"{self.units!r}")
        object.__setattr__(self, "units", self._checked_units(self.units, "[units]"))
        if not isinstance(self.file_units, Mapping):
            raise ChannelMapError(f"[units.\"PATTERN\"] must be tables of channel = unit, got "
                                  f"{self.file_units!r}")
        object.__setattr__(self, "file_units", {
            str(pat): self._checked_units(u, f"[units.{pat!r}]".replace("'", '"'))
            for pat, u in self.file_units.items()})

    def _checked_units(self, units: object, where: str) -> dict[str, str]:
        """A table of channel = unit, each a channel of the map and an acceleration unit."""
        if not isinstance(units, Mapping):
            raise ChannelMapError(f"{where} must be a table of channel = unit, got {units!r}")
        names = self.channels
        for key, unit in units.items():
            if key not in names:
                raise ChannelMapError(f"{where}: {key!r} is not a channel of the map (its "
                                      f"channels: {', '.join(map(repr, names))})")
            why = acceleration_unit(unit)
            if why is not None:
                raise ChannelMapError(f"{where} {key!r}: {why}")
        return {k: str(v).strip() for k, v in units.items()}

    def units_for(self, path: str | Path) -> dict[str, str]:
        """The units of the file ``path``: ``units`` with those of every ``file_units``
        pattern its name matches over them (later patterns win)."""
        name = Path(path).name
        out = dict(self.units)
        for pattern, units in self.file_units.items():
            if fnmatch.fnmatchcase(name, pattern):
                out.update(units)
        return out

    @property
    def channels(self) -> tuple[str, ...]:
        """Every channel the map names: the stations, then the tank and the base if named."""
        extra = tuple(c for c in (self.tank, self.base) if c is not None and c not in
                      self.stations)
        return self.stations + extra

    def only(self, stations: Sequence[str], base: bool = True) -> ChannelMap:
        """The map with only ``stations`` (a subset, kept in the map's order) and, unless
        ``base`` is false, its base; ``units`` of the channels dropped go too."""
        keep = [i for i, s in enumerate(self.stations) if s in stations]
        pos = None if self.positions is None else tuple(self.positions[i] for i in keep)
        ids = None if self.ids is None else tuple(self.ids[i] for i in keep)
        out = dataclasses.replace(self, stations=tuple(self.stations[i] for i in keep),
                                  positions=pos, ids=ids, base=self.base if base else None,
                                  units={}, file_units={})
        return dataclasses.replace(
            out, units={k: v for k, v in self.units.items() if k in out.channels},
            file_units={p: {k: v for k, v in u.items() if k in out.channels}
                        for p, u in self.file_units.items()})

    def with_units(self, units: Mapping[str, str]) -> ChannelMap:
        """The map with ``units`` added (they win over the map's own ``[units]`` and its
        file patterns' units)."""
        return dataclasses.replace(
            self, units={**self.units, **units},
            file_units={p: {k: v for k, v in u.items() if k not in units}
                        for p, u in self.file_units.items()})

    # -- files ------------------------------------------------------------------------------
    @classmethod
    def from_dict(cls, data: Mapping[str, Any], where: str = "channels",
                  units: Mapping[str, str] | None = None) -> ChannelMap:
        """From the ``[channels]`` table (keys ``stations``, ``positions`` or ``ids``,
        ``base``, ``tank``) and the ``[units]`` table (channel = unit, and per file pattern
        ``[units."PATTERN"]`` tables of channel = unit); unknown or missing keys are errors
        naming them."""
        if not isinstance(data, Mapping):
            raise ChannelMapError(f"{where}: [channels] must be a table")
        if units is not None and not isinstance(units, Mapping):
            raise ChannelMapError(f"{where}: [units] must be a table of channel = unit")
        unknown = [k for k in data if k not in _KEYS]
        if unknown:
            raise ChannelMapError(f"{where}: unknown key(s) {', '.join(map(repr, unknown))} in "
                                  f"[channels] (known: {', '.join(_KEYS)})")
        if "stations" not in data:
            raise ChannelMapError(f"{where}: [channels] has no 'stations' (the channel names "
                                  "of the beam accelerometers)")
        try:
            kwargs: dict[str, Any] = {k: (tuple(v) if isinstance(v, list) else v)
                                      for k, v in data.items()}
            table = dict(units or {})
            # a sub-table is a file pattern's units; a string is one channel's unit
            per_file = {k: v for k, v in table.items() if isinstance(v, Mapping)}
            return cls(**kwargs, units={k: v for k, v in table.items() if k not in per_file},
                       file_units=per_file)
        except ChannelMapError as exc:
            raise ChannelMapError(f"{where}: {exc}") from None

    @classmethod
    def from_toml(cls, path: str | Path) -> ChannelMap:
        """Read the ``[channels]`` and ``[units]`` tables of a TOML file (see the module
        docstring)."""
        try:
            data = load_toml_table(path, "", ChannelMapError)
        except ChannelMapError:
            raise
        except ConfigError as exc:
            raise ChannelMapError(str(exc)) from None
        if "channels" not in data:
            raise ChannelMapError(f"{path}: no [channels] table")
        return cls.from_dict(data["channels"], str(path), data.get("units"))

    def to_toml(self) -> str:
        """The map as TOML text (``[channels]`` and, if any, ``[units]`` tables) that
        :meth:`from_toml` reads back."""
        import tomli_w

        d: dict[str, Any] = {}
        for key in ("base", "tank"):
            if getattr(self, key) is not None:
                d[key] = getattr(self, key)
        d["stations"] = list(self.stations)
        if self.positions is not None:
            d["positions"] = list(self.positions)
        else:
            d["ids"] = list(self.ids or ())
        doc: dict[str, dict[str, object]] = {"channels": d}
        if self.units or self.file_units:
            doc["units"] = {**self.units, **{p: dict(u) for p, u in self.file_units.items()}}
        return tomli_w.dumps(doc)

    def write_toml(self, path: str | Path, batch: OutputBatch | None = None) -> Path:
        """Write :meth:`to_toml` to ``path``, atomically or into ``batch``."""
        text = self.to_toml()

        def write(tmp: str) -> None:
            Path(tmp).write_text(text, encoding="utf-8")

        return (batch.write if batch is not None else atomic_write)(Path(path), write)

    # -- the tank ---------------------------------------------------------------------------
    def tank_channel(self, modal: ModalModel | None) -> str:
        """The channel of the tank acceleration: ``tank``, or the station at the tank (the
        beam's tip, or the first tank's grid ID); a :class:`ChannelMapError` if neither.

        ``modal=None`` (a structure known by its measured modes alone, without a tank): the
        reference channel of the damping analyses, ``tank`` or the station farthest from the
        root (``positions``)."""
        if self.tank is not None:
            return self.tank
        if modal is None:
            if self.positions is not None:
                return self.stations[int(np.argmax(self.positions))]
            raise ChannelMapError("channels: name the reference channel ('tank'): without a "
                                  "structure, grid IDs do not say which station is the tip")
        if self.positions is not None and modal.length is not None:
            at = [s for s, x in zip(self.stations, self.positions, strict=True)
                  if abs(x - modal.length) <= 1e-6 * max(modal.length, 1.0)]
            if at:
                return at[0]
            raise ChannelMapError(f"channels: no station at the tank (x = {modal.length:g} m) "
                                  "and no 'tank' channel: name the tank's channel")
        if self.ids is not None and modal.tank_ids is not None:
            if modal.tank_ids[0] in self.ids:
                return self.stations[self.ids.index(modal.tank_ids[0])]
            raise ChannelMapError(f"channels: no station at the tank (grid {modal.tank_ids[0]})"
                                  " and no 'tank' channel: name the tank's channel")
        raise ChannelMapError("channels: name the tank's channel ('tank'): the structure does "
                              "not say where its tank is")


def _list(value: Any, key: str, n: int) -> tuple:
    if isinstance(value, str) or not isinstance(value, Sequence):
        raise ChannelMapError(f"channels.{key} must be a list, got {value!r}")
    if len(value) != n:
        raise ChannelMapError(f"channels.{key} has {len(value)} value(s) for {n} station(s)")
    return tuple(value)



# -- the structure seen by the stations ----------------------------------------------------------
def station_model(modal: ModalModel, channels: ChannelMap,
                  beam: CantileverBeam | None = None) -> ModalModel:
    """``modal`` with the map's stations: mode shapes at its ``positions`` on ``beam`` (the
    built-in cantilever), or the rows of ``modal``'s output points with its ``ids`` (or, without
    a beam, its stations at ``positions``), in the map's order.

    Raises
    ------
    ChannelMapError
        Positions without a beam and not among ``modal``'s stations, IDs not among its output
        points, or positions for a structure that has only IDs (and the reverse).
    """
    if channels.positions is not None:
        x = np.asarray(channels.positions)
        if beam is not None:
            off = x[(x < 0) | (x > beam.length)]
            if off.size:
                raise ChannelMapError(f"channels.positions {off.tolist()} m lie off the beam "
                                      f"[0, {beam.length:g}] m")
            return dataclasses.replace(modal, stations=x,
                                       psi_stations=beam.mode_shapes(x, modal.n_modes),
                                       station_ids=None)
        rows = []
        for v in x:
            hit = np.flatnonzero(np.abs(modal.stations - v) <= 1e-6)
            if hit.size == 0:
                raise ChannelMapError(f"channels.positions: no station of the structure at "
                                      f"{v:g} m (its stations: {modal.stations.tolist()} m)")
            rows.append(int(hit[0]))
    else:
        ids = modal.station_ids
        if ids is None:
            raise ChannelMapError("channels.ids: the structure has no output point IDs; give "
                                  "'positions' (m)")
        missing = [i for i in channels.ids or () if i not in ids]
        if missing:
            raise ChannelMapError(f"channels.ids {missing} are not output points of the "
                                  f"structure (its IDs: {list(ids)[:20]})")
        rows = [ids.index(i) for i in channels.ids or ()]
    return dataclasses.replace(
        modal, stations=modal.stations[rows], psi_stations=modal.psi_stations[rows],
        station_ids=None if modal.station_ids is None else tuple(modal.station_ids[r]
                                                                 for r in rows))
