"""MATLAB records (``.mat``): v5 (scipy) and v7.3 (HDF5, h5py).

One array per variable, an optional ``fs`` and a ``units`` struct (or ``<name>_units`` strings),
optionally all inside one struct. Entries that are not time histories (scalars, text, cells,
structs) are ignored and listed in ``attrs["ignored_variables"]``. Written as v5 (scipy). scipy.io
and h5py are imported on first use (about 0.9 s and 0.4 s).
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from sloshrom.io.record import (
    _TIME_NAMES,
    Record,
    RecordError,
    _build,
    _check_fs,
    _show,
    _unit_text,
    _why,
)
from sloshrom.io.units import same_unit

__all__ = ["read_mat", "write_mat"]

def _is_text(value: Any) -> bool:
    return isinstance(value, str | bytes) or (
        isinstance(value, np.ndarray) and value.dtype.kind in "US"
    )


def read_mat(p: Path, fs: float | None, units: Mapping[str, str]) -> Record:
    """Read a MATLAB ``.mat`` record file (v5 or v7.3; ``fs`` in Hz, ``units`` by name)."""
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


def write_mat(record: Record, tmp: str) -> None:
    """Write ``record`` as a MATLAB v5 ``.mat`` file to the temporary path ``tmp``."""
    import scipy.io

    out: dict[str, Any] = {"time": record.time, "fs": float(record.fs)}
    out.update(record.variables)
    out["units"] = dict(record.units)
    with open(tmp, "wb") as fh:
        scipy.io.savemat(fh, out, do_compression=True, oned_as="column")
