"""The grey box as an FMU (member ``SL_GREY``): the C port of ``GreyBoxNetwork.step`` equals
``predict``, its column lives in the FMU's state (saved, restored, serialised), its force reads
the state only; ONNX refuses it with the reason, said by its registry entry.

**The tolerance.** ``PARITY = 1e-12`` of the largest force, as every FMU (tests/test_fmu.py,
and the export command's own check). It is not a given for a model whose column has
thresholds (a contact, a landing, a release), so it was checked: ``predict`` itself moves by
~1e-8 of its largest force when its input moves by a relative 1e-13 (``perturbation_tolerance``
of tests/helpers.py; 1e-9 for 1e-15: a contact one sub-step earlier), so a column that differed
from ``predict``'s by one rounding would be ~1e-9 off, not 1e-12. The FMU is 5e-16 to 6e-16
off on this machine: its column does the operations of ``predict``'s (numba) column in their
order, with the same C library's ``exp`` and ``pow`` and no fused multiply-add, and so runs
bit for bit the same; only the network's and the features' sums (the order of a dot product)
round apart, and they do not feed back into the column. The figures are asserted below
(``test_..._equals_predict``), so a port that drifts by a rounding in its column fails.

Two models: a grey box whose column is identified in a second (``max_epochs = 0``) and whose
network's weights are then drawn at random (a contracting state map), so that every term of
the C network is exercised without training (the fast tests); and a tiny trained one (slow).
"""

from __future__ import annotations

import dataclasses
import re
import shutil
import subprocess
import sys
import warnings
import zipfile

import fmpy
import numpy as np
import pytest
from fmpy.fmi2 import FMU2Slave
from fmpy.validation import validate_fmu
from typer.testing import CliRunner

import sloshrom.cli.export  # noqa: F401  (registers `sloshrom export`)
from helpers import check_cli, perturbation_tolerance, rig_records
from sloshrom.beam.simulation.coupled import free_response
from sloshrom.cli import app
from sloshrom.rom.errors import FeedthroughWarning, ROMError
from sloshrom.rom.fmu import VR, check_fmu_exportable, export_fmu, load_fmu
from sloshrom.rom.fmu_runtime import _callbacks
from sloshrom.rom.grey.entry import GREY_CLASS
from sloshrom.rom.grey.estimator import GreyBox
from sloshrom.rom.grey.network import GreyBoxNetwork
from sloshrom.rom.grey.physics import grey_features
from sloshrom.rom.onnx import check_exportable
from sloshrom.rom.registry import register

# the validation record exceeds the short training record's input range by ~1 %: expected here
pytestmark = pytest.mark.filterwarnings("ignore::sloshrom.models.EnvelopeWarning")

PARITY = 1e-12
#: what predict itself does when its input moves by a relative 1e-13 (module docstring): far
#: above PARITY, so that the parity says "the same column", not "a column close to it"
SENSITIVE = 1e-10
DT = 0.002


def _grey(**kw) -> GreyBox:
    return GreyBox(physics_generations=2, physics_population=4, physics_windows=4,
                   n_states=3, neurons=8, window=10, horizon=40, batch=16, seed=0, **kw)


def _rel(y, ref) -> float:
    return float(np.max(np.abs(np.asarray(y) - ref)) / np.max(np.abs(ref)))


@pytest.fixture(scope="module")
def records():
    """A short VFA training record and a validation-like record (other path, other noise)."""
    return rig_records()


def _random_network(model: GreyBox, seed: int = 1) -> GreyBox:
    """``model`` with its network's weights drawn at random: small, the state map contracting
    (x_{k+1} ~ 0.9 x_k), the output map reading the state and every feature."""
    net = model.model_
    rng = np.random.default_rng(seed)
    p = {k: np.asarray(v) for k, v in net.params.items()}
    nx = net.spec.n_states
    nz, no, h = p["A"].shape[0], p["C"].shape[0], p["b1"].size

    def draw(*shape: int, s: float) -> np.ndarray:
        return s * rng.standard_normal(shape)

    a = draw(nz, nx, s=0.05)
    a[:nx] -= 0.1 * np.eye(nx)
    p.update(A=a, W1=draw(nz, h, s=nz**-0.5), b1=draw(h, s=0.1), W2=draw(h, nx, s=0.02),
             C=draw(no, s=0.1), V1=draw(no, h, s=no**-0.5), d1=draw(h, s=0.1),
             V2=draw(h, s=0.1))
    model.model_ = dataclasses.replace(net, params=p)
    return model


@pytest.fixture(scope="module")
def grey(records):
    """The fast model: the column identified (1 s), the network random (module docstring)."""
    tr, _ = records
    column = _grey(max_epochs=0).fit(tr["velocity"], tr["dynamic_force"], tr.fs, fill=0.5)
    alone = column.predict(records[1]["velocity"])
    return _random_network(column), alone


@pytest.fixture(scope="module")
def grey_fmu(grey, tmp_path_factory):
    with warnings.catch_warnings():
        warnings.simplefilter("error", FeedthroughWarning)  # strictly proper: no warning
        return export_fmu(grey[0], tmp_path_factory.mktemp("grey") / "grey.fmu")


# -- parity ---------------------------------------------------------------------------------------
def test_the_grey_box_fmu_validates_and_equals_predict(grey, grey_fmu, records):
    _, val = records
    model, column_alone = grey
    u = val["velocity"]
    assert validate_fmu(str(grey_fmu)) == []
    ref = model.predict(u)
    # a real prediction, with the network's part in it (not the column alone)
    assert np.std(ref) > 0.1 * np.std(val["dynamic_force"])
    assert _rel(column_alone, ref) > 0.01
    fmu = load_fmu(grey_fmu)
    try:
        rel = _rel(fmu.predict(u), ref)
    finally:
        fmu.close()
    assert rel <= PARITY, f"grey box: FMU (stepped through FMPy) vs predict {rel:.2e}"
    # the tolerance is meaningful: predict moves by far more than it when its input moves
    # by a rounding (the column's contacts are thresholds: module docstring)
    assert perturbation_tolerance(model.predict, u, eps=1e-13) > SENSITIVE


def test_the_generated_c_holds_the_column_exactly(grey):
    """The column's arrays and constants to 17 digits: the doubles its step reads."""
    from sloshrom.rom.fmu import model_data_source

    model = grey[0]
    src = model_data_source(model)
    net = model.model_
    for k in ("physics", "taps", "A", "V1"):
        body = re.search(rf"m0_{k}\[\d+\] = \{{(.*?)\}};", src, re.S).group(1)
        got = np.array([float(x) for x in body.replace("\n", " ").split(",")])
        assert np.array_equal(got, np.ravel(net.params[k])), k
    assert ".arch = SL_GREY" in src
    for k, v in (("fs", net.fs), ("g", 9.80665), ("coherence_time", 0.2)):
        assert float(re.search(rf"\.{k} = ([^,}}]+)", src).group(1)) == v, k
    for k in ("n_balls", "n_substeps", "n_past", "n_states", "neurons"):
        got = int(re.search(rf"\.{k} = (\d+)", src).group(1))
        assert got == getattr(net.spec, k), k


@pytest.mark.skipif(not sys.platform.startswith("linux") or shutil.which("cc") is None,
                    reason="needs Linux and a C compiler (cc)")
def test_a_build_for_this_cpu_with_contraction_on_by_default_keeps_the_parity(grey, grey_fmu,
                                                                            records, tmp_path):
    """GNU C mode (gcc's default) fuses a * b + c where the target has FMA (-march=native on
    most x86-64 machines, every aarch64): the kernels switch that off, or a contact of the
    column moves (measured without the switch: 2.2e-10 of the force; with it: 6.2e-16)."""
    _, val = records
    d = tmp_path / "native"
    with zipfile.ZipFile(grey_fmu) as zf:
        zf.extractall(d)
    so = next((d / "binaries").rglob("*.so"))
    subprocess.run(["cc", "-std=gnu99", "-O2", "-march=native", "-shared", "-fPIC", "-I",
                    "sources", *sorted(p.relative_to(d).as_posix()
                                       for p in (d / "sources").glob("*.c")),
                    "-lm", "-o", str(so)], cwd=d, check=True, capture_output=True)
    built = tmp_path / "native.fmu"
    with zipfile.ZipFile(built, "w") as zf:
        for p in sorted(d.rglob("*")):
            if p.is_file():
                zf.write(p, p.relative_to(d).as_posix())
    u = val["velocity"]
    fmu = load_fmu(built)
    try:
        assert _rel(fmu.predict(u), grey[0].predict(u)) <= PARITY
    finally:
        fmu.close()


# -- the FMU's state ------------------------------------------------------------------------------
def _slave(path, tmp):
    md = fmpy.read_model_description(str(path))
    d = fmpy.extract(str(path), unzipdir=str(tmp / "x"))
    f = FMU2Slave(guid=md.guid, unzipDirectory=d,
                  modelIdentifier=md.coSimulation.modelIdentifier, instanceName="t")
    cb = _callbacks([])
    f.instantiate(callbacks=cb)
    f._keep = cb  # the callbacks must outlive the instance
    f.setupExperiment(startTime=0.0)
    f.enterInitializationMode()
    f.exitInitializationMode()
    return f


def _run(f, u, k0: int, n: int) -> list[float]:
    out = []
    for k in range(k0, k0 + n):
        f.setReal([VR["velocity"]], [float(u[k])])
        out.append(f.getReal([VR["dynamic_force"]])[0])
        f.doStep(k * DT, DT)
    return out


def test_the_column_lives_in_the_fmu_state_and_a_restored_state_repeats_the_run(
        grey, grey_fmu, records, tmp_path):
    """The serialised state holds the network's state and the whole column (balls, gate,
    acceleration level, last acceleration and velocity, committed forces, features); a saved
    state, restored or deserialised, repeats the run bit for bit across impacts."""
    _, val = records
    model = grey[0]
    net, s = model.model_, model.model_.spec
    u = val["velocity"][:1200]
    phys = np.asarray(net.params["physics"])
    taps = np.asarray(net.params["taps"])
    feats = grey_features(phys, taps, u[None], net.fs, s.n_balls, s.n_substeps, s.n_past)[0]
    impact = int(np.argmax(np.abs(feats[:1000, 0])))  # the largest filtered force
    k0 = max(impact - 20, 1)
    f = _slave(grey_fmu, tmp_path)
    head = _run(f, u, 0, k0)
    saved = f.getFMUstate()
    blob = bytes(f.serializeFMUstate(saved))
    first = _run(f, u, k0, 50)  # through the impact
    assert np.max(np.abs(np.diff(first))) > 0.1 * np.max(np.abs(feats[:, 0]))
    f.setFMUstate(saved)
    assert _run(f, u, k0, 50) == first
    f.setFMUstate(f.deSerializeFMUstate(blob))
    assert _run(f, u, k0, 50) == first
    f.freeFMUstate(saved)
    f.freeInstance()
    assert _rel(head + first, model.predict(u[: k0 + 50])) <= PARITY
    # the state's doubles follow the header (sloshrom_fmi2.c, Snapshot: n_state at byte 72)
    n_state = int.from_bytes(blob[72:80], sys.byteorder)
    column = 3 * s.n_balls + 4 + (s.n_past - 1) * s.n_substeps + 4
    assert n_state == s.n_states + column
    x = np.frombuffer(blob[len(blob) - 8 * n_state:], dtype=np.float64)
    att = x[s.n_states + 2 * s.n_balls: s.n_states + 3 * s.n_balls]
    assert set(att) <= {0.0, 1.0}
    # the column's features at k0 are the numba column's (the order of the sums aside)
    np.testing.assert_allclose(x[-4:], feats[k0], rtol=0, atol=1e-13 * np.abs(feats).max())


def test_the_grey_box_fmu_is_strictly_proper(grey, grey_fmu, tmp_path):
    """Its force reads the state only: setting the input of t_k does not move it, and
    ModelStructure declares no dependency (no feed-through warning at export: the fixture)."""
    md = fmpy.read_model_description(str(grey_fmu))
    force = next(o for o in md.outputs if o.variable.name == "dynamic_force")
    assert not force.dependencies and "direct feed-through" not in md.description
    assert "grey box" in md.description
    f = _slave(grey_fmu, tmp_path)
    at_rest = f.getReal([VR["dynamic_force"]])[0]
    assert at_rest == pytest.approx(float(grey[0].predict(np.zeros(4))[0]), abs=1e-15)
    f.setReal([VR["velocity"]], [0.3])
    assert f.getReal([VR["dynamic_force"]])[0] == at_rest
    f.doStep(0.0, DT)
    f.setReal([VR["velocity"]], [0.0])
    assert f.getReal([VR["dynamic_force"]])[0] != at_rest  # the step took the input
    f.freeInstance()


# -- refusals and notes ---------------------------------------------------------------------------
ONNX_WHY = (r"the grey box \(10-ball column \+ network of 3 states, 8 neurons\) cannot be "
            r"exported to ONNX: its column is a sub-stepped simulation with contacts and a "
            r"release gate: .*turn on the column's state, which the ONNX exporter's graphs "
            r".*do not express\. Export it as an FMU \(`sloshrom export fmu`")


def test_onnx_refuses_the_grey_box_with_its_reason(grey, tmp_path):
    with pytest.raises(ROMError, match=ONNX_WHY):
        check_exportable(grey[0])
    d = tmp_path / "cli"
    d.mkdir()
    grey[0].save(d / "grey.npz")
    check_cli(d, d, None, ["export", "onnx", "{tmp}/grey.npz", "{tmp}/grey.onnx"], ONNX_WHY)


def test_an_export_note_is_the_refusal_and_only_for_a_format_not_exported(grey, monkeypatch):
    """The exporters print a class's note (rom/registry.py, export_notes), never a branch on
    its name; a note on a format the class exports is refused when it is registered."""
    assert "fmu" in GREY_CLASS.exports and "onnx" in GREY_CLASS.export_notes
    assert check_fmu_exportable(grey[0])
    noted = dataclasses.replace(GREY_CLASS, exports=frozenset(),
                                export_notes={"fmu": "its column needs a crystal ball"})
    monkeypatch.setattr(GreyBoxNetwork, "model_class", property(lambda self: noted))
    with pytest.raises(ROMError, match=r"the grey box \(.*\) cannot be exported to an FMU: "
                                       r"its column needs a crystal ball$"):
        check_fmu_exportable(grey[0])
    with pytest.raises(ROMError, match="exports to 'fmu' and has a note on why it does not"):
        register(dataclasses.replace(GREY_CLASS, name="grey_noted", class_name="GreyNoted",
                                     export_notes={"fmu": "contradiction"}))


# -- a trained grey box (slow) --------------------------------------------------------------------
@pytest.fixture(scope="module")
def trained(records, tmp_path_factory):
    """A tiny trained grey box (7 s): 2 x 100 Adam steps. (1 x 5, the least that trains, leaves
    a network whose state map grows: predict refuses its run as unstable after ~800 samples.)"""
    tr, _ = records
    model = _grey(max_epochs=2, steps_per_epoch=100).fit(tr["velocity"], tr["dynamic_force"],
                                                         tr.fs, fill=0.5)
    return model, model.save(tmp_path_factory.mktemp("trained") / "grey.npz")


@pytest.mark.slow
def test_a_trained_grey_box_exports_from_the_command_line_and_equals_predict(trained, records,
                                                                            tmp_path):
    """`sloshrom export fmu` runs its own 1e-12 check on the grey box, and the FMU equals
    predict on the validation record (measured 5.4e-16)."""
    _, val = records
    model, path = trained
    out = tmp_path / "grey.fmu"
    r = CliRunner().invoke(app, ["export", "fmu", str(path), str(out), "--step", "0.002"])
    assert r.exit_code == 0, r.output
    assert not [ln for ln in r.output.splitlines() if ln.startswith("warning:")], r.output
    rel = float(re.search(r"max rel\. difference (\S+)", r.output).group(1))
    assert rel <= PARITY
    u = val["velocity"]
    ref = model.predict(u)
    fmu = load_fmu(out)
    try:
        assert _rel(fmu.predict(u), ref) <= PARITY
    finally:
        fmu.close()
    assert perturbation_tolerance(model.predict, u, eps=1e-13) > SENSITIVE


@pytest.mark.slow
def test_the_coupled_beam_with_the_grey_fmu_equals_the_beam_with_the_model(trained, records,
                                                                          builtin_modal,
                                                                          tmp_path):
    """The beam with the model steps its JAX column, whose ``exp`` is XLA's (one ulp off the C
    library's for ~14 % of arguments), not ``predict``'s numba column: the two beams agree to
    what such a rounding makes of the column's contacts, not to PARITY. The tolerance is
    predict's own change when its input moves by a relative 1e-15 (~5 ulp) on the validation
    record (measured: 1.1e-9; the beams' forces differ by 1.1e-11)."""
    _, val = records
    model = trained[0]
    tol = perturbation_tolerance(model.predict, val["velocity"], eps=1e-15)
    assert tol < 1e-6  # a rounding is not an impact
    fmu = load_fmu(export_fmu(model, tmp_path / "grey.fmu"))
    try:
        a = free_response(model, builtin_modal, duration=2.0)
        b = free_response(fmu, builtin_modal, duration=2.0)
    finally:
        fmu.close()
    assert np.std(a["dynamic_force"]) > 0
    for k in ("dynamic_force", "tank_acceleration", "q"):
        assert _rel(b[k], a[k]) <= tol, k
