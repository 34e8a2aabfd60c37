"""Model files against hostile and damaged content: every field validated, limits before work.

A hostile edit here always *recomputes the checksum* (``modelfile.checksum``, as anyone can): the
checksum only detects accidental damage, the schema has to reject the content.
"""

from __future__ import annotations

import dataclasses
import io
import json
import math
import re
import tracemalloc
import zipfile
from pathlib import Path

import numpy as np
import pytest

from helpers import model_parts, perturbation_tolerance, relative_change, write_model_parts
from sloshrom import rom
from sloshrom.rom import modelfile
from sloshrom.rom.modelfile import ModelFileError
from sloshrom.rom.network import MinMaxScaler
from sloshrom.rom.tdnn.estimators import NFIR, NOE

DATA = Path(__file__).resolve().parents[1] / "data"


def _model(cls, seed=0, **kw):
    """A 'fitted' model with random parameters (no training needed)."""
    m = cls(**kw)
    rng = np.random.default_rng(seed)
    h, d = m.neurons, m.n_inputs
    params = {"W": rng.standard_normal((h, d)), "b": rng.standard_normal(h),
              "c": rng.standard_normal(h), "c0": np.float64(rng.standard_normal())}
    envelope = {"input_min": -0.5, "input_max": 0.7, "output_min": -3.0, "output_max": 2.0,
                "frequency_band": [5.0, 25.0]}
    history = {"train_mse": [1.0, 0.5], "val_mse": [1.0, float("nan")], "mu": [0.1, None],
               "stop_reason": "test", "best_epoch": 0, "trainer": "lm", "n_rows": 10,
               "train_seconds": 0.5}
    return cls.fitted(params, MinMaxScaler(-0.5, 0.7, -3.0, 2.0), 500.0, envelope, history,
                      **m.get_params())


@pytest.fixture(scope="module")
def saved(tmp_path_factory):
    d = tmp_path_factory.mktemp("models")
    return {"NFIR": _model(NFIR, delays=4, neurons=3).save(d / "nfir.npz"),
            "NOE": _model(NOE, delays=2, neurons=3).save(d / "noe.npz")}


def _hostile(src, dst, edit_meta=None, edit_arrays=None):
    meta, arrays = model_parts(src)
    if edit_meta is not None:
        edit_meta(meta)
    if edit_arrays is not None:
        edit_arrays(arrays)
    return write_model_parts(dst, meta, arrays)


def _set(*path_and_value):
    *path, value = path_and_value

    def edit(meta):
        obj = meta
        for k in path[:-1]:
            obj = obj[k]
        obj[path[-1]] = value

    return edit


def _drop(*path):
    def edit(meta):
        obj = meta
        for k in path[:-1]:
            obj = obj[k]
        del obj[path[-1]]

    return edit


NAN, INF = float("nan"), float("inf")
HP = "hyperparameters"

# (class, edit of the metadata, field the message must name)
HOSTILE = {
    # hyperparameters
    "delays-1e12": ("NFIR", _set(HP, "delays", 10**12), "hyperparameters.delays"),
    "delays-0": ("NFIR", _set(HP, "delays", 0), "hyperparameters.delays"),
    "delays-negative": ("NFIR", _set(HP, "delays", -4), "hyperparameters.delays"),
    "delays-float": ("NFIR", _set(HP, "delays", 4.0), "hyperparameters.delays"),
    "delays-string": ("NFIR", _set(HP, "delays", "4"), "hyperparameters.delays"),
    "delays-bool": ("NFIR", _set(HP, "delays", True), "hyperparameters.delays"),
    "delays-empty-list": ("NFIR", _set(HP, "delays", []), "hyperparameters.delays"),
    "delays-repeated": ("NFIR", _set(HP, "delays", [1, 2, 2, 3]), "hyperparameters.delays"),
    "delays-list-huge": ("NFIR", _set(HP, "delays", [1, 2, 3, 10**12]), "hyperparameters.delays"),
    "delays-regressor-too-big": ("NFIR", _set(HP, "delays", 9000), "hyperparameters.delays"),
    "neurons-0": ("NFIR", _set(HP, "neurons", 0), "hyperparameters.neurons"),
    "neurons-huge": ("NFIR", _set(HP, "neurons", 10**9), "hyperparameters.neurons"),
    "neurons-float": ("NFIR", _set(HP, "neurons", 3.5), "hyperparameters.neurons"),
    "neurons-weights-too-many": ("NFIR", lambda m: m[HP].update(delays=4000, neurons=4000),
                                 "hyperparameters.neurons"),
    "neurons-other-than-arrays": ("NFIR", _set(HP, "neurons", 5), "hyperparameters.neurons"),
    "delays-other-than-arrays": ("NFIR", _set(HP, "delays", 6), "hyperparameters.delays"),
    "hidden-unknown": ("NFIR", _set(HP, "hidden", "gaussian"), "hyperparameters.hidden"),
    "hidden-missing": ("NFIR", _drop(HP, "hidden"), "hyperparameters.hidden"),
    "max_epochs-negative": ("NFIR", _set(HP, "max_epochs", -1), "hyperparameters.max_epochs"),
    "max_epochs-huge": ("NFIR", _set(HP, "max_epochs", 10**15), "hyperparameters.max_epochs"),
    "seed-negative": ("NFIR", _set(HP, "seed", -1), "hyperparameters.seed"),
    "seed-huge": ("NFIR", _set(HP, "seed", 2**80), "hyperparameters.seed"),
    "seed-string": ("NFIR", _set(HP, "seed", "0"), "hyperparameters.seed"),
    "trainer-unknown": ("NFIR", _set(HP, "trainer", "sgd"), "hyperparameters.trainer"),
    "trainer-unknown-noe": ("NOE", _set(HP, "trainer", "sgd"), "hyperparameters.trainer"),
    "units-one": ("NFIR", _set(HP, "units", ["m/s"]), "hyperparameters.units"),
    "units-number": ("NFIR", _set(HP, "units", ["m/s", 5]), "hyperparameters.units[1]"),
    "units-mismatch": ("NFIR", _set(HP, "units", ["mm/s", "N"]), "hyperparameters.units"),
    "names-empty": ("NFIR", _set(HP, "names", ["", "f"]), "hyperparameters.names[0]"),
    "names-mismatch": ("NFIR", _set(HP, "names", ["u", "y"]), "hyperparameters.names"),
    "hyper-extra": ("NFIR", _set(HP, "out_delays", 2), "hyperparameters.out_delays"),
    "hyper-not-object": ("NFIR", _set(HP, [4, 3]), "hyperparameters"),
    "out_delays-0": ("NOE", _set(HP, "out_delays", 0), "hyperparameters.out_delays"),
    "out_delays-huge": ("NOE", _set(HP, "out_delays", 10**6), "hyperparameters.out_delays"),
    "out_delays-missing": ("NOE", _drop(HP, "out_delays"), "hyperparameters.out_delays"),
    "unstable_bound-0": ("NOE", _set(HP, "unstable_bound", 0.0), "hyperparameters.unstable_bound"),
    "unstable_bound-nan": ("NOE", _set(HP, "unstable_bound", NAN),
                           "hyperparameters.unstable_bound"),
    # sample rate
    "fs-0": ("NFIR", _set("fs", 0.0), "fs"),
    "fs-negative": ("NFIR", _set("fs", -500.0), "fs"),
    "fs-nan": ("NFIR", _set("fs", NAN), "fs"),
    "fs-inf": ("NFIR", _set("fs", INF), "fs"),
    "fs-huge": ("NFIR", _set("fs", 1e9), "fs"),
    "fs-string": ("NFIR", _set("fs", "500"), "fs"),
    "fs-missing": ("NFIR", _drop("fs"), "fs"),
    # units and names
    "units-control-char": ("NFIR", _set("units", "input", "m/s\x1b[2J"), "units.input"),
    "units-missing": ("NFIR", _drop("units", "output"), "units.output"),
    "units-long": ("NFIR", _set("units", "output", "N" * 1000), "units.output"),
    "names-empty-top": ("NFIR", _set("names", "input", ""), "names.input"),
    "names-not-string": ("NFIR", _set("names", "output", ["x"]), "names.output"),
    "names-extra": ("NFIR", _set("names", "third", "z"), "names.third"),
    # scaler
    "scaler-nan": ("NFIR", _set("scaler", "in_min", NAN), "scaler.in_min"),
    "scaler-inf": ("NFIR", _set("scaler", "out_max", INF), "scaler.out_max"),
    "scaler-huge": ("NFIR", _set("scaler", "out_max", 1e300), "scaler.out_max"),
    "scaler-equal": ("NFIR", _set("scaler", "in_max", -0.5), "scaler.in_max"),
    "scaler-reversed": ("NFIR", _set("scaler", "out_min", 5.0), "scaler.out_max"),
    "scaler-tiny-span": ("NFIR", lambda m: m["scaler"].update(in_min=0.0, in_max=5e-324),
                         "scaler.in_max"),
    "scaler-missing": ("NFIR", _drop("scaler", "out_min"), "scaler.out_min"),
    "scaler-string": ("NFIR", _set("scaler", "in_min", "-0.5"), "scaler.in_min"),
    "scaler-extra": ("NFIR", _set("scaler", "gain", 2.0), "scaler.gain"),
    # envelope
    "envelope-reversed": ("NFIR", _set("envelope", "input_min", 1.0), "envelope.input_max"),
    "envelope-nan": ("NFIR", _set("envelope", "output_max", NAN), "envelope.output_max"),
    "envelope-missing": ("NFIR", _drop("envelope", "input_max"), "envelope.input_max"),
    "band-reversed": ("NFIR", _set("envelope", "frequency_band", [30.0, 10.0]),
                      "envelope.frequency_band"),
    "band-negative": ("NFIR", _set("envelope", "frequency_band", [-1.0, 10.0]),
                      "envelope.frequency_band[0]"),
    "band-above-nyquist": ("NFIR", _set("envelope", "frequency_band", [5.0, 300.0]),
                           "envelope.frequency_band"),
    "band-one-value": ("NFIR", _set("envelope", "frequency_band", [5.0]),
                       "envelope.frequency_band"),
    "band-nan": ("NFIR", _set("envelope", "frequency_band", [NAN, 5.0]),
                 "envelope.frequency_band[0]"),
    "envelope-not-object": ("NFIR", _set("envelope", None), "envelope"),
    # history
    "history-string-entry": ("NFIR", _set("history", "train_mse", [1.0, "x"]),
                             "history.train_mse[1]"),
    "history-bool-entry": ("NFIR", _set("history", "val_mse", [True, 1.0]), "history.val_mse[0]"),
    "history-not-list": ("NFIR", _set("history", "mu", 3.0), "history.mu"),
    "history-unknown-key": ("NFIR", _set("history", "exec", "import os"), "history.exec"),
    "history-best-epoch-out-of-range": ("NFIR", _set("history", "best_epoch", 7),
                                        "history.best_epoch"),
    "history-best-epoch-negative": ("NFIR", _set("history", "best_epoch", -1),
                                    "history.best_epoch"),
    "history-stop-reason": ("NFIR", _set("history", "stop_reason", 3), "history.stop_reason"),
    "history-seconds-negative": ("NFIR", _set("history", "train_seconds", -1.0),
                                 "history.train_seconds"),
    "history-not-object": ("NFIR", _set("history", [1, 2]), "history"),
    # top level
    "version-not-string": ("NFIR", _set("sloshrom_version", 1), "sloshrom_version"),
    "version-empty": ("NFIR", _set("sloshrom_version", ""), "sloshrom_version"),
    "top-extra": ("NFIR", _set("post_load_hook", "os.system('rm -rf ~')"), "post_load_hook"),
    "class-swapped": ("NOE", _set("class", "NFIR"), "hyperparameters.out_delays"),
}


@pytest.mark.parametrize("case", list(HOSTILE), ids=list(HOSTILE))
def test_hostile_edit_with_recomputed_checksum_is_rejected_naming_the_field(
        tmp_path, saved, case):
    cls, edit, field = HOSTILE[case]
    p = _hostile(saved[cls], tmp_path / "m.npz", edit)
    with pytest.raises(ModelFileError) as err:
        rom.load_model(p)
    msg = str(err.value)
    assert msg.startswith(f"{p}: "), msg
    assert f"'{field}'" in msg, msg


def test_the_message_format(tmp_path, saved):
    p = _hostile(saved["NFIR"], tmp_path / "model.npz", _set(HP, "delays", 10**12))
    with pytest.raises(ModelFileError, match=re.escape(
            "model.npz: metadata field 'hyperparameters.delays': must be <= 10000, got "
            "1000000000000")):
        rom.load_model(p)


@pytest.mark.parametrize("field,value,match", [
    ("format", "sloshrom-rim", "not a sloshrom model file"),
    ("format_version", "1", "missing format version"),
    ("format_version", True, "missing format version"),
    ("format_version", 99, "format version 99 is newer"),
    ("class", "Sequential", "unknown model class 'Sequential'"),
    ("checksum", "md5:0", "checksum mismatch"),
])
def test_identity_fields(tmp_path, saved, field, value, match):
    meta, arrays = model_parts(saved["NFIR"])
    meta[field] = value
    if field != "checksum":
        meta["checksum"] = modelfile.checksum(meta, arrays)
    write_model_parts(tmp_path / "m.npz", meta, arrays, recompute=False)
    with pytest.raises(ModelFileError, match=match):
        rom.load_model(tmp_path / "m.npz")


@pytest.mark.parametrize("name,edit,match", [
    ("W", lambda a: a["W"].__setitem__((0, 0), np.nan), "parameter W contains NaN or inf"),
    ("c", lambda a: a["c"].__setitem__(1, np.inf), "parameter c contains NaN or inf"),
    ("b", lambda a: a["b"].__setitem__(0, 1e300), r"parameter b has values beyond"),
    ("W", lambda a: a.update(W=a["W"][:, :-1]), r"parameter W tampered: expected float \(3, 4\)"),
    ("c0", lambda a: a.update(c0=np.zeros(1)), r"parameter c0 tampered: expected float \(\)"),
    ("W", lambda a: a.update(W=np.ones((3, 4), dtype=np.int64)), "parameter W tampered"),
    ("b", lambda a: a.pop("b"), r"parameter b tampered: .*got None"),
])
def test_hostile_arrays_with_recomputed_checksum(tmp_path, saved, name, edit, match):
    meta, arrays = model_parts(saved["NFIR"])
    arrays = {k: np.array(v) for k, v in arrays.items()}
    edit(arrays)
    if all(k in arrays and arrays[k].dtype.kind == "f" for k in modelfile.PARAM_NAMES):
        meta["checksum"] = modelfile.checksum(meta, arrays)
    np.savez(tmp_path / "m.npz", metadata=np.array(json.dumps(meta)), **arrays)
    with pytest.raises(ModelFileError, match=match):
        rom.load_model(tmp_path / "m.npz")


def test_huge_delay_is_rejected_without_allocating(tmp_path, saved):
    p = _hostile(saved["NFIR"], tmp_path / "m.npz", _set(HP, "delays", 10**12))
    tracemalloc.start()
    try:
        with pytest.raises(ModelFileError, match="must be <= 10000"):
            rom.load_model(p)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak < 5e6, peak  # far below one float per delay


def test_npy_header_claiming_a_huge_array_is_rejected_before_allocation(tmp_path, saved):
    # a member whose header declares 10**12 floats but holds 8 bytes
    buf = io.BytesIO()
    np.lib.format.write_array_header_1_0(
        buf, {"descr": "<f8", "fortran_order": False, "shape": (10**6, 10**6)})
    buf.write(b"\0" * 8)
    p = tmp_path / "m.npz"
    with zipfile.ZipFile(saved["NFIR"]) as src, zipfile.ZipFile(p, "w") as dst:
        for info in src.infolist():
            data = buf.getvalue() if info.filename == "W.npy" else src.read(info)
            dst.writestr(info.filename, data)
    tracemalloc.start()
    try:
        with pytest.raises(ModelFileError, match=r"member 'W'.*does not match"):
            rom.load_model(p)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak < 5e6, peak


def test_deeply_nested_metadata_is_rejected_cleanly(tmp_path, saved):
    meta, arrays = model_parts(saved["NFIR"])
    meta["history"]["deep"] = 0
    meta["checksum"] = modelfile.checksum(meta, arrays)
    text = json.dumps(meta).replace('"deep": 0', '"deep": ' + "[" * 10_000 + "]" * 10_000)
    np.savez(tmp_path / "m.npz", metadata=np.array(text), **arrays)
    with pytest.raises(ModelFileError, match="nested more than 16 levels"):
        rom.load_model(tmp_path / "m.npz")
    # unbalanced, and objects rather than lists
    np.savez(tmp_path / "o.npz", metadata=np.array('{"a":' * 10_000), **arrays)
    with pytest.raises(ModelFileError, match="nested more than 16 levels"):
        rom.load_model(tmp_path / "o.npz")


def test_json_depth_scan_ignores_brackets_in_strings():
    deep = "[" * 20 + "]" * 20
    assert modelfile.json_depth_exceeds(deep, 16)
    assert not modelfile.json_depth_exceeds(json.dumps({"a": deep}), 16)
    assert not modelfile.json_depth_exceeds(json.dumps({"a": 'x\\"[[[' * 10}), 16)
    assert not modelfile.json_depth_exceeds("[" * 16 + "]" * 16, 16)
    assert modelfile.json_depth_exceeds("[" * 17 + "]" * 17, 16)


def test_brackets_in_a_name_do_not_count_as_nesting(tmp_path, saved):
    # a legitimate string full of brackets still loads
    meta, arrays = model_parts(saved["NFIR"])
    meta["units"]["input"] = meta[HP]["units"][0] = "[" * 30
    write_model_parts(tmp_path / "m.npz", meta, arrays)
    assert rom.load_model(tmp_path / "m.npz").units[0] == "[" * 30


def test_oversize_metadata_is_rejected(tmp_path, saved):
    meta, arrays = model_parts(saved["NFIR"])
    meta["history"]["stop_reason"] = "x" * modelfile.MAX_METADATA_CHARS
    write_model_parts(tmp_path / "m.npz", meta, arrays)
    with pytest.raises(ModelFileError, match=r"metadata of \d+ characters is more than 4194304"):
        rom.load_model(tmp_path / "m.npz")


def test_oversize_file_is_rejected_before_reading(tmp_path):
    p = tmp_path / "big.npz"
    with open(p, "wb") as fh:
        fh.truncate(modelfile.MAX_FILE_BYTES + 1)  # sparse: cheap
    with pytest.raises(ModelFileError, match="more than the 67108864 a model file can have"):
        rom.load_model(p)


def test_unknown_member_is_rejected(tmp_path, saved):
    meta, arrays = model_parts(saved["NFIR"])
    np.savez(tmp_path / "m.npz", metadata=np.array(json.dumps(meta)), extra=np.ones(3), **arrays)
    with pytest.raises(ModelFileError, match="unexpected member 'extra.npy'"):
        rom.load_model(tmp_path / "m.npz")


def test_nan_in_scaler_is_rejected_even_with_the_checksum_of_the_nan(tmp_path, saved):
    p = _hostile(saved["NOE"], tmp_path / "m.npz", _set("scaler", "out_min", NAN))
    with pytest.raises(ModelFileError, match="'scaler.out_min': must be a finite number, got nan"):
        rom.load_model(p)


# -- valid files ---------------------------------------------------------------------------------
@pytest.mark.parametrize("cls,kw", [
    (NFIR, {"delays": 4, "neurons": 3}),
    (NFIR, {"delays": [1, 5, 3], "neurons": 2, "hidden": "distance"}),
    (NOE, {"delays": 2, "neurons": 3, "out_delays": 3}),
])
def test_valid_files_load_and_predict_identically(tmp_path, cls, kw):
    m = _model(cls, **kw)
    m2 = rom.load_model(m.save(tmp_path / "m.npz"))
    assert type(m2) is cls and m2.get_params() == m.get_params()
    u = np.random.default_rng(1).uniform(-0.5, 0.7, 200)
    np.testing.assert_array_equal(m2.predict(u), m.predict(u))
    assert json.dumps(m2.history_) == json.dumps(m.history_)  # NaN and null kept as saved


@pytest.mark.reference
def test_files_written_before_the_schema_still_load():
    # written by the previous save (format version 1, trained: history with NaN entries)
    exp = np.load(DATA / "model_v1_expected.npz", allow_pickle=False)
    for name, cls in (("nfir", NFIR), ("noe", NOE)):
        m = rom.load_model(DATA / f"model_v1_{name}.npz")
        assert type(m) is cls
        assert any(isinstance(v, float) and math.isnan(v) for v in m.history_["mu"]
                   + m.history_["val_mse"])
        # written on another CPU: equal within the change a 1e-13 input perturbation makes
        got = m.predict(exp["u"])
        assert relative_change(got, exp[name]) <= perturbation_tolerance(m.predict, exp["u"])


# -- save refuses what load would refuse ---------------------------------------------------------
def test_save_refuses_out_of_bounds_and_writes_nothing(tmp_path):
    m = _model(NFIR, delays=4, neurons=3)
    p = m.save(tmp_path / "m.npz")
    before = p.read_bytes()
    m.model_ = dataclasses.replace(m.model_, fs=2e6)
    with pytest.raises(ValueError, match=r"cannot save the model: .*'fs': must be <= 1000000"):
        m.save(p)
    m.model_ = dataclasses.replace(m.model_, fs=500.0)
    m.history_ = {"train_mse": [0.1] * (modelfile.MAX_METADATA_CHARS // 4)}
    with pytest.raises(ValueError, match=r"shorten the training history"):
        m.save(p)
    assert p.read_bytes() == before
    assert sorted(x.name for x in tmp_path.iterdir()) == ["m.npz"]


# -- fuzzing: any damage gives ModelFileError or a model that validates ------------------------
def _check_loaded(m, u):
    """A model that loaded must be usable: it re-saves (same schema) and predicts finitely."""
    m.save(Path(u["dir"]) / "resaved.npz")
    y = m.predict(u["u"])
    assert y.shape == u["u"].shape and np.all(np.isfinite(y))


@pytest.mark.filterwarnings("ignore::sloshrom.rom.EnvelopeWarning")
def test_fuzz_bytes_of_a_valid_file(tmp_path, saved):
    src = saved["NFIR"].read_bytes()
    rng = np.random.default_rng(20261123)
    u = {"dir": tmp_path, "u": np.linspace(-0.4, 0.6, 40)}
    p = tmp_path / "f.npz"
    outcomes = {"error": 0, "loaded": 0}
    for case in range(400):
        data = bytearray(src)
        kind = case % 4
        if kind in (0, 1):  # flip 1..3 random bytes
            for i in rng.integers(0, len(data), 1 + case % 3):
                data[i] ^= int(rng.integers(1, 256))
        elif kind == 2:  # truncate
            del data[int(rng.integers(0, len(data))):]
        else:  # flip a byte in the zip directory and headers (the last ~300 bytes)
            i = len(data) - 1 - int(rng.integers(0, 300))
            data[i] ^= int(rng.integers(1, 256))
        p.write_bytes(bytes(data))
        m = _load_or_refuse(p, f"case {case} ({kind=})")
        if m is None:
            outcomes["error"] += 1
            continue
        outcomes["loaded"] += 1
        _check_loaded(m, u)
    assert outcomes["error"] > 300  # the damage was real


def _load_or_refuse(p, what: str):
    """The loaded model, or None if refused with a ModelFileError; anything else fails."""
    try:
        return rom.load_model(p)
    except ModelFileError:
        return None
    except Exception as exc:  # noqa: BLE001 - the point of the fuzz tests
        pytest.fail(f"{what}: {type(exc).__name__}: {exc}")


@pytest.mark.filterwarnings("ignore::sloshrom.rom.EnvelopeWarning")
def test_fuzz_metadata_text_with_recomputed_checksum(tmp_path, saved):
    meta, arrays = model_parts(saved["NOE"])
    text = json.dumps(meta)
    rng = np.random.default_rng(7)
    alphabet = list('0123456789.-+eE[]{}",:nultrfaNIy x')
    u = {"dir": tmp_path, "u": np.linspace(-0.4, 0.6, 40)}
    p = tmp_path / "f.npz"
    outcomes = {"error": 0, "loaded": 0}
    for case in range(300):
        chars = list(text)
        for _ in range(1 + case % 3):
            i = int(rng.integers(0, len(chars)))
            op = rng.integers(0, 3)
            if op == 0:
                chars[i] = alphabet[int(rng.integers(0, len(alphabet)))]
            elif op == 1:
                del chars[i]
            else:
                chars.insert(i, alphabet[int(rng.integers(0, len(alphabet)))])
        mutated = "".join(chars)
        try:  # recompute the checksum where the text still parses, as an attacker would
            m2 = json.loads(mutated)
            if isinstance(m2, dict):
                m2["checksum"] = modelfile.checksum(m2, arrays)
                mutated = json.dumps(m2)
        except (ValueError, RecursionError):
            pass
        np.savez(p, metadata=np.array(mutated), **arrays)
        m = _load_or_refuse(p, f"case {case}: {mutated}")
        if m is None:
            outcomes["error"] += 1
            continue
        outcomes["loaded"] += 1
        try:
            _check_loaded(m, u)
        except rom.UnstableModelError:
            pass  # a valid NOE may be unstable: reported as such, not a crash
    assert outcomes["error"] > 100 and outcomes["loaded"] > 0


# -- ONNX export writes atomically -----------------------------------------------------------
def test_failed_onnx_export_leaves_the_previous_file(tmp_path, monkeypatch):
    pytest.importorskip("onnx")
    import onnx

    from sloshrom.rom.onnx import export_onnx

    m = _model(NFIR, delays=4, neurons=3)
    out = tmp_path / "m.onnx"
    out.write_bytes(b"previous export")

    def reject(tmp):
        assert tmp.stat().st_size > 0 and tmp != out  # the complete temporary, not the target
        raise ValueError("parity check failed")

    with pytest.raises(ValueError, match="parity check failed"):
        export_onnx(m, out, verify=reject)
    assert out.read_bytes() == b"previous export"

    def half_write(proto, path, *args, **kwargs):
        Path(path).write_bytes(b"\x08\x08half")
        raise OSError("disk full")

    monkeypatch.setattr(onnx, "save_model", half_write)
    with pytest.raises(OSError, match="disk full"):
        export_onnx(m, out)
    assert out.read_bytes() == b"previous export"
    assert sorted(x.name for x in tmp_path.iterdir()) == ["m.onnx"]
    monkeypatch.undo()
    checked = []
    export_onnx(m, out, verify=checked.append)
    assert len(checked) == 1 and onnx.load(str(out)).graph.name.startswith("sloshrom_NFIR")


# -- the CLI reports a hostile file in one line ------------------------------------------------
@pytest.mark.parametrize("argv", [
    ["predict", "--model", "{m}", "--data", "{d}", "--out", "{o}.nc"],
    ["export", "onnx", "{m}", "{o}.onnx"],
])
def test_cli_reports_hostile_model_without_traceback(tmp_path, saved, argv):
    from typer.testing import CliRunner

    import sloshrom.cli.export  # noqa: F401  (registers `sloshrom export`)
    import sloshrom.cli.rom  # noqa: F401
    from sloshrom.cli import app
    from sloshrom.io import Record, write_record

    p = _hostile(saved["NFIR"], tmp_path / "m.npz", _set("envelope", "input_min", 9.0))
    t = np.arange(1000) / 500.0  # a valid input record: the model is the only problem
    d = write_record(Record(t, 500.0, {"velocity": 0.01 * np.sin(40 * t)}, {"velocity": "m/s"}),
                     tmp_path / "d.nc")
    args = [a.format(m=p, d=d, o=tmp_path / "out") for a in argv]
    res = CliRunner().invoke(app, args)
    assert res.exit_code != 0
    assert "Traceback" not in res.output
    assert res.exception is None or isinstance(res.exception, SystemExit)
    assert "metadata field 'envelope.input_max'" in res.output, res.output
    assert not list(tmp_path.glob("out*"))
