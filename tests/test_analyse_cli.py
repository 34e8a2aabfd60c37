"""``sloshrom analyse free|random`` end to end on a virtual lab's small files, and every bad
input as one clear error (exit 2, one line, nothing written: ``helpers.check_cli``)."""

from __future__ import annotations

import dataclasses
import shutil
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

from helpers import check_cli, runner
from sloshrom.beam.coupled import free_response, random_response
from sloshrom.beam.labfiles import lab_test_paths, write_lab_test
from sloshrom.beam.results import damping_band_table, mode1_damping_table, mode1_decay
from sloshrom.beam.structure import CantileverBeam, ModalModel, coupled_frozen_modes
from sloshrom.cli import app
from sloshrom.config import Tank
from sloshrom.io import Record, write_record
from sloshrom.models import FrozenLiquid

FS = 500.0
LEVELS = (0.1, 0.2)
MAP = """[channels]
stations = ["Acc 1", "Acc 2", "Acc 3", "Acc 4", "Acc 5"]
positions = [0.148, 0.296, 0.444, 0.592, 0.74]
"""


@pytest.fixture(scope="module")
def lab(tmp_path_factory):
    """The lab's files (frozen liquid, noise-free): a 2 s free decay, a random test of two
    33 s levels, their maps, and the simulations they come from."""
    d = tmp_path_factory.mktemp("lab")
    tank = Tank()
    beam = CantileverBeam.with_tank(tank)
    modal = ModalModel.from_beam(beam, tank)
    f1 = float(coupled_frozen_modes(modal, [tank.liquid_mass])[0][0])
    free = free_response(FrozenLiquid(1 / FS), modal, 0.0146, 2.0, tank)
    rnd = random_response(FrozenLiquid(1 / FS), modal, LEVELS, 33.0, 0, tank=tank)
    write_lab_test(free, modal, d / "free.uff", kind="free").write_toml(d / "free.toml")
    write_lab_test(rnd, modal, d / "random.uff", kind="random").write_toml(d / "random.toml")
    (d / "plain.toml").write_text(MAP)
    return {"dir": d, "modal": modal, "f1": f1, "free": free, "random": rnd}


def test_analyse_free_end_to_end(lab, tmp_path):
    d = lab["dir"]
    r = runner.invoke(app, ["analyse", "free", str(d / "free.uff"), "--channels",
                            str(d / "plain.toml"), "--name", "lab", "--out", str(tmp_path)])
    assert r.exit_code == 0, r.output
    names = sorted(p.name for p in tmp_path.iterdir())
    assert names == ["damping_bands.csv", "damping_bands.md", "fig14_station_accelerations.png",
                     "fig16_modal_accelerations.png", "fig21_instantaneous_damping.png",
                     "free_lab.nc"]
    # the table holds what the analysis of the simulation in memory gives
    decay = mode1_decay(lab["free"], lab["modal"], lab["f1"])
    # a measured test (a result with source) gets the bands of its own amplitude range
    want = damping_band_table({"s": {**lab["free"], "source": ["free.uff"]}}, {"s": decay},
                              lab["f1"])
    rows = [ln.split(",") for ln in (tmp_path / "damping_bands.csv").read_text().splitlines()]
    assert rows[0][:4] == ["case", "band", "method", "zeta"]
    assert [r[0] for r in rows[1:]] == ["lab"] * len(want)
    for row, w in zip(rows[1:], want, strict=True):
        assert row[1:3] == [w["band"], w["method"]]
        np.testing.assert_allclose(float(row[3]), w["zeta"], rtol=1e-6, atol=1e-10,
                                   equal_nan=True)
    got = {(r[1], r[2]): float(r[3]) for r in rows[1:]}
    # the result file can be analysed again on its own (psi_stations, f1_Hz)
    with xr.open_dataset(tmp_path / "free_lab.nc") as ds:
        assert ds.attrs["f1_Hz"] == pytest.approx(lab["f1"], rel=1e-12)
        assert ds.attrs["source"] == "free.uff" and "interface_force" not in ds
        modal = dataclasses.replace(lab["modal"], psi_stations=ds["psi_stations"].values)
        res = {k: ds[k].values for k in ("base_acceleration", "station_acceleration",
                                         "tank_acceleration")} | {"fs": ds.attrs["fs"]}
        f1 = ds.attrs["f1_Hz"]
        again = damping_band_table({"a": res}, {"a": mode1_decay(res, modal, f1)}, f1,
                                   bands="auto")
    for row in again:
        np.testing.assert_allclose(row["zeta"], got[row["band"], row["method"]], rtol=1e-9,
                                   equal_nan=True)


def test_analyse_random_end_to_end(lab, tmp_path):
    d = lab["dir"]
    files = [str(p) for p in lab_test_paths(d / "random.uff", "random", LEVELS)]
    r = runner.invoke(app, ["analyse", "random", *files, "--channels", str(d / "random.toml"),
                            "--levels", "0.1,0.2", "--accuracy", "0.01", "--out",
                            str(tmp_path)])
    assert r.exit_code == 0, r.output
    assert "warning: 0.1 g RMS: a 33 s random record" in r.output  # too short for 1 %
    assert {p.name for p in tmp_path.iterdir()} == {
        "random_measured.nc", "table2_mode1_damping.csv", "table2_mode1_damping.md",
        "fig18_tank_acceleration.png", "fig22_tank_acceleration_window.png", "fig23_psd.png"}
    want = mode1_damping_table({"s": lab["random"]}, LEVELS, lab["f1"])
    text = (tmp_path / "table2_mode1_damping.csv").read_text().splitlines()
    keys = text[0].split(",")
    assert keys[:3] == ["case", "rms_g", "lscf_h1"] and len(text) == 3
    for line, row in zip(text[1:], want, strict=True):
        got = dict(zip(keys, line.split(","), strict=True))
        assert got["case"] == "measured"
        np.testing.assert_allclose(float(got["lscf_output"]), row["lscf_output"], rtol=1e-6)
    with xr.open_dataset(tmp_path / "random_measured.nc") as ds:
        assert ds["level"].values.tolist() == list(LEVELS)
        assert ds["psi_stations"].dims == ("station", "mode")


def test_analyse_free_on_modal_toml_with_ids(lab, tmp_path):
    """Stations named by ID on the user's modal data (its ``station_ids``), in the map's order."""
    import tomli_w

    user = lab["modal"].to_dict() | {"station_ids": [11, 12, 13, 14, 15]}
    (tmp_path / "modal.toml").write_text(tomli_w.dumps({"modal": user}))
    (tmp_path / "ids.toml").write_text(
        '[channels]\nstations = ["Acc 5", "Acc 1", "Acc 2", "Acc 3", "Acc 4"]\n'
        'ids = [15, 11, 12, 13, 14]\ntank = "Acc 5"\n')
    r = runner.invoke(app, ["analyse", "free", str(lab["dir"] / "free.uff"), "--channels",
                            str(tmp_path / "ids.toml"), "--modal-toml",
                            str(tmp_path / "modal.toml"), "--out", str(tmp_path / "o")])
    assert r.exit_code == 0, r.output
    with xr.open_dataset(tmp_path / "o" / "free_measured.nc") as ds:
        assert ds["station_id"].values.tolist() == [15, 11, 12, 13, 14]
        np.testing.assert_array_equal(ds["psi_stations"].values[0],
                                      lab["modal"].psi_stations[4])


def test_beam_free_writes_the_damping_bands(tmp_path):
    r = runner.invoke(app, ["beam", "free", "--sloshing", "frozen", "--duration", "2",
                            "--out", str(tmp_path)])
    assert r.exit_code == 0, r.output
    rows = (tmp_path / "damping_bands.csv").read_text().splitlines()
    assert rows[0].startswith("case,band,method,zeta") and len(rows) == 9  # 4 bands x 2
    with xr.open_dataset(tmp_path / "free_frozen.nc") as ds:
        assert ds.attrs["f1_Hz"] > 0 and "psi_stations" in ds and "q" in ds


# -- bad input -----------------------------------------------------------------------------------
def _csv(path: Path, fn, n: int = 1000, fs: float = FS, unit: str = "g",
         base: bool = False) -> None:
    t = np.arange(n) / fs
    x = fn(t)
    cols = {f"a{k}": x * k / 5 for k in range(1, 6)}
    if base:
        cols["base"] = fn(t + 0.1) * 0.1
    # by hand: a Record refuses NaN, a lab's file may hold them
    head = ",".join(["time [s]", *(f"{c} [{unit}]" for c in cols)])
    np.savetxt(path, np.column_stack([t, *cols.values()]), delimiter=",", header=head,
               comments="", fmt="%.17g")


def _decay(t):
    return np.exp(-0.6 * t) * np.sin(2 * np.pi * 10.19 * t)


CSV_MAP = """[channels]
stations = ["a1", "a2", "a3", "a4", "a5"]
positions = [0.148, 0.296, 0.444, 0.592, 0.74]
base = "base"
"""


def _world(tmp: Path, lab_dir: Path) -> None:
    for p in lab_dir.iterdir():
        shutil.copy(p, tmp / p.name)
    (tmp / "csv.toml").write_text(CSV_MAP)
    (tmp / "nobase.toml").write_text(CSV_MAP.replace('base = "base"\n', ""))
    (tmp / "missing.toml").write_text(MAP.replace("Acc 5", "Acc 9"))
    (tmp / "bogus.toml").write_text(MAP + "bogus = 1\n")
    (tmp / "ids.toml").write_text(MAP.replace("positions = [0.148, 0.296, 0.444, 0.592, 0.74]",
                                              "ids = [1, 2, 3, 4, 5]"))
    _csv(tmp / "speed.csv", _decay, unit="m/s")
    _csv(tmp / "nan.csv", lambda t: np.where(t == t[7], np.nan, _decay(t)))
    _csv(tmp / "steady.csv", lambda t: np.sin(2 * np.pi * 10.19 * t))
    _csv(tmp / "short.csv", _decay, n=500)
    n = 16500
    _csv(tmp / "sine.csv", lambda t: np.sin(2 * np.pi * 10.3 * t), n=n, base=True)
    _csv(tmp / "r500.csv", lambda t: np.sin(2 * np.pi * 10.3 * t), n=n, base=True)
    _csv(tmp / "r250.csv", lambda t: np.sin(2 * np.pi * 10.3 * t), n=n, fs=250.0, base=True)
    _csv(tmp / "rshort.csv", lambda t: np.sin(2 * np.pi * 10.3 * t), n=4000, base=True)
    t = np.arange(n) / FS
    write_record(Record(t, FS, {**{f"a{k}": np.sin(2 * np.pi * 10 * t) for k in range(1, 6)},
                                "base": np.zeros(n)}, dict.fromkeys(
        [*(f"a{k}" for k in range(1, 6)), "base"], "g")), tmp / "zero.csv")


FREE = ["analyse", "free"]
RANDOM = ["analyse", "random"]
OUT = ["--out", "{tmp}/res"]
CASES = [
    ("channel-not-in-file", [*FREE, "{tmp}/free.uff", "--channels", "{tmp}/missing.toml", *OUT],
     r"free\.uff: no channel 'Acc 9' .*the file's channels: 'Acc 1 \(1:\+Z\)'"),
    ("unit-not-acceleration", [*FREE, "{tmp}/speed.csv", "--channels", "{tmp}/csv.toml", *OUT],
     r"speed\.csv: channel 'a1' is in 'm/s', not an acceleration"),
    ("nan", [*FREE, "{tmp}/nan.csv", "--channels", "{tmp}/csv.toml", *OUT],
     r"nan\.csv.*contains NaN/inf"),
    ("free-does-not-decay", [*FREE, "{tmp}/steady.csv", "--channels", "{tmp}/nobase.toml", *OUT],
     r"steady\.csv: the tank acceleration does not decay"),
    ("free-too-short", [*FREE, "{tmp}/short.csv", "--channels", "{tmp}/nobase.toml", *OUT],
     r"short\.csv: 1 s is too short .*need 18 periods"),
    ("random-sine-base", [*RANDOM, "{tmp}/sine.csv", "--channels", "{tmp}/csv.toml", *OUT],
     r"sine\.csv: the base acceleration \(0\.071 g\) is not random: 100 % of its power"),
    ("random-zero-base", [*RANDOM, "{tmp}/zero.csv", "--channels", "{tmp}/csv.toml",
                          "--levels", "0.1", *OUT],
     r"zero\.csv: the base acceleration \(0\.1 g\) is constant"),
    ("random-rates-differ", [*RANDOM, "{tmp}/r500.csv", "{tmp}/r250.csv", "--channels",
                             "{tmp}/csv.toml", "--levels", "0.1,0.2", *OUT],
     r"r250\.csv is sampled at 250 Hz, .*r500\.csv at 500 Hz"),
    ("random-too-short", [*RANDOM, "{tmp}/rshort.csv", "--channels", "{tmp}/csv.toml", *OUT],
     r"4000 samples: Table 2 needs at least 16384"),
    ("random-no-base", [*RANDOM, "{tmp}/sine.csv", "--channels", "{tmp}/nobase.toml", *OUT],
     r"a random test needs the 'base' channel"),
    ("random-levels-count", [*RANDOM, "{tmp}/sine.csv", "--channels", "{tmp}/csv.toml",
                             "--levels", "0.1,0.2", *OUT],
     r"--levels gives 2 level\(s\) for 1 file\(s\)"),
    ("map-unknown-key", [*FREE, "{tmp}/free.uff", "--channels", "{tmp}/bogus.toml", *OUT],
     r"--channels: .*bogus\.toml: unknown key\(s\) 'bogus'"),
    ("map-ids-without-structure", [*FREE, "{tmp}/free.uff", "--channels", "{tmp}/ids.toml",
                                   *OUT], r"'ids' name grid IDs of your structure"),
    ("no-such-file", [*FREE, "{tmp}/nope.uff", "--channels", "{tmp}/plain.toml", *OUT],
     r"FILE .*nope\.uff: no such file"),
    ("bad-f1", [*FREE, "{tmp}/free.uff", "--channels", "{tmp}/plain.toml", "--f1", "-3",
                *OUT], r"--f1 must be > 0 Hz"),
    ("bad-accuracy", [*RANDOM, "{tmp}/sine.csv", "--channels", "{tmp}/csv.toml",
                      "--accuracy", "0", *OUT], r"--accuracy must be in \(0, 1\]"),
    ("bad-name", [*FREE, "{tmp}/free.uff", "--channels", "{tmp}/plain.toml", "--name", "a/b",
                  *OUT], r"--name 'a/b'"),
    ("unknown-estimator", [*RANDOM, "{tmp}/sine.csv", "--channels", "{tmp}/csv.toml",
                           "--estimator", "prony", *OUT],
     r"--estimator: unknown damping estimator 'prony'; known: lscf_h1, .*ssi_cov"),
]


@pytest.mark.parametrize(("argv", "match"), [c[1:] for c in CASES], ids=[c[0] for c in CASES])
def test_analyse_rejects(tmp_path, lab, argv, match):
    check_cli(tmp_path, lab["dir"], lambda tmp: _world(tmp, lab["dir"]), argv, match)
