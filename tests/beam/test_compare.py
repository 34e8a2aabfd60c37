"""Measured against predicted (``sloshrom.beam.compare``, ``sloshrom compare``): the verdicts
follow the intervals, a prediction with the wrong damping is found outside, and bad inputs get
one clear error with nothing written."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
import xarray as xr
from typer.testing import CliRunner

from sloshrom.beam import compare as compare_module
from sloshrom.beam.compare import (
    AnalysedTest,
    CaseNameError,
    analyse_test,
    compare_rows,
    comparison_cases,
    match_levels,
)
from sloshrom.beam.damping.columns import table2_dataset
from sloshrom.beam.damping.uncertainty import format_interval
from sloshrom.beam.errors import BeamError
from sloshrom.beam.results import to_dataset
from sloshrom.beam.simulation.coupled import free_response, random_response
from sloshrom.beam.simulation.structure import CantileverBeam, ModalModel, coupled_frozen_modes
from sloshrom.cli import app
from sloshrom.config import Tank
from sloshrom.models import FrozenLiquid

FS = 500.0
TANK = Tank()


def _modal(zeta1: float) -> ModalModel:
    beam = CantileverBeam.with_tank(TANK)
    return ModalModel.from_beam(beam, TANK, n_modes=3, damping=(zeta1, 0.005, 0.005))


F1 = float(coupled_frozen_modes(_modal(0.01), TANK.liquid_mass)[0][0])


def _noisy(ds: xr.Dataset, rms: float, seed: int) -> xr.Dataset:
    rng = np.random.default_rng(seed)
    ds = ds.copy(deep=True)
    for v in ("station_acceleration", "tank_acceleration", "base_acceleration"):
        ds[v].values = ds[v].values + rms * rng.standard_normal(ds[v].shape)
    return ds


def _dataset(kind: str, zeta1: float, case: str) -> xr.Dataset:
    modal = _modal(zeta1)
    if kind == "free":
        res = free_response(FrozenLiquid(1 / FS), modal, 0.0146, 6.0, TANK)
    else:
        res = random_response(FrozenLiquid(1 / FS), modal, (0.1, 0.2), 70.0, 0, tank=TANK)
    return to_dataset(res, case, kind, TANK, modal, f1=F1)


@pytest.fixture(scope="module")
def random_sets() -> dict[str, xr.Dataset]:
    return {"measured": _noisy(_dataset("random", 0.01, "measured"), 0.014, 1),
            "frozen": _dataset("random", 0.01, "frozen"),
            "stiff": _dataset("random", 0.02, "stiff")}


@pytest.fixture(scope="module")
def free_sets() -> dict[str, xr.Dataset]:
    return {"measured": _noisy(_dataset("free", 0.01, "measured"), 0.014, 2),
            "frozen": _dataset("free", 0.01, "frozen"),
            "stiff": _dataset("free", 0.02, "stiff")}


@pytest.mark.long
def test_random_verdicts_follow_the_damping(random_sets):
    tests = {k: analyse_test(ds) for k, ds in random_sets.items()}
    rows = compare_rows(tests["measured"], [tests["frozen"], tests["stiff"]])
    assert {r["case"] for r in rows} == {"frozen", "stiff"}
    assert len(rows) == 2 * 3 * 2  # levels x estimators x cases
    h1 = [r for r in rows if r["estimator"] == "lscf_h1"]
    # the same linear beam without sensor noise lies inside the noisy measurement's interval;
    # twice its first-mode damping lies outside, at every level
    assert all(r["verdict"] == "inside" for r in h1 if r["case"] == "frozen")
    assert all(r["verdict"] == "outside" and r["z"] > 1.96 for r in h1 if r["case"] == "stiff")
    for r in h1:
        assert r["measured_low"] < r["measured"] < r["measured_high"]
        assert math.isclose(r["difference"], r["predicted"] / r["measured"] - 1)


def test_free_verdicts_follow_the_damping(free_sets):
    tests = {k: analyse_test(ds) for k, ds in free_sets.items()}
    rows = compare_rows(tests["measured"], [tests["frozen"], tests["stiff"]])
    for case, verdict in (("frozen", "inside"), ("stiff", "outside")):
        # bands where both decays hold data (twice the damping leaves the bands sooner)
        got = [r for r in rows if r["case"] == case and np.isfinite(r["measured"])
               and np.isfinite(r["predicted"])]
        assert {r["method"] for r in got} == {"hilbert", "log_decrement"}, case
        assert all(r["verdict"] == verdict for r in got), (case, got)


def _test(kind: str, levels: list[float]) -> AnalysedTest:
    rows = [{"case": "x", "rms_g": lv, "lscf_h1": 0.01, "lscf_h1_std": 0.001,
             "lscf_h1_low": 0.008, "lscf_h1_high": 0.012} for lv in levels]
    return AnalysedTest("x", kind, FS, 10.0, [], levels=levels, table2=table2_dataset(rows))


def test_levels_match_within_ten_percent():
    assert match_levels([0.1, 0.2, 0.4], [0.098, 0.41]) == [0, None, 1]
    with pytest.raises(BeamError, match="no RMS level within 10 %"):
        compare_rows(_test("random", [0.1]), [_test("random", [0.3])])
    with pytest.raises(BeamError, match="free test"):
        compare_rows(_test("random", [0.1]),
                     [AnalysedTest("f", "free", FS, 10.0, [])])


def test_missing_estimates_give_na():
    m, p = _test("random", [0.1]), _test("random", [0.1])
    p.damping["value"].loc[{"level": 0.1, "estimator": "lscf_h1"}] = float("nan")
    row = compare_rows(m, [p])[0]
    assert row["verdict"] == "n/a" and row["consistent"] == "n/a"


# -- command line --------------------------------------------------------------------------------
def _write(ds: xr.Dataset, path: Path) -> Path:
    ds.to_netcdf(path, engine="h5netcdf")
    return path


@pytest.mark.long
def test_cli_compare_random(tmp_path, random_sets):
    files = [_write(ds, tmp_path / f"random_{k}.nc") for k, ds in random_sets.items()]
    out = tmp_path / "cmp"
    r = CliRunner().invoke(app, ["compare", *map(str, files), "--out", str(out)])
    assert r.exit_code == 0, r.output
    assert "stiff" in r.output and "outside" in r.output
    for name in ("comparison.csv", "comparison.md", "analyses.csv", "fig23_comparison.png",
                 "table2_comparison.png"):
        assert (out / name).is_file(), name
    head = (out / "comparison.csv").read_text().splitlines()[0].split(",")
    assert head[:3] == ["rms_g", "estimator", "measured"] and "verdict" in head


def test_cli_compare_free(tmp_path, free_sets):
    files = [_write(ds, tmp_path / f"free_{k}.nc") for k, ds in free_sets.items()]
    out = tmp_path / "cmp"
    r = CliRunner().invoke(app, ["compare", *map(str, files), "--out", str(out)])
    assert r.exit_code == 0, r.output
    assert (out / "fig21_comparison.png").is_file()
    assert (out / "comparison.md").read_text().count("hilbert") >= 2


@pytest.mark.parametrize("what", ["kinds", "twice", "not_netcdf", "old_file", "same_case"])
def test_cli_compare_bad_input(tmp_path, random_sets, free_sets, what):
    a = _write(random_sets["measured"], tmp_path / "a.nc")
    if what == "kinds":
        b, match = _write(free_sets["frozen"], tmp_path / "b.nc"), "free test"
    elif what == "twice":
        b, match = a, "twice"
    elif what == "not_netcdf":
        b = tmp_path / "b.nc"
        b.write_text("time,x\n0,1\n")
        match = "not a readable NetCDF"
    elif what == "old_file":
        b = _write(random_sets["frozen"].drop_vars("psi_stations"), tmp_path / "b.nc")
        match = "lacks psi_stations"
    else:
        b = _write(random_sets["frozen"].assign_attrs(case="measured"), tmp_path / "b.nc")
        match = "case name 'measured'"
    out = tmp_path / "cmp"
    r = CliRunner().invoke(app, ["compare", str(a), str(b), "--out", str(out)])
    assert r.exit_code == 2, r.output
    assert match in " ".join(r.output.split())
    assert not out.exists()


# -- checks before any analysis, renamed cases -----------------------------------------------------
def test_comparison_cases_checks_names_kinds_and_levels(random_sets, free_sets):
    m, f, s = random_sets["measured"], random_sets["frozen"], random_sets["stiff"]
    assert comparison_cases([m, f, s], ["m", "f", "s"]) == ["measured", "frozen", "stiff"]
    twin = f.assign_attrs(case="measured")
    with pytest.raises(CaseNameError, match=r"m and t both have the case name 'measured'"):
        comparison_cases([m, twin], ["m", "t"])
    # renaming the first input that has the case resolves the clash
    assert comparison_cases([m, twin], ["m", "t"], {"measured": "lab"}) == ["lab", "measured"]
    # renames apply to the names as given: no chains, a swap is a swap
    assert comparison_cases([m, f], ["m", "f"], {"measured": "frozen", "frozen": "measured"}) \
        == ["frozen", "measured"]
    with pytest.raises(CaseNameError, match=r"no input has the case 'rom'") as err:
        comparison_cases([m, f], ["m", "f"], {"rom": "x"})
    assert err.value.rename == ("rom", "x")
    with pytest.raises(CaseNameError, match=r"both have the case name 'measured'"):
        comparison_cases([m, f], ["m", "f"], {"frozen": "measured"})
    with pytest.raises(BeamError, match=r"f is a free test, the measurement m a random test"):
        comparison_cases([m, free_sets["frozen"]], ["m", "f"])
    far = f.assign_coords(level=f["level"].values * 3)
    with pytest.raises(BeamError, match=r"far has no RMS level within 10 %"):
        comparison_cases([m, far], ["m", "far"])
    with pytest.raises(BeamError, match=r"old: the beam result lacks psi_stations"):
        comparison_cases([m, f.drop_vars("psi_stations")], ["m", "old"])


def test_cli_compare_refuses_same_case_names_before_any_analysis(tmp_path, random_sets,
                                                                  monkeypatch):
    a = _write(random_sets["measured"], tmp_path / "a.nc")
    b = _write(random_sets["frozen"].assign_attrs(case="measured"), tmp_path / "b.nc")
    calls = []
    monkeypatch.setattr(compare_module, "analyse_test",
                        lambda *a, **k: calls.append(a) or pytest.fail("analysed"))
    r = CliRunner().invoke(app, ["compare", str(a), str(b), "--out", str(tmp_path / "cmp")])
    assert r.exit_code == 2 and calls == []
    assert "rename one with --name OLD=NEW" in " ".join(r.output.split())


def test_cli_compare_renames_a_case(tmp_path, free_sets):
    a = _write(free_sets["measured"], tmp_path / "a.nc")
    b = _write(free_sets["frozen"].assign_attrs(case="measured"), tmp_path / "b.nc")
    out = tmp_path / "cmp"
    r = CliRunner().invoke(app, ["compare", str(a), str(b), "--name", "measured=lab",
                                 "--out", str(out)])
    assert r.exit_code == 0, r.output
    assert "of lab (z = " in r.output
    rows = (out / "comparison.csv").read_text().splitlines()
    case = rows[0].split(",").index("case")
    assert {ln.split(",")[case] for ln in rows[1:]} == {"measured"}  # the prediction's name
    assert {ln.split(",")[0] for ln in (out / "analyses.csv").read_text().splitlines()[1:]} \
        == {"lab", "measured"}


def test_compare_reads_measured_files_of_both_versions(free_sets):
    """A measured result of format version 1 (the built-in model's values in its attributes)
    and one of version 2 (only what was measured or given) are analysed alike."""
    new = free_sets["measured"].copy()
    for key in ("seed", "modal_frequencies_Hz", "modal_damping", "liquid_mass",
                "structure_mass", "tank_fill"):
        new.attrs.pop(key, None)
    new.attrs.update(origin="measured", source="lab.uff", format_version=2,
                     structure="built-in cantilever model (not measured)")
    old = free_sets["measured"].copy()
    old.attrs.pop("format_version", None)
    old.attrs.update(origin="measured", source="lab.uff")
    a, b = analyse_test(old), analyse_test(new)
    assert a.source == b.source == "lab.uff"
    for ra, rb in zip(a.rows, b.rows, strict=True):
        assert ra.keys() == rb.keys()
        np.testing.assert_array_equal([ra["zeta"], ra["low"], ra["high"]],
                                      [rb["zeta"], rb["low"], rb["high"]])


# -- printing intervals ------------------------------------------------------------------------
def test_format_interval_resolves_the_width():
    assert format_interval(1.36841, 1.37512) == ("1.3684", "1.3751")
    assert format_interval(1.0, 2.0, 1.234) == ("1.0", "2.0", "1.2")  # values share decimals
    assert format_interval(1.37, 1.37) == ("1.37", "1.37")  # no width: 3 significant digits
    assert format_interval(250.0, 980.0) == ("250", "980")  # never negative decimals
    assert format_interval(1.0, 1.0 + 1e-12) == ("1.000000", "1.000000")  # capped
    assert format_interval(float("nan"), 2.0, float("inf")) == ("—", "2.00", "—")
    rng = np.random.default_rng(0)
    for _ in range(500):
        width = 10 ** rng.uniform(-5, 2)  # down to what 6 decimals resolve
        mid = width * 10 ** rng.uniform(0, 5)
        lo, hi = mid - width / 2, mid + width / 2
        a, b = format_interval(lo, hi)
        # the bounds differ visibly, and the printed width is the width to two digits
        assert a != b, (lo, hi)
        assert abs((float(b) - float(a)) - width) <= 0.1 * width + 1e-12, (lo, hi, a, b)


def test_cli_compare_refuses_a_comparison_of_only_na(tmp_path, free_sets, monkeypatch):
    """Every row n/a: exit 2 naming the first row's reason, nothing written."""
    real = compare_module.compare_rows

    def all_na(measured, predicted):
        return [dict(r, verdict="n/a", reason="measured: no estimate (test)")
                for r in real(measured, predicted)]

    monkeypatch.setattr(compare_module, "compare_rows", all_na)
    files = [_write(free_sets[k], tmp_path / f"free_{k}.nc") for k in ("measured", "frozen")]
    out = tmp_path / "cmp"
    r = CliRunner().invoke(app, ["compare", *map(str, files), "--out", str(out)])
    assert r.exit_code == 2, r.output
    assert ("error: no comparison, nothing written: every row is n/a; the first, frozen: "
            "measured: no estimate (test)") in r.output
    assert not out.exists()


def test_structures_and_sample_rates_are_checked(free_sets):
    """One structure within 15 % of f1; fs the rate of the time axis within 0.1 %."""
    m = free_sets["measured"]
    f1 = float(m.attrs["f1_Hz"])
    compare_module.check_structures([m, m.assign_attrs(f1_Hz=1.14 * f1)], ["m", "p"])
    with pytest.raises(BeamError, match=r"p predicts a structure whose first mode is at "
                       r"11\.8\d Hz, the measurement m has it at 10\.19 Hz \(\+16 %"):
        compare_module.check_structures([m, m.assign_attrs(f1_Hz=1.16 * f1)], ["m", "p"])
    compare_module.check_sample_rate(m.assign_attrs(fs=FS * 1.0009))
    with pytest.raises(BeamError, match=r"attribute 'fs' says 500\.55 Hz but the time axis is "
                       r"sampled at 500 Hz"):
        compare_module.check_sample_rate(m.assign_attrs(fs=FS * 1.0011))


def test_cli_compare_refuses_levels_that_are_not_the_base_rms(tmp_path, random_sets):
    """A result whose level labels are swapped (0.2 g on the 0.1 g run) would match each
    prediction to the wrong run: refused before any analysis, both values named."""
    a = _write(random_sets["measured"].assign_coords(level=[0.2, 0.1]), tmp_path / "a.nc")
    b = _write(random_sets["frozen"], tmp_path / "b.nc")
    out = tmp_path / "cmp"
    r = CliRunner().invoke(app, ["compare", str(a), str(b), "--out", str(out)])
    assert r.exit_code == 2, r.output
    assert ("a.nc: the levels given do not match the measured base RMS (level 1: 0.2 g given, "
            "its base RMS 0.1 g; level 2: 0.1 g given, its base RMS 0.2 g)") in r.output
    assert not out.exists()
