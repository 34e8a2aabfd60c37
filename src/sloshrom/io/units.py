"""Units of records: the table of accepted spellings and their SI factors.

Physics is SI inside; files may use the units of a small explicit table (g, mm, kN, ft/s, lbf,
...), converted on read. Other units are *unknown*: kept as written and never taken for SI
(:func:`is_known_unit`, :func:`same_unit`; :func:`sloshrom.io.require_unit` checks a record's).
docs/formats.md lists every entry of the table.

This module is pure (it raises nothing of its own and imports no other module of
:mod:`sloshrom.io`), so that the record type and every file format can use it.
"""

from __future__ import annotations

import re
from collections.abc import Iterable

from sloshrom.config import G

__all__ = ["STANDARD_UNITS", "canonical_unit", "is_known_unit", "same_unit"]

# SI units of the standard variable names (so that every command reads every other's output).
STANDARD_UNITS: dict[str, str] = {
    "time": "s",
    "acceleration": "m/s^2",
    "velocity": "m/s",
    "displacement": "m",
    "force": "N",
    "dynamic_force": "N",
    "base_acceleration": "m/s^2",
    "tank_acceleration": "m/s^2",
    "interface_force": "N",
    "station_acceleration": "m/s^2",
    "modal_acceleration": "m/s^2",
}


# Accepted spellings -> (canonical SI unit, factor to SI). Kept small and explicit on purpose
# (docs/formats.md lists every entry): a unit not in the table is *unknown*. Unknown units are
# read and kept as written, never converted, and never taken for an SI unit by code that needs a
# dimension (see is_known_unit, same_unit, require_unit). Exact factors: ft = 0.3048 m,
# in = 0.0254 m, lbf = 0.45359237 kg x 9.80665 m/s^2 = 4.4482216152605 N (all by definition).
_UNIT_TABLE: dict[str, tuple[str, float]] = {}


def _add_units(spellings: Iterable[str], si: str, factor: float = 1.0) -> None:
    for s in spellings:
        _UNIT_TABLE[s] = (si, factor)


_FT, _IN, _LBF = 0.3048, 0.0254, 4.4482216152605
_LENGTHS = {"m": 1.0, "mm": 1e-3, "cm": 1e-2, "ft": _FT, "in": _IN}
_PER_S = ["/s", " s-1", " s^-1", ".s-1", "*s^-1", "/sec"]
_PER_S2 = ["/s^2", "/s2", "/s**2", " s-2", " s^-2", ".s-2", "*s^-2", "/s/s", "/sec^2", "/s\u00b2"]
for _base, _k in _LENGTHS.items():
    _add_units([_base + suffix for suffix in _PER_S2], "m/s^2", _k)
    _add_units([_base + suffix for suffix in _PER_S], "m/s", _k)
_add_units(["g", "gn", "g0", "g_n"], "m/s^2", G)
_add_units(["m", "meter", "meters", "metre", "metres"], "m")
_add_units(["mm", "millimeter", "millimeters", "millimetre", "millimetres"], "m", 1e-3)
_add_units(["cm"], "m", 1e-2)
_add_units(["km"], "m", 1e3)
_add_units(["um", "\u00b5m", "\u03bcm", "micron", "microns"], "m", 1e-6)
_add_units(["ft", "foot", "feet"], "m", _FT)
_add_units(["in", "inch", "inches"], "m", _IN)
_add_units(["n", "newton", "newtons"], "N")
_add_units(["kn", "kilonewton", "kilonewtons"], "N", 1e3)
_add_units(["mn", "millinewton", "millinewtons"], "N", 1e-3)
_add_units(["lbf"], "N", _LBF)
_add_units(["kip", "kips", "klbf"], "N", 1e3 * _LBF)
_add_units(["s", "sec", "secs", "second", "seconds"], "s")
_add_units(["ms", "msec", "millisecond", "milliseconds"], "s", 1e-3)
_add_units(["us", "\u00b5s", "\u03bcs", "microsecond", "microseconds"], "s", 1e-6)
_add_units(["ns", "nanosecond", "nanoseconds"], "s", 1e-9)
_add_units(["min", "mins", "minute", "minutes"], "s", 60.0)
_add_units(["h", "hr", "hrs", "hour", "hours"], "s", 3600.0)
_add_units(["d", "day", "days"], "s", 86400.0)
_add_units(["hz"], "Hz")
_add_units(["kg"], "kg")
_add_units(["1", "-", "none", "dimensionless"], "1")

# CF time units: "<unit> since <reference date>" (e.g. "days since 2020-01-01 00:00").
_SINCE = re.compile(r"^\s*(?P<unit>\S+)\s+since\s+(?P<ref>\S.*?)\s*$", re.IGNORECASE)


def _lookup(unit: object) -> tuple[str, float] | None:
    """Table entry of a unit spelling, or None when unknown (or not a string)."""
    if not isinstance(unit, str):
        return None
    u = unit.replace("\u00a0", " ").strip()
    key = u.lower()
    entry = _UNIT_TABLE.get(key)
    # Case matters for the prefix: "MN", "Ms", "MM/S" are mega (or shouting); only milli is in the
    # table, so an upper-case M on a milli abbreviation is left unknown rather than guessed.
    if (entry is not None and u[:1] == "M" and entry[1] < 1.0
            and not key.startswith(("milli", "micro"))):
        return None
    return entry


def canonical_unit(unit: str) -> tuple[str, float]:
    """Canonical SI spelling of a unit and the factor that converts values to it.

    Parameters
    ----------
    unit : str
        A unit as written in a file, e.g. ``"m/s2"``, ``"g"``, ``"mm"``, ``"kN"``, ``"ft/s"``.

    Returns
    -------
    (str, float)
        SI unit and factor (``value_SI = factor * value``). Unknown units are returned unchanged
        (stripped) with factor 1: they are kept, not converted. Use :func:`is_known_unit` to tell
        the two cases apart.
    """
    entry = _lookup(unit)
    if entry is not None:
        return entry
    return str(unit).replace("\u00a0", " ").strip(), 1.0


def is_known_unit(unit: object) -> bool:
    """Whether ``unit`` is in the unit table (so its dimension and SI factor are known).

    Parameters
    ----------
    unit : object
        Usually a string such as ``"m/s^2"`` or ``"V"``; anything else is not a known unit.

    Returns
    -------
    bool
        ``True`` for the spellings listed in docs/formats.md (case-insensitive, except that an
        upper-case ``M`` is never read as milli), ``False`` for everything else (volts, ``"MN"``,
        numbers, ``None``).
    """
    return _lookup(unit) is not None


def same_unit(a: str, b: str) -> bool:
    """Whether two unit strings denote the same unit (same dimension and same scale).

    Known units are compared after normalisation (``"m/s2"`` is ``"m/s^2"``, ``"G"`` is ``"g"``;
    ``"mm/s"`` is *not* ``"m/s"``). Unknown units are the same only if spelled identically
    (case-sensitive: ``"mV"`` is not ``"MV"``). A known and an unknown unit are never the same.

    Parameters
    ----------
    a, b : str

    Returns
    -------
    bool
    """
    la, lb = _lookup(a), _lookup(b)
    if la is not None or lb is not None:
        return la == lb
    return canonical_unit(a)[0] == canonical_unit(b)[0]


def _time_unit(unit: str) -> tuple[float, str | None] | None:
    """Factor to seconds and CF reference date of a time unit; None if not a time unit.

    ``"ms"`` -> ``(1e-3, None)``; ``"days since 2020-01-01"`` -> ``(86400.0, "2020-01-01")``.
    """
    m = _SINCE.match(unit)
    base, ref = (m.group("unit"), m.group("ref")) if m else (unit, None)
    entry = _lookup(base)
    if entry is None or entry[0] != "s":
        return None
    return entry[1], ref
