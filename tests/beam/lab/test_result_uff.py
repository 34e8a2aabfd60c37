"""Beam results as UFF dataset 58: channels, nodes, units, FRFs, multi-tank, atomic writes."""

from __future__ import annotations

import numpy as np
import pytest
import pyuff
import xarray as xr

from sloshrom.beam.damping.analysis import frf_h1
from sloshrom.beam.lab.uff58 import BASE_NODE, FIRST_TANK_NODE, write_result_uff
from sloshrom.beam.results import to_dataset
from sloshrom.beam.simulation.coupled import free_response, random_response
from sloshrom.beam.simulation.structure import coupled_frozen_modes
from sloshrom.config import Tank
from sloshrom.fileio import OutputBatch
from sloshrom.io.uff import read_uff58
from sloshrom.models import FrozenLiquid

# ASCII dataset 58 writes "%20.11e": 12 significant digits, so every value is within half a
# unit of the 12th digit (measured: 4.98e-12 relative, the bound itself)
ASCII_RTOL = 5e-12
# the abscissa increment has 6 significant digits ("%13.5e"): 0.1220703125 Hz -> 0.122070 Hz
FREQ_RTOL = 5e-6

SPEC = {"base_acceleration": 12, "station_acceleration": 12, "tank_acceleration": 12,
        "tank_velocity": 11, "interface_force": 9, "dynamic_force": 13}
UNIT = {12: "m/s^2", 11: "m/s", 9: "N", 13: "N"}


@pytest.fixture(scope="module")
def modal(builtin_modal):
    return builtin_modal


@pytest.fixture(scope="module")
def free_ds(modal):
    res = free_response(FrozenLiquid(1 / 500), modal, duration=2.0)
    return to_dataset(res, "frozen", "free", Tank(), modal)


@pytest.fixture(scope="module")
def random_ds(modal):
    res = random_response(FrozenLiquid(1 / 500), modal, (0.1, 0.2), duration=40.0, seed=0)
    return to_dataset(res, "frozen", "random", Tank(), modal, seed=0)


@pytest.fixture(scope="module")
def random_file(random_ds, tmp_path_factory):
    path = write_result_uff(random_ds, tmp_path_factory.mktemp("uff") / "random_frozen.uff")
    return path, pyuff.UFF(str(path)).read_sets()


def _close(got, want, rtol):
    """Equal to ``rtol`` relative, value by value (real and imaginary parts separately)."""
    got, want = np.asarray(got), np.asarray(want)
    for g, w in ((got.real, want.real), (np.imag(got), np.imag(want))):
        assert np.all(np.abs(g - w) <= rtol * np.abs(w)), np.max(np.abs(g - w) / np.abs(w))


def _expected(ds, s):
    """The dataset variable a time-history dataset of the file holds."""
    level = s["load_case_id"] - 1 if "level" in ds.dims else None
    var = s["id5"].strip()
    da = ds[var]
    if var == "station_acceleration":
        da = da.isel(station=s["rsp_node"] - 1) if "station_id" not in ds.coords else \
            da.isel(station=list(ds["station_id"].values).index(s["rsp_node"]))
    elif "tank" in da.dims:
        da = da.sel(tank=s["rsp_node"])
    return da.isel(level=level).values if level is not None else da.values


def test_random_run_channels_nodes_units_and_values(random_ds, random_file):
    ds, (_, sets) = random_ds, random_file
    n_st, levels = ds.sizes["station"], ds["level"].values
    # 164 + per level: base, 5 stations, tank acceleration/velocity/2 forces, 5 FRFs, 5 coherences
    assert len(sets) == 1 + len(levels) * (1 + n_st + 4 + 2 * n_st) == 41
    assert sets[0]["type"] == 164 and sets[0]["units_code"] == 1
    time_sets = [s for s in sets[1:] if s["func_type"] == 1]
    assert len(time_sets) == len(levels) * (n_st + 5)
    for s in time_sets:
        var = s["id5"].strip()
        level = levels[s["load_case_id"] - 1]
        assert s["id1"].strip().endswith(f" {level:g} g RMS") and var in s["id1"]
        assert f"level {level:g} g RMS" in s["id3"]
        assert s["rsp_dir"] == 3 and (s["ref_node"], s["ref_dir"]) == (0, 0)
        assert s["ordinate_spec_data_type"] == SPEC[var]
        assert s["ordinate_axis_units_lab"].strip() == UNIT[SPEC[var]]
        assert s["abscissa_spec_data_type"] == 17 and s["abscissa_axis_units_lab"] == "s"
        assert s["abscissa_min"] == 0.0 and s["abscissa_inc"] == 1 / ds.attrs["fs"]
        expected_node = {"base_acceleration": BASE_NODE, "station_acceleration": None}.get(
            var, FIRST_TANK_NODE)
        if expected_node is not None:
            assert s["rsp_node"] == expected_node
        _close(s["data"], _expected(ds, s), ASCII_RTOL)
    stations = [s for s in time_sets if s["id5"].strip() == "station_acceleration"
                and s["load_case_id"] == 1]
    assert [s["rsp_node"] for s in stations] == list(range(1, n_st + 1))
    assert stations[1]["id1"].strip() == "station_acceleration 0.296 m 0.1 g RMS"


def test_frfs_equal_frf_h1_and_peak_at_first_coupled_mode(random_ds, random_file, modal):
    ds, (_, sets) = random_ds, random_file
    fs = ds.attrs["fs"]
    f1, f2 = coupled_frozen_modes(modal, Tank().liquid_mass)[0][:2]
    frfs = [s for s in sets if s.get("func_type") == 4]
    cohs = [s for s in sets if s.get("func_type") == 6]
    assert len(frfs) == len(cohs) == ds.sizes["level"] * ds.sizes["station"]
    for s in frfs + cohs:
        lv, k = s["load_case_id"] - 1, s["rsp_node"] - 1
        f, h, coh = frf_h1(ds["base_acceleration"].values[lv],
                           ds["station_acceleration"].values[lv, :, k], fs, 4096)
        assert (s["ref_node"], s["ref_dir"], s["rsp_dir"]) == (BASE_NODE, 3, 3)
        assert s["abscissa_spec_data_type"] == 18 and s["abscissa_axis_units_lab"] == "Hz"
        assert s["num_pts"] == f.size and s["x"][0] == 0.0
        _close(s["x"][1:], f[1:], FREQ_RTOL)
        if s["func_type"] == 4:
            assert s["ord_data_type"] == 6 and np.iscomplexobj(s["data"])
            assert (s["ordinate_spec_data_type"], s["orddenom_spec_data_type"]) == (12, 12)
            assert s["ordinate_axis_units_lab"] == s["orddenom_axis_units_lab"] == "m/s^2"
            _close(s["data"], h, ASCII_RTOL)
            # the frozen beam is linear: |H| peaks at its first coupled mode (below mode 2)
            band = f < 0.5 * (f1 + f2)
            peak = f[band][np.argmax(np.abs(h[band]))]
            assert abs(peak - f1) <= f[1], (k, peak, f1)
        else:
            assert s["ord_data_type"] == 4 and s["ordinate_spec_data_type"] == 1
            _close(s["data"], coh, ASCII_RTOL)
    tip = [s for s in frfs if s["rsp_node"] == ds.sizes["station"]]
    for s in tip:  # at the tip (the tank) the first mode is the global peak
        assert abs(s["x"][np.argmax(np.abs(s["data"]))] - f1) <= s["abscissa_inc"]


def test_binary_file_is_exact(random_ds, tmp_path):
    path = write_result_uff(random_ds, tmp_path / "r.uff", binary=True)
    sets = pyuff.UFF(str(path)).read_sets()
    assert len(sets) == 41
    for s in sets[1:]:
        if s["func_type"] == 1:
            np.testing.assert_array_equal(s["data"], _expected(random_ds, s))
    s = next(s for s in sets[1:] if s["func_type"] == 4)
    _, h, _ = frf_h1(random_ds["base_acceleration"].values[0],
                     random_ds["station_acceleration"].values[0, :, 0], 500.0)
    np.testing.assert_array_equal(s["data"], h)


def test_read_uff58_reads_the_time_histories_and_skips_the_frfs(random_ds, random_file,
                                                               free_ds, tmp_path):
    rec = read_uff58(random_file[0])
    assert rec.fs == 500.0 and rec.attrs["uff_skipped_non_time_datasets"] == 20
    assert len(rec.names) == 20
    _close(rec["station_acceleration_0_74_m_0_2_g_rms"],
           random_ds["station_acceleration"].values[1, :, -1], ASCII_RTOL)
    _close(rec["interface_force_0_1_g_rms"], random_ds["interface_force"].values[0], ASCII_RTOL)
    rec = read_uff58(write_result_uff(free_ds, tmp_path / "free.uff"))
    assert rec.names[:2] == ["base_acceleration", "station_acceleration_0_148_m"]
    assert rec.units["velocity"] == "m/s" and "uff_skipped_non_time_datasets" not in rec.attrs


def test_free_run_writes_time_histories_only(free_ds, tmp_path):
    sets = pyuff.UFF(str(write_result_uff(free_ds, tmp_path / "f.uff", frf=True))).read_sets()
    assert len(sets) == 1 + 1 + free_ds.sizes["station"] + 4
    for s in sets[1:]:
        assert s["func_type"] == 1 and s["load_case_id"] == 0
        assert "free" in s["id2"] and s["id3"].strip() == "free"
        _close(s["data"], _expected(free_ds, s), ASCII_RTOL)


def _hand_ds(tank_ids=(7, 9), station_ids=(11, 12, 13), random=False, n=512, fs=200.0):
    """A small multi-tank result, built by hand (as the multi-tank simulator will)."""
    rng = np.random.default_rng(1)
    lead = ("level",) if random else ()
    nl = (2,) if random else ()
    nt, ns = len(tank_ids), len(station_ids)
    base = rng.standard_normal((*nl, n))
    tank = {"units": "m/s^2"}
    ds = xr.Dataset(
        {
            "base_acceleration": ((*lead, "time"), base, {"units": "m/s^2"}),
            "station_acceleration": ((*lead, "time", "station"),
                                     base[..., None] * np.arange(1, ns + 1)
                                     + 0.1 * rng.standard_normal((*nl, n, ns)), tank),
            "tank_acceleration": ((*lead, "time", "tank"), rng.standard_normal((*nl, n, nt)),
                                  tank),
            "tank_velocity": ((*lead, "time", "tank"), rng.standard_normal((*nl, n, nt)),
                              {"units": "m/s"}),
            "interface_force": ((*lead, "time", "tank"), rng.standard_normal((*nl, n, nt)),
                                {"units": "N"}),
            "dynamic_force": ((*lead, "time", "tank"), rng.standard_normal((*nl, n, nt)),
                              {"units": "N"}),
        },
        coords={"time": np.arange(n) / fs, "station": np.linspace(0.2, 0.6, ns),
                "station_id": ("station", list(station_ids)), "tank": list(tank_ids)},
        attrs={"case": "two tanks", "test": "random" if random else "free", "fs": fs},
    )
    return ds.assign_coords(level=[0.1, 0.3]) if random else ds


def test_multi_tank_one_channel_per_tank_with_its_id(tmp_path):
    ds = _hand_ds()
    sets = pyuff.UFF(str(write_result_uff(ds, tmp_path / "m.uff"))).read_sets()[1:]
    assert len(sets) == 1 + 3 + 4 * 2
    by_var: dict[str, list[int]] = {}
    for s in sets:
        by_var.setdefault(s["id5"].strip(), []).append(s["rsp_node"])
        _close(s["data"], _expected(ds, s), ASCII_RTOL)
    assert by_var == {"base_acceleration": [BASE_NODE], "station_acceleration": [11, 12, 13],
                      "tank_acceleration": [7, 9], "tank_velocity": [7, 9],
                      "interface_force": [7, 9], "dynamic_force": [7, 9]}
    assert sets[4]["id1"].strip() == "tank_acceleration tank 7"
    assert sets[4]["rsp_ent_name"].strip() == "tank"
    # random, two levels: FRFs referenced to the base, responses at the station IDs
    ds = _hand_ds(random=True)
    sets = pyuff.UFF(str(write_result_uff(ds, tmp_path / "r.uff", nperseg=128))).read_sets()
    frfs = [s for s in sets if s.get("func_type") == 4]
    assert [(s["rsp_node"], s["load_case_id"]) for s in frfs] == \
        [(i, lv) for lv in (1, 2) for i in (11, 12, 13)]
    assert frfs[0]["num_pts"] == 65 and frfs[0]["abscissa_inc"] == pytest.approx(200 / 128)
    # no tank coordinate: tanks numbered from FIRST_TANK_NODE
    sets = pyuff.UFF(str(write_result_uff(_hand_ds().drop_vars("tank"),
                                          tmp_path / "n.uff"))).read_sets()
    assert [s["rsp_node"] for s in sets[1:] if s["id5"].strip() == "dynamic_force"] == \
        [FIRST_TANK_NODE, FIRST_TANK_NODE + 1]


def test_write_is_atomic(free_ds, tmp_path, monkeypatch):
    path = tmp_path / "result.uff"
    path.write_text("previous result\n")
    original = pyuff.UFF.write_sets

    def fail_half_way(self, dsets, mode="add", force_double=True):
        original(self, dsets[:3], mode=mode, force_double=force_double)
        raise OSError("disk full")

    monkeypatch.setattr(pyuff.UFF, "write_sets", fail_half_way)
    with pytest.raises(OSError, match="disk full"):
        write_result_uff(free_ds, path)
    with pytest.raises(OSError, match="disk full"):
        write_result_uff(free_ds, tmp_path / "new.uff")
    assert path.read_text() == "previous result\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["result.uff"]
    monkeypatch.setattr(pyuff.UFF, "write_sets", original)
    # in a batch: the file appears at the commit, or not at all
    with pytest.raises(RuntimeError), OutputBatch() as batch:
        write_result_uff(free_ds, tmp_path / "b.uff", batch=batch)
        raise RuntimeError("a later file failed")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["result.uff"]
    with OutputBatch() as batch:
        write_result_uff(free_ds, path, batch=batch)
        assert path.read_text() == "previous result\n"
    assert len(pyuff.UFF(str(path)).read_sets()) == 11


def test_bad_datasets_are_refused(free_ds, tmp_path):
    out = tmp_path / "x.uff"
    for test in ("harmonic", None):
        ds = free_ds.copy()
        ds.attrs["test"] = test
        if test is None:
            del ds.attrs["test"]
        with pytest.raises(ValueError, match=r"test=.*expected 'free' or 'random'"):
            write_result_uff(ds, out)
    ds = _hand_ds()
    ds.attrs["test"] = "random"
    with pytest.raises(ValueError, match="no 'level' dimension"):
        write_result_uff(ds, out)
    with pytest.raises(ValueError, match="'level' dimension"):
        write_result_uff(_hand_ds(random=True).assign_attrs(test="free"), out)
    with pytest.raises(ValueError, match=r"'station_acceleration 0.2 m' .* node 7"):
        write_result_uff(_hand_ds(station_ids=(7, 8, 10)), out)
    with pytest.raises(ValueError, match="node IDs must be integers"):
        write_result_uff(_hand_ds(tank_ids=(0, 1)), out)
    ds = _hand_ds()
    del ds["tank_velocity"].attrs["units"]
    with pytest.raises(ValueError, match="'tank_velocity' has no units"):
        write_result_uff(ds, out)
    ds["tank_velocity"].attrs["units"] = "N"
    with pytest.raises(ValueError, match="'tank_velocity' is in 'N'"):
        write_result_uff(ds, out)
    ds = _hand_ds()
    ds["dynamic_force"][0, 0] = np.nan
    with pytest.raises(ValueError, match="'dynamic_force' holds NaN"):
        write_result_uff(ds, out)
    ds = _hand_ds(random=True)
    ds["base_acceleration"][1] = 0.0
    ds["station_acceleration"][1] = 0.0
    with pytest.raises(ValueError, match="level 0.3 g RMS: .*H1 FRF is not defined"):
        write_result_uff(ds, out)
    assert not out.exists()
    write_result_uff(ds, out, frf=False)  # the time histories alone are fine
    # a known non-SI unit is converted; a case name of any length and characters fits its line
    ds = _hand_ds().assign_attrs(case="line\nbreak é " * 20)
    ds["base_acceleration"].attrs["units"] = "g"
    s = pyuff.UFF(str(write_result_uff(ds, out))).read_sets(1)
    _close(s["data"], ds["base_acceleration"].values * 9.80665, ASCII_RTOL)
    assert s["id2"].startswith("sloshrom: case line?break ? line") and len(s["id2"]) <= 80
