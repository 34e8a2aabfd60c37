"""Time-history records: the in-memory ``Record``, file I/O, units and preprocessing.

A :class:`Record` is a set of variables sampled on one uniform time axis, each with a unit, plus
free-form attributes (tank, fill, provenance). Every command of ``sloshrom`` reads and writes
records, so that they read each other's output and the user's own shaker data. Files:

- NetCDF (``.nc``): the native format, written atomically (NetCDF-4 via xarray/h5netcdf);
  NetCDF-3 files are read too (scipy).
- CSV (``.csv``): a header row of names, units as ``name [unit]`` or in a second row; a ``time``
  column or the ``fs`` argument.
- MATLAB (``.mat``) v5 (scipy) and v7.3 (HDF5, h5py): one array per variable, optional ``fs``
  and ``units`` struct, optionally all inside one struct.
- UFF dataset 58 (``.uff``/``.unv``): :mod:`sloshrom.io.uff`.

Every bad input ends in one :class:`RecordError` whose single-line message names the file, the
variable and the problem; nothing is dropped or guessed silently (complex values, huge values,
unknown or contradicting units, a bad ``fs`` are all errors).

Preprocessing, as in the paper (section 2.1): the tank velocity by integrating the measured
acceleration with drift removal, and the dynamic sloshing force ``df = force + (m_l + m_s) acc``
from the load-cell force (sign convention of ``sloshrom.rig``: the load cells measure the force the
tank assembly exerts, ``force = -(m_l + m_s) acc + df``).

Physics is SI inside; files may use the units of a small explicit table (g, mm, kN, ft/s, lbf,
...), converted on read. Other units are kept as written and never taken for SI
(:func:`is_known_unit`, :func:`same_unit`, :func:`require_unit`).
"""

from __future__ import annotations

import csv
import io
import json
import math
import re
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from fractions import Fraction
from pathlib import Path
from typing import Any

import numpy as np

from sloshrom.config import G, Tank
from sloshrom.fileio import atomic_write

__all__ = [
    "MAX_ABS_VALUE",
    "STANDARD_UNITS",
    "Record",
    "RecordError",
    "canonical_unit",
    "dynamic_force",
    "is_known_unit",
    "preprocess",
    "read_record",
    "record_from_measurement",
    "require",
    "require_unit",
    "resample",
    "same_unit",
    "velocity_from_acceleration",
    "write_record",
]


class RecordError(ValueError):
    """A record or a record file is invalid (the message names the file, variable and problem).

    The message is always one line: line breaks of embedded text (exception messages, file
    contents) are replaced by spaces.
    """

    def __init__(self, message: object = "", *args: object) -> None:
        super().__init__(re.sub(r"\s*[\r\n]+\s*", " ", str(message)).strip(), *args)


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

# Second axes of the standard 2-D variables (first axis is always time).
_STANDARD_DIMS = {"station_acceleration": "station", "modal_acceleration": "mode"}

# Largest magnitude accepted in a record. float64 overflows at 1.8e308; with |x| < 1e100 a
# square is < 1e200 and a sum of squares over even 1e12 samples < 1e212, so MSE, RMS, energies
# (force x velocity) and products with masses stay finite. No quantity of this domain comes near
# it (SI forces, accelerations, raw ADC counts, volts all < 1e12): a larger value is a fill value
# (MATLAB realmax, Fortran huge) or a corrupt file, never a measurement.
MAX_ABS_VALUE = 1e100

# NetCDF default fill values of float32/float64 (netCDF-C NC_FILL_FLOAT/NC_FILL_DOUBLE): what
# unwritten data read as when a file has no _FillValue attribute.
_NC_DEFAULT_FILLS = (9.969209968386869e36, float(np.float32(9.96921e36)))

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


def _show(value: Any, limit: int = 60) -> str:
    """Short one-line repr of a value for an error message."""
    if isinstance(value, np.generic):
        value = value.item()  # 5, not np.int64(5)
    text = " ".join(repr(value).split())
    return text if len(text) <= limit else text[: limit - 3] + "..."


def _why(exc: BaseException, limit: int = 160) -> str:
    """Short one-line description of an exception for an error message."""
    text = " ".join(f"{type(exc).__name__}: {exc}".split())
    return text if len(text) <= limit else text[: limit - 3] + "..."


def _unit_text(value: Any, where: str) -> str | None:
    """A unit as read from a file: the string (None if empty); RecordError if it is not text.

    ``where`` names the file and variable, e.g. ``"x.nc: variable 'force'"``.
    """
    if isinstance(value, bytes):
        try:
            value = value.decode("utf-8")
        except UnicodeDecodeError:
            raise RecordError(f"{where}: unit {_show(value)} is not UTF-8 text") from None
    if isinstance(value, np.ndarray) and value.dtype.kind in "US":
        if value.size == 0:
            return None
        if value.size == 1:
            value = str(value.reshape(-1)[0])
    if isinstance(value, np.str_):
        value = str(value)
    if not isinstance(value, str):
        raise RecordError(
            f"{where}: unit {_show(value)} ({type(value).__name__}) is not a unit string"
        )
    text = value.replace("\u00a0", " ").strip()
    if not text:
        return None
    if text != "1":
        try:
            float(text)
        except ValueError:
            pass
        else:
            raise RecordError(f"{where}: unit {text!r} is a number, not a unit")
    return text


def _as_float_array(name: str, value: Any) -> np.ndarray:
    """Values of a variable as a float array; RecordError for complex, text, dates, objects."""
    raw = value if isinstance(value, np.ndarray) else None
    if raw is None:
        try:
            raw = np.asarray(value)
        except (TypeError, ValueError) as exc:  # ragged nested lists
            raise RecordError(f"variable {name!r}: not numeric ({_why(exc)})") from exc
    kind = raw.dtype.kind
    if kind == "c":
        imag = np.abs(raw.imag)
        peak = float(imag.max()) if imag.size and np.all(np.isfinite(imag)) else float("nan")
        raise RecordError(
            f"variable {name!r}: complex values (dtype {raw.dtype}, max |imag| {peak:.3g}): a "
            "time history must be real (export the real part if the imaginary part is round-off)"
        )
    if kind == "V":
        raise RecordError(f"variable {name!r}: structured values (dtype {raw.dtype}), not numbers")
    if kind in "US":
        raise RecordError(
            f"variable {name!r}: text, not numbers (dtype {raw.dtype}, e.g. "
            f"{_show(raw.reshape(-1)[0] if raw.size else '')})"
        )
    if kind in "mM":
        raise RecordError(
            f"variable {name!r}: dates/durations (dtype {raw.dtype}), not numbers; give time as "
            "numeric seconds"
        )
    try:
        arr = np.asarray(raw, dtype=float)
    except (TypeError, ValueError) as exc:
        raise RecordError(f"variable {name!r}: not numeric ({_why(exc)})") from exc
    return arr


def _check_magnitude(name: str, arr: np.ndarray, t: np.ndarray | None) -> None:
    """RecordError if any |value| >= MAX_ABS_VALUE (finite values only are passed)."""
    big = np.abs(arr) >= MAX_ABS_VALUE
    if np.any(big):
        flat = int(np.flatnonzero(big)[0])
        row = flat // (arr.size // arr.shape[0]) if arr.ndim > 1 else flat
        at = f"sample {row}" + (f", t={t[row]:g} s" if t is not None else "")
        raise RecordError(
            f"variable {name!r} has a value of magnitude >= {MAX_ABS_VALUE:g} "
            f"({arr.reshape(-1)[flat]:g} at {at}): not a measurement (fill value? corrupt "
            "file?); squares and sums of it would overflow"
        )


def _check_fs(fs: Any, where: str = "") -> float:
    """``fs`` as a float; RecordError unless it is a finite positive number of Hz."""
    prefix = f"{where}: " if where else ""
    if isinstance(fs, bool | str | bytes) or fs is None:
        raise RecordError(f"{prefix}fs must be a number in Hz, got {_show(fs)}")
    try:
        arr = np.asarray(fs)
        if arr.dtype.kind not in "biuf":  # complex, text, objects: not a rate
            raise TypeError(arr.dtype)
        arr = arr.astype(float)
    except (TypeError, ValueError):
        raise RecordError(f"{prefix}fs must be a number in Hz, got {_show(fs)}") from None
    if arr.size != 1:
        raise RecordError(f"{prefix}fs must be one number in Hz, got shape {arr.shape}")
    value = float(arr.reshape(-1)[0])
    if not (math.isfinite(value) and value > 0):
        raise RecordError(f"{prefix}fs must be a finite positive rate in Hz, got {value:g}")
    return value


@dataclass(eq=False)  # arrays: no element-wise __eq__
class Record:
    """Variables sampled on one uniform time axis, with units and attributes.

    Parameters
    ----------
    time : array_like
        Sample times, s; 1-D, at least 2 samples, finite, strictly increasing, uniform (steps
        equal within 1 %).
    fs : float or None
        Sample rate, Hz; ``None`` derives it from ``time``. If given it must be a finite positive
        number matching ``time`` (0.1 %).
    variables : dict of str to array_like
        Each of shape ``(n,)`` or ``(n, k)`` with ``n = len(time)``; real, finite values of
        magnitude below :data:`MAX_ABS_VALUE` (1e100).
    units : dict of str to str
        A non-empty unit string for every variable (``"time"`` optional, always ``"s"``). Known
        spellings are normalised (``"m/s2"`` -> ``"m/s^2"``); values are NOT converted (see
        :meth:`to_si`); unknown units (``"V"``) are kept as written.
    attrs : dict
        Free-form attributes: ``tank`` (dict of :class:`sloshrom.config.Tank` fields or a Tank),
        ``fill``, ``provenance``, ... Values must be numbers, strings, lists or dicts.
    dims : dict of str to str, optional
        Name of the second axis of 2-D variables (default: ``station``/``mode`` for the standard
        beam variables, ``<name>_index`` otherwise).

    Raises
    ------
    RecordError
        Naming the variable and the problem (NaN/inf, huge values, complex or text values,
        length mismatch, non-uniform or non-increasing time, missing unit, bad ``fs``).
    """

    time: np.ndarray
    fs: float | None
    variables: dict[str, np.ndarray]
    units: dict[str, str] = field(default_factory=dict)
    attrs: dict[str, Any] = field(default_factory=dict)
    dims: dict[str, str] = field(default_factory=dict)

    def __post_init__(self) -> None:
        t = _as_float_array("time", self.time)
        if t.ndim != 1:
            raise RecordError(f"time must be 1-D, got shape {t.shape}")
        if t.size < 2:
            raise RecordError(f"a record needs at least 2 samples, got {t.size}")
        if not np.all(np.isfinite(t)):
            bad = int(np.flatnonzero(~np.isfinite(t))[0])
            raise RecordError(f"time contains NaN/inf (first at sample {bad})")
        _check_magnitude("time", t, None)
        dt = np.diff(t)
        if np.any(dt <= 0):
            bad = int(np.flatnonzero(dt <= 0)[0])
            raise RecordError(
                f"time is not strictly increasing (sample {bad + 1}: {t[bad + 1]!r} after "
                f"{t[bad]!r})"
            )
        step = (t[-1] - t[0]) / (t.size - 1)
        dev = np.abs(dt - step)
        if np.any(dev > 0.01 * step):
            bad = int(np.argmax(dev))
            raise RecordError(
                f"time is not uniformly sampled: step {dt[bad]!r} s at sample {bad + 1} vs "
                f"mean step {step!r} s (resample to a uniform grid first)"
            )
        fs_time = 1.0 / step
        if self.fs is None:
            fs = fs_time
        else:
            fs = _check_fs(self.fs)
            if abs(fs - fs_time) > 1e-3 * fs:
                raise RecordError(f"fs={fs!r} Hz does not match the time axis (1/dt = {fs_time!r})")
        self.time = t
        self.fs = fs
        if not isinstance(self.variables, Mapping):
            raise RecordError("variables must be a dict of name -> array")
        if not isinstance(self.units, Mapping):
            raise RecordError("units must be a dict of name -> unit string")
        variables: dict[str, np.ndarray] = {}
        units: dict[str, str] = {"time": "s"}
        tu = self.units.get("time", "s")
        if not isinstance(tu, str) or canonical_unit(tu) != ("s", 1.0):
            raise RecordError(f"time must be in s in a Record, got unit {_show(tu)}")
        for name, value in self.variables.items():
            if not isinstance(name, str) or not name.strip() or name == "time":
                raise RecordError(f"invalid variable name {_show(name)}")
            arr = _as_float_array(name, value)
            if arr.ndim == 0 or arr.shape[0] != t.size:
                hint = ""
                if arr.ndim == 2 and arr.shape[1] == t.size:
                    hint = " (time runs along the second axis: transpose it to (n, k))"
                elif arr.size == 0:
                    hint = " (the variable is empty)"
                raise RecordError(
                    f"variable {name!r} has shape {arr.shape}, expected ({t.size}, ...) to match "
                    f"time{hint}"
                )
            if arr.ndim > 2:
                raise RecordError(f"variable {name!r}: at most 2-D (time, x), got {arr.shape}")
            finite = np.isfinite(arr)
            if not np.all(finite):
                bad = int(np.flatnonzero(~finite.reshape(t.size, -1).all(axis=1))[0])
                raise RecordError(
                    f"variable {name!r} contains NaN/inf (first at sample {bad}, t={t[bad]:g} s)"
                )
            _check_magnitude(name, arr, t)
            unit = self.units.get(name)
            if unit is not None and not isinstance(unit, str):
                raise RecordError(
                    f"variable {name!r}: unit {_show(unit)} ({type(unit).__name__}) is not a "
                    "unit string"
                )
            if unit is None or not unit.strip():
                raise RecordError(
                    f"variable {name!r} has no unit (give units={{{name!r}: ...}}; "
                    f"SI for this name: {STANDARD_UNITS.get(name, 'unknown')!r})"
                )
            variables[name] = arr
            si, k = canonical_unit(unit)
            units[name] = si if k == 1.0 else unit.strip()
        self.variables = variables
        self.units = units
        self.attrs = dict(self.attrs)
        if isinstance(self.attrs.get("tank"), Tank):
            self.attrs["tank"] = self.attrs["tank"].to_dict()
        dims = {}
        for name, arr in variables.items():
            if arr.ndim == 2:
                dims[name] = self.dims.get(name, _STANDARD_DIMS.get(name, f"{name}_index"))
        self.dims = dims

    # -- access -------------------------------------------------------------------------------
    def __getitem__(self, name: str) -> np.ndarray:
        if name == "time":
            return self.time
        require(self, [name])
        return self.variables[name]

    def __contains__(self, name: object) -> bool:
        return name == "time" or name in self.variables

    def __len__(self) -> int:
        return int(self.time.size)

    @property
    def names(self) -> list[str]:
        """Variable names (time excluded)."""
        return list(self.variables)

    @property
    def duration(self) -> float:
        """Record length t[-1] - t[0], s."""
        return float(self.time[-1] - self.time[0])

    @property
    def tank(self) -> Tank | None:
        """The tank of the attrs, or None."""
        t = self.attrs.get("tank")
        return None if t is None else Tank.from_dict(dict(t))

    def with_variables(
        self, variables: Mapping[str, Any], units: Mapping[str, str], **attrs: Any
    ) -> Record:
        """A new record with variables added or replaced (and attrs updated)."""
        return Record(
            self.time,
            self.fs,
            {**self.variables, **variables},
            {**self.units, **units},
            {**self.attrs, **attrs},
            dict(self.dims),
        )

    def to_si(self) -> Record:
        """A copy with every known unit (g, mm, kN, ft/s, lbf, ...) converted to SI.

        Unknown units (``"V"``) are kept as they are. Raises :class:`RecordError` (naming the
        source file) if a converted value reaches :data:`MAX_ABS_VALUE`.
        """
        variables, units = {}, {}
        for name, arr in self.variables.items():
            si, k = canonical_unit(self.units[name])
            variables[name] = arr * k if k != 1.0 else arr
            units[name] = si
        try:
            return Record(self.time, self.fs, variables, units, dict(self.attrs), dict(self.dims))
        except RecordError as exc:
            src = self.attrs.get("source")
            raise RecordError(f"{src}: {exc}" if src else str(exc)) from None

    # -- xarray ---------------------------------------------------------------------------------
    def to_dataset(self):
        """The record as an ``xarray.Dataset`` (``units`` attributes, ``fs`` and attrs flattened).

        Dict attributes become JSON strings (``tank`` as numeric ``tank_<field>`` attributes).
        """
        import xarray as xr

        data_vars = {}
        for name, arr in self.variables.items():
            dims = ("time",) if arr.ndim == 1 else ("time", self.dims[name])
            data_vars[name] = xr.Variable(dims, arr, {"units": self.units[name]})
        ds = xr.Dataset(data_vars, coords={"time": ("time", self.time, {"units": "s"})})
        ds.attrs.update(_flatten_attrs(self.attrs))
        ds.attrs["fs"] = float(self.fs)
        return ds

    @classmethod
    def from_dataset(
        cls,
        ds,
        source: str = "dataset",
        fs: float | None = None,
        units: Mapping[str, str] | None = None,
    ) -> Record:
        """Build a record from an ``xarray.Dataset`` with a 1-D ``time`` coordinate/variable.

        Variables along the time dimension are taken (moved to time-first if stored the other way
        round); the others (e.g. station positions) are ignored.

        Parameters
        ----------
        ds : xarray.Dataset
            ``time`` in a time unit (s, ms, min, h, d, ...; no ``units`` attribute means s) or CF
            ``"<unit> since <date>"`` (then time starts at 0 s; ``attrs["time_reference"]`` keeps
            the date and ``attrs["time_start"]`` the first sample's offset from it, s).
        source : str
            Names the file in error messages.
        fs : float, optional
            Sample rate, Hz, checked against the ``fs`` attribute and the time axis.
        units : dict, optional
            Units of variables without a ``units`` attribute; one that contradicts the file's is
            an error.

        Returns
        -------
        Record
        """
        if "time" not in ds.variables:
            raise RecordError(f"{source}: no 'time' variable or coordinate")
        tvar = ds["time"]
        if tvar.ndim != 1:
            raise RecordError(f"{source}: time must be 1-D, got dims {tvar.dims}")
        tdim = tvar.dims[0]
        time = np.asarray(tvar.values)
        if np.issubdtype(time.dtype, np.datetime64) or np.issubdtype(time.dtype, np.timedelta64):
            raise RecordError(f"{source}: time must be numeric seconds, got {time.dtype}")
        variables: dict[str, np.ndarray] = {}
        file_units: dict[str, str] = {}
        dims: dict[str, str] = {}
        traw = tvar.attrs.get("units")
        tunit = None if traw is None else _unit_text(traw, f"{source}: variable 'time'")
        if tunit is not None:
            file_units["time"] = tunit
        tunit = (units or {}).get("time", tunit) or "s"  # no unit: seconds
        t, tattrs = _time_seconds(source, time, tunit)
        for key, var in ds.data_vars.items():
            name = str(key)
            if tdim not in var.dims or name == "time":
                continue
            if var.dims[0] != tdim:  # named dimensions: moving time first is unambiguous
                var = var.transpose(tdim, ...)
            values = np.asarray(var.values)
            if values.dtype.kind == "f" and values.size:
                _check_nc_fill(source, name, values, t)
            variables[name] = values
            if var.attrs.get("units") is not None:
                unit = _unit_text(var.attrs["units"], f"{source}: variable {name!r}")
                if unit is not None:
                    file_units[name] = unit
            if var.ndim == 2:
                dims[name] = str(var.dims[1])
        if not variables:
            raise RecordError(
                f"{source}: no variables along the time dimension {tdim!r} (data variables: "
                f"{_names(str(k) for k in ds.data_vars) or 'none'})"
            )
        all_units = _merge_units(source, file_units, units or {}, ["time", *variables])
        all_units.pop("time", None)  # converted to s above
        for name in variables:
            if name not in all_units:
                raise RecordError(
                    f"{source}: variable {name!r} has no 'units' attribute (give units="
                    f"{{{name!r}: ...}}; SI for this name: "
                    f"{STANDARD_UNITS.get(name, 'unknown')!r})"
                )
        attrs = _unflatten_attrs(dict(ds.attrs), source)
        fs_file = attrs.pop("fs", None)
        if fs is not None and fs_file is not None:
            ff = _check_fs(fs_file, f"{source}: attribute 'fs'")
            if abs(ff - fs) > 1e-3 * fs:
                raise RecordError(f"{source}: fs={fs:g} Hz given but the file says fs={ff:g} Hz")
        attrs.update(tattrs)
        try:
            return cls(t, fs if fs is not None else fs_file, variables, all_units, attrs, dims)
        except RecordError as exc:
            raise RecordError(f"{source}: {exc}") from None


def _names(names: Iterable[str], limit: int = 8) -> str:
    """Quoted, comma-separated names, at most ``limit`` of them (messages stay short)."""
    items = [repr(n) for n in names]
    more = f", ... ({len(items)} in all)" if len(items) > limit else ""
    return ", ".join(items[:limit]) + more


def _check_nc_fill(source: str, name: str, values: np.ndarray, t: np.ndarray) -> None:
    """RecordError if a float variable holds the NetCDF default fill value (unwritten data)."""
    hit = np.isin(values, _NC_DEFAULT_FILLS)
    if np.any(hit):
        row = int(np.flatnonzero(hit.reshape(values.shape[0], -1).any(axis=1))[0])
        at = f", t={t[row]:g} s" if row < t.size else ""
        raise RecordError(
            f"{source}: variable {name!r} holds the NetCDF default fill value 9.97e+36 at sample "
            f"{row}{at}: unwritten (missing) data"
        )


def _time_seconds(source: str, time: Any, unit: str) -> tuple[np.ndarray, dict[str, Any]]:
    """Time values in ``unit`` as seconds, plus the attrs of a CF reference date (if any).

    CF ``"<unit> since <date>"`` times are counted from the first sample (subtracted before
    scaling, so that e.g. days since 1970 keep sub-millisecond resolution).
    """
    conv = _time_unit(unit)
    if conv is None:
        raise RecordError(
            f"{source}: time unit {unit!r} is not a time unit (use s, ms, us, min, h, d or CF "
            "'<unit> since <date>')"
        )
    k, ref = conv
    try:
        t = _as_float_array("time", time)
    except RecordError as exc:
        raise RecordError(f"{source}: {exc}") from None
    if ref is None:
        return (t * k if k != 1.0 else t), {}
    if t.ndim != 1 or t.size == 0 or not np.isfinite(t[0]):
        return t * k, {}  # the Record names the problem
    return (t - t[0]) * k, {"time_reference": ref, "time_start": float(t[0]) * k}


def _merge_units(
    source: str, file_units: Mapping[str, str], given: Mapping[str, str], names: list[str]
) -> dict[str, str]:
    """The file's units completed by the caller's (``units=``).

    RecordError if the caller names a variable the file does not have, or gives a unit that
    contradicts the file's (the same unit spelled differently is fine).
    """
    unknown = [k for k in given if k not in names]
    if unknown:
        raise RecordError(
            f"{source}: units= names {_names(unknown)}, which the file does not have (it has "
            f"{_names(names)})"
        )
    out = dict(file_units)
    for name, unit in given.items():
        have = file_units.get(name)
        if have is not None and not same_unit(have, unit):
            raise RecordError(
                f"{source}: variable {name!r}: units= gives {unit!r} but the file says {have!r}"
            )
        out.setdefault(name, unit)
    return out


def require(record: Record, names: Iterable[str]) -> None:
    """Raise a clear :class:`RecordError` if any of ``names`` is missing from ``record``.

    The message names the record's source file and lists what it has (and, for MAT files,
    what was ignored and why, from ``attrs["ignored_variables"]``).
    """
    missing = [n for n in names if n not in record]
    if missing:
        src = record.attrs.get("source", "record")
        ignored = record.attrs.get("ignored_variables")
        why = ""
        if isinstance(ignored, Mapping):
            hits = [f"{n!r} ({ignored[n]})" for n in missing if n in ignored]
            if hits:
                why = f"; ignored in the file: {', '.join(hits)}"
        msg = (
            f"{src}: missing variable(s) {', '.join(map(repr, missing))}; "
            f"it has {_names(['time', *record.names])}{why}"
        )
        raise RecordError(msg[:399])


def require_unit(
    record: Record, name: str, expected: str, *, allow_unknown: bool = False
) -> None:
    """Raise a clear :class:`RecordError` unless ``record.units[name]`` is ``expected``.

    "Is" means :func:`same_unit` (``"m/s2"`` is ``"m/s^2"``; ``"mm/s"`` is not ``"m/s"``: convert
    with :meth:`Record.to_si` first). An unknown unit (``"V"``) is refused unless
    ``allow_unknown`` is true and it is spelled exactly as ``expected``: a model identified on
    volts may be run on volts, but nothing is taken for SI without knowing it.

    Parameters
    ----------
    record : Record
    name : str
        Variable (must exist).
    expected : str
        The unit the caller needs, e.g. the model's input unit.
    allow_unknown : bool
        Accept identical unknown units.

    Raises
    ------
    RecordError
        ``"<source>: variable 'x' has unit 'mm/s', expected 'm/s'"`` (naming unknown units).
    """
    require(record, [name])
    unit = record.units[name]
    if same_unit(unit, expected) and (allow_unknown or is_known_unit(unit)):
        return
    src = record.attrs.get("source", "record")
    notes = [f"{u!r} is not a known unit" for u in dict.fromkeys((unit, expected))
             if not is_known_unit(u)]
    if not notes and canonical_unit(unit)[0] == canonical_unit(expected)[0]:
        notes.append("same dimension, other scale: convert with Record.to_si()")
    raise RecordError(
        f"{src}: variable {name!r} has unit {unit!r}, expected {expected!r}"
        + (f" ({'; '.join(notes)})" if notes else "")
    )


# -- attributes <-> NetCDF ----------------------------------------------------------------------
_JSON_PREFIX = "json:"


def _flatten_attrs(attrs: Mapping[str, Any]) -> dict[str, Any]:
    out: dict[str, Any] = {}
    for key, value in attrs.items():
        if value is None:
            continue
        if key == "tank" and isinstance(value, Mapping | Tank):
            tank = value.to_dict() if isinstance(value, Tank) else dict(value)
            for k, v in tank.items():
                out[f"tank_{k}"] = float(v)
        elif isinstance(value, bool):
            out[key] = int(value)
        elif isinstance(value, int | float | np.integer | np.floating | str):
            out[key] = value
        else:
            out[key] = _JSON_PREFIX + json.dumps(value, default=_json_default)
    return out


def _json_default(obj: Any) -> Any:
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    if isinstance(obj, np.generic):
        return obj.item()
    return str(obj)


def _unflatten_attrs(raw: Mapping[str, Any], source: str = "dataset") -> dict[str, Any]:
    out: dict[str, Any] = {}
    tank: dict[str, float] = {}
    for key, value in raw.items():
        if isinstance(value, np.ndarray) and value.size == 1:
            value = value.item()
        if isinstance(value, np.generic):
            value = value.item()
        if key.startswith("tank_"):
            tank[key[5:]] = value
        elif isinstance(value, str) and value.startswith(_JSON_PREFIX):
            try:
                out[key] = json.loads(value[len(_JSON_PREFIX) :])
            except ValueError as exc:
                raise RecordError(
                    f"{source}: attribute {key!r} is not valid JSON ({_why(exc)})"
                ) from None
        else:
            out[key] = value
    if tank:
        out["tank"] = tank
    return out


# -- file I/O -----------------------------------------------------------------------------------
def read_record(
    path: str | Path,
    fs: float | None = None,
    units: Mapping[str, str] | None = None,
    si: bool = True,
) -> Record:
    """Read a record from NetCDF (``.nc``), CSV (``.csv``), MATLAB (``.mat``, v5 or v7.3) or
    UFF dataset 58 (``.uff``/``.unv``, see :func:`sloshrom.io.uff.read_uff58`).

    Parameters
    ----------
    path : str or Path
    fs : float, optional
        Sample rate, Hz (finite, > 0), for files without a time column/variable
        (time = arange(n) / fs); if the file has a time axis or an ``fs`` of its own, they must
        agree (0.1 %).
    units : dict, optional
        Units for variables whose file gives none, e.g. ``{"acceleration": "g"}``. For NetCDF,
        CSV and MAT a unit that contradicts the file's, or a name the file does not have, is an
        error; for UFF they override the ordinate labels (see :func:`sloshrom.io.uff.read_uff58`).
    si : bool
        Convert known units (g, mm, kN, mN, ms, ft/s, lbf, ...) to SI (default). Unknown units
        (``"V"``) are kept as written.

    Returns
    -------
    Record
        With ``attrs["source"]`` = the path.

    Raises
    ------
    RecordError
        One line naming the file, the variable and the problem: missing/empty/truncated file,
        unknown suffix, bad ``fs``, bad or missing data/units, complex or huge values.
    """
    p = Path(path)
    if fs is not None:
        fs = _check_fs(fs, str(p))
    given = _check_units_arg(p, units)
    if not p.is_file():
        raise RecordError(f"{p}: no such file")
    if p.stat().st_size == 0:
        raise RecordError(f"{p}: file is empty")
    suffix = p.suffix.lower()
    if suffix not in (".nc", ".nc4", ".netcdf", ".h5", ".csv", ".txt", ".mat", ".uff", ".unv"):
        raise RecordError(
            f"{p}: unknown record format {suffix!r} (use .nc, .csv, .mat, .uff or .unv)"
        )
    try:
        if suffix in (".csv", ".txt"):
            rec = _read_csv(p, fs, given)
        elif suffix == ".mat":
            rec = _read_mat(p, fs, given)
        elif suffix in (".uff", ".unv"):
            from sloshrom.io.uff import read_uff58  # UFF dataset 58 time histories (pyuff)

            rec = read_uff58(p, units=given)
            if fs is not None and abs(rec.fs - fs) > 1e-3 * fs:
                raise RecordError(
                    f"{p}: fs={fs:g} Hz given but the file's time axis says {rec.fs:g} Hz"
                )
        else:
            rec = _read_netcdf(p, fs, given)
    except OSError as exc:  # permissions, a file that vanished or changed while read
        raise RecordError(f"{p}: cannot read the file ({_why(exc)})") from exc
    rec.attrs.setdefault("source", str(p))
    return rec.to_si() if si else rec


def _check_units_arg(p: Path, units: Mapping[str, str] | None) -> dict[str, str]:
    """The caller's ``units=`` as a dict of name -> non-empty unit string."""
    if units is None:
        return {}
    if not isinstance(units, Mapping):
        raise RecordError(f"{p}: units= must be a dict of name -> unit, got {_show(units)}")
    out = {}
    for name, unit in units.items():
        text = _unit_text(unit, f"{p}: units={{{name!r}: ...}}")
        if not isinstance(name, str) or text is None:
            raise RecordError(f"{p}: units= entry {_show(name)}: {_show(unit)} is not a unit")
        out[name] = text
    return out


# NetCDF-3 "classic" (CDF\x01) and "64-bit offset" (CDF\x02) files are read with scipy;
# CDF\x05 (64-bit data, CDF-5) is not supported by scipy.
_CDF_MAGIC = {b"CDF\x01": "scipy", b"CDF\x02": "scipy"}


def _read_netcdf(p: Path, fs: float | None, units: Mapping[str, str]) -> Record:
    import xarray as xr

    with p.open("rb") as fh:
        magic = fh.read(4)
    if magic[:3] == b"CDF" and magic not in _CDF_MAGIC:
        raise RecordError(
            f"{p}: NetCDF-3 variant {magic!r} (CDF-5, 64-bit data) is not supported; convert it "
            "to NetCDF-4 (nccopy -k nc4 in.nc out.nc)"
        )
    engine = _CDF_MAGIC.get(magic, "h5netcdf")  # NetCDF-4 is HDF5 (also after a user block)
    # scipy: no memory map, so that nothing refers to the file once it is closed
    kw: dict[str, Any] = {"mmap": False} if engine == "scipy" else {}
    try:
        # no CF time decoding: time stays numeric (s, ms, "days since ...", ...)
        with xr.open_dataset(
            p, engine=engine, decode_times=False, decode_timedelta=False, **kw
        ) as ds:
            ds = ds.load()
    except Exception as exc:  # h5py/scipy/xarray raise many types for corrupt files
        kind = "NetCDF-3" if engine == "scipy" else "NetCDF"
        raise RecordError(f"{p}: not a readable {kind} file ({_why(exc)})") from exc
    return Record.from_dataset(ds, source=str(p), fs=fs, units=units)


_HEADER_UNIT = re.compile(r"^\s*(?P<name>[^\[\(]*?)\s*[\[\(]\s*(?P<unit>[^\]\)]*?)\s*[\]\)]\s*$")
_TIME_NAMES = ("time", "t", "Time", "TIME")


def _build(
    source: str,
    columns: dict[str, np.ndarray],
    file_units: Mapping[str, str],
    fs: float | None,
    units: Mapping[str, str],
    ignored: Mapping[str, str] | None = None,
) -> Record:
    """Common tail of CSV/MAT readers: pick the time axis, attach units, validate.

    ``fs`` has been checked (finite, > 0) by the caller; ``ignored`` lists file entries that are
    not time histories (name -> reason), kept in ``attrs["ignored_variables"]``.
    """
    cols = dict(columns)
    ignored = dict(ignored or {})
    tname = next((k for k in _TIME_NAMES if k in cols), None)
    all_units = _merge_units(source, file_units, units, [*cols, *ignored])
    attrs: dict[str, Any] = {"source": source}
    if ignored:
        attrs["ignored_variables"] = ignored
    if tname is not None:
        traw = np.asarray(cols.pop(tname))
        if traw.ndim == 0:
            traw = traw.reshape(1)
        if traw.ndim != 1:
            raise RecordError(
                f"{source}: time variable {tname!r} has shape {traw.shape}, expected a vector"
            )
        time, tattrs = _time_seconds(source, traw, all_units.get(tname, "s"))
        attrs.update(tattrs)
    elif fs is not None:
        if not cols:
            raise RecordError(f"{source}: no data columns{_ignored_note(ignored)}")
        lengths = {k: (np.shape(v)[0] if np.ndim(v) else 1) for k, v in cols.items()}
        empty = [k for k, n in lengths.items() if n == 0]
        if empty:
            raise RecordError(f"{source}: variable {empty[0]!r} is empty (0 samples)")
        time = np.arange(max(lengths.values())) / fs
    else:
        raise RecordError(
            f"{source}: no 'time' column/variable; pass fs= (Hz) to read it"
            + _ignored_note(ignored)
        )
    if time.size < 2:
        raise RecordError(f"{source}: a record needs at least 2 samples, got {time.size}")
    if not cols:
        raise RecordError(f"{source}: no data variables besides time{_ignored_note(ignored)}")
    var_units = {k: all_units[k] for k in cols if k in all_units}
    try:
        return Record(time, fs, cols, var_units, attrs)
    except RecordError as exc:
        raise RecordError(f"{source}: {exc}") from None


def _ignored_note(ignored: Mapping[str, str]) -> str:
    if not ignored:
        return ""
    return " (ignored: " + ", ".join(f"{k!r} ({v})" for k, v in list(ignored.items())[:6]) + ")"


def _is_number(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


def _read_csv(p: Path, fs: float | None, units: Mapping[str, str]) -> Record:
    try:
        text = p.read_text(encoding="utf-8-sig")  # -sig: a byte-order mark is not a name
    except UnicodeDecodeError as exc:
        raise RecordError(f"{p}: not a UTF-8 text CSV file ({_why(exc)})") from exc
    if "\x00" in text:
        raise RecordError(f"{p}: binary data (NUL bytes), not a text CSV file (UTF-16?)")
    lines = [ln for ln in text.splitlines() if ln.strip() and not ln.lstrip().startswith("#")]
    if not lines:
        raise RecordError(f"{p}: no header or data")
    header = lines[0]
    delim = max((",", ";", "\t"), key=header.count)
    if header.count(delim) == 0:
        delim = ","
    names_raw = next(csv.reader([header], delimiter=delim))
    if all(_is_number(f) for f in names_raw):
        raise RecordError(
            f"{p}: the first row {_show(header)} holds numbers, not column names (add a header "
            "row such as 'time [s],acceleration [g]')"
        )
    names, file_units = [], {}
    for raw in names_raw:
        m = _HEADER_UNIT.match(raw)
        name = (m.group("name") if m else raw).strip()
        if not name:
            raise RecordError(f"{p}: empty column name in header {_show(header, 120)}")
        if m:
            unit = _unit_text(m.group("unit"), f"{p}: column {name!r}")
            if unit is not None:
                file_units[name] = unit
        names.append(name)
    if len(set(names)) != len(names):
        dup = next(n for n in names if names.count(n) > 1)
        raise RecordError(f"{p}: duplicate column name {dup!r} in header {_show(names, 120)}")
    body = lines[1:]
    if body:
        first = next(csv.reader([body[0]], delimiter=delim))
        if not _is_numeric_row(first, delim != ","):  # a units row, or a data row with a typo
            _units_row(p, names, first, file_units)
            body = body[1:]
    if not body:
        raise RecordError(f"{p}: header but no data rows")
    if delim != "," and any("," in ln for ln in body) and not any("." in ln for ln in body):
        # decimal comma (European spreadsheets export "1,5;2,25"): with ; or tab delimiters
        # and no decimal point anywhere, a comma can only be the decimal separator
        body = [ln.replace(",", ".") for ln in body]
    try:
        data = np.loadtxt(io.StringIO("\n".join(body)), delimiter=delim, ndmin=2)
    except ValueError as exc:
        raise RecordError(
            f"{p}: bad data row ({_find_bad_field(body, delim, names) or _why(exc)})"
        ) from exc
    if data.shape[1] != len(names):
        raise RecordError(f"{p}: {data.shape[1]} data columns but {len(names)} names in header")
    cols = {name: data[:, i] for i, name in enumerate(names)}
    return _build(str(p), cols, file_units, fs, units)


def _units_row(p: Path, names: list[str], fields: list[str], file_units: dict[str, str]) -> None:
    """Read a CSV units row into ``file_units`` (checked against the header's units)."""
    if len(fields) != len(names):
        raise RecordError(f"{p}: units row has {len(fields)} fields, header {len(names)}")
    numeric = [(n, f) for n, f in zip(names, fields, strict=True)
               if f.strip() and f.strip() != "1" and _is_number(f)]
    if numeric:  # numbers and text mixed: a data row with a bad field, not a units row
        name, field_ = next((n, f) for n, f in zip(names, fields, strict=True)
                            if not _is_number(f))
        raise RecordError(f"{p}: bad data row (data row 1, column {name!r}: {field_!r} is not a "
                          "number)")
    for name, u in zip(names, fields, strict=True):
        unit = _unit_text(u, f"{p}: units row, column {name!r}")
        if unit is None:
            continue
        head = file_units.get(name)
        if head is not None and not same_unit(head, unit):
            raise RecordError(
                f"{p}: column {name!r}: the header says unit {head!r}, the units row {unit!r}"
            )
        file_units.setdefault(name, unit)


def _find_bad_field(body: list[str], delim: str, names: list[str]) -> str | None:
    """Locate the first non-numeric CSV field, naming its data row and column."""
    for i, fields in enumerate(csv.reader(body, delimiter=delim)):
        if len(fields) != len(names):
            return f"data row {i + 1} has {len(fields)} fields, the header {len(names)}"
        for name, f in zip(names, fields, strict=True):
            try:
                float(f)
            except ValueError:
                return f"data row {i + 1}, column {name!r}: {_show(f)} is not a number"
    return None


def _is_numeric_row(fields: list[str], decimal_comma: bool = False) -> bool:
    try:
        [float(f.replace(",", ".") if decimal_comma else f) for f in fields if f.strip()]
    except ValueError:
        return False
    return True


def _is_text(value: Any) -> bool:
    return isinstance(value, str | bytes) or (
        isinstance(value, np.ndarray) and value.dtype.kind in "US"
    )


def _read_mat(p: Path, fs: float | None, units: Mapping[str, str]) -> Record:
    import h5py

    try:
        is_h5 = h5py.is_hdf5(p)
    except OSError:
        is_h5 = False
    items = _read_mat73(p) if is_h5 else _read_mat5(p)
    # A file with one struct holding everything: unpack it.
    structs = [k for k, v in items.items() if isinstance(v, dict) and k != "units"]
    arrays = [k for k, v in items.items() if not isinstance(v, dict)]
    if len(structs) == 1 and not [a for a in arrays if a not in ("fs",)]:
        inner = items[structs[0]]
        items = {**inner, **{k: v for k, v in items.items() if k != structs[0]}}
    file_units: dict[str, str] = {}
    if "units" in items:
        table = items.pop("units")
        if not isinstance(table, dict):
            raise RecordError(
                f"{p}: 'units' must be a struct of unit strings (units.force = 'N'), got "
                f"{_show(table)}"
            )
        for k, v in table.items():
            unit = _unit_text(v, f"{p}: units.{k}")
            if unit is not None:
                file_units[k] = unit
    for k in [k for k in items if k.endswith("_units") and len(k) > len("_units")]:
        base, v = k[: -len("_units")], items[k]
        if base not in items and not _is_text(v):
            continue  # an ordinary variable that happens to end in _units
        unit = _unit_text(v, f"{p}: {k}")
        items.pop(k)
        if unit is None:
            continue
        if base in file_units and not same_unit(file_units[base], unit):
            raise RecordError(
                f"{p}: variable {base!r}: units.{base} = {file_units[base]!r} but {k} = {unit!r}"
            )
        file_units.setdefault(base, unit)
    if "fs" in items:
        v = items.pop("fs")
        if _is_text(v) or isinstance(v, dict):
            raise RecordError(f"{p}: variable 'fs' is {_show(v)}, not a number in Hz")
        fs_file = _check_fs(v, f"{p}: variable 'fs'")
        if fs is not None and abs(fs_file - fs) > 1e-3 * fs:
            raise RecordError(f"{p}: fs={fs:g} Hz given but the file says fs={fs_file:g} Hz")
        fs = fs_file if fs is None else fs
    tname = next((k for k in _TIME_NAMES if k in items), None)
    cols: dict[str, np.ndarray] = {}
    ignored: dict[str, str] = {}
    for k, v in items.items():
        reason = _mat_not_a_history(v, k == tname)
        if reason is None:
            arr = np.asarray(v)
            cols[k] = arr.reshape(-1) if arr.ndim == 2 and 1 in arr.shape else arr
            continue
        if k == tname or (reason != "a scalar" and (k in file_units or k in units)):
            raise RecordError(f"{p}: variable {k!r} holds {reason}, not a time history")
        ignored[k] = reason  # settings, notes: not time histories (attrs say which)
    return _build(str(p), cols, file_units, fs, units, ignored)


def _mat_not_a_history(value: Any, is_time: bool) -> str | None:
    """Why a MAT entry is not a time history (None if it is one: a numeric array)."""
    if isinstance(value, dict):
        return "a struct"
    if _is_text(value):
        return "text"
    arr = np.asarray(value)
    if arr.dtype.kind not in "biufc":
        return "a cell/object array" if arr.dtype.kind == "O" else f"a {arr.dtype} array"
    if arr.size == 0:
        return "an empty array (0 samples)"
    if arr.size == 1 and not is_time:
        return "a scalar"  # masses, settings
    return None


def _read_mat5(p: Path) -> dict[str, Any]:
    import scipy.io

    try:
        raw = scipy.io.loadmat(p, squeeze_me=True, struct_as_record=False, simplify_cells=True)
    except NotImplementedError as exc:
        raise RecordError(f"{p}: unsupported MAT version ({_why(exc)})") from exc
    except Exception as exc:
        raise RecordError(f"{p}: not a readable MAT file ({_why(exc)})") from exc
    return {k: v for k, v in raw.items() if not k.startswith("__")}


# MATLAB classes stored as plain HDF5 datasets of numbers (or characters) in v7.3 files.
_MAT_CLASSES = {"double", "single", "int8", "uint8", "int16", "uint16", "int32", "uint32",
                "int64", "uint64", "logical", "char"}


def _read_mat73(p: Path) -> dict[str, Any]:
    import h5py

    def convert(obj):
        if isinstance(obj, h5py.Group):
            return {k: convert(obj[k]) for k in obj if not k.startswith("#")}
        cls = obj.attrs.get("MATLAB_class", b"")
        cls = cls.decode() if isinstance(cls, bytes) else str(cls)
        if obj.attrs.get("MATLAB_empty", 0):
            # MATLAB stores an empty array as its dimensions (e.g. [0 0]): not data
            return "" if cls == "char" else np.empty((0,))
        if cls and cls not in _MAT_CLASSES:  # MATLAB string, cell, function_handle, objects
            return np.array(f"<MATLAB {cls}>", dtype=object)
        arr = np.asarray(obj[()])
        if cls == "char":
            return "".join(chr(c) for c in arr.ravel(order="F"))
        if arr.dtype.names and {"real", "imag"} <= set(arr.dtype.names):
            arr = arr["real"] + 1j * arr["imag"]  # MATLAB complex: compound (real, imag)
        elif arr.dtype.names or arr.dtype.kind == "V":
            return np.array(None, dtype=object)  # other compound/opaque types: not numbers
        if cls == "logical":
            arr = arr.astype(bool)
        # MATLAB stores column-major: h5py sees the transpose.
        return arr.T

    try:
        with h5py.File(p, "r") as fh:
            return {k: convert(fh[k]) for k in fh if not k.startswith("#")}
    except Exception as exc:
        raise RecordError(f"{p}: not a readable MAT v7.3 file ({_why(exc)})") from exc


def write_record(record: Record, path: str | Path) -> Path:
    """Write a record atomically (temporary file in the same directory + ``os.replace``).

    ``.nc`` (NetCDF4 via xarray/h5netcdf, the native format), ``.csv`` (``name [unit]`` header,
    1-D variables only) or ``.mat`` (MATLAB v5: one array per variable, ``fs``, ``units`` struct).

    Parameters
    ----------
    record : Record
    path : str or Path

    Returns
    -------
    Path
    """
    p = Path(path)
    suffix = p.suffix.lower()
    if suffix not in (".nc", ".csv", ".mat"):
        raise RecordError(f"{p}: unknown record format {suffix!r} (use .nc, .csv or .mat)")

    def write(tmp: str) -> None:
        if suffix == ".nc":
            record.to_dataset().to_netcdf(tmp, engine="h5netcdf")
        elif suffix == ".csv":
            _write_csv(record, tmp)
        else:
            _write_mat(record, tmp)

    return atomic_write(p, write, suffix=suffix)


def _write_csv(record: Record, tmp: str) -> None:
    two_d = [n for n, a in record.variables.items() if a.ndim != 1]
    if two_d:
        raise RecordError(f"CSV holds 1-D variables only; {two_d} are 2-D (use .nc)")
    names = ["time", *record.names]
    header = ",".join(f"{n} [{record.units[n]}]" for n in names)
    data = np.column_stack([record.time, *record.variables.values()])
    with open(tmp, "w", encoding="utf-8", newline="") as fh:
        np.savetxt(fh, data, delimiter=",", header=header, comments="", fmt="%.17g")


def _write_mat(record: Record, tmp: str) -> None:
    import scipy.io

    out: dict[str, Any] = {"time": record.time, "fs": float(record.fs)}
    out.update(record.variables)
    out["units"] = dict(record.units)
    with open(tmp, "wb") as fh:
        scipy.io.savemat(fh, out, do_compression=True, oned_as="column")


# -- preprocessing ------------------------------------------------------------------------------
def velocity_from_acceleration(
    acceleration: Any, fs: float, f_highpass: float = 1.0, order: int = 4, axis: int = -1
) -> np.ndarray:
    """Velocity by integrating acceleration in the frequency domain, with drift removal.

    ``V(f) = H(f) A(f) / (i 2 pi f)`` where ``H`` is the magnitude of a Butterworth high-pass of
    ``order`` at ``f_highpass`` applied with zero phase (``|H|^2 = r / (1 + r)``,
    ``r = (f/f_hp)^(2 order)``), after removing the mean of the acceleration. Why this choice: the
    spectral integral is exact for band-limited signals (the trapezoid rule loses 0.8 % of
    amplitude at 25 Hz for fs = 500 Hz), zero phase keeps the velocity in phase with the force,
    and the high-pass removes the drift that accelerometer offset and low-frequency noise cause
    (1/f blows them up). The record is zero-padded (acceleration assumed zero outside it), which
    is exact for tests that start and end at rest; otherwise expect edge transients lasting about
    ``1/f_highpass`` s. Amplitude error in the band: ``(f_hp/f)^(2 order) / 2`` (2.6e-6 at 5 Hz
    for the defaults).

    Parameters
    ----------
    acceleration : array_like
        m/s^2, sampled at ``fs``.
    fs : float
        Sample rate, Hz.
    f_highpass : float
        High-pass corner, Hz; keep it well below the lowest excitation frequency (0 disables the
        filter; the mean is still removed).
    order : int
        Butterworth order of the high-pass.
    axis : int
        Time axis.

    Returns
    -------
    ndarray
        Velocity, m/s, same shape.
    """
    from scipy import fft

    a = np.asarray(acceleration, dtype=float)
    fs = _check_fs(fs)
    if not (np.isfinite(f_highpass) and 0 <= f_highpass < fs / 2):
        raise RecordError(f"f_highpass must be in [0, fs/2) Hz, got {f_highpass!r}")
    a = np.moveaxis(a, axis, -1)
    n = a.shape[-1]
    a = a - a.mean(axis=-1, keepdims=True)
    pad = int(math.ceil(3.0 * fs / f_highpass)) if f_highpass > 0 else n
    nfft = fft.next_fast_len(n + max(pad, n // 4), real=True)
    spec = fft.rfft(a, nfft, axis=-1)
    f = fft.rfftfreq(nfft, 1.0 / fs)
    with np.errstate(divide="ignore", invalid="ignore"):
        gain = 1.0 / (2j * np.pi * f)
        if f_highpass > 0:
            r = (f / f_highpass) ** (2 * order)
            gain = gain * np.sqrt(r / (1.0 + r))
    gain[0] = 0.0
    v = fft.irfft(spec * gain, nfft, axis=-1)[..., :n]
    return np.moveaxis(v, -1, axis)


def dynamic_force(
    force: Any, acceleration: Any, liquid_mass: float, structure_mass: float
) -> np.ndarray:
    """Dynamic sloshing force ``df = force + (m_l + m_s) acc`` (N).

    The load cells measure ``force = -(m_l + m_s) acc + df``: the inertia of the frozen liquid and
    of the structure above the load cells plus the dynamic sloshing force (paper Eq. 2, w up).

    Parameters
    ----------
    force : array_like
        Measured interface force, N (static weight removed).
    acceleration : array_like
        Tank vertical acceleration, m/s^2.
    liquid_mass, structure_mass : float
        kg.

    Returns
    -------
    ndarray
        N.
    """
    m = float(liquid_mass) + float(structure_mass)
    if not (np.isfinite(m) and liquid_mass >= 0 and structure_mass >= 0):
        raise RecordError(
            f"masses must be finite and >= 0 kg, got {liquid_mass!r}, {structure_mass!r}"
        )
    return np.asarray(force, dtype=float) + m * np.asarray(acceleration, dtype=float)


def resample(record: Record, fs_new: float, max_denominator: int = 1000) -> Record:
    """Resample every variable to ``fs_new`` by polyphase filtering (anti-aliased).

    Uses ``scipy.signal.resample_poly`` (Kaiser-windowed FIR, linear-trend padding at the ends)
    with ``fs_new / fs`` as a ratio of integers.

    Parameters
    ----------
    record : Record
    fs_new : float
        Hz; ``fs_new / fs`` must be a fraction with denominator <= ``max_denominator``.

    Returns
    -------
    Record
    """
    from scipy import signal

    try:
        fs_new = _check_fs(fs_new)
    except RecordError as exc:
        raise RecordError(f"resample: new {exc}") from None
    ratio = Fraction(fs_new / record.fs).limit_denominator(max_denominator)
    if ratio == 0 or abs(float(ratio) * record.fs - fs_new) > 1e-9 * fs_new:
        raise RecordError(f"fs_new / fs = {fs_new}/{record.fs} is not a simple fraction")
    up, down = ratio.numerator, ratio.denominator
    variables = {}
    for name, arr in record.variables.items():
        if up == down:
            variables[name] = arr.copy()
        else:
            variables[name] = signal.resample_poly(arr, up, down, axis=0, padtype="line")
    n_new = next(iter(variables.values())).shape[0] if variables else len(record) * up // down
    time = record.time[0] + np.arange(n_new) / float(fs_new)
    attrs = {**record.attrs, "resampled_from_fs": float(record.fs)}
    return Record(time, float(fs_new), variables, dict(record.units), attrs, dict(record.dims))


def preprocess(
    raw: Record, tank: Tank | None = None, f_highpass: float = 1.0, fs: float | None = None
) -> Record:
    """Add ``velocity`` and ``dynamic_force`` to a raw shaker record (paper section 2.1).

    Parameters
    ----------
    raw : Record
        Needs ``acceleration`` (tank, vertical) and ``force`` (load cells); converted to SI first.
    tank : Tank, optional
        Liquid and structure masses; default the record's ``attrs["tank"]``, else the paper tank.
    f_highpass : float
        Drift-removal corner of the velocity integration, Hz (see
        :func:`velocity_from_acceleration`).
    fs : float, optional
        Resample to this rate first (polyphase, anti-aliased).

    Returns
    -------
    Record
        The raw variables plus ``velocity`` (m/s) and ``dynamic_force`` (N); attrs record the tank
        and the preprocessing.
    """
    if fs is not None:
        fs = _check_fs(fs)
    rec = raw.to_si()
    require(rec, ["acceleration", "force"])
    for name, si in (("acceleration", "m/s^2"), ("force", "N")):
        require_unit(rec, name, si)  # unknown units (volts) are refused, never taken for SI
    if tank is None:
        try:
            tank = rec.tank or Tank()
        except ValueError as exc:  # ConfigError: tank_* attributes of a file out of range
            src = rec.attrs.get("source", "record")
            raise RecordError(f"{src}: attribute 'tank': {exc}") from None
    if fs is not None and fs != rec.fs:
        rec = resample(rec, fs)
    acc = rec["acceleration"]
    vel = velocity_from_acceleration(acc, rec.fs, f_highpass=f_highpass, axis=0)
    dfo = dynamic_force(rec["force"], acc, tank.liquid_mass, tank.structure_mass)
    return rec.with_variables(
        {"velocity": vel, "dynamic_force": dfo},
        {"velocity": "m/s", "dynamic_force": "N"},
        tank=tank.to_dict(),
        fill=tank.fill,
        preprocessing={
            "velocity": f"spectral integration of acceleration, zero-phase Butterworth "
            f"high-pass order 4 at {f_highpass} Hz",
            "dynamic_force": "force + (liquid_mass + structure_mass) * acceleration",
            "liquid_mass": tank.liquid_mass,
            "structure_mass": tank.structure_mass,
        },
    )


def record_from_measurement(
    measurement: Mapping[str, Any],
    tank: Tank | None = None,
    truth: bool = True,
    f_highpass: float = 1.0,
    **attrs: Any,
) -> Record:
    """Preprocessed record from a virtual-rig measurement (``sloshrom.rig.VirtualRig.measure``).

    Parameters
    ----------
    measurement : dict
        Keys ``fs`` (Hz), ``time`` (s), ``acceleration`` (m/s^2), ``force`` (N), and optionally
        the noise-free ``true_velocity`` (m/s) and ``true_dynamic_force`` (N).
    tank : Tank, optional
        Default: the paper tank.
    truth : bool
        Keep ``true_velocity``/``true_dynamic_force`` in the record (to check preprocessing).
    f_highpass : float
        Drift-removal corner of the velocity integration, Hz.
    **attrs
        Extra attributes (seed, provenance, ...).

    Returns
    -------
    Record
        ``acceleration``, ``force``, ``velocity``, ``dynamic_force`` (+ truth), SI units.
    """
    tank = Tank() if tank is None else tank
    missing = [k for k in ("fs", "time", "acceleration", "force") if k not in measurement]
    if missing:
        raise RecordError(f"rig measurement lacks {missing}")
    variables = {"acceleration": measurement["acceleration"], "force": measurement["force"]}
    units = {"acceleration": "m/s^2", "force": "N"}
    if truth:
        for k, u in (("true_velocity", "m/s"), ("true_dynamic_force", "N")):
            if k in measurement:
                variables[k] = measurement[k]
                units[k] = u
    raw = Record(
        np.asarray(measurement["time"], dtype=float),
        float(measurement["fs"]),
        variables,
        units,
        {"tank": tank.to_dict(), "fill": tank.fill, **attrs},
    )
    return preprocess(raw, tank, f_highpass=f_highpass)
