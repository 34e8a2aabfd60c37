"""Records: construction, NetCDF/CSV/MAT round trips, units, preprocessing, resampling."""

from __future__ import annotations

import h5py
import numpy as np
import pytest
import scipy.io

from sloshrom.config import G, Tank
from sloshrom.io import (
    Record,
    canonical_unit,
    dynamic_force,
    preprocess,
    read_record,
    resample,
    velocity_from_acceleration,
    write_record,
)
from sloshrom.signals import harmonic, vfa

FS = 500.0


def _record(n=2000, fs=FS):
    rng = np.random.default_rng(0)
    t = np.arange(n) / fs
    return Record(
        t,
        fs,
        {
            "acceleration": rng.standard_normal(n),
            "force": rng.standard_normal(n) * 3.0,
            "velocity": rng.standard_normal(n) * 0.1,
        },
        {"acceleration": "m/s^2", "force": "N", "velocity": "m/s"},
        {"tank": Tank(fill=0.4), "fill": 0.4, "provenance": {"seed": 3, "note": "test"}},
    )


def test_record_basics():
    r = _record()
    assert r.fs == FS and len(r) == 2000 and r.names == ["acceleration", "force", "velocity"]
    assert r.units["time"] == "s" and r["time"] is r.time
    assert r.tank == Tank(fill=0.4)
    # fs derived from time
    r2 = Record(r.time, None, r.variables, r.units)
    assert r2.fs == pytest.approx(FS)
    # unit spellings normalised, values untouched; to_si converts
    r3 = Record(r.time, FS, {"a": r["acceleration"], "x": r["force"]}, {"a": "m/s2", "x": "g"})
    assert r3.units == {"time": "s", "a": "m/s^2", "x": "g"}
    np.testing.assert_array_equal(r3["x"], r["force"])
    np.testing.assert_allclose(r3.to_si()["x"], r["force"] * G)
    assert r3.to_si().units["x"] == "m/s^2"


@pytest.mark.parametrize(
    ("unit", "si", "k"),
    [
        ("m/s²", "m/s^2", 1.0),
        ("m s-2", "m/s^2", 1.0),
        ("G", "m/s^2", G),
        ("mm", "m", 1e-3),
        ("kN", "N", 1e3),
        ("mN", "N", 1e-3),
        ("newton", "N", 1.0),
        ("ms", "s", 1e-3),
        ("furlong", "furlong", 1.0),
    ],
)
def test_canonical_unit(unit, si, k):
    assert canonical_unit(unit) == (si, k)


def test_netcdf_round_trip(tmp_path):
    r = _record()
    beam = Record(
        r.time,
        FS,
        {"station_acceleration": np.ones((2000, 3)), "dynamic_force": r["force"]},
        {"station_acceleration": "m/s^2", "dynamic_force": "N"},
    )
    for rec, name in ((r, "a.nc"), (beam, "b.nc")):
        path = write_record(rec, tmp_path / name)
        back = read_record(path)
        assert back.names == rec.names and back.units == rec.units and back.fs == rec.fs
        np.testing.assert_array_equal(back.time, rec.time)
        for k in rec.names:
            np.testing.assert_array_equal(back[k], rec[k])
    back = read_record(tmp_path / "a.nc")
    assert back.tank == Tank(fill=0.4)
    assert back.attrs["provenance"] == {"seed": 3, "note": "test"}
    assert back.attrs["fill"] == 0.4
    assert read_record(tmp_path / "b.nc").dims == {"station_acceleration": "station"}
    # no temporary files left behind
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.nc", "b.nc"]


def test_netcdf_units_converted_on_read(tmp_path):
    r = _record()
    ds = r.to_dataset()
    ds["acceleration"].attrs["units"] = "g"
    ds["force"].attrs["units"] = "kN"
    ds.to_netcdf(tmp_path / "x.nc", engine="h5netcdf")
    back = read_record(tmp_path / "x.nc")
    np.testing.assert_allclose(back["acceleration"], r["acceleration"] * G)
    np.testing.assert_allclose(back["force"], r["force"] * 1e3)
    assert back.units["acceleration"] == "m/s^2" and back.units["force"] == "N"
    raw = read_record(tmp_path / "x.nc", si=False)
    assert raw.units["acceleration"] == "g"
    # CF-style time units stay numeric seconds (no datetime/timedelta decoding)
    for tu, k in (("seconds since 2024-01-01 00:00:00", 1.0), ("milliseconds", 1e-3)):
        ds = r.to_dataset()
        ds["time"] = ("time", r.time / k, {"units": tu})
        ds.to_netcdf(tmp_path / "t.nc", engine="h5netcdf")
        np.testing.assert_allclose(read_record(tmp_path / "t.nc").time, r.time, rtol=1e-12)


def test_csv_round_trip_and_layouts(tmp_path):
    r = _record(200)
    write_record(r, tmp_path / "r.csv")
    back = read_record(tmp_path / "r.csv")
    assert back.units == r.units
    for k in r.names:
        np.testing.assert_array_equal(back[k], r[k])  # %.17g is exact
    # a units row, semicolons, mm and g, no time column: fs given
    t = np.arange(5) / 100.0
    text = "# exported by a DAQ\ndisp;acc\nmm;g\n" + "\n".join(
        f"{1.0 * i};{0.5 * i}" for i in range(5)
    )
    (tmp_path / "u.csv").write_text(text)
    u = read_record(tmp_path / "u.csv", fs=100.0)
    np.testing.assert_allclose(u.time, t)
    np.testing.assert_allclose(u["disp"], np.arange(5) * 1e-3)
    np.testing.assert_allclose(u["acc"], np.arange(5) * 0.5 * G)
    # "name (unit)" headers and a time column in ms
    (tmp_path / "p.csv").write_text("time (ms),force (mN)\n0,1\n2,2\n4,3\n")
    p = read_record(tmp_path / "p.csv")
    assert p.fs == pytest.approx(500.0)
    np.testing.assert_allclose(p["force"], [1e-3, 2e-3, 3e-3])
    # units supplied by the caller
    (tmp_path / "n.csv").write_text("time,acceleration\n0,1\n0.5,2\n")
    n = read_record(tmp_path / "n.csv", units={"acceleration": "m/s2"})
    assert n.fs == 2.0 and n.units["acceleration"] == "m/s^2"


def test_mat_v5_round_trip_and_struct(tmp_path):
    r = _record(300)
    write_record(r, tmp_path / "r.mat")
    back = read_record(tmp_path / "r.mat")
    assert back.units == r.units and back.fs == r.fs
    for k in r.names:
        np.testing.assert_array_equal(back[k], r[k])
    # everything inside one struct, fs instead of time, row vectors, units as <name>_units
    s = {"fs": 100.0, "acc": np.arange(10.0)[None, :], "acc_units": "g", "mass": 0.2}
    scipy.io.savemat(tmp_path / "s.mat", {"test1": s})
    m = read_record(tmp_path / "s.mat")
    np.testing.assert_allclose(m["acc"], np.arange(10.0) * G)
    np.testing.assert_allclose(m.time, np.arange(10) / 100.0)
    assert m.names == ["acc"]


def _write_mat73(path, columns, units):
    """A MATLAB v7.3 file as MATLAB writes it (HDF5, column-major, char as uint16)."""
    with h5py.File(path, "w", userblock_size=512) as fh:
        for k, v in columns.items():
            d = fh.create_dataset(k, data=np.asarray(v, dtype=float)[None, :])  # MATLAB n x 1
            d.attrs["MATLAB_class"] = np.bytes_("double")
        g = fh.create_group("units")
        g.attrs["MATLAB_class"] = np.bytes_("struct")
        for k, u in units.items():
            d = g.create_dataset(k, data=np.array([[ord(c)] for c in u], dtype=np.uint16))
            d.attrs["MATLAB_class"] = np.bytes_("char")
    with open(path, "r+b") as fh:
        text = b"MATLAB 7.3 MAT-file, Platform: GLNXA64, HDF5 schema 1.00 ."
        fh.write(text.ljust(116, b" ") + b" " * 8 + b"\x00\x02" + b"IM")


def test_mat_v73(tmp_path):
    r = _record(300)
    cols = {"time": r.time, **r.variables}
    _write_mat73(
        tmp_path / "r73.mat", cols, {"acceleration": "g", "force": "N", "velocity": "mm/s"}
    )
    assert h5py.is_hdf5(tmp_path / "r73.mat")
    with pytest.raises(NotImplementedError):  # scipy cannot read it: the h5py path is needed
        scipy.io.loadmat(tmp_path / "r73.mat")
    back = read_record(tmp_path / "r73.mat")
    assert back.fs == pytest.approx(FS)
    np.testing.assert_allclose(back["acceleration"], r["acceleration"] * G)
    np.testing.assert_allclose(back["velocity"], r["velocity"] * 1e-3)
    np.testing.assert_array_equal(back["force"], r["force"])


def test_velocity_from_acceleration_harmonic():
    h = harmonic(FS, 10.0, 0.005, n_cycles=30)
    v = velocity_from_acceleration(h.acceleration, FS)
    vmax = np.abs(h.velocity).max()
    # The harmonic's ramp makes acceleration jump at its ends (a 1.4 % step), which sampling
    # cannot represent exactly: ~1e-3 at worst; steady cycles are what the energy uses.
    assert np.abs(v - h.velocity).max() < 2e-3 * vmax
    # accelerometer offset and a slow (0.2 Hz) drift are removed by the high-pass
    drift = 0.05 + 0.05 * np.sin(2 * np.pi * 0.2 * h.time)
    v2 = velocity_from_acceleration(h.acceleration + drift, FS)
    assert np.abs(v2 - h.velocity)[h.steady].max() < 5e-3 * vmax
    v_nohp = velocity_from_acceleration(h.acceleration + drift, FS, f_highpass=0.0)
    assert np.abs(v_nohp - h.velocity)[h.steady].max() > 5e-2 * vmax  # the drift is real
    # batched along a leading axis
    vb = velocity_from_acceleration(np.stack([h.acceleration, 2 * h.acceleration]), FS)
    np.testing.assert_allclose(vb[1], 2 * v, atol=1e-12)


def test_velocity_from_acceleration_vfa_smooth():
    p = vfa(FS, "validation", duration=60.0)
    v = velocity_from_acceleration(p.acceleration, FS)
    assert np.abs(v - p.velocity).max() < 1e-5 * np.abs(p.velocity).max()


def test_preprocess_recovers_dynamic_force():
    tank = Tank()
    p = vfa(FS, "validation", duration=60.0)
    # a synthetic "sloshing" force with memory, plus the rigid inertia the load cells also see
    true_df = 0.3 * np.sin(2 * np.pi * 3.0 * p.time) * (np.abs(p.acceleration) > 2 * G)
    m = tank.liquid_mass + tank.structure_mass
    force = -m * p.acceleration + true_df
    raw = Record(
        p.time,
        FS,
        {"acceleration": p.acceleration / G, "force": force * 1e3},  # in g and mN
        {"acceleration": "g", "force": "mN"},
        {"tank": tank},
    )
    out = preprocess(raw)
    assert set(out.names) >= {"acceleration", "force", "velocity", "dynamic_force"}
    assert out.units["dynamic_force"] == "N" and out.units["velocity"] == "m/s"
    np.testing.assert_allclose(out["dynamic_force"], true_df, atol=1e-9 * np.abs(force).max())
    assert np.abs(out["velocity"] - p.velocity).max() < 1e-5 * np.abs(p.velocity).max()
    assert out.attrs["preprocessing"]["structure_mass"] == tank.structure_mass
    # a wrong structure mass leaves an inertial residue proportional to acceleration
    wrong = preprocess(raw, tank=tank.replace(structure_mass=0.40))
    resid = wrong["dynamic_force"] - true_df
    np.testing.assert_allclose(resid, -0.05 * p.acceleration, atol=1e-9)


def test_dynamic_force_sign():
    acc = np.array([0.0, 1.0, -2.0])
    np.testing.assert_allclose(dynamic_force(-0.5 * acc, acc, 0.1, 0.4), 0.0)


def test_resample_polyphase():
    t = np.arange(5000) / 5000.0
    x = np.sin(2 * np.pi * 10 * t) + 0.5 * np.sin(2 * np.pi * 400 * t)  # 400 Hz aliases at 500
    r = Record(t, 5000.0, {"x": x, "y": np.c_[x, -x]}, {"x": "m", "y": "m"})
    d = resample(r, 500.0)
    assert d.fs == 500.0 and len(d) == 500 and d["y"].shape == (500, 2)
    clean = np.sin(2 * np.pi * 10 * d.time)
    inner = slice(50, -50)
    assert np.abs(d["x"] - clean)[inner].max() < 5e-3  # anti-aliased: the 400 Hz is gone
    assert d.attrs["resampled_from_fs"] == 5000.0
    u = resample(d, 1500.0)
    assert len(u) == 1500 and u.fs == 1500.0


# -- sloshrom rig (CLI) with a stand-in rig ------------------------------------------------------
class _FakeRig:
    """Stand-in for sloshrom.rig.VirtualRig: coarse step, a known dynamic force, rigid inertia."""

    def __init__(self, tank=None, params=None, sensors=None, seed=0):
        self.tank = Tank() if tank is None else tank
        self.dt = 1e-3
        self.seed = seed

    def measure(self, acceleration):
        acc = np.asarray(acceleration)[::2]  # "acquisition" at 500 Hz
        t = np.arange(acc.size) / 500.0
        df = 0.05 * np.tanh(acc / G)  # some nonlinear force
        m = self.tank.liquid_mass + self.tank.structure_mass
        vel = np.concatenate(([0.0], np.cumsum(0.5 * (acc[1:] + acc[:-1])) / 500.0))
        return {
            "fs": 500.0,
            "time": t,
            "acceleration": acc,
            "force": -m * acc + df,
            "true_velocity": vel,
            "true_dynamic_force": df,
        }


@pytest.fixture
def fake_rig(monkeypatch):
    import sys
    import types

    mod = types.ModuleType("sloshrom.rig.virtual")
    mod.VirtualRig = _FakeRig
    monkeypatch.setitem(sys.modules, "sloshrom.rig.virtual", mod)
    return mod


def test_cli_rig_vfa_and_harmonic(tmp_path, fake_rig):
    from typer.testing import CliRunner

    import sloshrom.cli.rig  # noqa: F401  (registers the sub-command)
    from sloshrom.cli._app import app

    runner = CliRunner()
    (tmp_path / "tank.toml").write_text("[tank]\nstructure_mass = 0.3\n")
    out = tmp_path / "v.nc"
    res = runner.invoke(
        app,
        ["rig", "vfa", "--split", "validation", "--duration", "20", "--out", str(out),
         "--seed", "4", "--tank", str(tmp_path / "tank.toml"), "--fill", "0.4"],
    )  # fmt: skip
    assert res.exit_code == 0, res.output
    rec = read_record(out)
    for name in ("acceleration", "velocity", "force", "dynamic_force", "true_dynamic_force"):
        assert name in rec
    assert rec.fs == 500.0 and rec.duration == pytest.approx(20.0, abs=0.01)
    assert rec.tank == Tank(fill=0.4, structure_mass=0.3)
    assert rec.attrs["seed"] == 4 and rec.attrs["split"] == "validation"
    prov = rec.attrs["provenance"]
    assert prov["signal"]["split"] == "validation" and "sloshrom_version" in prov
    np.testing.assert_allclose(rec["dynamic_force"], rec["true_dynamic_force"], atol=1e-9)
    vmax = np.abs(rec["velocity"]).max()
    assert np.abs(rec["velocity"] - rec["true_velocity"]).max() < 1e-2 * vmax

    out2 = tmp_path / "h.nc"
    res = runner.invoke(
        app, ["rig", "harmonic", "-f", "12", "--accel-g", "2", "--out", str(out2), "--no-truth"]
    )
    assert res.exit_code == 0, res.output
    h = read_record(out2)
    assert "true_dynamic_force" not in h
    assert np.abs(h["acceleration"]).max() == pytest.approx(2 * G, rel=0.02)
    assert h.attrs["provenance"]["signal"]["accel_g"] == pytest.approx(2.0)

    res = runner.invoke(app, ["rig", "harmonic", "-f", "12", "--out", str(out2)])
    assert res.exit_code == 2 and "exactly one of" in res.output
    res = runner.invoke(app, ["rig", "vfa", "--split", "test", "--out", str(out)])
    assert res.exit_code == 2 and "--split" in res.output
    res = runner.invoke(app, ["rig", "vfa", "--help"])
    assert res.exit_code == 0 and "Example" in res.output


@pytest.mark.slow
def test_cli_rig_real_harmonic(tmp_path):
    """The real virtual rig through the CLI: record complete, preprocessing matches its truth."""
    from typer.testing import CliRunner

    import sloshrom.cli.rig  # noqa: F401
    from sloshrom.cli._app import app

    out = tmp_path / "h.nc"
    res = CliRunner().invoke(
        app, ["rig", "harmonic", "-f", "12", "--accel-g", "4", "--out", str(out), "--seed", "1"]
    )
    assert res.exit_code == 0, res.output
    rec = read_record(out)
    for name in ("acceleration", "velocity", "force", "dynamic_force"):
        assert rec.units[name] == {"acceleration": "m/s^2", "velocity": "m/s"}.get(name, "N")
    vt, ft = rec["true_velocity"], rec["true_dynamic_force"]
    assert np.abs(rec["velocity"] - vt).max() < 5e-3 * np.abs(vt).max()
    # at 4 g the liquid slams: a large dynamic force, recovered up to the load-cell noise
    rms = np.sqrt(np.mean(ft**2))
    assert rms > 0.5
    assert np.sqrt(np.mean((rec["dynamic_force"] - ft) ** 2)) < 0.02 * rms


@pytest.mark.slow
def test_preprocessing_exact_on_noise_free_rig():
    """Without sensor noise, preprocessing the real rig's output recovers its truth."""
    import sloshrom.rig.virtual as rig_mod
    from sloshrom.io import record_from_measurement

    rig = rig_mod.VirtualRig(sensors=rig_mod.SensorParams(force_noise=0.0, acceleration_noise=0.0))
    p = vfa(1.0 / rig.dt, "validation", duration=20.0)
    rec = record_from_measurement(rig.measure(p.acceleration), rig.tank)
    ft, vt = rec["true_dynamic_force"], rec["true_velocity"]
    assert np.sqrt(np.mean(ft**2)) > 0.5  # the path reaches the violent regime
    np.testing.assert_allclose(rec["dynamic_force"], ft, rtol=0, atol=1e-9)
    assert np.abs(rec["velocity"] - vt).max() < 1e-4 * np.abs(vt).max()  # measured 9.5e-6
