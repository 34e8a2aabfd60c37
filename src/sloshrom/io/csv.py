"""CSV records (``.csv``, ``.txt``): text tables of one column per variable.

A header row of names, units as ``name [unit]`` (or ``name (unit)``) or in a second row; a
``time`` column or the ``fs`` argument. Delimiter ``,``, ``;`` or tab (from the header); fields
may be quoted. With ``;`` or tab and no decimal point anywhere, a comma is the decimal separator
(European spreadsheets: ``0,5;1,2`` or ``"0,5";"1,2"``); a quoted decimal comma with ``,`` as
the delimiter is refused, naming the row and column. Lines starting with ``#`` are comments.
Written as ``name [unit]`` headers and 17 significant digits (1-D variables only).
"""

from __future__ import annotations

import csv
import io
import re
from collections.abc import Mapping
from pathlib import Path

import numpy as np

from sloshrom.io.record import Record, RecordError, _build, _show, _unit_text, _why
from sloshrom.io.units import same_unit

__all__ = ["read_csv", "write_csv"]

_HEADER_UNIT = re.compile(r"^\s*(?P<name>[^\[\(]*?)\s*[\[\(]\s*(?P<unit>[^\]\)]*?)\s*[\]\)]\s*$")
# a number written with a decimal comma ("0,5", "-1,25e-3"): never a unit, never a valid number
_DECIMAL_COMMA = re.compile(r"^\s*[+-]?\d*,\d+(?:[eE][+-]?\d+)?\s*$")


def _is_number(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


def read_csv(p: Path, fs: float | None, units: Mapping[str, str]) -> Record:
    """Read a CSV record file (a time column, or ``fs`` in Hz; ``units`` by column)."""
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
        if delim == ",":
            _refuse_decimal_comma(p, names, first, 1)
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
        # quotechar: spreadsheets may quote every field ("0,5";"1,2")
        data = np.loadtxt(io.StringIO("\n".join(body)), delimiter=delim, ndmin=2, quotechar='"')
    except ValueError as exc:
        if delim == ",":
            for i, fields in enumerate(csv.reader(body, delimiter=delim)):
                _refuse_decimal_comma(p, names, fields, i + 1)
        raise RecordError(
            f"{p}: bad data row ({_find_bad_field(body, delim, names) or _why(exc)})"
        ) from exc
    if data.shape[1] != len(names):
        raise RecordError(f"{p}: {data.shape[1]} data columns but {len(names)} names in header")
    cols = {name: data[:, i] for i, name in enumerate(names)}
    return _build(str(p), cols, file_units, fs, units)


def _refuse_decimal_comma(p: Path, names: list[str], fields: list[str], row: int) -> None:
    """RecordError naming the first decimal-comma number of a comma-delimited data row.

    With ``,`` as the delimiter a decimal comma can only come quoted (``"0,5","1,2"``); it is
    refused rather than guessed (``"1,234"`` may be a thousands separator), with the fix.
    """
    for name, f in zip(names, fields, strict=False):
        if _DECIMAL_COMMA.match(f):
            raise RecordError(
                f"{p}: data row {row}, column {name!r}: {_show(f)} is a number with a decimal "
                "comma in a comma-delimited file; write it with a decimal point, or delimit "
                "the columns with ';' or tab (a comma is then read as the decimal separator)"
            )


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


def write_csv(record: Record, tmp: str) -> None:
    """Write ``record``'s 1-D variables as CSV columns to the temporary path ``tmp``."""
    two_d = [n for n, a in record.variables.items() if a.ndim != 1]
    if two_d:
        raise RecordError(f"CSV holds 1-D variables only; {two_d} are 2-D (use .nc)")
    names = ["time", *record.names]
    header = ",".join(f"{n} [{record.units[n]}]" for n in names)
    data = np.column_stack([record.time, *record.variables.values()])
    with open(tmp, "w", encoding="utf-8", newline="") as fh:
        np.savetxt(fh, data, delimiter=",", header=header, comments="", fmt="%.17g")
