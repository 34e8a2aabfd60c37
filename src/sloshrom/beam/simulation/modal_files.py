"""Modal models (structures) in and out of files: UFF 55, Nastran punch, NetCDF and CSV.

:func:`read_modes` reads the normal modes of a structure into a
:class:`~sloshrom.beam.simulation.modes. ModeSet`, choosing the format from the suffix:

- ``.unv`` / ``.uff``: UFF dataset 55 (normal modes, analysis type 2) with nodes from dataset
  2411 or 15 and units from dataset 164 (read with pyuff);
- ``.pch`` / ``.punch``: Nastran SOL 103 eigenvectors, ``DISPLACEMENT(PUNCH)`` or
  ``VECTOR(PUNCH)`` (80-column text; generalised masses 1, Nastran's default ``NORM=MASS``,
  unless a mode table gives them);
- ``.nc``: the sloshrom NetCDF modal format (``format = "sloshrom-modes"``);
- ``.csv``: the sloshrom CSV modal format (one row per mode and node, units in the header).

:func:`read_mode_table` reads per-mode damping, modal masses and participation (CSV or TOML) to
complete files that lack them. The writers (:func:`write_modes_uff`, :func:`write_modes_punch`,
:func:`write_modes_netcdf`, :func:`write_modes_csv`, :func:`write_mode_table`) write atomically.
docs/formats.md ("Modal models (structures)") describes every format and its unit rules. No
reader executes code from a file; every problem is a :class:`ModalDataError` naming the file.
"""

from __future__ import annotations

import csv
import io
import math
import re
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from sloshrom.beam.simulation.modes import ModeSet, mode_table_arrays
from sloshrom.beam.simulation.structure import ModalDataError
from sloshrom.config import load_toml_table
from sloshrom.fileio import (
    atomic_write,
    atomic_write_text,
    netcdf_writer,
    not_a_regular_file,
)
from sloshrom.io.uff import open_uff
from sloshrom.io.units import canonical_unit, is_known_unit

__all__ = [
    "MASS_UNITS", "read_mode_table", "read_modes", "write_mode_table", "write_modes_csv",
    "write_modes_netcdf", "write_modes_punch", "write_modes_uff",
]

_LBF, _IN = 4.4482216152605, 0.0254
#: mass units (case-sensitive: "Mg" is a tonne, "mg" is not accepted) -> kg
MASS_UNITS: dict[str, float] = {
    "kg": 1.0, "g": 1e-3, "t": 1e3, "Mg": 1e3, "tonne": 1e3,
    "lbf*s^2/in": _LBF / _IN, "lbf s^2/in": _LBF / _IN, "slinch": _LBF / _IN,
    "lb": 0.45359237, "lbm": 0.45359237,
}
#: frequency units -> Hz
_FREQ_UNITS = {"hz": 1.0, "rad/s": 1.0 / (2.0 * math.pi), "rad s-1": 1.0 / (2.0 * math.pi)}
_FORMATS = {".unv": "uff", ".uff": "uff", ".pch": "punch", ".punch": "punch", ".nc": "netcdf",
            ".csv": "csv"}
NETCDF_FORMAT, NETCDF_VERSION = "sloshrom-modes", 1


def _reason(exc: BaseException, limit: int = 160) -> str:
    text = " ".join(str(exc).split()) or type(exc).__name__
    return text if len(text) <= limit else text[: limit - 3] + "..."


def _check_file(p: Path) -> None:
    why = not_a_regular_file(p)
    if why is not None:
        raise ModalDataError(f"{p}: {why}")
    if not p.is_file():
        raise ModalDataError(f"{p}: no such file")
    if p.stat().st_size == 0:
        raise ModalDataError(f"{p}: file is empty")


def _unit_factor(where: str, name: str, unit: Any, kind: str) -> float:
    """Factor to SI (Hz for frequencies) of ``unit`` of quantity ``name`` of ``kind``.

    ``kind``: ``mass`` (kg), ``frequency`` (Hz), ``length`` (m), ``1`` (dimensionless).
    """
    expected = {"mass": "a mass (kg)", "frequency": "a frequency (Hz)",
                "length": "a length (m)", "1": "dimensionless ('1')"}[kind]
    u = str(unit).strip() if isinstance(unit, str) else None
    if u is None:
        raise ModalDataError(f"{where}: {name} has no unit; expected {expected}")
    if kind == "mass" and u in MASS_UNITS:
        return MASS_UNITS[u]
    if kind == "frequency" and u.lower() in _FREQ_UNITS:
        return _FREQ_UNITS[u.lower()]
    if kind == "1" and u == "":
        return 1.0
    si, factor = canonical_unit(u)
    if is_known_unit(u) and si == {"length": "m", "1": "1"}.get(kind):
        return factor
    raise ModalDataError(f"{where}: {name} has unit {u!r}; expected {expected}")


def _mass_unit(mass_unit: str | None) -> float:
    if mass_unit is None:
        return 1.0
    if mass_unit not in MASS_UNITS:
        raise ModalDataError(
            f"mass_unit {mass_unit!r}: use one of {', '.join(MASS_UNITS)} (case-sensitive)"
        )
    return MASS_UNITS[mass_unit]


# =============================================================================================
# dispatch
def read_modes(
    path: str | Path,
    format: str | None = None,  # noqa: A002 (the natural name; the builtin is not used here)
    *,
    mass_unit: str | None = None,
    mode_table: str | Path | Mapping[str, Any] | None = None,
) -> ModeSet:
    """Read the normal modes of a structure from a file.

    Parameters
    ----------
    path : str or Path
        The modal model: ``.unv``/``.uff`` (UFF 55), ``.pch``/``.punch`` (Nastran punch),
        ``.nc`` (NetCDF) or ``.csv`` (CSV modal format).
    format : {"uff", "punch", "netcdf", "csv"}, optional
        Overrides the suffix.
    mass_unit : str, optional
        Mass unit of the generalised masses of a punch or UFF file (:data:`MASS_UNITS`:
        ``"kg"`` (default), ``"t"``/``"Mg"`` for mm-t-s models, ``"g"``, ``"lbf*s^2/in"``).
        For UFF it overrides the unit dataset 164 implies. NetCDF and CSV carry their units.
    mode_table : path or mapping, optional
        Per-mode damping (-), modal masses (kg) and participation (kg), see
        :func:`read_mode_table`; its columns replace the file's values (in kg, never scaled by
        ``mass_unit``). A table is matched to the file's modes **by mode number** (its row for
        mode k goes to the mode the file numbers k), whatever order the file lists them in.

    Returns
    -------
    ModeSet
        SI units, modes in the order of their mode numbers (:attr:`ModeSet.mode_numbers`);
        ``source`` is ``"<format>:<file name>"``.

    Raises
    ------
    ModalDataError
        Missing, empty, truncated or malformed file; unknown format; a damping ratio outside
        [0, 1) or a modal mass that is not positive (never silently replaced); the problems
        each reader lists.
    """
    p = Path(path)
    fmt = format.lower() if format is not None else _FORMATS.get(p.suffix.lower())
    if fmt is None and p.suffix.lower() == ".op2":
        raise ModalDataError(
            f"{p}: Nastran OP2 is not read (pyNastran, its reader, requires numpy < 2, which "
            "JAX does not allow): ask Nastran for DISPLACEMENT(PUNCH) and read the .pch file"
        )
    if fmt not in ("uff", "punch", "netcdf", "csv"):
        raise ModalDataError(
            f"{p}: unknown modal-model format {format or p.suffix or '(no suffix)'!r} "
            f"(suffixes {', '.join(_FORMATS)}; or format='uff'/'punch'/'netcdf'/'csv')"
        )
    if mass_unit is not None and fmt in ("netcdf", "csv"):
        raise ModalDataError(
            f"{p}: mass_unit= is for punch and UFF files; {fmt} files carry their units"
        )
    factor = _mass_unit(mass_unit)
    table: Mapping[str, Any] | None
    table = read_mode_table(mode_table) if isinstance(mode_table, (str, Path)) else mode_table
    _check_file(p)
    reader = {"uff": _read_uff, "punch": _read_punch, "netcdf": _read_netcdf,
              "csv": _read_csv}[fmt]
    parts = reader(p, factor if mass_unit is not None else None)
    parts.setdefault("source", f"{'uff55' if fmt == 'uff' else fmt}:{p.name}")
    n = np.asarray(parts["frequencies"]).size
    numbers = parts.get("mode_numbers")
    label = (np.arange(1, n + 1) if numbers is None else np.asarray(numbers)).tolist()
    if table is not None:
        cols = mode_table_arrays(table, n, f"mode table for {p.name}", numbers)
        if "modal_mass" in cols:  # the file may hold none: the table's fill the gap
            parts["modal_masses"] = cols["modal_mass"]
    masses = parts.get("modal_masses")
    m = np.full(n, 0.0) if masses is None else np.asarray(masses, dtype=float)
    wrong = np.flatnonzero(~np.isfinite(m) | (m < 0))
    if wrong.size:  # a value the file gives is wrong, not missing: say so
        k = int(wrong[0])
        raise ModalDataError(
            f"{p}: the modal mass of mode {label[k]} is {float(m[k])!r} in the file; a modal "
            "mass (phi^T M phi) must be positive and finite (a sign or unit error?)"
        )
    if np.any(m == 0):
        bad = np.flatnonzero(m == 0)
        raise ModalDataError(
            f"{p}: no modal mass for mode(s) {', '.join(str(label[k]) for k in bad[:10])} in "
            "the file: give a mode table with a modal_mass column (kg)"
        )
    ms = ModeSet(**parts)
    return ms.with_table(table) if table is not None else ms


# =============================================================================================
# mode tables
def read_mode_table(path: str | Path) -> dict[str, np.ndarray]:
    """Read per-mode damping, modal masses and participation (CSV or TOML).

    CSV: a header ``mode,damping[,modal_mass_kg][,participation_kg]`` (columns in any order,
    ``#`` comment lines allowed); ``mode`` gives each row's mode number (integers >= 1, each
    once, any order: ``7,8,9`` for a file whose rigid-body modes 1-6 were removed). Columns:
    ``damping`` (ratio, -), ``modal_mass`` and ``participation`` / ``participation_x`` / ``_y``
    / ``_z`` with an optional mass-unit suffix (``modal_mass_kg``, ``modal_mass_t``; none means
    kg). ``participation`` is along +Z. TOML: a ``[modes]`` table of arrays ``damping``,
    ``modal_mass`` (kg), ``participation`` (kg), ..., entry k for mode k + 1, or for the mode
    numbers of an optional ``mode`` array. The table is applied to a modal file **by mode
    number** (:func:`~sloshrom.beam.simulation.modes.mode_table_arrays`), never by position.

    Returns
    -------
    dict
        Column name (without unit) -> float array in SI, sorted by mode number, and ``mode``
        (the mode numbers, int).
    """
    p = Path(path)
    _check_file(p)
    if p.suffix.lower() == ".toml":
        try:
            data = load_toml_table(p, "modes", ModalDataError)
        except ModalDataError:
            raise
        except Exception as exc:  # ConfigError of a malformed file: keep its message
            raise ModalDataError(_reason(exc)) from exc
        if not isinstance(data, dict) or not data:
            raise ModalDataError(f"{p}: [modes] must be a table of per-mode arrays")
        out: dict[str, np.ndarray] = {}
        for k, v in data.items():
            try:
                out[k] = np.atleast_1d(np.asarray(v, dtype=float))
            except (TypeError, ValueError) as exc:
                raise ModalDataError(f"{p}: [modes] {k} must be an array of numbers") from exc
        if "mode" in out:
            out["mode"] = _table_modes(p, out["mode"])
            for k, v in out.items():
                if v.shape != out["mode"].shape:
                    raise ModalDataError(f"{p}: [modes] {k} has {v.size} entries, mode "
                                         f"{out['mode'].size}: one per listed mode")
            order = np.argsort(out["mode"])
            out = {k: v[order] for k, v in out.items()}
        # names and values checked now; the modes a file needs when the table is applied
        n = out["mode"].size if "mode" in out else min(a.size for a in out.values())
        mode_table_arrays(out, n, str(p), out.get("mode", np.arange(1, n + 1)))
        return out
    header, rows = _csv_rows(p)
    cols = _csv_columns(p, header, _TABLE_KINDS)
    if "mode" not in cols:
        raise ModalDataError(f"{p}: no 'mode' column (header {','.join(header)})")
    if not rows:
        raise ModalDataError(f"{p}: a header but no rows")
    values = _csv_values(p, rows, len(header))
    modes = _table_modes(p, values[:, cols["mode"][0]])
    order = np.argsort(modes)
    out = {name: values[order, j] * f for name, (j, f) in cols.items() if name != "mode"}
    if not out:
        raise ModalDataError(f"{p}: only a mode column; give damping, modal_mass, ...")
    out["mode"] = modes[order]
    mode_table_arrays(out, modes.size, str(p), out["mode"])
    return out


def _table_modes(p: Path, modes: np.ndarray) -> np.ndarray:
    """A table's mode numbers: integers >= 1, each once."""
    ok = np.isfinite(modes) & (modes == np.round(modes)) & (modes >= 1)
    if not np.all(ok) or np.unique(modes).size != modes.size:
        shown = sorted(int(m) if np.isfinite(m) and m == int(m) else m for m in modes.tolist())
        raise ModalDataError(
            f"{p}: the mode column must give each row's mode number, an integer >= 1, each "
            f"once (tables are matched to the modes by number); got {shown[:20]}"
        )
    return modes.astype(np.int64)


def write_mode_table(ms: ModeSet, path: str | Path) -> Path:
    """Write a mode set's damping, modal masses and participation as a mode-table CSV."""
    header = ["mode", "modal_mass_kg"]
    cols = [ms.mode_numbers, ms.modal_masses]
    if ms.damping is not None:
        header.append("damping")
        cols.append(ms.damping)
    if ms.participation is not None:
        for c, name in enumerate(("participation_x_kg", "participation_y_kg",
                                  "participation_z_kg")):
            if np.all(np.isfinite(ms.participation[c])):
                header.append(name)
                cols.append(ms.participation[c])
    lines = [",".join(header)]
    for k in range(ms.n_modes):
        lines.append(",".join(_num(c[k]) if j else str(int(c[k])) for j, c in enumerate(cols)))
    return atomic_write_text(path, "\n".join(lines) + "\n")


def _num(v: float) -> str:
    """Shortest text that reads back as the same float."""
    return repr(float(v))


# =============================================================================================
# CSV helpers (shared by the mode table and the CSV modal format)
# column name -> quantity kind; names of kind other than "1"/"int" take a unit suffix
_TABLE_KINDS = {"mode": "int", "damping": "1", "modal_mass": "mass", "participation": "mass",
                "participation_x": "mass", "participation_y": "mass", "participation_z": "mass"}
_MODES_CSV_KINDS = {
    "mode": "int", "node": "int", "frequency": "frequency", "modal_mass": "mass",
    "damping": "1", "participation_x": "mass", "participation_y": "mass",
    "participation_z": "mass", "x": "length", "y": "length", "z": "length",
    "shape_x": "1", "shape_y": "1", "shape_z": "1",
}


def _csv_rows(p: Path) -> tuple[list[str], list[tuple[int, list[str]]]]:
    """Header and (line number, cells) of the non-blank, non-comment lines of a CSV file."""
    try:
        text = p.read_text(encoding="utf-8-sig")
    except (OSError, UnicodeDecodeError) as exc:
        raise ModalDataError(f"{p}: not a readable text file ({_reason(exc)})") from exc
    rows: list[tuple[int, list[str]]] = []
    for lineno, line in enumerate(text.splitlines(), 1):
        if not line.strip() or line.lstrip().startswith("#"):
            continue
        cells = next(csv.reader([line]))
        rows.append((lineno, [c.strip() for c in cells]))
    if not rows:
        raise ModalDataError(f"{p}: no header line (only comments or blank lines)")
    return rows[0][1], rows[1:]


def _csv_columns(p: Path, header: list[str], kinds: Mapping[str, str]
                 ) -> dict[str, tuple[int, float]]:
    """Column name -> (index, factor to SI) from a header of ``name[_unit]`` cells."""
    cols: dict[str, tuple[int, float]] = {}
    for j, cell in enumerate(header):
        if cell in kinds:
            name, unit = cell, None
        else:
            # longest name that the cell starts with, followed by "_<unit>"
            cand = [k for k in kinds if cell.startswith(k + "_") and kinds[k] not in ("1", "int")]
            if not cand:
                raise ModalDataError(
                    f"{p}: unknown column {cell!r} (columns: {', '.join(kinds)}; quantities "
                    "with units take a suffix such as _Hz, _kg, _m)"
                )
            name = max(cand, key=len)
            unit = cell[len(name) + 1:]
        if name in cols:
            raise ModalDataError(f"{p}: column {name!r} appears twice")
        kind = kinds[name]
        if kind in ("1", "int"):
            factor = 1.0
        elif unit is None:
            default = {"mass": "kg", "frequency": "Hz", "length": "m"}[kind]
            if kind != "mass":  # masses default to kg (mode tables); others need a unit
                raise ModalDataError(f"{p}: column {cell!r} needs a unit suffix, e.g. "
                                     f"{cell}_{default}")
            factor = 1.0
        else:
            factor = _unit_factor(str(p), f"column {cell!r}", unit, kind)
        cols[name] = (j, factor)
    return cols


def _csv_values(p: Path, rows: list[tuple[int, list[str]]], width: int) -> np.ndarray:
    out = np.empty((len(rows), width))
    for i, (lineno, cells) in enumerate(rows):
        if len(cells) != width:
            raise ModalDataError(
                f"{p}: line {lineno} has {len(cells)} cells, the header {width} (truncated or "
                "edited file?)"
            )
        for j, c in enumerate(cells):
            try:
                out[i, j] = float(c)
            except ValueError:
                raise ModalDataError(
                    f"{p}: line {lineno}, column {j + 1}: {c[:40]!r} is not a number"
                ) from None
    return out


# =============================================================================================
# CSV modal format
def _read_csv(p: Path, mass_factor: float | None) -> dict[str, Any]:
    header, rows = _csv_rows(p)
    cols = _csv_columns(p, header, _MODES_CSV_KINDS)
    required = ("mode", "node", "frequency", "modal_mass", "shape_x", "shape_y", "shape_z")
    missing = [c for c in required if c not in cols]
    if missing:
        raise ModalDataError(
            f"{p}: missing column(s) {', '.join(missing)} (a modes CSV has mode, node, "
            "frequency_Hz, modal_mass_kg, shape_x, shape_y, shape_z; optional damping, "
            "x_m, y_m, z_m, participation_x_kg, ...)"
        )
    xyz = [c for c in ("x", "y", "z") if c in cols]
    if xyz and len(xyz) != 3:
        raise ModalDataError(f"{p}: give all three coordinate columns x, y, z or none")
    if not rows:
        raise ModalDataError(f"{p}: a header but no rows")
    v = _csv_values(p, rows, len(header))
    lines = np.array([ln for ln, _ in rows])

    def col(name: str) -> np.ndarray:
        j, f = cols[name]
        return v[:, j] * f

    for name in ("mode", "node"):
        c = col(name)
        if np.any(c != np.round(c)):
            i = int(np.flatnonzero(c != np.round(c))[0])
            raise ModalDataError(f"{p}: line {lines[i]}: {name} {c[i]!r} is not an integer")
    mode, node = col("mode").astype(np.int64), col("node").astype(np.int64)
    # the file's mode numbers (>= 1, in any order); the modes sorted by number
    mode_ids = sorted(dict.fromkeys(mode.tolist()))
    if mode_ids[0] < 1:
        raise ModalDataError(f"{p}: mode numbers must be integers >= 1, got {mode_ids[0]}")
    first = mode == mode_ids[0]
    nodes = node[first]
    n, s = len(mode_ids), nodes.size
    per_mode: dict[str, list[float]] = {"frequency": [], "modal_mass": [], "damping": [],
                                        "participation_x": [], "participation_y": [],
                                        "participation_z": []}
    shapes = np.zeros((s, 3, n))
    for k, number in enumerate(mode_ids):
        sel = np.flatnonzero(mode == number)
        if not np.array_equal(node[sel], nodes):
            raise ModalDataError(
                f"{p}: mode {number} lists {sel.size} node rows, mode {mode_ids[0]} lists {s} "
                "(the nodes and their order must be the same for every mode; truncated file?)"
            )
        for name in per_mode:
            if name not in cols:
                continue
            vals = col(name)[sel]
            if not np.all((vals == vals[0]) | (np.isnan(vals) & np.isnan(vals[0]))):
                raise ModalDataError(
                    f"{p}: {name} of mode {number} differs between its rows (lines "
                    f"{lines[sel[0]]}..{lines[sel[-1]]})"
                )
            per_mode[name].append(float(vals[0]))
        for c, name in enumerate(("shape_x", "shape_y", "shape_z")):
            shapes[:, c, k] = col(name)[sel]
    parts: dict[str, Any] = {
        "frequencies": np.array(per_mode["frequency"]),
        "modal_masses": np.array(per_mode["modal_mass"]), "nodes": nodes, "shapes": shapes,
        "mode_numbers": np.array(mode_ids, dtype=np.int64),
    }
    if "damping" in cols:
        parts["damping"] = np.array(per_mode["damping"])
    pcols = [c for c in ("participation_x", "participation_y", "participation_z") if c in cols]
    if pcols:
        part = np.full((3, n), np.nan)
        for c in pcols:
            part["xyz".index(c[-1])] = per_mode[c]
        parts["participation"] = part
    if xyz:
        parts["coordinates"] = np.column_stack([col(c)[first] for c in ("x", "y", "z")])
    return parts


def write_modes_csv(ms: ModeSet, path: str | Path) -> Path:
    """Write a mode set in the CSV modal format (SI, one row per mode and node, full precision).

    Columns: ``mode, node, frequency_Hz, modal_mass_kg[, damping][, participation_x_kg,
    participation_y_kg, participation_z_kg][, x_m, y_m, z_m], shape_x, shape_y, shape_z``.
    """
    header = ["mode", "node", "frequency_Hz", "modal_mass_kg"]
    if ms.damping is not None:
        header.append("damping")
    if ms.participation is not None:
        header += ["participation_x_kg", "participation_y_kg", "participation_z_kg"]
    if ms.coordinates is not None:
        header += ["x_m", "y_m", "z_m"]
    header += ["shape_x", "shape_y", "shape_z"]
    buf = io.StringIO()
    buf.write(f"# sloshrom modal model ({ms.source or 'no source'})\n")
    buf.write(",".join(header) + "\n")
    for k in range(ms.n_modes):
        head = [_num(ms.frequencies[k]), _num(ms.modal_masses[k])]
        if ms.damping is not None:
            head.append(_num(ms.damping[k]))
        if ms.participation is not None:
            head += [_num(v) for v in ms.participation[:, k]]
        for i, node in enumerate(ms.nodes.tolist()):
            row = [str(int(ms.mode_numbers[k])), str(node), *head]
            if ms.coordinates is not None:
                row += [_num(v) for v in ms.coordinates[i]]
            row += [_num(v) for v in ms.shapes[i, :, k]]
            buf.write(",".join(row) + "\n")
    return atomic_write_text(path, buf.getvalue())


# =============================================================================================
# NetCDF modal format
def _read_netcdf(p: Path, mass_factor: float | None) -> dict[str, Any]:
    import xarray as xr

    with p.open("rb") as fh:
        magic = fh.read(4)
    engine = "scipy" if magic in (b"CDF\x01", b"CDF\x02") else "h5netcdf"
    kw: dict[str, Any] = {"mmap": False} if engine == "scipy" else {}
    try:
        with xr.open_dataset(p, engine=engine, decode_times=False, **kw) as ds:
            ds = ds.load()
    except Exception as exc:  # h5py/scipy raise many types for corrupt or truncated files
        raise ModalDataError(f"{p}: not a readable NetCDF file ({_reason(exc)})") from exc
    fmt = ds.attrs.get("format")
    if fmt != NETCDF_FORMAT:
        raise ModalDataError(
            f"{p}: not a sloshrom modal-model file (attribute format = {fmt!r}, expected "
            f"{NETCDF_FORMAT!r})"
        )
    try:
        version = int(ds.attrs.get("format_version", -1))
    except (TypeError, ValueError):
        version = -1
    if version != NETCDF_VERSION:
        raise ModalDataError(
            f"{p}: format_version {ds.attrs.get('format_version')!r}; this sloshrom reads "
            f"version {NETCDF_VERSION}"
        )
    where = str(p)
    for name in ("frequency", "modal_mass", "shape", "node"):
        if name not in ds.variables:
            raise ModalDataError(f"{p}: no variable {name!r}")
    dims = {"frequency": ("mode",), "modal_mass": ("mode",), "damping": ("mode",),
            "participation": ("direction", "mode"), "shape": ("node", "direction", "mode"),
            "coordinates": ("node", "xyz")}
    kinds = {"frequency": "frequency", "modal_mass": "mass", "damping": "1",
             "participation": "mass", "shape": "1", "coordinates": "length"}

    def get(name: str) -> np.ndarray | None:
        if name not in ds.variables:
            return None
        var = ds[name]
        if tuple(var.dims) != dims[name]:
            raise ModalDataError(
                f"{p}: {name} has dimensions {tuple(var.dims)}, expected {dims[name]}"
            )
        if "units" not in var.attrs:
            raise ModalDataError(f"{p}: {name} has no units attribute")
        factor = _unit_factor(where, name, var.attrs["units"], kinds[name])
        return np.asarray(var.values, dtype=float) * factor

    if "direction" in ds.variables or "participation" in ds or "shape" in ds:
        dirs = [str(d) for d in ds["direction"].values] if "direction" in ds.variables else []
        if dirs != ["x", "y", "z"]:
            raise ModalDataError(f"{p}: coordinate direction must be ['x', 'y', 'z'], got {dirs}")
    nodes = np.asarray(ds["node"].values)
    if not np.issubdtype(nodes.dtype, np.integer):
        raise ModalDataError(f"{p}: node IDs must be integers, got dtype {nodes.dtype}")
    parts: dict[str, Any] = {
        "frequencies": get("frequency"), "modal_masses": get("modal_mass"), "nodes": nodes,
        "shapes": get("shape"), "damping": get("damping"),
        "participation": get("participation"), "coordinates": get("coordinates"),
    }
    if "mode" in ds.variables:  # the mode numbers tables are matched by
        numbers = np.asarray(ds["mode"].values)
        if numbers.shape != np.shape(parts["frequencies"]) or \
                not np.issubdtype(numbers.dtype, np.integer) or np.any(numbers < 1) or \
                np.unique(numbers).size != numbers.size:
            raise ModalDataError(f"{p}: coordinate mode must hold distinct integer mode numbers "
                                 f">= 1, one per mode, got {numbers.tolist()[:10]}")
        order = np.argsort(numbers, kind="stable")
        parts["mode_numbers"] = numbers[order].astype(np.int64)
        for key, axis in (("frequencies", 0), ("modal_masses", 0), ("damping", 0),
                          ("participation", 1), ("shapes", 2)):
            if parts[key] is not None:
                parts[key] = np.take(parts[key], order, axis=axis)
    if ds.attrs.get("source"):
        parts["attrs"] = {"written_from": str(ds.attrs["source"])}
    return parts


def write_modes_netcdf(ms: ModeSet, path: str | Path) -> Path:
    """Write a mode set in the NetCDF modal format (NetCDF-4, SI, float64)."""
    import xarray as xr

    data: dict[str, Any] = {
        "frequency": (("mode",), ms.frequencies, {"units": "Hz"}),
        "modal_mass": (("mode",), ms.modal_masses, {"units": "kg"}),
        "shape": (("node", "direction", "mode"), ms.shapes, {"units": "1"}),
    }
    if ms.damping is not None:
        data["damping"] = (("mode",), ms.damping, {"units": "1"})
    if ms.participation is not None:
        data["participation"] = (("direction", "mode"), ms.participation, {"units": "kg"})
    if ms.coordinates is not None:
        data["coordinates"] = (("node", "xyz"), ms.coordinates, {"units": "m"})
    ds = xr.Dataset(
        data,
        coords={"node": ("node", ms.nodes.astype(np.int64)), "direction": ["x", "y", "z"],
                "mode": ("mode", ms.mode_numbers.astype(np.int64))},
        attrs={"format": NETCDF_FORMAT, "format_version": NETCDF_VERSION,
               "source": ms.source},
    )
    return atomic_write(path, netcdf_writer(ds), suffix=".nc")


# =============================================================================================
# UFF dataset 55 (+ 2411 / 15 nodes, 164 units)
_ANALYSIS = {0: "unknown", 1: "static", 2: "normal mode", 3: "complex eigenvalue first order",
             4: "transient", 5: "frequency response", 6: "buckling",
             7: "complex eigenvalue second order"}


def _read_uff(p: Path, mass_factor: float | None) -> dict[str, Any]:
    uff, types = open_uff(p, ModalDataError)
    sets: list[tuple[int, dict[str, Any]]] = []
    for i, typ in enumerate(types):
        if typ not in (55, 2411, 15, 164):
            continue  # other datasets (58 functions, elements, ...) are not needed
        try:
            sets.append((i, uff.read_sets(i)))
        except Exception as exc:
            raise ModalDataError(
                f"{p}: dataset {i + 1} of {len(types)} (type {typ}) is unreadable "
                f"({_reason(exc, 80)})"
            ) from exc
    d55 = [(i, s) for i, s in sets if s.get("type") == 55]
    if not d55:
        raise ModalDataError(
            f"{p}: holds no mode shapes (dataset 55); dataset types {sorted(set(types))}"
        )
    for i, s in d55:
        at = int(s.get("analysis_type", 0))
        if at != 2:
            raise ModalDataError(
                f"{p}: dataset {i + 1} (55) is analysis type {at} ({_ANALYSIS.get(at, '?')}), "
                "not normal modes (2); only real normal modes are read"
            )
        if int(s.get("data_type", 2)) != 2 or np.iscomplexobj(s.get("r1")):
            raise ModalDataError(f"{p}: dataset {i + 1} (55) holds complex data; normal modes "
                                 "are real")
        if int(s.get("data_ch", 0)) not in (2, 3):
            raise ModalDataError(
                f"{p}: dataset {i + 1} (55) has data characteristic {s.get('data_ch')}; mode "
                "shapes need 2 (3 DOF translation) or 3 (6 DOF, rotations ignored)"
            )
    # units: SI = file value / factor (UFF 164); mass = force / acceleration, time in s
    length_f, force_f, attrs = 1.0, 1.0, {}
    d164 = [s for _, s in sets if s.get("type") == 164]
    if d164:
        length_f, force_f = float(d164[0]["length"]), float(d164[0]["force"])
        if not (length_f > 0 and force_f > 0 and math.isfinite(length_f * force_f)):
            raise ModalDataError(f"{p}: dataset 164 unit factors length {length_f!r}, force "
                                 f"{force_f!r}; they must be finite and positive")
        attrs["uff_units"] = str(d164[0].get("units_description", "")).strip()
    else:
        attrs["uff_units"] = "no dataset 164: SI assumed"
    to_kg = mass_factor if mass_factor is not None else length_f / force_f
    d55.sort(key=lambda t: int(t[1].get("mode_n", 0)))
    numbers = [int(s.get("mode_n", 0)) for _, s in d55]
    if len(set(numbers)) != len(numbers):
        raise ModalDataError(f"{p}: mode numbers repeat in the dataset-55 sets: {numbers}")
    if min(numbers) < 1:
        raise ModalDataError(f"{p}: dataset-55 mode numbers must be >= 1, got {numbers[:10]} "
                             "(mode tables are matched to the modes by these numbers)")
    nodes = np.asarray(d55[0][1]["node_nums"]).astype(np.int64)
    n, s_ = len(d55), nodes.size
    shapes = np.zeros((s_, 3, n))
    freq, mass, vis, his = (np.zeros(n) for _ in range(4))
    for k, (i, s) in enumerate(d55):
        nn = np.asarray(s["node_nums"]).astype(np.int64)
        if not np.array_equal(np.sort(nn), np.sort(nodes)):
            raise ModalDataError(
                f"{p}: mode {numbers[k]} (dataset {i + 1}) lists {nn.size} nodes, mode "
                f"{numbers[0]} lists {s_}; every mode must list the same nodes"
            )
        order = np.argsort(nn)[np.argsort(np.argsort(nodes))]  # rows of nn in nodes' order
        for c, key in enumerate(("r1", "r2", "r3")):
            shapes[:, c, k] = np.asarray(s[key], dtype=float)[order]
        freq[k] = float(s.get("freq", np.nan))
        mass[k] = float(s.get("modal_m", 0.0) or 0.0) * to_kg
        vis[k] = float(s.get("modal_damp_vis", 0.0) or 0.0)
        his[k] = float(s.get("modal_damp_his", 0.0) or 0.0)
        # damping is what the tool predicts: a wrong value in the file is an error, never 0
        # (a loss factor eta gives the ratio eta / 2, so it may reach 2)
        for name, v, top in (("viscous damping ratio", vis[k], 1),
                             ("hysteretic damping (loss factor)", his[k], 2)):
            if not (math.isfinite(v) and 0.0 <= v < top):
                raise ModalDataError(
                    f"{p}: mode {numbers[k]} (dataset {i + 1}) has {name} {float(v)!r}; it "
                    f"must be in [0, {top}) (0: not given)"
                )
    # viscous ratio if given, else half the hysteretic (loss factor) ratio; all zero: none
    zeta = np.where(vis > 0, vis, 0.5 * his)
    coords = None
    for _, s in sets:
        if s.get("type") in (2411, 15):
            ids = np.asarray(s["node_nums"]).astype(np.int64)
            xyz = np.column_stack([np.asarray(s[c], dtype=float) for c in "xyz"]) / length_f
            lookup = {int(v): j for j, v in enumerate(ids)}
            if all(int(v) in lookup for v in nodes):
                coords = xyz[[lookup[int(v)] for v in nodes]]
                break
            attrs["coordinates"] = "dataset 2411/15 lacks some mode-shape nodes: not used"
    return {
        "frequencies": freq, "modal_masses": mass, "nodes": nodes, "shapes": shapes,
        "damping": zeta if np.any(zeta > 0) else None, "coordinates": coords, "attrs": attrs,
        "mode_numbers": np.asarray(numbers, dtype=np.int64),
    }


def write_modes_uff(ms: ModeSet, path: str | Path) -> Path:
    """Write a mode set as UFF: dataset 164 (SI), 2411 (nodes, if coordinates are known) and
    one dataset 55 (normal mode, 3 DOF translation) per mode, with pyuff's writer.

    Dataset 55 holds frequency, modal mass, viscous damping ratio (0 when unknown) and shapes
    with 6 significant digits (pyuff writes ``%13.5e``); participation is not stored.
    """
    import pyuff

    p = Path(path)
    sets: list[dict[str, Any]] = [pyuff.prepare_164(
        units_code=1, units_description="SI", temp_mode=2, length=1.0, force=1.0, temp=1.0,
        temp_offset=273.15, return_full_dict=True)]
    if ms.coordinates is not None:
        c = ms.coordinates
        zeros = np.zeros(ms.n_nodes, dtype=int)
        sets.append(pyuff.prepare_2411(
            node_nums=ms.nodes.astype(int), def_cs=zeros, disp_cs=zeros, color=zeros + 1,
            x=c[:, 0], y=c[:, 1], z=c[:, 2], return_full_dict=True))
    for k in range(ms.n_modes):
        sets.append(pyuff.prepare_55(
            id1="sloshrom modes", id2=(ms.source or "NONE")[:80], id3="NONE", id4="NONE",
            id5=f"mode {k + 1}", model_type=1, analysis_type=2, data_ch=2, spec_data_type=8,
            data_type=2, n_data_per_node=3,
            r1=ms.shapes[:, 0, k], r2=ms.shapes[:, 1, k], r3=ms.shapes[:, 2, k],
            node_nums=ms.nodes.astype(int), load_case=1, mode_n=int(ms.mode_numbers[k]),
            freq=float(ms.frequencies[k]), modal_m=float(ms.modal_masses[k]),
            modal_damp_vis=float(ms.damping[k]) if ms.damping is not None else 0.0,
            modal_damp_his=0.0, return_full_dict=True))
        for key in ("r4", "r5", "r6", "eig", "modal_a", "modal_b", "freq_step_n"):
            sets[-1].pop(key, None)  # present (None) in the full dict: pyuff would write 6 DOF
    return atomic_write(
        p, lambda tmp: pyuff.UFF(tmp).write_sets(sets, mode="overwrite"),
        suffix=p.suffix or ".unv",
    )


# =============================================================================================
# Nastran punch
_EIGEN = re.compile(
    r"EIGENVALUE\s*=\s*(?P<lam>[-+]?[0-9.]+(?:[EeDd][-+]?[0-9]+)?)\s+MODE\s*=\s*(?P<mode>\d+)"
)
_META = ("TITLE", "SUBTITLE", "LABEL", "REAL OUTPUT", "SUBCASE ID", "ELEMENT TYPE",
         "ELEMENT ID", "POINT ID", "FREQUENCY", "TIME", "GRID")
_COMPLEX = ("REAL-IMAGINARY", "MAGNITUDE-PHASE", "COMPLEX")


def _float(text: str) -> float:
    return float(text.strip().replace("D", "E").replace("d", "e"))


def _punch_data_line(line: str) -> tuple[int, str, list[float]]:
    """ID, point type and T1..T3 of a data line: by columns, else by whitespace."""
    try:
        gid, typ = int(line[0:10]), line[10:18].strip()
        if typ in ("G", "S", "E", "H"):
            fields = [line[18:36], line[36:54], line[54:72]]
            vals = [_float(f) for f in fields if f.strip()]
            if typ == "G" and len(vals) != 3:
                raise ModalDataError  # not by columns: try by whitespace
            return gid, typ, vals
    except ValueError:
        pass
    tok = line.split()
    if len(tok) >= 3 and tok[1] in ("G", "S", "E", "H"):
        vals = [_float(t) for t in tok[2:5]]  # ValueError: caller names the line
        if tok[1] == "G" and len(vals) != 3:
            raise ModalDataError("a grid needs T1, T2, T3")
        return int(tok[0]), tok[1], vals
    raise ModalDataError("not 'ID TYPE T1 T2 T3'")


def _read_punch(p: Path, mass_factor: float | None) -> dict[str, Any]:
    try:
        text = p.read_bytes().decode("latin-1")
    except OSError as exc:
        raise ModalDataError(f"{p}: unreadable ({_reason(exc)})") from exc
    kind: str | None = None
    is_complex = False
    subcase: int | None = None
    modes: list[dict[str, Any]] = []
    current: dict[str, Any] | None = None
    scalars: set[int] = set()
    after_point = False  # a -CONT- line belongs to the preceding point line
    other_kinds: set[str] = set()
    lines = text.splitlines()
    # a file cut inside its last line: the rest of a number would read as another number
    cut_line = len(lines) if text and not text.endswith(("\n", "\r")) else 0
    numbered: bool | None = None  # do the data records carry sequence numbers (cols 73-80)?
    for lineno, raw in enumerate(lines, 1):
        line = raw.rstrip("\r\n")
        s = line.strip()
        if not s:
            continue
        if s.startswith("$"):
            head = line[:72].strip()[1:].strip().upper()
            after_point = False
            if head.startswith("TITLE"):  # a new result block begins
                kind, is_complex, current = None, False, None
            elif "EIGENVECTOR" in head:
                kind = "eigen"
                is_complex = is_complex or any(c in head for c in _COMPLEX)
            elif any(head.startswith(c) for c in _COMPLEX):
                is_complex = True
            elif head.startswith("EIGENVALUE"):
                if kind == "eigen" and not is_complex:
                    m = _EIGEN.search(head)
                    if m is None:
                        raise ModalDataError(f"{p}: line {lineno}: cannot read the eigenvalue "
                                             f"and mode number of {s[:72]!r}")
                    current = {"mode": int(m.group("mode")), "lam": _float(m.group("lam")),
                               "subcase": subcase, "line": lineno, "ids": [], "vals": []}
                    modes.append(current)
            elif head.startswith("SUBCASE ID"):
                try:
                    subcase = int(head.split("=", 1)[1].split()[0])
                except (IndexError, ValueError):
                    raise ModalDataError(f"{p}: line {lineno}: unreadable {s[:40]!r}") from None
            elif not any(head.startswith(m) for m in _META):
                kind = head.split("=")[0].strip() or "?"  # another result: skip its data
                other_kinds.add(kind)
                current = None
            if kind == "eigen" and is_complex:
                raise ModalDataError(
                    f"{p}: line {lineno}: complex eigenvectors ({s[:40]!r}); only real normal "
                    "modes (SOL 103) are read"
                )
            continue
        if kind != "eigen":
            continue
        if lineno == cut_line:
            raise ModalDataError(
                f"{p}: line {lineno}: the file ends inside this record (no line break after "
                f"{s[-20:]!r}): truncated file? (if it is complete, end it with a line break)"
            )
        has_seq = line[72:].strip().isdigit()
        if numbered is None:
            numbered = has_seq
        elif numbered and not has_seq:
            raise ModalDataError(
                f"{p}: line {lineno} is cut short ({len(line)} columns, no sequence number in "
                "columns 73-80 as the other records have): truncated or edited file?"
            )
        if s.startswith("-CONT-"):
            if not after_point:
                raise ModalDataError(f"{p}: line {lineno}: a -CONT- line without a point line "
                                     "before it")
            after_point = False
            continue
        if current is None:
            raise ModalDataError(f"{p}: line {lineno}: data before any $EIGENVALUE line")
        try:
            gid, typ, vals = _punch_data_line(line)
        except ValueError:
            raise ModalDataError(
                f"{p}: line {lineno}: cannot read {s[:72]!r} (expected a point line: ID in "
                "columns 1-10, type G or S in 11-18, T1 T2 T3 in 19-72)"
            ) from None
        after_point = True
        if typ != "G":
            scalars.add(gid)
            continue
        if not all(math.isfinite(v) for v in vals):
            raise ModalDataError(f"{p}: line {lineno}: non-finite value in {s[:72]!r}")
        current["ids"].append(gid)
        current["vals"].append(vals)
    if not modes:
        found = f" (found {', '.join(sorted(other_kinds))})" if other_kinds else ""
        raise ModalDataError(
            f"{p}: holds no eigenvectors{found} (is it a SOL 103 DISPLACEMENT(PUNCH)?)"
        )
    modes.sort(key=lambda m: m["mode"])  # by mode number: the order tables are matched in
    subcases = sorted({str(m["subcase"]) for m in modes})
    if len(subcases) > 1:
        raise ModalDataError(f"{p}: eigenvectors of several subcases ({', '.join(subcases)}); "
                             "split the file, one subcase per file")
    numbers = [m["mode"] for m in modes]
    if len(set(numbers)) != len(numbers):
        raise ModalDataError(f"{p}: mode numbers repeat: {numbers}")
    if modes[0]["mode"] < 1:
        raise ModalDataError(f"{p}: mode numbers must be >= 1, got {numbers[:10]} (mode "
                             "tables are matched to the modes by these numbers)")
    for m in modes:
        if not m["lam"] > 0:
            raise ModalDataError(
                f"{p}: mode {m['mode']} (line {m['line']}) has eigenvalue {m['lam']!r} "
                "(rad/s)^2: a rigid-body or mechanism mode; constrain the model or remove the "
                "mode from the file"
            )
    nodes = np.asarray(modes[0]["ids"], dtype=np.int64)
    if nodes.size == 0:
        raise ModalDataError(f"{p}: mode {modes[0]['mode']} lists no grid points")
    if np.unique(nodes).size != nodes.size:
        raise ModalDataError(f"{p}: mode {modes[0]['mode']} lists a grid twice")
    shapes = np.zeros((nodes.size, 3, len(modes)))
    for k, m in enumerate(modes):
        ids = np.asarray(m["ids"], dtype=np.int64)
        if not np.array_equal(ids, nodes):
            lost = sorted(set(nodes.tolist()) - set(ids.tolist()))[:5]
            extra = sorted(set(ids.tolist()) - set(nodes.tolist()))[:5]
            raise ModalDataError(
                f"{p}: mode {m['mode']} (line {m['line']}) lists {ids.size} grids, mode "
                f"{modes[0]['mode']} lists {nodes.size}"
                + (f"; missing {lost}" if lost else "") + (f"; extra {extra}" if extra else "")
                + ": every mode must list the same grids in the same order (truncated file?)"
            )
        shapes[:, :, k] = np.asarray(m["vals"], dtype=float)
    lam = np.array([m["lam"] for m in modes])
    attrs: dict[str, Any] = {
        "generalised_masses": "1 (NORM=MASS) x mass_unit, unless a mode table gives them",
    }
    if scalars:
        attrs["ignored_scalar_points"] = sorted(scalars)
    if other_kinds:
        attrs["ignored_punch_results"] = sorted(other_kinds)
    if modes[0]["subcase"] is not None:
        attrs["subcase"] = modes[0]["subcase"]
    to_kg = mass_factor if mass_factor is not None else 1.0
    return {
        "frequencies": np.sqrt(lam) / (2 * math.pi), "modal_masses": np.full(lam.size, to_kg),
        "nodes": nodes, "shapes": shapes, "attrs": attrs,
        "mode_numbers": np.array([m["mode"] for m in modes], dtype=np.int64),
    }


def write_modes_punch(ms: ModeSet, path: str | Path) -> Path:
    """Write a mode set as a Nastran-style punch file (``$EIGENVECTOR`` blocks, SOL 103 style).

    80-column records: the header lines of every mode, ``$EIGENVALUE = lambda MODE = m`` with
    ``lambda = (2 pi f)^2`` (rad/s)^2, a ``G`` line (ID cols 1-10, type 11-18, T1 T2 T3 as
    ``%18.10E`` in 19-72) and a ``-CONT-`` line (rotations, zero) per grid, a sequence number
    in columns 73-80. Modal masses, damping and participation are not stored (a punch holds
    none): write them with :func:`write_mode_table`.
    """
    out: list[str] = []

    def rec(text: str) -> None:
        out.append(f"{text[:72]:<72}{len(out) + 1:8d}")

    for k in range(ms.n_modes):
        lam = (2 * math.pi * float(ms.frequencies[k])) ** 2
        rec(f"$TITLE   = sloshrom modes {ms.source}")
        rec("$SUBTITLE=")
        rec("$LABEL   =")
        rec("$EIGENVECTOR")
        rec("$REAL OUTPUT")
        rec(f"$SUBCASE ID = {1:11d}")
        rec(f"$EIGENVALUE = {lam:17.10E}  MODE = {int(ms.mode_numbers[k]):5d}")
        for i, node in enumerate(ms.nodes.tolist()):
            t = ms.shapes[i, :, k]
            rec(f"{node:10d}{'G':>8}{t[0]:18.10E}{t[1]:18.10E}{t[2]:18.10E}")
            rec(f"{'-CONT-':<18}{0.0:18.10E}{0.0:18.10E}{0.0:18.10E}")
    return atomic_write_text(path, "\n".join(out) + "\n")
