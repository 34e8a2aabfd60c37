"""Progress without a terminal: plain log lines (throttled, with a heartbeat) instead of rich's
bars, stage lines of `sloshrom reproduce`, and the training's epochs, errors and time left,
ensemble members in other processes included."""

from __future__ import annotations

import functools
import io
import multiprocessing
import re
import time
from concurrent.futures import ProcessPoolExecutor

import numpy as np
import pytest
from rich.console import Console
from rich.progress import Progress
from typer.testing import CliRunner

import sloshrom.cli.progress as progress_module
import sloshrom.pipeline.chain as chain
import sloshrom.rom.ensemble as ensemble_module
import sloshrom.rom.epochs as epochs_module
from helpers import smooth_io
from sloshrom.cli import app
from sloshrom.cli.progress import PlainProgress, progress_bars
from sloshrom.rom.epochs import (
    EpochFile,
    EpochPace,
    TrainingProgress,
    duration_text,
    epoch_reports,
    poll_once,
)

LINE = re.compile(r"^\[ *(\d+\.\d) s\] (.*)$")


class Clock:
    """A clock the test moves by hand."""

    def __init__(self) -> None:
        self.t = 1000.0

    def __call__(self) -> float:
        return self.t


def _lines(text: str) -> list[tuple[float, str]]:
    """The ``[  12.3 s] text`` lines of a log as (seconds, text); other lines are left out."""
    return [(float(m.group(1)), m.group(2)) for m in map(LINE.match, text.splitlines()) if m]


def _plain(**kw) -> tuple[PlainProgress, io.StringIO, Clock]:
    clock, out = Clock(), io.StringIO()
    return PlainProgress(out, clock=clock, **kw), out, clock


# -- the plain logger ----------------------------------------------------------------------------
def test_progress_lines_are_throttled_to_one_per_30_s_per_task():
    log, out, clock = _plain()
    rom = log.add_task("training", total=100, stage="rom")
    maps = log.add_task("harmonic tests", total=100, stage="maps")
    for s in range(1, 100):  # a report of each task every second
        clock.t += 1.0
        log.update(rom, completed=s, description=f"epoch {s}")
        log.update(maps, completed=s)
    lines = _lines(out.getvalue())
    rom_at = [t for t, text in lines if text.startswith("rom:")]
    maps_at = [t for t, text in lines if text.startswith("maps:")]
    # each task: its first report at once, then every 30 s, independently of the other
    assert rom_at == maps_at == [0.0, 30.0, 60.0, 90.0]
    assert (30.0, "rom: epoch 30 (30/100)") in lines
    assert (60.0, "maps: harmonic tests (60/100)") in lines


def test_a_count_already_in_the_text_is_not_repeated():
    log, out, clock = _plain()
    task = log.add_task("training NFIR", total=200, info="")
    clock.t += 31.0
    log.update(task, completed=12, info="epoch 12/200, train 0.1, val 0.2")
    assert _lines(out.getvalue())[-1] == (31.0, "training NFIR: epoch 12/200, train 0.1, val 0.2")


def test_events_are_printed_at_once():
    log, out, clock = _plain()
    log.stage("data", "reused", 0.01)
    log.stage("rom", "start", 0.0)
    clock.t += 0.5
    log.stage("rom", "done", 192.84)
    assert _lines(out.getvalue()) == [(0.0, "data: reused (cached)"), (0.0, "rom: start"),
                                      (0.5, "rom: done in 192.8 s")]


def test_the_heartbeat_prints_the_latest_state_when_nothing_came_for_30_s():
    log, out, clock = _plain(heartbeat=30.0)
    log.stage("rom", "start", 0.0)
    task = log.add_task("training", total=100, stage="rom")
    clock.t += 5.0
    log.update(task, completed=5, description="epoch 5")  # held back by the throttle
    clock.t += 24.0
    log.beat()  # 29 s without a line: nothing yet
    assert len(_lines(out.getvalue())) == 2
    clock.t += 1.0
    log.beat()  # 30 s: the state held back
    assert _lines(out.getvalue())[-1] == (30.0, "rom: epoch 5 (5/100)")
    clock.t += 30.0
    log.beat()  # no news since: said again, with its age
    assert _lines(out.getvalue())[-1] == (
        60.0, "still running, last news 55 s ago: rom: epoch 5 (5/100)")
    clock.t += 10.0
    log.beat()
    assert len(_lines(out.getvalue())) == 4
    # a heartbeat line counts for the throttle: the next report waits 30 s after it
    log.update(task, completed=6, description="epoch 6")
    assert len(_lines(out.getvalue())) == 4


def test_the_heartbeat_thread_keeps_a_line_coming():
    out = io.StringIO()
    with PlainProgress(out, heartbeat=0.05) as log:
        log.stage("beam", "start", 0.0)
        time.sleep(0.4)
    n = len(out.getvalue().splitlines())
    assert n >= 3, out.getvalue()
    assert "still running, last news" in out.getvalue()
    time.sleep(0.2)  # stopped with the block
    assert len(out.getvalue().splitlines()) == n


def test_a_spinner_task_without_total_says_its_stage_and_step():
    log, out, clock = _plain()
    task = log.add_task("", total=None, stage="analyse free")
    clock.t += 40.0
    log.update(task, description="reading 3 files")
    assert [t for _, t in _lines(out.getvalue())] == ["analyse free",
                                                      "analyse free: reading 3 files"]


def test_a_removed_task_stays_the_latest_news_and_a_closed_stream_stops_nothing():
    log, out, clock = _plain()
    task = log.add_task("free response: rig", total=None)
    log.remove_task(task)
    clock.t += 30.0
    log.beat()
    assert _lines(out.getvalue())[-1] == (
        30.0, "still running, last news 30 s ago: free response: rig")
    out.close()  # the log's reader went away
    log.line("beam: done in 31.0 s")
    log.update(task, completed=1)  # a task it forgot: nothing


# -- which display -------------------------------------------------------------------------------
def test_a_terminal_keeps_richs_bars(monkeypatch):
    monkeypatch.setattr(Console, "is_terminal", property(lambda self: True))
    assert isinstance(progress_bars(console=Console(file=io.StringIO())), Progress)
    monkeypatch.setattr(Console, "is_terminal", property(lambda self: False))
    assert isinstance(progress_bars(console=Console(file=io.StringIO())), PlainProgress)


def _fake_run(out, cfg, progress, on_stage):
    """A stand-in for the chain: one reused stage, one that runs and reports."""
    on_stage("data", "reused", 0.01)
    on_stage("rom", "start", 0.0)
    progress("rom", 0, 3, "training NFIR(6, 3)")
    progress("rom", 1, 3, "training NFIR(6, 3): epoch 1/3")
    on_stage("rom", "done", 1.5)
    return {"stages": {"data": {"reused": True}, "rom": {"reused": False}},
            "timings_s": {"data": 0.01, "rom": 1.5}}


def test_reproduce_without_a_terminal_logs_the_stages(monkeypatch, tmp_path):
    monkeypatch.setattr(chain, "run", _fake_run)
    res = CliRunner().invoke(app, ["reproduce", "--quick", "--out", str(tmp_path / "r")])
    assert res.exit_code == 0, res.output
    texts = [t for _, t in _lines(res.output)]
    assert texts == ["data: reused (cached)", "rom: start", "rom: training NFIR(6, 3) (0/3)",
                     "rom: done in 1.5 s"]  # epoch 1 came within 30 s of the first line


def test_reproduce_on_a_terminal_draws_richs_bars(monkeypatch, tmp_path):
    monkeypatch.setattr(chain, "run", _fake_run)
    monkeypatch.setattr(Console, "is_terminal", property(lambda self: True))
    res = CliRunner().invoke(app, ["reproduce", "--quick", "--out", str(tmp_path / "r")])
    assert res.exit_code == 0, res.output
    assert not _lines(res.output) and "rom: start" not in res.output
    assert "training NFIR(6, 3): epoch 1/3" in res.output and "━" in res.output  # a bar


def test_a_tiny_reproduce_logs_every_stage(tiny_reproduce):
    """The real chain through CliRunner (not a terminal): resumed after its rom stage, then
    rerun with everything cached."""
    texts = [t for _, t in _lines(tiny_reproduce["resumed_log"])]
    for line in ("data: reused (cached)", "rom: reused (cached)", "sweep: start",
                 "maps: start", "beam: start", "report: start"):
        assert line in texts, tiny_reproduce["resumed_log"]
    for stage in ("sweep", "maps", "beam", "report"):
        assert any(re.fullmatch(rf"{stage}: done in \d+\.\d s", t) for t in texts), stage
        starts = [k for k, t in enumerate(texts) if t == f"{stage}: start"]
        ends = [k for k, t in enumerate(texts) if t.startswith(f"{stage}: done")]
        assert len(starts) == len(ends) == 1 and starts[0] < ends[0]
    rerun = [t for _, t in _lines(tiny_reproduce["rerun_log"])]
    assert rerun[:5] == [f"{s}: reused (cached)" for s in ("data", "rom", "maps", "beam")] + [
        "report: start"]


# -- the training's pace -------------------------------------------------------------------------
def test_duration_text():
    assert [duration_text(s) for s in (0.4, 42, 190, 3900)] == [
        "0 s", "42 s", "3 min 10 s", "1 h 05 min"]


def test_time_left_is_the_epochs_left_times_the_median_epoch():
    tp = TrainingProgress(100, unit="N^2")
    assert tp.seconds_left() is None and tp.text() == ""
    # epoch 1 compiles (10 s), the others take 1 s
    for epoch, seconds in [(0, 0.0), (1, 10.0), (2, 11.0), (3, 12.0), (4, 13.0)]:
        tp.epoch(epoch, {"train_mse": 0.5, "val_mse": 0.25, "seconds": seconds})
    assert tp.epoch_seconds() == 1.0
    assert tp.seconds_left() == 96.0
    assert tp.text() == "epoch 4/100, train 0.5, val 0.25 N^2, at most 1 min 36 s left"
    assert (tp.done, tp.total) == (4, 100)
    # an error it does not have (Adam's epoch 0: no training error yet) is left out
    tp.epoch(5, {"train_mse": float("nan"), "val_mse": 0.125, "seconds": 14.0})
    assert tp.text().startswith("epoch 5/100, val 0.125 N^2, at most")


def test_reports_that_skip_epochs_give_the_mean_epoch_between_them():
    pace = EpochPace()
    for epoch, seconds in [(0, 0.0), (4, 8.0), (10, 20.0), (10, 99.0), (12, 24.0)]:
        pace.observe(epoch, seconds)
    assert pace.durations == [2.0, 2.0, 2.0]


def test_an_ensemble_divides_the_epochs_left_among_its_workers():
    tp = TrainingProgress(10, members=3, concurrent=2)
    for m in (0, 1):
        for e in range(3):
            tp.epoch(e, {"train_mse": 1.0, "val_mse": 2.0, "seconds": 2.0 * e}, member=m)
    # (8 + 8 + 10 epochs left) x 2 s over 2 workers
    assert tp.seconds_left() == 26.0
    tp.finished(0)  # stopped early: counts as done
    tp.epoch(9, {"train_mse": 1.0, "val_mse": 2.0, "seconds": 18.0}, member=0)  # late: ignored
    assert tp.seconds_left() == 18.0 and tp.done == 10 + 2
    assert tp.text() == ("1/3 members done; member 1 epoch 2/10, train 1, val 2; "
                         "at most 18 s left")


def test_epoch_files_are_read_by_the_poller(tmp_path):
    writer = EpochFile(str(tmp_path), 2, min_interval=0.0)
    assert writer(3, {"train_mse": 0.1, "val_mse": float("nan"), "seconds": 1.5}) is None
    seen: dict[int, int] = {}
    got = []
    poll_once(tmp_path, seen, lambda k, e, info: got.append((k, e, dict(info))))
    poll_once(tmp_path, seen, lambda k, e, info: got.append((k, e, dict(info))))  # nothing new
    assert len(got) == 1 and got[0][:2] == (2, 3) and got[0][2]["seconds"] == 1.5
    # a worker that cannot write (another machine) loses the progress, not the training
    assert EpochFile(str(tmp_path / "absent"), 0)(1, {"seconds": 1.0}) is None


def test_epoch_files_cross_a_process_boundary(tmp_path):
    got = []
    ctx = multiprocessing.get_context("spawn")
    with epoch_reports(lambda k, e, info: got.append((k, e)), interval=0.05) as d, \
            ProcessPoolExecutor(1, mp_context=ctx) as ex:
        assert ex.submit(EpochFile(d, 1), 7, {"train_mse": 1.0, "seconds": 2.0}).result() is None
    assert got == [(1, 7)]


@pytest.mark.parametrize("scheduler", ["sequential", "threads"])
def test_ensemble_members_report_their_epochs(scheduler):
    from sloshrom.rom.ensemble import Ensemble
    from sloshrom.rom.tdnn.estimators import NFIR

    u, y = smooth_io()
    got = []
    Ensemble(NFIR(delays=3, neurons=4, max_epochs=3), n_members=2).fit(
        u, y, 500.0, validation=smooth_io(600, 2), scheduler=scheduler, n_workers=2,
        epoch_progress=lambda k, e, info: got.append((k, e, set(info))))
    assert {k for k, _, _ in got} == {0, 1}
    assert all(0 <= e <= 3 and {"train_mse", "val_mse", "seconds"} <= keys
               for _, e, keys in got)


@pytest.mark.slow
def test_ensemble_members_in_worker_processes_report_their_epochs():
    from sloshrom.rom.ensemble import Ensemble
    from sloshrom.rom.tdnn.estimators import NFIR

    u, y = smooth_io()
    got = []
    Ensemble(NFIR(delays=3, neurons=4, max_epochs=3), n_members=2).fit(
        u, y, 500.0, validation=smooth_io(600, 2), n_workers=2,  # a new LocalCluster
        epoch_progress=lambda k, e, info: got.append((k, e)))
    assert {k for k, _ in got} == {0, 1}


def _records(tmp_path):
    from sloshrom.io import Record, write_record

    paths = []
    for name, seed, n in (("train", 1, 2000), ("validation", 2, 600)):
        u, y = smooth_io(n, seed)
        rec = Record(np.arange(n) / 500.0, 500.0, {"velocity": u, "dynamic_force": y},
                     {"velocity": "m/s", "dynamic_force": "N"}, {})
        paths.append(write_record(rec, tmp_path / f"{name}.nc"))
    # the paper's plain MSE: the passive recipe's probes would take most of the time
    return ["--data", str(paths[0]), "--validation", str(paths[1]), "--delays", "3",
            "--neurons", "4", "--max-epochs", "3", "--amplitude-weighting", "0",
            "--passivity", "0", "--cycle-energy", "0"]


def test_train_without_a_terminal_logs_the_epochs(tmp_path, monkeypatch):
    res = CliRunner().invoke(app, ["train", *_records(tmp_path), "--out",
                                   str(tmp_path / "m.npz")])
    assert res.exit_code == 0, res.output
    texts = [t for _, t in _lines(res.output)]
    # the epochs came within 30 s of the first line (a slow machine: the heartbeat's lines)
    assert texts[0] == "training NFIR: 0/3", res.output
    assert all(t.startswith(("training NFIR: epoch", "still running")) for t in texts[1:])
    assert "wrote" in res.output
    # every report printed: epoch, errors (their unit) and time left
    monkeypatch.setattr(progress_module, "EVERY", 0.0)
    res = CliRunner().invoke(app, ["train", *_records(tmp_path), "--out",
                                   str(tmp_path / "m2.npz")])
    assert res.exit_code == 0, res.output
    last = [t for _, t in _lines(res.output)][-1]
    assert re.fullmatch(r"training NFIR: epoch 3/3, train [\d.e+-]+, val [\d.e+-]+ N\^2, "
                        r"at most 0 s left", last), res.output


def test_train_ensemble_without_a_terminal_logs_its_members(tmp_path, monkeypatch):
    monkeypatch.setattr(progress_module, "EVERY", 0.0)
    # the members' files polled every 10 ms, not every second: these members train for about
    # a second in all, and a member done before the first poll is reported only as done
    monkeypatch.setattr(ensemble_module, "epoch_reports",
                        functools.partial(epochs_module.epoch_reports, interval=0.01))
    res = CliRunner().invoke(app, ["train", *_records(tmp_path), "--out",
                                   str(tmp_path / "e.npz"), "--ensemble", "2",
                                   "--scheduler", "threads"])
    assert res.exit_code == 0, res.output
    texts = [t for _, t in _lines(res.output)]
    assert texts[0] == "training 2 x NFIR: 0/2", res.output
    assert any(re.fullmatch(r"training 2 x NFIR: 0/2 members done; member \d epoch \d/3, "
                            r"train .*, val .* N\^2(; at most .* left)?", t)
               for t in texts), res.output
    assert "2/2 members done" in texts[-1], res.output
