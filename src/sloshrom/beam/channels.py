"""Channel maps of measured beam tests: which channel of a laboratory's files is which
accelerometer, and the structure those accelerometers see.

* :class:`ChannelMap` - the map, a small TOML file (``[channels]``: ``stations`` with their
  ``positions`` on the built-in cantilever or ``ids`` on the user's structure, ``base``,
  ``tank``), validated on construction; read and written by :meth:`ChannelMap.from_toml` and
  :meth:`ChannelMap.write_toml`.
* :func:`station_model` - the modal model seen by the map's stations (modal filtering).

A bad map is a :class:`ChannelMapError`. The readers of the files the map names are in
:mod:`sloshrom.beam.measured`, the writer of such files in :mod:`sloshrom.beam.labfiles`.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from sloshrom.beam.errors import BeamError
from sloshrom.beam.structure import CantileverBeam, ModalModel
from sloshrom.config import ConfigError, load_toml_table
from sloshrom.fileio import OutputBatch, atomic_write

__all__ = ["ChannelMap", "ChannelMapError", "station_model"]

_KEYS = ("stations", "positions", "ids", "base", "tank")


class ChannelMapError(ConfigError, BeamError):
    """A channel map is invalid (unknown or missing keys, duplicates, wrong types)."""


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
    """

    stations: tuple[str, ...]
    positions: tuple[float, ...] | None = None
    ids: tuple[int, ...] | None = None
    base: str | None = None
    tank: str | None = None

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

    # -- files ------------------------------------------------------------------------------
    @classmethod
    def from_dict(cls, data: Mapping[str, Any], where: str = "channels") -> ChannelMap:
        """From the ``[channels]`` table (keys ``stations``, ``positions`` or ``ids``,
        ``base``, ``tank``); unknown or missing keys are errors naming them."""
        if not isinstance(data, Mapping):
            raise ChannelMapError(f"{where}: [channels] must be a table")
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
            return cls(**kwargs)
        except ChannelMapError as exc:
            raise ChannelMapError(f"{where}: {exc}") from None

    @classmethod
    def from_toml(cls, path: str | Path) -> ChannelMap:
        """Read the ``[channels]`` table of a TOML file (see the module docstring)."""
        try:
            table = load_toml_table(path, "channels", ChannelMapError)
        except ChannelMapError:
            raise
        except ConfigError as exc:
            raise ChannelMapError(str(exc)) from None
        return cls.from_dict(table, str(path))

    def to_toml(self) -> str:
        """The map as TOML text (``[channels]`` table) that :meth:`from_toml` reads back."""
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
        return tomli_w.dumps({"channels": d})

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
