"""Results survive write failures, kills and concurrent runs (``sloshrom.fileio``).

- a full disk (``ENOSPC``), the file-size limit (``EFBIG``) or a read-only folder while a command
  writes: one ``error:`` line naming the file and the reason, exit code 2, the previous results
  byte-identical and no temporary left (the NetCDF writers used to crash in HDF5: exit 139);
- ``kill -9`` while writing: the temporaries the killed process left are removed by the next
  write of the same target (those of a live process never);
- a batch killed at every step of its commit: a reader (after :func:`complete_commits`) and the
  next run see the old set or the new set, complete;
- two ``reproduce`` runs into one folder at once: the second is refused with the first's pid.

Kills are real (``SIGKILL`` at a named step: ``SLOSHROM_FAULT_KILL``); disk errors are injected
in process through ``fileio._fault_hook`` (and a real ``RLIMIT_FSIZE`` in a subprocess).
"""

from __future__ import annotations

import errno
import json
import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from helpers import runner, snapshot
from sloshrom import fileio
from sloshrom.cli import app
from sloshrom.io import Record, write_record

SRC = str(Path(__file__).resolve().parents[1] / "src")
CLI = "from sloshrom.cli import app; app(prog_name='sloshrom')"
FS = 500.0

pytestmark = pytest.mark.long  # real kills and commands in new processes


def _env(**extra: str) -> dict[str, str]:
    # the sloshrom this test imports (PYTHONPATH first), else this checkout's
    path = os.pathsep.join(p for p in (os.environ.get("PYTHONPATH"), SRC) if p)
    return {**os.environ, "PYTHONPATH": path, **extra}


def sloshrom(argv: list[str], *, fsize: int | None = None, kill_at: str | None = None,
             timeout: float = 300.0) -> subprocess.CompletedProcess[str]:
    """``sloshrom ARGV`` in a new process, with a file-size limit (bytes) or killed at a step."""
    limit = (f"import resource; resource.setrlimit(resource.RLIMIT_FSIZE, ({fsize}, {fsize}))\n"
             if fsize is not None else "")
    env = _env(**({fileio.FAULT_ENV: kill_at} if kill_at else {}))
    return subprocess.run([sys.executable, "-c", limit + CLI, *argv], capture_output=True,
                          text=True, env=env, timeout=timeout)


def error_lines(text: str) -> list[str]:
    return [ln for ln in text.splitlines() if ln.startswith("error:")]


def temporaries(d: Path) -> list[str]:
    """Hidden files left in ``d``'s tree (temporaries, journals), the folder's lock excepted."""
    return sorted(str(p) for p in d.rglob(".*") if p.is_file())


def assert_refused_cleanly(code: int, output: str, before: dict, roots: list[Path],
                           match: str) -> None:
    """Exit code 2, one error line matching ``match``, no traceback, every file as it was."""
    assert code == 2, output
    assert "Traceback" not in output and "Segmentation" not in output, output
    errors = error_lines(output)
    assert len(errors) == 1, output
    assert re.search(match, errors[0]), errors[0]
    assert snapshot(*roots) == before  # names, sizes, times, contents: no temporary either


def raise_at(pattern: str, err: int):
    """A ``_fault_hook`` raising ``OSError(err)`` at the first step matching ``pattern``."""
    import fnmatch

    def hook(step: str) -> None:
        if fnmatch.fnmatchcase(step, pattern):
            raise OSError(err, os.strerror(err))

    return hook


def dead_pid() -> int:
    """The process id of a process that has ended."""
    proc = subprocess.Popen([sys.executable, "-c", "pass"])
    proc.wait()
    return proc.pid


@pytest.fixture
def live_pid():
    proc = subprocess.Popen(["sleep", "60"])
    yield proc.pid
    proc.kill()
    proc.wait()


# -- inputs ------------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def inputs(tmp_path_factory, model_files):
    """A 500 Hz velocity/force record (6 s), the tiny NFIR model, and a 2 s free-decay lab test
    of the built-in beam (UFF + channel map)."""
    from sloshrom.beam.lab.virtual import write_lab_test
    from sloshrom.beam.simulation.coupled import free_response
    from sloshrom.beam.simulation.structure import CantileverBeam, ModalModel
    from sloshrom.config import Tank
    from sloshrom.models import FrozenLiquid

    d = tmp_path_factory.mktemp("fault_inputs")
    n = 3000
    rng = np.random.default_rng(0)
    u = np.convolve(rng.standard_normal(n), np.ones(8) / 8, mode="same") * 0.05
    rec = Record(np.arange(n) / FS, FS, {"velocity": u, "dynamic_force": np.tanh(20 * u)},
                 {"velocity": "m/s", "dynamic_force": "N"}, {})
    write_record(rec, d / "record.nc")
    tank = Tank()
    modal = ModalModel.from_beam(CantileverBeam.with_tank(tank), tank)
    free = free_response(FrozenLiquid(1 / FS), modal, 0.0146, 2.0, tank)
    write_lab_test(free, modal, d / "free.uff", kind="free").write_toml(d / "free.toml")
    return {"record": d / "record.nc", "model": model_files / "good.npz",
            "uff": d / "free.uff", "map": d / "free.toml"}


def predict_argv(inputs, out: Path) -> list[str]:
    return ["predict", "--model", str(inputs["model"]), "--data", str(inputs["record"]),
            "--out", str(out)]


def analyse_argv(inputs, out: Path) -> list[str]:
    return ["analyse", "free", str(inputs["uff"]), "--channels", str(inputs["map"]),
            "--builtin-beam", "--out", str(out)]


def first_run(argv: list[str]) -> None:
    res = runner.invoke(app, argv)
    assert res.exit_code == 0, res.output


# -- 1. a write failure: one line, the previous result intact ----------------------------------
def test_predict_beyond_the_file_size_limit_is_one_line(inputs, tmp_path):
    """EFBIG in the NetCDF writer (it crashed in HDF5 with a segmentation fault, exit 139)."""
    out = tmp_path / "pred.nc"
    first_run(predict_argv(inputs, out))
    before = snapshot(tmp_path)
    res = sloshrom(predict_argv(inputs, out), fsize=out.stat().st_size // 2)
    assert_refused_cleanly(res.returncode, res.stderr, before, [tmp_path],
                           rf"{re.escape(str(out))}: cannot write: file too large.*"
                           "previous pred.nc is intact")


def test_analyse_beyond_the_file_size_limit_is_one_line(inputs, tmp_path):
    """The same in a batch of results (NetCDF, tables, figures): all previous files intact."""
    out = tmp_path / "res"
    first_run(analyse_argv(inputs, out))
    before = snapshot(tmp_path)
    limit = (out / "free_measured.nc").stat().st_size // 2
    res = sloshrom(analyse_argv(inputs, out), fsize=limit)
    assert_refused_cleanly(res.returncode, res.stderr, before, [tmp_path],
                           r"free_measured\.nc: cannot write: file too large.*previous results "
                           "are intact")


@pytest.mark.parametrize("err, reason", [(errno.ENOSPC, "no space left on device"),
                                         (errno.EROFS, "read-only file system")])
def test_injected_disk_errors_are_one_line(inputs, tmp_path, monkeypatch, err, reason):
    """A full disk or a read-only file system as the NetCDF result is complete."""
    out = tmp_path / "pred.nc"
    first_run(predict_argv(inputs, out))
    before = snapshot(tmp_path)
    monkeypatch.setattr(fileio, "_fault_hook", raise_at("written:pred.nc", err))
    res = runner.invoke(app, predict_argv(inputs, out))
    assert_refused_cleanly(res.exit_code, res.output, before, [tmp_path], reason)


def test_read_only_folder_is_one_line(inputs, tmp_path, monkeypatch):
    """A folder we may not create files in (chmod 0555; as root, which ignores permissions, the
    refusal is injected where the temporary is created)."""
    out = tmp_path / "ro" / "pred.nc"
    first_run(predict_argv(inputs, out))
    before = snapshot(tmp_path)
    if os.geteuid() == 0:
        def refuse(*args, **kwargs):
            raise PermissionError(errno.EACCES, "Permission denied", str(out.parent / ".x"))

        monkeypatch.setattr(fileio.tempfile, "mkstemp", refuse)
    else:
        out.parent.chmod(0o555)
    try:
        res = runner.invoke(app, predict_argv(inputs, out))
    finally:
        out.parent.chmod(0o755)
    assert_refused_cleanly(res.exit_code, res.output, before, [tmp_path],
                           r"pred\.nc.*(permission denied|not writable)")


def test_netcdf_writer_writes_what_xarray_reads_back(tmp_path):
    import xarray as xr

    ds = xr.Dataset({"a": ("t", np.arange(5.0), {"units": "N"})}, attrs={"fs": 500.0})
    fileio.atomic_write(tmp_path / "a.nc", fileio.netcdf_writer(ds))
    with xr.open_dataset(tmp_path / "a.nc", engine="h5netcdf") as back:
        xr.testing.assert_identical(back.load(), ds)


# -- 2. kill -9 leftovers ----------------------------------------------------------------------
def test_temporaries_of_dead_writers_are_removed_live_ones_kept(inputs, tmp_path, live_pid):
    out = tmp_path / "pred.nc"
    stale = tmp_path / f".pred.nc.{dead_pid()}.abcd1234.nc"
    live = tmp_path / f".pred.nc.{live_pid}.abcd1234.nc"
    other = tmp_path / f".other.nc.{dead_pid()}.abcd1234.nc"  # another target's: not ours
    for p in (stale, live, other):
        p.write_bytes(b"x" * 100)
    first_run(predict_argv(inputs, out))
    assert not stale.exists()
    assert live.exists() and other.exists()


def test_kill_during_a_write_then_the_next_run_cleans_up(inputs, tmp_path):
    """A real SIGKILL once the temporary is complete, then a successful re-run."""
    out = tmp_path / "pred.nc"
    first_run(predict_argv(inputs, out))
    old = out.read_bytes()
    res = sloshrom(predict_argv(inputs, out), kill_at="replace:pred.nc")
    assert res.returncode == -9, res.stderr
    assert out.read_bytes() == old
    left = temporaries(tmp_path)
    assert len(left) == 1 and re.search(r"\.pred\.nc\.\d+\.\w{8}\.nc$", left[0]), left
    first_run(predict_argv(inputs, out))
    assert temporaries(tmp_path) == []


def test_kill_during_a_batch_then_the_next_run_cleans_up(inputs, tmp_path):
    """analyse killed as its 3rd file is written: nothing changed; the re-run leaves no
    temporary (the killed process's are removed)."""
    out = tmp_path / "res"
    first_run(analyse_argv(inputs, out))
    before = snapshot(tmp_path)
    res = sloshrom(analyse_argv(inputs, out), kill_at="written:fig21*")
    assert res.returncode == -9, res.stderr
    assert len(temporaries(tmp_path)) >= 2
    assert {k: v for k, v in snapshot(tmp_path).items() if not Path(k).name.startswith(".")} \
        == before
    first_run(analyse_argv(inputs, out))
    assert temporaries(tmp_path) == []


def test_long_names_keep_their_temporaries_within_255_bytes(tmp_path):
    """A 253-byte name: its temporary's copy of the name is shortened, and still recognised as
    the target's when its writer was killed."""
    name = "a" * 250 + ".nc"
    code = ("import sys; from sloshrom.fileio import atomic_write_text; "
            "atomic_write_text(sys.argv[1], 'old')")
    res = subprocess.run([sys.executable, "-c", code, str(tmp_path / name)], timeout=60,
                         env=_env(**{fileio.FAULT_ENV: "replace:*"}))
    assert res.returncode == -9
    left = temporaries(tmp_path)
    assert len(left) == 1 and len(os.fsencode(Path(left[0]).name)) <= 255
    fileio.atomic_write_text(tmp_path / name, "new")
    assert (tmp_path / name).read_text() == "new"
    assert temporaries(tmp_path) == []


# -- 3. a batch's commit is all or nothing -----------------------------------------------------
BATCH = """
import sys
from sloshrom.fileio import OutputBatch
d, tag = sys.argv[1], sys.argv[2]
with OutputBatch() as batch:
    for name in ("a.txt", "sub/b.txt", "c.txt", "sub/d.txt"):
        batch.write_text(f"{d}/{name}", f"{tag} {name}")
"""
NAMES = ("a.txt", "sub/b.txt", "c.txt", "sub/d.txt")
STEPS = ["written:a.txt", "written:d.txt", "journal", "rename:0", "rename:1", "rename:2",
         "rename:3", "renamed"]


def _batch(d: Path, tag: str, kill_at: str | None = None) -> int:
    env = _env(**({fileio.FAULT_ENV: kill_at} if kill_at else {}))
    return subprocess.run([sys.executable, "-c", BATCH, str(d), tag], env=env,
                          timeout=60).returncode


def _contents(d: Path) -> set[str]:
    return {(d / n).read_text() for n in NAMES}


@pytest.mark.parametrize("step", STEPS)
def test_a_batch_killed_at_any_step_of_its_commit_is_old_or_new(tmp_path, step):
    d = tmp_path / "res"
    assert _batch(d, "old") == 0
    assert _batch(d, "new", kill_at=step) == -9
    done = fileio.complete_commits(d)  # what a reader (or the next run) does first
    seen = _contents(d)
    assert seen in ({f"old {n}" for n in NAMES}, {f"new {n}" for n in NAMES}), seen
    if step in ("journal", "rename:1", "renamed"):
        assert seen == {f"new {n}" for n in NAMES}  # once journalled: rolled forward
        assert len(done) == {"journal": 4, "rename:1": 3, "renamed": 0}[step]
    assert not list(d.rglob(".sloshrom-commit*"))
    assert _batch(d, "next") == 0
    assert _contents(d) == {f"next {n}" for n in NAMES}
    assert temporaries(d) == []  # the killed run's temporaries: removed by the next run


def test_the_next_batch_completes_an_unfinished_commit(tmp_path):
    """Without an explicit complete_commits: the next batch into the folder rolls forward
    before writing (its own files then replace the old set)."""
    d = tmp_path / "res"
    assert _batch(d, "old") == 0
    assert _batch(d, "new", kill_at="rename:2") == -9
    assert list(d.glob(".sloshrom-commit.*.commit"))
    with fileio.OutputBatch() as batch:
        batch.write_text(d / "a.txt", "mine")
    assert (d / "a.txt").read_text() == "mine"
    assert {(d / n).read_text() for n in NAMES[1:]} == {f"new {n}" for n in NAMES[1:]}
    assert not list(d.rglob(".sloshrom-commit*"))


def test_a_journal_of_a_live_process_is_left_alone(tmp_path, live_pid):
    (tmp_path / "x.tmp").write_text("new")
    journal = tmp_path / f".sloshrom-commit.{live_pid}.abcd1234.commit"
    journal.write_text(json.dumps({"renames": [["x.tmp", "x.txt"]]}))
    assert fileio.complete_commits(tmp_path) == []
    assert journal.exists() and not (tmp_path / "x.txt").exists()


def test_a_failed_rename_leaves_a_journal_the_next_run_completes(tmp_path, monkeypatch):
    d = tmp_path / "res"
    assert _batch(d, "old") == 0
    monkeypatch.setattr(fileio, "_fault_hook", raise_at("rename:2", errno.EIO))
    with pytest.raises(fileio.OutputWriteError, match="journal"), fileio.OutputBatch() as b:
        for name in NAMES:
            b.write_text(d / name, f"new {name}")
    monkeypatch.setattr(fileio, "_fault_hook", None)
    # another process (a reader, the next run) finishes it: this one's journal is its own
    code = subprocess.run([sys.executable, "-c", "import sys; from sloshrom.fileio import "
                           "complete_commits; complete_commits(sys.argv[1])", str(d)],
                          env=_env(), timeout=60).returncode
    assert code == 0
    assert _contents(d) == {f"new {n}" for n in NAMES}
    assert temporaries(d) == []


# -- 4. each command: a disk error at its write leaves the previous results ---------------------
@pytest.fixture(scope="module")
def command_inputs(inputs, tmp_path_factory):
    """Two beam results for ``compare`` (one analysed lab test under two names) and the short
    records of ``train --ensemble``."""
    from helpers import smooth_io

    d = tmp_path_factory.mktemp("command_inputs")
    res = runner.invoke(app, analyse_argv(inputs, d / "analysed"))
    assert res.exit_code == 0, res.output
    for name in ("m1.nc", "m2.nc"):
        shutil.copy(d / "analysed" / "free_measured.nc", d / name)
    for name, seed, n in (("train", 1, 2000), ("validation", 2, 600)):
        u, y = smooth_io(n, seed)
        rec = Record(np.arange(n) / FS, FS, {"velocity": u, "dynamic_force": y},
                     {"velocity": "m/s", "dynamic_force": "N"}, {})
        write_record(rec, d / f"{name}.nc")
    return {**inputs, "dir": d}


def _command(name: str, ins: dict, out: Path) -> list[str]:
    d = ins.get("dir")
    return {
        "predict": lambda: predict_argv(ins, out / "pred.nc"),
        "analyse": lambda: analyse_argv(ins, out),
        "compare": lambda: ["compare", str(d / "m1.nc"), str(d / "m2.nc"), "--name",
                            "measured=lab", "--out", str(out)],
        "export fmu": lambda: ["export", "fmu", str(ins["model"]), str(out / "rom.fmu")],
        "export onnx": lambda: ["export", "onnx", str(ins["model"]), str(out / "rom.onnx")],
        "train --ensemble": lambda: [
            "train", "--data", str(d / "train.nc"), "--validation", str(d / "validation.nc"),
            "--out", str(out / "ens.npz"), "--delays", "3", "--neurons", "4",
            "--max-epochs", "2", "--seed", "3", "--ensemble", "2", "--scheduler", "threads"],
    }[name]()


COMMANDS = ["predict", "analyse", "compare", "export fmu", "export onnx", "train --ensemble"]


@pytest.fixture(scope="module")
def first_results(command_inputs, tmp_path_factory):
    """Each command's first, successful run, once a module (the tests below copy its results
    into their own folder): ``(folder, the steps it wrote)`` by command, made when first asked.
    """
    done: dict[str, tuple[Path, list[str]]] = {}

    def get(command: str) -> tuple[Path, list[str]]:
        if command not in done:
            out = tmp_path_factory.mktemp("first_run") / "res"
            steps: list[str] = []
            with pytest.MonkeyPatch.context() as mp:
                mp.setattr(fileio, "_fault_hook", steps.append)
                first_run(_command(command, command_inputs, out))
            done[command] = (out, steps)
        return done[command]

    return get


def first_run_in(first_results, command: str, out: Path) -> list[str]:
    """The command's first run, as if it had written ``out``: a copy of its results there; the
    steps it wrote."""
    done, steps = first_results(command)
    shutil.copytree(done, out)
    return steps


@pytest.mark.parametrize("err, reason", [(errno.ENOSPC, "no space left on device"),
                                         (errno.EROFS, "read-only file system")])
@pytest.mark.parametrize("command", COMMANDS)
def test_a_disk_error_at_a_commands_write_leaves_its_results(command_inputs, first_results,
                                                             tmp_path, monkeypatch, command, err,
                                                             reason):
    """The error as the command's last file is complete (for a batch: after the others):
    exit 2, one line, every previous file byte-identical, no temporary."""
    out = tmp_path / "res"
    argv = _command(command, command_inputs, out)
    if command == "train --ensemble":  # (training twice would take 20 s)
        out.mkdir()
        (out / "ens.npz").write_bytes(b"the previous model")
        last = "written:ens.npz"
    else:  # the first run's results (one run for both errors)
        steps = first_run_in(first_results, command, out)
        last = [st for st in steps if st.startswith("written:")][-1]
    before = snapshot(tmp_path)
    monkeypatch.setattr(fileio, "_fault_hook", raise_at(last, err))
    res = runner.invoke(app, argv)
    assert_refused_cleanly(res.exit_code, res.output, before, [tmp_path], reason)


@pytest.mark.parametrize("command", [
    "compare", "export fmu",
    # two trainings, one in a new process: slow tier (the fast tier kills the two commands above
    # at their write, and fails the ensemble's write with a disk error)
    pytest.param("train --ensemble", marks=pytest.mark.slow)])
def test_a_kill_at_a_commands_write_leaves_its_results(command_inputs, first_results, tmp_path,
                                                       command):
    """SIGKILL as the command's first file is complete: every previous file as it was; the
    next run succeeds and removes the killed run's temporaries."""
    out = tmp_path / "res"
    argv = _command(command, command_inputs, out)
    if command == "train --ensemble":
        out.mkdir()
        (out / "ens.npz").write_bytes(b"the previous model")
    else:
        first_run_in(first_results, command, out)
    before = snapshot(tmp_path)
    res = sloshrom(argv, kill_at="written:*")
    assert res.returncode == -9, res.stderr
    assert temporaries(tmp_path), "the kill came after the write"
    visible = {k: v for k, v in snapshot(tmp_path).items() if not Path(k).name.startswith(".")}
    assert visible == before
    first_run(argv)
    assert temporaries(tmp_path) == []


# -- 5. one reproduce per folder ---------------------------------------------------------------
def test_folder_lock_refuses_a_live_holder_and_takes_over_a_dead_one(tmp_path, live_pid):
    lock = tmp_path / ".sloshrom.lock"
    lock.write_text(json.dumps({"pid": live_pid, "started": "then"}))
    with pytest.raises(fileio.FolderBusyError, match=f"process {live_pid}, started then"), \
            fileio.folder_lock(lock):
        pass
    gone = dead_pid()
    lock.write_text(json.dumps({"pid": gone, "started": "then"}))
    with fileio.folder_lock(lock) as note:
        assert note is not None and f"process {gone}" in note
        assert json.loads(lock.read_text())["pid"] == os.getpid()
    assert not lock.exists()


HOLD = """
import sys, time
from sloshrom.fileio import folder_lock
with folder_lock(sys.argv[1]):
    print("locked", flush=True)
    time.sleep(60)
"""


def test_reproduce_refuses_a_folder_another_run_holds(tmp_path):
    """A real holder (flock held by another process): exit 2, one line naming its pid, nothing
    written."""
    out = tmp_path / "res"
    out.mkdir()
    holder = subprocess.Popen([sys.executable, "-c", HOLD, str(out / ".sloshrom.lock")],
                              stdout=subprocess.PIPE, text=True, env=_env())
    try:
        assert holder.stdout is not None and holder.stdout.readline().strip() == "locked"
        before = snapshot(tmp_path)
        res = runner.invoke(app, ["reproduce", "--quick", "--out", str(out)])
        assert_refused_cleanly(res.exit_code, res.output, before, [tmp_path],
                               rf"--out {re.escape(str(out))}: another sloshrom run \(process "
                               rf"{holder.pid}, started")
    finally:
        holder.kill()
        holder.wait()


def test_reproduce_refuses_a_planted_lock_of_a_live_process(tmp_path, live_pid):
    out = tmp_path / "res"
    out.mkdir()
    (out / ".sloshrom.lock").write_text(json.dumps({"pid": live_pid, "started": "x"}))
    before = snapshot(tmp_path)
    res = runner.invoke(app, ["reproduce", "--quick", "--out", str(out)])
    assert_refused_cleanly(res.exit_code, res.output, before, [tmp_path],
                           rf"process {live_pid}.*delete {re.escape(str(out))}/\.sloshrom\.lock")


# -- 4. reproduce over a finished folder: a failure or a kill leaves it as it was -------------
@pytest.fixture
def finished(tiny_reproduce, tmp_path):
    """A copy of the tiny reproduce folder (every stage cached) and its configuration."""
    out = tmp_path / "res"
    shutil.copytree(tiny_reproduce["out"], out)
    return out, tiny_reproduce["config"]


def test_reproduce_reuses_the_folder_after_a_stale_lock(finished, tmp_path):
    out, config = finished
    gone = dead_pid()
    (out / ".sloshrom.lock").write_text(json.dumps({"pid": gone, "started": "x"}))
    res = runner.invoke(app, ["reproduce", "--config", str(config), "--out", str(out)])
    assert res.exit_code == 0, res.output
    assert f"took over the lock of process {gone}" in res.output
    assert not (out / ".sloshrom.lock").exists()


@pytest.mark.parametrize("err, reason", [(errno.ENOSPC, "no space left on device"),
                                         (errno.EROFS, "read-only file system")])
def test_reproduce_disk_error_leaves_the_results(finished, tmp_path, monkeypatch, err, reason):
    out, config = finished
    before = snapshot(tmp_path)
    monkeypatch.setattr(fileio, "_fault_hook", raise_at("written:report.html", err))
    res = runner.invoke(app, ["reproduce", "--config", str(config), "--out", str(out)])
    assert_refused_cleanly(res.exit_code, res.output, before, [tmp_path],
                           rf"report\.html: cannot write: {reason}.*previous report.html")


def test_reproduce_killed_then_resumed(finished, tmp_path):
    """Killed (SIGKILL) as it replaces its summary: the old summary stays; the next run
    finishes and leaves no temporary and no lock."""
    out, config = finished
    old = (out / "summary.json").read_bytes()
    argv = ["reproduce", "--config", str(config), "--out", str(out)]
    res = sloshrom(argv, kill_at="replace:summary.json")
    assert res.returncode == -9, res.stderr
    assert (out / "summary.json").read_bytes() == old
    assert (out / ".sloshrom.lock").exists()  # the dead run's: taken over below
    res = sloshrom(argv)
    assert res.returncode == 0, res.stderr
    assert "took over the lock" in res.stderr
    assert temporaries(out) == []


@pytest.mark.slow  # two `reproduce` processes (the maps stage redone); the fast tier keeps a
# kill at every step of a batch's commit (above) and a killed `reproduce` resumed (before)
def test_reproduce_killed_in_a_stages_commit_then_resumed(finished, tmp_path):
    """Killed between the two renames of a map's batch (NetCDF + PNG): a reader finishing the
    commit sees both new files; the next run redoes the maps stage (its record was not written)
    and ends with no journal, no temporary and no lock."""
    out, config = finished
    (out / ".stages" / "maps.json").unlink()  # the maps stage runs again
    argv = ["reproduce", "--config", str(config), "--out", str(out)]
    res = sloshrom(argv, kill_at="rename:1")
    assert res.returncode == -9, res.stderr
    (journal,) = out.rglob(".sloshrom-commit.*.commit")
    renames = json.loads(journal.read_text())["renames"]
    assert [Path(t).name for _, t in renames] == ["phi_d_rig.nc", "phi_d_rig.png"]
    png = out / "maps" / "phi_d_rig.png"
    assert (out / "maps" / Path(renames[1][0]).name).is_file()  # the new figure, not moved
    assert fileio.complete_commits(out) == [png]  # what a reader does first
    assert png.stat().st_mtime_ns >= (out / "maps" / "phi_d_rig.nc").stat().st_mtime_ns
    assert not list(out.rglob(".sloshrom-commit*"))
    res = sloshrom(argv)
    assert res.returncode == 0, res.stderr
    assert "maps" in res.stderr and temporaries(out) == []
