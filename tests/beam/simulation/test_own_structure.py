"""Your own structure: the cantilever written in every modal format, read back and coupled,
gives the built-in cantilever's responses; the command line on a structure file."""

from __future__ import annotations

import dataclasses
import warnings

import numpy as np
import pytest
import xarray as xr
from typer.testing import CliRunner

from helpers import TESTS
from sloshrom.beam.simulation.coupled import free_response, random_response
from sloshrom.beam.simulation.modal_files import (
    read_modes,
    write_mode_table,
    write_modes_csv,
    write_modes_netcdf,
    write_modes_punch,
    write_modes_uff,
)
from sloshrom.beam.simulation.modes import ModeSet
from sloshrom.beam.simulation.structure import ModalModel
from sloshrom.cli import app
from sloshrom.models import FrozenLiquid
from sloshrom.rom.loading import load_model

ROM = str(TESTS / "data" / "model_v1_nfir.npz")
KEYS = ("q", "tank_acceleration", "interface_force", "dynamic_force", "station_acceleration")
WRITERS = {"nc": write_modes_netcdf, "csv": write_modes_csv, "pch": write_modes_punch,
           "unv": write_modes_uff}


def _round6(a):
    """Values as UFF 55 stores them (``%13.5e``)."""
    return np.vectorize(lambda v: float(f"{v:.5e}"))(np.asarray(a, dtype=float))


def _responses(modal: ModalModel) -> dict[str, np.ndarray]:
    out = {}
    for name, model in (("frozen", FrozenLiquid(0.002)), ("rom", load_model(ROM))):
        with warnings.catch_warnings():  # the test ROM's envelope is a small one
            warnings.simplefilter("ignore", UserWarning)
            fr = free_response(model, modal, tip_displacement=0.002, duration=1.0)
            rr = random_response(model, modal, (0.05,), duration=4.0, seed=2)
        for k in KEYS:
            out[f"free {name} {k}"], out[f"random {name} {k}"] = fr[k], rr[k]
    return out


@pytest.fixture(scope="module")
def builtin(builtin_modal):
    return builtin_modal


@pytest.fixture(scope="module")
def builtin_responses(builtin):
    return _responses(builtin)


@pytest.mark.parametrize("fmt", ["nc", "csv", "pch", "unv"])
def test_cantilever_from_every_format_couples_like_the_builtin(fmt, tmp_path, builtin,
                                                                 builtin_responses):
    ms = ModeSet.from_cantilever()
    path = WRITERS[fmt](ms, tmp_path / f"cantilever.{fmt}")
    # punch and UFF 55 hold no participation (punch: no damping either): the mode table
    table = write_mode_table(ms, tmp_path / "modes.csv") if fmt in ("pch", "unv") else None
    modal = read_modes(path, mode_table=table).to_modal_model(tanks=5, outputs=[1, 2, 3, 4, 5])
    assert modal.tank_ids == (5,) and modal.station_ids == (1, 2, 3, 4, 5)
    got = _responses(modal)
    if fmt == "unv":
        # the file holds 6 significant digits (the mode table gives masses and participation
        # exactly): equal to round-off to the rounded cantilever, and close to the exact one
        rounded = dataclasses.replace(
            builtin, frequencies=_round6(builtin.frequencies),
            damping=_round6(builtin.damping), psi_tank=_round6(builtin.psi_tank),
            psi_stations=_round6(builtin.psi_stations))
        want, rtol = _responses(rounded), 1e-12
        for k in (k for k in got if "frozen" in k):  # linear: the rounding stays small
            np.testing.assert_allclose(got[k], builtin_responses[k], rtol=0,
                                       atol=1e-4 * np.abs(builtin_responses[k]).max(),
                                       err_msg=k)
    else:
        # NetCDF and CSV hold float64 (repr), our punch 11 significant digits
        want, rtol = builtin_responses, (1e-12 if fmt in ("nc", "csv") else 1e-8)
    for k, v in got.items():
        np.testing.assert_allclose(v, want[k], rtol=0, atol=rtol * np.abs(want[k]).max(),
                                   err_msg=k)


def _cli(*args: str):
    return CliRunner().invoke(app, list(args))


@pytest.fixture(scope="module")
def cantilever_files(tmp_path_factory):
    d = tmp_path_factory.mktemp("structure")
    ms = ModeSet.from_cantilever()
    return (write_modes_punch(ms, d / "cantilever.pch"), write_mode_table(ms, d / "modes.csv"))


@pytest.mark.long  # 3.2-3.5 s in the fast tier under load
def test_cli_structure_file_reproduces_the_builtin_beam(tmp_path, cantilever_files):
    pch, table = cantilever_files
    common = ["beam", "free", "--sloshing", "frozen", "--duration", "2", "--tip-displacement",
              "0.005"]
    res = _cli(*common, "--out", str(tmp_path / "builtin"))
    assert res.exit_code == 0, res.output
    res = _cli(*common, "--structure", str(pch), "--mode-table", str(table), "--tank", "5",
               "--outputs", "1,2,3,4,5", "--uff", "--out", str(tmp_path / "own"))
    assert res.exit_code == 0, res.output
    a = xr.load_dataset(tmp_path / "builtin" / "free_frozen.nc")
    b = xr.load_dataset(tmp_path / "own" / "free_frozen.nc")
    for k in ("tank_acceleration", "station_acceleration", "q"):
        np.testing.assert_allclose(b[k].values, a[k].values, rtol=0,
                                   atol=1e-8 * np.abs(a[k].values).max())
    assert b["station_id"].values.tolist() == [1, 2, 3, 4, 5] and b.attrs["tank_id"] == 5
    import pyuff

    sets = pyuff.UFF(str(tmp_path / "own" / "free_frozen.uff")).read_sets()
    acc5 = [d for d in sets if d["type"] == 58 and d["rsp_node"] == 5
            and d["ordinate_spec_data_type"] == 12]
    assert len(acc5) == 1  # the tank at grid 5 is the output at grid 5: written once
    np.testing.assert_allclose(acc5[0]["data"], a["tank_acceleration"].values, rtol=1e-8,
                               atol=1e-8 * np.abs(a["tank_acceleration"].values).max())
    assert (tmp_path / "own" / "table1_frozen_modes.md").is_file()


@pytest.mark.long  # 3.2-3.5 s in the fast tier under load
def test_cli_two_tanks_with_their_own_models_and_fills(tmp_path, cantilever_files):
    pch, table = cantilever_files
    res = _cli("beam", "free", "--structure", str(pch), "--mode-table", str(table),
               "--tank", "5", "--tank", "3:frozen:fill=0.3", "--sloshing", "rig",
               "--duration", "2", "--out", str(tmp_path / "two"))
    assert res.exit_code == 0, res.output
    ds = xr.load_dataset(tmp_path / "two" / "free_rig.nc")
    assert ds["tank"].values.tolist() == [5, 3]
    assert ds["tank_acceleration"].dims == ("time", "tank")
    np.testing.assert_allclose(ds.attrs["tank_fill"], [0.5, 0.3])
    assert np.all(ds["dynamic_force"].sel(tank=3).values == 0)  # its own model: frozen
    assert np.std(ds["dynamic_force"].sel(tank=5).values) > 0.1  # the rig sloshes
    ref = xr.load_dataset(tmp_path / "two" / "free_frozen.nc")
    assert np.all(ref["dynamic_force"].values == 0)  # the reference: every tank frozen


@pytest.mark.parametrize(("args", "message"), [
    (["--tank", "5"], "--tank places things on a --structure"),
    (["--structure", "PCH", "--tank", "99"], "grid 99 is not in"),
    (["--structure", "PCH"], "at least one --tank"),
    (["--structure", "PCH", "--tank", "5:fill=1.5"], "fill level must be in"),
    (["--structure", "PCH", "--tank", "5", "--tank", "5"], "grid 5 is given twice"),
    (["--structure", "PCH", "--tank", "five"], "integer grid/node ID"),
    (["--structure", "PCH", "--tank", "5:rig:frozen"], "expected GRID"),
    (["--structure", "PCH", "--tank", "5:rig", "--sloshing", "rig"], "every --tank has its own"),
    (["--structure", "PCH", "--tank", "5", "--outputs", "1,x"], "integer grid IDs"),
    (["--structure", "PCH", "--tank", "5", "--direction", "up"], "direction 'up'"),
])
def test_cli_structure_errors(tmp_path, cantilever_files, args, message):
    pch, table = cantilever_files
    args = [str(pch) if a == "PCH" else a for a in args]
    res = _cli("beam", "free", *args, "--mode-table", str(table), "--duration", "2",
               "--out", str(tmp_path / "x")) if "--structure" in args else _cli(
        "beam", "free", *args, "--duration", "2", "--out", str(tmp_path / "x"))
    assert res.exit_code == 2, res.output
    assert message in res.output, res.output
    assert not (tmp_path / "x").exists()


def test_cli_random_needs_participation(tmp_path, cantilever_files):
    pch, _ = cantilever_files
    damping = tmp_path / "damping.csv"
    damping.write_text("mode,damping\n1,0.01\n2,0.005\n3,0.005\n")
    res = _cli("beam", "random", "--structure", str(pch), "--mode-table", str(damping),
               "--tank", "5", "--duration", "40", "--out", str(tmp_path / "r"))
    assert res.exit_code == 2 and "participation" in res.output, res.output
