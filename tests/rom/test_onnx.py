"""ONNX export of the ROMs: parity with onnxruntime, the step/state contract, metadata, CLI."""

from __future__ import annotations

import json

import numpy as np
import onnxruntime as ort
import pytest

import sloshrom.cli.export  # noqa: F401  (registers `sloshrom export`)
from helpers import rig_records
from sloshrom.cli import app
from sloshrom.rom.errors import ROMError
from sloshrom.rom.onnx import ONNX_FORMAT_VERSION, SIGN_CONVENTION, export_onnx, run_onnx
from sloshrom.rom.tdnn.estimators import NFIR, NOE

# the validation record exceeds the short training record's input range by ~1 %: expected here
pytestmark = pytest.mark.filterwarnings("ignore::sloshrom.rom.EnvelopeWarning")


@pytest.fixture(scope="module")
def records():
    """A short VFA training record and a validation-like record (other path, other noise)."""
    return rig_records()


@pytest.fixture(scope="module")
def nfir(records):
    train, _ = records
    return NFIR(delays=20, neurons=8, max_epochs=8, seed=0).fit(
        train["velocity"], train["dynamic_force"], fs=train.fs)


def _rel(y, ref):
    return float(np.max(np.abs(y - ref)) / np.max(np.abs(ref)))


@pytest.mark.parametrize("form", ["step", "sequence"])
def test_nfir_parity_on_validation_record(tmp_path, nfir, records, form):
    _, val = records
    u = val["velocity"]
    ref = nfir.predict(u)
    path = export_onnx(nfir, tmp_path / f"nfir_{form}.onnx", form=form)
    y = run_onnx(path, u)
    rel = _rel(y, ref)
    assert rel <= 1e-6, f"{form}: onnxruntime vs sloshrom max relative difference {rel:.2e}"
    # and it is a real prediction, not zeros: the ROM follows the rig's force
    assert np.std(ref) > 0.3 * np.std(val["dynamic_force"])


def test_step_graph_matches_rom_step_and_feeds_back_the_delay_line(tmp_path, nfir, records):
    import jax
    import jax.numpy as jnp

    u = records[1]["velocity"][:300]
    sess = ort.InferenceSession(str(export_onnx(nfir, tmp_path / "s.onnx")),
                                providers=["CPUExecutionProvider"])
    state_o = np.zeros((1, nfir.max_delay))
    with jax.enable_x64(True):  # step is a JAX function in the caller's precision
        state_r = nfir.init_state()
        for k in range(u.size):
            y_o, state_o = sess.run(None, {"velocity": u[k : k + 1].reshape(1, 1),
                                           "u_state": state_o})
            state_r, y_r = nfir.step(state_r, jnp.asarray(u[k]))
            assert y_o[0, 0] == pytest.approx(float(y_r), rel=1e-9, abs=1e-12)
    # the state is the physical past input, most recent first
    np.testing.assert_array_equal(state_o[0, :5], u[::-1][:5])


def test_step_graph_is_batched(tmp_path, nfir, records):
    u = records[1]["velocity"]
    sess = ort.InferenceSession(str(export_onnx(nfir, tmp_path / "s.onnx")),
                                providers=["CPUExecutionProvider"])
    rng = np.random.default_rng(0)
    state = rng.uniform(-0.05, 0.05, (3, nfir.max_delay))
    vel = u[:3].reshape(3, 1)
    y_b, st_b = sess.run(None, {"velocity": vel, "u_state": state})
    for i in range(3):
        y_i, st_i = sess.run(None, {"velocity": vel[i : i + 1], "u_state": state[i : i + 1]})
        assert y_b[i, 0] == pytest.approx(y_i[0, 0], rel=1e-12)
        np.testing.assert_array_equal(st_b[i], st_i[0])


def test_metadata(tmp_path, nfir):
    import onnx

    proto = onnx.load(str(export_onnx(nfir, tmp_path / "m.onnx")))
    meta = {p.key: p.value for p in proto.metadata_props}
    assert meta["format"] == "sloshrom-onnx" and meta["format_version"] == "1" == str(
        ONNX_FORMAT_VERSION)
    assert float(meta["sample_rate_hz"]) == nfir.fs_
    assert json.loads(meta["delays"]) == list(range(1, 21))
    assert meta["input_unit"] == "m/s" and meta["output_unit"] == "N"
    assert meta["input_name"] == "velocity" and meta["output_name"] == "dynamic_force"
    assert meta["sign_convention"] == SIGN_CONVENTION and "up" in SIGN_CONVENTION
    assert json.loads(meta["scaler"]) == nfir.scaler_.to_dict()
    assert "most recent first" in meta["state"]
    assert [i.name for i in proto.graph.input] == ["velocity", "u_state"]
    assert [o.name for o in proto.graph.output] == ["dynamic_force", "u_state_out"]


#: 5 s is enough to check the graph
N_OTHER = 2500


@pytest.fixture(scope="module")
def other_models(records):
    """Each architecture's model, fitted once for both graph forms (by class name)."""
    train, _ = records
    u, y = train["velocity"][:N_OTHER], train["dynamic_force"][:N_OTHER]
    fitted = {}

    def model(cls, kw):
        if cls.__name__ not in fitted:
            fitted[cls.__name__] = cls(max_epochs=3, seed=0, **kw).fit(u, y, fs=train.fs)
        return fitted[cls.__name__]

    return model


@pytest.mark.parametrize(
    ("cls", "kw"),
    [(NFIR, dict(delays=[1, 2, 4, 8], neurons=5, hidden="distance")),
     (NOE, dict(delays=2, neurons=5, out_delays=2))],
    ids=["nfir-distance", "noe"],
)
@pytest.mark.parametrize("form", ["step", "sequence"])
def test_other_architectures(tmp_path, records, other_models, cls, kw, form):
    _, val = records
    n = N_OTHER
    model = other_models(cls, kw)
    u = val["velocity"][:n]
    y = run_onnx(export_onnx(model, tmp_path / "m.onnx", form=form), u)
    assert _rel(y, model.predict(u)) <= 1e-6


def test_float32_export(tmp_path, nfir, records):
    u = records[1]["velocity"]
    y = run_onnx(export_onnx(nfir, tmp_path / "f32.onnx", form="sequence", dtype="float32"), u)
    rel = _rel(y, nfir.predict(u))
    assert rel <= 1e-4, f"float32 graph: max relative difference {rel:.2e}"


@pytest.mark.slow
def test_paper_size_nfir_parity(tmp_path, records):
    """NFIR(70, 35), 2,521 parameters (one LM epoch: the graph, not the fit, is under test)."""
    train, val = records
    model = NFIR(delays=70, neurons=35, max_epochs=1).fit(train["velocity"][:3000],
                                                          train["dynamic_force"][:3000],
                                                          fs=train.fs)
    u = val["velocity"]
    y = run_onnx(export_onnx(model, tmp_path / "p.onnx", form="sequence"), u)
    assert _rel(y, model.predict(u)) <= 1e-6


def test_unfitted_and_bad_arguments(tmp_path, nfir):
    with pytest.raises(ROMError, match="not fitted"):
        export_onnx(NFIR(), tmp_path / "x.onnx")
    with pytest.raises(ROMError, match="form must be"):
        export_onnx(nfir, tmp_path / "x.onnx", form="loop")
    with pytest.raises(ROMError, match="dtype must be"):
        export_onnx(nfir, tmp_path / "x.onnx", dtype="float16")
    assert not list(tmp_path.iterdir())


# -- CLI ----------------------------------------------------------------------------------------
def test_cli_export_onnx(tmp_path, nfir):
    from typer.testing import CliRunner

    runner = CliRunner()
    model = nfir.save(tmp_path / "nfir.npz")
    res = runner.invoke(app, ["export", "onnx", str(model), str(tmp_path / "nfir.onnx")])
    assert res.exit_code == 0, res.output
    assert "max rel. difference" in res.output and (tmp_path / "nfir.onnx").is_file()
    res = runner.invoke(app, ["export", "onnx", str(model), str(tmp_path / "seq.onnx"),
                              "--form", "sequence", "--dtype", "float32"])
    assert res.exit_code == 0, res.output
    for args, match in [
        ([str(tmp_path / "nfir.onnx"), str(model)], "output must be a .onnx file"),
        ([str(tmp_path / "none.npz"), str(tmp_path / "o.onnx")], "model file not found"),
        ([str(tmp_path / "nfir.onnx"), str(tmp_path / "o.onnx")], "not a sloshrom model"),
        ([str(model), str(tmp_path / "o.onnx"), "--form", "loop"], "--form must be"),
    ]:
        res = runner.invoke(app, ["export", "onnx", *args])
        assert res.exit_code != 0 and "Traceback" not in res.output
        assert isinstance(res.exception, SystemExit)
        assert match in res.output, res.output
    assert sorted(p.name for p in tmp_path.iterdir()) == ["nfir.npz", "nfir.onnx", "seq.onnx"]
