"""Hostile input for the record readers (read_record, Record, read_uff58, preprocess).

Every case is either read correctly (the values are asserted) or rejected with ONE
``RecordError`` whose single-line message (< 400 characters) names the file, the variable or
channel, and the problem. Categories: units, silently wrong values, file structure, and valid
edge cases that must keep reading. Complements ``READER_CASES`` in tests/test_bad_input.py.
"""

from __future__ import annotations

import re
import warnings
from collections.abc import Callable
from pathlib import Path

import h5py
import numpy as np
import pytest
import pyuff
import scipy.io
import xarray as xr

from sloshrom.config import G
from sloshrom.io import (
    MAX_ABS_VALUE,
    Record,
    RecordError,
    canonical_unit,
    is_known_unit,
    preprocess,
    read_record,
    require_unit,
    resample,
    same_unit,
    write_record,
)
from sloshrom.io.uff import read_uff58, write_uff58

FS = 100.0
N = 200
T = np.arange(N) / FS
ACC = np.sin(2 * np.pi * 5 * T)
FORCE = 0.1 * np.cos(2 * np.pi * 5 * T)


# -- builders ------------------------------------------------------------------------------------
def _text(name: str, text: str, encoding: str = "utf-8") -> Callable[[Path], Path]:
    def make(tmp: Path) -> Path:
        p = tmp / name
        p.write_bytes(text.encode(encoding))
        return p

    return make


def _rows(n: int = N, sep: str = ",", acc=ACC, force=FORCE) -> str:
    return _table(T[:n], acc[:n], force[:n], sep=sep)


def _table(*cols, sep: str = ",", comma: bool = False, quote: bool = False) -> str:
    """Data rows of columns (17 significant digits), optionally with decimal commas, optionally
    each field in double quotes (as spreadsheets export them)."""
    def field(v) -> str:
        text = repr(float(v)).replace(".", ",") if comma else repr(float(v))
        return f'"{text}"' if quote else text

    return "".join(sep.join(field(c[k]) for c in cols) + "\n" for k in range(len(cols[0])))


def _csv(header: str, rows: str | None = None, name: str = "r.csv") -> Callable[[Path], Path]:
    return _text(name, header + "\n" + (_rows() if rows is None else rows))


def _ds(time_units: str | None = "s", time=T, **attrs) -> xr.Dataset:
    tattrs = {} if time_units is None else {"units": time_units}
    return xr.Dataset(
        {"acceleration": ("time", ACC, {"units": "m/s^2"}),
         "force": ("time", FORCE, {"units": "N"})},
        coords={"time": ("time", time, tattrs)},
        attrs={"fs": FS, **attrs},
    )


def _nc(edit: Callable[[xr.Dataset], xr.Dataset] = lambda ds: ds, engine: str = "h5netcdf",
        name: str = "r.nc", **kw) -> Callable[[Path], Path]:
    def make(tmp: Path) -> Path:
        p = tmp / name
        with warnings.catch_warnings():  # h5netcdf warns about invalid_netcdf (complex) files
            warnings.simplefilter("ignore", UserWarning)
            edit(_ds()).to_netcdf(p, engine=engine, **kw)
        return p

    return make


def _set(name: str, value, **attrs) -> Callable[[xr.Dataset], xr.Dataset]:
    def edit(ds: xr.Dataset) -> xr.Dataset:
        dims = ("time",) if np.ndim(value) == 1 else ("time", f"{name}_index")
        ds[name] = xr.Variable(dims, value, attrs)
        return ds

    return edit


def _mat(name: str = "r.mat", base: bool = True, **items) -> Callable[[Path], Path]:
    def make(tmp: Path) -> Path:
        p = tmp / name
        out = {"time": T, "acceleration": ACC, "force": FORCE,
               "units": {"acceleration": "m/s^2", "force": "N"}} if base else {}
        out.update(items)
        scipy.io.savemat(p, out)
        return p

    return make


def _mat73(fill: Callable[[h5py.File], None], name: str = "r73.mat") -> Callable[[Path], Path]:
    """A MATLAB v7.3 file as MATLAB writes it (HDF5 with a 512-byte MATLAB header)."""

    def make(tmp: Path) -> Path:
        p = tmp / name
        with h5py.File(p, "w", userblock_size=512) as fh:
            fill(fh)
        with open(p, "r+b") as fh:
            text = b"MATLAB 7.3 MAT-file, Platform: GLNXA64, HDF5 schema 1.00 ."
            fh.write(text.ljust(116, b" ") + b" " * 8 + b"\x00\x02" + b"IM")
        return p

    return make


def _h5var(group, name: str, value, cls: str = "double", **attrs) -> None:
    """A MATLAB variable: stored transposed (column-major), with its MATLAB_class."""
    d = group.create_dataset(name, data=np.asarray(value).T)
    d.attrs["MATLAB_class"] = np.bytes_(cls)
    for k, v in attrs.items():
        d.attrs[k] = v


def _h5char(group, name: str, text: str) -> None:
    d = group.create_dataset(name, data=np.array([[ord(c)] for c in text], dtype=np.uint16))
    d.attrs["MATLAB_class"] = np.bytes_("char")


def _h5units(group, **units) -> None:
    g = group.create_group("units")
    g.attrs["MATLAB_class"] = np.bytes_("struct")
    for k, u in units.items():
        _h5char(g, k, u)


def _d58(label, data, fs=FS, unit="N", spec=9, ord_type=4, t0=0.0, node=1, aspec=17,
         alab="s", x=None):
    """A complete dataset-58 dict as pyuff writes it."""
    even = x is None
    return pyuff.prepare_58(
        binary=0, id1=label, id2="hostile", id3="", id4="", id5="",
        func_type=1, ver_num=0, load_case_id=0, rsp_ent_name="tank", rsp_node=node,
        rsp_dir=3, ref_ent_name="tank", ref_node=0, ref_dir=0, ord_data_type=ord_type,
        num_pts=len(data), abscissa_spacing=int(even), abscissa_min=t0, abscissa_inc=1 / fs,
        z_axis_value=0.0, abscissa_spec_data_type=aspec, abscissa_len_unit_exp=0,
        abscissa_force_unit_exp=0, abscissa_temp_unit_exp=0, abscissa_axis_units_lab=alab,
        ordinate_spec_data_type=spec, ordinate_len_unit_exp=0, ordinate_force_unit_exp=0,
        ordinate_temp_unit_exp=0, ordinate_axis_units_lab=unit, orddenom_spec_data_type=0,
        orddenom_len_unit_exp=0, orddenom_force_unit_exp=0, orddenom_temp_unit_exp=0,
        orddenom_axis_units_lab="", z_axis_spec_data_type=0, z_axis_len_unit_exp=0,
        z_axis_force_unit_exp=0, z_axis_temp_unit_exp=0, z_axis_axis_units_lab="",
        data=np.asarray(data), x=(t0 + np.arange(len(data)) / fs) if even else np.asarray(x),
        return_full_dict=True,
    ) | {"func_id": 0, "abscissa_axis_lab": "Time", "ordinate_axis_lab": label,
         "orddenom_axis_lab": "", "z_axis_axis_lab": ""}


def _uff(*sets, name: str = "r.uff") -> Callable[[Path], Path]:
    def make(tmp: Path) -> Path:
        p = tmp / name
        pyuff.UFF(str(p)).write_sets(list(sets), mode="overwrite")
        return p

    return make


def _uff_lines(edit: Callable[[list[str], int], list[str]], n: int = N) -> Callable[[Path], Path]:
    """A one-channel ASCII UFF file whose lines go through ``edit(lines, start)``.

    ``start`` is the index of the dataset's opening "    -1" line: record 7 (data type,
    num_pts, spacing, min, increment) is ``start + 8``, the data lines start at ``start + 13``.
    """

    def make(tmp: Path) -> Path:
        p = _uff(_d58("force", FORCE[:n]), name="e.uff")(tmp)
        lines = p.read_text().splitlines()
        start = next(j for j, ln in enumerate(lines) if ln.rstrip() == "    -1"
                     and lines[j + 1].strip() == "58")
        p.write_text("\n".join(edit(lines, start)) + "\n")
        return p

    return make


def _record7(**fields) -> Callable[[list[str], int], list[str]]:
    """Rewrite fields of record 7 (formats 3I10, 3E13.5)."""
    names = ["ord_data_type", "num_pts", "abscissa_spacing", "abscissa_min", "abscissa_inc", "z"]

    def edit(lines: list[str], start: int) -> list[str]:
        line = lines[start + 8]
        vals = [line[0:10], line[10:20], line[20:30], line[30:43], line[43:56], line[56:69]]
        for k, v in fields.items():
            i = names.index(k)
            vals[i] = f"{v:10d}" if i < 3 else f"{v:13.5e}"
        lines[start + 8] = "".join(vals)
        return lines

    return edit


def _drop_data_lines(k: int) -> Callable[[list[str], int], list[str]]:
    """Remove ``k`` data lines in the middle of the dataset (the file still ends with -1)."""

    def edit(lines: list[str], start: int) -> list[str]:
        return lines[: start + 20] + lines[start + 20 + k:]

    return edit


def _bad_data_line(lines: list[str], start: int) -> list[str]:
    lines[start + 17] = lines[start + 17][:20] + "   1.0000000000ex+00" + lines[start + 17][40:]
    return lines


def _binary_uff_cut(tmp: Path) -> Path:
    """Binary dataset 58 with half its data bytes removed, closing "-1" kept."""
    p = write_uff58(Record(T, FS, {"force": FORCE}, {"force": "N"}), tmp / "b.uff", binary=True)
    data = p.read_bytes()
    end = data.rindex(b"    -1")
    p.write_bytes(data[: end - 8 * (N // 2)] + data[end:])  # 100 doubles gone
    return p


def _cdf5(tmp: Path) -> Path:
    p = _nc(engine="scipy", name="c5.nc")(tmp)
    data = bytearray(p.read_bytes())
    data[3] = 5
    p.write_bytes(bytes(data))
    return p


def _truncated_nc3(tmp: Path) -> Path:
    p = _nc(engine="scipy", name="t3.nc")(tmp)
    data = p.read_bytes()
    p.write_bytes(data[: len(data) * 2 // 3])
    return p


def _nc_fill(ds: xr.Dataset) -> xr.Dataset:
    f = FORCE.copy()
    f[33] = 9.969209968386869e36  # what netCDF-C returns for unwritten data
    ds["force"] = ("time", f, {"units": "N"})
    return ds


def _nc_transposed(ds: xr.Dataset) -> xr.Dataset:
    ds["station_acceleration"] = xr.Variable(("station", "time"), np.vstack([ACC, 2 * ACC]),
                                             {"units": "g"})
    return ds


def _nc_time_dim_t(ds: xr.Dataset) -> xr.Dataset:
    return xr.Dataset(
        {"time": ("t", T, {"units": "s"}), "force": ("t", FORCE, {"units": "N"})}
    )


def _nc_no_time_vars(ds: xr.Dataset) -> xr.Dataset:
    return xr.Dataset({"mass": ("x", [0.1, 0.2], {"units": "kg"})},
                      coords={"time": ("time", T, {"units": "s"})})


# -- reader cases: rejected --------------------------------------------------------------------
# (id, build(tmp) -> path, read_record kwargs, regex the one-line message must match)
UNITS = "time [s],acceleration [g],force [N]"
REJECT_UNITS = [
    ("csv-header-unit-vs-units-row", _csv("time [s],acceleration [g],force [N]\ns,m/s^2,N"),
     {}, r"r\.csv: column 'acceleration': the header says unit 'g', the units row 'm/s\^2'"),
    ("csv-units-row-mixed-with-numbers", _csv("time,acceleration,force\ns,5,N"), {},
     r"r\.csv: bad data row \(data row 1, column 'time': 's' is not a number"),
    ("csv-empty-bracket-unit", _csv("time [s],acceleration [],force [N]"), {},
     r"r\.csv: variable 'acceleration' has no unit"),
    ("csv-numeric-header-unit", _csv("time [s],acceleration [9.81],force [N]"), {},
     r"r\.csv: column 'acceleration': unit '9\.81' is a number, not a unit"),
    ("csv-time-unit-not-time-since", _csv("time [m since 2020-01-01],acceleration [g],force [N]"),
     {}, r"r\.csv: time unit 'm since 2020-01-01' is not a time unit"),
    ("csv-time-unit-hertz", _csv("time [Hz],acceleration [g],force [N]"), {},
     r"r\.csv: time unit 'Hz' is not a time unit"),
    ("csv-units-arg-contradicts-file", _csv(UNITS), {"units": {"force": "kN"}},
     r"r\.csv: variable 'force': units= gives 'kN' but the file says 'N'"),
    ("csv-units-arg-unknown-name", _csv("time [s],acceleration,force [N]"),
     {"units": {"acceleraton": "g"}},
     r"r\.csv: units= names 'acceleraton', which the file does not have"),
    ("csv-units-arg-number", _csv("time [s],acceleration,force [N]"),
     {"units": {"acceleration": 9.81}}, r"r\.csv: units=\{'acceleration': \.\.\.\}: unit 9\.81"),
    ("csv-units-arg-empty", _csv("time [s],acceleration,force [N]"),
     {"units": {"acceleration": " "}}, r"r\.csv: units= entry 'acceleration'"),
    ("nc-units-numeric", _nc(_set("force", FORCE, units=5)), {},
     r"r\.nc: variable 'force': unit 5 \(\w+\) is not a unit string"),
    ("nc-units-list", _nc(_set("force", FORCE, units=["N", "kN"])), {},
     r"r\.nc: variable 'force': unit .*is not a unit string"),
    ("nc-units-float", _nc(_set("acceleration", ACC, units=9.81)), {},
     r"r\.nc: variable 'acceleration': unit 9\.81 .*not a unit string"),
    ("nc-time-units-numeric", _nc(lambda ds: ds.assign_coords(
        time=("time", T, {"units": 1.0}))), {}, r"r\.nc: variable 'time': unit 1\.0"),
    ("nc-time-units-unknown-since", _nc(lambda ds: ds.assign_coords(
        time=("time", T, {"units": "fortnights since 2020-01-01"}))), {},
     r"r\.nc: time unit 'fortnights since 2020-01-01' is not a time unit"),
    ("nc-time-units-arg-contradicts", _nc(), {"units": {"time": "ms"}},
     r"r\.nc: variable 'time': units= gives 'ms' but the file says 's'"),
    ("nc-units-arg-contradicts", _nc(), {"units": {"acceleration": "g"}},
     r"r\.nc: variable 'acceleration': units= gives 'g' but the file says 'm/s\^2'"),
    ("mat-units-struct-number", _mat(units={"acceleration": 9.81, "force": "N"}), {},
     r"r\.mat: units\.acceleration: unit 9\.81 .*is not a unit string"),
    ("mat-units-not-a-struct", _mat(units="SI"), {},
     r"r\.mat: 'units' must be a struct of unit strings"),
    ("mat-name-units-contradicts-struct", _mat(force_units="kN"), {},
     r"r\.mat: variable 'force': units\.force = 'N' but force_units = 'kN'"),
    ("mat-name-units-number", _mat(base=False, time=T, force=FORCE, force_units=5.0), {},
     r"r\.mat: force_units: unit 5\.0 .*not a unit string"),
    ("uff-abscissa-hertz", _uff(_d58("force", FORCE, alab="Hz")), {},
     r"r\.uff: dataset 1 \(channel 'force'\): abscissa units 'Hz' are not a time unit"),
    ("uff-abscissa-frequency-type", _uff(_d58("force", FORCE, aspec=18)), {},
     r"r\.uff: dataset 1 \(channel 'force'\): the abscissa is frequency"),
    ("uff-units-arg-unknown-key", _uff(_d58("force", FORCE)), {"units": {"forse": "N"}},
     r"r\.uff: units= names \['forse'\], neither a variable nor a channel label"),
]

REJECT_VALUES = [
    ("csv-1e308", _csv(UNITS, _rows(force=np.r_[FORCE[:5], 1e308, FORCE[6:]])), {},
     r"r\.csv: variable 'force' has a value of magnitude >= 1e\+100 \(1e\+308 at sample 5, "
     r"t=0\.05 s\)"),
    ("csv-1e100-negative", _csv(UNITS, _rows(acc=np.r_[ACC[:9], -1e100, ACC[10:]])), {},
     r"r\.csv: variable 'acceleration' has a value of magnitude >= 1e\+100 \(-1e\+100 at "
     r"sample 9"),
    ("csv-huge-only-after-si", _csv("time [s],acceleration [g],force [kip]",
                                    _rows(force=np.r_[FORCE[:3], 1e99, FORCE[4:]])), {},
     r"r\.csv: variable 'force' has a value of magnitude >= 1e\+100 \(4\.4\d*e\+102 at "
     r"sample 3"),
    ("nc-1e200", _nc(_set("force", np.r_[FORCE[:-1], 1e200], units="N")), {},
     r"r\.nc: variable 'force' has a value of magnitude .*at sample 199, t=1\.99 s"),
    ("nc-netcdf-default-fill", _nc(_nc_fill), {},
     r"r\.nc: variable 'force' holds the NetCDF default fill value 9\.97e\+36 at sample 33"),
    ("nc-fillvalue-masked", _nc(_set("force", np.r_[FORCE[:7], -999.0, FORCE[8:]],
                                     units="N", _FillValue=-999.0)), {},
     r"r\.nc: variable 'force' contains NaN/inf \(first at sample 7"),
    ("mat-realmax", _mat(force=np.r_[FORCE[:-1], np.finfo(float).max]), {},
     r"r\.mat: variable 'force' has a value of magnitude >= 1e\+100"),
    ("nc-complex", _nc(_set("force", FORCE + 1e-3j, units="N"), invalid_netcdf=True), {},
     r"r\.nc: variable 'force': complex values .*: a time history must be real"),
    ("mat5-complex", _mat(force=FORCE + 0.5j), {},
     r"r\.mat: variable 'force': complex values \(dtype complex128, max \|imag\| 0\.5\): a "
     r"time history must be real"),
    ("mat5-complex-zero-imag", _mat(acceleration=ACC.astype(complex)), {},
     r"r\.mat: variable 'acceleration': complex values"),
    ("mat73-complex", _mat73(lambda fh: (
        _h5var(fh, "time", T[None, :]),
        fh.create_dataset("force", data=np.array(
            [(f, 1.0) for f in FORCE], dtype=[("real", "<f8"), ("imag", "<f8")])[:, None]),
        _h5units(fh, force="N"))), {},
     r"r73\.mat: variable 'force': complex values"),
    ("csv-fs-zero", _csv("acceleration [g],force [N]", "1,2\n3,4\n"), {"fs": 0},
     r"r\.csv: fs must be a finite positive rate in Hz, got 0"),
    ("csv-fs-negative", _csv("acceleration [g],force [N]", "1,2\n3,4\n"), {"fs": -500.0},
     r"r\.csv: fs must be a finite positive rate in Hz, got -500"),
    ("csv-fs-nan", _csv("acceleration [g],force [N]", "1,2\n3,4\n"), {"fs": float("nan")},
     r"r\.csv: fs must be a finite positive rate in Hz, got nan"),
    ("csv-fs-inf", _csv("acceleration [g],force [N]", "1,2\n3,4\n"), {"fs": float("inf")},
     r"r\.csv: fs must be a finite positive rate in Hz, got inf"),
    ("csv-fs-text", _csv("acceleration [g],force [N]", "1,2\n3,4\n"), {"fs": "500"},
     r"r\.csv: fs must be a number in Hz, got '500'"),
    ("csv-fs-bool", _csv("acceleration [g],force [N]", "1,2\n3,4\n"), {"fs": True},
     r"r\.csv: fs must be a number in Hz, got True"),
    ("csv-fs-tiny-time-overflows", _csv("acceleration [g],force [N]", "1,2\n3,4\n"),
     {"fs": 1e-200}, r"r\.csv: variable 'time' has a value of magnitude >= 1e\+100"),
    ("mat-fs-zero-in-file", _mat(base=False, acceleration=ACC, force=FORCE, fs=0.0,
                                 units={"acceleration": "g", "force": "N"}), {},
     r"r\.mat: variable 'fs': fs must be a finite positive rate in Hz, got 0"),
    ("mat-fs-vector", _mat(base=False, acceleration=ACC, fs=np.array([500.0, 500.0]),
                           units={"acceleration": "g"}), {},
     r"r\.mat: variable 'fs': fs must be one number in Hz, got shape \(2,\)"),
    ("mat-fs-text", _mat(base=False, acceleration=ACC, fs="500 Hz",
                         units={"acceleration": "g"}), {},
     r"r\.mat: variable 'fs' is '500 Hz', not a number in Hz"),
    ("mat-fs-arg-contradicts-file", _mat(base=False, acceleration=ACC, fs=500.0,
                                         units={"acceleration": "g"}), {"fs": 1000.0},
     r"r\.mat: fs=1000 Hz given but the file says fs=500 Hz"),
    ("nc-fs-arg-contradicts-attr", _nc(), {"fs": 50.0},
     r"r\.nc: fs=50 Hz given but the file says fs=100 Hz"),
    ("nc-fs-attr-zero", _nc(lambda ds: ds.assign_attrs(fs=0.0)), {},
     r"r\.nc: fs must be a finite positive rate in Hz, got 0"),
    ("uff-num-pts-larger", _uff_lines(_record7(num_pts=300)), {},
     r"e\.uff: dataset 1 \(channel 'force'\): the header declares 300 points but the dataset "
     r"holds 200"),
    ("uff-num-pts-smaller", _uff_lines(_record7(num_pts=150)), {},
     r"e\.uff: dataset 1 \(channel 'force'\): the header declares 150 points but the dataset "
     r"holds 200"),
    ("uff-data-lines-missing", _uff_lines(_drop_data_lines(10)), {},
     r"e\.uff: dataset 1 \(channel 'force'\): the header declares 200 points but the dataset "
     r"holds 160"),
    ("uff-binary-data-cut", _binary_uff_cut, {},
     r"b\.uff: dataset 2 \(channel 'force'\): the header declares 200 points but the dataset "
     r"holds 100"),
    ("uff-increment-zero", _uff_lines(_record7(abscissa_inc=0.0)), {},
     r"e\.uff: dataset 1 \(channel 'force'\): abscissa increment 0\.0 s; it must be a finite "
     r"positive step"),
    ("uff-increment-negative", _uff_lines(_record7(abscissa_inc=-0.01)), {},
     r"e\.uff: dataset 1 \(channel 'force'\): abscissa increment -0\.01 s"),
    ("uff-spacing-code-7", _uff_lines(_record7(abscissa_spacing=7)), {},
     r"e\.uff: dataset 1 of 1 \(type 58, channel 'force'\): line 9 \(header record 7\): "
     r"abscissa spacing code 7 \(0 uneven, 1 even\)$"),
    ("uff-ordinate-type-3", _uff_lines(_record7(ord_data_type=3)), {},
     r"e\.uff: dataset 1 of 1 \(type 58, channel 'force'\): line 9 \(header record 7\): "
     r"ordinate data type 3"),
    ("uff-non-numeric-data-line", _uff_lines(_bad_data_line), {},
     r"e\.uff: dataset 1 of 1 \(type 58, channel 'force'\): line 18 \(data\): "
     r"'1\.0000000000ex\+00' is not a number$"),
    ("uff-non-numeric-header", _uff_lines(lambda lines, s: [
        *lines[: s + 8], lines[s + 8].replace("       200", "       abc"), *lines[s + 9:]]), {},
     r"e\.uff: dataset 1 of 1 \(type 58\): line 9 \(header record 7\): 'abc' is not a "
     r"number$"),
    ("uff-one-sample", _uff_lines(lambda lines, s: [
        *_record7(num_pts=1)(lines, s)[: s + 13], lines[s + 13][:20], *lines[s + 14:]], n=4), {},
     r"e\.uff: dataset 1 \(channel 'force'\): 1 sample\(s\); a record needs at least 2"),
    ("uff-complex-channel", _uff(_d58("force", FORCE + 1j, ord_type=6)), {},
     r"r\.uff: dataset 1 \(channel 'force'\): complex data"),
    ("uff-uneven-decreasing", _uff(_d58("force", FORCE[:5], x=[0.0, 0.01, 0.03, 0.02, 0.04])),
     {}, r"r\.uff: dataset 1 \(channel 'force'\): abscissa \(time\) value 0\.02 at sample 3 "
     r"after 0\.03"),
    ("uff-huge-value", _uff(_d58("force", np.r_[FORCE[:-1], 1e250])), {},
     r"r\.uff: variable 'force' has a value of magnitude >= 1e\+100"),
    ("nc3-cdf5", _cdf5, {}, r"c5\.nc: NetCDF-3 variant .* \(CDF-5, 64-bit data\) is not "
     r"supported"),
    ("nc3-truncated", _truncated_nc3, {}, r"t3\.nc: not a readable NetCDF-3 file"),
    ("uff-fs-arg-contradicts", _uff(_d58("force", FORCE)), {"fs": 500.0},
     r"r\.uff: fs=500 Hz given but the file's time axis says 100 Hz"),
]

REJECT_STRUCTURE = [
    ("csv-duplicate-columns", _csv("time [s],force [N],force [N]"), {},
     r"r\.csv: duplicate column name 'force'"),
    ("csv-no-header", _text("r.csv", _rows()), {},
     r"r\.csv: the first row .* holds numbers, not column names"),
    ("csv-one-sample", _csv(UNITS, _rows(1)), {},
     r"r\.csv: a record needs at least 2 samples, got 1"),
    ("csv-NaT", _csv(UNITS, _rows(5) + "NaT,1,2\n"), {},
     r"r\.csv: bad data row \(data row 6, column 'time': 'NaT' is not a number"),
    ("csv-utf16", _text("r.csv", UNITS + "\n" + _rows(), "utf-16"), {},
     r"r\.csv: not a UTF-8 text CSV file"),
    ("csv-latin1-unit", _text("r.csv", "time [s],acceleration [m/s\u00b2],force [N]\n" + _rows(),
                              "latin-1"), {}, r"r\.csv: not a UTF-8 text CSV file"),
    ("csv-nul-bytes", _text("r.csv", UNITS + "\n0,1\x00,2\n"), {},
     r"r\.csv: binary data \(NUL bytes\)"),
    ("csv-trailing-delimiter", _csv(UNITS + ",", "".join(
        f"{k / FS},1,2,\n" for k in range(5))), {}, r"r\.csv: empty column name in header"),
    ("csv-decimal-comma-with-comma-delimiter", _csv(UNITS, "0,0;1,5;2\n"), {},
     r"r\.csv: bad data row \(data row 1, column 'acceleration': '0;1' is not a number"),
    ("csv-quoted-decimal-comma-with-comma-delimiter", _csv(UNITS, _table(
        T, ACC, FORCE, comma=True, quote=True)), {},
     r"r\.csv: data row 1, column 'time': '0,0' is a number with a decimal comma in a "
     r"comma-delimited file; write it with a decimal point, or delimit the columns with ';'"),
    ("csv-quoted-decimal-comma-no-units", _csv("time,acceleration,force", _table(
        T, ACC, FORCE, comma=True, quote=True)), {},
     r"r\.csv: data row 1, column 'time': '0,0' is a number with a decimal comma"),
    ("csv-quoted-decimal-comma-in-a-later-row", _csv(UNITS, _rows(5) + '"0,05",1,2\n'), {},
     r"r\.csv: data row 6, column 'time': '0,05' is a number with a decimal comma"),
    ("mat-transposed-matrix", _mat(station=np.vstack([ACC, ACC, ACC]),
                                   units={"acceleration": "m/s^2", "force": "N",
                                          "station": "g"}), {},
     r"r\.mat: variable 'station' has shape \(3, 200\), expected \(200, \.\.\.\) to match "
     r"time \(time runs along the second axis: transpose it"),
    ("mat-time-matrix", _mat(time=np.c_[T, T]), {},
     r"r\.mat: time variable 'time' has shape \(200, 2\), expected a vector"),
    ("mat-empty-variable-with-unit", _mat(force=np.zeros((0, 0))), {},
     r"r\.mat: variable 'force' holds an empty array \(0 samples\), not a time history"),
    ("mat-text-in-numeric-field", _mat(force=np.array(["0.1", "0.2", "0.3"])), {},
     r"r\.mat: variable 'force' holds text, not a time history"),
    ("mat-char-in-numeric-field", _mat(acceleration="1 2 3 4"), {},
     r"r\.mat: variable 'acceleration' holds text, not a time history"),
    ("mat-cell-in-numeric-field", _mat(force=np.array([0.1, "x", 0.3], dtype=object)), {},
     r"r\.mat: variable 'force' holds a cell/object array"),
    ("mat-one-sample", _mat(time=0.0, acceleration=1.0, force=2.0), {},
     r"r\.mat: a record needs at least 2 samples, got 1"),
    ("mat-all-scalars-with-fs", _mat(base=False, acceleration=1.0, force=2.0), {"fs": 100.0},
     r"r\.mat: no data columns \(ignored: 'acceleration' \(a scalar\), 'force' \(a scalar\)"),
    ("mat-two-structs", _mat(base=False, run1={"time": T, "force": FORCE},
                             run2={"time": T, "force": FORCE}), {},
     r"r\.mat: no 'time' column/variable; pass fs= \(Hz\) to read it \(ignored: 'run1' "
     r"\(a struct\), 'run2' \(a struct\)"),
    ("mat-3d-array", _mat(force=np.ones((N, 2, 2))), {},
     r"r\.mat: variable 'force': at most 2-D \(time, x\), got \(200, 2, 2\)"),
    ("mat-time-text", _mat(time="0:0.01:1.99"), {},
     r"r\.mat: variable 'time' holds text, not a time history"),
    ("mat73-empty-with-unit", _mat73(lambda fh: (
        _h5var(fh, "time", T[None, :]), _h5var(fh, "acceleration", ACC[None, :]),
        _h5var(fh, "force", np.array([0, 0], dtype=np.uint64), MATLAB_empty=1),
        _h5units(fh, acceleration="g", force="N"))), {},
     r"r73\.mat: variable 'force' holds an empty array \(0 samples\)"),
    ("mat73-text-in-numeric-field", _mat73(lambda fh: (
        _h5var(fh, "time", T[None, :]), _h5char(fh, "force", "lots"),
        _h5units(fh, force="N"))), {}, r"r73\.mat: variable 'force' holds text"),
    ("nc-no-variables-along-time", _nc(_nc_no_time_vars), {},
     r"r\.nc: no variables along the time dimension 'time' \(data variables: 'mass'\)"),
    ("nc-text-variable-along-time", _nc(_set("label", np.array(["a"] * N), units="1")), {},
     r"r\.nc: variable 'label': text, not numbers"),
    ("nc-bad-json-attribute", _nc(lambda ds: ds.assign_attrs(provenance="json:{oops")), {},
     r"r\.nc: attribute 'provenance' is not valid JSON"),
    ("nc-time-2d", _nc(lambda ds: xr.Dataset(
        {"time": (("a", "b"), np.ones((2, 2))), "x": ("a", [1.0, 2.0], {"units": "m"})})), {},
     r"r\.nc: time must be 1-D, got dims \('a', 'b'\)"),
    ("nc-time-not-numeric", _nc(lambda ds: ds.assign_coords(
        time=("time", np.array([f"t{k}" for k in range(N)]), {"units": "s"}))), {},
     r"r\.nc: variable 'time': text, not numbers"),
]

REJECT_CASES = REJECT_UNITS + REJECT_VALUES + REJECT_STRUCTURE


@pytest.mark.parametrize(("build", "kwargs", "match"), [c[1:] for c in REJECT_CASES],
                         ids=[c[0] for c in REJECT_CASES])
def test_reader_rejects(tmp_path, build, kwargs, match):
    path = build(tmp_path)
    with pytest.raises(RecordError) as info:
        read_record(path, **kwargs)
    msg = str(info.value)
    assert re.search(match, msg), msg
    assert "\n" not in msg and "\r" not in msg and len(msg) < 400, msg  # one line, not a dump
    assert path.name in msg  # the file is named


def test_case_ids_unique():
    ids = [c[0] for c in REJECT_CASES + ACCEPT_CASES]
    assert len(ids) == len(set(ids))


# -- reader cases: read correctly ---------------------------------------------------------------
def _check_standard(rec: Record) -> None:
    np.testing.assert_array_equal(rec.time, T)
    np.testing.assert_allclose(rec["acceleration"], ACC, rtol=1e-15)
    np.testing.assert_allclose(rec["force"], FORCE, rtol=1e-15)
    assert rec.fs == pytest.approx(FS)


def _check_ft(rec: Record) -> None:
    assert rec.units["velocity"] == "m/s" and rec.units["force"] == "N"
    np.testing.assert_array_equal(rec["velocity"], ACC * 0.3048)  # exact: one multiplication
    np.testing.assert_array_equal(rec["force"], FORCE * 4.4482216152605)


def _check_imperial_acc(rec: Record) -> None:
    assert rec.units == {"time": "s", "a1": "m/s^2", "a2": "m/s^2", "d": "m", "f": "N"}
    np.testing.assert_array_equal(rec["a1"], ACC * 0.3048)
    np.testing.assert_array_equal(rec["a2"], ACC * 0.0254)
    np.testing.assert_array_equal(rec["d"], ACC * 0.0254)
    np.testing.assert_array_equal(rec["f"], FORCE * 4448.2216152605)


def _check_since(k: float, ref: str, offset: float, atol: float = 1e-9
                 ) -> Callable[[Record], None]:
    """Time from the first sample, to the resolution of the file's numbers (``atol``, s)."""

    def check(rec: Record) -> None:
        np.testing.assert_allclose(rec.time, T, rtol=0, atol=atol)
        assert rec.fs == pytest.approx(FS, rel=1e-6)
        assert rec.attrs["time_reference"] == ref
        assert rec.attrs["time_start"] == pytest.approx(offset * k)

    return check


#: 2023-11-14 22:13:20.123456789 in ns since 1970 (not a multiple of the float64 step there)
NS_START = 1_700_000_000_123_456_789


def _days(ds: xr.Dataset) -> xr.Dataset:
    # 100 Hz samples starting 1500.25 days after 2020-01-01, in days
    return ds.assign_coords(time=("time", 1500.25 + T / 86400.0,
                                  {"units": "days since 2020-01-01 00:00:00"}))


def _transposed_check(rec: Record) -> None:
    assert rec["station_acceleration"].shape == (N, 2)
    np.testing.assert_allclose(rec["station_acceleration"][:, 1], 2 * ACC * G)
    assert rec.dims["station_acceleration"] == "station"


def _mat_rows_and_columns(tmp: Path) -> Path:
    p = tmp / "rc.mat"
    scipy.io.savemat(p, {"time": T[None, :], "acceleration": ACC[:, None],
                         "force": FORCE[None, :], "units": {"acceleration": "m/s^2",
                                                            "force": "N"}})
    return p


def _mat_ints(tmp: Path) -> Path:
    p = tmp / "i.mat"
    counts = np.arange(N, dtype=np.int16) - 100
    scipy.io.savemat(p, {"fs": 100, "adc": counts, "units": {"adc": "V", "big": "1"},
                         "big": np.arange(N, dtype=np.uint64) + 2**40}, oned_as="row")
    return p


def _check_ints(rec: Record) -> None:
    np.testing.assert_array_equal(rec["adc"], np.arange(N) - 100.0)
    assert rec.units["adc"] == "V"  # unknown unit: kept as written
    np.testing.assert_array_equal(rec["big"], np.arange(N) + 2.0**40)
    assert "ignored_variables" not in rec.attrs


def _mat73_struct(fh: h5py.File) -> None:
    g = fh.create_group("test1")
    g.attrs["MATLAB_class"] = np.bytes_("struct")
    _h5var(g, "time", T[:, None])  # MATLAB column vector: h5py sees (1, n)
    _h5var(g, "acceleration", (ACC / G)[None, :])
    _h5var(g, "force", FORCE[:, None].astype(">f8"))  # big-endian
    _h5var(g, "trigger", (ACC > 0)[None, :].astype(np.uint8), cls="logical")
    _h5var(g, "mass", np.array([[0.2]]))
    _h5units(g, acceleration="g", force="N", trigger="1")


def _check_mat73_struct(rec: Record) -> None:
    np.testing.assert_allclose(rec["acceleration"], ACC, rtol=1e-15)
    np.testing.assert_array_equal(rec["force"], FORCE)
    np.testing.assert_array_equal(rec["trigger"], (ACC > 0).astype(float))
    assert rec.attrs["ignored_variables"] == {"mass": "a scalar"}


def _mat_ignores(rec: Record) -> None:
    _check_standard(rec)
    assert rec.attrs["ignored_variables"] == {"notes": "text", "empty": "an empty array "
                                              "(0 samples)", "mass": "a scalar"}


def _nc_big_endian(ds: xr.Dataset) -> xr.Dataset:
    ds["force"] = ("time", FORCE.astype(">f8"), {"units": "N"})
    ds["counts"] = ("time", (np.arange(N) - 100).astype(">i4"), {"units": "1"})
    return ds


def _uff_ms(tmp: Path) -> Path:
    p = tmp / "ms.uff"
    s = _d58("force", FORCE, fs=FS / 1000.0, alab="ms")  # increment 10 (ms)
    pyuff.UFF(str(p)).write_sets([s], mode="overwrite")
    return p


def _uff_check_ms(rec: Record) -> None:
    assert rec.fs == FS and rec.time[-1] == pytest.approx(T[-1])
    np.testing.assert_allclose(rec["force"], FORCE, rtol=1e-11, atol=1e-14)


def _uff_uneven_ok(tmp: Path) -> Path:
    p = tmp / "x.uff"
    pyuff.UFF(str(p)).write_sets([_d58("force", FORCE, x=T)], mode="overwrite")
    return p


# (id, build(tmp) -> path, read_record kwargs, check(record))
ACCEPT_CASES = [
    ("csv-bom", _text("r.csv", UNITS + "\n" + _rows(), "utf-8-sig"), {},
     lambda r: (_check_standard(_unscale_g(r)), r.names == ["acceleration", "force"])),
    ("csv-crlf", _text("r.csv", (UNITS + "\n" + _rows()).replace("\n", "\r\n")), {},
     lambda r: _check_standard(_unscale_g(r))),
    ("csv-semicolon-decimal-comma", _csv("time [s];acceleration [m/s2];force [N]",
                                         _table(T, ACC, FORCE, sep=";", comma=True)), {},
     _check_standard),
    ("csv-tab-decimal-comma-units-row", _csv("time\tacceleration\tforce\ns\tm/s^2\tN",
                                             _table(T, ACC, FORCE, sep="\t", comma=True)), {},
     _check_standard),
    ("csv-semicolon-quoted-decimal-comma", _csv("time [s];acceleration [m/s2];force [N]",
                                                _table(T, ACC, FORCE, sep=";", comma=True,
                                                       quote=True)), {}, _check_standard),
    ("csv-quoted-fields", _csv("time [s],acceleration [m/s2],force [N]",
                               _table(T, ACC, FORCE, quote=True)), {}, _check_standard),
    ("csv-units-row-same-unit-respelled", _csv("time [s],acceleration [m/s2],force [N]\n"
                                               "sec,m s-2,newton"), {}, _check_standard),
    ("csv-ft-per-s-and-lbf-exact", _csv("time [s],velocity [ft/s],force [lbf]",
                                        _rows()), {}, _check_ft),
    ("csv-imperial-acceleration", _csv("time [s],a1 [ft/s^2],a2 [in/s2],d [in],f [kip]",
                                       _table(T, ACC, ACC, ACC, FORCE)), {},
     _check_imperial_acc),
    ("csv-cf-days-since", _csv("time [days since 2020-01-01],acceleration [m/s^2],force [N]",
                               _table(1500.25 + T / 86400, ACC, FORCE)), {},
     _check_since(86400.0, "2020-01-01", 1500.25, 3e-8)),  # 1500 d: float64 step 2e-8 s
    ("csv-time-in-minutes", _csv("time [min],acceleration [m/s^2],force [N]",
                                 _table(T / 60, ACC, FORCE)), {},
     lambda r: np.testing.assert_allclose(r.time, T, atol=1e-12)),
    ("csv-huge-fs", _csv("acceleration [m/s^2],force [N]", _table(ACC, FORCE)), {"fs": 1e12},
     lambda r: (np.testing.assert_allclose(r.time, np.arange(N) / 1e12), r.fs == 1e12)),
    ("csv-value-just-below-bound", _csv(UNITS, _rows(force=np.r_[FORCE[:5], 9.9e99,
                                                                 FORCE[6:]])), {},
     lambda r: r["force"][5] == 9.9e99),
    ("csv-unknown-unit-kept", _csv("time [s],voltage [V],force [N]"), {},
     lambda r: (r.units["voltage"] == "V", np.testing.assert_array_equal(r["voltage"], ACC))),
    ("csv-mega-newton-not-milli", _csv("time [s],acceleration [m/s^2],force [MN]"), {},
     lambda r: (r.units["force"] == "MN", np.testing.assert_array_equal(r["force"], FORCE))),
    ("nc-cf-days-since", _nc(_days), {},
     _check_since(86400.0, "2020-01-01 00:00:00", 1500.25, 3e-8)),
    ("nc-cf-hours-since", _nc(lambda ds: ds.assign_coords(
        time=("time", 7.0 + T / 3600.0, {"units": "hours since 1970-01-01"}))), {},
     _check_since(3600.0, "1970-01-01", 7.0)),
    ("nc-cf-minutes-since", _nc(lambda ds: ds.assign_coords(
        time=("time", 2.0 + T / 60.0, {"units": "minutes since 2024-06-01T12:00"}))), {},
     _check_since(60.0, "2024-06-01T12:00", 2.0)),
    ("nc-cf-seconds-since", _nc(lambda ds: ds.assign_coords(
        time=("time", 1.7e9 + T, {"units": "seconds since 1970-01-01"}))), {},
     _check_since(1.0, "1970-01-01", 1.7e9, 2.4e-7)),  # float64 step at 1.7e9 s: 2.4e-7 s
    ("nc-cf-ms-since", _nc(lambda ds: ds.assign_coords(
        time=("time", 5000.0 + 1000.0 * T, {"units": "ms since 2020-01-01"}))), {},
     _check_since(1e-3, "2020-01-01", 5000.0)),
    # int64 nanoseconds since 1970 (pandas, numpy datetime64 as integers): exact, although
    # float64 holds 1.7e18 only to 256 ns
    ("nc-cf-int64-nanoseconds-since", _nc(lambda ds: ds.assign_coords(
        time=("time", NS_START + np.arange(N, dtype=np.int64) * 10_000_000,
              {"units": "nanoseconds since 1970-01-01"}))), {},
     _check_since(1e-9, "1970-01-01", float(NS_START), 1e-15)),
    ("nc-cf-float-ns-since", _nc(lambda ds: ds.assign_coords(
        time=("time", NS_START + 1e9 * T, {"units": "ns since 1970-01-01"}))), {},
     _check_since(1e-9, "1970-01-01", float(NS_START), 2.6e-7)),  # float64 step at 1.7e18: 256
    ("csv-ns-since", _csv("time [ns since 2020-01-01],acceleration [m/s^2],force [N]",
                          _table(5e12 + 1e9 * T, ACC, FORCE)), {},
     _check_since(1e-9, "2020-01-01", 5e12, 1e-9)),
    ("csv-microseconds-since", _csv("time [microseconds since 2020-01-01],acceleration [m/s^2],"
                                    "force [N]", _table(5e9 + 1e6 * T, ACC, FORCE)), {},
     _check_since(1e-6, "2020-01-01", 5e9, 1e-9)),
    ("nc-time-without-units-is-seconds", _nc(lambda ds: ds.assign_coords(time=("time", T))),
     {}, _check_standard),
    ("nc3-classic-round-trip", _nc(engine="scipy", format="NETCDF3_CLASSIC"), {},
     lambda r: (_check_standard(r), r.attrs["source"].endswith("r.nc"))),
    ("nc3-64bit-offset-round-trip", _nc(engine="scipy", format="NETCDF3_64BIT"), {},
     _check_standard),
    ("nc-transposed-2d-variable", _nc(_nc_transposed), {}, _transposed_check),
    ("nc-time-dimension-named-t", _nc(_nc_time_dim_t), {},
     lambda r: (np.testing.assert_array_equal(r["force"], FORCE), r.fs == pytest.approx(FS))),
    ("nc-cf-packed-int16", _nc(_set("force", (np.round(FORCE * 1e4)).astype(np.int16),
                                    units="N", scale_factor=1e-4)), {},
     lambda r: np.testing.assert_allclose(r["force"], np.round(FORCE * 1e4) * 1e-4)),
    ("nc-big-endian-and-int", _nc(_nc_big_endian), {},
     lambda r: (np.testing.assert_array_equal(r["force"], FORCE),
                np.testing.assert_array_equal(r["counts"], np.arange(N) - 100.0))),
    ("nc-time-unit-from-units-arg", _nc(lambda ds: ds.assign_coords(time=("time", T * 1e3))),
     {"units": {"time": "ms"}}, lambda r: np.testing.assert_allclose(r.time, T, rtol=1e-15)),
    ("mat73-string-class-ignored", _mat73(lambda fh: (
        _h5var(fh, "time", T[None, :]), _h5var(fh, "force", FORCE[None, :]),
        _h5var(fh, "note", np.arange(6, dtype=np.uint64)[None, :], cls="string"),
        _h5units(fh, force="N"))), {},
     lambda r: (r.names == ["force"],
                r.attrs["ignored_variables"] == {"note": "a cell/object array"})),
    ("nc-units-arg-fills-missing", _nc(_set("extra", ACC)), {"units": {"extra": "mm"}},
     lambda r: np.testing.assert_allclose(r["extra"], ACC * 1e-3)),
    ("mat-row-and-column-vectors", _mat_rows_and_columns, {}, _check_standard),
    ("mat-int16-adc-counts", _mat_ints, {}, _check_ints),
    ("mat-n-by-k-matrix", _mat(station=np.c_[ACC, 2 * ACC, 3 * ACC],
                               units={"acceleration": "m/s^2", "force": "N", "station": "g"}),
     {}, lambda r: np.testing.assert_allclose(r["station"][:, 2], 3 * ACC * G)),
    ("mat-ignores-notes-empty-scalars", _mat(notes="run 3, tank half full", empty=np.zeros(0),
                                             mass=0.2), {}, _mat_ignores),
    ("mat-fs-arg-agrees-with-file", _mat(base=False, acceleration=ACC, fs=100.0,
                                         units={"acceleration": "m/s^2"}), {"fs": 100.0},
     lambda r: np.testing.assert_array_equal(r.time, T)),
    ("mat-time-in-ms", _mat(time=T * 1e3, units={"time": "ms", "acceleration": "m/s^2",
                                                 "force": "N"}), {},
     lambda r: np.testing.assert_allclose(r.time, T, rtol=1e-15)),
    ("mat73-struct-big-endian-logical", _mat73(_mat73_struct), {}, _check_mat73_struct),
    ("uff-abscissa-in-ms", _uff_ms, {}, _uff_check_ms),
    ("uff-uneven-abscissa", _uff_uneven_ok, {},
     lambda r: np.testing.assert_allclose(r["force"], FORCE, rtol=1e-11, atol=1e-14)),
]


def _unscale_g(rec: Record) -> Record:
    """The UNITS header has acceleration in g: undo the conversion to compare with ACC."""
    return Record(rec.time, rec.fs, {"acceleration": rec["acceleration"] / G,
                                     "force": rec["force"]},
                  {"acceleration": "m/s^2", "force": "N"})


@pytest.mark.parametrize(("build", "kwargs", "check"), [c[1:] for c in ACCEPT_CASES],
                         ids=[c[0] for c in ACCEPT_CASES])
def test_reader_accepts(tmp_path, build, kwargs, check):
    rec = read_record(build(tmp_path), **kwargs)
    out = check(rec)
    for item in out if isinstance(out, tuple) else (out,):
        if isinstance(item, bool | np.bool_):  # comparisons returned by the check must hold
            assert item


# -- Record / preprocess (the Python API) ------------------------------------------------------
API_CASES = [
    ("record-complex", dict(variables={"force": FORCE + 1j}),
     r"variable 'force': complex values \(dtype complex128, max \|imag\| 1\)"),
    ("record-complex-time", dict(time=T + 0j), r"variable 'time': complex values"),
    ("record-text", dict(variables={"force": np.array(["1"] * N)}),
     r"variable 'force': text, not numbers \(dtype <U1"),
    ("record-dates", dict(variables={"force": np.arange(N).astype("datetime64[s]")}),
     r"variable 'force': dates/durations"),
    ("record-ragged", dict(variables={"force": [[1.0], [1.0, 2.0]]}),
     r"variable 'force': not numeric"),
    ("record-1e300", dict(variables={"force": np.r_[1e300, FORCE[1:]]}),
     r"variable 'force' has a value of magnitude >= 1e\+100 \(1e\+300 at sample 0, t=0 s\)"),
    ("record-2d-huge", dict(variables={"st": np.c_[ACC, np.r_[ACC[:9], -2e101, ACC[10:]]]},
                            units={"st": "m"}),
     r"variable 'st' has a value of magnitude >= 1e\+100 \(-2e\+101 at sample 9"),
    ("record-fs-zero", dict(fs=0), r"fs must be a finite positive rate in Hz, got 0"),
    ("record-fs-bool", dict(fs=True), r"fs must be a number in Hz, got True"),
    ("record-fs-array", dict(fs=np.array([FS, FS])), r"fs must be one number in Hz"),
    ("record-unit-number", dict(units={"force": 5}),
     r"variable 'force': unit 5 \(int\) is not a unit string"),
    ("record-unit-empty", dict(units={"force": " "}), r"variable 'force' has no unit"),
    ("record-empty-variable", dict(variables={"force": np.zeros(0)}),
     r"variable 'force' has shape \(0,\), expected \(200, \.\.\.\) to match time \(the "
     r"variable is empty\)"),
    ("record-one-sample", dict(time=[0.0], variables={"force": [1.0]}),
     r"a record needs at least 2 samples, got 1"),
    ("record-time-huge", dict(time=T * 1e100, variables={"force": FORCE}),
     r"variable 'time' has a value of magnitude >= 1e\+100"),
    ("record-name-blank", dict(variables={" ": FORCE}, units={" ": "N"}),
     r"invalid variable name ' '"),
]


@pytest.mark.parametrize(("kw", "match"), [c[1:] for c in API_CASES],
                         ids=[c[0] for c in API_CASES])
def test_record_rejects(kw, match):
    args = {"time": T, "fs": None, "variables": {"force": FORCE}, "units": {"force": "N"}, **kw}
    with pytest.raises(RecordError) as info:
        Record(args["time"], args["fs"], args["variables"], args["units"])
    msg = str(info.value)
    assert re.search(match, msg), msg
    assert "\n" not in msg and len(msg) < 400


def test_record_accepts_bound_and_integers():
    below = np.nextafter(MAX_ABS_VALUE, 0)
    r = Record(np.arange(N), None, {"x": np.r_[below, np.zeros(N - 1)],
                                    "n": np.arange(N, dtype=">i8")}, {"x": "V", "n": "1"})
    assert r["x"][0] == below and r.fs == 1.0 and r["n"].dtype == float
    assert r.units == {"time": "s", "x": "V", "n": "1"}


@pytest.mark.parametrize(
    ("units", "match"),
    [({"acceleration": "V", "force": "N"},
      r"record: variable 'acceleration' has unit 'V', expected 'm/s\^2' \('V' is not a known "
      r"unit\)"),
     ({"acceleration": "m/s^2", "force": "MN"},
      r"variable 'force' has unit 'MN', expected 'N' \('MN' is not a known unit\)"),
     ({"acceleration": "m/s", "force": "N"},
      r"variable 'acceleration' has unit 'm/s', expected 'm/s\^2'$")],
    ids=["preprocess-volts", "preprocess-mega-newton", "preprocess-velocity-as-acceleration"],
)
def test_preprocess_refuses_units(units, match):
    rec = Record(T, FS, {"acceleration": ACC, "force": FORCE}, units)
    with pytest.raises(RecordError, match=match):
        preprocess(rec)


def test_preprocess_converts_imperial_and_names_file(tmp_path):
    p = tmp_path / "imp.csv"
    p.write_text("time [s],acceleration [in/s^2],force [lbf]\n" + _rows())
    out = preprocess(read_record(p, si=False))
    np.testing.assert_array_equal(out["acceleration"], ACC * 0.0254)
    np.testing.assert_array_equal(out["force"], FORCE * 4.4482216152605)
    p.write_text("time [s],acceleration [V],force [lbf]\n" + _rows())
    with pytest.raises(RecordError, match=r"imp\.csv: variable 'acceleration' has unit 'V'"):
        preprocess(read_record(p))
    p.write_text("time [s],acceleration [in/s^2],force [lbf]\n" + _rows())
    with pytest.raises(RecordError, match=r"^fs must be a finite positive rate in Hz, got 0$"):
        preprocess(read_record(p), fs=0.0)
    with pytest.raises(RecordError, match=r"resample: new fs must be a finite positive rate"):
        resample(read_record(p), -1.0)


def test_preprocess_names_file_of_bad_tank_attributes(tmp_path):
    p = _nc(lambda ds: ds.assign_attrs(tank_fill=1.5))(tmp_path)
    with pytest.raises(RecordError, match=r"r\.nc: attribute 'tank': fill level must be in "
                                          r"\(0, 1\)"):
        preprocess(read_record(p))


def test_missing_variable_says_why_it_was_ignored(tmp_path):
    p = _mat(acceleration="1 2 3", units={"force": "N"})(tmp_path)
    rec = read_record(p)
    assert rec.attrs["ignored_variables"] == {"acceleration": "text"}
    with pytest.raises(RecordError, match=r"r\.mat: missing variable\(s\) 'acceleration'; it has "
                                          r"'time', 'force'; ignored in the file: "
                                          r"'acceleration' \(text\)"):
        preprocess(rec)


# -- units API -----------------------------------------------------------------------------------
@pytest.mark.parametrize(
    ("unit", "si", "k"),
    [("ft", "m", 0.3048), ("feet", "m", 0.3048), ("in", "m", 0.0254), ("km", "m", 1e3),
     ("\u00b5m", "m", 1e-6), ("ft/s", "m/s", 0.3048), ("in/s", "m/s", 0.0254),
     ("cm/s", "m/s", 1e-2), ("ft/s^2", "m/s^2", 0.3048), ("in/s2", "m/s^2", 0.0254),
     ("mm/s^2", "m/s^2", 1e-3), ("cm/s\u00b2", "m/s^2", 1e-2), ("lbf", "N", 4.4482216152605),
     ("kip", "N", 4448.2216152605), ("min", "s", 60.0), ("h", "s", 3600.0),
     ("days", "s", 86400.0), ("us", "s", 1e-6),
     ("ns", "s", 1e-9), ("nanoseconds", "s", 1e-9), ("Millimeter", "m", 1e-3)],
)
def test_unit_table(unit, si, k):
    assert canonical_unit(unit) == (si, k) and is_known_unit(unit)


@pytest.mark.parametrize("unit", ["V", "MN", "Mn", "Ms", "MM/S", "furlong", "", 5, None, "lb",
                                  "days since 2020-01-01", "kgf"])
def test_unknown_units(unit):
    assert not is_known_unit(unit)


@pytest.mark.parametrize(
    ("a", "b", "same"),
    [("m/s2", "m/s^2", True), ("G", "g", True), ("N", "newton", True), ("mm/s", "m/s", False),
     ("g", "m/s^2", False), ("V", "V", True), ("mV", "MV", False), ("V", "m/s", False),
     ("ft/s", "m/s", False), ("kip", "kips", True)],
)
def test_same_unit(a, b, same):
    assert same_unit(a, b) is same


def test_require_unit():
    rec = Record(T, FS, {"u": ACC, "v": ACC, "w": ACC}, {"u": "m/s", "v": "V", "w": "mm/s"},
                 {"source": "data.nc"})
    require_unit(rec, "u", "m s-1")
    require_unit(rec, "v", "V", allow_unknown=True)
    with pytest.raises(RecordError, match=r"data\.nc: variable 'v' has unit 'V', expected 'V' "
                                          r"\('V' is not a known unit\)"):
        require_unit(rec, "v", "V")
    with pytest.raises(RecordError, match=r"data\.nc: variable 'w' has unit 'mm/s', expected "
                                          r"'m/s' \(same dimension, other scale"):
        require_unit(rec, "w", "m/s")
    with pytest.raises(RecordError, match=r"data\.nc: missing variable\(s\) 'x'"):
        require_unit(rec, "x", "m/s")


def test_record_error_is_one_line():
    err = RecordError("x.csv: bad\nthing\r\n  here")
    assert str(err) == "x.csv: bad thing here" and isinstance(err, ValueError)


# -- round trips of the edge cases through the writers ----------------------------------------
def test_cf_time_survives_round_trip(tmp_path):
    rec = read_record(_nc(_days)(tmp_path))
    back = read_record(write_record(rec, tmp_path / "back.nc"))
    assert back.attrs["time_reference"] == "2020-01-01 00:00:00"
    assert back.attrs["time_start"] == pytest.approx(1500.25 * 86400.0)
    np.testing.assert_array_equal(back.time, rec.time)


def test_uff_round_trip_of_imperial_record(tmp_path):
    rec = Record(T, FS, {"velocity": ACC, "force": FORCE}, {"velocity": "ft/s", "force": "kip"})
    back = read_record(write_uff58(rec, tmp_path / "imp.uff"))  # written in SI
    np.testing.assert_allclose(back["velocity"], ACC * 0.3048, rtol=1e-11, atol=1e-15)
    np.testing.assert_allclose(back["force"], FORCE * 4448.2216152605, rtol=1e-11)
    assert read_uff58(tmp_path / "imp.uff").units == {"time": "s", "velocity": "m/s",
                                                      "force": "N"}


# -- the tank a record carries: checked when it is read, not when it is written ---------------
@pytest.mark.parametrize(("attrs", "match"), [
    ({"tank_fill": "half"}, r"r\.nc: attribute 'tank': fill must be a number in \(0, 1\), got "
                            r"'half' \(the tank_\* attributes\)"),
    ({"tank_density": -1000.0}, r"r\.nc: attribute 'tank': density must be a finite positive "
                                r"number, got -1000\.0"),
    ({"tank_height": 27.2}, r"r\.nc: attribute 'tank': tank dimensions look like millimetres"),
    ({"fill": "half"}, r"r\.nc: attribute 'fill' must be a fill level d/h in \(0, 1\), got "
                       r"'half'"),
    ({"fill": 1.5}, r"r\.nc: attribute 'fill' must be a fill level d/h in \(0, 1\), got 1\.5"),
    ({"fill": 0.5, "tank_fill": 0.25}, r"r\.nc: attribute 'fill' = 0\.5 but the tank attributes "
                                       r"say fill 0\.25"),
], ids=["tank-fill-text", "tank-density-negative", "tank-height-mm", "fill-text", "fill-1.5",
        "fill-disagrees-with-tank"])
def test_record_tank_attributes_are_checked_when_read(tmp_path, attrs, match):
    p = _nc(lambda ds: ds.assign_attrs(**attrs))(tmp_path)
    with pytest.raises(RecordError, match=match):
        read_record(p)


def test_record_tank_attributes_that_read_are_written_back(tmp_path):
    p = _nc(lambda ds: ds.assign_attrs(tank_fill=np.float32(0.25), fill=0.25, tank_id=2001,
                                       tank_note="lab 3"))(tmp_path)
    rec = read_record(p)
    assert rec.attrs["tank"] == {"fill": 0.25} and rec.attrs["fill"] == 0.25
    assert rec.attrs["tank_id"] == 2001 and rec.attrs["tank_note"] == "lab 3"  # not the tank's
    back = read_record(write_record(rec, tmp_path / "back.nc"))
    assert back.tank.fill == 0.25 and back.attrs["tank_note"] == "lab 3"
    with pytest.raises(RecordError, match=r"attribute 'tank': unknown tank parameter\(s\): "
                                          r"colour"):
        Record(T, FS, {"force": FORCE}, {"force": "N"}, {"tank": {"colour": 1.0}})


def test_a_named_pipe_is_not_a_missing_file(tmp_path):
    import os

    os.mkfifo(tmp_path / "pipe.nc")
    with pytest.raises(RecordError, match=r"pipe\.nc: is a named pipe \(FIFO\), not a regular "
                                          r"file"):
        read_record(tmp_path / "pipe.nc")  # and it must not block waiting for a writer
    os.mkfifo(tmp_path / "pipe.uff")
    with pytest.raises(RecordError, match=r"pipe\.uff: is a named pipe"):
        read_uff58(tmp_path / "pipe.uff")


def test_time_axis_names():
    """The names of a record's time axis: "time", and a reader's time name (t, Time, TIME)
    unless a variable has it (a file with a time and a t column keeps t as a signal)."""
    t = np.arange(4) / FS
    rec = Record(t, FS, {"force": np.ones(4)}, {"force": "N"})
    assert [n for n in ("time", "t", "Time", "TIME", "force", "T", "tt") if rec.is_time_axis(n)] \
        == ["time", "t", "Time", "TIME"]
    rec = Record(t, FS, {"t": np.ones(4)}, {"t": "N"})
    assert rec.is_time_axis("time") and not rec.is_time_axis("t")
