"""Reading and writing records: dispatch on the file suffix to the format modules.

``read_record`` reads NetCDF (:mod:`~sloshrom.io.netcdf`), CSV (:mod:`~sloshrom.io.csv`), MATLAB
(:mod:`~sloshrom.io.matlab`) and UFF58 (:mod:`~sloshrom.io.uff`) files; ``write_record`` writes
NetCDF, CSV or MATLAB v5 atomically. The format modules import their heavy libraries (xarray,
scipy.io, h5py, pyuff: 0.4 to 1.4 s each) on first use, so importing this one stays cheap.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path

from sloshrom.fileio import atomic_write
from sloshrom.io import csv, matlab, netcdf, uff
from sloshrom.io.record import (
    AbsentUnitNamesError,
    Record,
    RecordError,
    _check_fs,
    _show,
    _unit_text,
    _why,
    require_file,
)

__all__ = ["read_record", "write_record"]

def read_record(
    path: str | Path,
    fs: float | None = None,
    units: Mapping[str, str] | None = None,
    si: bool = True,
    *,
    shared_units: bool = False,
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
    shared_units : bool
        ``units`` are shared by the files of a test campaign (a channel map's): names this file
        lacks are ignored, and for UFF a unit only fills an empty ordinate label (one that
        contradicts the label is an error, as for the other formats; UFF keys may also be
        ``node:dir``).

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
    require_file(p)
    suffix = p.suffix.lower()
    if suffix not in (".nc", ".nc4", ".netcdf", ".h5", ".csv", ".txt", ".mat", ".uff", ".unv"):
        raise RecordError(
            f"{p}: unknown record format {suffix!r} (use .nc, .csv, .mat, .uff or .unv)"
        )
    try:
        try:
            rec = _read(p, suffix, fs, given, shared_units)
        except AbsentUnitNamesError as exc:
            if not shared_units:
                raise
            # a campaign's units name channels other files have: read again with this file's
            rec = _read(p, suffix, fs, {k: v for k, v in given.items() if k in exc.present},
                        shared_units)
    except OSError as exc:  # permissions, a file that vanished or changed while read
        raise RecordError(f"{p}: cannot read the file ({_why(exc)})") from exc
    rec.attrs.setdefault("source", str(p))
    return rec.to_si() if si else rec


def _read(p: Path, suffix: str, fs: float | None, given: dict[str, str],
          shared_units: bool) -> Record:
    """The record of one file by its format (``given``: checked units)."""
    if suffix in (".csv", ".txt"):
        return csv.read_csv(p, fs, given)
    if suffix == ".mat":
        return matlab.read_mat(p, fs, given)
    if suffix in (".uff", ".unv"):
        rec = uff.read_uff58(p, units=given, shared_units=shared_units)
        if fs is not None and abs(rec.fs - fs) > 1e-3 * fs:
            raise RecordError(
                f"{p}: fs={fs:g} Hz given but the file's time axis says {rec.fs:g} Hz"
            )
        return rec
    return netcdf.read_netcdf(p, fs, given)


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
            netcdf.write_netcdf(record, tmp)
        elif suffix == ".csv":
            csv.write_csv(record, tmp)
        else:
            matlab.write_mat(record, tmp)

    return atomic_write(p, write, suffix=suffix)
