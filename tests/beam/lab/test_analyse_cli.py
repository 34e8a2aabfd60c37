"""``sloshrom analyse free|random`` end to end on a virtual lab's small files, and every bad
input as one clear error (exit 2, one line, nothing written: ``helpers.check_cli``)."""

from __future__ import annotations

import csv
import dataclasses
import shutil
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

from helpers import check_cli, runner
from sloshrom.beam.damping.columns import table2_dataset
from sloshrom.beam.damping.tables import damping_band_table, mode1_damping_table, mode1_decay
from sloshrom.beam.lab.virtual import lab_test_paths, write_lab_test
from sloshrom.beam.simulation.coupled import free_response, random_response
from sloshrom.beam.simulation.structure import CantileverBeam, ModalModel, coupled_frozen_modes
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


def _csv_rows(path: Path) -> list[dict[str, str]]:
    with path.open(newline="") as fh:  # a reason with commas is a quoted cell
        return list(csv.DictReader(fh))


def test_analyse_free_end_to_end(lab, tmp_path):
    """On the built-in beam at a given f1, the table is that of the simulation in memory."""
    d = lab["dir"]
    r = runner.invoke(app, ["analyse", "free", str(d / "free.uff"), "--channels",
                            str(d / "plain.toml"), "--name", "lab", "--builtin-beam",
                            "--f1", repr(lab["f1"]), "--out", str(tmp_path)])
    assert r.exit_code == 0, r.output
    assert "1 mode given" in r.output
    names = sorted(p.name for p in tmp_path.iterdir())
    assert names == ["damping_bands.csv", "damping_bands.md", "damping_by_mode.png",
                     "fig14_station_accelerations.png", "fig16_modal_accelerations.png",
                     "fig21_instantaneous_damping.png", "free_lab.nc"]
    # the table holds what the analysis of the simulation in memory gives
    decay = mode1_decay(lab["free"], lab["modal"], lab["f1"])
    # a measured test (a result with source) gets the bands of its own amplitude range
    want = damping_band_table({"s": {**lab["free"], "source": ["free.uff"]}}, {"s": decay},
                              lab["f1"])
    rows = _csv_rows(tmp_path / "damping_bands.csv")
    assert list(rows[0])[:6] == ["case", "mode", "mode_frequency_Hz", "band", "method", "zeta"]
    assert [r["case"] for r in rows] == ["lab"] * len(want)
    for row, w in zip(rows, want, strict=True):
        assert [row["band"], row["method"]] == [w["band"], w["method"]]
        np.testing.assert_allclose(float(row["zeta"]), w["zeta"], rtol=1e-6, atol=1e-10,
                                   equal_nan=True)
    got = {(r["band"], r["method"]): float(r["zeta"]) for r in rows}
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


def test_analyse_free_finds_the_modes(lab, tmp_path):
    """Without a structure or --f1, mode 1 is found in the decay's spectrum and band-passed
    out of the tank channel: its damping is the modal filter's within the bands' intervals."""
    d = lab["dir"]
    r = runner.invoke(app, ["analyse", "free", str(d / "free.uff"), "--channels",
                            str(d / "plain.toml"), "--modes", "1", "--out", str(tmp_path)])
    assert r.exit_code == 0, r.output
    assert "1 mode found:" in r.output
    assert "fig16_modal_accelerations.png" not in {p.name for p in tmp_path.iterdir()}
    rows = _csv_rows(tmp_path / "damping_bands.csv")
    # the periodogram of a 2 s decay locates the peak to a fraction of its 0.5 Hz lines
    assert float(rows[0]["mode_frequency_Hz"]) == pytest.approx(lab["f1"], rel=0.01)
    decay = mode1_decay(lab["free"], lab["modal"], lab["f1"])
    want = {(w["band"], w["method"]): w for w in damping_band_table(
        {"s": {**lab["free"], "source": ["free.uff"]}}, {"s": decay}, lab["f1"])}
    both = [(row, want[row["band"], row["method"]]) for row in rows
            if (row["band"], row["method"]) in want]
    assert len(both) >= 4
    for row, w in both:  # the band-pass of the tank channel against the modal filter
        if np.isfinite(w["zeta"]) and np.isfinite(float(row["zeta"])):
            assert abs(float(row["zeta"]) - w["zeta"]) <= max(
                w["high"] - w["low"], 0.02 * w["zeta"]), row
    with xr.open_dataset(tmp_path / "free_measured.nc") as ds:
        # a measurement without a structure claims no model's values
        assert "psi_stations" not in ds and "modal_frequencies_Hz" not in ds.attrs
        assert ds.attrs["modes_from"] == "found"


@pytest.mark.long
def test_analyse_random_end_to_end(lab, tmp_path):
    d = lab["dir"]
    files = [str(p) for p in lab_test_paths(d / "random.uff", "random", LEVELS)]
    r = runner.invoke(app, ["analyse", "random", *files, "--channels", str(d / "random.toml"),
                            "--levels", "0.1,0.2", "--accuracy", "0.01", "--builtin-beam",
                            "--f1", repr(lab["f1"]), "--out", str(tmp_path)])
    assert r.exit_code == 0, r.output
    assert "warning: mode 1, 0.1 g RMS: a 33 s random record" in r.output  # too short for 1 %
    assert {p.name for p in tmp_path.iterdir()} == {
        "random_measured.nc", "table2_damping.csv", "table2_damping.md", "damping_by_mode.png",
        "fig18_tank_acceleration.png", "fig22_tank_acceleration_window.png", "fig23_psd.png"}
    want = mode1_damping_table({"s": lab["random"]}, LEVELS, lab["f1"])
    rows = _csv_rows(tmp_path / "table2_damping.csv")
    assert list(rows[0])[:5] == ["case", "mode", "mode_frequency_Hz", "rms_g", "lscf_h1"]
    assert len(rows) == 2
    for got, row in zip(rows, want, strict=True):
        assert got["case"] == "measured" and got["mode"] == "1"
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
        # the user gave the structure: its values are written, marked as given
        assert ds.attrs["structure"] == "--modal-toml modal.toml"
        np.testing.assert_array_equal(ds.attrs["given_modal_frequencies_Hz"],
                                      lab["modal"].frequencies)
        assert "modal_frequencies_Hz" not in ds.attrs and "given_liquid_mass" not in ds.attrs


def test_beam_free_writes_the_damping_bands(tmp_path):
    r = runner.invoke(app, ["beam", "free", "--sloshing", "frozen", "--duration", "2",
                            "--out", str(tmp_path)])
    assert r.exit_code == 0, r.output
    rows = (tmp_path / "damping_bands.csv").read_text().splitlines()
    assert rows[0].startswith("case,band,method,zeta") and len(rows) == 9  # 4 bands x 2
    with xr.open_dataset(tmp_path / "free_frozen.nc") as ds:
        assert ds.attrs["f1_Hz"] > 0 and "psi_stations" in ds and "q" in ds


@pytest.mark.long  # 3.1-3.7 s in the fast tier (2026-12-07)
def test_one_map_for_a_campaign_and_units_from_the_command_line(lab, tmp_path):
    """The random test's map (it names the base) on the free decay, a station the file lacks,
    and a channel without a unit given by --unit: the results of the plain map."""
    import pyuff

    d = lab["dir"]
    sets = [dict(s) for s in pyuff.UFF(str(d / "free.uff")).read_sets() if s["type"] == 58]
    for s in sets:  # Acc 1 without a unit label, no dataset 164 saying SI
        s["ordinate_axis_units_lab"] = "" if s["id1"] == "Acc 1" else "m/s^2"
    pyuff.UFF(str(tmp_path / "r01.uff")).write_sets(sets, mode="overwrite")
    text = (d / "random.toml").read_text()
    campaign = text.replace('"Acc 1",', '"Acc 1",\n    "Acc 9",').replace(
        "0.148,", "0.148,\n    0.2,")
    (tmp_path / "campaign.toml").write_text(campaign)
    ref = tmp_path / "ref"
    r = runner.invoke(app, ["analyse", "free", str(d / "free.uff"), "--channels",
                            str(d / "plain.toml"), "--out", str(ref)])
    assert r.exit_code == 0, r.output
    argv = ["analyse", "free", str(tmp_path / "r01.uff"), "--channels",
            str(tmp_path / "campaign.toml"), "--out", str(tmp_path / "o")]
    r = runner.invoke(app, argv)
    assert r.exit_code == 2
    assert ("r01.uff: channel 'Acc 1' has no unit in the file (UFF 58 dataset 1, ordinate unit "
            "label empty); give it with --unit 'Acc 1=g' (or m/s^2), or in the channel map's "
            "[units] table") in " ".join(r.output.split())
    r = runner.invoke(app, [*argv, "--unit", "Acc 1=m/s^2"])
    assert r.exit_code == 0, r.output
    out = " ".join(r.output.split())
    assert ("note: r01.uff has no channel 'Acc 9' (the map names it): the analyses use the "
            "stations 'Acc 1', 'Acc 2', 'Acc 3', 'Acc 4', 'Acc 5'") in out
    assert ("note: r01.uff has no channel 'Base Z' (the map names it): a free decay without a "
            "base channel has its base at rest") in out
    assert ((tmp_path / "o" / "damping_bands.csv").read_text()
            == (ref / "damping_bands.csv").read_text())
    with xr.open_dataset(tmp_path / "o" / "free_measured.nc") as ds:
        assert ds["station"].values.tolist() == [0.148, 0.296, 0.444, 0.592, 0.74]
        assert ds.attrs["channel_units"].startswith("Acc 1=m/s^2 (given), Acc 2=m/s^2")
        assert "Acc 9" not in ds.attrs["channel_map"] and "Base Z" not in ds.attrs["channel_map"]
        assert ds.attrs["f1_from"] == "the data (spectral peak)"
        assert ds.attrs["structure"].startswith("none: the measured modes alone")
        for key in ("modal_frequencies_Hz", "modal_damping", "liquid_mass", "structure_mass"):
            assert key not in ds.attrs


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


def _noise(t):
    return 9.8 * np.random.default_rng(3).standard_normal(t.size)


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
    _csv(tmp / "noise.csv", lambda t: np.random.default_rng(0).standard_normal(t.size), n=4000)
    n = 16500
    _csv(tmp / "sine.csv", lambda t: np.sin(2 * np.pi * 10.3 * t), n=n, base=True)
    _csv(tmp / "r500.csv", lambda t: np.sin(2 * np.pi * 10.3 * t), n=n, base=True)
    _csv(tmp / "r250.csv", lambda t: np.sin(2 * np.pi * 10.3 * t), n=n, fs=250.0, base=True)
    _csv(tmp / "rshort.csv", lambda t: np.sin(2 * np.pi * 10.3 * t), n=4000, base=True)
    # random runs: a base of 0.98 g RMS (m/s^2 labelled g?), and a 1 MHz time axis
    _csv(tmp / "rms098.csv", _noise, n=n, base=True)
    _csv(tmp / "fast.csv", _noise, n=n, fs=1e6, base=True)
    _csv(tmp / "decay.csv", _decay)
    # the stations in reverse: the reference (outermost) channel is the root's sensor
    (tmp / "reversed.toml").write_text(MAP.replace('"Acc 1", "Acc 2", "Acc 3", "Acc 4", "Acc 5"',
                                                   '"Acc 5", "Acc 4", "Acc 3", "Acc 2", "Acc 1"'))
    # a campaign whose manifest swaps the levels of its random runs
    (tmp / "camp").mkdir()
    for g in LEVELS:
        shutil.copy(lab_dir / f"random_{g:g}g.uff", tmp / "camp" / f"r{g:g}.uff")
    (tmp / "camp" / "campaign.toml").write_text(
        '[[test]]\nfiles = ["r0.1.uff", "r0.2.uff"]\nkind = "random"\nname = "rnd"\n'
        'levels = [0.2, 0.1]\n')
    t = np.arange(n) / FS
    write_record(Record(t, FS, {**{f"a{k}": np.sin(2 * np.pi * 10 * t) for k in range(1, 6)},
                                "base": np.zeros(n)}, dict.fromkeys(
        [*(f"a{k}" for k in range(1, 6)), "base"], "g")), tmp / "zero.csv")


FREE = ["analyse", "free"]
RANDOM = ["analyse", "random"]
OUT = ["--out", "{tmp}/res"]
RUNS = ["{tmp}/random_0.1g.uff", "{tmp}/random_0.2g.uff", "--channels", "{tmp}/random.toml"]
CASES = [
    ("channel-not-in-file", [*FREE, "{tmp}/free.uff", "--channels", "{tmp}/missing.toml", *OUT],
     r"free\.uff: no channel 'Acc 9' .*the file's channels: 'Acc 1 \(1:\+Z\)'"),
    ("unit-not-acceleration", [*FREE, "{tmp}/speed.csv", "--channels", "{tmp}/csv.toml", *OUT],
     r"speed\.csv: channel 'a1' is in 'm/s', not an acceleration"),
    ("nan", [*FREE, "{tmp}/nan.csv", "--channels", "{tmp}/csv.toml", *OUT],
     r"nan\.csv.*contains NaN/inf"),
    ("free-does-not-decay", [*FREE, "{tmp}/steady.csv", "--channels", "{tmp}/nobase.toml", *OUT],
     r"steady\.csv: the tank acceleration does not decay"),
    ("free-too-short", [*FREE, "{tmp}/short.csv", "--channels", "{tmp}/nobase.toml",
                        "--f1", "10.19", *OUT],
     r"short\.csv: 1 s is too short .*mode 1 \(10\.19 Hz\): need 18 periods"),
    ("free-no-resonance", [*FREE, "{tmp}/noise.csv", "--channels", "{tmp}/nobase.toml", *OUT],
     r"no resonance found in the spectrum of the tank channel.*--f1 or --frequencies"),
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
                                   *OUT], r"name the reference channel \('tank'\)"),
    ("map-ids-on-builtin", [*FREE, "{tmp}/free.uff", "--channels", "{tmp}/ids.toml",
                            "--builtin-beam", *OUT], r"'ids' name grid IDs of your structure"),
    ("f1-and-frequencies", [*FREE, "{tmp}/free.uff", "--channels", "{tmp}/plain.toml",
                            "--f1", "10", "--frequencies", "10,60", *OUT],
     r"--f1 and --frequencies both name the modes"),
    ("bad-frequencies", [*FREE, "{tmp}/free.uff", "--channels", "{tmp}/plain.toml",
                         "--frequencies", "10,x", *OUT], r"--frequencies must be comma-separated"),
    ("frequency-twice", [*FREE, "{tmp}/free.uff", "--channels", "{tmp}/plain.toml",
                         "--frequencies", "10,10", *OUT], r"names a mode twice"),
    ("mode-at-nyquist", [*FREE, "{tmp}/free.uff", "--channels", "{tmp}/plain.toml",
                         "--frequencies", "10,240", *OUT], r"too close to the Nyquist"),
    ("bad-modes", [*FREE, "{tmp}/free.uff", "--channels", "{tmp}/plain.toml", "--modes", "0",
                   *OUT], r"--modes must be >= 1"),
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
    # the levels given against the files' measured base RMS (factor 1.25)
    ("random-levels-swapped", [*RANDOM, *RUNS, "--levels", "0.2,0.1", *OUT],
     r"--levels: the levels given do not match the measured base RMS \(random_0\.1g\.uff: "
     r"0\.2 g given, its base RMS 0\.1 g; random_0\.2g\.uff: 0\.1 g given, its base RMS "
     r"0\.2 g\); each level must be within a factor 1\.25 of its run's"),
    ("random-levels-tiny", [*RANDOM, *RUNS, "--levels", "1e-300,0.1", *OUT],
     r"random_0\.1g\.uff: 1e-300 g given, its base RMS 0\.1 g; random_0\.2g\.uff: 0\.1 g"),
    ("random-levels-far", [*RANDOM, *RUNS, "--levels", "1.5,1.9", *OUT],
     r"random_0\.1g\.uff: 1\.5 g given, its base RMS 0\.1 g; random_0\.2g\.uff: 1\.9 g"),
    ("random-levels-not-the-base", [*RANDOM, "{tmp}/rms098.csv", "--channels", "{tmp}/csv.toml",
                                    "--levels", "0.1", *OUT],
     r"rms098\.csv: 0\.1 g given, its base RMS 0\.9\d+ g"),
    ("campaign-levels-swapped", ["analyse", "campaign", "{tmp}/camp", "--channels",
                                 "{tmp}/random.toml", *OUT],
     r"camp/campaign\.toml: test 'rnd': levels: the levels given do not match the measured "
     r"base RMS \(r0\.1\.uff: 0\.2 g given, its base RMS 0\.1 g; r0\.2\.uff: 0\.1 g given"),
    # a given mode that is not a resonance of the data
    ("free-f1-not-the-peak", [*FREE, "{tmp}/decay.csv", "--channels", "{tmp}/nobase.toml",
                              "--f1", "20", *OUT],
     r"modes: the mode given at 20 Hz is not a resonance of the data: the tank channel's "
     r"spectrum has no peak in 13-27 Hz.*strongest peak is at 10\.\d+ Hz"),
    ("free-lab-f1-not-the-peak", [*FREE, "{tmp}/free.uff", "--channels", "{tmp}/plain.toml",
                                  "--f1", "20", *OUT],
     r"the mode given at 20 Hz is not a resonance.*strongest peak is at 10\.\d+ Hz"),
    ("random-f1-not-the-peak", [*RANDOM, *RUNS, "--f1", "20", *OUT],
     r"the mode given at 20 Hz is not a resonance of the data: H1 \(base -> tank\) has no "
     r"peak in 13-27 Hz"),
    # the map's station order against the data at mode 1
    ("free-stations-reversed", [*FREE, "{tmp}/free.uff", "--channels", "{tmp}/reversed.toml",
                                *OUT],
     r"--channels .*reversed\.toml: the channel map contradicts the data: at mode 1 \(10\.\d+ "
     r"Hz\) station 'Acc 1' \(at 0\.74 m\) moves 0\.0\d+ x as much as 'Acc 5' \(at 0\.148 m\)"),
    ("free-stations-reversed-builtin", [*FREE, "{tmp}/free.uff", "--channels",
                                        "{tmp}/reversed.toml", "--builtin-beam", *OUT],
     r"station 'Acc 1' \(mode shape 1\) moves 0\.0\d+ x as much as 'Acc 5' \(mode shape"),
    # a sample rate that leaves the mode's band without lines
    ("random-fs-1MHz", [*RANDOM, "{tmp}/fast.csv", "--channels", "{tmp}/csv.toml", "--f1",
                        "10.2", *OUT],
     r"the files' sample rate fs = 1e\+06 Hz leaves 0 line\(s\) of the 16384-sample Welch "
     r"spectra .* its analyses need 8, so fs at most 2\.089e\+04 Hz"),
]


@pytest.fixture(scope="module")
def world(lab, tmp_path_factory) -> Path:
    """What every case reads (``_world``), written once; each case gets its own copy."""
    d = tmp_path_factory.mktemp("world")
    _world(d, lab["dir"])
    return d


def _copy_of(world: Path) -> Callable[[Path], None]:
    """A case's setup: a copy of the world in its folder."""
    def setup(tmp: Path) -> None:
        shutil.copytree(world, tmp, dirs_exist_ok=True)

    return setup


@pytest.mark.parametrize(("argv", "match"), [c[1:] for c in CASES], ids=[c[0] for c in CASES])
def test_analyse_rejects(tmp_path, lab, world, argv, match):
    check_cli(tmp_path, lab["dir"], _copy_of(world), argv, match)


def _nan_rows(rows):
    """The rows with every estimate NaN and a reason, as an analysis that found nothing."""
    out = []
    for r in rows:
        r = dict(r)
        for k in [k for k in r if k in ("zeta", "lscf_h1", "lscf_output", "half_power")]:
            r[k] = float("nan")
            r["reason" if k == "zeta" else f"{k}_reason"] = "no peak inside band (test)"
        out.append(r)
    return out


@pytest.mark.parametrize("kind", ["free", "random"])
def test_a_table_of_nan_is_never_written(lab, world, tmp_path, monkeypatch, kind):
    """Every estimate NaN: exit 2 with the first cell's reason, nothing written."""
    from sloshrom.beam.lab import every_mode as lab_module

    d = lab["dir"]
    if kind == "free":
        real = lab_module.free_mode_rows
        monkeypatch.setattr(lab_module, "free_mode_rows",
                            lambda *a, **k: _nan_rows(real(*a, **k)))
        argv = [*FREE, "{tmp}/free.uff", "--channels", "{tmp}/plain.toml", *OUT]
        match = r"free\.uff: damping bands: no damping estimate at all, nothing written; " \
                r"the first cell: measured mode 1, .* g, Hilbert: no peak inside band \(test\)"
    else:  # the analyses replaced: a Table 2 of NaN at once
        def nan_table(res, name, found, **k):
            rows = [{"case": name, "rms_g": g, "lscf_h1": np.nan,
                     "lscf_h1_reason": "no peak inside band (test)", "lscf_output": np.nan,
                     "half_power": np.nan} for g in LEVELS]
            return table2_dataset(rows).expand_dims(mode=[1]).assign_coords(
                case=name, mode_frequency_Hz=("mode", [10.2]))

        monkeypatch.setattr(lab_module, "random_mode_dataset", nan_table)
        argv = [*RANDOM, *RUNS, *OUT]
        match = r"random_0\.1g\.uff, random_0\.2g\.uff: Table 2: no damping estimate at all, " \
                r"nothing written; the first cell: measured mode 1 0\.1 g, LSCF on H1: no peak"
    check_cli(tmp_path, d, _copy_of(world), argv, match)


def test_fewer_stations_than_the_structures_modes(lab, tmp_path):
    """Two stations on the built-in beam's three modes: no modal filtering (the tank channel
    band-passed), the figures drawn (``compare`` of such a result: test_hostile_cli.py)."""
    d = lab["dir"]
    (tmp_path / "two.toml").write_text(
        '[channels]\nstations = ["Acc 1", "Acc 5"]\npositions = [0.148, 0.74]\n')
    r = runner.invoke(app, [*FREE, str(d / "free.uff"), "--channels", str(tmp_path / "two.toml"),
                            "--builtin-beam", "--out", str(tmp_path / "o")])
    assert r.exit_code == 0, r.output
    assert (tmp_path / "o" / "fig16_modal_accelerations.png").is_file()
