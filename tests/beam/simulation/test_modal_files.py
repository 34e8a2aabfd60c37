"""Modal models (structures) from files: ModeSet, UFF 55, Nastran punch, NetCDF, CSV, tables."""

from __future__ import annotations

import dataclasses
import re

import numpy as np
import pytest
import pyuff  # a hard dependency: an import error must fail, not skip

from sloshrom.beam.simulation.modal_files import (
    MASS_UNITS,
    read_mode_table,
    read_modes,
    write_mode_table,
    write_modes_csv,
    write_modes_netcdf,
    write_modes_punch,
    write_modes_uff,
)
from sloshrom.beam.simulation.modes import ModeSet
from sloshrom.beam.simulation.structure import ModalDataError, ModalModel

FIELDS = ("frequencies", "damping", "modal_masses", "psi_tank", "participation",
          "psi_stations", "stations")


@pytest.fixture(scope="module")
def cantilever() -> ModeSet:
    return ModeSet.from_cantilever()


@pytest.fixture(scope="module")
def beam_model(builtin_modal) -> ModalModel:
    return builtin_modal


def _round6(a):
    """Values as UFF 55 stores them: ``%13.5e``, 6 significant digits."""
    return np.vectorize(lambda v: float(f"{v:.5e}"))(np.asarray(a, dtype=float))


def _rounded_set(ms: ModeSet) -> ModeSet:
    return dataclasses.replace(
        ms, frequencies=_round6(ms.frequencies), modal_masses=_round6(ms.modal_masses),
        damping=_round6(ms.damping), shapes=_round6(ms.shapes))


def _assert_sets(a: ModeSet, b: ModeSet, rtol: float, participation: bool = True) -> None:
    np.testing.assert_array_equal(a.nodes, b.nodes)
    assert (a.coordinates is None) == (b.coordinates is None)
    for name in ("frequencies", "modal_masses", "damping", "shapes", "coordinates"):
        if getattr(b, name) is None:
            continue
        np.testing.assert_allclose(getattr(a, name), getattr(b, name), rtol=rtol, atol=0,
                                   err_msg=name)
    if participation:
        np.testing.assert_allclose(a.participation, b.participation, rtol=rtol, atol=0)


def _assert_model(a: ModalModel, b: ModalModel, rtol: float = 0.0) -> None:
    for name in FIELDS:
        if rtol:
            np.testing.assert_allclose(getattr(a, name), getattr(b, name), rtol=rtol,
                                       err_msg=name)
        else:
            np.testing.assert_array_equal(getattr(a, name), getattr(b, name), err_msg=name)
    assert a.structure_mass == b.structure_mass


# -- ModeSet ----------------------------------------------------------------------------------
def test_cantilever_mode_set_reproduces_from_beam_exactly(cantilever, beam_model):
    assert cantilever.nodes.tolist() == [1, 2, 3, 4, 5]
    np.testing.assert_array_equal(cantilever.coordinates[:, 0], beam_model.stations)
    assert not np.any(cantilever.shapes[:, :2, :])
    modal = cantilever.to_modal_model(tanks=5, outputs=[1, 2, 3, 4, 5])
    _assert_model(modal, beam_model)
    assert modal.psi_tank.shape == (3,)
    assert modal.attrs == {"modes_source": "cantilever:euler-bernoulli", "direction": "+Z"}
    # default outputs: every node (5 <= 64)
    _assert_model(cantilever.to_modal_model(tanks=5), beam_model)


def test_direction_picks_component_and_sign(cantilever, beam_model):
    down = cantilever.to_modal_model(tanks=5, direction="-z")
    np.testing.assert_array_equal(down.psi_tank, -beam_model.psi_tank)
    np.testing.assert_array_equal(down.participation, -beam_model.participation)
    np.testing.assert_array_equal(down.psi_stations, -beam_model.psi_stations)
    assert down.attrs["direction"] == "-Z"
    # a mode shape that is zero at the tank is allowed (x: the beam does not move along it)
    side = cantilever.to_modal_model(tanks=5, direction="+X")
    assert not np.any(side.psi_tank) and not np.any(side.participation)
    with pytest.raises(ModalDataError, match=r"direction 'up'.*\+X, -X, \+Y"):
        cantilever.to_modal_model(tanks=5, direction="up")


def test_stations_without_coordinates_are_indices(cantilever):
    ms = dataclasses.replace(cantilever, coordinates=None)
    modal = ms.to_modal_model(tanks=5, outputs=[2, 4])
    np.testing.assert_array_equal(modal.stations, [0.0, 1.0])
    np.testing.assert_array_equal(modal.psi_stations, cantilever.shapes[[1, 3], 2, :])


def test_conversion_errors(cantilever):
    wing = dataclasses.replace(cantilever, source="punch:wing.pch")
    with pytest.raises(ModalDataError, match=r"grid 2001 is not in wing\.pch \(nodes 1\.\.5\)"):
        wing.to_modal_model(tanks=2001)
    with pytest.raises(ModalDataError, match="grid 9 is not in wing.pch"):
        wing.to_modal_model(tanks=5, outputs=[1, 9])
    undamped = dataclasses.replace(wing, damping=None)
    with pytest.raises(ModalDataError, match=r"no modal damping in wing\.pch: give a mode "
                                             "table with a damping column"):
        undamped.to_modal_model(tanks=5)
    np.testing.assert_array_equal(
        undamped.to_modal_model(tanks=5, damping=[0.02, 0.02, 0.02]).damping, 0.02)
    n = 70
    big = ModeSet([5.0], [1.0], np.arange(1, n + 1), np.ones((n, 3, 1)), damping=[0.01],
                  participation=np.ones((3, 1)), source="uff55:big.unv")
    with pytest.raises(ModalDataError, match=r"big\.unv has 70 nodes: give outputs="):
        big.to_modal_model(tanks=1)
    assert big.to_modal_model(tanks=1, outputs=[1, 70]).psi_stations.shape == (2, 1)


def test_select_modes_and_table(cantilever):
    two = cantilever.select_modes(2)
    assert two.n_modes == 2 and two.shapes.shape == (5, 3, 2)
    with pytest.raises(ModalDataError, match="the file holds 3 modes, 6 requested"):
        cantilever.select_modes(6)
    t = cantilever.with_table({"damping": [0.02, 0.03, 0.04], "modal_mass": [1, 2, 3],
                               "participation": [4, 5, 6]})
    np.testing.assert_array_equal(t.damping, [0.02, 0.03, 0.04])
    np.testing.assert_array_equal(t.modal_masses, [1, 2, 3])
    np.testing.assert_array_equal(t.participation[2], [4, 5, 6])
    np.testing.assert_array_equal(t.participation[0], cantilever.participation[0])
    # a longer table serves a reduced set; a shorter one is an error
    assert two.with_table({"damping": [0.1, 0.2, 0.3]}).damping.tolist() == [0.1, 0.2]
    with pytest.raises(ModalDataError, match=r"damping lists 2 mode\(s\); the mode set holds 3"):
        cantilever.with_table({"damping": [0.1, 0.2]})
    with pytest.raises(ModalDataError, match="unknown column"):
        cantilever.with_table({"zeta": [0.1, 0.2, 0.3]})
    # a participation component without any participation in the set: the others unknown
    bare = dataclasses.replace(cantilever, participation=None).with_table(
        {"participation_y": [1, 2, 3]})
    assert np.isnan(bare.participation[[0, 2]]).all()


@pytest.mark.parametrize(("change", "message"), [
    ({"frequencies": [10.0, -1.0, 30.0]}, "frequency of mode 2 is -1.0 Hz"),
    ({"frequencies": [10.0, np.nan, 30.0]}, "frequencies of mode 2 is nan"),
    ({"modal_masses": [1.0, 0.0, 1.0]}, "modal mass of mode 2 is 0.0 kg"),
    ({"modal_masses": [1.0, np.inf, 1.0]}, "modal_masses of mode 2 is inf"),
    ({"shapes": np.zeros((5, 2, 3))}, r"shapes must have shape \(n_nodes, 3, n_modes\)"),
    ({"nodes": [1, 2, 3, 3, 5]}, r"duplicate node ID\(s\) \[3\]"),
    ({"damping": [0.01, 1.0, 0.01]}, r"damping ratios must be in \[0, 1\)"),
    ({"damping": [0.01, -0.1, 0.01]}, r"damping ratios must be in \[0, 1\)"),
    ({"frequencies": [], "modal_masses": [], "shapes": np.zeros((5, 3, 0)),
      "damping": None, "participation": None}, "no modes"),
    ({"participation": np.zeros((1, 3))}, r"participation must have shape \(3, n_modes\)"),
    ({"coordinates": np.zeros((5, 2))}, r"coordinates must have shape \(n_nodes, 3\)"),
])
def test_mode_set_validation(cantilever, change, message):
    with pytest.raises(ModalDataError, match=message):
        dataclasses.replace(cantilever, **change)


def test_mode_set_rejects_non_finite_shape(cantilever):
    shapes = np.array(cantilever.shapes)
    shapes[3, 2, 1] = np.nan
    with pytest.raises(ModalDataError, match="mode 2 is not finite at node 4"):
        dataclasses.replace(cantilever, shapes=shapes)
    assert not cantilever.shapes.flags.writeable  # frozen, arrays included


# -- round trips ------------------------------------------------------------------------------
def test_netcdf_and_csv_round_trip(tmp_path, cantilever, beam_model):
    for writer, name in ((write_modes_netcdf, "m.nc"), (write_modes_csv, "m.csv")):
        back = read_modes(writer(cantilever, tmp_path / name))
        _assert_sets(back, cantilever, rtol=1e-12)
        assert back.source == f"{'netcdf' if name.endswith('nc') else 'csv'}:{name}"
        _assert_model(back.to_modal_model(tanks=5, outputs=[1, 2, 3, 4, 5]), beam_model,
                      rtol=1e-12)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["m.csv", "m.nc"]  # no temporaries


def test_punch_round_trip_with_mode_table(tmp_path, cantilever, beam_model):
    pch = write_modes_punch(cantilever, tmp_path / "wing.pch")
    lines = pch.read_text().splitlines()
    assert all(len(ln) == 80 for ln in lines)
    assert lines[7][72:].strip() == "8"  # sequence number
    bare = read_modes(pch)  # no masses, no damping, no participation in a punch
    np.testing.assert_array_equal(bare.modal_masses, 1.0)
    assert bare.damping is None and bare.participation is None and bare.coordinates is None
    table = write_mode_table(cantilever, tmp_path / "modes.csv")
    back = read_modes(pch, mode_table=table)
    _assert_sets(back, dataclasses.replace(cantilever, coordinates=None), rtol=1e-9)
    modal = back.to_modal_model(tanks=5, outputs=[1, 2, 3, 4, 5])
    np.testing.assert_array_equal(modal.stations, np.arange(5.0))  # no coordinates in a punch
    for name in FIELDS[:-1]:
        np.testing.assert_allclose(getattr(modal, name), getattr(beam_model, name), rtol=1e-9)


def test_uff_round_trip_to_six_digits(tmp_path, cantilever, beam_model):
    unv = write_modes_uff(cantilever, tmp_path / "wing.unv")
    back = read_modes(unv)
    assert back.participation is None  # dataset 55 holds none
    assert back.source == "uff55:wing.unv"
    want = _rounded_set(cantilever)
    _assert_sets(back, want, rtol=0, participation=False)  # exactly the 6-digit values
    _assert_sets(back, cantilever, rtol=5e-6, participation=False)
    # participation from a mode table; the conversion equals the rounded beam model
    table = tmp_path / "gamma.csv"
    table.write_text("mode,participation_kg\n" + "".join(
        f"{k + 1},{float(g)!r}\n" for k, g in enumerate(beam_model.participation)))
    modal = read_modes(unv, mode_table=table).to_modal_model(tanks=5)
    rounded = dataclasses.replace(
        beam_model, frequencies=_round6(beam_model.frequencies),
        damping=_round6(beam_model.damping), modal_masses=_round6(beam_model.modal_masses),
        psi_tank=_round6(beam_model.psi_tank), psi_stations=_round6(beam_model.psi_stations))
    _assert_model(modal, rounded)


def _uff_sets(ms, length=1.0, force=1.0, code=1, mass=None, analysis=2, nodes_of=None,
              data_ch=2, with_164=True):
    """Datasets as another tool writes them: 164 with the given factors, 2411 and 55s in file
    units (SI value x factor; mass factor = force / length)."""
    sets = []
    if with_164:
        sets.append(pyuff.prepare_164(
            units_code=code, units_description="user", temp_mode=1, length=float(length),
            force=float(force), temp=1.0, temp_offset=273.15, return_full_dict=True))
    z = np.zeros(ms.n_nodes, dtype=int)
    c = ms.coordinates * length
    sets.append(pyuff.prepare_2411(node_nums=ms.nodes, def_cs=z, disp_cs=z, color=z + 1,
                                   x=c[:, 0], y=c[:, 1], z=c[:, 2], return_full_dict=True))
    masses = ms.modal_masses * force / length if mass is None else mass
    for k in range(ms.n_modes):
        nodes = ms.nodes if nodes_of is None else nodes_of(k)
        rows = np.searchsorted(ms.nodes, nodes)
        kw = {"r1": ms.shapes[rows, 0, k], "r2": ms.shapes[rows, 1, k],
              "r3": ms.shapes[rows, 2, k]}
        if data_ch == 3:
            kw |= {"r4": kw["r1"] * 0 + 7.0, "r5": kw["r1"] * 0, "r6": kw["r1"] * 0}
        if analysis == 2:
            kw |= {"freq": float(ms.frequencies[k]), "modal_m": float(masses[k]),
                   "modal_damp_vis": float(ms.damping[k]), "modal_damp_his": 0.0}
        else:
            kw |= {"eig": complex(-1.0, 2 * np.pi * ms.frequencies[k]),
                   "r1": kw["r1"] + 0j, "r2": kw["r2"] + 0j, "r3": kw["r3"] + 0j}
        sets.append(pyuff.prepare_55(
            id1="NONE", id2="NONE", id3="NONE", id4="NONE", id5="NONE", model_type=1,
            analysis_type=analysis, data_ch=data_ch, spec_data_type=8,
            data_type=2 if analysis == 2 else 5, n_data_per_node=3 * (data_ch - 1),
            node_nums=nodes, load_case=1, mode_n=k + 1, **kw))
    return sets


def _write_uff(path, sets):
    pyuff.UFF(str(path)).write_sets(sets, mode="overwrite")
    return path


@pytest.mark.parametrize(("length", "force", "kg_per_mass_unit"), [
    (1000.0, 1.0, 1000.0),  # mm, N, s: mass unit = N s^2/mm = tonne
    (1 / 0.0254, 1 / 4.4482216152605, 175.12683524647636),  # in, lbf, s: slinch
])
def test_uff_164_units(tmp_path, cantilever, length, force, kg_per_mass_unit):
    assert length / force == pytest.approx(kg_per_mass_unit, rel=1e-12)
    unv = _write_uff(tmp_path / "u.unv", _uff_sets(cantilever, length, force))
    back = read_modes(unv)
    np.testing.assert_allclose(back.modal_masses, cantilever.modal_masses, rtol=5e-6)
    np.testing.assert_allclose(back.coordinates, cantilever.coordinates, rtol=1e-14,
                               atol=1e-16)
    np.testing.assert_array_equal(back.shapes, _round6(cantilever.shapes))  # not scaled
    # mass_unit= overrides the unit dataset 164 implies
    np.testing.assert_allclose(read_modes(unv, mass_unit="kg").modal_masses,
                               _round6(cantilever.modal_masses / kg_per_mass_unit))


def test_uff_six_dof_keeps_translations_and_no_164_is_si(tmp_path, cantilever):
    unv = _write_uff(tmp_path / "six.unv", _uff_sets(cantilever, data_ch=3, with_164=False))
    back = read_modes(unv)
    np.testing.assert_array_equal(back.shapes, _round6(cantilever.shapes))
    assert "SI assumed" in back.attrs["uff_units"]


def test_punch_mass_units(tmp_path, cantilever):
    pch = write_modes_punch(cantilever, tmp_path / "mm.pch")
    np.testing.assert_array_equal(read_modes(pch, mass_unit="t").modal_masses, 1000.0)
    np.testing.assert_array_equal(read_modes(pch, mass_unit="Mg").modal_masses, 1000.0)
    np.testing.assert_array_equal(read_modes(pch, mass_unit="g").modal_masses, 1e-3)
    slinch = read_modes(pch, mass_unit="lbf*s^2/in").modal_masses
    np.testing.assert_allclose(slinch, 175.1268, rtol=1e-6)
    assert MASS_UNITS["lbf*s^2/in"] == pytest.approx(4.4482216152605 / 0.0254)
    with pytest.raises(ModalDataError, match=r"mass_unit 'mg': use one of"):
        read_modes(pch, mass_unit="mg")
    # a mode table's masses are kg, never scaled
    t = read_modes(pch, mass_unit="t", mode_table={"modal_mass": [2.0, 3.0, 4.0]})
    np.testing.assert_array_equal(t.modal_masses, [2.0, 3.0, 4.0])


# -- a punch file as Nastran writes it --------------------------------------------------------
NASTRAN_PUNCH = """\
$TITLE   = WING GVT CORRELATION                                                1
$SUBTITLE=                                                                     2
$LABEL   = NORMAL MODES                                                        3
$EIGENVECTOR                                                                   4
$REAL OUTPUT                                                                   5
$SUBCASE ID =           1                                                      6
$EIGENVALUE =  3.9478418E+03  MODE =     1                                     7
       101       G      0.000000E+00      0.000000E+00      2.500000E-01       8
-CONT-                  0.000000E+00     -1.250000E-02      0.000000E+00       9
       102       G      1.000000E-03     -2.000000E-03      1.000000E+00      10
-CONT-                  0.000000E+00     -2.500000E-02      0.000000E+00      11
      9001       S      4.000000E-01                                          12
$TITLE   = WING GVT CORRELATION                                               13
$SUBTITLE=                                                                    14
$LABEL   = NORMAL MODES                                                       15
$EIGENVECTOR                                                                  16
$REAL OUTPUT                                                                  17
$SUBCASE ID =           1                                                     18
$EIGENVALUE =  1.5791367E+05  MODE =     2                                    19
       101       G      0.000000E+00      0.000000E+00     -6.000000E-01      20
-CONT-                  0.000000E+00      3.000000E-02      0.000000E+00      21
       102       G      0.000000E+00      0.000000E+00      1.000000E+00      22
-CONT-                  0.000000E+00      5.000000E-02      0.000000E+00      23
      9001       S     -1.000000E-01                                          24
"""


def test_hand_written_nastran_punch(tmp_path):
    pch = tmp_path / "wing.pch"
    pch.write_text(NASTRAN_PUNCH)
    ms = read_modes(pch, mode_table={"damping": [0.01, 0.02], "participation": [0.3, 0.2]})
    np.testing.assert_allclose(ms.frequencies, [10.0, 63.245553], rtol=1e-7)
    assert ms.nodes.tolist() == [101, 102]
    np.testing.assert_array_equal(ms.shapes[:, :, 0], [[0, 0, 0.25], [1e-3, -2e-3, 1.0]])
    np.testing.assert_array_equal(ms.shapes[:, 2, 1], [-0.6, 1.0])
    np.testing.assert_array_equal(ms.modal_masses, 1.0)
    assert ms.attrs["ignored_scalar_points"] == [9001]
    assert ms.attrs["subcase"] == 1
    modal = ms.to_modal_model(tanks=102, outputs=[101, 102])
    np.testing.assert_array_equal(modal.psi_tank, [1.0, 1.0])
    # the same text without column alignment (whitespace-separated) still parses
    loose = tmp_path / "loose.pch"
    loose.write_text(re.sub(r"^( +)(\d+) +G", r"\2 G", NASTRAN_PUNCH, flags=re.M))
    np.testing.assert_array_equal(read_modes(loose).shapes, ms.shapes)


def _punch_with(tmp_path, old, new, name="bad.pch"):
    p = tmp_path / name
    p.write_text(NASTRAN_PUNCH.replace(old, new))
    return p


def test_punch_errors(tmp_path):
    static = _punch_with(tmp_path, "$EIGENVECTOR", "$DISPLACEMENTS")
    with pytest.raises(ModalDataError, match=r"holds no eigenvectors \(found DISPLACEMENTS\) "
                                             r"\(is it a SOL 103 DISPLACEMENT\(PUNCH\)\?\)"):
        read_modes(static)
    cplx = _punch_with(tmp_path, "$REAL OUTPUT", "$REAL-IMAGINARY OUTPUT")
    with pytest.raises(ModalDataError, match="line 5: complex eigenvectors"):
        read_modes(cplx)
    neg = _punch_with(tmp_path, "=  3.9478418E+03  MODE", "= -1.2000000E-04  MODE")
    with pytest.raises(ModalDataError, match=r"mode 1 \(line 7\) has eigenvalue -0\.00012 "
                                             r"\(rad/s\)\^2: a rigid-body or mechanism mode"):
        read_modes(neg)
    grids = _punch_with(tmp_path, "       102       G      0.000000E+00",
                        "       103       G      0.000000E+00")
    with pytest.raises(ModalDataError, match=r"mode 2 \(line 19\) lists 2 grids, mode 1 lists 2;"
                                             r" missing \[102\]; extra \[103\]"):
        read_modes(grids)
    garbage = _punch_with(tmp_path, "       102       G      1.000000E-03",
                          "       102       G      1.0000O0E-03")
    with pytest.raises(ModalDataError, match=r"line 10: cannot read"):
        read_modes(garbage)
    truncated = tmp_path / "cut.pch"
    truncated.write_text("\n".join(NASTRAN_PUNCH.splitlines()[:20]) + "\n")
    with pytest.raises(ModalDataError, match=r"mode 2 .* lists 1 grids, mode 1 lists 2; "
                                             r"missing \[102\].*truncated file"):
        read_modes(truncated)


# -- NetCDF and CSV specifics -----------------------------------------------------------------
def test_netcdf_units(tmp_path, cantilever):
    import xarray as xr

    path = write_modes_netcdf(cantilever, tmp_path / "m.nc")
    with xr.open_dataset(path, engine="h5netcdf") as ds:
        ds = ds.load()
    rad = ds.copy()
    rad["frequency"] = rad["frequency"] * 2 * np.pi
    rad["frequency"].attrs["units"] = "rad/s"
    rad["coordinates"] = rad["coordinates"] * 1000
    rad["coordinates"].attrs["units"] = "mm"
    rad["modal_mass"] = rad["modal_mass"] / 1000
    rad["modal_mass"].attrs["units"] = "t"
    rad.to_netcdf(tmp_path / "rad.nc", engine="h5netcdf")
    _assert_sets(read_modes(tmp_path / "rad.nc"), cantilever, rtol=1e-14)

    def broken(name, **change):
        bad = ds.copy()
        for var, unit in change.items():
            if unit is None:
                del bad[var].attrs["units"]
            else:
                bad[var].attrs["units"] = unit
        bad.to_netcdf(tmp_path / name, engine="h5netcdf")
        return tmp_path / name

    with pytest.raises(ModalDataError, match=r"modal_mass has unit 'm'; expected a mass \(kg\)"):
        read_modes(broken("m1.nc", modal_mass="m"))
    with pytest.raises(ModalDataError, match="frequency has no units attribute"):
        read_modes(broken("m2.nc", frequency=None))
    with pytest.raises(ModalDataError, match=r"shape has unit 'm'; expected dimensionless"):
        read_modes(broken("m3.nc", shape="m"))
    other = ds.copy()
    other.attrs["format"] = "something-else"
    other.to_netcdf(tmp_path / "other.nc", engine="h5netcdf")
    with pytest.raises(ModalDataError, match="not a sloshrom modal-model file"):
        read_modes(tmp_path / "other.nc")
    with pytest.raises(ModalDataError, match="mass_unit= is for punch and UFF"):
        read_modes(path, mass_unit="t")


def test_csv_units_and_errors(tmp_path, cantilever):
    good = write_modes_csv(cantilever, tmp_path / "m.csv").read_text()
    mm = tmp_path / "mm.csv"
    lines = good.splitlines()
    mm.write_text(lines[1].replace("x_m,y_m,z_m", "x_mm,y_mm,z_mm") + "\n" + "\n".join(
        ",".join(c if j not in (8, 9, 10) else repr(float(c) * 1000)
                 for j, c in enumerate(ln.split(","))) for ln in lines[2:]) + "\n")
    np.testing.assert_allclose(read_modes(mm).coordinates, cantilever.coordinates, rtol=1e-15)

    def variant(name, text):
        (tmp_path / name).write_text(text)
        return tmp_path / name

    with pytest.raises(ModalDataError, match=r"column 'frequency_kHz' has unit 'kHz'; expected "
                                             r"a frequency"):
        read_modes(variant("u.csv", good.replace("frequency_Hz", "frequency_kHz")))
    with pytest.raises(ModalDataError, match=r"unknown column 'shape_z_m'"):
        read_modes(variant("s.csv", good.replace("shape_z", "shape_z_m")))
    with pytest.raises(ModalDataError, match=r"line 4, column 3: 'ten' is not a number"):
        rows = good.splitlines()
        rows[3] = ",".join(["1", "2", "ten", *rows[3].split(",")[3:]])
        read_modes(variant("n.csv", "\n".join(rows) + "\n"))
    with pytest.raises(ModalDataError, match=r"mode 3 lists 3 node rows, mode 1 lists 5 .*"
                                             r"truncated file"):
        read_modes(variant("t.csv", "\n".join(good.splitlines()[:-2]) + "\n"))
    with pytest.raises(ModalDataError, match=r"line 3 has \d+ cells, the header 14"):
        read_modes(variant("c.csv", good[: good.index("\n", good.index("\n") + 1) + 40]))


# -- files that are not modal models ---------------------------------------------------------
def test_missing_empty_and_unknown_files(tmp_path, cantilever):
    with pytest.raises(ModalDataError, match=r"nope\.unv: no such file"):
        read_modes(tmp_path / "nope.unv")
    for suffix in (".unv", ".pch", ".nc", ".csv"):
        (tmp_path / f"empty{suffix}").write_bytes(b"")
        with pytest.raises(ModalDataError, match=rf"empty\{suffix}: file is empty"):
            read_modes(tmp_path / f"empty{suffix}")
    (tmp_path / "m.op2").write_bytes(b"\0" * 10)
    with pytest.raises(ModalDataError, match=r"OP2 is not read.*DISPLACEMENT\(PUNCH\)"):
        read_modes(tmp_path / "m.op2")
    nc = write_modes_netcdf(cantilever, tmp_path / "cut.nc")
    nc.write_bytes(nc.read_bytes()[:2000])
    with pytest.raises(ModalDataError, match=r"cut\.nc: not a readable NetCDF file"):
        read_modes(nc)


def test_uff_errors(tmp_path, cantilever):
    unv = write_modes_uff(cantilever, tmp_path / "cut.unv")
    unv.write_bytes(unv.read_bytes()[:-200])
    with pytest.raises(ModalDataError, match=r"cut\.unv: truncated or not a UFF file"):
        read_modes(unv)
    nodes_only = _write_uff(tmp_path / "nodes.unv", _uff_sets(cantilever)[:2])
    with pytest.raises(ModalDataError, match=r"holds no mode shapes \(dataset 55\); dataset "
                                             r"types \[164, 2411\]"):
        read_modes(nodes_only)
    cplx = _write_uff(tmp_path / "cplx.unv", _uff_sets(cantilever, analysis=3))
    with pytest.raises(ModalDataError, match=r"analysis type 3 \(complex eigenvalue first "
                                             r"order\), not normal modes \(2\)"):
        read_modes(cplx)
    ragged = _write_uff(tmp_path / "ragged.unv", _uff_sets(
        cantilever, nodes_of=lambda k: cantilever.nodes[: 5 - k]))
    with pytest.raises(ModalDataError, match=r"mode 2 \(dataset 4\) lists 4 nodes, mode 1 "
                                             r"lists 5; every mode must list the same nodes"):
        read_modes(ragged)
    massless = _write_uff(tmp_path / "massless.unv", _uff_sets(cantilever, mass=[0.0] * 3))
    with pytest.raises(ModalDataError, match=r"no modal mass for mode\(s\) 1, 2, 3 in the file: "
                                             "give a mode table with a modal_mass column"):
        read_modes(massless)
    fixed = read_modes(massless, mode_table={"modal_mass": [1.0, 2.0, 3.0]})
    np.testing.assert_array_equal(fixed.modal_masses, [1.0, 2.0, 3.0])


# -- mode tables ------------------------------------------------------------------------------
def test_mode_tables(tmp_path):
    toml = tmp_path / "modes.toml"
    toml.write_text("[modes]\ndamping = [0.01, 0.02]\nmodal_mass = [1.5, 2.5]\n"
                    "participation = [0.3, -0.1]\n")
    t = read_mode_table(toml)
    assert t["damping"].tolist() == [0.01, 0.02] and t["participation"].tolist() == [0.3, -0.1]
    csv = tmp_path / "modes.csv"
    csv.write_text("# from the f06\nmode,damping,modal_mass_t\n2,0.02,0.0025\n1,0.01,0.0015\n")
    t = read_mode_table(csv)  # rows in any order, masses converted to kg
    assert t["damping"].tolist() == [0.01, 0.02]
    np.testing.assert_allclose(t["modal_mass"], [1.5, 2.5], rtol=1e-15)
    for text, message in [
        ("mode,damping\n1,0.01\n1,0.02\n", r"each row's mode number, an integer >= 1, each "
                                             r"once .*got \[1, 1\]"),
        ("mode,damping\n0,0.01\n2.5,0.02\n", r"an integer >= 1, each once"),
        ("mode,zeta\n1,0.01\n", r"unknown column 'zeta'"),
        ("mode,damping\n1,1.5\n", r"damping ratios must be in \[0, 1\)"),
        ("mode,modal_mass_lbs\n1,2\n", r"has unit 'lbs'; expected a mass"),
        ("damping\n0.01\n", "no 'mode' column"),
    ]:
        csv.write_text(text)
        with pytest.raises(ModalDataError, match=message):
            read_mode_table(csv)
    toml.write_text("[damping]\nx = 1\n")
    with pytest.raises(ModalDataError, match=r"no \[modes\] table"):
        read_mode_table(toml)


# -- hostile modal files: nothing may change the physics without a word -----------------------
def _reversed_punch(tmp_path, ms):
    """The punch of ``ms`` with its mode blocks in reverse order (as a concatenation gives)."""
    lines = write_modes_punch(ms, tmp_path / "fwd.pch").read_text().splitlines()
    per = len(lines) // ms.n_modes
    blocks = [lines[k * per:(k + 1) * per] for k in range(ms.n_modes)]
    p = tmp_path / "rev.pch"
    p.write_text("\n".join(ln for b in blocks[::-1] for ln in b) + "\n")
    return p


def test_mode_table_is_matched_by_mode_number_not_position(tmp_path, cantilever):
    table = write_mode_table(cantilever, tmp_path / "t.csv")
    fwd = read_modes(write_modes_punch(cantilever, tmp_path / "fwd.pch"), mode_table=table)
    rev = read_modes(_reversed_punch(tmp_path, cantilever), mode_table=table)
    assert rev.mode_numbers.tolist() == [1, 2, 3]
    for name in ("frequencies", "damping", "modal_masses", "shapes", "participation"):
        np.testing.assert_array_equal(getattr(rev, name), getattr(fwd, name), err_msg=name)
    np.testing.assert_allclose(rev.damping, cantilever.damping)
    # a file without its rigid-body modes: numbered 7..9, and a table of those numbers
    ms7 = dataclasses.replace(cantilever, mode_numbers=[7, 8, 9])
    pch7 = write_modes_punch(ms7, tmp_path / "m7.pch")
    t7 = tmp_path / "t7.csv"
    t7.write_text("mode,damping\n9,0.03\n7,0.01\n8,0.02\n")
    assert read_modes(pch7, mode_table=t7).damping.tolist() == [0.01, 0.02, 0.03]
    with pytest.raises(ModalDataError, match=r"damping lists 3 mode\(s\); the mode set holds 3, "
                                             r"numbered up to 9 \(a table is matched to the "
                                             r"modes by mode number"):
        read_modes(pch7, mode_table={"damping": [0.01, 0.02, 0.03]})
    toml = tmp_path / "t7.toml"
    toml.write_text("[modes]\nmode = [8, 7, 9]\ndamping = [0.02, 0.01, 0.03]\n")
    assert read_modes(pch7, mode_table=toml).damping.tolist() == [0.01, 0.02, 0.03]
    with pytest.raises(ModalDataError, match=r"no row for mode\(s\) 9 of the mode set"):
        read_modes(pch7, mode_table={"mode": [7, 8], "damping": [0.01, 0.02]})
    # every format keeps the numbers; select_modes keeps the lowest
    for writer, name in ((write_modes_csv, "m7.csv"), (write_modes_netcdf, "m7.nc"),
                         (write_modes_uff, "m7.unv")):
        back = read_modes(writer(ms7, tmp_path / name))
        assert back.mode_numbers.tolist() == [7, 8, 9], name
        assert back.select_modes(2).mode_numbers.tolist() == [7, 8]
    assert read_mode_table(write_mode_table(ms7, tmp_path / "w7.csv"))["mode"].tolist() == [7, 8, 9]


def test_netcdf_and_csv_modes_in_another_order_read_sorted(tmp_path, cantilever):
    import xarray as xr

    with xr.open_dataset(write_modes_netcdf(cantilever, tmp_path / "m.nc"),
                         engine="h5netcdf") as ds:
        ds = ds.load()
    ds.isel(mode=[2, 0, 1]).to_netcdf(tmp_path / "shuffled.nc", engine="h5netcdf")
    back = read_modes(tmp_path / "shuffled.nc")
    _assert_sets(back, cantilever, rtol=1e-12)
    ds.assign_coords(mode=[1, 1, 2]).to_netcdf(tmp_path / "twice.nc", engine="h5netcdf")
    with pytest.raises(ModalDataError, match=r"coordinate mode must hold distinct integer mode "
                                             r"numbers"):
        read_modes(tmp_path / "twice.nc")
    lines = write_modes_csv(cantilever, tmp_path / "m.csv").read_text().splitlines()
    (tmp_path / "r.csv").write_text("\n".join([*lines[:2], *lines[2:][::-1]]) + "\n")
    back = read_modes(tmp_path / "r.csv")
    np.testing.assert_array_equal(back.frequencies, cantilever.frequencies)
    np.testing.assert_array_equal(back.shapes[::-1], cantilever.shapes)  # nodes as listed


@pytest.mark.parametrize(("fields", "message"), [
    ({"modal_damp_vis": -0.01}, r"mode 1 \(dataset \d+\) has viscous damping ratio -0\.01"),
    ({"modal_damp_vis": float("nan")}, r"mode 1 .* viscous damping ratio nan"),
    ({"modal_damp_vis": 1.5}, r"viscous damping ratio 1\.5; it must be in \[0, 1\)"),
    ({"modal_damp_vis": 0.0, "modal_damp_his": -0.02},
     r"hysteretic damping \(loss factor\) -0\.02; it must be in \[0, 2\)"),
    ({"modal_m": -2.0}, r"the modal mass of mode 1 is -2\.0 in the file; a modal mass .* must "
                        r"be positive and finite"),
    ({"modal_m": float("nan")}, r"the modal mass of mode 1 is nan in the file"),
])
def test_uff_unphysical_damping_and_mass_are_refused(tmp_path, cantilever, fields, message):
    sets = _uff_sets(cantilever)
    for st in sets:
        if st["type"] == 55:
            st.update(fields)
    unv = _write_uff(tmp_path / "bad.unv", sets)
    with pytest.raises(ModalDataError, match=message):
        read_modes(unv)
    # a mode table never hides a wrong value of the file
    with pytest.raises(ModalDataError, match=message):
        read_modes(unv, mode_table={"damping": [0.01] * 3, "participation": [1.0] * 3})


def test_punch_cut_inside_a_number_is_refused(tmp_path, cantilever):
    text = write_modes_punch(cantilever, tmp_path / "w.pch").read_text()
    lines = text.splitlines()
    grid = len(lines) - 2  # the last grid line, then its -CONT-
    for cut in (lines[:grid] + [lines[grid][:60]],  # inside T3, no line break
                lines[:-1] + [lines[-1][:30]]):  # inside the last -CONT-
        p = tmp_path / "cut.pch"
        p.write_text("\n".join(cut))
        with pytest.raises(ModalDataError, match=r"the file ends inside this record .*truncated "
                                                 r"file\? \(if it is complete"):
            read_modes(p)
    # a record without its sequence number among records that have one: cut short
    short = lines[:]
    short[grid] = short[grid][:60]
    p = tmp_path / "short.pch"
    p.write_text("\n".join(short) + "\n")
    with pytest.raises(ModalDataError, match=rf"line {grid + 1} is cut short \(60 columns, no "
                                             r"sequence number"):
        read_modes(p)
    # the hand-written punch (no final cut) and the whitespace form still read
    (tmp_path / "hand.pch").write_text(NASTRAN_PUNCH)
    assert read_modes(tmp_path / "hand.pch").n_modes == 2


def test_values_that_would_overflow_are_refused(tmp_path, cantilever, beam_model):
    from sloshrom.beam.simulation.structure import coupled_frozen_modes

    with pytest.raises(ModalDataError, match=r"mode 1 is [\d.]+e\+198 at node 1; shape values "
                                             r"must be below 1e\+100"):
        dataclasses.replace(cantilever, shapes=cantilever.shapes * 1e200)
    with pytest.raises(ModalDataError, match=r"modal_masses holds 1e\+150"):
        dataclasses.replace(cantilever, modal_masses=[1e150, 1.0, 1.0])
    # shapes and masses in inconsistent units: refused before scipy, naming the mode
    big = dataclasses.replace(cantilever, shapes=cantilever.shapes * 1e50).to_modal_model(5)
    with pytest.raises(ModalDataError, match=r"weighs [\d.]+e\+99 times the modal masses "
                                             r"\(largest: mode 1 at tank 1"):
        coupled_frozen_modes(big, 0.124)
    with pytest.raises(ModalDataError, match=r"psi_tank holds 1e\+200"):
        ModalModel(**{**{k: getattr(beam_model, k) for k in FIELDS}, "psi_tank": [1e200, 1, 1],
                      "structure_mass": 0.45})
    # the largest values allowed still give a finite stiffness and eigenproblem
    edge = dataclasses.replace(beam_model, frequencies=[9.9e99, 9.8e99, 9.99e99],
                               modal_masses=[9.9e99] * 3)
    assert np.all(np.isfinite(edge.stiffness))


def test_too_many_modes_are_refused_before_the_eigen_solve(tmp_path):
    from sloshrom.beam.simulation.structure import MAX_MODES

    n = MAX_MODES + 1
    many = ModeSet(10.0 * np.arange(1, n + 1), np.ones(n), [1, 2], np.ones((2, 3, n)),
                   damping=np.full(n, 0.01), source="csv:many.csv")
    with pytest.raises(ModalDataError, match=rf"many\.csv holds {n} modes; a modal model takes "
                                             rf"at most {MAX_MODES} .*select_modes"):
        many.to_modal_model(tanks=1)
    assert many.select_modes(3).to_modal_model(tanks=1).n_modes == 3
    with pytest.raises(ModalDataError, match=rf"{n} modes: a modal model holds at most "):
        ModalModel(frequencies=many.frequencies, damping=many.damping,
                   modal_masses=many.modal_masses, psi_tank=np.ones(n), participation=None,
                   stations=[0.0], psi_stations=np.ones((1, n)), structure_mass=0.45)


def test_uff_result_nodes_are_checked_before_the_run(cantilever):
    from sloshrom.beam.lab.uff58 import check_result_nodes

    check_result_nodes(cantilever.to_modal_model(tanks=5))  # tank at an output point: fine
    base = dataclasses.replace(cantilever, nodes=np.array([1, 2, 3, 4, 1000]))
    with pytest.raises(ModalDataError, match=r"output point 1000 is the node the UFF results "
                                             r"give the base"):
        check_result_nodes(base.to_modal_model(tanks=4))
    with pytest.raises(ModalDataError, match=r"tank 1000 is the node"):
        check_result_nodes(base.to_modal_model(tanks=1000, outputs=[1, 2]))
    # two tanks without IDs (a modal TOML) get nodes 1, 2: the output points 1, 2 too
    two = ModalModel(frequencies=[10.0], damping=[0.01], modal_masses=[1.0],
                     psi_tank=[[1.0], [0.5]], participation=None, stations=[0.1, 0.2],
                     psi_stations=[[0.2], [0.4]], structure_mass=0.45)
    with pytest.raises(ModalDataError, match=r"tank 1 and output point 1 would both be UFF "
                                             r"node 1"):
        check_result_nodes(two)


def test_special_files_are_named_as_such(tmp_path):
    import os

    os.mkfifo(tmp_path / "pipe.pch")
    with pytest.raises(ModalDataError, match=r"pipe\.pch: is a named pipe \(FIFO\), not a "
                                             r"regular file"):
        read_modes(tmp_path / "pipe.pch")  # not "no such file"; and it must not block
    os.mkfifo(tmp_path / "pipe.csv")
    with pytest.raises(ModalDataError, match=r"is a named pipe"):
        read_mode_table(tmp_path / "pipe.csv")
