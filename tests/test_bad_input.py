"""Bad-input suite: every reader and every command, fed what users actually feed them.

Each case must give ONE clear error naming the problem: a ``RecordError``/``ConfigError``/
``ModelFileError`` (all ``ValueError``) from the Python API; from the CLI an ``error: ...`` line,
exit code != 0, no Python traceback, and no (half-)written output file. The number of cases is
quoted in docs/interchange.md (``pytest --collect-only -q tests/test_bad_input.py``).
"""

from __future__ import annotations

import re
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest

from helpers import check_cli, good_record
from sloshrom.config import ConfigError
from sloshrom.io import Record, RecordError, preprocess, read_record, write_record

FS = 100.0
N = 200


def _csv(tmp: Path, header: str, rows: list[str], name: str = "r.csv") -> Path:
    p = tmp / name
    p.write_text("\n".join([header, *rows]) + "\n")
    return p


def _good_rows(n: int = 20) -> list[str]:
    return [f"{k / FS!r},{np.sin(k / 3):.6f},{np.cos(k / 5):.6f}" for k in range(n)]


def _written(tmp: Path, suffix: str) -> Path:
    if suffix in (".uff", ".unv"):
        from sloshrom.io.uff import write_uff58

        return write_uff58(good_record(), tmp / f"good{suffix}")
    return write_record(good_record(), tmp / f"good{suffix}")


def _truncated(suffix: str, keep: float = 0.5) -> Callable[[Path], Path]:
    def make(tmp: Path) -> Path:
        p = _written(tmp, suffix)
        data = p.read_bytes()
        p.write_bytes(data[: int(len(data) * keep)])
        return p

    return make


def _empty(suffix: str) -> Callable[[Path], Path]:
    def make(tmp: Path) -> Path:
        p = tmp / f"empty{suffix}"
        p.write_bytes(b"")
        return p

    return make


def _mat73(tmp: Path) -> Path:
    """A MATLAB v7.3 (HDF5) file, cut in half."""
    import h5py

    p = tmp / "r73.mat"
    with h5py.File(p, "w") as fh:
        fh["time"] = (np.arange(N) / FS)[None, :]
        fh["acceleration"] = np.ones((1, N))
    data = p.read_bytes()
    p.write_bytes(data[: len(data) // 3])
    return p


def _nc_with(tmp: Path, edit: Callable) -> Path:
    ds = good_record().to_dataset()
    ds = edit(ds)
    p = tmp / "edited.nc"
    ds.to_netcdf(p, engine="h5netcdf")
    return p


def _mat_with(tmp: Path, **items) -> Path:
    import scipy.io

    p = tmp / "edited.mat"
    rec = good_record()
    out = {"time": rec.time, "acceleration": rec["acceleration"], "force": rec["force"],
           "units": {"acceleration": "m/s^2", "force": "N"}, **items}
    scipy.io.savemat(p, out)
    return p


def _uff_rates(tmp: Path) -> Path:
    import pyuff

    from sloshrom.io.uff import write_uff58

    a = write_uff58(good_record(), tmp / "a.uff")
    t = np.arange(N) / (2 * FS)
    b = write_uff58(Record(t, 2 * FS, {"force": np.ones(N)}, {"force": "N"}), tmp / "b.uff")
    sets = [s for s in pyuff.UFF(str(a)).read_sets() if s["type"] == 58][:1]
    sets += [s for s in pyuff.UFF(str(b)).read_sets() if s["type"] == 58]
    for s in sets:
        s.setdefault("func_id", 0)
        for k in ("abscissa_axis_lab", "ordinate_axis_lab", "orddenom_axis_lab",
                  "z_axis_axis_lab"):
            s[k] = s.get(k) or ""
    p = tmp / "rates.uff"
    pyuff.UFF(str(p)).write_sets(sets, mode="overwrite")
    return p


def _nan_in(ds, value=np.nan):
    ds["force"].values[17] = value
    return ds


# (id, build(tmp) -> path, read_record kwargs, regex the message must match)
READER_CASES = [
    ("empty-nc", _empty(".nc"), {}, r"empty\.nc: file is empty"),
    ("empty-csv", _empty(".csv"), {}, r"empty\.csv: file is empty"),
    ("empty-mat", _empty(".mat"), {}, r"empty\.mat: file is empty"),
    ("empty-uff", _empty(".uff"), {}, r"empty\.uff: file is empty"),
    ("missing-file", lambda tmp: tmp / "nope.nc", {}, r"nope\.nc: no such file"),
    ("unknown-suffix", lambda tmp: _csv(tmp, "a", ["1"], name="r.xlsx"), {},
     r"unknown record format '\.xlsx'"),
    ("truncated-nc", _truncated(".nc"), {}, r"good\.nc: not a readable NetCDF file"),
    ("truncated-nc-header", _truncated(".nc", 0.02), {}, r"good\.nc: not a readable NetCDF"),
    ("truncated-mat5", _truncated(".mat"), {}, r"good\.mat: not a readable MAT file"),
    ("truncated-mat73", _mat73, {}, r"r73\.mat: not a readable MAT"),
    ("truncated-uff", _truncated(".uff"), {}, r"good\.uff: truncated or not a UFF file"),
    ("csv-truncated-row", lambda tmp: _csv(tmp, "time [s],acceleration [g],force [N]",
                                           [*_good_rows(), "0.2,0.1"]), {},
     r"bad data row \(data row 21 has 2 fields"),
    ("csv-nan", lambda tmp: _csv(tmp, "time [s],acceleration [g],force [N]",
                                 [*_good_rows(), "0.2,nan,1"]), {},
     r"'acceleration' contains NaN/inf \(first at sample 20"),
    ("csv-inf", lambda tmp: _csv(tmp, "time [s],acceleration [g],force [N]",
                                 [*_good_rows(), "0.2,1,inf"]), {},
     r"'force' contains NaN/inf \(first at sample 20"),
    ("nc-nan", lambda tmp: _nc_with(tmp, _nan_in), {}, r"'force' contains NaN/inf"),
    ("nc-inf", lambda tmp: _nc_with(tmp, lambda ds: _nan_in(ds, -np.inf)), {},
     r"'force' contains NaN/inf \(first at sample 17"),
    ("mat-nan", lambda tmp: _mat_with(tmp, force=np.r_[np.ones(N - 1), np.nan]), {},
     r"'force' contains NaN/inf \(first at sample 199"),
    ("csv-missing-unit", lambda tmp: _csv(tmp, "time [s],acceleration,force [N]",
                                          _good_rows()), {},
     r"'acceleration' has no unit in the file \(no \[unit\] in the CSV header\); give it "
     r"with units="),
    ("nc-missing-unit", lambda tmp: _nc_with(
        tmp, lambda ds: ds.assign(force=ds["force"].copy(data=ds["force"].values).drop_attrs())),
     {}, r"variable 'force' has no unit in the file \(no 'units' attribute\)"),
    ("csv-time-unit-wrong", lambda tmp: _csv(tmp, "time [m],acceleration [g],force [N]",
                                             _good_rows()), {},
     r"time unit 'm' is not a time unit"),
    ("csv-non-monotonic", lambda tmp: _csv(tmp, "time [s],acceleration [g],force [N]",
                                           [*_good_rows()[:5], _good_rows()[6],
                                            _good_rows()[5], *_good_rows()[7:]]), {},
     r"time is not strictly increasing \(sample 6"),
    ("csv-duplicated-sample", lambda tmp: _csv(tmp, "time [s],acceleration [g],force [N]",
                                               [*_good_rows()[:8], _good_rows()[7],
                                                *_good_rows()[8:]]), {},
     r"time is not strictly increasing \(sample 8"),
    ("csv-non-uniform", lambda tmp: _csv(tmp, "time [s],acceleration [g],force [N]",
                                         [*_good_rows()[:10], *_good_rows(40)[30:]]), {},
     r"time is not uniformly sampled"),
    ("csv-fs-mismatch", lambda tmp: _csv(tmp, "time [s],acceleration [g],force [N]",
                                         _good_rows()), {"fs": 1000.0},
     r"fs=1000\.0 Hz does not match the time axis"),
    ("mat-fs-mismatch", lambda tmp: _mat_with(tmp, fs=250.0), {},
     r"fs=250\.0 Hz does not match the time axis"),
    ("mat-length-mismatch", lambda tmp: _mat_with(tmp, force=np.ones(N - 3)), {},
     r"'force' has shape \(197,\), expected \(200, \.\.\.\)"),
    ("uff-rate-mismatch", _uff_rates, {}, r"different sample rates: 'force' 200 Hz"),
    ("csv-no-time-no-fs", lambda tmp: _csv(tmp, "acceleration [g],force [N]",
                                           ["1,2", "3,4"]), {},
     r"no 'time' column/variable; pass fs="),
]


@pytest.mark.parametrize(("build", "kwargs", "match"), [c[1:] for c in READER_CASES],
                         ids=[c[0] for c in READER_CASES])
def test_reader_rejects(tmp_path, build, kwargs, match):
    path = build(tmp_path)
    with pytest.raises(RecordError) as info:
        read_record(path, **kwargs)
    msg = str(info.value)
    assert re.search(match, msg), msg
    assert "\n" not in msg.strip() and len(msg) < 400  # one line, not a dump


@pytest.mark.parametrize(
    ("units", "match"),
    [({"acceleration": "kg", "force": "N"}, r"'acceleration' has unit 'kg', expected 'm/s\^2'"),
     ({"acceleration": "m/s^2", "force": "m"}, r"'force' has unit 'm', expected 'N'")],
    ids=["preprocess-wrong-acc-unit", "preprocess-wrong-force-unit"],
)
def test_preprocess_rejects_wrong_units(units, match):
    rec = good_record()
    rec = Record(rec.time, rec.fs, rec.variables, units)
    with pytest.raises(RecordError, match=match):
        preprocess(rec)


# -- CLI (model_files: the session's, conftest.py) ----------------------------------------------
def _write_text(name: str, text: str) -> Callable[[Path], None]:
    def make(tmp: Path) -> None:
        (tmp / name).write_text(text)

    return make


def _mkdir(name: str) -> Callable[[Path], None]:
    return lambda tmp: (tmp / name).mkdir()


# (id, setup(tmp), argv with {tmp}/{models}, regex of the error)
H = ["rig", "harmonic", "--frequency", "12", "--accel-g", "4"]
CLI_CASES = [
    ("harmonic-fill-1.5", None, [*H, "--fill", "1.5", "--out", "{tmp}/h.nc"],
     r"--fill must be in \(0, 1\), got 1\.5"),
    ("harmonic-height-mm-as-m", _write_text("t.toml", "[tank]\nheight = 27.2\n"),
     [*H, "--tank", "{tmp}/t.toml", "--out", "{tmp}/h.nc"], r"look like millimetres.*27\.2"),
    ("harmonic-unknown-tank-key", _write_text("t.toml", "[tank]\nfil = 0.5\n"),
     [*H, "--tank", "{tmp}/t.toml", "--out", "{tmp}/h.nc"], r"unknown tank parameter\(s\): fil"),
    ("harmonic-tank-no-table", _write_text("t.toml", "fill = 0.5\n"),
     [*H, "--tank", "{tmp}/t.toml", "--out", "{tmp}/h.nc"], r"no \[tank\] table"),
    ("harmonic-tank-bad-toml", _write_text("t.toml", "[tank\nfill="),
     [*H, "--tank", "{tmp}/t.toml", "--out", "{tmp}/h.nc"], r"not valid TOML"),
    ("harmonic-tank-missing", None, [*H, "--tank", "{tmp}/none.toml", "--out", "{tmp}/h.nc"],
     r"--tank .*none\.toml: no such file"),
    ("harmonic-tank-nan", _write_text("t.toml", "[tank]\ndensity = nan\n"),
     [*H, "--tank", "{tmp}/t.toml", "--out", "{tmp}/h.nc"], r"density must be a finite positive"),
    ("harmonic-negative-frequency", None,
     ["rig", "harmonic", "--frequency", "-12", "--accel-g", "4", "--out", "{tmp}/h.nc"],
     r"--frequency must be in \(0, 200\] Hz, got -12"),
    ("harmonic-nan-frequency", None,
     ["rig", "harmonic", "--frequency", "nan", "--accel-g", "4", "--out", "{tmp}/h.nc"],
     r"--frequency must be in \(0, 200\] Hz, got nan"),
    ("harmonic-inf-amplitude", None,
     ["rig", "harmonic", "--frequency", "12", "--accel-g", "inf", "--out", "{tmp}/h.nc"],
     r"--accel-g must be in \(0, 60\] g, got inf"),
    ("harmonic-both-amplitudes", None,
     [*H, "--amplitude", "0.001", "--out", "{tmp}/h.nc"], r"exactly one of --amplitude"),
    ("harmonic-zero-cycles", None, [*H, "--cycles", "0", "--out", "{tmp}/h.nc"],
     r"--cycles must be >= 1, got 0"),
    ("harmonic-unknown-out-format", None, [*H, "--out", "{tmp}/h.xlsx"],
     r"--out .*h\.xlsx: unknown format '\.xlsx'"),
    ("harmonic-out-is-a-directory", _mkdir("h.nc"), [*H, "--out", "{tmp}/h.nc"],
     r"[Ii]s a directory"),
    ("vfa-unknown-split", None, ["rig", "vfa", "--split", "test", "--out", "{tmp}/v.nc"],
     r"--split must be 'train' or 'validation'"),
    ("vfa-negative-duration", None, ["rig", "vfa", "--duration", "-1", "--out", "{tmp}/v.nc"],
     r"--duration must be in \[10, 3600\] s, got -1"),
    ("vfa-fill-zero", None, ["rig", "vfa", "--fill", "0", "--out", "{tmp}/v.nc"],
     r"--fill must be in \(0, 1\), got 0"),
    ("config-show-unknown-key", _write_text("c.toml", "[rom]\ndelay = 5\n"),
     ["config", "show", "--config", "{tmp}/c.toml"], r"unknown configuration key 'rom\.delay'"),
    ("config-show-unknown-table", _write_text("c.toml", "[tanks]\nfill = 0.5\n"),
     ["config", "show", "--config", "{tmp}/c.toml"], r"unknown configuration key 'tanks'"),
    ("config-show-fill-1.5", _write_text("c.toml", "[tank]\nfill = 1.5\n"),
     ["config", "show", "--config", "{tmp}/c.toml"], r"\[tank\]: fill level must be in \(0, 1\)"),
    ("config-show-wrong-type", _write_text("c.toml", "[rom]\nneurons = \"many\"\n"),
     ["config", "show", "--config", "{tmp}/c.toml"],
     r"'rom\.nfir\.neurons' must be an integer, got 'many'"),
    ("config-show-missing-file", None, ["config", "show", "--config", "{tmp}/none.toml"],
     r"--config .*none\.toml: no such file"),
    ("reproduce-unknown-key", _write_text("c.toml", "[tank]\nfil = 0.5\n"),
     ["reproduce", "--config", "{tmp}/c.toml", "--out", "{tmp}/res"],
     r"unknown configuration key 'tank\.fil'"),
    ("reproduce-fill-1.5", _write_text("c.toml", "[tank]\nfill = 1.5\n"),
     ["reproduce", "--config", "{tmp}/c.toml", "--out", "{tmp}/res"],
     r"\[tank\]: fill level must be in \(0, 1\)"),
    ("reproduce-height-mm-as-m", _write_text("c.toml", "[tank]\nheight = 27.2\n"),
     ["reproduce", "--config", "{tmp}/c.toml", "--out", "{tmp}/res"],
     r"\[tank\]: tank dimensions look like millimetres"),
    ("reproduce-negative-delays", _write_text("c.toml", "[rom]\ndelays = -5\n"),
     ["reproduce", "--config", "{tmp}/c.toml", "--out", "{tmp}/res"],
     r"'rom\.nfir\.delays' must be an integer in \[1, 10000\], got -5"),
    ("reproduce-zero-duration", _write_text("c.toml", "[data]\ntrain_duration = 0.0\n"),
     ["reproduce", "--config", "{tmp}/c.toml", "--out", "{tmp}/res"],
     r"'data\.train_duration' must be a VFA duration in s in \[10, 3600\], got 0\.0"),
    ("reproduce-short-duration", _write_text("c.toml", "[data]\ntrain_duration = 5.0\n"),
     ["reproduce", "--config", "{tmp}/c.toml", "--out", "{tmp}/res"],
     r"'data\.train_duration' must be a VFA duration in s in \[10, 3600\], got 5\.0 "
     r"\(the shortest VFA path is 10 s"),
    ("reproduce-nan-fs", _write_text("c.toml", "[rig]\nfs = nan\n"),
     ["reproduce", "--config", "{tmp}/c.toml", "--out", "{tmp}/res"],
     r"'rig\.fs' must be a record rate in Hz in \[100, 5000\], got nan"),
    ("reproduce-unknown-arch", _write_text("c.toml", "[rom]\narch = \"lstm\"\n"),
     ["reproduce", "--config", "{tmp}/c.toml", "--out", "{tmp}/res"],
     r"'rom\.arch' must be \"nfir\" or \"noe\" or \"nss\" or \"lss\" or \"grey\", got 'lstm'"),
    ("map-neither-rig-nor-model", None, ["map", "--out", "{tmp}/m.nc"],
     r"exactly one of --rig or --model"),
    ("map-tiny-grid", None, ["map", "--rig", "--n-omega", "1", "--out", "{tmp}/m.nc"],
     r"--n-omega must be in \[2, 200\], got 1"),
    ("map-model-missing", None, ["map", "--model", "{tmp}/none.npz", "--out", "{tmp}/m.nc"],
     r"--model .*none\.npz: no such file"),
    ("map-model-newer-version", None,
     ["map", "--model", "{models}/newer.npz", "--out", "{tmp}/m.nc"],
     r"format version 99 is newer"),
    ("map-model-tampered-shape", None,
     ["map", "--model", "{models}/tampered.npz", "--out", "{tmp}/m.nc"],
     r"parameter W tampered: expected float \(3, 4\)"),
    ("map-model-not-a-model", None,
     ["map", "--model", "{models}/text.npz", "--out", "{tmp}/m.nc"],
     r"text\.npz: not a sloshrom model file"),
    ("map-reference-not-netcdf", _write_text("ref.nc", "hello"),
     ["map", "--rig", "--reference", "{tmp}/ref.nc", "--out", "{tmp}/m.nc"],
     r"ref\.nc: not a readable NetCDF map"),
    ("map-reference-not-a-map", lambda tmp: write_record(good_record(), tmp / "ref.nc"),
     ["map", "--rig", "--reference", "{tmp}/ref.nc", "--out", "{tmp}/m.nc"],
     r"ref\.nc: not a map file \(no 'phi_d' variable\)"),
]


def _rom_files(tmp: Path) -> None:
    """Records for `train`/`predict`: a good one at 500 Hz, one at 250 Hz, one without y."""
    t = np.arange(1500) / 500.0
    u = 0.05 * np.sin(2 * np.pi * 7 * t) * np.sin(np.pi * t / t[-1])
    write_record(Record(t, 500.0, {"velocity": u, "dynamic_force": np.tanh(20 * u)},
                        {"velocity": "m/s", "dynamic_force": "N"}), tmp / "good.nc")
    write_record(Record(2 * t, 250.0, {"velocity": u, "dynamic_force": u},
                        {"velocity": "m/s", "dynamic_force": "N"}), tmp / "r250.nc")
    write_record(Record(t, 500.0, {"acceleration": u}, {"acceleration": "m/s^2"}),
                 tmp / "acc.nc")
    (tmp / "empty.nc").write_bytes(b"")


TR = ["train", "--max-epochs", "2", "--delays", "4", "--neurons", "3", "--out", "{tmp}/m.npz"]
# `sloshrom train/predict` (sloshrom.cli.rom)
ROM_CLI_CASES = [
    ("train-empty-record", [*TR, "--data", "{tmp}/empty.nc", "--validation", "{tmp}/good.nc"],
     r"empty\.nc: file is empty"),
    ("train-missing-variables", [*TR, "--data", "{tmp}/acc.nc", "--validation",
                                 "{tmp}/good.nc"], r"acc\.nc: no variable velocity"),
    ("train-mismatched-rates", [*TR, "--data", "{tmp}/good.nc", "--validation",
                                "{tmp}/r250.nc"], r"sample-rate mismatch.*500 Hz vs 250 Hz"),
    ("train-zero-delays", [*TR, "--delays", "0", "--data", "{tmp}/good.nc", "--validation",
                           "{tmp}/good.nc"], r"--delays must be an integer in \[1, 10000\], got 0"),
    ("predict-newer-model", ["predict", "--model", "{models}/newer.npz", "--data",
                             "{tmp}/good.nc", "--out", "{tmp}/p.nc"], r"format version 99"),
    ("predict-tampered-model", ["predict", "--model", "{models}/tampered.npz", "--data",
                                "{tmp}/good.nc", "--out", "{tmp}/p.nc"], r"parameter W tampered"),
    ("predict-mismatched-rate", ["predict", "--model", "{models}/good.npz", "--data",
                                 "{tmp}/r250.nc", "--out", "{tmp}/p.nc"],
     r"sample-rate mismatch.*250 Hz vs 500 Hz"),
    ("predict-missing-variable", ["predict", "--model", "{models}/good.npz", "--data",
                                  "{tmp}/acc.nc", "--out", "{tmp}/p.nc"],
     r"acc\.nc: no variable velocity"),
]


@pytest.mark.parametrize(("argv", "match"), [c[1:] for c in ROM_CLI_CASES],
                         ids=[c[0] for c in ROM_CLI_CASES])
def test_rom_cli_rejects(tmp_path, model_files, argv, match):
    _rom_files(tmp_path)
    check_cli(tmp_path, model_files, None, argv, match)


def _beam_files(tmp: Path) -> None:
    (tmp / "fill.toml").write_text("[tank]\nfill = 1.5\n")
    (tmp / "mm.toml").write_text("[tank]\nheight = 27.2\n")
    (tmp / "modal.toml").write_text("[modal]\nfrequencies = [-1.0]\n")
    (tmp / "bad.toml").write_text("[modal\n")
    (tmp / "text.npz").write_text("not a model\n")


BF = ["beam", "free", "--out", "{tmp}/res"]
BR = ["beam", "random", "--out", "{tmp}/res"]
# `sloshrom beam free/random` (sloshrom.cli.beam)
BEAM_CLI_CASES = [
    ("beam-fill-1.5", [*BF, "--tank-toml", "{tmp}/fill.toml", "--sloshing", "frozen"],
     r"fill level must be in \(0, 1\)"),
    ("beam-height-mm-as-m", [*BF, "--tank-toml", "{tmp}/mm.toml", "--sloshing", "frozen"],
     r"look like millimetres"),
    ("beam-model-missing", [*BF, "--sloshing", "{tmp}/none.npz"], r"none\.npz does not exist"),
    ("beam-not-a-model", [*BF, "--sloshing", "{tmp}/text.npz"], r"not a sloshrom model file"),
    ("beam-tampered-model", [*BF, "--sloshing", "{models}/tampered.npz"],
     r"parameter W tampered"),
    ("beam-negative-duration", [*BF, "--sloshing", "frozen", "--duration", "-1"],
     r"--duration must be in \(0, 600\] s, got -1"),
    ("beam-nan-duration", [*BF, "--sloshing", "frozen", "--duration", "nan"],
     r"--duration must be in \(0, 600\] s, got nan"),
    ("beam-tip-27-m", [*BF, "--sloshing", "frozen", "--tip-displacement", "27"],
     r"--tip-displacement must be in \(-0\.2, 0\.2\) m, got 27"),
    ("beam-modal-missing-keys", [*BF, "--sloshing", "frozen", "--modal-toml",
                                 "{tmp}/modal.toml"], r"modal data: missing key"),
    ("beam-modal-bad-toml", [*BF, "--sloshing", "frozen", "--modal-toml", "{tmp}/bad.toml"],
     r"not valid TOML"),
    ("beam-levels-not-numbers", [*BR, "--levels", "abc"], r"--levels must be comma-separated"),
    ("beam-negative-level", [*BR, "--levels", "-0.1", "--sloshing", "frozen"],
     r"--levels must be RMS values in \(0, 2\] g, got '-0\.1'"),
    ("beam-zero-sigma", [*BR, "--sigma", "0", "--duration", "20", "--sloshing", "frozen"],
     r"--sigma must be a positive frequency in Hz, got 0\.0"),
]
_BEAM_XFAIL: dict[str, str] = {}  # known gaps, each with its reason


@pytest.mark.parametrize(
    ("argv", "match"),
    [pytest.param(*c[1:], id=c[0], marks=[pytest.mark.xfail(strict=True, reason=_BEAM_XFAIL[c[0]])]
                  if c[0] in _BEAM_XFAIL else []) for c in BEAM_CLI_CASES],
)
def test_beam_cli_rejects(tmp_path, model_files, argv, match):
    _beam_files(tmp_path)
    check_cli(tmp_path, model_files, None, argv, match)


@pytest.mark.parametrize(("setup", "argv", "match"), [c[1:] for c in CLI_CASES],
                         ids=[c[0] for c in CLI_CASES])
def test_cli_rejects(tmp_path, model_files, setup, argv, match):
    check_cli(tmp_path, model_files, setup, argv, match)


def test_case_count():
    """docs/interchange.md quotes this suite's case count; keep them in step."""
    n = len(READER_CASES) + 2 + len(CLI_CASES) + len(ROM_CLI_CASES) + len(BEAM_CLI_CASES)
    doc = Path(__file__).resolve().parents[1] / "docs" / "interchange.md"
    assert doc.is_file(), f"{doc} is missing: it must quote the bad-input case count"
    want = f"**{n} cases** in `tests/test_bad_input.py`"
    assert want in doc.read_text(), f"docs/interchange.md must say '{want}'"


def test_config_error_is_value_error():
    # every user-input error type is a ValueError: callers can catch one thing
    from sloshrom.rom.modelfile import ModelFileError

    assert issubclass(ConfigError, ValueError) and issubclass(RecordError, ValueError)
    assert issubclass(ModelFileError, ValueError)
