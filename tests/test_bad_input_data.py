"""Bad records and record files: each gives one clear RecordError naming the problem."""

from __future__ import annotations

import numpy as np
import pytest

from sloshrom.io import Record, RecordError, preprocess, read_record, require, write_record

T = np.arange(100) / 100.0
X = np.sin(T)


def _rec(time=T, variables=None, units=None, fs=None):
    variables = {"acceleration": X} if variables is None else variables
    units = {"acceleration": "m/s^2"} if units is None else units
    return Record(time, fs, variables, units)


@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
def test_nan_inf_named(bad):
    x = X.copy()
    x[37] = bad
    with pytest.raises(RecordError, match=r"'acceleration' contains NaN/inf \(first at sample 37"):
        _rec(variables={"acceleration": x})
    t = T.copy()
    t[5] = bad
    with pytest.raises(RecordError, match="time contains NaN/inf"):
        _rec(time=t)


def test_mismatched_lengths():
    with pytest.raises(RecordError, match=r"'force' has shape \(99,\).*match time"):
        _rec(
            variables={"acceleration": X, "force": X[:-1]},
            units={"acceleration": "g", "force": "N"},
        )


def test_non_uniform_time():
    t = T.copy()
    t[50:] += 0.004  # a glitch of 40 % of a step
    with pytest.raises(RecordError, match="not uniformly sampled"):
        _rec(time=t)


def test_non_increasing_time():
    t = T.copy()
    t[10], t[11] = t[11], t[10]
    with pytest.raises(RecordError, match="not strictly increasing"):
        _rec(time=t)
    with pytest.raises(RecordError, match="not strictly increasing"):
        _rec(time=T[::-1].copy())


def test_missing_unit_and_fs_mismatch():
    with pytest.raises(RecordError, match="'velocity' has no unit"):
        _rec(variables={"acceleration": X, "velocity": X})
    with pytest.raises(RecordError, match="does not match the time axis"):
        _rec(fs=50.0)


def test_missing_variable_named(tmp_path):
    r = _rec()
    with pytest.raises(RecordError, match="missing variable\\(s\\) 'force'"):
        require(r, ["acceleration", "force"])
    with pytest.raises(RecordError, match="missing variable\\(s\\) 'velocity'"):
        r["velocity"]
    path = write_record(r, tmp_path / "r.nc")
    with pytest.raises(RecordError, match=r"r\.nc: missing variable\(s\) 'force'"):
        preprocess(read_record(path))


def test_empty_file(tmp_path):
    for name in ("e.nc", "e.csv", "e.mat"):
        (tmp_path / name).write_bytes(b"")
        with pytest.raises(RecordError, match="file is empty"):
            read_record(tmp_path / name)
    (tmp_path / "h.csv").write_text("time,acceleration\n")
    with pytest.raises(RecordError, match="header but no data rows"):
        read_record(tmp_path / "h.csv")


def test_truncated_netcdf(tmp_path):
    path = write_record(_rec(), tmp_path / "r.nc")
    data = path.read_bytes()
    path.write_bytes(data[: len(data) // 2])
    with pytest.raises(RecordError, match="not a readable NetCDF file"):
        read_record(path)


def test_garbage_mat_and_unknown_suffix(tmp_path):
    (tmp_path / "g.mat").write_bytes(b"not a mat file at all" * 10)
    with pytest.raises(RecordError, match="not a readable MAT file"):
        read_record(tmp_path / "g.mat")
    (tmp_path / "r.xlsx").write_bytes(b"x")
    with pytest.raises(RecordError, match="unknown record format"):
        read_record(tmp_path / "r.xlsx")
    with pytest.raises(RecordError, match="no such file"):
        read_record(tmp_path / "missing.nc")


def test_bad_csv(tmp_path):
    (tmp_path / "a.csv").write_text("time,acceleration [g]\n0,1\n0.1,oops\n")
    with pytest.raises(RecordError, match="bad data row.*row 2, column 'acceleration': 'oops'"):
        read_record(tmp_path / "a.csv")
    (tmp_path / "b.csv").write_text("acceleration [g]\n1\n2\n")
    with pytest.raises(RecordError, match="no 'time' column"):
        read_record(tmp_path / "b.csv")
    (tmp_path / "c.csv").write_text("time,acceleration\n0,1\n0.1,2\n")
    with pytest.raises(RecordError, match="'acceleration' has no unit"):
        read_record(tmp_path / "c.csv")
    (tmp_path / "d.csv").write_text("time [s],acceleration [g]\n0,1\n0.1,\n")
    with pytest.raises(RecordError, match="data row 2, column 'acceleration': '' is not a number"):
        read_record(tmp_path / "d.csv")


def test_no_half_written_file_on_error(tmp_path):
    r = Record(T, None, {"y": np.c_[X, X]}, {"y": "m"})
    with pytest.raises(RecordError, match="1-D variables only"):
        write_record(r, tmp_path / "r.csv")
    assert list(tmp_path.iterdir()) == []
