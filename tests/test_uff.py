"""UFF dataset 58 time histories: written by pyuff, read as records, preprocessed, trained on."""

from __future__ import annotations

import re

import numpy as np
import pytest
import pyuff  # a hard dependency: an import error must fail, not skip

from sloshrom.config import G, Tank
from sloshrom.io import Record, RecordError, preprocess, read_record
from sloshrom.io.uff import read_uff58, write_uff58


def _d58(label, data, fs, unit="", spec=0, func_type=1, rsp_dir=3, t0=0.0, node=1):
    """A complete dataset-58 dict as pyuff writes it (all fields given explicitly)."""
    return pyuff.prepare_58(
        binary=0, id1=label, id2="shaker test", id3="", id4="", id5="",
        func_type=func_type, ver_num=0, load_case_id=0, rsp_ent_name="tank", rsp_node=node,
        rsp_dir=rsp_dir, ref_ent_name="tank", ref_node=0, ref_dir=0, ord_data_type=4,
        num_pts=len(data), abscissa_spacing=1, abscissa_min=t0, abscissa_inc=1 / fs,
        z_axis_value=0.0, abscissa_spec_data_type=17, abscissa_len_unit_exp=0,
        abscissa_force_unit_exp=0, abscissa_temp_unit_exp=0,
        abscissa_axis_units_lab="s", ordinate_spec_data_type=spec, ordinate_len_unit_exp=0,
        ordinate_force_unit_exp=0, ordinate_temp_unit_exp=0,
        ordinate_axis_units_lab=unit, orddenom_spec_data_type=0, orddenom_len_unit_exp=0,
        orddenom_force_unit_exp=0, orddenom_temp_unit_exp=0,
        orddenom_axis_units_lab="", z_axis_spec_data_type=0, z_axis_len_unit_exp=0,
        z_axis_force_unit_exp=0, z_axis_temp_unit_exp=0,
        z_axis_axis_units_lab="", data=np.asarray(data, float), x=t0 + np.arange(len(data)) / fs,
        return_full_dict=True,
    ) | {"func_id": 0, "abscissa_axis_lab": "Time", "ordinate_axis_lab": label,
         "orddenom_axis_lab": "", "z_axis_axis_lab": ""}


def _write(path, sets):
    pyuff.UFF(str(path)).write_sets(sets, mode="overwrite")
    return path


@pytest.fixture(scope="module")
def rig_measurement():
    """A short harmonic test on the virtual rig (12 Hz, 7 mm = 4 g: sloshing, 1.5 s)."""
    from sloshrom.rig.virtual import VirtualRig
    from sloshrom.signals import harmonic

    rig = VirtualRig(seed=3)
    h = harmonic(1.0 / rig.dt, 12.0, 7e-3, n_cycles=10)
    return rig.measure(h.acceleration)


@pytest.mark.long
def test_pyuff_file_read_preprocessed_and_trained(tmp_path, rig_measurement):
    """Accelerometer in g (labelled), load cell force with no unit label (units= mapping)."""
    m = rig_measurement
    fs = float(m["fs"])
    path = _write(tmp_path / "shaker.uff", [
        _d58("Tank accel Z", m["acceleration"] / G, fs, unit="g", spec=12, node=1),
        _d58("Load cells", m["force"], fs, unit="", spec=0, node=2),
    ])
    with pytest.raises(RecordError, match=r"'Load cells'.*no unit.*units="):
        read_record(path)
    rec = read_uff58(path, names={"Load cells": "force"}, units={"force": "N"})
    assert rec.names == ["acceleration", "force"]
    assert rec.units["acceleration"] == "g" and rec.fs == fs
    rec = rec.to_si()
    # ASCII UFF keeps 12 significant digits
    np.testing.assert_allclose(rec["acceleration"], m["acceleration"], rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(rec["force"], m["force"], rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(rec.time, m["time"] - m["time"][0] + rec.time[0], atol=1e-12)
    ch = rec.attrs["uff_channels"]
    assert [c["direction"] for c in ch] == ["+Z", "+Z"]
    assert ch[1]["unit_from"] == "units="

    pre = preprocess(rec, Tank())
    err = pre["dynamic_force"] - m["true_dynamic_force"]
    # preprocessing recovers the rig's true dynamic force from the UFF data
    assert np.sqrt(np.mean(err**2)) < 0.1 * np.std(m["true_dynamic_force"])

    from sloshrom.rom.tdnn.estimators import NFIR

    u, y = pre["velocity"], pre["dynamic_force"]
    model = NFIR(delays=21, neurons=10, max_epochs=30, seed=0).fit(u, y, fs=pre.fs)
    rel = np.sqrt(np.mean((model.predict(u) - y) ** 2)) / np.std(y)
    # measured 0.35 (a zero predictor gives 1.0)
    assert rel < 0.5, f"tiny NFIR on the UFF record: relative RMS error {rel:.3f}"


def test_uff_suffixes_go_through_read_record(tmp_path):
    t = np.arange(300) / 250.0
    rec = Record(t, 250.0, {"acceleration": np.sin(9 * t), "force": np.cos(4 * t)},
                 {"acceleration": "m/s^2", "force": "kN"})
    for suffix, binary in ((".uff", False), (".unv", True)):
        p = write_uff58(rec, tmp_path / f"r{suffix}", binary=binary)
        back = read_record(p)  # converts to SI
        assert back.units == {"time": "s", "acceleration": "m/s^2", "force": "N"}
        np.testing.assert_allclose(back["force"], 1e3 * rec["force"], rtol=1e-9)
        assert back.fs == 250.0
    assert not [f for f in tmp_path.iterdir() if f.name.startswith(".")]


def test_si_dataset_164_supplies_units(tmp_path):
    fs = 100.0
    d164 = pyuff.prepare_164(units_code=1, units_description="SI", temp_mode=2, length=1.0,
                             force=1.0, temp=1.0, temp_offset=273.15, return_full_dict=True)
    path = _write(tmp_path / "si.uff", [d164, _d58("a", np.ones(50), fs, spec=12),
                                        _d58("f", np.zeros(50), fs, spec=13, node=2)])
    rec = read_uff58(path)
    assert rec.units == {"time": "s", "acceleration": "m/s^2", "force": "N"}


def test_non_time_functions_are_skipped_or_refused(tmp_path):
    fs = 100.0
    frf = _d58("FRF", np.ones(50), fs, unit="g/N", func_type=4)
    with pytest.raises(RecordError, match="no time-response channels"):
        read_uff58(_write(tmp_path / "frf.uff", [frf]))
    rec = read_uff58(_write(tmp_path / "mix.uff",
                            [frf, _d58("acc", np.ones(50), fs, unit="g", spec=12)]))
    assert rec.names == ["acceleration"] and rec.attrs["uff_skipped_non_time_datasets"] == 1


@pytest.mark.parametrize(
    ("second", "match"),
    [
        (dict(data=np.ones(40), fs=100.0), "different lengths"),
        (dict(data=np.ones(50), fs=200.0), "different sample rates"),
        (dict(data=np.ones(50), fs=100.0, t0=1.0), "start at different times"),
    ],
)
def test_mismatched_channels(tmp_path, second, match):
    a = _d58("acc", np.ones(50), 100.0, unit="g", spec=12)
    b = _d58("force", unit="N", spec=13, node=2, **second)
    with pytest.raises(RecordError, match=match):
        read_uff58(_write(tmp_path / "bad.uff", [a, b]))


def test_bad_files_and_names(tmp_path):
    junk = tmp_path / "junk.uff"
    junk.write_text("this is not\na universal file\n")
    with pytest.raises(RecordError, match="truncated or not a UFF file"):
        read_record(junk)
    junk.write_text("    -1\n    15\n    -1\n")  # only an unsupported dataset
    with pytest.raises(RecordError, match="no time-response channels"):
        read_record(junk)
    empty = tmp_path / "empty.unv"
    empty.write_bytes(b"")
    with pytest.raises(RecordError, match="file is empty"):
        read_record(empty)
    p = _write(tmp_path / "two.uff", [_d58("a1", np.ones(50), 100.0, unit="g", spec=12),
                                      _d58("a2", np.ones(50), 100.0, unit="g", spec=12)])
    # two accelerometers: named after their labels, or as the user says
    assert read_uff58(p).names == ["a1", "a2"]
    assert read_uff58(p, names={0: "acceleration", "a2": "top"}).names == ["acceleration", "top"]
    with pytest.raises(RecordError, match="two channels map to the variable 'x'"):
        read_uff58(p, names={0: "x", 1: "x"})
    with pytest.raises(RecordError, match="unknown channel"):
        read_uff58(p, names={"nope": "x"})


def test_nan_and_truncated_files(tmp_path):
    p = _write(tmp_path / "n.uff", [_d58("force", np.r_[np.ones(49), 7.0], 100.0, unit="N")])
    text = p.read_text()
    p.write_text(text.replace("   7.00000000000e+00", "                 nan"))
    with pytest.raises(RecordError, match=r"'force' contains NaN/inf \(first at sample 49"):
        read_record(p)
    p.write_text(text[: len(text) // 2])
    with pytest.raises(RecordError, match="n.uff: truncated or not a UFF file"):
        read_record(p)


@pytest.mark.long  # 3.2-3.5 s in the fast tier under load
def test_cli_train_on_uff(tmp_path, rig_measurement):
    """`sloshrom train` on UFF58 files (velocity and dynamic force channels)."""
    from typer.testing import CliRunner

    import sloshrom.cli.rom  # noqa: F401  (registers `train` on the app)
    from sloshrom.cli import app
    from sloshrom.io import record_from_measurement
    from sloshrom.rom.loading import load_model

    rec = record_from_measurement(rig_measurement, truth=False)
    path = write_uff58(rec, tmp_path / "pre.uff")
    assert read_uff58(path).names == ["acceleration", "force", "velocity", "dynamic_force"]
    res = CliRunner().invoke(app, ["train", "--data", str(path), "--validation", str(path),
                                   "--delays", "10", "--neurons", "4", "--max-epochs", "3",
                                   "--out", str(tmp_path / "m.npz")])
    assert res.exit_code == 0, res.output
    model = load_model(tmp_path / "m.npz")
    assert model.fs_ == 500.0


def test_cli_import_uff(tmp_path, rig_measurement):
    """`sloshrom import uff`: raw shaker UFF -> preprocessed record, and its errors."""
    from typer.testing import CliRunner

    import sloshrom.cli.export  # noqa: F401  (registers `import` and `export`)
    from sloshrom.cli import app

    m = rig_measurement
    fs = float(m["fs"])
    raw = _write(tmp_path / "raw.uff", [
        _d58("Tank Z", m["acceleration"] / G, fs, unit="g", node=1),
        _d58("Load cell", m["force"], fs, unit="", node=2),
    ])
    runner = CliRunner()
    out = tmp_path / "pre.nc"
    res = runner.invoke(app, ["import", "uff", str(raw), str(out), "--name", "Tank Z=acceleration",
                              "--name", "1=force", "--unit", "force=N"])
    assert res.exit_code == 0, res.output
    rec = read_record(out)
    assert rec.names == ["acceleration", "force", "velocity", "dynamic_force"]
    err = rec["dynamic_force"] - m["true_dynamic_force"]
    assert np.sqrt(np.mean(err**2)) < 0.1 * np.std(m["true_dynamic_force"])
    for args, match in [
        (["--name", "Tank Z=acceleration", "--name", "1=force"], "'Load cell'.*no unit"),
        (["--name", "Tank Z"], "--name must look like CHANNEL=VARIABLE"),
        (["--name", "Tank Z=acceleration", "--unit", "load_cell=N"],
         r"missing variable\(s\) 'force'"),
    ]:
        bad = tmp_path / "bad.nc"
        res = runner.invoke(app, ["import", "uff", str(raw), str(bad), *args])
        assert res.exit_code != 0 and isinstance(res.exception, SystemExit), res.output
        assert re.search(match, res.output), res.output
        assert not bad.exists()
