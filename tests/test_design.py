"""`sloshrom design`: the identification programme as drive files (CSV, UFF 58, programme.json),
its shaker check, and `sloshrom rig play` of a drive file."""

from __future__ import annotations

import json
import re

import numpy as np
import pytest
from typer.testing import CliRunner

from helpers import TINY_DESIGN_TOML
from sloshrom.cli import app
from sloshrom.config import G
from sloshrom.io.programme import (
    CSV_DECIMALS,
    read_drive_csv,
    resample_drive,
    time_decimals,
    write_drive_csv,
)
from sloshrom.pipeline import Context, settings
from sloshrom.pipeline import data as data_stage
from sloshrom.rig.limits import RIG_RATE
from sloshrom.signals import ShakerLimits

EPS = np.finfo(float).eps
#: A "use" programme of five short segments (two VFA pieces, two random levels, one decay).
TINY = {"data": {"design": "use", "train_duration": 12.0, "validation_duration": 12.0,
                 "extension_duration": 20.0, "random_factors": [1.0],
                 "random_duration": 10.0, "decay_factors": [1.0], "decay_duration": 3.0},
        "beam": {"free_duration": 3.0, "random_duration": 40.0, "rms_g": [0.1, 0.3]}}


@pytest.fixture(scope="module")
def cfg():
    return settings.validate(settings.merge(settings.defaults(), TINY))


@pytest.fixture(scope="module")
def prog(cfg):
    return data_stage.programme(cfg, cfg.tank.tank(), "train", RIG_RATE)


@pytest.fixture(scope="module")
def written(tmp_path_factory):
    """`sloshrom design` at the programme's own rate (no resampling), train split."""
    d = tmp_path_factory.mktemp("design")
    (d / "tiny.toml").write_text(TINY_DESIGN_TOML)
    res = CliRunner().invoke(app, ["design", "--out", str(d / "out"), "--config",
                                   str(d / "tiny.toml"), "--split", "train", "--fs",
                                   str(int(RIG_RATE)), "--segment-column",
                                   "--format", "csv,uff"])
    assert res.exit_code == 0, res.output
    return d / "out", res.output


def _integrals(a: np.ndarray, fs: float) -> tuple[np.ndarray, np.ndarray]:
    v = np.concatenate([[0.0], np.cumsum(0.5 * (a[1:] + a[:-1]))]) / fs
    x = np.concatenate([[0.0], np.cumsum(0.5 * (v[1:] + v[:-1]))]) / fs
    return v, x


# -- the programme ---------------------------------------------------------------------------------
def test_programme_segments(prog):
    assert [s.name for s in prog.segments] == ["vfa", "vfa extension", "random 0.1 g",
                                               "random 0.3 g", "decay 1.00"]
    assert prog.fs == RIG_RATE and prog.pause == 0.0


def test_each_segment_starts_and_ends_at_rest(prog):
    for s in prog.segments:
        a = s.acceleration
        v, x = _integrals(a, prog.fs)
        peak = np.max(np.abs(a))
        assert max(abs(a[0]), abs(a[-1])) <= 1e-9 * peak, s.name
        # worst-case round-off of a running sum of n terms: n eps sum|terms|
        n = a.size
        tol_v = n * EPS * np.sum(np.abs(a)) / prog.fs
        tol_x = n * EPS * np.sum(np.abs(v)) / prog.fs
        if s.kind == "vfa":
            # a VFA is at rest analytically (w, w', w'' zero at both ends: signals.VFA); its
            # samples' trapezoidal sums differ from the exact integrals by the sampling error,
            # 1e-8 of the peak velocity at 10 kHz: nanometres, not round-off
            tol_v = max(tol_v, 1e-7 * np.max(np.abs(v)))
            tol_x = max(tol_x, 2e-5 * np.max(np.abs(x)))
        assert abs(v[-1]) <= tol_v, (s.name, v[-1], tol_v)
        assert abs(x[-1]) <= tol_x, (s.name, x[-1], tol_x)
        # and the tolerance is meaningful: far below the segment's own motion
        assert tol_v < 1e-6 * np.max(np.abs(v)) and tol_x < 1e-4 * np.max(np.abs(x))


def test_check_names_the_limit_exceeded(prog):
    m = prog.motion()
    roomy = ShakerLimits(2 * m["displacement"], 2 * m["velocity"], 2 * m["acceleration"])
    assert prog.check(roomy) == []
    assert prog.check(roomy, max_duration=2 * prog.duration) == []
    low_acc = ShakerLimits(2 * m["displacement"], 2 * m["velocity"], 0.9 * m["acceleration"])
    (msg,) = prog.check(low_acc)
    assert "acceleration" in msg and f"{m['acceleration'] / G:.4g} g" in msg
    low_stroke = ShakerLimits(0.5 * m["displacement"], 2 * m["velocity"],
                              2 * m["acceleration"])
    assert ["stroke" in t for t in prog.check(low_stroke)] == [True]
    assert ["duration" in t for t in prog.check(roomy, max_duration=1.0)] == [True]
    out = data_stage.programme_outputs(prog, low_acc)
    assert not out["fits"] and out["exceeds"] == [msg]
    assert out["verdict"].startswith("needs a bigger shaker")
    assert data_stage.programme_outputs(prog, roomy)["fits"]


def test_programme_outputs(prog):
    out = data_stage.programme_outputs(prog, setup=30.0)
    assert [s["name"] for s in out["segments"]] == [s.name for s in prog.segments]
    assert out["duration_s"] == pytest.approx(prog.duration, abs=5e-4)  # to the ms
    assert out["lab_time_s"] == pytest.approx(prog.duration + 30.0 * 5, abs=5e-4)
    assert out["peaks"]["acceleration_g"] == pytest.approx(prog.motion()["acceleration"] / G)
    assert max(s["peaks"]["stroke_mm"] for s in out["segments"]) == pytest.approx(
        out["peaks"]["stroke_mm"], rel=1e-5)  # the VFAs' sampling leaves ~0.1 um
    ends = [s["start_s"] + s["duration_s"] for s in out["segments"]]
    assert ends[-1] == pytest.approx(out["duration_s"], abs=1e-3)
    # the "use" design is beyond the paper's shaker, and says so
    assert not out["fits"] and "acceleration" in " ".join(out["exceeds"])
    json.dumps(out)


class _Stop(Exception):
    pass


def test_stage_data_plays_the_programme_function(cfg, tmp_path, monkeypatch):
    calls, played = {}, []
    real = data_stage.programme

    def spy(*args, **kw):
        p = real(*args, **kw)
        calls[args[2]] = (args, p)
        return p

    def measure(self, acceleration):
        played.append(np.asarray(acceleration))
        raise _Stop

    monkeypatch.setattr(data_stage, "programme", spy)
    from sloshrom.rig.virtual import VirtualRig

    monkeypatch.setattr(VirtualRig, "measure", measure)
    with pytest.raises(_Stop):
        data_stage.stage_data(Context(tmp_path, cfg))
    # each record played as its programme makes it (both, in threads; only the first where
    # numba's threading layer makes them run in turn)
    assert "train" in calls and set(calls) <= {"train", "validation"}
    assert len(played) == len(calls)
    for (*_, fs), prog in calls.values():
        assert fs == RIG_RATE
        assert any(np.array_equal(a, prog.acceleration()) for a in played)


# -- drive files -----------------------------------------------------------------------------------
def test_design_csv_reads_back_as_the_programme(written, prog):
    out, _ = written
    d = read_drive_csv(out / "train.csv")
    assert d.fs == RIG_RATE and d.column == "acceleration_m_s2"
    a = prog.acceleration()
    assert d.acceleration.size == a.size
    # CSV_DECIMALS written: half a unit of the last decimal (with the decimal's round-off)
    half = 0.5 * 10.0**-CSV_DECIMALS
    np.testing.assert_allclose(d.acceleration, a, rtol=0, atol=half * (1 + 1e-9))
    assert np.max(np.abs(d.acceleration - a)) > 0.1 * half  # it is rounded, not exact
    sizes = [s.acceleration.size for s in prog.segments]
    np.testing.assert_array_equal(d.segment, np.repeat(np.arange(1, 6), sizes))
    t = np.loadtxt(out / "train.csv", delimiter=",", skiprows=1, usecols=0)
    np.testing.assert_allclose(t, np.arange(a.size) / RIG_RATE, rtol=0, atol=5.1e-10)
    lines = (out / "train.csv").read_text().splitlines()
    assert lines[0] == "time_s,acceleration_m_s2,segment"
    # 10 kHz: the step 0.0001 s written with 4 decimals, a rest as 0 (never -0)
    assert lines[1] == "0.0000,0.000000,1" and lines[2].startswith("0.0001,")
    assert not any(",-0.000000," in ln for ln in lines[1:])


def test_design_uff_has_the_unit_rate_and_samples(written, prog):
    import pyuff

    out, _ = written
    sets = pyuff.UFF(str(out / "train.uff")).read_sets()
    d58 = [s for s in sets if s["type"] == 58]
    assert [s["id1"].strip() for s in d58] == [s.name for s in prog.segments]
    for s, seg in zip(d58, prog.segments, strict=True):
        assert s["ordinate_axis_units_lab"].strip() == "m/s^2"
        assert s["ordinate_spec_data_type"] == 12 and s["func_type"] == 1
        assert 1.0 / s["abscissa_inc"] == pytest.approx(RIG_RATE, rel=1e-12)
        assert s["num_pts"] == seg.acceleration.size
        np.testing.assert_allclose(s["data"], seg.acceleration, rtol=5.1e-12, atol=1e-300)
    assert sets[0]["type"] == 164


def test_design_summary_and_console(written, prog):
    out, console = written
    s = json.loads((out / "programme.json").read_text())
    tr = s["splits"]["train"]
    assert [g["name"] for g in tr["segments"]] == [g.name for g in prog.segments]
    assert tr["duration_s"] == pytest.approx(prog.duration, abs=5e-4)
    assert tr["files"] == {"csv": "train.csv", "uff": "train.uff"}
    # times to the millisecond (the segments as configured: 12 s, not 12.0001 s), samples
    # exact
    cfg_data = TINY["data"]
    assert [g["duration_s"] for g in tr["segments"]] == [
        cfg_data["train_duration"], cfg_data["extension_duration"],
        cfg_data["random_duration"], cfg_data["random_duration"], cfg_data["decay_duration"]]
    n = np.cumsum([0] + [g.acceleration.size for g in prog.segments])
    assert [g["first_sample"] for g in tr["segments"]] == list(n[:-1])
    assert [g["samples"] for g in tr["segments"]] == list(np.diff(n))
    assert [g["start_s"] for g in tr["segments"]] == [round(k / RIG_RATE, 3) for k in n[:-1]]
    assert tr["duration_s"] == round(n[-1] / RIG_RATE, 3)
    # the sizes: estimated before writing, said after
    flat = " ".join(console.split())
    est = float(re.search(r"as csv and uff: about (\S+) MB", flat).group(1))
    real = sum((out / f).stat().st_size for f in ("train.csv", "train.uff")) / 1e6
    assert 0.7 * real <= est <= 1.3 * real, (est, real)
    assert re.search(r"train\.csv \((\S+) [kM]B\)", flat), flat
    assert s["exceeds"] and all(t.startswith("train: peak") for t in s["exceeds"])
    assert "vfa extension" in console and "laboratory time" in console
    assert "exceeds the shaker's 6 g" in console
    # the segments beyond each limit by name, and the two ways out (said once)
    flat = " ".join(console.split())
    over = [g["name"] for g in tr["segments"] if g["peaks"]["acceleration_g"] > 6.0]
    assert over and f"beyond 6 g of acceleration: {', '.join(over)}" in flat, flat
    assert 'to fit this shaker: [data] design = "shaker"' in flat
    need = max(g["peaks"]["acceleration_g"] for g in tr["segments"])
    larger = float(re.search(r"--max-acceleration (\S+)", flat).group(1))
    assert need <= larger <= 1.1 * need, (need, larger)


def test_resampling_keeps_the_band_and_the_rest():
    fs, n = RIG_RATE, 40001
    t = np.arange(n) / fs
    w = np.sin(np.pi * t / t[-1]) ** 4  # at rest at both ends
    a = w * (np.sin(2 * np.pi * 25 * t) + 0.3 * np.sin(2 * np.pi * 190 * t))
    down = resample_drive(a, fs, 2000.0)
    assert down.size == 8001
    np.testing.assert_allclose(down, a[::5], atol=1e-4 * np.max(np.abs(a)))
    back = resample_drive(down, 2000.0, fs)
    assert back.size == n
    np.testing.assert_allclose(back, a, atol=2e-4 * np.max(np.abs(a)))
    # 500 Hz keeps 190 Hz (pass band 200 Hz) and a rational rate such as 2048 Hz works
    np.testing.assert_allclose(resample_drive(a, fs, 500.0), a[::20],
                               atol=1e-3 * np.max(np.abs(a)))
    assert resample_drive(a, fs, 2048.0).size == round(4.0 * 2048) + 1


def test_drive_csv_round_trip_in_g(tmp_path):
    a = np.array([0.0, 1.5, -2.25e-7, 0.0])
    p = write_drive_csv(tmp_path / "d.csv", a, 2048.0)
    d = read_drive_csv(p)
    assert d.fs == 2048.0
    np.testing.assert_allclose(d.acceleration, a, rtol=0, atol=0.5 * 10.0**-CSV_DECIMALS)
    # 1/2048 s needs 11 decimals: written to 9, within the reader's 1e-6 of a step
    assert p.read_text().splitlines()[2].startswith("0.000488281,")
    (tmp_path / "g.csv").write_text("time [s],acceleration [g]\n0,0\n0.001,1\n0.002,0\n")
    d = read_drive_csv(tmp_path / "g.csv")
    assert d.fs == 1000.0 and d.acceleration[1] == pytest.approx(G)


def test_time_decimals_write_each_step_exactly():
    assert [time_decimals(f) for f in (1.0, 10.0, 500.0, 2000.0, 10000.0, 2500.0)] == [
        0, 1, 3, 4, 4, 4]
    assert time_decimals(2048.0) == 9 and time_decimals(3.0) == 9


def test_design_writes_the_csv_alone_by_default(tmp_path):
    (tmp_path / "tiny.toml").write_text(TINY_DESIGN_TOML)
    res = CliRunner().invoke(app, ["design", "--out", str(tmp_path / "out"), "--config",
                                   str(tmp_path / "tiny.toml"), "--split", "train"])
    assert res.exit_code == 0, res.output
    assert sorted(p.name for p in (tmp_path / "out").iterdir()) == [
        ".sloshrom-written.json", "programme.json", "train.csv"]
    # about 20 bytes a sample at 2000 Hz, as the help says
    d = json.loads((tmp_path / "out" / "programme.json").read_text())
    n = d["splits"]["train"]["drive"]["samples"]
    per = (tmp_path / "out" / "train.csv").stat().st_size / n
    assert 14.0 <= per <= 22.0, per


# -- bad input -------------------------------------------------------------------------------------
@pytest.mark.parametrize("args, msg", [
    (["--max-stroke", "-1"], "--max-stroke must be > 0 mm"),
    (["--max-velocity", "0"], "--max-velocity must be > 0 m/s"),
    (["--format", "csv,xls"], "unknown format 'xls'"),
    (["--split", "test"], "--split must be"),
    (["--fs", "100"], "--fs must be in [500, 10000] Hz"),
    (["--pause", "-2"], "--pause must be"),
])
def test_design_refuses_bad_options(tmp_path, args, msg):
    res = CliRunner().invoke(app, ["design", "--out", str(tmp_path / "o"), *args])
    assert res.exit_code == 2
    assert msg in " ".join(res.output.split()), res.output
    assert not (tmp_path / "o").exists()


def test_design_strict_writes_nothing(tmp_path):
    (tmp_path / "tiny.toml").write_text(TINY_DESIGN_TOML)
    res = CliRunner().invoke(app, ["design", "--out", str(tmp_path / "o"), "--config",
                                   str(tmp_path / "tiny.toml"), "--split", "validation",
                                   "--strict", "--format", "csv"])
    assert res.exit_code == 1, res.output
    assert "exceeds the shaker's limits (--strict): nothing written" in res.output
    assert not (tmp_path / "o").exists()


@pytest.mark.parametrize("text, msg", [
    ("time_s,acceleration_m_s2\n0,0\n0.001,nan\n0.002,0\n", "line 3: NaN"),
    ("time_s,acceleration_m_s2\n0,0\n0.001,1\n0.0025,0\n0.003,0\n", "uniform time column"),
    ("time_s,acceleration_m_s2\n0,0\n0.001,1\n0.001,0\n", "does not increase"),
    ("time_ms,acceleration_m_s2\n0,0\n1,1\n", "expected a time column"),
    ("time_s,acceleration_mm_s2\n0,0\n0.001,1\n", "acceleration_m_s2"),
    ("time_s,acceleration_m_s2,force_n\n0,0,1\n0.001,1,1\n", "unknown column(s) ['force_n']"),
    ("time_s,acceleration_m_s2\n0,0\n0.001,abc\n", "not a numeric table"),
])
def test_rig_play_refuses_a_bad_drive(tmp_path, text, msg):
    p = tmp_path / "drive.csv"
    p.write_text(text)
    res = CliRunner().invoke(app, ["rig", "play", str(p), "--out", str(tmp_path / "r.nc")])
    assert res.exit_code == 2, res.output
    out = " ".join(res.output.split())
    assert msg in out and str(p) in out, out
    assert not (tmp_path / "r.nc").exists()


def test_rig_play_refuses_a_rate_it_cannot_take(tmp_path):
    p = write_drive_csv(tmp_path / "slow.csv", np.zeros(200), 40.0)
    res = CliRunner().invoke(app, ["rig", "play", str(p), "--out", str(tmp_path / "r.nc")])
    assert res.exit_code == 2 and "cannot carry the shaker band" in res.output


def test_rig_play_records_a_design_drive(tmp_path):
    from sloshrom.io import read_record

    fs = 2000.0
    t = np.arange(int(3 * fs) + 1) / fs
    a = 2 * G * np.sin(np.pi * t / t[-1]) ** 2 * np.sin(2 * np.pi * 12 * t)
    p = write_drive_csv(tmp_path / "train.csv", a, fs)
    res = CliRunner().invoke(app, ["rig", "play", str(p), "--out", str(tmp_path / "r.nc")])
    assert res.exit_code == 0, res.output
    rec = read_record(tmp_path / "r.nc")
    assert rec.duration == pytest.approx(3.0, abs=2e-3) and rec.fs == 500.0
    assert np.max(np.abs(rec["acceleration"])) == pytest.approx(2 * G, rel=0.05)
    assert rec.attrs["provenance"]["signal"]["file_fs"] == fs
