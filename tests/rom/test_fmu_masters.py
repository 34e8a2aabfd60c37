"""The exported FMU under the co-simulation masters of other tools, every class (slow tier).

One FMU of every class that exports (NFIR, its distance form and a network on the acceleration,
NOE, NSS with and without feed-through, LSS, the grey box, ensembles), the two feed-through
classes also exported strictly proper, run by:

* **libcosim** (libcosimpy): its last-value observer reads every variable of the FMU, in
  initialisation mode too, and the override manipulator sets the input at each step. An
  ``fmi2Error`` there made libcosim throw, and the whole process abort (SIGABRT): the master
  runs in a subprocess, so that an abort is a failure here, not the end of the test run.
  libcosim reads the outputs after each step, the input of the step before still set: a model
  without feed-through, or exported strictly proper, gives the model's force (1e-12); a
  feed-through model as it is, its force one input late (measured, docs/interchange.md).
* **fmu-manipulation-toolbox**: its FMI 2.0 XSD and semantic checks (``fmutool -check``), and
  its container (an FMU that runs FMUs: a master of its own) around each FMU, run by FMPy: the
  same force as the FMU alone.
* **valgrind** (memcheck): the C master of ``tests/rom/fmi2_master.c`` makes every FMI call a
  master makes (the observer's reads in initialisation mode, the state saved, serialised, read
  back and restored) on each FMU; no invalid access, no definite or indirect leak.

A tool that cannot be installed here is a skip that says so (libcosimpy has wheels for Linux
x86-64 and Windows only; valgrind is a system package).
"""

from __future__ import annotations

import shutil
import subprocess
import sys
import warnings
import zipfile
from pathlib import Path

import fmpy
import numpy as np
import pytest

from helpers import rig_records
from sloshrom.rom.ensemble import Ensemble
from sloshrom.rom.fmu import VR, check_fmu_exportable, export_fmu
from sloshrom.rom.grey.estimator import GreyBox
from sloshrom.rom.lss import LSS
from sloshrom.rom.nss.estimator import NSS
from sloshrom.rom.tdnn.estimators import NFIR, NOE

pytestmark = [pytest.mark.slow,
              pytest.mark.filterwarnings("ignore::sloshrom.models.EnvelopeWarning"),
              pytest.mark.filterwarnings("ignore::sloshrom.rom.errors.FeedthroughWarning")]

PARITY = 1e-12  # as tests/rom/test_fmu.py
LINUX = sys.platform.startswith("linux")
needs_cc = pytest.mark.skipif(not LINUX or shutil.which("cc") is None,
                              reason="needs Linux and a C compiler (cc) to build the FMUs")
MASTER = Path(__file__).with_name("fmi2_master.c")
N = 1500  # communication points of each run (3 s at 500 Hz)

#: libcosim as a master, in its own process: argv = FMU, step (s), input VR, N, input file,
#: output file, force VR; writes the force its last-value observer read after each step
LIBCOSIM = """
import sys
import numpy as np
from libcosimpy.CosimExecution import CosimExecution
from libcosimpy.CosimLogging import CosimLogLevel, log_output_level
from libcosimpy.CosimManipulator import CosimManipulator
from libcosimpy.CosimObserver import CosimObserver
from libcosimpy.CosimSlave import CosimLocalSlave

fmu, dt, vr, n, src, dst, force = sys.argv[1:]
u = np.loadtxt(src)
log_output_level(CosimLogLevel.ERROR)
ex = CosimExecution.from_step_size(round(float(dt) * 1e9))
slave = ex.add_local_slave(CosimLocalSlave(fmu_path=fmu, instance_name="tank"))
observer = CosimObserver.create_last_value()
ex.add_observer(observer)
override = CosimManipulator.create_override()
ex.add_manipulator(override)
out = []
for k in range(int(n)):
    override.slave_real_values(slave, [int(vr)], [float(u[k])])
    assert ex.step()
    out.append(observer.last_real_values(slave, [int(force)])[0])
np.savetxt(dst, out)
"""


def _grey() -> GreyBox:
    """A grey box whose column is identified in a second and whose network is not trained: the
    member SL_GREY runs (the column's parity is tests/rom/grey/test_fmu.py's)."""
    return GreyBox(physics_generations=2, physics_population=4, physics_windows=4, n_states=3,
                   neurons=8, window=10, horizon=40, batch=16, seed=0, max_epochs=0)


def _nss(**kw: object) -> NSS:
    return NSS(**{"n_states": 3, "neurons": 8, "window": 10, "horizon": 40, "batch": 16,
                  "max_epochs": 3, "seed": 0, **kw})


@pytest.fixture(scope="module")
def records():
    return rig_records()


@pytest.fixture(scope="module")
def exports(records, tmp_path_factory):
    """name -> (model, FMU, input kind, how): how is "proper" (no feed-through), "late" (a
    feed-through model exported strictly proper) or "through" (as it is)."""
    tr, _ = records
    u, y, fs = tr["velocity"], tr["dynamic_force"], tr.fs
    acc = {"units": ("m/s^2", "N"), "names": ("acceleration", "dynamic_force")}
    models = {
        "nfir": NFIR(delays=20, neurons=8, max_epochs=3, seed=0).fit(u, y, fs),
        "nfir_distance": NFIR(delays=10, neurons=6, hidden="distance", max_epochs=3,
                              seed=0).fit(u, y, fs),
        "nfir_acceleration": NFIR(delays=10, neurons=6, max_epochs=3, seed=0,
                                  **acc).fit(tr["acceleration"], y, fs),
        "noe": NOE(delays=4, neurons=6, max_epochs=3, seed=0).fit(u, y, fs),
        "nss_proper": _nss(feedthrough="no").fit(u, y, fs),
        "nss": _nss().fit(u, y, fs),
        "lss": LSS().fit(u, y, fs),
        "grey": _grey().fit(u, y, fs, fill=0.5),
        "ensemble_nfir": Ensemble(NFIR(delays=5, neurons=4, max_epochs=2), n_members=2,
                                  seeds=[5, 6]).fit(u, y, fs, scheduler="sequential"),
        "ensemble_nss": Ensemble(_nss(max_epochs=2), n_members=2, seeds=[3, 4]).fit(
            u, y, fs, scheduler="sequential"),
    }
    d = tmp_path_factory.mktemp("masters")
    out = {}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for name, m in models.items():
            kind = "acceleration" if name == "nfir_acceleration" else "velocity"
            through = any(n.feedthrough for n in check_fmu_exportable(m))
            out[name] = (m, export_fmu(m, d / f"{name}.fmu"), kind,
                         "through" if through else "proper")
            if through:
                out[f"{name}_late"] = (m, export_fmu(m, d / f"{name}_late.fmu",
                                                     strictly_proper=True), kind, "late")
    return out


def _input(kind: str, records) -> np.ndarray:
    return np.asarray(records[1][kind][:N])


def _rel(y, ref) -> float:
    return float(np.max(np.abs(np.asarray(y) - ref)) / np.max(np.abs(ref)))


NAMES = ["nfir", "nfir_distance", "nfir_acceleration", "noe", "nss_proper", "nss", "nss_late",
         "lss", "lss_late", "grey", "ensemble_nfir", "ensemble_nss", "ensemble_nss_late"]


# -- libcosim --------------------------------------------------------------------------------------
@needs_cc
@pytest.mark.parametrize("name", NAMES)
def test_libcosim_observes_and_runs_every_class(name, exports, records, tmp_path):
    pytest.importorskip("libcosimpy", reason="libcosimpy has no wheel for this platform (Linux "
                                             "x86-64 and Windows only)")
    model, fmu, kind, how = exports[name]
    u = _input(kind, records)
    np.savetxt(tmp_path / "u.txt", u)
    (tmp_path / "master.py").write_text(LIBCOSIM)
    run = subprocess.run([sys.executable, str(tmp_path / "master.py"), str(fmu),
                          repr(1.0 / model.fs_), str(VR[kind]), str(N), str(tmp_path / "u.txt"),
                          str(tmp_path / "y.txt"), str(VR["dynamic_force"])],
                         capture_output=True, text=True, timeout=300, check=False)
    # an fmi2Error in the observer's reads aborted the process: return code -6 (SIGABRT)
    assert run.returncode == 0, (run.returncode, run.stderr[-2000:])
    y = np.loadtxt(tmp_path / "y.txt")  # read after step k: the force at t_(k+1)
    ref = np.asarray(model.predict(u))
    if how == "proper":  # the force at t_(k+1) reads inputs up to u_k: the model's
        assert _rel(y[:-1], ref[1:]) <= PARITY
    elif how == "late":  # the model's force of t_k, held
        assert _rel(y, ref) <= PARITY
    else:  # one input late: the figure docs/interchange.md quotes, measured
        assert _rel(y[:-1], ref[1:]) > 0.01


# -- fmu-manipulation-toolbox ----------------------------------------------------------------------
def _fmutool() -> str:
    pytest.importorskip("fmu_manipulation_toolbox")
    exe = Path(sys.executable).with_name("fmutool")
    if not exe.is_file():
        pytest.skip("fmu-manipulation-toolbox's fmutool is not next to this Python")
    return str(exe)


def _fmpy_run(path: Path, kind: str, u: np.ndarray, fs: float) -> np.ndarray:
    sig = np.zeros(u.size, dtype=[("time", float), (kind, float)])
    sig["time"], sig[kind] = np.arange(u.size) * (1.0 / fs), u
    res = fmpy.simulate_fmu(str(path), stop_time=sig["time"][-1], output_interval=1.0 / fs,
                            step_size=1.0 / fs, input=sig, output=["dynamic_force"])
    return np.asarray(res["dynamic_force"])


@needs_cc
@pytest.mark.parametrize("name", NAMES)
def test_fmu_manipulation_toolbox_checks_and_contains_every_class(name, exports, records,
                                                                 tmp_path):
    exe = _fmutool()
    from fmu_manipulation_toolbox.assembly import Assembly

    model, fmu, kind, _ = exports[name]
    check = subprocess.run([exe, "-input", str(fmu), "-check"], capture_output=True,
                           text=True, timeout=300, check=False)
    text = check.stdout + check.stderr
    assert check.returncode == 0 and "compliant with FMI-2.0" in text, text[-2000:]
    assert "No semantic error" in text, text[-2000:]
    # the toolbox's container: a master of its own inside an FMU, around ours
    shutil.copyfile(fmu, tmp_path / "slosh.fmu")
    (tmp_path / "box.csv").write_text("rule;from_fmu;from_port;to_fmu;to_port\n"
                                      "FMU;slosh.fmu;;;\n")
    Assembly("box.csv", fmu_directory=tmp_path,
             default_step_size=repr(1.0 / model.fs_)).make_fmu()
    u = _input(kind, records)
    alone = _fmpy_run(fmu, kind, u, model.fs_)
    assert _rel(_fmpy_run(tmp_path / "box.fmu", kind, u, model.fs_), alone) <= PARITY


# -- valgrind --------------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def master(exports, tmp_path_factory):
    if shutil.which("valgrind") is None:
        pytest.skip("valgrind is not installed (Debian/Ubuntu: apt install valgrind)")
    d = tmp_path_factory.mktemp("master")
    with zipfile.ZipFile(exports["nfir"][1]) as zf:
        zf.extractall(d / "fmu")
    exe = d / "master"
    subprocess.run(["cc", "-std=c99", "-Wall", "-Wextra", "-Werror", "-O2", "-g", "-I",
                    str(d / "fmu" / "sources"), str(MASTER), "-ldl", "-o", str(exe)],
                   check=True, capture_output=True, text=True)
    return exe


@needs_cc
@pytest.mark.parametrize("name", NAMES)
def test_every_fmi_call_is_clean_under_valgrind(name, exports, records, master, tmp_path):
    model, fmu, kind, how = exports[name]
    md = fmpy.read_model_description(str(fmu))
    with zipfile.ZipFile(fmu) as zf:
        zf.extractall(tmp_path)
    so = tmp_path / "binaries" / str(fmpy.platform) / f"{md.coSimulation.modelIdentifier}.so"
    u = _input(kind, records)
    run = subprocess.run(["valgrind", "-q", "--error-exitcode=99", "--leak-check=full",
                          "--errors-for-leak-kinds=definite,indirect", str(master), "state",
                          str(so), md.guid, str(VR[kind]), str(u.size)],
                         input="\n".join(f"{x:.17g}" for x in u), capture_output=True,
                         text=True, timeout=600, check=False)
    assert run.returncode == 0, (run.returncode, run.stderr[-3000:])
    lines = run.stdout.split()
    assert lines[-2:] == ["repeat", "ok"], run.stdout[-500:]
    y = np.array([float(v) for v in lines[:-2]])
    ref = np.asarray(model.predict(u))
    if how == "late":
        ref = np.asarray(model.predict(np.concatenate([[0.0], u])))[:-1]
    assert _rel(y, ref) <= PARITY  # the master sets the input before it reads the force
