"""Every mode of a laboratory's test: found from the data (``sloshrom.beam.damping.peaks``),
analysed at each mode (``sloshrom.beam.lab.every_mode``), a campaign folder classified
(``sloshrom.beam.lab.campaign``) and run from the command line (``sloshrom analyse campaign``)."""

from __future__ import annotations

import numpy as np
import pytest

from helpers import check_cli, runner
from sloshrom.beam.damping.analysis import AnalysisError
from sloshrom.beam.damping.columns import table2_rows
from sloshrom.beam.damping.peaks import common_modes, find_modes, given_modes, mode_bands
from sloshrom.beam.damping.uncertainty import ShortRecordWarning
from sloshrom.beam.lab.campaign import CampaignError, campaign_tests
from sloshrom.beam.lab.channels import ChannelMap
from sloshrom.beam.lab.every_mode import (
    free_mode_decays,
    free_mode_rows,
    modes_of_test,
    random_mode_dataset,
)
from sloshrom.beam.lab.synthetic import LabBeam, free_decay, random_test
from sloshrom.cli import app
from sloshrom.config import G
from sloshrom.io import Record, write_record

FS = 500.0
BEAM = LabBeam()
MAP = ChannelMap(stations=("a1", "a2", "a3", "a4", "a5"), positions=BEAM.positions, base="base")


def _random_res(levels=(0.1, 0.2), duration=40.0, band=(3.0, 220.0)):
    runs = [random_test(BEAM, g, duration, FS, band=band, seed=k)
            for k, g in enumerate(levels)]
    st = np.stack([r["stations"] for r in runs])
    return {"time": runs[0]["time"], "fs": FS, "base_acceleration": np.stack(
        [r["base"] for r in runs]), "station_acceleration": st,
        "tank_acceleration": st[..., -1], "rms_levels_g": np.asarray(levels),
        "source": ["synthetic"]}


def _free_res(duration=20.0, seed=3):
    r = free_decay(BEAM, 8.5, duration, FS, seed=seed)
    n = r["time"].size
    return {"time": r["time"], "fs": FS, "base_acceleration": np.zeros(n),
            "station_acceleration": r["stations"], "tank_acceleration": r["stations"][:, -1],
            "source": ["synthetic"]}


# -- finding modes -------------------------------------------------------------------------------
def test_h1_peaks_are_the_beams_modes():
    """The peaks of H1 lie within a Welch line (0.12 Hz at 40 s) of the three modes."""
    res = _random_res(levels=(0.1,))
    found = find_modes(res["tank_acceleration"][0], FS, res["base_acceleration"][0])
    assert [m.source for m in found] == ["H1 peak"] * 3
    np.testing.assert_allclose([m.frequency for m in found], BEAM.frequencies, atol=0.13)
    assert all(m.coherence >= 0.5 and m.prominence_db > 10 for m in found)


def test_band_limited_shaker_finds_only_excited_modes():
    """A shaker band ending at 40 Hz leaves mode 3 (180 Hz, 140 dB down) unexcited: its H1
    peak is incoherent noise and is not a mode; modes 1 and 2 are found."""
    res = _random_res(levels=(0.1,), band=(3.0, 40.0))
    fr = [m.frequency for m in find_modes(res["tank_acceleration"][0], FS,
                                          res["base_acceleration"][0])]
    assert len(fr) == 2
    np.testing.assert_allclose(fr, BEAM.frequencies[:2], atol=0.13)


def test_decay_spectrum_peaks():
    res = _free_res()
    found = find_modes(res["tank_acceleration"], FS)
    # the whole record's zero-padded periodogram locates each peak to a fraction of 0.05 Hz
    np.testing.assert_allclose([m.frequency for m in found][:2], BEAM.frequencies[:2],
                               rtol=0.01)


def test_white_noise_has_no_mode():
    rng = np.random.default_rng(0)
    assert find_modes(rng.standard_normal(20000), FS) == []


def test_common_modes_and_bands():
    a = given_modes([10.0, 60.0])
    b = given_modes([10.4, 61.0, 150.0])
    got = common_modes([a, b, given_modes([10.2])])
    # 150 Hz appears in one record of three: not a mode of the test
    assert [round(m.frequency, 1) for m in got] == [10.2, 60.5]
    bands = mode_bands([10.0, 64.0, 180.0], FS)
    assert bands[0] == (5.0, 15.0)
    assert bands[1] == (32.0, 96.0)  # the neighbours' geometric means lie outside f (1 -/+ 0.5)
    assert bands[2] == (pytest.approx(np.sqrt(64 * 180)), 225.0)  # between 2 and 3; 0.9 Nyquist
    assert mode_bands([10.0, 12.0], FS)[0] == (5.0, pytest.approx(np.sqrt(120)))
    with pytest.raises(AnalysisError, match="too close to the Nyquist"):
        mode_bands([10.0, 230.0], FS)
    with pytest.raises(AnalysisError, match="not distinct"):
        given_modes([10.0, 10.0])


# -- analysis at every mode ----------------------------------------------------------------------
def test_random_rows_at_every_found_mode_of_a_short_record():
    """The fast tier's version of the next test: a 34 s record (one Welch segment, said to be
    too short) is analysed at each of the three modes it finds, one row a mode, each value
    inside its interval (the calibration against the true damping needs the lab's 120 s)."""
    res = _random_res(levels=(0.2,), duration=34.0)
    modes = modes_of_test(res, "random")
    assert modes.how == "found" and len(modes.modes) == 3
    with pytest.warns(ShortRecordWarning, match=r"from 1 Welch segment\(s\) .* at least 3"):
        rows = table2_rows(random_mode_dataset(res, "lab", modes, estimators=["half_power"]))
    assert [r["mode"] for r in rows] == [1, 2, 3]
    for r in rows:
        assert r["half_power_low"] < r["half_power"] < r["half_power_high"], r


@pytest.mark.slow  # 120 s of record analysed at three modes with the bootstrap (~10 s); the fast
# tier: test_random_rows_at_every_found_mode_of_a_short_record
def test_random_rows_at_every_mode():
    """Table 2 at each mode of the three-mode beam: LSCF on H1 within 4 of its stated std of
    the true damping (a tolerance from the interval, not from this seed's error); a record of
    one Welch segment is said to be too short."""
    with pytest.warns(ShortRecordWarning, match=r"from 1 Welch segment\(s\) .* at least 3"):
        random_mode_dataset(_random_res(levels=(0.1,), duration=34.0), "lab",
                         modes_of_test(_random_res(levels=(0.1,), duration=34.0), "random",
                                       frequencies=[10.3]), estimators=["half_power"])
    res = _random_res(levels=(0.2,), duration=120.0)  # 6 Welch segments, as a lab runs
    modes = modes_of_test(res, "random")
    assert modes.how == "found" and len(modes.modes) == 3
    rows = table2_rows(random_mode_dataset(res, "lab", modes,
                                           estimators=["lscf_h1", "half_power"]))
    assert [r["mode"] for r in rows] == [1, 2, 3]
    for r, z in zip(rows, BEAM.damping, strict=True):
        assert abs(r["lscf_h1"] - z) <= 4 * r["lscf_h1_std"], r
        assert r["lscf_h1_low"] < r["lscf_h1"] < r["lscf_h1_high"]


def test_free_decay_of_every_mode():
    """Each mode band-passed out of the tip channel decays at its own damping: in the bands
    of its own amplitude range (down to 3 x the noise floor), the 95 % intervals of modes 1 and
    2 hold the true damping in at least 80 % of the (band, method) cells (about 30 cells:
    fewer than 80 % has a binomial probability below 1 % for calibrated intervals)."""
    res = _free_res()
    modes = modes_of_test(res, "free", max_modes=2)
    decays = free_mode_decays(res, modes)
    rows = free_mode_rows(res, "lab", modes, decays)
    inside = []
    for r in rows:
        if np.isfinite(r["low"]) and np.isfinite(r["high"]):
            inside.append(r["low"] <= BEAM.damping[r["mode"] - 1] <= r["high"])
    assert len(inside) >= 20 and np.mean(inside) >= 0.8, rows
    assert {r["mode"] for r in rows} == {1, 2}
    # every cell without a value or an interval says why
    assert all(r["reason"] for r in rows if not np.isfinite(r["high"]))


def test_given_modes_and_too_short():
    res = _free_res(duration=1.5)
    modes = modes_of_test(res, "free", frequencies=[10.3])
    assert modes.how == "given" and modes.frequencies == [10.3]
    with pytest.raises(AnalysisError, match="needs 18 periods"):
        free_mode_decays(res, modes)


# -- a campaign folder ---------------------------------------------------------------------------
def _write(path, res, base=True, units=None):
    u = {"a1": "g", "a2": "m/s^2", "a3": "g", "a4": "m/s^2", "a5": "m/s^2", "base": "g"}
    u.update(units or {})
    v = {f"a{k + 1}": res["stations"][:, k] / (G if u[f"a{k + 1}"] == "g" else 1.0)
         for k in range(5)}
    if base:
        v["base"] = res["base"] / G
    write_record(Record(res["time"], FS, v, {k: u[k] for k in v}), path)


@pytest.fixture(scope="module")
def campaign(tmp_path_factory):
    d = tmp_path_factory.mktemp("campaign")
    for k, g in enumerate((0.1, 0.2)):
        _write(d / f"r{k}.csv", random_test(BEAM, g, 34.0, FS, seed=k))
    dec = free_decay(BEAM, 8.5, 10.0, FS, seed=5)
    dec["base"] = np.zeros(dec["time"].size)
    _write(d / "decay.csv", dec)
    (d / "map.toml").write_text(MAP.to_toml())
    return d


def test_campaign_by_content(campaign):
    tests = campaign_tests(campaign, MAP)
    assert [(t.kind, t.name, [p.name for p in t.files]) for t in tests] == [
        ("free", "decay", ["decay.csv"]), ("random", "random", ["r0.csv", "r1.csv"])]


def test_campaign_manifest(campaign, tmp_path):
    for p in campaign.iterdir():
        (tmp_path / p.name).write_bytes(p.read_bytes())
    (tmp_path / "campaign.toml").write_text(
        '[[test]]\nfile = "decay.csv"\nkind = "free"\nname = "release1"\n'
        '[[test]]\nfiles = ["r0.csv", "r1.csv"]\nkind = "random"\nlevels = [0.1, 0.2]\n')
    tests = campaign_tests(tmp_path, MAP)
    assert [(t.name, t.how, t.levels) for t in tests] == [
        ("release1", "manifest", None), ("random", "manifest", (0.1, 0.2))]
    for bad, match in (('[[test]]\nfile = "decay.csv"\nkind = "sine"\n', "kind must be"),
                       ('[[test]]\nfile = "nope.csv"\nkind = "free"\n', "no file"),
                       ('[[test]]\nfile = "decay.csv"\nkind = "free"\nfoo = 1\n',
                        "unknown key"),
                       ('[[test]]\nfiles = ["r0.csv"]\nkind = "random"\nlevels = [0.1]\n'
                        '[[test]]\nfiles = ["r1.csv"]\nkind = "random"\n', "named 'random'")):
        (tmp_path / "campaign.toml").write_text(bad)
        with pytest.raises(CampaignError, match=match):
            campaign_tests(tmp_path, MAP)


@pytest.mark.slow
def test_campaign_command(campaign, tmp_path):
    """The folder in one command: every test, every mode, one page (about 40 s)."""
    out = tmp_path / "out"
    r = runner.invoke(app, ["analyse", "campaign", str(campaign), "--channels",
                            str(campaign / "map.toml"), "--out", str(out)])
    assert r.exit_code == 0, r.output
    assert "decay (free: decay.csv); random (random: r0.csv, r1.csv)" in r.output
    md = (out / "campaign.md").read_text()
    for k in (1, 2, 3):  # every mode of the random test in the page
        assert f"\n| {k} | " in md
    assert (out / "random" / "table2_damping.csv").is_file()
    assert (out / "decay" / "damping_bands.csv").is_file()
    assert "data:image/png;base64," in (out / "campaign.html").read_text()


def test_campaign_rejects(campaign, tmp_path):
    def world(tmp):
        (tmp / "empty").mkdir()
        (tmp / "map.toml").write_text(MAP.to_toml())
    check_cli(tmp_path, campaign, world,
              ["analyse", "campaign", "{tmp}/empty", "--channels", "{tmp}/map.toml", "--out",
               "{tmp}/res"], r"holds no data file")


def test_compare_a_measurement_without_structure(tmp_path):
    """``analyse free`` without a structure writes no mode shapes; ``compare`` analyses it
    again on its own (mode 1 band-passed out of the tank channel) and gets its table."""
    dec = free_decay(BEAM, 8.5, 10.0, FS, seed=5)
    dec["base"] = np.zeros(dec["time"].size)
    _write(tmp_path / "decay.csv", dec)
    (tmp_path / "map.toml").write_text(MAP.to_toml())
    r = runner.invoke(app, ["analyse", "free", str(tmp_path / "decay.csv"), "--channels",
                            str(tmp_path / "map.toml"), "--modes", "1", "--out",
                            str(tmp_path / "m")])
    assert r.exit_code == 0, r.output
    copy = tmp_path / "copy.nc"
    copy.write_bytes((tmp_path / "m" / "free_measured.nc").read_bytes())
    r = runner.invoke(app, ["compare", str(tmp_path / "m" / "free_measured.nc"), str(copy),
                            "--name", "measured=again", "--out", str(tmp_path / "c")])
    assert r.exit_code == 0, r.output
    first = (tmp_path / "m" / "damping_bands.csv").read_text().splitlines()
    z = [ln.split(",")[5] for ln in first[1:]]
    table = (tmp_path / "c" / "analyses.csv").read_text()
    assert all(v in table for v in z if v != "nan"), (z, table)
