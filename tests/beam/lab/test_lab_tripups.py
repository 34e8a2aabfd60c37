"""What a laboratory engineer trips over, each case once (issue 53): units asked for every
channel in one message and per file, a mis-scaled station named, node numbers that change
between files, an ambiguous unit refused, band messages and table cells that say what they
mean."""

from __future__ import annotations

import csv
import textwrap

import numpy as np
import pytest

from helpers import runner
from sloshrom.beam.damping.analysis import AnalysisError, half_power_damping, noise_floor
from sloshrom.beam.damping.peaks import given_modes, mode_bands
from sloshrom.beam.lab.channels import ChannelMap, ChannelMapError, acceleration_unit
from sloshrom.beam.lab.every_mode import (
    TestModes,
    check_station_amplitudes,
    free_mode_decays,
    free_mode_rows,
    modes_of_test,
)
from sloshrom.beam.lab.measured import read_free_test, read_random_test
from sloshrom.beam.lab.synthetic import LabBeam, free_decay
from sloshrom.beam.lab.uff58 import channel_identity, check_channel_identity
from sloshrom.beam.lab.virtual import write_lab_campaign
from sloshrom.beam.results import write_table
from sloshrom.cli import app
from sloshrom.io.record import MissingUnitError, RecordError

# a decay has no base channel: the map's base is left out, with a note
pytestmark = pytest.mark.filterwarnings("ignore::sloshrom.beam.lab.measured.MissingChannelNote")


# -- units -----------------------------------------------------------------------------------------
def test_a_capital_g_is_refused_with_the_accepted_spellings():
    """``G`` is giga- in SI and a gravity unit in some software: refused, naming ``g``; the
    lower-case ``g`` and the SI spellings stay accepted."""
    why = acceleration_unit("G")
    assert why is not None and "ambiguous" in why and "'g'" in why and "m/s^2" in why
    assert acceleration_unit("g") is None and acceleration_unit("m/s2") is None
    with pytest.raises(ChannelMapError, match=r"\[units\] 'acc1': 'G' is ambiguous"):
        ChannelMap(stations=("acc1",), positions=(1.0,), units={"acc1": "G"})


# -- messages and tables ---------------------------------------------------------------------------
def test_a_band_in_a_message_has_four_significant_digits():
    """A band's edges are computed (geometric means of two modes): 16 digits say nothing."""
    f = np.linspace(0.0, 250.0, 2049)
    rising = f  # largest at the band's upper edge: no peak inside
    with pytest.raises(AnalysisError, match=r"no peak inside band 143\.1-189\.5 Hz") as err:
        half_power_damping(f, rising, (143.08389147201, 189.4827361))
    assert "143.0838" not in str(err.value)


def test_tables_keep_a_reason_s_commas_and_bars(tmp_path):
    """The CSV quotes a text with commas (every CSV reader gets the reason back whole); the
    Markdown table escapes ``|`` so that ``|H1|`` stays ``|H1|`` and the cell stays one cell."""
    reason = "low coherence at the mode: 0.43 at 12.5 Hz (the peak of |H1|, 5 % wide), below 0.5"
    rows = [{"mode": 1, "zeta": float("nan"), "reason": reason},
            {"mode": 2, "zeta": 0.0062, "reason": ""}]
    csv_path, md_path = write_table(rows, tmp_path / "t")
    with csv_path.open(newline="") as fh:
        back = list(csv.DictReader(fh))
    assert [r["reason"] for r in back] == [reason, ""]
    assert [r["mode"] for r in back] == ["1", "2"]
    line = md_path.read_text().splitlines()[2]
    assert r"the peak of \|H1\|, 5 % wide" in line
    # the row has as many cells as the header: the escaped bars split nothing
    assert line.replace(r"\|", "").count("|") == 4


# -- a campaign whose sensor set-up changes between the random runs and the decay -----------------
@pytest.fixture(scope="module")
def setups(tmp_path_factory):
    """Random runs (34 s, 0.1 / 0.2 g) with every station in g at nodes 1-5; a decay (8 s) with
    acc2 and acc4 in m/s^2 at nodes 11-15; no unit labels (the units must be given)."""
    d = tmp_path_factory.mktemp("setups")
    cmap = write_lab_campaign(d, levels=(0.1, 0.2), duration=34.0, decay_duration=8.0,
                              units=["g"] * 5, decay_units=["g", "m/s^2", "g", "m/s^2", "g"],
                              decay_nodes=[11, 12, 13, 14, 15], unit_labels=False)
    labelled = tmp_path_factory.mktemp("labelled")
    write_lab_campaign(labelled, levels=(0.1, 0.2), duration=34.0, decay_duration=8.0,
                       units=["g"] * 5, decay_units=["g", "m/s^2", "g", "m/s^2", "g"],
                       decay_nodes=[11, 12, 13, 14, 15])
    return {"dir": d, "labelled": labelled, "map": cmap}


def test_every_channel_without_a_unit_in_one_message(setups):
    """Six unlabelled channels: one error names all six, with the options and the [units]
    table to paste (a placeholder no run accepts, so that nobody's guess becomes a unit)."""
    d = setups["dir"]
    with pytest.raises(MissingUnitError) as err:
        read_random_test([d / "random_0.1g.uff"], setups["map"], None)
    assert err.value.channels == ["base", "acc1", "acc2", "acc3", "acc4", "acc5"]
    assert "channels 'base', 'acc1'" in str(err.value)
    (d / "channels.toml").write_text(setups["map"].to_toml())
    r = runner.invoke(app, ["analyse", "random", str(d / "random_0.1g.uff"), "--channels",
                            str(d / "channels.toml"), "--out", str(d / "out")])
    assert r.exit_code == 2
    err_text = r.stderr if r.stderr_bytes is not None else r.output
    assert ("random_0.1g.uff: 6 channels have no unit in the file (UFF 58 datasets 1, 2, 3, 4, "
            "5, 6, ordinate unit labels empty): 'base', 'acc1', 'acc2'") in " ".join(
                err_text.split())
    lines = err_text.splitlines()
    assert ("  --unit base=UNIT --unit acc1=UNIT --unit acc2=UNIT --unit acc3=UNIT "
            "--unit acc4=UNIT --unit acc5=UNIT") in lines
    assert '  acc5 = "UNIT"' in lines and "  [units]" in lines
    # the placeholder is refused, not read as a unit
    with pytest.raises(ChannelMapError, match="unknown unit 'UNIT'"):
        setups["map"].with_units({"acc1": "UNIT"})


def test_units_per_file_from_the_map_s_file_patterns(setups):
    """The map's [units] for the random runs, a [units."decay*.uff"] table for the decay: each
    file is read in its own units (against the same files with unit labels)."""
    d, ref_dir = setups["dir"], setups["labelled"]
    text = setups["map"].to_toml() + textwrap.dedent('''
        [units]
        base = "g"
        acc1 = "g"
        acc2 = "g"
        acc3 = "g"
        acc4 = "g"
        acc5 = "g"

        [units."decay*.uff"]
        acc2 = "m/s^2"
        acc4 = "m/s^2"
        ''')
    (d / "per_file.toml").write_text(text)
    cmap = ChannelMap.from_toml(d / "per_file.toml")
    assert cmap.units_for("decay.uff")["acc2"] == "m/s^2"
    assert cmap.units_for("random_0.1g.uff")["acc2"] == "g"
    assert ChannelMap.from_toml(_written(cmap, d / "again.toml")) == cmap  # round trip
    free = read_free_test(d / "decay.uff", cmap, None)
    ref = read_free_test(ref_dir / "decay.uff", setups["map"], None)
    np.testing.assert_allclose(free["station_acceleration"], ref["station_acceleration"],
                               rtol=1e-10)
    rnd = read_random_test([d / "random_0.1g.uff"], cmap, None)
    ref = read_random_test([ref_dir / "random_0.1g.uff"], setups["map"], None)
    np.testing.assert_allclose(rnd["station_acceleration"], ref["station_acceleration"],
                               rtol=1e-10)
    # --unit wins over the map's [units] and its patterns
    assert cmap.with_units({"acc2": "g"}).units_for("decay.uff")["acc2"] == "g"


def _written(cmap: ChannelMap, path):
    path.write_text(cmap.to_toml())
    return path


def test_a_station_in_the_wrong_unit_is_named(setups):
    """The random runs' units applied to the decay: acc2 and acc4 read 9.81 times too large.
    The amplitudes against the other stations name both, with the unit mix-up."""
    d = setups["dir"]
    cmap = setups["map"].with_units({c: "g" for c in setups["map"].channels})
    res = read_free_test(d / "decay.uff", cmap, None)
    modes = modes_of_test(res, "free")
    # (8.8-9.0 rather than 9.81: the uniform cantilever's shape stands in for the beam's)
    with pytest.raises(AnalysisError, match=r"'acc2' moves [89]\.\d+ x as much as its mode "
                       r"shape and the other stations say \(data in m/s\^2 read as g\?\); "
                       r"'acc4' moves [89]\.\d+ x .* at mode 1 \(10\.3\d? Hz\)"):
        check_station_amplitudes(res, modes)
    # with the decay's own units nothing is named
    good = read_free_test(setups["labelled"] / "decay.uff", setups["map"], None)
    check_station_amplitudes(good, modes_of_test(good, "free"))


def test_node_numbers_that_change_between_files_are_named(setups, tmp_path):
    """A map by node numbers fits one file only: where the laboratory renumbered the nodes
    (acc1 is node 1 in the random runs, 2 in the decay), it reads another accelerometer.
    One line names both nodes and recommends labels; a map by labels reads both set-ups."""
    write_lab_campaign(tmp_path, levels=(0.1,), duration=34.0, decay_duration=8.0,
                       decay_nodes=[2, 1, 3, 4, 5])
    by_node = ChannelMap(stations=tuple(f"{k}:+Z" for k in range(1, 6)),
                         positions=setups["map"].positions, base="base")
    rnd = read_random_test([tmp_path / "random_0.1g.uff"], by_node, None)
    free = read_free_test(tmp_path / "decay.uff", by_node, None)  # reads, silently swapped
    with pytest.raises(RecordError, match=r"the channel map's '1:\+Z' is 'acc1' in "
                       r"random_0.1g.uff but is 'acc2' in decay.uff, where 'acc1' is 2:\+Z: "
                       r"the node numbers change between the files, so a map by node numbers "
                       r"fits one file only; name the channels by their labels \('acc1', "
                       r"...\) in the map"):
        check_channel_identity([*rnd["channel_identity"], *free["channel_identity"]])
    # a node the other file does not have at all, while its channel is there elsewhere
    d = setups["labelled"]
    ident = channel_identity(*_uff_record(d / "decay.uff"), list(by_node.channels))
    with pytest.raises(RecordError, match=r"'1:\+Z' is 'acc1' in random_0.1g.uff but finds no "
                       r"channel in decay.uff, where 'acc1' is 11:\+Z"):
        check_channel_identity([*rnd["channel_identity"], ident])
    # by labels, the same files agree
    by_label = read_free_test(tmp_path / "decay.uff", setups["map"], None)
    rnd = read_random_test([tmp_path / "random_0.1g.uff"], setups["map"], None)
    check_channel_identity([*rnd["channel_identity"], *by_label["channel_identity"]])


def _uff_record(path):
    from sloshrom.io.read import read_record

    return read_record(path), path


# -- free decays: every band an interval ---------------------------------------------------------
def test_a_decay_that_stops_above_its_floor_still_gives_every_band_an_interval():
    """6 s of the 10.3 Hz mode (1.37 %) end at 2 % of its start, above the noise floor: the
    floor's tail fit has no noise to measure (NaN), and the closed forms gave a band shorter
    than one smoothing window no interval. The bootstrap takes the noise the spectrum shows
    away from the modes: every band has one, each within 4 of its std of the truth (a 4-sigma
    check: 6e-5 per band for a calibrated std)."""
    beam = LabBeam()
    d = free_decay(beam, 8.5, 6.0, 500.0, noise_g=0.002, seed=5)
    n = d["time"].size
    res = {"fs": 500.0, "time": d["time"], "station_acceleration": d["stations"],
           "tank_acceleration": d["stations"][:, -1], "base_acceleration": np.zeros(n)}
    assert np.isnan(noise_floor(d["stations"][:, -1], 500.0, 10.3))  # the case
    modes = TestModes(given_modes(beam.frequencies), mode_bands(beam.frequencies, 500.0),
                      "given")
    rows = [r for r in free_mode_rows(res, "short", modes, free_mode_decays(res, modes))
            if r["mode"] == 1 and np.isfinite(r["zeta"])]
    assert any(r["method"] == "hilbert" and r["n_cycles"] < 4 for r in rows)  # short bands
    for r in rows:
        assert np.isfinite(r["std"]) and r["reason"] == "", r
        assert abs(r["zeta"] - beam.damping[0]) < 4 * r["std"], r
