"""Time-history records: the in-memory :class:`Record` and its checks.

A :class:`Record` is a set of variables sampled on one uniform time axis, each with a unit, plus
free-form attributes (tank, fill, provenance). Every command of ``sloshrom`` reads and writes
records, so that they read each other's output and the user's own shaker data (file formats:
:mod:`sloshrom.io.read`).

Every bad input ends in one :class:`RecordError` whose single-line message names the file, the
variable and the problem; nothing is dropped or guessed silently (complex values, huge values,
unknown or contradicting units, a bad ``fs`` are all errors). The checks shared by the file
formats (units read from a file, ``fs``, building a record from columns) live here too.

Array convention: a Record stores each variable with **time on axis 0**, ``(n,)`` or
``(n, k)`` (``k`` stations or modes, second axis named in :attr:`Record.dims`), as its files do.
The numerical core (models, ``simulate``, signals, energy) puts time on the **last** axis with
batch axes leading; for the 1-D variables of a shaker record the two coincide, 2-D variables
(beam stations, modes) must be transposed (``record[name].T``) when passed to the core.
"""

from __future__ import annotations

import json
import math
import re
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from sloshrom.config import FILL_TOLERANCE, ConfigError, Tank
from sloshrom.errors import SloshromError
from sloshrom.fileio import not_a_regular_file
from sloshrom.io.units import (
    STANDARD_UNITS,
    _time_unit,
    canonical_unit,
    is_known_unit,
    same_unit,
)

__all__ = [
    "MAX_ABS_VALUE",
    "AbsentUnitNamesError",
    "MissingUnitError",
    "NoTimeAxisError",
    "Record",
    "RecordError",
    "UnitConflictError",
    "require",
    "require_file",
    "require_unit",
]

class RecordError(SloshromError):
    """A record or a record file is invalid (the message names the file, variable and problem).

    The message is always one line: line breaks of embedded text (exception messages, file
    contents) are replaced by spaces.
    """

    def __init__(self, message: object = "", *args: object) -> None:
        super().__init__(re.sub(r"\s*[\r\n]+\s*", " ", str(message)).strip(), *args)


class MissingUnitError(RecordError):
    """Channels have no unit in their file and the caller gave none.

    Attributes ``path`` (the file), ``channel`` (the first channel's label), ``channels``
    (every such channel of the file, so that one message can ask for all of them), ``detail``
    (where the file would say it, e.g. ``"UFF 58 dataset 1, ordinate unit label empty"``) and
    ``si`` (the SI unit of a standard variable name, else ``None``) let a caller say how to
    give them.
    """

    def __init__(self, path: object, channel: str, detail: str, si: str | None = None,
                 kind: str = "channel", channels: Sequence[str] | None = None) -> None:
        self.path, self.channel, self.detail, self.si = str(path), channel, detail, si
        self.channels = list(channels) if channels else [channel]
        hint = f" (SI: {si!r})" if si else ""
        if len(self.channels) == 1:
            super().__init__(f"{path}: {kind} {channel!r} has no unit in the file ({detail}); "
                             f"give it with units={{{channel!r}: ...}}{hint}")
        else:
            names = ", ".join(repr(c) for c in self.channels)
            super().__init__(f"{path}: {kind}s {names} have no unit in the file ({detail}); "
                             "give them with units={...}")


class NoTimeAxisError(RecordError):
    """A CSV or MATLAB file without a time column or variable, read without ``fs=``.

    Attribute ``source`` (the file) lets a caller say how to give the time axis in its own
    words (a command has no ``fs=``).
    """

    def __init__(self, source: str, ignored: str = "") -> None:
        self.source = source
        super().__init__(f"{source}: no 'time' column/variable; pass fs= (Hz) to read it"
                         f"{ignored}")


class UnitConflictError(RecordError):
    """A unit the caller gave contradicts the file's own (attributes ``path``, ``channel``,
    ``given``, ``in_file``)."""

    def __init__(self, path: object, channel: str, given: str, in_file: str,
                 kind: str = "variable") -> None:
        self.path, self.channel, self.given, self.in_file = str(path), channel, given, in_file
        super().__init__(f"{path}: {kind} {channel!r}: units= gives {given!r} but the file "
                         f"says {in_file!r}")


class AbsentUnitNamesError(RecordError):
    """``units=`` names variables the file does not have (attributes ``absent`` and
    ``present``, the file's names)."""

    def __init__(self, source: str, absent: list[str], present: list[str]) -> None:
        self.absent, self.present = list(absent), list(present)
        super().__init__(f"{source}: units= names {_names(self.absent)}, which the file does not "
                         f"have (it has {_names(self.present)})")


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


def _check_tank_attrs(attrs: dict[str, Any]) -> None:
    """Validate the ``tank`` and ``fill`` attributes in place, when the record is made.

    A file's ``tank_*`` attributes become ``attrs["tank"]``: text for a number (a fill of
    "half") or an unphysical value (a negative density) is refused here, naming the attribute,
    not when the tank is used or the record written. Valid values become floats.
    """
    tank = attrs.get("tank")
    checked = None
    if isinstance(tank, Tank):
        checked = tank
        attrs["tank"] = tank.to_dict()
    elif isinstance(tank, Mapping):
        try:
            checked = Tank.from_dict(dict(tank))
        except (ConfigError, TypeError) as exc:
            raise RecordError(f"attribute 'tank': {exc} (the tank_* attributes)") from None
        attrs["tank"] = {k: float(getattr(checked, k)) for k in tank}
    fill = attrs.get("fill")
    if fill is None:
        return
    if isinstance(fill, np.ndarray) and fill.size == 1:
        fill = fill.item()
    if isinstance(fill, bool) or not isinstance(fill, int | float | np.integer | np.floating) \
            or not 0.0 < float(fill) < 1.0:
        raise RecordError(f"attribute 'fill' must be a fill level d/h in (0, 1), got "
                          f"{_show(fill)}")
    attrs["fill"] = float(fill)
    if checked is not None and abs(float(fill) - checked.fill) > FILL_TOLERANCE:
        raise RecordError(f"attribute 'fill' = {float(fill):g} but the tank attributes say fill "
                          f"{checked.fill:g}: one record has one fill level")


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
        Each of shape ``(n,)`` or ``(n, k)`` with ``n = len(time)``: **time on axis 0**, as in
        the files (the numerical core puts time on the last axis: transpose 2-D variables before
        passing them to it). Real, finite values of magnitude below :data:`MAX_ABS_VALUE`
        (1e100).
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
                si = STANDARD_UNITS.get(name)
                raise RecordError(f"variable {name!r} has no unit (give units={{{name!r}: ...}}"
                                  + (f"; SI: {si!r})" if si else ")"))
            variables[name] = arr
            si, k = canonical_unit(unit)
            units[name] = si if k == 1.0 else unit.strip()
        self.variables = variables
        self.units = units
        self.attrs = dict(self.attrs)
        _check_tank_attrs(self.attrs)
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

    def is_time_axis(self, name: str) -> bool:
        """Whether ``name`` names the record's time axis rather than a signal: ``"time"``, or a
        name the readers take the time axis from (``t``, ``Time``, ``TIME``) that is not one of
        the variables (a file with both a ``time`` and a ``t`` column keeps ``t`` as a signal).
        """
        return name == "time" or (name in _TIME_NAMES and name not in self.variables)

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
                raise MissingUnitError(source, name, "no 'units' attribute",
                                       STANDARD_UNITS.get(name), kind="variable")
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
    scaling, so that e.g. days since 1970 keep sub-millisecond resolution; integer counts, such
    as int64 nanoseconds since 1970, are subtracted as integers: exact).
    """
    conv = _time_unit(unit)
    if conv is None:
        raise RecordError(
            f"{source}: time unit {unit!r} is not a time unit (use s, ms, us, ns, min, h, d or "
            "CF '<unit> since <date>' with one of them)"
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
    raw = np.asarray(time)
    if raw.dtype.kind in "iu" and -2**62 <= int(raw.min()) <= int(raw.max()) < 2**62:
        # float64 holds 1.7e18 ns only to 256 ns: subtract the integers (no int64 overflow here)
        offset = (raw.astype(np.int64) - np.int64(raw[0])).astype(float)
        return offset * k, {"time_reference": ref, "time_start": float(raw[0]) * k}
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
        raise AbsentUnitNamesError(source, unknown, names)
    out = dict(file_units)
    for name, unit in given.items():
        have = file_units.get(name)
        if have is not None and not same_unit(have, unit):
            raise UnitConflictError(source, name, unit, have)
        out.setdefault(name, unit)
    return out


def require_file(path: str | Path) -> Path:
    """``path`` as a file a reader can open, or a :class:`RecordError` that says why not: not
    a regular file (a directory, a named pipe, ...), no such file, or an empty file.

    Parameters
    ----------
    path : str or Path

    Returns
    -------
    Path
    """
    p = Path(path)
    why = not_a_regular_file(p)
    if why is not None:
        raise RecordError(f"{p}: {why}")
    if not p.is_file():
        raise RecordError(f"{p}: no such file")
    if p.stat().st_size == 0:
        raise RecordError(f"{p}: file is empty")
    return p


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


#: the ``tank_<field>`` attributes that make a record's tank (others, e.g. the ``tank_id`` of a
#: beam result, stay attributes of their own)
_TANK_FIELDS = frozenset(Tank.__dataclass_fields__)


def _unflatten_attrs(raw: Mapping[str, Any], source: str = "dataset") -> dict[str, Any]:
    out: dict[str, Any] = {}
    tank: dict[str, float] = {}
    for key, value in raw.items():
        if isinstance(value, np.ndarray) and value.size == 1:
            value = value.item()
        if isinstance(value, np.generic):
            value = value.item()
        if key.startswith("tank_") and key[5:] in _TANK_FIELDS:
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
        raise NoTimeAxisError(source, _ignored_note(ignored))
    if time.size < 2:
        raise RecordError(f"{source}: a record needs at least 2 samples, got {time.size}")
    if not cols:
        raise RecordError(f"{source}: no data variables besides time{_ignored_note(ignored)}")
    var_units = {k: all_units[k] for k in cols if k in all_units}
    unitless = [k for k in cols if not str(var_units.get(k) or "").strip()]
    if unitless:
        where = ("no [unit] in the CSV header" if source.lower().endswith((".csv", ".txt"))
                 else "no entry in the units struct")
        raise MissingUnitError(source, unitless[0], where, STANDARD_UNITS.get(unitless[0]),
                               kind="variable", channels=unitless)
    try:
        return Record(time, fs, cols, var_units, attrs)
    except RecordError as exc:
        raise RecordError(f"{source}: {exc}") from None


def _ignored_note(ignored: Mapping[str, str]) -> str:
    if not ignored:
        return ""
    return " (ignored: " + ", ".join(f"{k!r} ({v})" for k, v in list(ignored.items())[:6]) + ")"

