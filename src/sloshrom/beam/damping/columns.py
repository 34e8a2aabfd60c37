"""The flat columns of paper Table 2: the one place where a damping table over the
``estimator`` dimension becomes the rows of its files, and where such rows become a dataset again.

Inside the package a damping table is an xarray Dataset whose estimates run over the dimension
``estimator`` (``sloshrom.beam.damping.uncertainty.RandomDamping.to_dataset``,
``sloshrom.beam.damping.tables.mode1_damping_dataset``: over ``(case, level, estimator)``). Its
files and records - ``table2_mode1_damping.csv``/``.md``, ``table2_damping.csv``, the
``table2`` rows of ``summary.json`` - hold one row per case and level, an estimator's numbers
in columns named after it (``lscf_h1``, ``lscf_h1_std``, ``frequency_h1``, ...). Those names and
their order are a file contract, that of the versions before the estimator registry:

* :func:`table2_columns` - one row's estimate columns, in the contract's order;
* :func:`table2_rows` - every row of a table (its leading columns from its coordinates);
* :func:`table2_dataset` - rows read back (a stage record, a file) as a Dataset over
  ``(level, estimator)``.

Nothing else in the package composes or parses a column name from an estimator's name
(``tests/test_architecture.py``).
"""

from __future__ import annotations

import itertools
from collections.abc import Iterator, Mapping, Sequence
from typing import TYPE_CHECKING

import numpy as np
import xarray as xr

from sloshrom.beam.damping.registry import ESTIMATORS, TABLE2, label
from sloshrom.beam.simulation.members import Cell, Row

if TYPE_CHECKING:  # the uncertainty module makes its columns here
    from sloshrom.beam.damping.uncertainty import RandomDamping

__all__ = ["ESTIMATE_FIELDS", "LEADING_COLUMNS", "column", "each_row", "table2_columns",
           "table2_dataset", "table2_rows"]

#: The column of each per-estimator variable, ``{}`` standing for the estimator's name.
ESTIMATE_FIELDS: dict[str, str] = {
    "value": "{}", "std": "{}_std", "low": "{}_low", "high": "{}_high",
    "uncorrected": "{}_uncorrected", "iqr": "{}_iqr", "n_poles": "{}_n",
    "frequency": "frequency_{}", "reason": "{}_reason", "note": "{}_note",
    "spread": "{}_spread", "members": "{}_members",
}
#: The frequency columns of paper Table 2's two LSCF estimators, named before the registry.
_LEGACY_FREQUENCY = {TABLE2[0]: "frequency_h1", TABLE2[1]: "frequency_output"}
#: The column of a table's coordinate where it is not the coordinate's name: the RMS base level.
LEADING_COLUMNS: dict[str, str] = {"level": "rms_g"}
#: Per-row numbers of a damping dataset that are not Table 2's own columns: written right after
#: the leading columns, in this order.
_ROW_NUMBERS = ("max_tank_acceleration_g",)
#: Per-row numbers of the estimate columns (:func:`table2_columns`).
_SCALARS = ("noise_input", "noise_output", "duration_s", "n_cycles")


def column(name: str, field: str) -> str:
    """The file column of estimator ``name``'s variable ``field`` (:data:`ESTIMATE_FIELDS`):
    ``column("lscf_h1", "std") == "lscf_h1_std"``; Table 2's LSCF frequencies keep their
    names (``frequency_h1``, ``frequency_output``)."""
    if field == "frequency" and name in _LEGACY_FREQUENCY:
        return _LEGACY_FREQUENCY[name]
    return ESTIMATE_FIELDS[field].format(name)


def _members(d: xr.Dataset) -> int:
    """The members an ensemble's row averages (0: a single model's row)."""
    if "n_members" not in d:
        return 0
    n = float(d["n_members"])
    return int(n) if np.isfinite(n) and n > 0 else 0


def table2_columns(result: xr.Dataset | RandomDamping) -> Row:
    """The estimate columns of one Table 2 row, names and order a file contract.

    Paper Table 2's three estimators first, as ever: their values, ``frequency_h1``,
    ``frequency_output``, ``{est}_iqr`` and ``{est}_n`` of the LSCF ones, the uncorrected
    bootstrapped values, the noise ratios, ``{est}_std``/``_low``/``_high`` (bootstrapped
    estimators first), ``duration_s``, ``n_cycles``. Any other estimator asked follows:
    ``{est}``, ``{est}_std``, ``{est}_low``, ``{est}_high``, ``frequency_{est}``,
    ``{est}_uncorrected``. Last, for every estimator, ``{est}_reason`` (``""`` when the value and
    its interval exist, else why not: a cell is never a silent NaN) and ``{est}_note`` (``""``
    unless the value comes from a fallback attempt, which it names).

    Parameters
    ----------
    result : xarray.Dataset or RandomDamping
        One row's estimates over the dimension ``estimator`` (in the order asked) with the
        scalars ``noise_input``, ``noise_output``, ``duration_s``, ``n_cycles``
        (``RandomDamping.to_dataset``, or one case and level of a damping table); a
        ``RandomDamping`` is taken as its dataset.

    Returns
    -------
    dict
        Column -> number (Python ``float``; the pole counts ``int``, an ensemble's the mean
        over its members, a ``float``) or text.
    """
    d = result if isinstance(result, xr.Dataset) else result.to_dataset()
    names = [str(n) for n in d.estimator.values]
    count = float if _members(d) else int

    def get(field: str, n: str) -> Cell:
        v = d[field].sel(estimator=n).values.item()
        if field in ("reason", "note"):
            return str(v)
        return count(v) if field == "n_poles" else float(v)

    legacy = [n for n in TABLE2 if n in names]
    h1, out_only, hp = TABLE2
    clusters = [n for n in (h1, out_only) if n in names]
    out: Row = {n: get("value", n) for n in legacy}
    for field in ("frequency", "iqr", "n_poles"):
        out.update({column(n, field): get(field, n) for n in clusters})
    out.update({column(n, "uncorrected"): get("uncorrected", n) for n in (h1, hp) if n in names})
    out.update({k: float(d[k]) for k in _SCALARS[:2]})
    for n in (h1, hp, out_only):
        if n in names:
            out.update({column(n, f): get(f, n) for f in ("std", "low", "high")})
    out.update({k: float(d[k]) for k in _SCALARS[2:]})
    for n in names:
        if n not in legacy:
            out.update({column(n, f): get(f, n) for f in ("value", "std", "low", "high",
                                                         "frequency", "uncorrected")})
    for n in names:
        out.update({column(n, f): get(f, n) for f in ("reason", "note")})
    return out


def each_row(ds: xr.Dataset) -> Iterator[tuple[Row, xr.Dataset]]:
    """Every row of a damping table, in order: its leading columns (scalar coordinates such as
    ``case``, then per dimension but ``estimator`` its coordinate - ``level`` as ``rms_g`` - and
    the coordinates along it, such as ``mode_frequency_Hz``) and its estimates (the dataset at
    that index, over ``estimator``)."""
    # the rows in the order of the estimates' dimensions (a dataset's own order of dimensions
    # is that of its variables' first appearance)
    dims = [str(d) for d in ds["value"].dims if d != "estimator"]
    scalars = [str(c) for c in ds.coords if ds[c].ndim == 0]
    along = {d: [str(c) for c in ds.coords if c != d and ds[c].dims == (d,)] for d in dims}
    for idx in itertools.product(*(range(ds.sizes[d]) for d in dims)):
        d = ds.isel(dict(zip(dims, idx, strict=True)))
        head: Row = {c: d[c].values.item() for c in scalars}
        for dim in dims:
            head[LEADING_COLUMNS.get(dim, dim)] = d[dim].values.item()
            head.update({c: d[c].values.item() for c in along[dim]})
        yield head, d


def table2_rows(ds: xr.Dataset) -> list[Row]:
    """The rows of a damping table as its files hold them: one per index of every dimension but
    ``estimator``, in order.

    Parameters
    ----------
    ds : xarray.Dataset
        A damping table (``sloshrom.beam.damping.tables.mode1_damping_dataset``: dimensions
        ``(case, level, estimator)``; ``sloshrom.beam.lab.every_mode.random_mode_dataset``:
        ``(mode, level, estimator)`` with a scalar ``case``), optionally with
        ``max_tank_acceleration_g`` over its rows and, for an ensemble's rows (``n_members`` >
        0), ``spread`` and ``members`` over the estimators.

    Returns
    -------
    list of dict
        Each row: its scalar coordinates (``case``), then per dimension its coordinate
        (``level`` as ``rms_g``, g) and the coordinates along it (``mode_frequency_Hz``), then
        ``max_tank_acceleration_g`` if the table has it, then :func:`table2_columns`; an
        ensemble's row then ``{est}_spread`` (-) and ``{est}_members`` per estimator (Table 2's
        first) and ``n_members``.
    """
    rows = []
    for head, d in each_row(ds):
        row = dict(head)
        row.update({k: float(d[k]) for k in _ROW_NUMBERS if k in d})
        row.update(table2_columns(d))
        n = _members(d)
        if n:
            names = [str(e) for e in d.estimator.values]
            for e in [*(e for e in TABLE2 if e in names), *(e for e in names if e not in TABLE2)]:
                row[column(e, "spread")] = float(d["spread"].sel(estimator=e))
                row[column(e, "members")] = int(d["members"].sel(estimator=e))
            row["n_members"] = n
        rows.append(row)
    return rows


def table2_dataset(rows: Sequence[Mapping[str, Cell]]) -> xr.Dataset:
    """The Table 2 rows of one case (:func:`table2_rows`, or a table or stage record read back)
    as a Dataset over RMS level and estimator.

    Returns
    -------
    xarray.Dataset
        Dimensions ``level`` (coordinate: ``rms_g``, g) and ``estimator`` (coordinates: the
        names, ``registry.TABLE2`` first and then every other registered estimator that a row
        holds, and ``label``); variables ``value``, ``std``, ``low``, ``high`` (damping ratio,
        -; NaN where a row lacks the column), ``spread`` (-: the standard deviation over an
        ensemble's members, NaN for a single model), ``reason`` and ``note`` (str; ``""``
        where a row lacks the column, as rows written before these columns existed).
    """
    keys = set().union(*(r.keys() for r in rows)) if rows else set()
    names = [*TABLE2, *(n for n in ESTIMATORS if n not in TABLE2 and n in keys)]
    nan = float("nan")

    def numbers(field: str) -> np.ndarray:
        return np.array([[float(r.get(column(n, field), nan)) for n in names] for r in rows],
                        dtype=float).reshape(len(rows), len(names))

    def texts(field: str) -> np.ndarray:
        return np.array([[str(r.get(column(n, field), "") or "") for n in names] for r in rows],
                        dtype=object).reshape(len(rows), len(names))

    dims = ("level", "estimator")
    return xr.Dataset(
        {**{f: (dims, numbers(f), {"units": "1"}) for f in ("value", "std", "low", "high",
                                                            "spread")},
         **{f: (dims, texts(f)) for f in ("reason", "note")}},
        coords={"level": ("level", [float(r[LEADING_COLUMNS["level"]]) for r in rows],
                          {"units": "g"}),
                "estimator": names, "label": ("estimator", [label(n) for n in names])})
