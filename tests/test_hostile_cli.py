"""Hostile CLI cases: every option of every command fed 0, -1, nan, inf, huge values, empty
strings, directories, paths under a file, output = input, wrong units and wrong types.

Same contract as tests/test_bad_input.py (``helpers.check_cli``): exit code 2, exactly one
``error:`` line naming the option/file/key and the problem, no traceback, and no file created,
removed or modified. Every case fails *before* any work (no rig run, no training, no beam
simulation), so the whole suite runs in seconds. The count is quoted in docs/interchange.md.
"""

from __future__ import annotations

import os
import shutil
import warnings
from pathlib import Path

import numpy as np
import pytest

from helpers import (
    TINY_DESIGN_TOML,
    check_cli,
    good_record,
    make_model_files,
    model_parts,
    runner,
    write_model_parts,
)
from sloshrom.cli import app
from sloshrom.io import Record, write_record
from sloshrom.io.uff import write_uff58


@pytest.fixture(scope="module")
def model_files(tmp_path_factory):
    """The session's model files (conftest.py) plus ROMs the beam and the map cannot use."""
    from sloshrom.rom.tdnn.estimators import NFIR

    d = make_model_files(tmp_path_factory.mktemp("models"))
    rng = np.random.default_rng(1)
    u = np.convolve(rng.standard_normal(600), np.ones(8) / 8, mode="same") * 0.05
    y = np.tanh(20 * np.roll(u, 2)) * 0.5
    # a velocity-contract ROM (its input is not named "acceleration") in m/s^2
    NFIR(delays=4, neurons=3, max_epochs=2, units=("m/s^2", "N"),
         names=("tank_accel", "dynamic_force")).fit(u, y, fs=500.0).save(d / "ms2.npz")
    NFIR(delays=4, neurons=3, max_epochs=2).fit(u, y, fs=250.0).save(d / "r250.npz")
    NFIR(delays=4, neurons=3, max_epochs=2).fit(u, y, fs=100.0).save(d / "slow100.npz")
    _ball_file(d / "ball.toml")
    _forged_ensemble(u, y, d / "ens_fills.npz")
    return d


def _forged_ensemble(u: np.ndarray, y: np.ndarray, path: Path) -> None:
    """An ensemble identified at fill 0.5 whose member 1 is forged to fill 0.3 (checksum
    recomputed): the union of the members' ranges, 0.3 to 0.5, holds both fills."""
    from sloshrom.rom.ensemble import Ensemble
    from sloshrom.rom.tdnn.estimators import NFIR

    ens = Ensemble(NFIR(delays=4, neurons=3, max_epochs=2), n_members=2).fit(
        u, y, 500.0, scheduler="sequential", fill=0.5)
    meta, arrays = model_parts(ens.save(path))
    meta["members"][1]["envelope"].update(fill_min=0.3, fill_max=0.3)
    write_model_parts(path, meta, arrays)


def _ball_file(path: Path) -> None:
    """A bouncing-ball model of the paper tank at fill 0.5 (parameters given, not fitted)."""
    from sloshrom.rom.ball.model import BouncingBall

    ball = BouncingBall.from_parameters(0.5, 0.3, 0.01, fs=500.0)
    ball.envelope_ = {"input_min": -0.1, "input_max": 0.1, "output_min": -1.0,
                      "output_max": 1.0, "frequency_band": [5.0, 25.0], "acceleration_max": 60.0}
    ball.save(path)


def _map_file(path: Path, ob: np.ndarray, ab: np.ndarray) -> None:
    import xarray as xr

    da = xr.DataArray(np.ones((ob.size, ab.size)), dims=("omega_bar", "a_bar"),
                      coords={"omega_bar": ob, "a_bar": ab}, name="phi_d")
    da.to_dataset().to_netcdf(path, engine="h5netcdf")


def _world(tmp: Path) -> None:
    """Everything the cases read: records, TOML files, a directory, a file used as a parent."""
    t = np.arange(1500) / 500.0
    u = 0.05 * np.sin(2 * np.pi * 7 * t) * np.sin(np.pi * t / t[-1])
    good = Record(t, 500.0, {"velocity": u, "dynamic_force": np.tanh(20 * u)},
                  {"velocity": "m/s", "dynamic_force": "N"}, {"calibration": "lab 3"})
    for suffix in (".nc", ".csv", ".mat"):
        write_record(good, tmp / f"good{suffix}")
    # a unit no table converts to m/s: the ROM must not take it for one
    write_record(Record(t, 500.0, {"velocity": u, "dynamic_force": u},
                        {"velocity": "rad/s", "dynamic_force": "N"}), tmp / "rads.nc")
    write_record(Record(t, 500.0, {"velocity": u, "station_acceleration": np.zeros((t.size, 2))},
                        {"velocity": "m/s", "station_acceleration": "m/s^2"}), tmp / "twod.nc")
    (tmp / "adir").mkdir()
    (tmp / "afile").write_text("a file, not a directory\n")
    (tmp / "t.toml").write_text("[tank]\nfill = 0.5\n")
    (tmp / "tank.nc").write_text("[tank]\nfill = 0.5\n")  # TOML content, record suffix
    (tmp / "raw.nc").write_text("not read: the output check comes first\n")
    write_uff58(good_record(), tmp / "good.uff")  # 100 Hz, acceleration + force
    (tmp / "modal300.toml").write_text(
        "[modal]\nfrequencies = [300.0]\ndamping = [0.01]\nmodal_masses = [1.0]\n"
        "psi_tank = [1.0]\nparticipation = [1.0]\nstations = [0.5]\npsi_stations = [[1.0]]\n"
        "structure_mass = 0.45\n")
    from sloshrom.config import Tank
    from sloshrom.pipeline import settings
    from sloshrom.pipeline.maps import map_grid

    cfg = settings.load().replace(map={"n_omega": 2, "n_a": 2})
    ob, ab = map_grid(cfg, Tank())
    _map_file(tmp / "ref22.nc", ob, ab)
    _map_file(tmp / "ref22_other.nc", ob * 1.1, ab)
    _lab(tmp)


def _lab(tmp: Path) -> None:
    """A laboratory's 2 s free decay (``lab.uff``, frozen liquid) with its channel maps
    (``ch.toml``; ``chb.toml`` with a base channel, ``ids.toml`` by grid ID), the beam's modal
    TOML, and two beam results of it for ``compare`` (``free_m.nc``, ``free_p.nc``)."""
    import dataclasses

    import tomli_w

    from sloshrom.beam.lab.virtual import write_lab_test
    from sloshrom.beam.results import to_dataset
    from sloshrom.beam.simulation.coupled import free_response
    from sloshrom.beam.simulation.structure import CantileverBeam, ModalModel, coupled_frozen_modes
    from sloshrom.config import Tank
    from sloshrom.models import FrozenLiquid

    tank = Tank()
    modal = ModalModel.from_beam(CantileverBeam.with_tank(tank), tank)
    f1 = float(coupled_frozen_modes(modal, [tank.liquid_mass])[0][0])
    free = free_response(FrozenLiquid(1 / 500.0), modal, 0.0146, 2.0, tank)
    cmap = write_lab_test(free, modal, tmp / "lab.uff", kind="free")
    cmap.write_toml(tmp / "ch.toml")
    dataclasses.replace(cmap, base="Base Z").write_toml(tmp / "chb.toml")
    (tmp / "ids.toml").write_text(
        '[channels]\nstations = ["Acc 1", "Acc 2", "Acc 3", "Acc 4", "Acc 5"]\n'
        'ids = [1, 2, 3, 4, 5]\n')
    (tmp / "modal.toml").write_text(tomli_w.dumps({"modal": modal.to_dict()}))
    ds = to_dataset(free, "measured", "free", tank, modal, f1=f1)
    ds.to_netcdf(tmp / "free_m.nc", engine="h5netcdf")
    ds.assign_attrs(case="frozen").to_netcdf(tmp / "free_p.nc", engine="h5netcdf")
    # an 8 s decay into sensor noise: the spectrum between the modes is a noise floor
    long = free_response(FrozenLiquid(1 / 500.0), modal, 0.0146, 8.0, tank)
    write_lab_test(long, modal, tmp / "noisy.uff", kind="free", noise_rms=0.1)


def _copy(src: str, dst: str):
    """Copy ``src`` ({tmp}, {models}) to ``tmp/dst``: a file where the command must not write."""

    def make(tmp: Path, models: Path) -> None:
        (tmp / dst).parent.mkdir(parents=True, exist_ok=True)
        shutil.copyfile(src.format(tmp=tmp, models=models), tmp / dst)

    make.wants_models = True
    return make


def _text(name: str, text: str):
    def make(tmp: Path) -> None:
        (tmp / name).parent.mkdir(parents=True, exist_ok=True)
        (tmp / name).write_text(text)

    return make


def _bytes(name: str, data: bytes):
    """A file of ``data`` under ``name`` (text in another encoding, or not text at all)."""

    def make(tmp: Path) -> None:
        (tmp / name).parent.mkdir(parents=True, exist_ok=True)
        (tmp / name).write_bytes(data)

    return make


def _drive_jump(name: str, n: int = 6000, row: int = 5000, jump: float = 3e-4):
    """A 2000 Hz drive CSV of ``n`` rows whose time column jumps by ``jump`` s at data row
    ``row`` (line ``row + 2``: the header is line 1) and keeps the step after it."""

    def make(tmp: Path) -> None:
        from sloshrom.io.programme import write_drive_csv

        t = np.arange(n) / 2000.0
        a = np.sin(2 * np.pi * 10 * t) * np.sin(np.pi * t / t[-1]) ** 2
        write_drive_csv(tmp / name, a, 2000.0)
        lines = (tmp / name).read_text().splitlines()
        for k in range(row, n):
            tk, ak = lines[k + 1].split(",")
            lines[k + 1] = f"{float(tk) + jump:.9f},{ak}"
        (tmp / name).write_text("\n".join(lines) + "\n")

    return make


def _design_drive(folder: str, uff: bool = False):
    """The drive files of a two-segment programme at 2000 Hz as `sloshrom design` writes them
    (``train.csv``; with ``uff`` also ``train.uff``) in ``folder``."""

    def make(tmp: Path) -> None:
        from sloshrom.io.programme import drive_uff_sets, write_drive_csv
        from sloshrom.io.uff import write_uff_sets

        d = tmp / folder
        d.mkdir(parents=True, exist_ok=True)
        t = np.arange(2001) / 2000.0
        seg = 5.0 * np.sin(2 * np.pi * 12 * t) * np.sin(np.pi * t / t[-1]) ** 2
        write_drive_csv(d / "train.csv", np.concatenate([seg, seg]), 2000.0)  # back to back
        if uff:
            write_uff_sets(drive_uff_sets([("vfa", seg), ("vfa 2", seg)], 2000.0,
                                          "sloshrom design: train programme"), d / "train.uff")

    return make




TOO_LONG = "y" * 300 + ".nc"
V = ["rig", "vfa"]
VO = [*V, "--out", "{tmp}/v.nc"]
H = ["rig", "harmonic", "--out", "{tmp}/h.nc"]
H12 = [*H, "--frequency", "12"]
TR = ["train", "--max-epochs", "2", "--delays", "4", "--neurons", "3"]
TRG = [*TR, "--data", "{tmp}/good.nc", "--validation", "{tmp}/good.nc"]
TRO = [*TRG, "--out", "{tmp}/m.npz"]
NSO = ["train", "--arch", "nss", "--data", "{tmp}/good.nc", "--validation", "{tmp}/good.nc",
       "--out", "{tmp}/m.npz"]
P = ["predict", "--model", "{models}/good.npz"]
S = ["sweep", "--data", "{tmp}/good.nc", "--validation", "{tmp}/good.nc", "--max-epochs", "2"]
SO = [*S, "--out", "{tmp}/sw"]
M = ["map", "--rig", "--out", "{tmp}/m.nc"]
CS = ["config", "show", "--config", "{tmp}/c.toml"]
RP = ["reproduce", "--config", "{tmp}/c.toml", "--out", "{tmp}/res"]
BF = ["beam", "free", "--sloshing", "frozen"]
BFO = [*BF, "--out", "{tmp}/res"]
BR = ["beam", "random", "--sloshing", "frozen"]
BRO = [*BR, "--out", "{tmp}/res"]
E = ["export", "onnx"]
EF = ["export", "fmu"]
U = ["import", "uff"]
SEED_MAX = r"\[0, 4294967295\]"


def _cfg(text: str):
    return _text("c.toml", text)


def _all(*setups):
    """Several setups of one case, in order."""

    def make(tmp: Path) -> None:
        for setup in setups:
            setup(tmp)

    return make


def _modal(name: str, writer: str = "csv", **change):
    """The cantilever's modes (nodes 1..5, 3 modes, the tank at node 5) with ``change``d
    fields, written by the ``writer`` ("csv", "punch", "uff") of sloshrom."""

    def make(tmp: Path) -> None:
        import dataclasses

        from sloshrom.beam.simulation import modal_files
        from sloshrom.beam.simulation.modes import ModeSet

        ms = dataclasses.replace(ModeSet.from_cantilever(), **change)
        getattr(modal_files, f"write_modes_{writer}")(ms, tmp / name)

    return make


def _scaled_shapes(name: str, factor: float):
    """The cantilever's modal CSV with its shapes times ``factor`` (masses unchanged)."""

    def make(tmp: Path) -> None:
        import dataclasses

        from sloshrom.beam.simulation.modal_files import write_modes_csv
        from sloshrom.beam.simulation.modes import ModeSet

        ms = ModeSet.from_cantilever()
        write_modes_csv(dataclasses.replace(ms, shapes=ms.shapes * factor), tmp / name)

    return make


def _many_modes(tmp: Path) -> None:
    """A modal CSV of 300 modes (the eigen-solve of more than 200 is what hung)."""
    from sloshrom.beam.simulation.modal_files import write_modes_csv
    from sloshrom.beam.simulation.modes import ModeSet

    n = 300
    write_modes_csv(ModeSet(10.0 * np.arange(1, n + 1), np.ones(n), np.arange(1, 6),
                            np.ones((5, 3, n)), damping=np.full(n, 0.01),
                            participation=np.ones((3, n))), tmp / "many.csv")


def _huge_shapes(tmp: Path) -> None:
    """The cantilever's modal CSV with its shape columns times 1e200."""
    _modal("huge.csv")(tmp)
    p = tmp / "huge.csv"
    lines = p.read_text().splitlines()
    rows = [",".join([*r.split(",")[:-3], *(repr(float(v) * 1e200) for v in r.split(",")[-3:])])
            for r in lines[2:]]
    p.write_text("\n".join([*lines[:2], *rows]) + "\n")


def _uff_modes(name: str, **fields):
    """The cantilever's modes as UFF 55 with ``fields`` of every dataset 55 replaced."""

    def make(tmp: Path) -> None:
        import pyuff

        _modal(name, "uff")(tmp)
        sets = pyuff.UFF(str(tmp / name)).read_sets()
        for st in sets:
            if st["type"] == 55:
                st.update(fields)
        pyuff.UFF(str(tmp / name)).write_sets(sets, mode="overwrite")

    return make


def _punch_cut(tmp: Path) -> None:
    """A punch file cut inside the last number of its last grid line."""
    _modal("cut.pch", "punch")(tmp)
    lines = (tmp / "cut.pch").read_text().splitlines()
    (tmp / "cut.pch").write_text("\n".join(lines[:-1])[:-12])  # -CONT- gone, T3 cut


def _nc_attrs(name: str, **attrs):
    """good.nc with ``attrs`` set (as another program would write them)."""

    def make(tmp: Path) -> None:
        import xarray as xr

        with xr.open_dataset(tmp / "good.nc", engine="h5netcdf") as ds:
            ds = ds.load()
        ds.attrs.update(attrs)
        ds.to_netcdf(tmp / name, engine="h5netcdf")

    return make


def _one_sided(tmp: Path) -> None:
    """A record whose velocity never changes sign (not an oscillation about rest)."""
    t = np.arange(1500) / 500.0
    u = 0.02 + 0.01 * np.sin(2 * np.pi * 7 * t)
    write_record(Record(t, 500.0, {"velocity": u, "dynamic_force": np.tanh(20 * u)},
                        {"velocity": "m/s", "dynamic_force": "N"}), tmp / "onesided.nc")


def _fifo(name: str):
    def make(tmp: Path) -> None:
        os.mkfifo(tmp / name)

    return make


ST = [*BFO, "--structure"]  # beam free on a modal file


def _result(name: str, nan: str = "", **attrs):
    """The beam result free_p.nc with ``attrs`` set (as another program would write them;
    None: removed) and the variable ``nan`` (if given) holding a NaN."""

    def make(tmp: Path) -> None:
        import xarray as xr

        with xr.open_dataset(tmp / "free_p.nc", engine="h5netcdf") as ds:
            ds = ds.load()
        ds.attrs.update({k: v for k, v in attrs.items() if v is not None})
        for k in [k for k, v in attrs.items() if v is None]:
            del ds.attrs[k]
        if nan:
            ds[nan].values[5] = np.nan
        ds.to_netcdf(tmp / name, engine="h5netcdf")

    return make


def _reshaped(name: str, how: str):
    """A beam result made from free_m.nc (case ``measured``) or free_p.nc: ``"two"`` keeps
    its first and last station (2 stations for the 3 modes of its ``psi_stations``);
    ``"levels"`` gives its signals a level axis of 2 RMS levels (a random test's shape) while
    its attribute still says ``test = "free"``."""

    def make(tmp: Path) -> None:
        import xarray as xr

        src = "free_m.nc" if how == "two" else "free_p.nc"
        with xr.open_dataset(tmp / src, engine="h5netcdf") as ds:
            ds = ds.load()
        if how == "two":
            ds = ds.isel(station=[0, ds.sizes["station"] - 1])
        else:
            signals = ["station_acceleration", "tank_acceleration", "base_acceleration"]
            ds = ds.assign({v: ds[v].expand_dims(level=[0.1, 0.2]) for v in signals})
            ds = ds.assign_attrs(case="random")
        ds.to_netcdf(tmp / name, engine="h5netcdf")

    return make


def _png(name: str):
    """A binary file (a PNG's first bytes) under ``name``: not text, not NetCDF."""

    def make(tmp: Path) -> None:
        (tmp / name).write_bytes(b"\x89PNG\r\n\x1a\n\x00\x00\x00\rIHDR" + bytes(range(256)))

    return make


def _unitless(name: str, label: str):
    """``lab.uff`` as a file whose channel ``label`` has an empty ordinate unit label (and
    no dataset 164 saying SI)."""

    def make(tmp: Path) -> None:
        import pyuff

        sets = [dict(s) for s in pyuff.UFF(str(tmp / "lab.uff")).read_sets() if s["type"] == 58]
        for s in sets:
            s["ordinate_axis_units_lab"] = "" if s["id1"] == label else "m/s^2"
        pyuff.UFF(str(tmp / name)).write_sets(sets, mode="overwrite")

    return make


MAP5 = ('[channels]\nstations = ["Acc 1", "Acc 2", "Acc 3", "Acc 4", "Acc 5"]\n'
        'positions = [0.148, 0.296, 0.444, 0.592, 0.74]\n')
AF = ["analyse", "free", "{tmp}/lab.uff", "--channels", "{tmp}/ch.toml"]
AFO = [*AF, "--out", "{tmp}/res"]
AR = ["analyse", "random", "{tmp}/lab.uff", "--channels", "{tmp}/chb.toml"]
ARO = [*AR, "--out", "{tmp}/res"]
CMP = ["compare", "{tmp}/free_m.nc", "{tmp}/free_p.nc"]
CMPO = [*CMP, "--out", "{tmp}/cmp"]


# (id, extra setup(tmp) or None, argv, regex of the one error line)
HOSTILE_CASES = [
    # -- the application ----------------------------------------------------------------------
    ("no-such-command", None, ["frobnicate"], r"No such command 'frobnicate'"),
    ("version-extra-argument", None, ["version", "now"], r"unexpected extra argument"),
    # -- rig vfa --------------------------------------------------------------------------------
    ("vfa-no-out", None, V, r"Missing option '--out'"),
    ("vfa-seed--1", None, [*VO, "--seed", "-1"], rf"--seed must be in {SEED_MAX}, got -1"),
    ("vfa-seed-huge", None, [*VO, "--seed", "99999999999999"],
     rf"--seed must be in {SEED_MAX}, got 99999999999999"),
    ("vfa-seed-not-a-number", None, [*VO, "--seed", "abc"], r"Invalid value for '--seed'"),
    ("vfa-seed-float", None, [*VO, "--seed", "1.5"], r"Invalid value for '--seed'"),
    ("vfa-duration-nan", None, [*VO, "--duration", "nan"],
     r"--duration must be in \[10, 3600\] s, got nan"),
    ("vfa-duration-inf", None, [*VO, "--duration", "inf"],
     r"--duration must be in \[10, 3600\] s, got inf"),
    ("vfa-duration-1e7-memory", None, [*VO, "--duration", "1e7"],
     r"--duration must be in \[10, 3600\] s, got 10000000\.0 .*memory"),
    ("vfa-duration-1e308", None, [*VO, "--duration", "1e308"], r"--duration must be in"),
    ("vfa-duration-9.9", None, [*VO, "--duration", "9.9"], r"shortest VFA path is 10 s"),
    ("vfa-duration-empty", None, [*VO, "--duration", ""], r"Invalid value for '--duration'"),
    ("vfa-out-empty", None, [*V, "--out", ""], r"--out \.: is a directory"),
    ("vfa-out-is-a-directory", lambda tmp: (tmp / "d.nc").mkdir(), [*V, "--out", "{tmp}/d.nc"],
     r"d\.nc: is a directory"),
    ("vfa-out-under-a-file", None, [*V, "--out", "{tmp}/afile/v.nc"],
     r"afile is not a directory"),
    ("vfa-out-name-too-long", None, [*V, "--out", "{tmp}/" + TOO_LONG],
     r"longer than 255 bytes"),
    ("vfa-out-no-suffix", None, [*V, "--out", "{tmp}/v"], r"unknown format '\(no suffix\)'"),
    ("vfa-out-is-the-tank-file", None, [*V, "--tank", "{tmp}/tank.nc", "--out", "{tmp}/tank.nc"],
     r"tank\.nc is also an input of this command: refusing to overwrite it"),
    ("vfa-fill-nan", None, [*VO, "--fill", "nan"], r"--fill must be in \(0, 1\), got nan"),
    ("vfa-fill-1", None, [*VO, "--fill", "1"], r"--fill must be in \(0, 1\), got 1\.0"),
    ("vfa-fill--0.5", None, [*VO, "--fill", "-0.5"], r"--fill must be in \(0, 1\), got -0\.5"),
    ("vfa-tank-is-a-directory", None, [*VO, "--tank", "{tmp}/adir"],
     r"--tank .*adir: is a directory"),
    ("vfa-tank-zero-height", _text("z.toml", "[tank]\nheight = 0\n"),
     [*VO, "--tank", "{tmp}/z.toml"], r"height must be a finite positive number"),
    ("vfa-split-empty", None, [*VO, "--split", ""], r"--split must be 'train' or 'validation'"),
    ("vfa-misspelt-option", None, [*VO, "--durration", "10"], r"No such option: --durration"),
    # -- rig harmonic ---------------------------------------------------------------------------
    ("harmonic-300-hz-above-sensors", None, [*H, "-f", "300", "--accel-g", "1"],
     r"--frequency must be in \(0, 200\] Hz, got 300\.0 .*anti-alias filter at 200 Hz"),
    ("harmonic-frequency-0", None, [*H, "-f", "0", "--accel-g", "1"],
     r"--frequency must be in \(0, 200\] Hz, got 0\.0"),
    ("harmonic-frequency-inf", None, [*H, "-f", "inf", "--accel-g", "1"],
     r"--frequency must be in \(0, 200\] Hz, got inf"),
    ("harmonic-frequency-1e308", None, [*H, "-f", "1e308", "--accel-g", "1"],
     r"--frequency must be in \(0, 200\] Hz, got 1e\+308"),
    ("harmonic-frequency-text", None, [*H, "-f", "twelve", "--accel-g", "1"],
     r"Invalid value for '--frequency'"),
    ("harmonic-no-frequency", None, [*H, "--accel-g", "1"], r"Missing option '--frequency'"),
    ("harmonic-cycles-huge-memory", None, [*H12, "--accel-g", "1", "--cycles", "10000000"],
     r"--cycles 10000000 at 12 Hz make a 8\.333e\+05 s test, more than 3600 s .*memory"),
    ("harmonic-cycles-at-1-mhz", None,
     [*H, "-f", "0.001", "--accel-g", "1e-9", "--cycles", "20"],
     r"--cycles 20 at 0\.001 Hz make a 2\.8e\+04 s test"),
    ("harmonic-too-short-for-the-sensors", None,
     [*H, "-f", "200", "--accel-g", "1", "--cycles", "1"],
     r"--cycles 1 at 200 Hz make a 0\.045 s test; the sensors' filters need at least 0\.08 s"),
    ("harmonic-cycles--1", None, [*H12, "--accel-g", "1", "--cycles", "-1"],
     r"--cycles must be >= 1, got -1"),
    ("harmonic-amplitude-0", None, [*H12, "-a", "0"],
     r"--amplitude must be in \(0, 0\.125\] m, got 0\.0"),
    ("harmonic-amplitude-negative", None, [*H12, "-a", "-0.001"],
     r"--amplitude must be in \(0, 0\.125\] m, got -0\.001"),
    ("harmonic-amplitude-1-m", None, [*H12, "-a", "1"],
     r"--amplitude must be in \(0, 0\.125\] m, got 1\.0 \(ten times the shaker's stroke\)"),
    ("harmonic-accel-g-nan", None, [*H12, "--accel-g", "nan"],
     r"--accel-g must be in \(0, 60\] g, got nan"),
    ("harmonic-accel-g-1000", None, [*H12, "--accel-g", "1000"],
     r"--accel-g must be in \(0, 60\] g, got 1000\.0"),
    ("harmonic-derived-acceleration", None, [*H, "-f", "100", "-a", "0.1"],
     r"--amplitude at 100 Hz gives an acceleration amplitude of 4026 g, beyond ten times "
     r"the shaker's limit \(6 g\)"),
    ("harmonic-seed--1", None, [*H12, "--accel-g", "1", "--seed", "-1"],
     rf"--seed must be in {SEED_MAX}"),
    ("harmonic-fill-2", None, [*H12, "--accel-g", "1", "--fill", "2"],
     r"--fill must be in \(0, 1\), got 2\.0"),
    ("harmonic-out-csv-under-file", None,
     ["rig", "harmonic", "-f", "12", "--accel-g", "1", "--out", "{tmp}/afile/h.csv"],
     r"afile is not a directory"),
    # -- train ----------------------------------------------------------------------------------
    ("train-out-is-the-data", _copy("{tmp}/good.nc", "rec.npz"),
     [*TR, "--data", "{tmp}/rec.npz", "--validation", "{tmp}/good.nc", "--out", "{tmp}/rec.npz"],
     r"rec\.npz is also an input of this command"),
    ("train-out-is-the-validation", _copy("{tmp}/good.nc", "rec.npz"),
     [*TR, "--data", "{tmp}/good.nc", "--validation", "{tmp}/rec.npz", "--out", "{tmp}/rec.npz"],
     r"rec\.npz is also an input of this command"),
    ("train-out-record-suffix", None, [*TRG, "--out", "{tmp}/m.nc"],
     r"--out .*m\.nc: unknown format '\.nc' \(use \.npz\)"),
    ("train-out-is-a-directory", None, [*TRG, "--out", "{tmp}/adir"],
     r"adir: is a directory, expected a file name"),
    ("train-out-npz-directory", lambda tmp: (tmp / "d.npz").mkdir(), [*TRG, "--out", "{tmp}/d.npz"],
     r"d\.npz: is a directory"),
    ("train-out-under-a-file", None, [*TRG, "--out", "{tmp}/afile/m.npz"],
     r"afile is not a directory"),
    ("train-delays--1", None, [*TRO, "--delays", "-1"],
     r"--delays must be an integer in \[1, 10000\], got -1"),
    ("train-delays-huge", None, [*TRO, "--delays", "1000000"],
     r"--delays must be an integer in \[1, 10000\], got 1000000"),
    ("train-neurons-0", None, [*TRO, "--neurons", "0"],
     r"--neurons must be an integer in \[1, 4096\], got 0"),
    ("train-neurons-text", None, [*TRO, "--neurons", "many"], r"Invalid value for '--neurons'"),
    ("train-max-epochs--1", None, [*TRO, "--max-epochs", "-1"],
     r"--max-epochs must be an integer in \[0, 10000000\], got -1"),
    ("train-seed--1", None, [*TRO, "--seed", "-1"],
     rf"--seed must be an integer in {SEED_MAX}, got -1"),
    ("train-seed-2**40", None, [*TRO, "--seed", str(2**40)],
     rf"--seed must be an integer in {SEED_MAX}"),
    ("train-arch-lstm", None, [*TRO, "--arch", "lstm"],
     r"--arch must be one of nfir, noe, nss, lss, grey, got 'lstm'"),
    ("train-nss-delays", None, [*TRO, "--arch", "nss"],
     r"--delays does not apply to --arch nss \(NSS: .*\); its options are --n-states"),
    ("train-nss-states-0", None, [*NSO, "--states", "0"],
     r"--n-states must be an integer in \[1, 1024\], got 0"),
    ("train-nss-learning-rate-nan", None, [*NSO, "--learning-rate", "nan"],
     r"--learning-rate must be a number in \(0, 1\], got nan"),
    ("train-nss-horizon-7", None, [*NSO, "--horizon", "7"],
     r"--horizon must be an integer in \[8, 10000\]"),
    # each option bounded alone, their product ran for hours: one epoch's work is bounded
    ("train-nss-epoch-cost-window-horizon", None,
     [*NSO, "--neurons", "64", "--window", "9000", "--horizon", "9000"],
     r"one training epoch of NSS\(\d+ states, 64 neurons, strictly proper\), "
     r"--steps-per-epoch x --batch x \(--window \+ --horizon\) x --neurons = 200 x 128 x "
     r"\(9000 \+ 9000\) x 64 = 2\.95e\+10 neuron-samples, more than 1\.5e\+10 "
     r"\(about 6 min per epoch"),
    ("train-nss-epoch-cost-steps", None, [*NSO, "--steps-per-epoch", "10000000"],
     r"--steps-per-epoch x --batch x \(--window \+ --horizon\) x --neurons = 10000000 x 128 "
     r"x .* more than 1\.5e\+10"),
    ("train-nss-epoch-cost-batch", None, [*NSO, "--batch", "65536", "--neurons", "64"],
     r"= 200 x 65536 x \(\d+ \+ \d+\) x 64 = .* neuron-samples, more than 1\.5e\+10"),
    ("train-nss-input-acceleration", None, [*NSO, "--input", "acceleration"],
     r"--input acceleration: an NSS takes the tank velocity; the acceleration needs --arch "
     r"nfir$"),
    ("train-window-for-nfir", None, [*TRO, "--window", "5"],
     r"--window does not apply to --arch nfir \(NFIR: .*\); its options are --delays"),
    ("train-hidden-gauss", None, [*TRO, "--hidden", "gauss"],
     r"--hidden must be one of 'matlab', 'distance', got 'gauss'"),
    ("train-trainer-sgd", None, [*TRO, "--trainer", "sgd"],
     r"--trainer must be one of 'adam', 'fast', 'lm', got 'sgd'"),
    ("train-trainer-sgd-for-noe", None, [*TRO, "--arch", "noe", "--trainer", "sgd"],
     r"--trainer must be one of 'lm', 'fast', 'adam', got 'sgd'"),
    ("train-cycle-energy--1", None, [*TRO, "--cycle-energy", "-1"],
     r"--cycle-energy must be a number in \[0, 1e\+12\], got -1"),
    ("train-cycle-energy-with-lm", None, [*TRO, "--trainer", "lm", "--cycle-energy", "0.1"],
     r"--cycle-energy > 0 needs --trainer 'adam', got 'lm': set --cycle-energy to 0 or "
     r"--trainer to 'adam'$"),
    ("train-input-empty", None, [*TRO, "--input", ""], r"--input must name a variable"),
    ("train-input-is-output", None, [*TRO, "--input", "velocity", "--output", "velocity"],
     r"--input and --output must be different variables"),
    # the time axis is no signal: a model of it (validation MSE = predicting 0) was written
    ("train-input-time", None, [*TRO, "--input", "time"],
     r"--input time: 'time' is the time axis of .*good\.nc, not a signal; name one of its "
     r"signals: velocity, dynamic_force$"),
    ("train-output-time-mat", None, [*TR, "--data", "{tmp}/good.mat", "--validation",
                                     "{tmp}/good.mat", "--out", "{tmp}/m.npz", "--output", "time"],
     r"--output time: 'time' is the time axis of .*good\.mat, not a signal"),
    ("train-input-csv-time-column-t", _text("tcol.csv", "t [s],velocity [m/s],dynamic_force [N]\n"
                                                        "0,0,0\n0.002,0.1,0.2\n0.004,0.2,0.3\n"),
     [*TR, "--data", "{tmp}/tcol.csv", "--validation", "{tmp}/good.nc", "--out", "{tmp}/m.npz",
      "--input", "t"], r"--input t: 't' is the time axis of .*tcol\.csv, not a signal; name one "
                       r"of its signals: velocity, dynamic_force$"),
    ("train-validation-input-time", _text("tval.csv", "Time [s],velocity [m/s],force [N]\n"
                                                      "0,0,0\n0.002,0.1,0.2\n"),
     [*TR, "--data", "{tmp}/tval.csv", "--validation", "{tmp}/tval.csv", "--out", "{tmp}/m.npz",
      "--input", "Time", "--output", "force"], r"--input Time: 'Time' is the time axis"),
    ("train-data-missing", None,
     [*TR, "--data", "{tmp}/none.nc", "--validation", "{tmp}/good.nc", "--out", "{tmp}/m.npz"],
     r"--data .*none\.nc: no such file"),
    ("train-data-is-a-directory", None,
     [*TR, "--data", "{tmp}/adir", "--validation", "{tmp}/good.nc", "--out", "{tmp}/m.npz"],
     r"--data .*adir: is a directory"),
    ("train-validation-empty-path", None,
     [*TR, "--data", "{tmp}/good.nc", "--validation", "", "--out", "{tmp}/m.npz"],
     r"--validation \.: is a directory, expected a file"),
    ("train-validation-other-unit", None,
     [*TR, "--data", "{tmp}/good.nc", "--validation", "{tmp}/rads.nc", "--out", "{tmp}/m.npz"],
     r"unit mismatch: variable 'velocity' is in 'm/s' in .*good\.nc but in 'rad/s' in "
     r".*rads\.nc"),
    ("train-units-swapped", lambda tmp: write_record(
        Record(np.arange(200) / 500.0, 500.0, {"velocity": np.ones(200),
                                               "dynamic_force": np.ones(200)},
               {"velocity": "N", "dynamic_force": "m/s"}), tmp / "swapped.nc"),
     [*TR, "--data", "{tmp}/swapped.nc", "--validation", "{tmp}/swapped.nc", "--out",
      "{tmp}/m.npz"], r"swapped\.nc: variable 'velocity' is in 'N', but velocity is in 'm/s'"),
    ("train-record-too-short", None,
     ["train", "--delays", "1000", "--neurons", "1000", "--data", "{tmp}/good.nc",
      "--validation", "{tmp}/good.nc", "--out", "{tmp}/m.npz"],
     r"good\.nc: 1500 samples are too few for NFIR\(1000, 1000\) \(training needs at least "
     r"21050\)"),
    # -- predict --------------------------------------------------------------------------------
    ("predict-out-is-the-data-nc", None, [*P, "--data", "{tmp}/good.nc", "--out", "{tmp}/good.nc"],
     r"good\.nc is also an input of this command: refusing to overwrite it"),
    ("predict-out-is-the-data-csv", None,
     [*P, "--data", "{tmp}/good.csv", "--out", "{tmp}/good.csv"],
     r"good\.csv is also an input of this command"),
    ("predict-out-is-the-data-mat", None,
     [*P, "--data", "{tmp}/good.mat", "--out", "{tmp}/good.mat"],
     r"good\.mat is also an input of this command"),
    ("predict-out-is-the-data-other-spelling", None,
     [*P, "--data", "{tmp}/good.nc", "--out", "{tmp}/adir/../good.nc"],
     r"good\.nc is also an input of this command"),
    ("predict-out-is-the-model", _copy("{models}/good.npz", "model.nc"),
     ["predict", "--model", "{tmp}/model.nc", "--data", "{tmp}/good.nc", "--out",
      "{tmp}/model.nc"], r"model\.nc is also an input of this command"),
    ("predict-input-in-other-unit", None, [*P, "--data", "{tmp}/rads.nc", "--out", "{tmp}/p.nc"],
     r"rads\.nc: variable 'velocity' is in 'rad/s', the model .*good\.npz expects 'm/s'"),
    ("predict-out-xlsx", None, [*P, "--data", "{tmp}/good.nc", "--out", "{tmp}/p.xlsx"],
     r"unknown format '\.xlsx' \(use \.nc, \.csv, \.mat\)"),
    ("predict-out-under-a-file", None,
     [*P, "--data", "{tmp}/good.nc", "--out", "{tmp}/afile/p.nc"], r"afile is not a directory"),
    ("predict-2d-record-to-csv", None, [*P, "--data", "{tmp}/twod.nc", "--out", "{tmp}/p.csv"],
     r"CSV holds 1-D variables only, .*twod\.nc has 2-D station_acceleration"),
    ("predict-model-is-a-directory", None,
     ["predict", "--model", "{tmp}/adir", "--data", "{tmp}/good.nc", "--out", "{tmp}/p.nc"],
     r"--model .*adir: is a directory"),
    ("predict-model-missing", None,
     ["predict", "--model", "{tmp}/none.npz", "--data", "{tmp}/good.nc", "--out", "{tmp}/p.nc"],
     r"--model .*none\.npz: no such file"),
    # an ensemble is the mean of models at one fill: the union of the members' fill ranges
    # passed a member at 30 % beside one at 50 %
    ("predict-ensemble-members-at-two-fills", None,
     ["predict", "--model", "{models}/ens_fills.npz", "--data", "{tmp}/good.nc", "--fill", "0.5",
      "--out", "{tmp}/p.nc"],
     r"ens_fills\.npz: ensemble member 1 was identified at fill 30\.0%, member 0 was identified "
     r"at fill 50\.0%: the members of an ensemble are identified at one fill"),
    ("predict-ensemble-members-at-two-fills-no-fill", None,
     ["predict", "--model", "{models}/ens_fills.npz", "--data", "{tmp}/good.nc", "--out",
      "{tmp}/p.nc"], r"ens_fills\.npz: ensemble member 1 was identified at fill 30\.0%"),
    ("predict-data-empty-path", None, [*P, "--data", "", "--out", "{tmp}/p.nc"],
     r"--data \.: is a directory, expected a file"),
    # -- sweep ----------------------------------------------------------------------------------
    ("sweep-scheduler-unreachable", None, [*SO, "--scheduler", "tcp://127.0.0.1:1"],
     r"--scheduler tcp://127\.0\.0\.1:1: no Dask scheduler reachable"),
    ("sweep-scheduler-no-port", None, [*SO, "--scheduler", "localhost"],
     r"--scheduler 'localhost': expected tcp://HOST:PORT"),
    ("sweep-scheduler-bad-port", None, [*SO, "--scheduler", "tcp://localhost:99999"],
     r"expected tcp://HOST:PORT"),
    ("sweep-scheduler-protocol", None, [*SO, "--scheduler", "ucx://host:8786"],
     r"unsupported protocol 'ucx'"),
    ("sweep-scheduler-empty", None, [*SO, "--scheduler", ""], r"--scheduler: empty address"),
    ("sweep-workers-0", None, [*SO, "--workers", "0"], r"--workers must be in \[1, \d+\], got 0"),
    ("sweep-workers-1000", None, [*SO, "--workers", "1000"],
     r"--workers must be in \[1, \d+\], got 1000 \(this machine has"),
    ("sweep-arch-all", None, [*SO, "--arch", "all"], r"--arch must be nfir, noe or both"),
    ("sweep-delays-text", None, [*SO, "--delays", "a,b"],
     r"--delays must be a comma-separated list of integers"),
    ("sweep-delays-zero", None, [*SO, "--delays", "0,5"],
     r"--delays must list integers in \[1, 10000\], got '0,5'"),
    ("sweep-delays-repeated", None, [*SO, "--delays", "5,5"], r"--delays must not repeat"),
    ("sweep-neurons-huge", None, [*SO, "--neurons", "100000"],
     r"--neurons must list integers in \[1, 4096\]"),
    ("sweep-neurons-empty", None, [*SO, "--neurons", ""],
     r"--neurons must list integers in \[1, 4096\], got ''"),
    ("sweep-out-is-a-file", None, [*S, "--out", "{tmp}/afile"],
     r"afile: exists and is not a directory"),
    ("sweep-out-is-the-data", None, [*S, "--out", "{tmp}/good.nc"],
     r"good\.nc is also an input of this command"),
    ("sweep-input-time", None, [*SO, "--input", "time"],
     r"--input time: 'time' is the time axis of .*good\.nc, not a signal"),
    ("sweep-validation-other-unit", None,
     ["sweep", "--data", "{tmp}/good.nc", "--validation", "{tmp}/rads.nc", "--out", "{tmp}/sw"],
     r"unit mismatch: variable 'velocity'"),
    ("sweep-max-epochs--1", None, [*SO, "--max-epochs", "-1"], r"--max-epochs must be in"),
    ("sweep-seed--1", None, [*SO, "--seed", "-1"], rf"--seed must be in {SEED_MAX}"),
    ("sweep-grid-too-big", None, [*SO, "--arch", "nfir", "--delays", "900"],
     r"good\.nc: 1500 samples are too few for NFIR\(900, 40\)"),
    # -- map ------------------------------------------------------------------------------------
    ("map-rig-and-model", None, [*M, "--model", "{models}/good.npz"],
     r"exactly one of --rig or --model"),
    ("map-n-omega-huge", None, [*M, "--n-omega", "1000000"],
     r"--n-omega must be in \[2, 200\], got 1000000 \(each frequency"),
    ("map-n-a-0", None, [*M, "--n-a", "0"], r"--n-a must be in \[2, 200\], got 0"),
    ("map-n-a-float", None, [*M, "--n-a", "2.5"], r"Invalid value for '--n-a'"),
    ("map-seed--1", None, [*M, "--seed", "-1"], rf"--seed must be in {SEED_MAX}"),
    ("map-out-is-the-reference", None,
     ["map", "--rig", "--reference", "{tmp}/ref22.nc", "--out", "{tmp}/ref22.nc"],
     r"ref22\.nc is also an input of this command"),
    ("map-out-png", None, ["map", "--rig", "--out", "{tmp}/m.png"],
     r"unknown format '\.png' \(use \.nc\)"),
    ("map-out-under-a-file", None, ["map", "--rig", "--out", "{tmp}/afile/m.nc"],
     r"afile is not a directory"),
    ("map-out-png-is-a-directory", lambda tmp: (tmp / "m.png").mkdir(),
     ["map", "--rig", "--out", "{tmp}/m.nc"], r"--out \(its PNG\) .*m\.png: is a directory"),
    ("map-reference-other-shape", None,
     [*M, "--reference", "{tmp}/ref22.nc", "--n-omega", "3", "--n-a", "2"],
     r"map of shape \(2, 2\), this map will be \(3, 2\): use the same --n-omega and --n-a"),
    ("map-reference-other-grid", None,
     [*M, "--reference", "{tmp}/ref22_other.nc", "--n-omega", "2", "--n-a", "2"],
     r"its omega_bar grid differs from this map's"),
    ("map-reference-is-a-directory", None, [*M, "--reference", "{tmp}/adir"],
     r"--reference .*adir: is a directory"),
    ("map-model-in-acceleration-units", None,
     ["map", "--model", "{models}/ms2.npz", "--out", "{tmp}/m.nc"],
     r"the ROM maps 'm/s\^2' to 'N'; the map feeds it the tank velocity in m/s"),
    ("map-model-too-slow", None, ["map", "--model", "{models}/slow100.npz", "--out", "{tmp}/m.nc"],
     r"the ROM runs at 100 Hz, too slow for harmonic tests up to 25 Hz"),
    # -- config show / reproduce ----------------------------------------------------------------
    ("config-rms-empty", _cfg("[beam]\nrms_g = []\n"), CS,
     r"'beam\.rms_g' must be a non-empty list of RMS levels in g, each in \(0, 2\], got \[\]"),
    ("reproduce-rms-empty", _cfg("[beam]\nrms_g = []\n"), RP,
     r"'beam\.rms_g' must be a non-empty list of RMS levels in g"),
    ("config-rms-string", _cfg("[beam]\nrms_g = \"0.1\"\n"), CS, r"'beam\.rms_g' must be a list"),
    ("config-rms-negative", _cfg("[beam]\nrms_g = [0.1, -0.2]\n"), CS,
     r"'beam\.rms_g\[1\]' must be an RMS level in g in \(0, 2\], got -0\.2"),
    ("config-damping-too-short", _cfg("[beam]\ndamping = [0.01]\n"), CS,
     r"'beam\.damping' has 1 ratio\(s\) but 'beam\.n_modes' is 3"),
    ("config-damping-1", _cfg("[beam]\ndamping = [1.0, 0.005, 0.005]\n"), CS,
     r"'beam\.damping\[0\]' must be a damping ratio in \[0, 1\), got 1\.0"),
    ("config-n-modes-6", _cfg("[beam]\nn_modes = 6\ndamping = [0.01, 0.01, 0.01, 0.01, 0.01, "
                              "0.01]\n"), CS,
     r"'beam\.n_modes' must be an integer in \[1, 5\], got 6 \(the modal filter"),
    ("config-f-min-above-f-max", _cfg("[map]\nf_min = 30.0\n"), CS,
     r"'map\.f_min' \(30 Hz\) must be below 'map\.f_max' \(25 Hz\)"),
    ("config-a-bar-swapped", _cfg("[map]\na_bar_min = 0.5\na_bar_max = 0.1\n"), CS,
     r"'map\.a_bar_min' \(0\.5\) must be below 'map\.a_bar_max' \(0\.1\)"),
    ("config-n-omega-huge", _cfg("[map]\nn_omega = 100000\n"), CS,
     r"'map\.n_omega' must be an integer in \[2, 200\], got 100000"),
    ("config-fs-0", _cfg("[rig]\nfs = 0\n"), CS,
     r"'rig\.fs' must be a record rate in Hz in \[100, 5000\], got 0\.0"),
    ("config-fs-10-khz", _cfg("[rig]\nfs = 10000.0\n"), CS,
     r"'rig\.fs' must be a record rate in Hz in \[100, 5000\], got 10000\.0 \(decimated"),
    ("config-free-duration-1", _cfg("[beam]\nfree_duration = 1.0\n"), CS,
     r"'beam\.free_duration' = 1 s is too short for the damping analysis of mode 1 "
     r"\(10\.2 Hz\): need at least 1\.8 s"),
    ("config-random-duration-20", _cfg("[beam]\nrandom_duration = 20.0\n"), CS,
     r"'beam\.random_duration' = 20 s must hold at least one 16384-sample Welch segment"),
    ("config-random-memory", _cfg("[beam]\nrandom_duration = 600.0\n"
                                  "rms_g = [0.1, 0.2, 0.3, 0.4]\n"), CS,
     r"'beam\.random_duration' x 4 levels = 2400 s is more than 1800 s"),
    ("config-f0-1e6", _cfg("[beam]\nf0 = 1e6\n"), CS,
     r"'beam\.f0' \+ 4 'beam\.sigma' = 1\.00002e\+06 Hz must stay below 250 Hz"),
    ("config-sigma-60", _cfg("[beam]\nsigma = 60.0\n"), CS,
     r"'beam\.f0' \+ 4 'beam\.sigma' = 252 Hz must stay below 250 Hz"),
    ("config-psd-below-0-hz", _cfg("[beam]\nf0 = 5.0\n"), CS,
     r"'beam\.f0' - 3 'beam\.sigma' = -7 Hz must not be below 0 Hz"),
    ("config-sweep-grid-empty", _cfg("[rom]\nsweep_nfir_delays = []\n"), CS,
     r"'rom\.sweep_nfir_delays' must be a non-empty list of delays"),
    ("config-sweep-grid-strings", _cfg("[rom]\nsweep_noe_neurons = [\"ten\"]\n"), CS,
     r"'rom\.sweep_noe_neurons\[0\]' must be an integer in \[1, 4096\], got 'ten'"),
    ("config-sweep-workers-0", _cfg("[rom]\nsweep_workers = 0\n"), CS,
     r"'rom\.sweep_workers' must be a number of parallel trainings in \[1, 64\], got 0"),
    ("config-neurons-float", _cfg("[rom]\nneurons = 3.5\n"), CS,
     r"'rom\.nfir\.neurons' must be an integer in \[1, 4096\], got 3\.5"),
    # bool is an int in Python: true is called a boolean, not "must be true or false"
    ("config-nss-states-true", _cfg("[rom.nss]\nn_states = true\n"), CS,
     r"'rom\.nss\.n_states' must be an integer, got true \(a boolean\)$"),
    ("config-former-nss-states-true", _cfg("[rom]\nnss_states = true\n"), CS,
     r"'rom\.nss\.n_states' must be an integer, got true \(a boolean\)$"),
    ("config-nss-epoch-cost",
     _cfg("[rom]\narch = \"nss\"\n[rom.nss]\nwindow = 9000\nhorizon = 9000\n"), CS,
     r"one training epoch of NSS\(8 states, 64 neurons, strictly proper\), "
     r"'rom\.nss\.steps_per_epoch' x 'rom\.nss\.batch' x \('rom\.nss\.window' \+ "
     r"'rom\.nss\.horizon'\) x 'rom\.nss\.neurons' = 200 x 128 x \(9000 \+ 9000\) x 64 = "
     r"2\.95e\+10 neuron-samples, more than 1\.5e\+10"),
    ("reproduce-quick-nss-epoch-cost",
     _cfg("[rom]\narch = \"nss\"\n[rom.nss]\nwindow = 9000\nhorizon = 9000\n"),
     ["reproduce", "--quick", "--config", "{tmp}/c.toml", "--out", "{tmp}/res"],
     r"'rom\.nss\.window' \+ 'rom\.nss\.horizon'\) x 'rom\.nss\.neurons' = .* more than "
     r"1\.5e\+10"),
    ("config-compared-nss-epoch-cost", _cfg("[rom]\narch = \"nfir\"\ncompare = [\"nss\"]\n"
                                            "[rom.nss]\nneurons = 4096\n"), CS,
     r"NSS\(8 states, 4096 neurons, strictly proper\), .* = 200 x 128 x \(50 \+ 200\) x "
     r"4096 = 2\.62e\+10 neuron-samples"),
    ("config-max-epochs-negative", _cfg("[rom]\nmax_epochs = -1\n"), CS,
     r"'rom\.nfir\.max_epochs' must be an integer in \[0, 10000000\], got -1"),
    ("config-rig-seed-negative", _cfg("[rig]\nseed = -1\n"), CS,
     r"'rig\.seed' must be a non-negative integer seed in \[0, 4294967295\], got -1"),
    ("config-hidden-gauss", _cfg("[rom]\nhidden = \"gauss\"\n"), CS,
     r"'rom\.nfir\.hidden' must be one of 'matlab', 'distance', got 'gauss'"),
    ("config-train-duration-memory", _cfg("[data]\ntrain_duration = 1e7\n"), CS,
     r"'data\.train_duration' must be a VFA duration in s in \[10, 3600\], got 10000000\.0 "
     r".*memory"),
    ("config-tip-0", _cfg("[beam]\ntip_displacement = 0.0\n"), CS,
     r"'beam\.tip_displacement' must be an initial tip displacement in m in \(0, 0\.2\]"),
    ("config-network-too-big", _cfg("[rom]\narch = \"nfir\"\ndelays = 1000\nneurons = 1000\n"
                                    "[data]\ntrain_duration = 10.0\n"), CS,
     r"'rom\.nfir': 5000 samples \('data\.train_duration' = 10 s at 'rig\.fs' = 500 Hz\) are "
     r"too few for NFIR\(1000, 1000\) \(training needs at least 21050\)$"),
    ("reproduce-sweep-grid-too-big", _cfg("[rom]\nsweep_nfir_delays = [1000]\n"
                                          "sweep_nfir_neurons = [1000]\n"
                                          "[data]\ntrain_duration = 10.0\n"),
     ["reproduce", "--sweep", "--config", "{tmp}/c.toml", "--out", "{tmp}/res"],
     r"the largest of 'rom\.sweep_nfir_delays'/'rom\.sweep_nfir_neurons': 5000 samples .* are "
     r"too few for NFIR\(1000, 1000\)"),
    ("reproduce-out-is-a-file", None, ["reproduce", "--quick", "--out", "{tmp}/afile"],
     r"afile: exists and is not a directory"),
    ("reproduce-out-is-the-config", _cfg("[rom]\nseed = 1\n"),
     ["reproduce", "--config", "{tmp}/c.toml", "--out", "{tmp}/c.toml"],
     r"c\.toml is also an input of this command"),
    ("reproduce-config-is-a-directory", None, ["reproduce", "--config", "{tmp}/adir"],
     r"--config .*adir: is a directory"),
    ("config-show-empty-path", None, ["config", "show", "--config", ""],
     r"--config \.: is a directory, expected a file"),
    # -- beam free ------------------------------------------------------------------------------
    ("beam-free-no-out", None, BF, r"Missing option '--out'"),
    ("beam-free-duration-1", None, [*BFO, "--duration", "1"],
     r"--duration 1 s is too short for the damping analysis of mode 1 \(10\.2 Hz\): need at "
     r"least 1\.8 s \(18 periods\)"),
    ("beam-free-duration-inf", None, [*BFO, "--duration", "inf"],
     r"--duration must be in \(0, 600\] s, got inf"),
    ("beam-free-duration-1e6", None, [*BFO, "--duration", "1e6"],
     r"--duration must be in \(0, 600\] s, got 1000000\.0"),
    ("beam-free-tip-0", None, [*BFO, "--tip-displacement", "0"],
     r"--tip-displacement must not be 0"),
    ("beam-free-tip-nan", None, [*BFO, "--tip-displacement", "nan"],
     r"--tip-displacement must be in \(-0\.2, 0\.2\) m, got nan"),
    ("beam-free-seed--1", None, [*BFO, "--seed", "-1"], rf"--seed must be in {SEED_MAX}"),
    ("beam-free-out-is-a-file", None, [*BF, "--out", "{tmp}/afile"],
     r"afile: exists and is not a directory"),
    ("beam-free-out-under-a-file", None, [*BF, "--out", "{tmp}/afile/res"],
     r"afile is not a directory"),
    ("beam-free-model-where-a-result-goes",
     _copy("{models}/good.npz", "res/table1_frozen_modes.csv"),
     [*BFO, "--sloshing", "{tmp}/res/table1_frozen_modes.csv"],
     r"table1_frozen_modes\.csv is also an input of this command"),
    ("beam-free-tank-where-a-result-goes", _copy("{tmp}/t.toml", "res/table1_frozen_modes.md"),
     [*BFO, "--tank-toml", "{tmp}/res/table1_frozen_modes.md"],
     r"table1_frozen_modes\.md is also an input of this command"),
    ("beam-free-result-is-a-directory", lambda tmp: (tmp / "res" / "free_frozen.nc").mkdir(
        parents=True), BFO, r"free_frozen\.nc: is a directory"),
    ("beam-free-rig-twice", None, [*BFO, "--sloshing", "rig", "--sloshing", "rig"],
     r"--sloshing rig: a second case named 'rig'"),
    ("beam-free-rom-named-rig", _copy("{models}/good.npz", "rig.npz"),
     [*BFO, "--sloshing", "rig", "--sloshing", "{tmp}/rig.npz"],
     r"rig\.npz: a second case named 'rig'"),
    ("beam-free-rom-in-acceleration-units", None, [*BFO, "--sloshing", "{models}/ms2.npz"],
     r"ms2\.npz: the ROM maps 'm/s\^2' to 'N'; the beam feeds it the tank velocity in m/s"),
    ("beam-free-rom-at-250-hz", None, [*BFO, "--sloshing", "{models}/r250.npz"],
     r"r250\.npz: the ROM runs at 250 Hz; the beam needs a multiple of 500 Hz"),
    ("beam-free-sloshing-empty", None, [*BFO, "--sloshing", ""], r"does not exist"),
    ("beam-free-mode-1-at-300-hz", None, [*BFO, "--modal-toml", "{tmp}/modal300.toml"],
     r"the first beam mode \(\d+(\.\d+)? Hz\) is too high for the 500 Hz results"),
    ("beam-free-modal-is-a-directory", None, [*BFO, "--modal-toml", "{tmp}/adir"],
     r"--modal-toml .*adir: is a directory"),
    ("beam-free-tank-missing", None, [*BFO, "--tank-toml", "{tmp}/none.toml"],
     r"--tank-toml .*none\.toml: no such file"),
    # -- beam random ----------------------------------------------------------------------------
    ("beam-random-f0-1e6", None, [*BRO, "--f0", "1e6"],
     r"--f0 \+ 4 --sigma = 1\.00002e\+06 Hz must stay below 250 Hz"),
    ("beam-random-f0-nan", None, [*BRO, "--f0", "nan"],
     r"--f0 must be a positive frequency in Hz, got nan"),
    ("beam-random-sigma-negative", None, [*BRO, "--sigma", "-4"],
     r"--sigma must be a positive frequency in Hz, got -4\.0"),
    ("beam-random-psd-below-0-hz", None, [*BRO, "--f0", "5", "--sigma", "4"],
     r"--f0 - 3 --sigma = -7 Hz must not be below 0 Hz"),
    ("beam-random-duration-20", None, [*BRO, "--duration", "20"],
     r"--duration must be in \[33, 600\] s, got 20\.0 \(Table 2 needs one 16384-sample"),
    ("beam-random-memory", None, [*BRO, "--duration", "600", "--levels", "0.1,0.2,0.3,0.4"],
     r"--duration 600 s x 4 level\(s\) = 2400 s is more than 1800 s"),
    ("beam-random-level-inf", None, [*BRO, "--levels", "inf"],
     r"--levels must be RMS values in \(0, 2\] g, got 'inf'"),
    ("beam-random-level-nan", None, [*BRO, "--levels", "0.1,nan"],
     r"--levels must be RMS values in \(0, 2\] g, got '0\.1,nan'"),
    ("beam-random-levels-empty", None, [*BRO, "--levels", ""],
     r"--levels must be RMS values in \(0, 2\] g, got ''"),
    ("beam-random-level-3-g", None, [*BRO, "--levels", "3"], r"--levels must be RMS values"),
    ("beam-random-seed--1", None, [*BRO, "--seed", "-1"], rf"--seed must be in {SEED_MAX}"),
    ("beam-random-out-is-a-file", None, [*BR, "--out", "{tmp}/afile"],
     r"afile: exists and is not a directory"),
    # -- export onnx ----------------------------------------------------------------------------
    ("onnx-out-is-the-model", _copy("{models}/good.npz", "m.onnx"),
     [*E, "{tmp}/m.onnx", "{tmp}/m.onnx"], r"m\.onnx is also an input of this command"),
    ("onnx-dtype-float16", None, [*E, "{models}/good.npz", "{tmp}/o.onnx", "--dtype", "float16"],
     r"--dtype must be 'float64' or 'float32', got 'float16'"),
    ("onnx-out-is-a-directory", lambda tmp: (tmp / "o.onnx").mkdir(),
     [*E, "{models}/good.npz", "{tmp}/o.onnx"], r"o\.onnx: is a directory"),
    ("onnx-out-under-a-file", None, [*E, "{models}/good.npz", "{tmp}/afile/o.onnx"],
     r"afile is not a directory"),
    ("onnx-tampered-model", None, [*E, "{models}/tampered.npz", "{tmp}/o.onnx"],
     r"parameter W tampered"),
    ("onnx-no-arguments", None, E, r"(?i)Missing argument 'MODEL'"),
    # -- export fmu ------------------------------------------------------------------------------
    ("fmu-out-is-the-model", _copy("{models}/good.npz", "m.fmu"),
     [*EF, "{tmp}/m.fmu", "{tmp}/m.fmu"], r"m\.fmu is also an input of this command"),
    ("fmu-out-is-onnx", None, [*EF, "{models}/good.npz", "{tmp}/o.onnx"],
     r"output must be a \.fmu file, got .*o\.onnx"),
    ("fmu-step-not-the-models", None, [*EF, "{models}/good.npz", "{tmp}/o.fmu", "--step",
                                       "0.001"],
     r"--step 0\.001 s is not the model's step 0\.002 s \(500 Hz\)"),
    ("fmu-step-nan", None, [*EF, "{models}/good.npz", "{tmp}/o.fmu", "--step", "nan"],
     r"--step must be > 0 s, got nan"),
    ("fmu-step-0", None, [*EF, "{models}/good.npz", "{tmp}/o.fmu", "--step", "0"],
     r"--step must be > 0 s, got 0\.0"),
    ("fmu-step--1", None, [*EF, "{models}/good.npz", "{tmp}/o.fmu", "--step", "-1"],
     r"--step must be > 0 s, got -1\.0"),
    ("fmu-out-is-a-directory", lambda tmp: (tmp / "o.fmu").mkdir(),
     [*EF, "{models}/good.npz", "{tmp}/o.fmu"], r"o\.fmu: is a directory"),
    ("fmu-out-under-a-file", None, [*EF, "{models}/good.npz", "{tmp}/afile/o.fmu"],
     r"afile is not a directory"),
    ("fmu-tampered-model", None, [*EF, "{models}/tampered.npz", "{tmp}/o.fmu"],
     r"parameter W tampered"),
    ("fmu-model-not-a-model", None, [*EF, "{models}/text.npz", "{tmp}/o.fmu"],
     r"text\.npz: not a sloshrom model file"),
    ("fmu-model-missing", None, [*EF, "{tmp}/nothing.npz", "{tmp}/o.fmu"],
     r"MODEL .*nothing\.npz: no such file"),
    ("fmu-model-fifo", _fifo("fifo.npz"), [*EF, "{tmp}/fifo.npz", "{tmp}/o.fmu"],
     r"MODEL .*fifo\.npz: is a named pipe \(FIFO\)"),
    ("fmu-model-in-ms2-on-the-velocity", None, [*EF, "{models}/ms2.npz", "{tmp}/o.fmu"],
     r"the model maps 'm/s\^2' to 'N'; an FMU's interface is SI \(the tank velocity in m/s"),
    ("fmu-model-is-a-ball", None, [*EF, "{models}/ball.toml", "{tmp}/o.fmu"],
     r"a BouncingBall cannot be exported to an FMU: an FMU holds fitted ROMs .*The "
     r"bouncing ball is a physics model"),
    ("fmu-no-arguments", None, EF, r"(?i)Missing argument 'MODEL'"),
    # -- import uff -----------------------------------------------------------------------------
    ("uff-out-is-the-input", None, [*U, "{tmp}/raw.nc", "{tmp}/raw.nc"],
     r"raw\.nc is also an input of this command"),
    ("uff-f-highpass-nan", None, [*U, "{tmp}/good.uff", "{tmp}/o.nc", "--f-highpass", "nan"],
     r"--f-highpass must be >= 0 Hz, got nan"),
    ("uff-f-highpass--1", None, [*U, "{tmp}/good.uff", "{tmp}/o.nc", "--f-highpass", "-1"],
     r"--f-highpass must be >= 0 Hz, got -1\.0"),
    ("uff-f-highpass-above-nyquist", None,
     [*U, "{tmp}/good.uff", "{tmp}/o.nc", "--f-highpass", "60"],
     r"--f-highpass must be in \[0, 50\) Hz, got 60\.0 \(below the Nyquist frequency"),
    ("uff-input-missing", None, [*U, "{tmp}/none.uff", "{tmp}/o.nc"], r"UFF .*none\.uff: no such"),
    ("uff-input-is-a-directory", None, [*U, "{tmp}/adir", "{tmp}/o.nc"], r"adir: is a directory"),
    ("uff-out-txt", None, [*U, "{tmp}/good.uff", "{tmp}/o.txt"],
     r"OUT .*o\.txt: unknown format '\.txt'"),
    ("uff-tank-missing", None, [*U, "{tmp}/good.uff", "{tmp}/o.nc", "--tank", "{tmp}/none.toml"],
     r"--tank .*none\.toml: no such file"),
    ("uff-name-without-key", None, [*U, "{tmp}/good.uff", "{tmp}/o.nc", "--name", "=force"],
     r"--name must look like CHANNEL=VARIABLE, got '=force'"),
    # == the kinds of the hostile review (each kind, several commands where it occurs) ========
    # -- modal files must not change the physics without a word --------------------------------
    ("beam-uff-negative-damping", _uff_modes("neg.unv", modal_damp_vis=-0.01),
     [*ST, "{tmp}/neg.unv", "--tank", "5"],
     r"neg\.unv: mode 1 \(dataset \d+\) has viscous damping ratio -0\.01; it must be in \[0, 1\)"),
    ("beam-uff-nan-damping", _uff_modes("nan.unv", modal_damp_vis=float("nan")),
     [*ST, "{tmp}/nan.unv", "--tank", "5"], r"nan\.unv: mode 1 .*viscous damping ratio nan"),
    ("beam-uff-negative-loss-factor", _uff_modes("his.unv", modal_damp_vis=0.0,
                                                 modal_damp_his=-0.02),
     [*ST, "{tmp}/his.unv", "--tank", "5"], r"hysteretic damping \(loss factor\) -0\.02"),
    ("beam-punch-cut-in-its-last-number", _punch_cut, [*ST, "{tmp}/cut.pch", "--tank", "5"],
     r"cut\.pch: line \d+: the file ends inside this record .*truncated file"),
    ("beam-mode-table-without-a-mode", _all(_modal("w.pch", "punch"),
                                           _text("t.csv", "mode,damping\n1,0.01\n3,0.02\n")),
     [*ST, "{tmp}/w.pch", "--tank", "5", "--mode-table", "{tmp}/t.csv"],
     r"no row for mode\(s\) 2 of the mode set \(a table is matched to the modes by mode "
     r"number; it lists modes 1, 3\)"),
    # -- no output may overwrite an input, not only --out ---------------------------------------
    ("reproduce-config-is-the-report", _text("res/report.html", "[rom]\nseed = 1\n"),
     ["reproduce", "--config", "{tmp}/res/report.html", "--out", "{tmp}/res"],
     r"the command writes .*report\.html, and .*report\.html is also an input"),
    ("reproduce-config-is-the-summary", _text("res/summary.json", "[rom]\nseed = 1\n"),
     ["reproduce", "--config", "{tmp}/res/summary.json", "--out", "{tmp}/res"],
     r"the command writes .*summary\.json, and .*summary\.json is also an input"),
    ("reproduce-config-is-the-lock", _text("res/.sloshrom.lock", "[rom]\nseed = 1\n"),
     ["reproduce", "--config", "{tmp}/res/.sloshrom.lock", "--out", "{tmp}/res"],
     r"the command writes .*\.sloshrom\.lock, and .*\.sloshrom\.lock is also an input"),
    # another run (this test's parent process: alive) holds the output folder
    ("reproduce-out-held-by-another-run",
     _text("res/.sloshrom.lock", f'{{"pid": {os.getppid()}, "started": "then"}}'),
     ["reproduce", "--quick", "--out", "{tmp}/res"],
     rf"--out .*res: another sloshrom run \(process {os.getppid()}, started then\) is writing "
     r"there; .*delete .*res/\.sloshrom\.lock"),
    ("reproduce-config-in-a-stage-directory", _all(lambda tmp: (tmp / "res/data").mkdir(
        parents=True), _text("res/data/c.toml", "[rom]\nseed = 1\n")),
     ["reproduce", "--config", "{tmp}/res/data/c.toml", "--out", "{tmp}/res"],
     r"the command writes .*res/data/, and .*c\.toml is also an input"),
    ("sweep-data-is-the-sweep-table", _copy("{tmp}/good.csv", "res/sweep.csv"),
     ["sweep", "--data", "{tmp}/res/sweep.csv", "--validation", "{tmp}/good.nc", "--out",
      "{tmp}/res", "--max-epochs", "2"],
     r"the command writes .*sweep\.csv, and .*sweep\.csv is also an input"),
    # -- contracts without gaps -----------------------------------------------------------------
    ("beam-ball-at-another-fill", None,
     [*BFO, "--sloshing", "{models}/ball.toml", "--fill", "0.3"],
     r"--sloshing .*ball\.toml was identified at fill 50\.0%; fill 30\.0% is outside"),
    ("config-unseen-fill-is-a-member", _cfg("[beyond]\nunseen_fills = [0.5, 0.625]\n"), CS,
     r"'beyond\.unseen_fills' \[0\.5\] is also in 'beyond\.fills'"),
    ("beam-tank-fill-twice", _modal("m.csv"),
     [*ST, "{tmp}/m.csv", "--tank", "5:fill=0.3:fill=0.4"],
     r"--tank '5:fill=0\.3:fill=0\.4': the key 'fill' is given twice"),
    ("beam-tank-two-models", _modal("m.csv"), [*ST, "{tmp}/m.csv", "--tank", "5:frozen:rig"],
     r"--tank '5:frozen:rig': two models \('frozen' and 'rig'\)"),
    ("beam-tank-unknown-key", _modal("m.csv"), [*ST, "{tmp}/m.csv", "--tank", "5:density=3"],
     r"--tank '5:density=3': unknown key 'density'"),
    ("uff-unit-twice", None,
     [*U, "{tmp}/good.uff", "{tmp}/o.nc", "--unit", "force=N", "--unit", "force=kN"],
     r"--unit: the key 'force' is given twice \('N' and 'kN'\)"),
    ("uff-name-twice", None,
     [*U, "{tmp}/good.uff", "{tmp}/o.nc", "--name", "0=force", "--name", "0=acceleration"],
     r"--name: the key '0' is given twice"),
    # -- validated at the door, not a traceback after the work ----------------------------------
    ("predict-record-tank-fill-text", _nc_attrs("half.nc", tank_fill="half"),
     [*P, "--data", "{tmp}/half.nc", "--out", "{tmp}/o.nc"],
     r"half\.nc: attribute 'tank': fill must be a number in \(0, 1\), got 'half'"),
    ("predict-record-negative-density", _nc_attrs("rho.nc", tank_density=-1000.0),
     [*P, "--data", "{tmp}/rho.nc", "--out", "{tmp}/o.csv"],
     r"rho\.nc: attribute 'tank': density must be a finite positive number, got -1000\.0"),
    ("predict-record-fill-text", _nc_attrs("fill.nc", fill="half"),
     [*P, "--data", "{tmp}/fill.nc", "--out", "{tmp}/o.nc"],
     r"fill\.nc: attribute 'fill' must be a fill level d/h in \(0, 1\), got 'half'"),
    ("train-record-fills-disagree", _nc_attrs("two.nc", fill=0.5, tank_fill=0.3),
     [*TR, "--data", "{tmp}/two.nc", "--validation", "{tmp}/good.nc", "--out", "{tmp}/m.npz"],
     r"two\.nc: attribute 'fill' = 0\.5 but the tank attributes say fill 0\.3"),
    ("beam-shapes-1e200", _huge_shapes, [*ST, "{tmp}/huge.csv", "--tank", "5"],
     r"huge\.csv: mode 1 is [\d.]+e\+198 at node 1; shape values must be below 1e\+100"),
    ("beam-shapes-in-other-units-than-masses", _scaled_shapes("big.csv", 1e50),
     [*ST, "{tmp}/big.csv", "--tank", "5"],
     r"the liquid at the tank\(s\) weighs [\d.]+e\+99 times the modal masses .*more than "
     r"1e\+12"),
    ("beam-uff-grid-is-the-base-node", _modal("n1000.csv", nodes=np.array([1, 2, 3, 4, 1000])),
     [*ST, "{tmp}/n1000.csv", "--tank", "4", "--uff"],
     r"--uff: output point 1000 is the node the UFF results give the base"),
    ("rig-harmonic-fill-1e-9", None, [*H12, "--accel-g", "1", "--fill", "1e-9"],
     r"the virtual rig cannot model fill 1e-09 \(liquid depth 2\.72e-11 m\): only 0 of the 6 "
     r"tank surface modes"),
    ("rig-vfa-fill-1e-9", None, [*VO, "--fill", "1e-9"],
     r"the virtual rig cannot model fill 1e-09"),
    ("beam-rig-fill-1e-9", None, [*BFO, "--sloshing", "rig", "--fill", "1e-9"],
     r"--sloshing rig: the virtual rig cannot model fill 1e-09"),
    ("map-rig-fill-1e-9", None, [*M, "--fill", "1e-9"],
     r"--rig: the virtual rig cannot model fill 1e-09"),
    ("config-tank-fill-1e-9", _cfg("[tank]\nfill = 1e-9\n"), CS,
     r"'tank\.fill' = 1e-09: the virtual rig cannot model fill 1e-09"),
    ("reproduce-beyond-fill-1e-9", _cfg("[beyond]\nenabled = true\nfills = [1e-9, 0.5]\n"
                                       "unseen_fills = [0.25]\nbeam_fills = [0.5]\n"), RP,
     r"'beyond\.fills' = 1e-09: the virtual rig cannot model fill 1e-09"),
    # -- limits checked before the work they limit -----------------------------------------------
    ("beam-structure-300-modes", _many_modes, [*ST, "{tmp}/many.csv", "--tank", "5"],
     r"many\.csv holds 300 modes; a modal model takes at most 200 .*--modes N"),
    ("config-ensemble-weights", _cfg("[rom]\narch = \"nfir\"\nensemble = 64\ndelays = 100\n"
                                     "neurons = 700\n"),
     CS, r"'rom\.ensemble' = 64 members of NFIR\(100, 700\) have 64 x 70000 = 4480000 weights "
         r"\(700 neurons x 100 regressor entries each\), more than 4194304"),
    ("reproduce-beyond-fill-ensemble-weights",
     _cfg("[rom]\narch = \"nfir\"\ndelays = 300\nneurons = 1000\n[beyond]\n"
          "fill_ensemble = 20\n"),
     [*RP, "--beyond"], r"'beyond\.fill_ensemble' = 20 members of NFIR\(300, 1000\) have .* = "
                        r"6000000 weights"),
    ("train-ensemble-weights", None,
     ["train", "--max-epochs", "1", "--data", "{tmp}/good.nc", "--validation", "{tmp}/good.nc",
      "--out",
      "{tmp}/e.npz", "--ensemble", "64", "--delays", "70", "--neurons", "950",
      "--scheduler", "sequential"],
     r"--ensemble 64: 64 members of NFIR\(70, 950\) have 64 x 66500 = 4256000 weights \(950 "
     r"neurons x 70 regressor entries each\), more than 4194304"),
    # -- clear messages -------------------------------------------------------------------------
    ("config-show-fifo", _fifo("fifo.toml"), ["config", "show", "--config", "{tmp}/fifo.toml"],
     r"--config .*fifo\.toml: is a named pipe \(FIFO\), not a regular file"),
    ("train-data-fifo", _fifo("fifo.nc"),
     [*TR, "--data", "{tmp}/fifo.nc", "--validation", "{tmp}/good.nc", "--out", "{tmp}/m.npz"],
     r"--data .*fifo\.nc: is a named pipe \(FIFO\)"),
    ("beam-sloshing-fifo", _fifo("fifo.npz"), [*BFO, "--sloshing", "{tmp}/fifo.npz"],
     r"--sloshing .*fifo\.npz: is a named pipe \(FIFO\)"),
    ("onnx-model-fifo", _fifo("fifo.npz"), [*E, "{tmp}/fifo.npz", "{tmp}/o.onnx"],
     r"MODEL .*fifo\.npz: is a named pipe \(FIFO\)"),
    # an export replaces OUT by renaming: a named pipe another program reads is refused
    ("onnx-out-fifo", _fifo("o.onnx"), [*E, "{models}/good.npz", "{tmp}/o.onnx"],
     r"OUT .*o\.onnx: is a named pipe \(FIFO\), not a regular file"),
    ("fmu-out-fifo", _fifo("o.fmu"), [*EF, "{models}/good.npz", "{tmp}/o.fmu"],
     r"OUT .*o\.fmu: is a named pipe \(FIFO\), not a regular file"),
    ("beam-uff-negative-modal-mass", _uff_modes("negm.unv", modal_m=-2.0),
     [*ST, "{tmp}/negm.unv", "--tank", "5"],
     r"negm\.unv: the modal mass of mode 1 is -2\.0 in the file; a modal mass .* must be "
     r"positive"),
    ("train-input-does-not-oscillate", _one_sided,
     [*TR, "--data", "{tmp}/onesided.nc", "--validation", "{tmp}/onesided.nc", "--out",
      "{tmp}/m.npz"],
     r"the input 'velocity' does not oscillate about rest \(it stays between 0\.01 and 0\.03 "
     r"m/s, never changing sign\)"),
    # == measured tests: analyse free / analyse random, compare ===============================
    # -- analyse free -----------------------------------------------------------------------------
    ("analyse-free-no-out", None, AF, r"Missing option '--out'"),
    ("analyse-free-no-channels", None, ["analyse", "free", "{tmp}/lab.uff", "--out", "{tmp}/res"],
     r"Missing option '--channels'"),
    ("analyse-free-no-file", None, ["analyse", "free", "--channels", "{tmp}/ch.toml", "--out",
                                    "{tmp}/res"], r"Missing argument 'FILE'"),
    ("analyse-no-such-kind", None, ["analyse", "sine", "{tmp}/lab.uff"],
     r"No such command 'sine'"),
    ("analyse-free-out-is-a-file", None, [*AF, "--out", "{tmp}/afile"],
     r"--out .*afile: exists and is not a directory"),
    ("analyse-free-out-under-a-file", None, [*AF, "--out", "{tmp}/afile/res"],
     r"afile is not a directory"),
    ("analyse-free-out-name-too-long", None, [*AF, "--out", "{tmp}/" + "y" * 300],
     r"--out .*longer than 255 bytes"),
    ("analyse-free-out-is-the-file", None, [*AF, "--out", "{tmp}/lab.uff"],
     r"--out .*lab\.uff is also an input of this command"),
    ("analyse-free-out-is-the-channels-other-spelling", None,
     [*AF, "--out", "{tmp}/adir/../ch.toml"], r"ch\.toml is also an input of this command"),
    ("analyse-free-file-is-the-result", _copy("{tmp}/lab.uff", "res/free_lab.nc"),
     ["analyse", "free", "{tmp}/res/free_lab.nc", "--channels", "{tmp}/ch.toml", "--name", "lab",
      "--out", "{tmp}/res"], r"result file .*free_lab\.nc is also an input of this command"),
    ("analyse-free-file-is-the-table-other-spelling",
     _copy("{tmp}/lab.uff", "res/damping_bands.csv"),
     ["analyse", "free", "{tmp}/adir/../res/damping_bands.csv", "--channels", "{tmp}/ch.toml",
      "--out", "{tmp}/res"], r"result file .*damping_bands\.csv is also an input"),
    ("analyse-free-channels-is-a-figure",
     _copy("{tmp}/ch.toml", "res/fig14_station_accelerations.png"),
     [*AF[:3], "--channels", "{tmp}/res/fig14_station_accelerations.png", "--out", "{tmp}/res"],
     r"fig14_station_accelerations\.png is also an input of this command"),
    ("analyse-free-modal-is-the-table", _copy("{tmp}/modal.toml", "res/damping_bands.md"),
     [*AFO, "--modal-toml", "{tmp}/res/damping_bands.md"],
     r"damping_bands\.md is also an input of this command"),
    ("analyse-free-tank-is-a-figure", _copy("{tmp}/t.toml", "res/fig16_modal_accelerations.png"),
     [*AFO, "--tank-toml", "{tmp}/res/fig16_modal_accelerations.png"],
     r"fig16_modal_accelerations\.png is also an input of this command"),
    ("analyse-free-result-is-a-directory", lambda tmp: (tmp / "res/free_measured.nc").mkdir(
        parents=True), AFO, r"free_measured\.nc: is a directory"),
    ("analyse-free-channels-empty-path", None, [*AF[:3], "--channels", "", "--out", "{tmp}/res"],
     r"--channels \.: is a directory, expected a file"),
    ("analyse-free-channels-is-a-directory", None,
     [*AF[:3], "--channels", "{tmp}/adir", "--out", "{tmp}/res"],
     r"--channels .*adir: is a directory"),
    ("analyse-free-channels-missing", None,
     [*AF[:3], "--channels", "{tmp}/none.toml", "--out", "{tmp}/res"],
     r"--channels .*none\.toml: no such file"),
    ("analyse-free-channels-under-a-file", None,
     [*AF[:3], "--channels", "{tmp}/afile/ch.toml", "--out", "{tmp}/res"],
     r"--channels .*afile/ch\.toml: cannot be read \(Not a directory\)"),
    ("analyse-free-channels-name-too-long", None,
     [*AF[:3], "--channels", "{tmp}/" + "y" * 300 + ".toml", "--out", "{tmp}/res"],
     r"--channels .*y\.toml: .*(too long|longer than 255)"),
    ("analyse-free-channels-not-toml", _text("bad.toml", "stations = = [\n"),
     [*AF[:3], "--channels", "{tmp}/bad.toml", "--out", "{tmp}/res"],
     r"--channels: .*bad\.toml: not valid TOML"),
    ("analyse-free-channels-empty-file", _text("empty.toml", ""),
     [*AF[:3], "--channels", "{tmp}/empty.toml", "--out", "{tmp}/res"],
     r"--channels: .*empty\.toml: no \[channels\] table"),
    ("analyse-free-channels-binary", _png("bin.toml"),
     [*AF[:3], "--channels", "{tmp}/bin.toml", "--out", "{tmp}/res"],
     r"--channels: .*bin\.toml: not valid TOML \(not UTF-8 text: byte 0x89 at offset 0\)"),
    ("analyse-free-channels-is-the-record", None,
     [*AF[:3], "--channels", "{tmp}/lab.uff", "--out", "{tmp}/res"],
     r"--channels: .*lab\.uff: not valid TOML"),
    ("analyse-free-channels-fifo", _fifo("fifo.toml"),
     [*AF[:3], "--channels", "{tmp}/fifo.toml", "--out", "{tmp}/res"],
     r"--channels .*fifo\.toml: is a named pipe \(FIFO\)"),
    ("analyse-free-file-empty-path", None,
     ["analyse", "free", "", "--channels", "{tmp}/ch.toml", "--out", "{tmp}/res"],
     r"FILE \.: is a directory, expected a file"),
    ("analyse-free-file-is-a-directory", None,
     ["analyse", "free", "{tmp}/adir", "--channels", "{tmp}/ch.toml", "--out", "{tmp}/res"],
     r"FILE .*adir: is a directory"),
    ("analyse-free-file-under-a-file", None,
     ["analyse", "free", "{tmp}/afile/lab.uff", "--channels", "{tmp}/ch.toml", "--out",
      "{tmp}/res"], r"FILE .*afile/lab\.uff: cannot be read \(Not a directory\)"),
    ("analyse-free-file-name-too-long", None,
     ["analyse", "free", "{tmp}/" + "y" * 300 + ".uff", "--channels", "{tmp}/ch.toml", "--out",
      "{tmp}/res"], r"FILE .*y\.uff: .*(too long|longer than 255)"),
    ("analyse-free-file-twice-other-spelling", None,
     ["analyse", "free", "{tmp}/lab.uff", "{tmp}/adir/../lab.uff", "--channels", "{tmp}/ch.toml",
      "--out", "{tmp}/res"], r"FILE .*adir/\.\./lab\.uff is given twice \(also as .*lab\.uff\)"),
    ("analyse-free-file-binary", _png("bin.uff"),
     ["analyse", "free", "{tmp}/bin.uff", "--channels", "{tmp}/ch.toml", "--out", "{tmp}/res"],
     r"bin\.uff: truncated or not a UFF file"),
    ("analyse-free-file-is-the-channels", None,
     ["analyse", "free", "{tmp}/ch.toml", "--channels", "{tmp}/ch.toml", "--out", "{tmp}/res"],
     r"ch\.toml: unknown record format '\.toml'"),
    ("analyse-free-name-empty", None, [*AFO, "--name", ""], r"--name '': letters, digits"),
    ("analyse-free-name-a-path", None, [*AFO, "--name", "../up"], r"--name '\.\./up': letters"),
    ("analyse-free-name-too-long", None, [*AFO, "--name", "n" * 300],
     r"result file .*free_n+\.nc: .*longer than 255 bytes"),
    ("analyse-free-f1-0", None, [*AFO, "--f1", "0"], r"--f1 must be > 0 Hz, got 0\.0"),
    ("analyse-free-f1--1", None, [*AFO, "--f1", "-1"], r"--f1 must be > 0 Hz, got -1\.0"),
    ("analyse-free-f1-nan", None, [*AFO, "--f1", "nan"], r"--f1 must be > 0 Hz, got nan"),
    ("analyse-free-f1-inf", None, [*AFO, "--f1", "inf"], r"--f1 must be > 0 Hz, got inf"),
    ("analyse-free-f1-1e308", None, [*AFO, "--f1", "1e308"],
     r"the mode at 1e\+308 Hz is too close to the Nyquist frequency \(250 Hz\)"),
    ("analyse-free-f1-empty", None, [*AFO, "--f1", ""], r"Invalid value for '--f1'"),
    ("analyse-free-f1-text", None, [*AFO, "--f1", "ten"], r"Invalid value for '--f1'"),
    ("analyse-free-fill-nan", None, [*AFO, "--fill", "nan"],
     r"--fill must be in \(0, 1\), got nan"),
    ("analyse-free-fill-1e308", None, [*AFO, "--fill", "1e308"],
     r"--fill must be in \(0, 1\), got 1e\+308"),
    ("analyse-free-modal-is-a-directory", None, [*AFO, "--modal-toml", "{tmp}/adir"],
     r"--modal-toml .*adir: is a directory"),
    ("analyse-free-modal-empty-path", None, [*AFO, "--modal-toml", ""],
     r"--modal-toml \.: is a directory, expected a file"),
    ("analyse-free-modal-binary", _png("bin.toml"), [*AFO, "--modal-toml", "{tmp}/bin.toml"],
     r"bin\.toml: not valid TOML \(not UTF-8 text"),
    ("analyse-free-tank-toml-missing", None, [*AFO, "--tank-toml", "{tmp}/none.toml"],
     r"--tank-toml .*none\.toml: no such file"),
    ("analyse-free-tank-toml-zero-height", _text("z.toml", "[tank]\nheight = 0\n"),
     [*AFO, "--tank-toml", "{tmp}/z.toml"], r"height must be a finite positive number"),
    ("analyse-free-structure-with-positions", _modal("m.csv"),
     [*AFO, "--structure", "{tmp}/m.csv", "--tank", "5"],
     r"--channels .*ch\.toml: on --structure the stations are grid IDs: give 'ids'"),
    ("analyse-free-ids-without-structure", None,
     ["analyse", "free", "{tmp}/lab.uff", "--channels", "{tmp}/ids.toml", "--out", "{tmp}/res"],
     r"name the reference channel \('tank'\): without a structure, grid IDs"),
    ("analyse-free-ids-on-the-builtin-beam", None,
     ["analyse", "free", "{tmp}/lab.uff", "--channels", "{tmp}/ids.toml", "--builtin-beam",
      "--out", "{tmp}/res"], r"'ids' name grid IDs of your structure; give --structure"),
    ("analyse-free-structure-is-a-directory", None,
     ["analyse", "free", "{tmp}/lab.uff", "--channels", "{tmp}/ids.toml", "--structure",
      "{tmp}/adir", "--tank", "5", "--out", "{tmp}/res"], r"--structure .*adir: is a directory"),
    ("analyse-free-tank-with-a-sloshing-model", _modal("m.csv"),
     ["analyse", "free", "{tmp}/lab.uff", "--channels", "{tmp}/ids.toml", "--structure",
      "{tmp}/m.csv", "--tank", "5:frozen", "--out", "{tmp}/res"],
     r"--tank GRID:MODEL: a measured test has no sloshing model"),
    ("analyse-free-modes--1", _modal("m.csv"),
     ["analyse", "free", "{tmp}/lab.uff", "--channels", "{tmp}/ids.toml", "--structure",
      "{tmp}/m.csv", "--tank", "5", "--modes", "-1", "--out", "{tmp}/res"], r"--modes must be"),
    ("analyse-free-modes-zero", None, [*AFO, "--modes", "0"], r"--modes must be >= 1"),
    ("analyse-campaign-not-a-folder", None,
     ["analyse", "campaign", "{tmp}/lab.uff", "--channels", "{tmp}/ch.toml", "--out",
      "{tmp}/res"], r"DIRECTORY .*lab\.uff: not a folder"),
    ("analyse-campaign-no-data", _text("cdir/notes.txt", "nothing here\n"),
     ["analyse", "campaign", "{tmp}/cdir", "--channels", "{tmp}/ch.toml", "--out", "{tmp}/res"],
     r"cdir holds no data file"),
    ("analyse-campaign-manifest-kind", _text("cdir/campaign.toml",
                                             '[[test]]\nfile = "x.uff"\nkind = "sine"\n'),
     ["analyse", "campaign", "{tmp}/cdir", "--channels", "{tmp}/ch.toml", "--out", "{tmp}/res"],
     r"campaign\.toml: test 1: kind must be 'free' or 'random'"),
    ("analyse-campaign-manifest-not-toml", _text("cdir/campaign.toml", "[[test]\n"),
     ["analyse", "campaign", "{tmp}/cdir", "--channels", "{tmp}/ch.toml", "--out", "{tmp}/res"],
     r"campaign\.toml"),
    ("analyse-campaign-manifest-missing-file",
     _text("cdir/campaign.toml", '[[test]]\nfile = "gone.uff"\nkind = "free"\n'),
     ["analyse", "campaign", "{tmp}/cdir", "--channels", "{tmp}/ch.toml", "--out", "{tmp}/res"],
     r"test 1: no file .*gone\.uff"),
    ("analyse-campaign-bad-unit", None,
     ["analyse", "campaign", "{tmp}", "--channels", "{tmp}/ch.toml", "--unit", "Acc 1=furlong",
      "--out", "{tmp}/res"], r"--unit Acc 1=furlong"),
    ("analyse-example-short", None, ["analyse", "example", "{tmp}/ex", "--duration", "3"],
     r"--duration must be in \[34, 3600\] s"),
    ("analyse-example-into-a-file", None, ["analyse", "example", "{tmp}/lab.uff"],
     r"lab\.uff"),
    ("analyse-free-frequencies-negative", None, [*AFO, "--frequencies", "10,-3"],
     r"--frequencies must be positive numbers of Hz"),
    ("analyse-free-frequencies-nan", None, [*AFO, "--frequencies", "nan"],
     r"--frequencies must be positive numbers of Hz"),
    ("analyse-free-frequencies-empty", None, [*AFO, "--frequencies", ","],
     r"--frequencies must be positive numbers of Hz"),
    ("analyse-free-mode-table-without-structure", None, [*AFO, "--mode-table", "{tmp}/adir"],
     r"--mode-table places things on a --structure"),
    ("analyse-free-levels", None, [*AFO, "--levels", "0.1"], r"No such option: --levels"),
    ("analyse-free-accuracy", None, [*AFO, "--accuracy", "0.1"], r"No such option: --accuracy"),
    # -- analyse random ---------------------------------------------------------------------------
    ("analyse-random-no-out", None, AR, r"Missing option '--out'"),
    ("analyse-random-no-base-channel", None,
     ["analyse", "random", "{tmp}/lab.uff", "--channels", "{tmp}/ch.toml", "--out", "{tmp}/res"],
     r"--channels .*ch\.toml: a random test needs the 'base' channel"),
    ("analyse-random-out-is-a-file", None, [*AR, "--out", "{tmp}/afile"],
     r"afile: exists and is not a directory"),
    ("analyse-random-out-under-a-file", None, [*AR, "--out", "{tmp}/afile/res"],
     r"afile is not a directory"),
    ("analyse-random-out-name-too-long", None, [*AR, "--out", "{tmp}/" + "y" * 300],
     r"longer than 255 bytes"),
    ("analyse-random-out-is-the-second-file", _copy("{tmp}/lab.uff", "lab2.uff"),
     ["analyse", "random", "{tmp}/lab.uff", "{tmp}/lab2.uff", "--channels", "{tmp}/chb.toml",
      "--out", "{tmp}/lab2.uff"], r"lab2\.uff is also an input of this command"),
    ("analyse-random-file-is-the-table", _copy("{tmp}/lab.uff", "res/table2_damping.csv"),
     ["analyse", "random", "{tmp}/lab.uff", "{tmp}/res/table2_damping.csv", "--channels",
      "{tmp}/chb.toml", "--out", "{tmp}/res"],
     r"result file .*table2_damping\.csv is also an input"),
    ("analyse-random-channels-is-a-figure", _copy("{tmp}/chb.toml", "res/fig23_psd.png"),
     ["analyse", "random", "{tmp}/lab.uff", "--channels", "{tmp}/res/fig23_psd.png", "--out",
      "{tmp}/res"], r"fig23_psd\.png is also an input of this command"),
    ("analyse-random-channels-binary", _png("bin.toml"),
     ["analyse", "random", "{tmp}/lab.uff", "--channels", "{tmp}/bin.toml", "--out",
      "{tmp}/res"], r"--channels: .*bin\.toml: not valid TOML \(not UTF-8 text"),
    ("analyse-random-channels-not-toml", _text("bad.toml", "[channels\n"),
     ["analyse", "random", "{tmp}/lab.uff", "--channels", "{tmp}/bad.toml", "--out",
      "{tmp}/res"], r"--channels: .*bad\.toml: not valid TOML"),
    ("analyse-random-channels-empty-file", _text("empty.toml", ""),
     ["analyse", "random", "{tmp}/lab.uff", "--channels", "{tmp}/empty.toml", "--out",
      "{tmp}/res"], r"no \[channels\] table"),
    ("analyse-random-channels-is-a-directory", None,
     ["analyse", "random", "{tmp}/lab.uff", "--channels", "{tmp}/adir", "--out", "{tmp}/res"],
     r"--channels .*adir: is a directory"),
    ("analyse-random-file-twice-other-spelling", _copy("{tmp}/lab.uff", "lab2.uff"),
     ["analyse", "random", "{tmp}/lab.uff", "{tmp}/lab2.uff", "{tmp}/adir/../lab.uff",
      "--channels", "{tmp}/chb.toml", "--out", "{tmp}/res"],
     r"FILE .*adir/\.\./lab\.uff is given twice \(also as .*lab\.uff\)"),
    ("analyse-random-file-is-a-directory", None,
     ["analyse", "random", "{tmp}/lab.uff", "{tmp}/adir", "--channels", "{tmp}/chb.toml",
      "--out", "{tmp}/res"], r"FILE .*adir: is a directory"),
    ("analyse-random-levels-twice", None, [*ARO, "--levels", "0.1,0.1"],
     r"--levels '0\.1,0\.1' names a level twice: one level per file"),
    ("analyse-random-levels-0", None, [*ARO, "--levels", "0"],
     r"--levels must be RMS values in \(0, 100\) g, got '0'"),
    ("analyse-random-levels--1", None, [*ARO, "--levels", "-1"], r"--levels must be RMS values"),
    ("analyse-random-levels-nan", None, [*ARO, "--levels", "nan"],
     r"--levels must be RMS values in \(0, 100\) g, got 'nan'"),
    ("analyse-random-levels-inf", None, [*ARO, "--levels", "inf"], r"--levels must be RMS"),
    ("analyse-random-levels-1e308", None, [*ARO, "--levels", "1e308"],
     r"--levels must be RMS values in \(0, 100\) g, got '1e308'"),
    ("analyse-random-levels-empty", None, [*ARO, "--levels", ""],
     r"--levels must be RMS values in \(0, 100\) g, got ''"),
    ("analyse-random-levels-commas", None, [*ARO, "--levels", ","], r"--levels must be RMS"),
    ("analyse-random-levels-text", None, [*ARO, "--levels", "0.1;0.2"],
     r"--levels must be comma-separated numbers in g, got '0\.1;0\.2'"),
    ("analyse-random-levels-one-per-file", None, [*ARO, "--levels", "0.1,0.2"],
     r"--levels gives 2 level\(s\) for 1 file\(s\): one per file"),
    ("analyse-random-accuracy-0", None, [*ARO, "--accuracy", "0"],
     r"--accuracy must be in \(0, 1\], got 0\.0"),
    ("analyse-random-accuracy--1", None, [*ARO, "--accuracy", "-1"],
     r"--accuracy must be in \(0, 1\], got -1\.0"),
    ("analyse-random-accuracy-nan", None, [*ARO, "--accuracy", "nan"],
     r"--accuracy must be in \(0, 1\], got nan"),
    ("analyse-random-accuracy-inf", None, [*ARO, "--accuracy", "inf"],
     r"--accuracy must be in \(0, 1\], got inf"),
    ("analyse-random-accuracy-1e308", None, [*ARO, "--accuracy", "1e308"],
     r"--accuracy must be in \(0, 1\], got 1e\+308"),
    ("analyse-random-accuracy-1.5", None, [*ARO, "--accuracy", "1.5"],
     r"--accuracy must be in \(0, 1\], got 1\.5 \(a relative 1-sigma target"),
    ("analyse-random-accuracy-text", None, [*ARO, "--accuracy", "10%"],
     r"Invalid value for '--accuracy'"),
    ("analyse-random-accuracy-empty", None, [*ARO, "--accuracy", ""],
     r"Invalid value for '--accuracy'"),
    ("analyse-random-f1-nan", None, [*ARO, "--f1", "nan"], r"--f1 must be > 0 Hz, got nan"),
    ("analyse-random-f1--1", None, [*ARO, "--f1", "-1"], r"--f1 must be > 0 Hz, got -1\.0"),
    ("analyse-random-name-slash", None, [*ARO, "--name", "a/b"], r"--name 'a/b': letters"),
    ("analyse-random-fill-0", None, [*ARO, "--fill", "0"],
     r"--fill must be in \(0, 1\), got 0\.0"),
    ("analyse-random-tank-without-structure", None, [*ARO, "--tank", "5"],
     r"--tank places things on a --structure"),
    ("analyse-random-file-without-base", None, ARO,
     r"lab\.uff: no channel 'Base Z' \(the channel map names it: a random test needs the base"),
    ("analyse-random-unit-empty", None, [*ARO, "--unit", ""],
     r"--unit must look like CHANNEL=UNIT, got ''"),
    # -- units of channels: --unit and the map's [units] ------------------------------------------
    ("analyse-free-unit-no-equals", None, [*AFO, "--unit", "acc1"],
     r"--unit must look like CHANNEL=UNIT, got 'acc1'"),
    ("analyse-free-unit-no-channel", None, [*AFO, "--unit", "=g"],
     r"--unit must look like CHANNEL=UNIT, got '=g'"),
    ("analyse-free-unit-no-unit", None, [*AFO, "--unit", "Acc 1="],
     r"--unit must look like CHANNEL=UNIT, got 'Acc 1='"),
    ("analyse-free-unit-unknown", None, [*AFO, "--unit", "Acc 1=furlong"],
     r"--unit Acc 1=furlong: unknown unit 'furlong' \(use one of g, m/s\^2, mm/s\^2"),
    ("analyse-free-unit-not-acceleration", None, [*AFO, "--unit", "Acc 1=m/s"],
     r"--unit Acc 1=m/s: 'm/s' is not an acceleration unit \(use one of g, m/s\^2"),
    ("analyse-free-unit-not-a-channel", None, [*AFO, "--unit", "acc1=g"],
     r"--unit acc1=g: 'acc1' is not a channel of --channels .*ch\.toml \(its channels: "
     r"'Acc 1'"),
    ("analyse-free-unit-twice", None, [*AFO, "--unit", "Acc 1=g", "--unit", "Acc 1=m/s^2"],
     r"--unit: the key 'Acc 1' is given twice \('g' and 'm/s\^2'\); give it once"),
    ("analyse-free-unit-contradicts-the-file", None, [*AFO, "--unit", "Acc 2=g"],
     r"lab\.uff: channel 'Acc 2' is in 'm/s\^2' in the file but --unit Acc 2=g says 'g'; a "
     r"unit given is for a channel whose file has none"),
    ("analyse-free-map-unit-contradicts-the-file",
     _text("u.toml", MAP5 + '[units]\n"Acc 2" = "g"\n'),
     ["analyse", "free", "{tmp}/lab.uff", "--channels", "{tmp}/u.toml", "--out", "{tmp}/res"],
     r"lab\.uff: channel 'Acc 2' is in 'm/s\^2' in the file but the \[units\] table of "
     r"--channels .*u\.toml \(Acc 2 = 'g'\) says 'g'"),
    ("analyse-free-no-unit-in-the-file", _unitless("nounit.uff", "Acc 1"),
     ["analyse", "free", "{tmp}/nounit.uff", "--channels", "{tmp}/ch.toml", "--out",
      "{tmp}/res"],
     r"nounit\.uff: channel 'Acc 1' has no unit in the file \(UFF 58 dataset 1, ordinate unit "
     r"label empty\); give it with --unit 'Acc 1=g' \(or m/s\^2\), or in the channel map's "
     r"\[units\] table"),
    ("analyse-free-map-units-unknown", _text("u.toml", MAP5 + '[units]\n"Acc 1" = "furlong"\n'),
     ["analyse", "free", "{tmp}/lab.uff", "--channels", "{tmp}/u.toml", "--out", "{tmp}/res"],
     r"--channels: .*u\.toml: \[units\] 'Acc 1': unknown unit 'furlong' \(use one of g"),
    ("analyse-free-map-units-not-a-channel", _text("u.toml", MAP5 + '[units]\nacc9 = "g"\n'),
     ["analyse", "free", "{tmp}/lab.uff", "--channels", "{tmp}/u.toml", "--out", "{tmp}/res"],
     r"--channels: .*u\.toml: \[units\]: 'acc9' is not a channel of the map"),
    ("analyse-free-map-units-not-a-table", _text("u.toml", 'units = "g"\n' + MAP5),
     ["analyse", "free", "{tmp}/lab.uff", "--channels", "{tmp}/u.toml", "--out", "{tmp}/res"],
     r"--channels: .*u\.toml: \[units\] must be a table of channel = unit"),
    ("analyse-free-map-units-a-number", _text("u.toml", MAP5 + '[units]\n"Acc 1" = 9.81\n'),
     ["analyse", "free", "{tmp}/lab.uff", "--channels", "{tmp}/u.toml", "--out", "{tmp}/res"],
     r"\[units\] 'Acc 1': 9\.81 is not a unit"),
    # -- a campaign's map on a file that lacks its channels ---------------------------------------
    ("analyse-free-file-without-the-tank",
     _text("tip.toml", MAP5.replace("[channels]\n", '[channels]\ntank = "Tip Z"\n')),
     ["analyse", "free", "{tmp}/lab.uff", "--channels", "{tmp}/tip.toml", "--out", "{tmp}/res"],
     r"lab\.uff: no channel 'Tip Z' \(the channel map names it: the tank channel"),
    ("analyse-free-file-with-too-few-stations",
     _text("few.toml", MAP5.replace('"Acc 2", "Acc 3", "Acc 4"', '"Acc 7", "Acc 8", "Acc 9"')),
     ["analyse", "free", "{tmp}/lab.uff", "--channels", "{tmp}/few.toml", "--builtin-beam",
      "--out", "{tmp}/res"],
     r"lab\.uff: no channel 'Acc 7', 'Acc 8', 'Acc 9' \(the channel map names them; 2 "
     r"station\(s\) are left, and the modal filter needs at least 3 for the 3 modes"),
    # -- compare ----------------------------------------------------------------------------------
    ("compare-no-out", None, CMP, r"Missing option '--out'"),
    ("compare-no-prediction", None, ["compare", "{tmp}/free_m.nc", "--out", "{tmp}/cmp"],
     r"Missing argument 'PREDICTED"),
    ("compare-no-arguments", None, ["compare", "--out", "{tmp}/cmp"],
     r"Missing argument 'MEASURED'"),
    ("compare-out-is-a-file", None, [*CMP, "--out", "{tmp}/afile"],
     r"--out .*afile: exists and is not a directory"),
    ("compare-out-under-a-file", None, [*CMP, "--out", "{tmp}/afile/cmp"],
     r"afile is not a directory"),
    ("compare-out-name-too-long", None, [*CMP, "--out", "{tmp}/" + "y" * 300],
     r"--out .*longer than 255 bytes"),
    ("compare-out-is-the-measured", None, [*CMP, "--out", "{tmp}/free_m.nc"],
     r"free_m\.nc is also an input of this command"),
    ("compare-out-is-the-prediction-other-spelling", None,
     [*CMP, "--out", "{tmp}/adir/../free_p.nc"], r"free_p\.nc is also an input of this command"),
    ("compare-measured-is-the-table", _copy("{tmp}/free_m.nc", "cmp/comparison.csv"),
     ["compare", "{tmp}/cmp/comparison.csv", "{tmp}/free_p.nc", "--out", "{tmp}/cmp"],
     r"--out .*cmp: the command writes .*comparison\.csv, and .*comparison\.csv is also an "
     r"input"),
    ("compare-prediction-is-the-figure", _copy("{tmp}/free_p.nc", "cmp/fig21_comparison.png"),
     ["compare", "{tmp}/free_m.nc", "{tmp}/cmp/fig21_comparison.png", "--out", "{tmp}/cmp"],
     r"the command writes .*fig21_comparison\.png, and .*fig21_comparison\.png is also an "
     r"input"),
    ("compare-result-is-a-directory", lambda tmp: (tmp / "cmp/analyses.md").mkdir(parents=True),
     CMPO, r"analyses\.md: is a directory"),
    ("compare-measured-empty-path", None,
     ["compare", "", "{tmp}/free_p.nc", "--out", "{tmp}/cmp"],
     r"beam result \.: is a directory, expected a file"),
    ("compare-measured-is-a-directory", None,
     ["compare", "{tmp}/adir", "{tmp}/free_p.nc", "--out", "{tmp}/cmp"],
     r"beam result .*adir: is a directory"),
    ("compare-measured-missing", None,
     ["compare", "{tmp}/none.nc", "{tmp}/free_p.nc", "--out", "{tmp}/cmp"],
     r"beam result .*none\.nc: no such file"),
    ("compare-prediction-under-a-file", None,
     ["compare", "{tmp}/free_m.nc", "{tmp}/afile/p.nc", "--out", "{tmp}/cmp"],
     r"beam result .*afile/p\.nc: cannot be read \(Not a directory\)"),
    ("compare-prediction-name-too-long", None,
     ["compare", "{tmp}/free_m.nc", "{tmp}/" + TOO_LONG, "--out", "{tmp}/cmp"],
     r"beam result .*y\.nc: .*(too long|longer than 255)"),
    ("compare-prediction-fifo", _fifo("fifo.nc"),
     ["compare", "{tmp}/free_m.nc", "{tmp}/fifo.nc", "--out", "{tmp}/cmp"],
     r"beam result .*fifo\.nc: is a named pipe \(FIFO\)"),
    ("compare-same-file-other-spelling", None,
     ["compare", "{tmp}/free_m.nc", "{tmp}/adir/../free_m.nc", "--out", "{tmp}/cmp"],
     r"the same file is given twice"),
    ("compare-prediction-is-text", None,
     ["compare", "{tmp}/free_m.nc", "{tmp}/t.toml", "--out", "{tmp}/cmp"],
     r"t\.toml: not a readable NetCDF beam result"),
    ("compare-prediction-is-binary", _png("bin.nc"),
     ["compare", "{tmp}/free_m.nc", "{tmp}/bin.nc", "--out", "{tmp}/cmp"],
     r"bin\.nc: not a readable NetCDF beam result"),
    ("compare-prediction-is-a-record", None,
     ["compare", "{tmp}/free_m.nc", "{tmp}/good.nc", "--out", "{tmp}/cmp"],
     r"good\.nc: not a beam test result: attribute 'test' is None"),
    ("compare-prediction-is-the-lab-file", None,
     ["compare", "{tmp}/free_m.nc", "{tmp}/lab.uff", "--out", "{tmp}/cmp"],
     r"lab\.uff: not a readable NetCDF beam result"),
    ("compare-prediction-f1-nan", _result("f1.nc", f1_Hz=float("nan")),
     ["compare", "{tmp}/free_m.nc", "{tmp}/f1.nc", "--out", "{tmp}/cmp"],
     r"f1\.nc: attribute 'f1_Hz' must be a finite positive number in Hz, got nan"),
    ("compare-prediction-f1--1", _result("f1.nc", f1_Hz=-1.0),
     ["compare", "{tmp}/free_m.nc", "{tmp}/f1.nc", "--out", "{tmp}/cmp"],
     r"f1\.nc: attribute 'f1_Hz' must be a finite positive number in Hz, got -1\.0"),
    ("compare-prediction-f1-text", _result("f1.nc", f1_Hz="ten"),
     ["compare", "{tmp}/free_m.nc", "{tmp}/f1.nc", "--out", "{tmp}/cmp"],
     r"f1\.nc: attribute 'f1_Hz' must be a finite positive number in Hz, got 'ten'"),
    ("compare-prediction-f1-1e308", _result("f1.nc", f1_Hz=1e308),
     ["compare", "{tmp}/free_m.nc", "{tmp}/f1.nc", "--out", "{tmp}/cmp"],
     r"f1\.nc: the first beam mode \(1e\+308 Hz\) is too high for the 500 Hz results"),
    ("compare-measured-fs-0", _result("fs.nc", fs=0.0, case="measured"),
     ["compare", "{tmp}/fs.nc", "{tmp}/free_p.nc", "--out", "{tmp}/cmp"],
     r"fs\.nc: attribute 'fs' must be a finite positive number in Hz, got 0\.0"),
    ("compare-measured-fs-inf", _result("fs.nc", fs=float("inf"), case="measured"),
     ["compare", "{tmp}/fs.nc", "{tmp}/free_p.nc", "--out", "{tmp}/cmp"],
     r"fs\.nc: attribute 'fs' must be a finite positive number in Hz, got inf"),
    ("compare-prediction-nan-signal", _result("nan.nc", nan="tank_acceleration"),
     ["compare", "{tmp}/free_m.nc", "{tmp}/nan.nc", "--out", "{tmp}/cmp"],
     r"nan\.nc: variable 'tank_acceleration' contains NaN/inf"),
    ("compare-prediction-without-f1", _result("old.nc", test="free", f1_Hz=None),
     ["compare", "{tmp}/free_m.nc", "{tmp}/old.nc", "--out", "{tmp}/cmp"],
     r"old\.nc: .*f1_Hz"),
    ("compare-prediction-same-case", _result("twin.nc", case="measured"),
     ["compare", "{tmp}/free_m.nc", "{tmp}/twin.nc", "--out", "{tmp}/cmp"],
     r"free_m\.nc and .*twin\.nc both have the case name 'measured' \(the tables would mix "
     r"them\): rename one with --name OLD=NEW"),
    ("compare-prediction-other-kind", _result("rnd.nc", test="random"),
     ["compare", "{tmp}/free_m.nc", "{tmp}/rnd.nc", "--out", "{tmp}/cmp"],
     r"rnd\.nc: a random-test result needs a 'level' dimension"),
    ("compare-prediction-of-another-structure", _result("f25.nc", f1_Hz=25.4),
     ["compare", "{tmp}/free_m.nc", "{tmp}/f25.nc", "--out", "{tmp}/cmp"],
     r"f25\.nc predicts a structure whose first mode is at 25\.4 Hz, the measurement "
     r".*free_m\.nc has it at 10\.19 Hz \(\+149 %, beyond the 15 % of one structure\)"),
    ("compare-prediction-fs-not-its-time-axis", _result("fs2.nc", fs=1000.0),
     ["compare", "{tmp}/free_m.nc", "{tmp}/fs2.nc", "--out", "{tmp}/cmp"],
     r"fs2\.nc: attribute 'fs' says 1000 Hz but the time axis is sampled at 500 Hz"),
    ("compare-prediction-random-labelled-free", _reshaped("rf.nc", "levels"),
     ["compare", "{tmp}/free_m.nc", "{tmp}/rf.nc", "--out", "{tmp}/cmp"],
     r"rf\.nc: attribute 'test' says 'free', but the file holds a random test, not a free "
     r"decay: its signals have a 'level' dimension \(2 RMS base level\(s\)\)"),
    ("compare-measured-two-stations-three-modes", _reshaped("two.nc", "two"),
     ["compare", "{tmp}/two.nc", "{tmp}/free_p.nc", "--out", "{tmp}/cmp"],
     r"two\.nc: 2 station\(s\) for 3 modes: modal filtering separates at most as many "
     r"modes as there are stations"),
    ("compare-name-no-new", None, [*CMPO, "--name", "frozen="],
     r"--name must look like OLD=NEW, got 'frozen='"),
    ("compare-name-no-old", None, [*CMPO, "--name", "=rig"],
     r"--name must look like OLD=NEW, got '=rig'"),
    ("compare-name-no-equals", None, [*CMPO, "--name", "frozen"],
     r"--name must look like OLD=NEW, got 'frozen'"),
    ("compare-name-slash", None, [*CMPO, "--name", "frozen=a/b"],
     r"--name frozen=a/b: a case name has letters, digits, '-', '_' and '\.' only"),
    ("compare-name-space", None, [*CMPO, "--name", "frozen=a b"],
     r"--name frozen=a b: a case name has letters"),
    ("compare-name-twice", None, [*CMPO, "--name", "frozen=a", "--name", "frozen=b"],
     r"--name: the key 'frozen' is given twice \('a' and 'b'\); give it once"),
    ("compare-name-not-a-case", None, [*CMPO, "--name", "rom=a"],
     r"--name rom=a: no input has the case 'rom' \(their cases: 'measured', 'frozen'\)"),
    ("compare-name-clashes", None, [*CMPO, "--name", "frozen=measured"],
     r"free_m\.nc and .*free_p\.nc both have the case name 'measured'"),

    # == the new surfaces of the last round (issue 55) =========================================
    # -- rig play: a drive file that is not UTF-8 text was a UnicodeDecodeError ----------------
    ("play-drive-binary", _png("png.csv"),
     ["rig", "play", "{tmp}/png.csv", "--out", "{tmp}/p.nc"],
     r"png\.csv: binary data \(NUL bytes.*not a text CSV file: a drive file is plain text"),
    ("play-drive-utf16", _bytes("u16.csv", "time_s,acceleration_m_s2\n0,0\n0.001,0\n"
                                .encode("utf-16")),
     ["rig", "play", "{tmp}/u16.csv", "--out", "{tmp}/p.nc"],
     r"u16\.csv: UTF-16 text, not a text CSV file"),
    ("play-drive-latin1-before-header",
     _bytes("lat.csv", "Messung Düse 3\ntime_s,acceleration_m_s2\n0,0\n0.001,0\n"
            .encode("latin-1")),
     ["rig", "play", "{tmp}/lat.csv", "--out", "{tmp}/p.nc"],
     r"lat\.csv: line 1 is not UTF-8 text \(byte 0xfc at column 10\)"),
    ("play-drive-latin1-after-header",
     _bytes("lat2.csv", "time_s,acceleration_m_s2\n0,0\n# Düse\n0.001,0\n"
            .encode("latin-1")),
     ["rig", "play", "{tmp}/lat2.csv", "--out", "{tmp}/p.nc"],
     r"lat2\.csv: line 3 is not UTF-8 text \(byte 0xfc at column 4\)"),
    # ... and a jump in time was reported where its drift crossed the tolerance (line 3),
    # printed as np.float64(...)
    ("play-drive-time-jump-at-its-line", _drive_jump("jump.csv"),
     ["rig", "play", "{tmp}/jump.csv", "--out", "{tmp}/p.nc"],
     r"jump\.csv: line 5002: time 2\.5003 s follows 2\.4995 s after 0\.0008 s, but the "
     r"file's step is 0\.0005 s: a drive file needs a uniform time column$"),
    # -- train / predict --history N at the record's length - 1 --------------------------------
    # (train: NumPy's "too small to calculate a numerical gradient" from the cycle-energy loss)
    ("train-history-length-1", None, [*TRO, "--history", "1499"],
     r"--history must be in \[0, 1498\], got 1499 \(samples of the validation record "
     r".*good\.nc \(1500\), leaving 2 to score\)"),
    ("train-history-leaves-no-cycle", None, [*TRO, "--history", "1497"],
     r"--history 1497: the 3 sample\(s\) of the validation record after it hold no whole "
     r"input cycle for the cycle-energy term; take fewer samples of history"),
    # (predict: "a record needs at least 2 samples, got 1", which never named --history)
    ("predict-history-length-1", None,
     [*P, "--data", "{tmp}/good.nc", "--out", "{tmp}/p.nc", "--history", "1499"],
     r"--history must be in \[0, 1498\], got 1499 \(samples of .*good\.nc \(1500\), "
     r"leaving 2 to predict\)"),
    # -- a folder that holds files the command did not write: refused, named ---------------
    ("design-into-a-folder-with-the-users-train-csv",
     _all(_text("lab/train.csv", "time [s],velocity [m/s]\n0,0\n0.002,0.1\n"),
          _text("tiny.toml", TINY_DESIGN_TOML)),
     ["design", "--out", "{tmp}/lab", "--config", "{tmp}/tiny.toml", "--split", "train"],
     r"--out .*lab: holds train\.csv, which sloshrom design did not write \(or that changed "
     r"since\): refusing to replace it \(--overwrite replaces it; or choose another folder\)"),
    ("example-into-a-laboratorys-folder",
     _all(_text("lab/decay.uff", "a laboratory's real decay\n"),
          _text("lab/channels.toml", "[channels]\nstations = [\"Acc 1\"]\n")),
     ["analyse", "example", "{tmp}/lab", "--duration", "34"],
     r"DIRECTORY .*lab: holds decay\.uff, channels\.toml, which sloshrom analyse example did "
     r"not write \(or that changed since\): refusing to replace them \(--overwrite"),
    ("system-into-a-folder-with-the-users-train-nc", _text("bw/train.nc", "my own record\n"),
     ["system", "bouc-wen", "--out", "{tmp}/bw"],
     r"--out .*bw: holds train\.nc, which sloshrom system did not write \(or that changed "
     r"since\): refusing to replace it"),
    # -- a given mode read from noise ------------------------------------------------------------
    ("analyse-free-f1-in-the-noise",
     None, ["analyse", "free", "{tmp}/noisy.uff", "--channels", "{tmp}/ch.toml", "--out",
            "{tmp}/res", "--f1", "20"],
     r"the mode given at 20 Hz is not a resonance of the data: the tank channel's spectrum "
     r"has no peak in 13-27 Hz, the band its analyses filter, that stands 10 dB above its "
     r"surroundings and above the spectrum's noise floor .*strongest peak is at 10\.\d+ Hz"),
    # -- a file without time axis said in a laboratory's words, not read_record's fs= --------
    ("analyse-free-csv-without-time", _text("notime.csv", "Acc 5 [g]\n0.1\n0.2\n0.1\n"),
     ["analyse", "free", "{tmp}/notime.csv", "--channels", "{tmp}/ch.toml", "--out",
      "{tmp}/res"],
     r"notime\.csv: no time axis: a test's file needs a 'time' column"),
    ("analyse-campaign-design-drives-only", _design_drive("dr", uff=True),
     ["analyse", "campaign", "{tmp}/dr", "--channels", "{tmp}/ch.toml", "--out", "{tmp}/res"],
     r"dr holds no data file"),
    # -- a campaign is its folder --------------------------------------------------------------
    ("analyse-campaign-manifest-outside-the-folder",
     _all(_text("cdir/campaign.toml", '[[test]]\nfile = "../ch.toml"\nkind = "free"\n'),
          _text("cdir/a.uff", "x\n")),
     ["analyse", "campaign", "{tmp}/cdir", "--channels", "{tmp}/ch.toml", "--out", "{tmp}/res"],
     r"campaign\.toml: test 1: file '\.\./ch\.toml' is outside the campaign folder .*cdir: "
     r"name its files relative to it, without '\.\.'"),
    ("analyse-campaign-manifest-absolute-path",
     _text("cdir/campaign.toml", '[[test]]\nfile = "/etc/passwd"\nkind = "free"\n'),
     ["analyse", "campaign", "{tmp}/cdir", "--channels", "{tmp}/ch.toml", "--out", "{tmp}/res"],
     r"campaign\.toml: test 1: file '/etc/passwd' is outside the campaign folder"),
]


@pytest.fixture(scope="module")
def world(tmp_path_factory) -> Path:
    """What every case reads (``_world``), written once; each case gets its own copy."""
    d = tmp_path_factory.mktemp("world")
    _world(d)
    return d


@pytest.mark.parametrize(("setup", "argv", "match"), [c[1:] for c in HOSTILE_CASES],
                         ids=[c[0] for c in HOSTILE_CASES])
def test_hostile_cli_rejects(tmp_path, world, model_files, setup, argv, match):
    def both(tmp: Path) -> None:
        shutil.copytree(world, tmp, dirs_exist_ok=True)
        if getattr(setup, "wants_models", False):
            setup(tmp, model_files)
        elif setup is not None:
            setup(tmp)

    check_cli(tmp_path, model_files, both, argv, match)


def test_case_ids_are_unique():
    ids = [c[0] for c in HOSTILE_CASES]
    assert len(ids) == len(set(ids))


def test_case_count():
    """docs/interchange.md quotes this suite's case count; keep them in step."""
    want = f"**{len(HOSTILE_CASES)} cases** in `tests/test_hostile_cli.py`"
    doc = Path(__file__).resolve().parents[1] / "docs" / "interchange.md"
    assert want in doc.read_text(), f"docs/interchange.md must say '{want}'"


# -- beyond single cases ---------------------------------------------------------------------------
def test_reproduce_protects_everything_its_stages_write():
    """RESULT_ENTRIES (what `reproduce` refuses an input in) names every top-level file or
    directory the pipeline's sources write under the output directory."""
    import re

    import sloshrom.pipeline as pipeline
    from sloshrom.pipeline.chain import RESULT_ENTRIES

    names = set()
    for src in Path(pipeline.__file__).parent.glob("*.py"):
        text = src.read_text()
        names |= set(re.findall(r'(?:ctx\.path\(|ctx\.out\) / |ctx\.out / )"([^"/]+)', text))
        names |= {v.split("/")[0] for v in re.findall(r'^[A-Z_]+ = "([\w.]+/[\w./]+)"', text,
                                                      flags=re.M)}
    names |= {".stages"}  # sloshrom.pipeline.cache.StageCache
    assert names, "no output paths found in the pipeline's sources"
    listed = {e.rstrip("/") for e in RESULT_ENTRIES}
    assert names <= listed, sorted(names - listed)


def test_failed_batch_leaves_no_directory(tmp_path):
    """A batch that fails removes the directories it created (no empty result folder)."""
    from sloshrom.fileio import OutputBatch

    with pytest.raises(OSError), OutputBatch() as batch:
        batch.write_text(tmp_path / "res" / "sub" / "a.txt", "a")
        raise OSError("disk full")
    assert not (tmp_path / "res").exists()
    (tmp_path / "keep").mkdir()
    with pytest.raises(OSError), OutputBatch() as batch:
        batch.write_text(tmp_path / "keep" / "a.txt", "a")
        raise OSError("disk full")
    assert (tmp_path / "keep").is_dir()  # it was there before the batch: left alone
def test_late_failure_leaves_no_partial_results(tmp_path, monkeypatch):
    """A failure after the simulations (here: the third figure) leaves no result file at all."""
    import sloshrom.cli.beam as beam

    real = beam.savefig
    calls = []

    def flaky(fig, path, batch=None):
        calls.append(path)
        if len(calls) == 3:
            raise OSError("disk full")
        real(fig, path, batch)

    monkeypatch.setattr(beam, "savefig", flaky)
    out = tmp_path / "res"
    res = runner.invoke(app, ["beam", "free", "--sloshing", "frozen", "--duration", "2",
                              "--out", str(out)])
    assert res.exit_code != 0 and len(calls) == 3
    assert not [p for p in tmp_path.rglob("*") if p.is_file()], "partial results left behind"
    assert not out.exists(), "an empty result folder left behind"


def test_warnings_are_one_line_each(capsys):
    """Our warnings: one yellow line; third-party deprecations: silenced; others: with origin."""
    from sloshrom.cli._app import route_warnings
    from sloshrom.rom.errors import EnvelopeWarning

    with route_warnings():
        for _ in range(2):  # the same warning twice: shown once
            warnings.warn_explicit("input outside the training envelope\n  by 3 %",
                                   EnvelopeWarning, "/x/src/sloshrom/rom.py", 10,
                                   module="sloshrom.rom.tdnn.estimators")
        warnings.warn_explicit("old API", FutureWarning,
                               "/v/lib/python3.11/site-packages/xarray/core.py", 1,
                               module="xarray.core")
        warnings.warn_explicit("old API", DeprecationWarning,
                               "/v/lib/python3.11/site-packages/jax/_src/x.py", 1,
                               module="jax._src.x")
        warnings.warn_explicit("overflow encountered in exp", RuntimeWarning,
                               "/v/lib/python3.11/site-packages/numpy/core.py", 1,
                               module="numpy.core")
    err = capsys.readouterr().err.splitlines()
    assert err == ["warning: input outside the training envelope by 3 %",
                   "warning: overflow encountered in exp (RuntimeWarning from numpy)"], err


def test_the_cli_catches_the_one_base_and_no_bare_value_error():
    """The CLI catches SloshromError, the base of every room's errors, never a bare ValueError
    (a bug keeps its traceback), and no longer assembles a tuple of types."""
    import inspect

    import sloshrom.cli._app
    import sloshrom.cli.beam
    import sloshrom.cli.export
    import sloshrom.cli.pipeline
    import sloshrom.cli.rig
    import sloshrom.cli.rom  # noqa: F401
    from sloshrom.errors import SloshromError
    from sloshrom.rom.errors import ROMError, UnstableModelError

    # an unstable NOE on the user's input is a property of their model: a user error too
    assert issubclass(UnstableModelError, ROMError) and issubclass(ROMError, SloshromError)
    for mod in ("_app", "beam", "export", "pipeline", "rig", "rom"):
        src = inspect.getsource(__import__(f"sloshrom.cli.{mod}", fromlist=["x"]))
        assert "except ValueError as" not in src and "(ValueError," not in src, mod
        assert "user_errors" not in src and "sys.modules" not in src, mod


def test_a_sloshrom_error_from_deep_inside_is_one_line():
    """A SloshromError no command caught (here: from a room, two calls down) ends as one
    ``error:`` line with exit code 2; a plain ValueError (a bug) keeps its traceback."""
    import typer

    from sloshrom.cli._app import _OneLineErrors
    from sloshrom.rig.errors import RigError

    assert app.info.cls is _OneLineErrors  # the real root group is the one tested here
    t = typer.Typer(cls=_OneLineErrors)

    def deep(exc: Exception) -> None:
        raise exc

    @t.command()
    def user() -> None:
        deep(RigError("dt must be a positive step in s,\n  got -1"))

    @t.command()
    def bug() -> None:
        deep(ValueError("an internal invariant broke"))

    res = runner.invoke(t, ["user"])
    assert res.exit_code == 2, res.output
    assert res.exception is None or isinstance(res.exception, SystemExit), repr(res.exception)
    assert res.output.splitlines() == ["error: dt must be a positive step in s, got -1"]
    res = runner.invoke(t, ["bug"])
    assert type(res.exception) is ValueError and res.exit_code == 1


def test_bad_config_fails_in_the_library():
    """settings.validate is the library's check: pipeline.run callers get it too."""
    from sloshrom.config import ConfigError
    from sloshrom.pipeline import settings

    cfg = settings.defaults()
    settings.validate(cfg)
    cfg["beam"]["rms_g"] = []
    with pytest.raises(ConfigError, match=r"'beam\.rms_g' must be a non-empty list"):
        settings.validate(cfg)


# -- the new surfaces of the last round (issue 55), beyond single refusals -----------------------
def test_rig_play_plays_the_uff_that_design_writes(tmp_path):
    """`rig play` on design's UFF 58 read it as a CSV ("columns ['-1']: expected a time
    column"): it plays its segments back to back, as the CSV of the same programme."""
    from sloshrom.io import read_record

    _design_drive("lab", uff=True)(tmp_path)
    for name in ("train.csv", "train.uff"):
        res = runner.invoke(app, ["rig", "play", str(tmp_path / "lab" / name), "--out",
                                  str(tmp_path / f"{name}.nc"), "--no-truth"])
        assert res.exit_code == 0, res.output
    csv, uff = (read_record(tmp_path / f"train.{s}.nc") for s in ("csv", "uff"))
    assert len(csv) == len(uff) and uff.duration == pytest.approx(2.0, abs=2e-3)
    assert uff.attrs["provenance"]["signal"]["file_fs"] == 2000.0
    # the UFF holds 12 significant digits, the CSV 10: the same drive, the same rig noise
    peak = np.max(np.abs(csv["force"]))
    assert np.max(np.abs(uff["force"] - csv["force"])) <= 1e-6 * peak


def test_rig_play_help_states_the_rate_rule_it_applies(tmp_path):
    """The help said a rate that is not a whole number of Hz is refused, and 2000.5 Hz was
    accepted (and resampled correctly): the help now states the rule the resampler applies,
    and its own examples behave as it says."""
    from sloshrom.io.programme import MAX_DENOMINATOR, write_drive_csv

    res = runner.invoke(app, ["rig", "play", "--help"], terminal_width=200)
    help_text = " ".join(res.output.split())
    assert f"a fraction with a denominator up to {MAX_DENOMINATOR:,}" in help_text
    assert "2000.5 Hz is too, 2000.3 Hz is not" in help_text
    for fs, ok in ((2000.5, True), (2000.3, False)):
        t = np.arange(int(fs) + 1) / fs
        p = write_drive_csv(tmp_path / f"{fs}.csv", np.sin(2 * np.pi * 12 * t) *
                            np.sin(np.pi * t / t[-1]) ** 2, fs)
        res = runner.invoke(app, ["rig", "play", str(p), "--out", str(tmp_path / f"{fs}.nc"),
                                  "--no-truth"])
        assert (res.exit_code == 0) == ok, res.output
        if not ok:
            assert f"no fraction with a denominator up to {MAX_DENOMINATOR:,}" in res.output
            assert not (tmp_path / f"{fs}.nc").exists()


def test_a_campaign_leaves_out_the_drives_design_wrote_beside_its_tests(world, tmp_path):
    """`analyse campaign` on a folder where `design` also wrote read train.csv as a test ("pass
    fs= (Hz)"): a drive file is a shaker's command, left out with a note."""
    from sloshrom.beam.lab.campaign import campaign_tests
    from sloshrom.beam.lab.channels import ChannelMap
    from sloshrom.errors import Note

    shutil.copyfile(world / "lab.uff", tmp_path / "decay.uff")
    _design_drive(".", uff=True)(tmp_path)
    with pytest.warns(Note, match=r"train\.csv, train\.uff: drive file\(s\) of a shaker "
                                  r"programme \(`sloshrom design`\), not measured tests: left out"):
        tests = campaign_tests(tmp_path, ChannelMap.from_toml(world / "ch.toml"))
    assert [(t.kind, [p.name for p in t.files]) for t in tests] == [("free", ["decay.uff"])]


def test_analyse_example_replaces_its_own_files_and_no_others(tmp_path):
    """`analyse example DIR` replaced a laboratory's decay.uff and channels.toml without a word
    (refused now: test_hostile_cli_rejects); its own files of an earlier run it replaces, an
    edited one it refuses by name, and --overwrite replaces it."""
    d = tmp_path / "ex"
    argv = ["analyse", "example", str(d), "--duration", "34"]
    assert runner.invoke(app, argv).exit_code == 0
    res = runner.invoke(app, argv)
    assert res.exit_code == 0, res.output
    (d / "channels.toml").write_text((d / "channels.toml").read_text() + "# edited\n")
    res = runner.invoke(app, argv)
    assert res.exit_code == 2 and "holds channels.toml, which sloshrom analyse example did " \
        "not write" in " ".join(res.output.split()), res.output
    assert (d / "channels.toml").read_text().endswith("# edited\n")
    res = runner.invoke(app, [*argv, "--overwrite"])
    assert res.exit_code == 0, res.output
    assert not (d / "channels.toml").read_text().endswith("# edited\n")
