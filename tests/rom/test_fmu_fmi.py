"""The exported FMU under other FMI 2.0 masters and other Linux systems (issue 41).

A C master written against the FMI 2.0 headers (``tests/rom/fmi2_master.c``, compiled here with the
system's ``cc``) adds up its clock over 10^6 steps, loads two FMUs into one process with
``RTLD_GLOBAL`` and links two source FMUs into one program; the binary exports the ``fmi2``
functions only and needs glibc 2.17 at most; the FMI 2.0 co-simulation state machine, the log
categories, the warning status of a step outside the envelope, the serialised state's header,
the GUID, the declared feed-through; and the export command's hostile cases that need more than
one command line (a file-size limit, a killed export's build folder, an unstable check).

The models are tiny NFIR/NOE/NSS fitted on 600 samples in a second: the properties tested are
the FMU's, not the models'.
"""

from __future__ import annotations

import ctypes
import os
import platform
import re
import shutil
import subprocess
import sys
import tempfile
import time
import warnings
import zipfile
from pathlib import Path

import fmpy
import numpy as np
import pytest
from fmpy.fmi1 import FMICallException
from fmpy.fmi2 import FMU2Slave
from typer.testing import CliRunner

from helpers import check_cli
from sloshrom.cli import app
from sloshrom.rom.errors import FeedthroughWarning, ROMError
from sloshrom.rom.fmu import VR, export_fmu, load_fmu, remove_stale_builds
from sloshrom.rom.fmu_runtime import _callbacks
from sloshrom.rom.nss.estimator import NSS
from sloshrom.rom.tdnn.estimators import NFIR, NOE

pytestmark = [
    pytest.mark.long,  # C masters and compilers, 1e6-step runs
    pytest.mark.filterwarnings("ignore::sloshrom.models.EnvelopeWarning"),
    pytest.mark.filterwarnings("ignore::sloshrom.rom.errors.FeedthroughWarning"),
]

LINUX = sys.platform.startswith("linux")
needs_cc = pytest.mark.skipif(not LINUX or shutil.which("cc") is None,
                              reason="needs Linux and a C compiler (cc)")
MASTER = Path(__file__).with_name("fmi2_master.c")
PARITY = 1e-12  # as tests/rom/test_fmu.py (measured 1e-15)


def _data() -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(0)
    u = np.convolve(rng.standard_normal(600), np.ones(8) / 8, mode="same") * 0.05
    return u, np.tanh(20 * np.roll(u, 2)) * 0.5


def _nss(**kw: object) -> NSS:
    return NSS(n_states=2, neurons=4, window=10, horizon=40, batch=16, max_epochs=1, seed=0,
               **kw)


@pytest.fixture(scope="module")
def models():
    u, y = _data()
    return {"a": NFIR(delays=4, neurons=3, max_epochs=3, seed=0).fit(u, y, 500.0),
            "b": NOE(delays=2, neurons=3, max_epochs=2, seed=1).fit(u, -2 * y, 500.0)}


class Unzipped:
    """An exported FMU unzipped: its folder, binary, sources and GUID."""

    def __init__(self, fmu: Path) -> None:
        self.fmu = fmu
        self.dir = fmu.with_suffix("")
        with zipfile.ZipFile(fmu) as zf:
            zf.extractall(self.dir)
        md = fmpy.read_model_description(str(fmu))
        self.guid = md.guid
        self.id = md.coSimulation.modelIdentifier
        self.so = self.dir / "binaries" / str(fmpy.platform) / f"{self.id}.so"
        self.sources = self.dir / "sources"


@pytest.fixture(scope="module")
def fmus(models, tmp_path_factory):
    d = tmp_path_factory.mktemp("fmus")
    return {k: Unzipped(export_fmu(m, d / f"{k}.fmu")) for k, m in models.items()}


@pytest.fixture(scope="module")
def master(fmus, tmp_path_factory):
    exe = tmp_path_factory.mktemp("master") / "master"
    subprocess.run(["cc", "-std=c99", "-Wall", "-Wextra", "-Werror", "-O2", "-I",
                    str(fmus["a"].sources), str(MASTER), "-ldl", "-o", str(exe)],
                   check=True, capture_output=True, text=True)
    return exe


def _velocity(n: int) -> np.ndarray:
    t = np.arange(n) / 500.0
    return 0.03 * np.sin(2 * np.pi * 7 * t) * np.sin(np.pi * t / t[-1])


def _pair(cmd: list[str], u: np.ndarray) -> np.ndarray:
    run = subprocess.run(cmd, input="\n".join(f"{x:.17g}" for x in u), capture_output=True,
                         text=True, timeout=60, check=False)
    assert run.returncode == 0, run.stderr
    return np.loadtxt(run.stdout.splitlines()).reshape(-1, 2)


def _rel(y: np.ndarray, ref: np.ndarray) -> float:
    return float(np.max(np.abs(y - ref)) / np.max(np.abs(ref)))


# -- 1. a master that adds up its clock -----------------------------------------------------------
@needs_cc
@pytest.mark.parametrize("t0", [0.0, 1000.0])
def test_a_master_that_adds_up_its_clock_runs_a_million_steps(master, fmus, t0):
    """t += h (FMI 2.0's next communication point) drifts from t0 + k dt by up to 2e-9 s over
    10^6 steps: it failed at step 334,598 from t0 = 0 and 42,311 from t0 = 1000 s. A skipped
    and a repeated step stay refused (status 3, fmi2Error)."""
    a = fmus["a"]
    run = subprocess.run([str(master), "clock", str(a.so), a.guid, repr(t0), "1000000"],
                         capture_output=True, text=True, timeout=120, check=False)
    assert run.stdout.split("\n")[:3] == ["passed 1000000", "skip 3", "repeat 3"], \
        run.stdout + run.stderr
    assert run.stderr.count("steps must follow one another") == 2


# -- 2. only fmi2* exported; two FMUs in one process ----------------------------------------------
@needs_cc
@pytest.mark.skipif(shutil.which("nm") is None, reason="no nm (binutils)")
def test_only_the_fmi2_functions_are_exported(fmus):
    out = subprocess.run(["nm", "-D", "--defined-only", str(fmus["a"].so)], check=True,
                         capture_output=True, text=True).stdout
    names = [ln.split()[-1] for ln in out.splitlines() if ln.strip()]
    assert "fmi2DoStep" in names and "fmi2Instantiate" in names
    assert [n for n in names if not n.startswith("fmi2")] == []


@needs_cc
def test_two_fmus_loaded_globally_into_one_process_keep_their_models(master, fmus, models):
    """dlopen(RTLD_GLOBAL) of both: the second bound to the first's SL_MODEL before."""
    a, b = fmus["a"], fmus["b"]
    u = _velocity(1500)
    y = _pair([str(master), "pair", str(a.so), a.guid, str(b.so), b.guid, str(u.size)], u)
    assert _rel(y[:, 0], models["a"].predict(u)) <= PARITY
    assert _rel(y[:, 1], models["b"].predict(u)) <= PARITY
    # and through ctypes in this (Python) process, globally, after the C master's run
    libs = [ctypes.CDLL(str(f.so), mode=os.RTLD_GLOBAL) for f in (a, b)]
    assert all(hasattr(lib, "fmi2DoStep") and not hasattr(lib, "SL_MODEL") for lib in libs)


# -- 3. two source FMUs in one program ------------------------------------------------------------
@needs_cc
def test_two_source_fmus_link_into_one_program(models, tmp_path):
    """Each source FMU compiled with FMI2_FUNCTION_PREFIX=<id>_: the fmi2 functions and the
    internal names are per model; both run in one program and give their own forces."""
    objs = []
    for prefix, key in (("a_", "a"), ("b_", "b")):
        src = Unzipped(export_fmu(models[key], tmp_path / f"{key}.fmu", binary=False))
        for c in sorted(src.sources.glob("*.c")):
            obj = tmp_path / f"{prefix}{c.stem}.o"
            subprocess.run(["cc", "-std=c99", "-Wall", "-Wextra", "-Wpedantic", "-Werror", "-O2",
                            "-c", f"-DFMI2_FUNCTION_PREFIX={prefix}", "-I", str(src.sources),
                            str(c), "-o", str(obj)], check=True, capture_output=True)
            objs.append(str(obj))
    exe = tmp_path / "linked"
    run = subprocess.run(["cc", "-std=c99", "-O2", "-DSTATIC_PAIR", "-I", str(src.sources),
                          str(MASTER), *objs, "-ldl", "-lm", "-o", str(exe)],
                         capture_output=True, text=True, check=False)
    assert run.returncode == 0, run.stderr  # before: multiple definition of 'SL_MODEL'
    guids = [fmpy.read_model_description(str(tmp_path / f"{k}.fmu")).guid for k in "ab"]
    u = _velocity(1000)
    y = _pair([str(exe), "pair", "-", guids[0], "-", guids[1], str(u.size)], u)
    assert _rel(y[:, 0], models["a"].predict(u)) <= PARITY
    assert _rel(y[:, 1], models["b"].predict(u)) <= PARITY


# -- 4. glibc baseline ----------------------------------------------------------------------------
def _glibc_versions(so: Path) -> list[tuple[int, ...]]:
    """The GLIBC_x.y versions of the symbols the binary needs (``objdump -T``)."""
    out = subprocess.run(["objdump", "-T", str(so)], check=True, capture_output=True,
                         text=True).stdout
    return sorted({tuple(int(p) for p in v.split(".")) for v in
                   re.findall(r"\bGLIBC_(\d+(?:\.\d+)+)\b", out)})


@needs_cc
@pytest.mark.skipif(platform.libc_ver()[0] != "glibc", reason="not a glibc system")
@pytest.mark.skipif(shutil.which("objdump") is None, reason="no objdump (binutils)")
def test_the_binary_needs_glibc_2_17_at_most(fmus, tmp_path):
    """The manylinux2014 baseline (RHEL 7/8, Ubuntu 18.04): exp@GLIBC_2.29 before. Both the
    exported binary and one built with the documented plain cc command."""
    plain = tmp_path / "plain.so"
    src = fmus["b"].sources
    subprocess.run(["cc", "-shared", "-fPIC", "-O2", "-I", str(src),
                    *map(str, sorted(src.glob("*.c"))), "-lm", "-o", str(plain)],
                   check=True, capture_output=True)
    for so in (fmus["a"].so, fmus["b"].so, plain):
        versions = _glibc_versions(so)
        assert versions, so  # a parse that finds nothing proves nothing
        assert max(versions) <= (2, 17), (so, versions)


# -- 5. the FMI 2.0 state machine, logging, warning status, state, GUID --------------------------
def _slave(u: Unzipped, tmp: Path, upto: str = "step", logging_on: bool = False):
    """An FMPy slave of ``u`` brought to ``upto`` ("instantiated", "init" or "step") and the
    list its logger appends (status, message) to."""
    messages: list = []
    f = FMU2Slave(guid=u.guid, unzipDirectory=str(u.dir), modelIdentifier=u.id,
                  instanceName="t")
    cb = _callbacks(messages)
    f.instantiate(callbacks=cb, loggingOn=logging_on)
    f._keep = cb  # the callbacks must outlive the instance
    if upto in ("init", "step"):
        f.setupExperiment(startTime=0.0)
        f.enterInitializationMode()
    if upto == "step":
        f.exitInitializationMode()
    return f, messages


def _terminated(f):
    f.terminate()


STATE_MACHINE = [  # (id, state, what to do first, the refused call, the message)
    ("terminate-before-initialisation", "instantiated", None, lambda f: f.terminate(),
     "fmi2Terminate is not allowed when the FMU is instantiated"),
    ("terminate-in-initialization-mode", "init", None, lambda f: f.terminate(),
     "fmi2Terminate is not allowed when the FMU is initialization mode"),
    ("terminate-twice", "step", _terminated, lambda f: f.terminate(),
     "fmi2Terminate is not allowed when the FMU is terminated"),
    ("setreal-after-terminate", "step", _terminated,
     lambda f: f.setReal([VR["velocity"]], [0.1]),
     "fmi2SetReal is not allowed when the FMU is terminated"),
    ("dostep-after-terminate", "step", _terminated, lambda f: f.doStep(0.0, 0.002),
     "fmi2DoStep is not allowed when the FMU is terminated"),
    ("dostep-in-initialization-mode", "init", None, lambda f: f.doStep(0.0, 0.002),
     "fmi2DoStep is not allowed when the FMU is initialization mode"),
    ("getreal-before-initialisation", "instantiated", None,
     lambda f: f.getReal([VR["dynamic_force"]]),
     "fmi2GetReal is not allowed when the FMU is instantiated"),
    ("getboolean-before-initialisation", "instantiated", None,
     lambda f: f.getBoolean([VR["outside_envelope"]]),
     "fmi2GetBoolean is not allowed when the FMU is instantiated"),
    ("getinteger-before-initialisation", "instantiated", None,
     lambda f: f.getInteger([VR["samples_outside_envelope"]]),
     "fmi2GetInteger is not allowed when the FMU is instantiated"),
    ("exit-initialization-twice", "step", None, lambda f: f.exitInitializationMode(),
     "fmi2ExitInitializationMode is not allowed when the FMU is stepping"),
    ("setup-after-initialisation", "step", None, lambda f: f.setupExperiment(startTime=0.0),
     "fmi2SetupExperiment is not allowed when the FMU is stepping"),
]


@needs_cc
@pytest.mark.parametrize(("state", "first", "call", "message"), [c[1:] for c in STATE_MACHINE],
                         ids=[c[0] for c in STATE_MACHINE])
def test_a_call_the_state_machine_does_not_allow_is_refused(fmus, tmp_path, state, first, call,
                                                            message):
    f, messages = _slave(fmus["a"], tmp_path, state)
    if first is not None:
        first(f)
    with pytest.raises(FMICallException):
        call(f)
    assert messages[-1][0] == 3  # fmi2Error
    assert message in messages[-1][1]
    assert "FMI 2.0 co-simulation state machine" in messages[-1][1]
    f.freeInstance()


@needs_cc
def test_what_the_state_machine_allows_still_works(fmus, models, tmp_path):
    f, messages = _slave(fmus["a"], tmp_path, "instantiated")
    f.setReal([VR["velocity"]], [0.0])  # an input's start value, before initialisation
    f.setupExperiment(startTime=0.0)
    f.enterInitializationMode()
    rest = f.getReal([VR["dynamic_force"], VR["time_step"]])  # initial unknowns
    assert rest == [pytest.approx(float(models["a"].predict(np.zeros(4))[0]), abs=1e-15), 0.002]
    # an input's current value too, as the FMI reference FMUs answer: libcosim's last-value
    # observer reads every variable in initialisation mode, and an fmi2Error there aborted
    # the whole process (tests/rom/test_fmu_masters.py runs it)
    assert f.getReal([VR["velocity"]]) == [0.0]
    f.setReal([VR["velocity"]], [0.02])
    assert f.getReal([VR["velocity"]]) == [0.02]
    f.setReal([VR["velocity"]], [0.0])
    f.exitInitializationMode()
    f.doStep(0.0, 0.002)
    f.terminate()
    assert f.getReal([VR["dynamic_force"]])[0] == pytest.approx(rest[0], abs=1e-15)
    f.reset()  # back to instantiated: the whole sequence again
    f.setupExperiment(startTime=5.0)
    f.enterInitializationMode()
    f.exitInitializationMode()
    f.doStep(5.0, 0.002)
    assert [m for s, m in messages if s >= 3] == []
    f.freeInstance()


@needs_cc
def test_debug_logging_honours_its_categories(fmus, tmp_path):
    md = fmpy.read_model_description(str(fmus["a"].fmu))
    assert [c.name for c in md.logCategories] == ["logStatusError", "logStatusWarning",
                                                  "logAll"]
    f, messages = _slave(fmus["a"], tmp_path)
    f.setDebugLogging(False, ["logStatusError"])
    with pytest.raises(FMICallException):
        f.doStep(0.0, 0.001)
    assert messages == []  # refused, and not logged: its category is off
    f.setDebugLogging(True, ["logStatusError"])
    with pytest.raises(FMICallException):
        f.doStep(0.0, 0.001)
    assert len(messages) == 1 and "is not the model's step" in messages[0][1]
    with pytest.raises(FMICallException):
        f.setDebugLogging(True, ["logEverything"])
    assert "unknown log category 'logEverything'" in messages[-1][1]
    messages.clear()
    f.setDebugLogging(False, ["logStatusWarning"])
    hi = f.getReal([VR["input_max"]])[0]
    f.setReal([VR["velocity"]], [2 * hi])
    assert f.fmi2DoStep(f.component, 0.0, 0.002, 1) == 1  # fmi2Warning, not logged
    assert messages == []
    f.setDebugLogging(True, [])  # no categories: all of them
    f.reset()
    f.setupExperiment(startTime=0.0)
    f.enterInitializationMode()
    f.exitInitializationMode()
    f.setReal([VR["velocity"]], [2 * hi])
    assert f.fmi2DoStep(f.component, 0.0, 0.002, 1) == 1
    assert [s for s, _ in messages] == [1] and "left the training envelope" in messages[0][1]
    f.freeInstance()


@needs_cc
def test_a_step_outside_the_envelope_returns_a_warning(fmus, tmp_path):
    """Logged once as a warning, and every such step's status is fmi2Warning (was fmi2OK)."""
    f, messages = _slave(fmus["a"], tmp_path)
    lo, hi = f.getReal([VR["input_min"], VR["input_max"]])
    status = []
    for k, u in enumerate([0.0, 1.5 * hi, 0.0, 1.5 * lo, 0.0]):
        f.setReal([VR["velocity"]], [u])
        status.append(f.fmi2DoStep(f.component, k * 0.002, 0.002, 1))
    assert status == [0, 1, 0, 1, 0]
    assert [s for s, _ in messages] == [1]
    assert f.getInteger([VR["samples_outside_envelope"]]) == [2]
    f.freeInstance()


@needs_cc
def test_a_serialized_state_has_a_header_and_another_models_is_refused(fmus, tmp_path):
    # (FMPy's logger proxy is one per process: the last slave's list gets the messages)
    fb, _ = _slave(fmus["b"], tmp_path / "b")
    other = bytes(fb.serializeFMUstate(fb.getFMUstate()))
    fb.freeInstance()
    fa, ma = _slave(fmus["a"], tmp_path / "a")
    for k in range(5):
        fa.setReal([VR["velocity"]], [0.01 * k])
        fa.doStep(k * 0.002, 0.002)
    blob = bytes(fa.serializeFMUstate(fa.getFMUstate()))
    assert blob[:4] == (0x534C5354).to_bytes(4, sys.byteorder)  # magic "SLST"
    assert int.from_bytes(blob[4:8], sys.byteorder) == 1  # format version
    assert fmus["a"].guid.encode() in blob[8:72]
    bad = {
        "another model": other,
        "truncated": blob[:-8],
        "shorter than its header": blob[:20],
        "no header": b"\0\0\0\0" + blob[4:],
        "another format version": blob[:4] + (7).to_bytes(4, sys.byteorder) + blob[8:],
    }
    for why, data in bad.items():
        with pytest.raises(FMICallException):
            fa.deSerializeFMUstate(data)
        assert why in ma[-1][1], (why, ma[-1][1])
    # its own state restores the run (bit for bit: tests/rom/test_fmu.py)
    fa.setFMUstate(fa.deSerializeFMUstate(blob))
    fa.doStep(5 * 0.002, 0.002)
    fa.freeInstance()


def test_the_guid_includes_the_model_identifier(models, tmp_path):
    one = export_fmu(models["a"], tmp_path / "one.fmu", binary=False)
    two = export_fmu(models["a"], tmp_path / "two.fmu", binary=False)
    again = export_fmu(models["a"], tmp_path / "x" / "one.fmu", binary=False)
    guid = {p: fmpy.read_model_description(str(p)).guid for p in (one, two, again)}
    assert guid[one] != guid[two]
    assert guid[one] == guid[again]  # the same model under the same name: the same FMU


# -- 6. direct feed-through -----------------------------------------------------------------------
def test_feed_through_is_declared_and_warned(tmp_path):
    u, y = _data()
    nss = _nss().fit(u, y, 500.0)
    proper = _nss(feedthrough="no").fit(u, y, 500.0)
    assert nss.model_.feedthrough and not proper.model_.feedthrough
    with pytest.warns(FeedthroughWarning, match=r"direct feed-through .*algebraic loop.*"
                      r"--feedthrough no"):
        a = export_fmu(nss, tmp_path / "nss.fmu", binary=False)
    with warnings.catch_warnings():
        warnings.simplefilter("error", FeedthroughWarning)
        b = export_fmu(proper, tmp_path / "proper.fmu", binary=False)
    for path, through in ((a, True), (b, False)):
        md = fmpy.read_model_description(str(path))
        force = next(o for o in md.outputs if o.variable.name == "dynamic_force")
        assert ("direct feed-through" in md.description) == through
        assert [d.name for d in force.dependencies] == (["velocity"] if through else [])
        assert (force.dependenciesKind == ["dependent"]) == through
    model = nss.save(tmp_path / "nss.npz")
    r = CliRunner().invoke(app, ["export", "fmu", str(model), str(tmp_path / "c.fmu"),
                                 "--source-only"])
    assert r.exit_code == 0, r.output
    lines = [ln for ln in r.output.splitlines() if ln.startswith("warning:")]
    assert len(lines) == 1 and "direct feed-through" in lines[0]
    assert "--strictly-proper" in lines[0]


def test_a_feed_through_model_exports_strictly_proper(tmp_path):
    """A model with feed-through was one input late in every master that reads the outputs
    before it sets the inputs (FMPy's simulate_fmu, libcosim): exported strictly proper, its
    force at t_k is the model's of t_(k-1), no output depends on an input of its own point
    (ModelStructure), the description says so, and no feed-through warning is given. A
    strictly proper model has nothing to gain and is refused, with the reason."""
    u, y = _data()
    nss = _nss().fit(u, y, 500.0)
    with warnings.catch_warnings():
        warnings.simplefilter("error", FeedthroughWarning)
        path = export_fmu(nss, tmp_path / "sp.fmu", binary=False, strictly_proper=True)
    md = fmpy.read_model_description(str(path))
    force = next(o for o in md.outputs if o.variable.name == "dynamic_force")
    assert force.dependencies == [] and "direct feed-through" not in md.description
    assert "exported strictly proper: the force at t_k is the model's force of t_(k-1)" \
        in md.description
    assert "strictly proper export: one step, 0.002 s, late" in force.variable.description
    with pytest.raises(ROMError, match=r"has no direct feed-through .*strictly proper as it "
                                       r"is"):
        export_fmu(_nss(feedthrough="no").fit(u, y, 500.0), tmp_path / "no.fmu",
                   binary=False, strictly_proper=True)


def test_a_dimensionless_parameter_reads_as_a_number(tmp_path):
    """fill_min and fill_max read "... of the training (0.5 1)": the unit "1" is no word."""
    u, y = _data()
    m = NFIR(delays=4, neurons=3, max_epochs=2, seed=0).fit(u, y, 500.0, fill=0.5)
    md = fmpy.read_model_description(str(export_fmu(m, tmp_path / "f.fmu", binary=False)))
    text = {v.name: v.description for v in md.modelVariables}
    assert text["fill_min"] == "lowest fill level d/h of the training (0.5)"
    assert text["fill_max"] == "highest fill level d/h of the training (0.5)"
    assert text["time_step"] == "the model's time step: the only communication step (0.002 s)"


@needs_cc
def test_the_cli_exports_strictly_proper_and_checks_the_step_late_force(tmp_path):
    """`export fmu --strictly-proper` runs its check against the model's force one step
    late; on a model without feed-through it is one error line and nothing written."""
    u, y = _data()
    model = _nss().fit(u, y, 500.0).save(tmp_path / "nss.npz")
    r = CliRunner().invoke(app, ["export", "fmu", str(model), str(tmp_path / "sp.fmu"),
                                 "--strictly-proper"])
    assert r.exit_code == 0, r.output
    assert "strictly proper (its force one step late)" in r.output
    assert not [ln for ln in r.output.splitlines() if ln.startswith("warning:")]
    rel = float(re.search(r"max rel\. difference ([0-9.e+-]+)", r.output).group(1))
    assert rel <= PARITY
    nfir = NFIR(delays=4, neurons=3, max_epochs=2, seed=0).fit(u, y, 500.0)
    check_cli(tmp_path, tmp_path, None, ["export", "fmu", str(nfir.save(tmp_path / "n.npz")),
                                         str(tmp_path / "n.fmu"), "--strictly-proper"],
              r"the NFIR \(4 delays up to 4, 3 neurons\) has no direct feed-through .*"
              r"export it without that option")


# -- hostile input of the export command ----------------------------------------------------------
def _scaled(model, factor: float):
    """``model`` with its output weights ``c`` times ``factor`` (a network that predict runs)."""
    model.model_.params["c"] = np.asarray(model.model_.params["c"]) * factor
    return model


@needs_cc
def test_a_feed_forward_nfir_is_never_unstable(tmp_path):
    """Its output is bounded by its weights: predict and ONNX run it; the FMU refused it as
    "simulation unstable" (the closed loops' bound applied to it)."""
    u, y = _data()
    m = _scaled(NFIR(delays=4, neurons=3, max_epochs=3, seed=0).fit(u, y, 500.0), 200.0)
    v = _velocity(1000)
    ref = m.predict(v)
    assert np.max(np.abs(m.scaler_.y(ref))) > m.unstable_bound  # beyond the NOE's bound
    fmu = load_fmu(export_fmu(m, tmp_path / "big.fmu"))
    assert _rel(fmu.predict(v), ref) <= PARITY
    fmu.close()


@needs_cc
def test_an_unstable_check_names_the_model_and_out_not_the_temporary(tmp_path, model_files):
    u, y = _data()
    noe = _scaled(NOE(delays=2, neurons=3, max_epochs=2, seed=1).fit(u, y, 500.0), 200.0)
    model = noe.save(tmp_path / "noe.npz")
    check_cli(tmp_path, model_files, None, ["export", "fmu", str(model), "{tmp}/slosh.fmu"],
              r"MODEL .*noe\.npz: its FMU fails on the check input \(FMU slosh\.fmu: "
              r"simulation unstable.*slosh\.fmu not written")


@needs_cc
def test_a_file_size_limit_is_one_error_line_and_leaves_the_previous_fmu(models, tmp_path):
    """``prlimit --fsize=20000 sloshrom export fmu ...``: an OSError (EFBIG) traceback before.
    Python ignores SIGXFSZ, so write() fails with EFBIG."""
    model = models["a"].save(tmp_path / "m.npz")
    out = tmp_path / "o.fmu"
    out.write_bytes(b"previous")
    limit = 20000

    # the limit set in the child itself, as prlimit does (no fork of this JAX process)
    code = (f"import resource; resource.setrlimit(resource.RLIMIT_FSIZE, ({limit}, {limit})); "
            "from sloshrom.cli import app; app()")
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(sys.path)}
    run = subprocess.run([sys.executable, "-c", code, "export", "fmu", str(model), str(out),
                          "--no-check"], env=env, capture_output=True, text=True, timeout=300,
                         check=False)
    assert run.returncode == 2, run.stderr
    assert "Traceback" not in run.stderr
    lines = [ln for ln in run.stderr.splitlines() if ln.startswith("error:")]
    assert len(lines) == 1 and re.search(r"OUT .*o\.fmu: not written \(File too large\)",
                                         lines[0]), run.stderr
    assert out.read_bytes() == b"previous"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["m.npz", "o.fmu"]


def test_a_killed_exports_build_folder_is_removed_by_the_next(models, tmp_path, monkeypatch):
    """Build folders carry their PID: a dead process's folder older than STALE_BUILD_AGE goes;
    a live process's, or a young one, stays."""
    root = tmp_path / "tmp"
    root.mkdir()
    monkeypatch.setattr(tempfile, "tempdir", str(root))  # the export's temporary directory
    dead = subprocess.Popen([sys.executable, "-c", "pass"])
    dead.wait()
    stale, young, alive = (root / f"sloshrom-fmu-{pid}-{tail}" for pid, tail in (
        (dead.pid, "a1b2c3"), (dead.pid, "d4e5f6"), (os.getppid(), "g7h8i9")))
    old = time.time() - 3600
    for d in (stale, young, alive):
        (d / "fmu" / "sources").mkdir(parents=True)
        (d / "fmu" / "sources" / "x.c").write_text("/* a killed build */\n")
        if d is not young:
            os.utime(d, (old, old))
    export_fmu(models["a"], tmp_path / "m.fmu", binary=False)
    assert not stale.exists() and young.exists() and alive.exists()
    assert remove_stale_builds(root, age=0.0) == [young]
    assert sorted(p.name for p in root.iterdir()) == [alive.name]  # the export's own: gone
