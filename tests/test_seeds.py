"""A Levenberg-Marquardt stop at mu_max says why and what to try (history, warning, `train`'s
final line); `train --seeds N` keeps the best of N seeds on validation
(:meth:`Ensemble.best_member`); the members' validation spread for every class with members."""

from __future__ import annotations

import math
import re
import warnings

import numpy as np
import pytest
from scipy import signal
from typer.testing import CliRunner

from helpers import check_cli, smooth_io
from sloshrom.cli import app
from sloshrom.io import Record, write_record
from sloshrom.limits import MAX_SEED, MU_MAX
from sloshrom.rom.ensemble import Ensemble
from sloshrom.rom.errors import ROMError, TrainingWarning, UnstableModelError
from sloshrom.rom.lm import LMProblem, levenberg_marquardt, stop_message
from sloshrom.rom.loading import load_model
from sloshrom.rom.tdnn.estimators import NFIR, NOE

runner = CliRunner()
FS = 500.0
#: An NOE seed whose closed loop explodes on the resonant record at its initialisation: its
#: J^T J is ~1e58, beyond any damping, so LM stops at mu_max in epoch 1 (measured: seeds 1-4
#: of 0-4 stop at mu_max within 3 epochs; seed 0 stops on validation)
STUCK_SEED = 2


def resonant_io(n: int, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """A short record of a saturating resonance: a 3 Hz, 5 %-damped oscillator driven by a
    low-passed random velocity (m/s), its force ``30 tanh(3 x / std x)`` (N), at 500 Hz."""
    rng = np.random.default_rng(seed)
    u = signal.lfilter(*signal.butter(2, 5 / (FS / 2)), rng.standard_normal(n)) * 0.5
    u[:20] = 0.0
    w, z = 2 * np.pi * 3, 0.05
    b, a, _ = signal.cont2discrete(([w**2], [1, 2 * z * w, w**2]), 1 / FS)
    x = signal.lfilter(np.ravel(b), a, u)
    return u, 30 * np.tanh(3 * x / np.std(x))


def _write(d, name, u, y):
    rec = Record(np.arange(u.size) / FS, FS, {"velocity": u, "dynamic_force": y},
                 {"velocity": "m/s", "dynamic_force": "N"}, {})
    return write_record(rec, d / f"{name}.nc")


@pytest.fixture(scope="module")
def resonant(tmp_path_factory):
    """Training (1000 samples) and validation (600) records of :func:`resonant_io`."""
    d = tmp_path_factory.mktemp("resonant")
    return _write(d, "train", *resonant_io(1000, 1)), _write(d, "validation",
                                                              *resonant_io(600, 2))


@pytest.fixture(scope="module")
def smooth(tmp_path_factory):
    """Training (2000 samples) and validation (600) records of ``helpers.smooth_io``."""
    d = tmp_path_factory.mktemp("smooth")
    return _write(d, "train", *smooth_io(2000, 1)), _write(d, "validation", *smooth_io(600, 2))


# -- Levenberg-Marquardt's stop at mu_max ------------------------------------------------------


def _problem(normal, sse):
    return LMProblem(lambda x: (*normal(x), 4), sse)


def test_mu_max_stop_info_counts_what_every_trial_step_did():
    eye = np.eye(2)
    # every trial unstable (training error inf)
    res = levenberg_marquardt(_problem(lambda x: (eye, np.ones(2), 1.0), lambda x: math.inf),
                              np.zeros(2))
    info = res.stop_info
    assert res.stop_reason == "mu_max" and info["epoch"] == 1 and info["mu_max"] == MU_MAX
    # mu = 1e-3, 1e-2, ..., 1e10: 14 trials, all non-finite
    assert (info["trials"], info["not_finite"], info["not_solved"], info["worse"]) == (14, 14,
                                                                                        0, 0)
    assert "All 14 trial steps gave a non-finite training error" in stop_message(info)
    # J^T J so large that mu_max is below its rounding, and indefinite: nothing can be solved
    huge = np.diag([1e40, -1e40])
    res = levenberg_marquardt(_problem(lambda x: (huge, np.ones(2), 1.0), lambda x: 0.0),
                              np.zeros(2))
    info = res.stop_info
    assert (info["not_solved"], info["not_finite"], info["worse"]) == (14, 0, 0)
    assert info["jtj_max"] == 1e40 and math.isnan(info["shortest_step"])
    text = stop_message(info)
    assert "None of the 14 trial steps could be solved" in text
    assert "even mu_max is below its rounding error" in text
    assert "the last parameters are kept (no validation record)" in text
    # every step, however short, raises the error: the shortest step is the last one's
    res = levenberg_marquardt(_problem(lambda x: (eye, np.ones(2), 1.0), lambda x: 2.0),
                              np.zeros(2))
    info = res.stop_info
    assert (info["worse"], info["not_solved"], info["not_finite"]) == (14, 0, 0)
    # the step at mu = 1e10: (1 + mu)^-1 (1, 1), derived, not measured
    assert info["shortest_step"] == pytest.approx(math.sqrt(2) / (1 + 1e10), rel=1e-9)
    assert "All 14 trial steps raised it, down to the shortest step" in stop_message(info)


def test_other_stops_carry_no_stop_info():
    A, b = np.eye(3), np.ones(3)
    prob = LMProblem(lambda x: (A, A @ x - b, float((A @ x - b) @ (A @ x - b)), 3),
                     lambda x: float((A @ x - b) @ (A @ x - b)))
    res = levenberg_marquardt(prob, np.zeros(3))
    assert res.stop_reason == "min_grad" and res.stop_info == {}


def test_noe_stuck_at_mu_max_warns_why_and_keeps_it_in_its_file(tmp_path):
    u, y = resonant_io(1000, 1)
    with pytest.warns(TrainingWarning) as rec:
        m = NOE(seed=STUCK_SEED, max_epochs=50).fit(u, y, FS, validation=resonant_io(600, 2))
    h = m.history_
    assert h["stop_reason"] == "mu_max"
    msg = str(rec[0].message)
    assert msg == h["stop_message"]
    assert re.match(r"Levenberg-Marquardt stopped at epoch \d+: its damping mu passed mu_max = "
                    r"1e10 \(MATLAB trainlm's 'Maximum MU reached'\)", msg), msg
    assert f"epoch {len(h['train_mse']) - 1}:" in msg  # the epoch that failed, the last one
    assert "The NOE's derivatives run through its fed-back outputs" in msg
    assert "Try trainer 'adam' (multiple shooting on short sub-sequences)" in msg
    loaded = load_model(m.save(tmp_path / "stuck.npz"))
    assert loaded.history_["stop_message"] == msg


def test_a_normal_stop_does_not_warn():
    u, y = smooth_io(1000, 1)
    with warnings.catch_warnings():
        warnings.simplefilter("error", TrainingWarning)
        m = NOE(delays=2, neurons=3, max_epochs=5).fit(u, y, FS, validation=smooth_io(600, 2))
    assert m.history_["stop_reason"] != "mu_max" and "stop_message" not in m.history_


def test_train_says_why_it_stopped_at_mu_max_and_what_to_try(resonant, tmp_path):
    train, val = resonant
    res = runner.invoke(app, ["train", "--data", str(train), "--validation", str(val),
                              "--arch", "noe", "--seed", str(STUCK_SEED), "--max-epochs", "50",
                              "--out", str(tmp_path / "noe.npz")])
    assert res.exit_code == 0, res.output
    last = res.output.strip().splitlines()[-1]
    assert last.startswith(f"wrote {tmp_path / 'noe.npz'}: NOE(2, 10)"), last
    assert re.search(r"\(mu_max\).*; stopped: Levenberg-Marquardt's damping mu passed mu_max = "
                     r"1e10 at epoch \d+, no step lowered the training error \(why: the "
                     r"warning above\); try --trainer adam, fewer --neurons or --delays, or "
                     r"other seeds \(--seeds N keeps the best of N\)$", last), last
    warning = [ln for ln in res.output.splitlines() if ln.startswith("warning:")]
    assert len(warning) == 1 and "Levenberg-Marquardt stopped at epoch" in warning[0]


def test_train_says_nothing_of_mu_max_after_a_normal_stop(smooth, tmp_path):
    train, val = smooth
    res = runner.invoke(app, ["train", "--data", str(train), "--validation", str(val),
                              "--arch", "noe", "--delays", "2", "--neurons", "3",
                              "--max-epochs", "3", "--out", str(tmp_path / "noe.npz")])
    assert res.exit_code == 0, res.output
    assert "mu_max" not in res.output and "stopped:" not in res.output
    assert "warning:" not in res.output


@pytest.mark.parametrize("scheduler", ["sequential", "threads"])
def test_an_ensemble_warns_once_for_its_members_stuck_at_mu_max(scheduler):
    u, y = resonant_io(1000, 1)
    ens = Ensemble(NOE(seed=STUCK_SEED - 1, max_epochs=50), n_members=2)
    before = list(warnings.filters)
    with pytest.warns(TrainingWarning) as rec:
        ens.fit(u, y, FS, validation=resonant_io(600, 2), scheduler=scheduler, n_workers=2)
    # the members' own warnings filtered in this thread only, and the filter restored
    assert warnings.filters == before
    stuck = [m.seed for m in ens.members_ if m.history_["stop_reason"] == "mu_max"]
    assert STUCK_SEED in stuck
    ours = [w for w in rec if w.category is TrainingWarning]
    assert len(ours) == 1, [str(w.message) for w in ours]
    text = str(ours[0].message)
    assert text.startswith(f"{len(stuck)} of 2 members (seed") and str(STUCK_SEED) in text


def test_members_quiet_is_the_ensembles_context_only():
    """An ensemble training its members in this process quiets their TrainingWarning through a
    context variable, not the process's warnings filter: a model stuck at mu_max that another
    thread trains meanwhile (as the rom stage trains its compared classes beside the members)
    still says so."""
    import threading

    from sloshrom.rom.errors import members_quiet

    u, y = resonant_io(1000, 1)
    val = resonant_io(600, 2)

    def fit():
        return NOE(seed=STUCK_SEED, max_epochs=50).fit(u, y, FS, validation=val)

    beside = []
    with pytest.warns(TrainingWarning) as rec:
        token = members_quiet.set(True)
        try:
            quiet = fit()  # a member: quiet in this context
            t = threading.Thread(target=lambda: beside.append(fit()))
            t.start()
            t.join()
        finally:
            members_quiet.reset(token)
    ours = [w for w in rec if w.category is TrainingWarning]
    assert len(ours) == 1, [str(w.message) for w in ours]  # the thread's model's
    assert quiet.history_["stop_reason"] == beside[0].history_["stop_reason"] == "mu_max"


# -- the best of N seeds -------------------------------------------------------------------------


@pytest.fixture(scope="module")
def three_seeds():
    u, y = smooth_io()
    return Ensemble(NFIR(delays=3, neurons=4, max_epochs=3, seed=5), n_members=3).fit(
        u, y, FS, validation=smooth_io(600, 2), scheduler="sequential")


def test_member_errors_are_each_members_free_run_mse(three_seeds):
    uv, yv = smooth_io(600, 2)
    errors = three_seeds.member_errors(uv, yv)
    assert errors.shape == (3,)
    for e, m in zip(errors, three_seeds.members_, strict=True):
        assert e == pytest.approx(np.mean((m.predict(uv) - yv) ** 2), rel=1e-12)
    best = three_seeds.best_member(uv, yv)
    assert best is three_seeds.members_[int(np.argmin(errors))]
    assert best.seed == three_seeds.seeds_[int(np.argmin(errors))]
    with pytest.raises(ROMError, match=r"u and y must be records of the same length"):
        three_seeds.member_errors(uv, yv[:-1])


def test_an_unstable_member_is_never_the_best(three_seeds, monkeypatch):
    uv, yv = smooth_io(600, 2)
    errors = three_seeds.member_errors(uv, yv)
    first = int(np.argmin(errors))

    def unstable(self, u, history=None):
        raise UnstableModelError("left its bound")

    monkeypatch.setattr(three_seeds.members_[first], "predict", unstable.__get__(
        three_seeds.members_[first]))
    again = three_seeds.member_errors(uv, yv)
    assert math.isnan(again[first])
    assert three_seeds.best_member(uv, yv) is three_seeds.members_[int(np.nanargmin(again))]
    for m in three_seeds.members_:
        monkeypatch.setattr(m, "predict", unstable.__get__(m))
    with pytest.raises(ROMError, match=r"all 3 members are unstable on this record"):
        three_seeds.best_member(uv, yv)


def _tiny_seeds(train, val, out, *extra: str) -> list[str]:
    """``train --seeds 2`` of a tiny NFIR on the plain MSE, in threads."""
    return ["train", "--data", str(train), "--validation", str(val), "--delays", "3",
            "--neurons", "4", "--max-epochs", "2", "--seeds", "2", "--scheduler", "threads",
            "--amplitude-weighting", "0", "--passivity", "0", "--cycle-energy", "0",
            "--out", str(out), *extra]


def test_train_seeds_writes_the_best_single_model(smooth, tmp_path):
    train, val = smooth
    out = tmp_path / "best.npz"
    res = runner.invoke(app, _tiny_seeds(train, val, out, "--seed", "3"))
    assert res.exit_code == 0, res.output
    printed = {int(s): float(e) for s, e in
               re.findall(r"^seed (\d+): validation MSE ([\d.e+-]+) N\^2", res.output, re.M)}
    assert sorted(printed) == [3, 4]
    # the same seeds trained one by one: the file holds the one best on validation
    u, y = smooth_io(2000, 1)
    uv, yv = smooth_io(600, 2)
    mse = {}
    for s in (3, 4):
        # as train: [rom.nfir]'s float32 steps
        m = NFIR(delays=3, neurons=4, max_epochs=2, seed=s, precision="float32").fit(
            u, y, FS, validation=(uv, yv))
        mse[s] = float(np.mean((m.predict(uv) - yv) ** 2))
        # printed with 4 significant digits
        assert printed[s] == pytest.approx(mse[s], rel=5e-4)
    best = load_model(out)
    assert type(best) is NFIR and best.seed == min(mse, key=mse.get)
    assert np.mean((best.predict(uv) - yv) ** 2) == pytest.approx(mse[best.seed], rel=1e-9)
    vals = sorted(mse.values())
    spread = re.search(r"validation MSE over 2 seeds: ([\d.e+-]+) \+- ([\d.e+-]+) N\^2, min "
                       r"([\d.e+-]+) \(seed (\d+)\), max ([\d.e+-]+) \(seed (\d+)\), max/min "
                       r"([\d.e+-]+)", res.output)
    assert spread, res.output
    assert float(spread[1]) == pytest.approx(np.mean(vals), rel=5e-4)
    assert float(spread[2]) == pytest.approx(np.std(vals, ddof=1), rel=5e-4)
    assert int(spread[4]) == best.seed and float(spread[7]) == pytest.approx(
        vals[-1] / vals[0], rel=5e-3)
    assert f"seed {best.seed} (the best of 2 on validation)" in res.output.splitlines()[-1]


TR = ["train", "--data", "{tmp}/train.nc", "--validation", "{tmp}/validation.nc",
      "--out", "{tmp}/m.npz"]


def _records(d):
    _write(d, "train", *smooth_io(2000, 1))
    _write(d, "validation", *smooth_io(600, 2))


@pytest.mark.parametrize(("argv", "match"), [
    ([*TR, "--seeds", "3", "--ensemble", "2"],
     r"--seeds 3 with --ensemble 2: --seeds keeps the best single model, --ensemble the mean "
     r"of all; give one of them"),
    ([*TR, "--arch", "lss", "--seeds", "2"],
     r"--seeds 2: an LSS is fitted deterministically, so every seed gives the same model"),
    ([*TR, "--seeds", "0"], r"--seeds must be in \[1, 64\], got 0"),
    ([*TR, "--seed", str(MAX_SEED), "--seeds", "2"],
     rf"--seed {MAX_SEED} with --seeds 2: the last seed {MAX_SEED + 1} exceeds {MAX_SEED}"),
])
def test_bad_seeds_options_fail_clearly_and_write_nothing(tmp_path, argv, match):
    check_cli(tmp_path, tmp_path, _records, argv, match)


# -- the members' validation spread, for every class with members ---------------------------------

NSS_TINY = ["--states", "2", "--neurons", "4", "--window", "5", "--horizon", "20", "--batch",
            "4", "--steps-per-epoch", "2", "--max-epochs", "1"]


@pytest.mark.parametrize("argv", [
    ["--arch", "noe", "--delays", "2", "--neurons", "3", "--max-epochs", "2"],
    # two NSS compilations and trainings: 12-20 s on a busy machine
    pytest.param(["--arch", "nss", *NSS_TINY], marks=pytest.mark.slow),
], ids=["noe", "nss"])
def test_train_ensemble_prints_the_members_spread_for_every_class(smooth, tmp_path, argv):
    train, val = smooth
    res = runner.invoke(app, ["train", "--data", str(train), "--validation", str(val), *argv,
                              "--ensemble", "2", "--scheduler", "threads",
                              "--out", str(tmp_path / "e.npz")])
    assert res.exit_code == 0, res.output
    printed = [float(e) for e in re.findall(r"^member \d \(seed \d\): validation MSE "
                                            r"([\d.e+-]+) N\^2", res.output, re.M)]
    assert len(printed) == 2, res.output
    ens = load_model(tmp_path / "e.npz")
    uv, yv = smooth_io(600, 2)
    # the whole validation record's MSE of each member's free run
    np.testing.assert_allclose(printed, ens.member_errors(uv, yv), rtol=5e-4)
    last = res.output.strip().splitlines()[-1]
    assert re.search(r"validation MSE over members [\d.e+-]+ \+- [\d.e+-]+ N\^2, min .* max "
                     r".* max/min [\d.e+-]+; of the ensemble mean", last), last


def test_spread_text_gives_mean_std_min_max_and_their_ratio():
    from sloshrom.rom.ensemble import spread_text

    assert spread_text([1.0, 3.0], "N²") == "2 ± 1.41 N² (min 1, max 3, max/min 3)"
    assert spread_text([2.0, float("nan"), 4.0], "N²").endswith(", 1 member without a value")
    assert spread_text([float("nan")], "N²") == "n/a"


def test_the_fill_study_reports_the_spread_of_an_ensemble_member(tmp_path):
    """[beyond] fill_ensemble > 1 trains an ensemble at every fill: its members' spread is in
    the section, as the main ROM's is in the validation section."""
    from types import SimpleNamespace

    from sloshrom.studies.fills.config import FILL_TARGETS
    from sloshrom.studies.fills.outputs import FillsOutputs
    from sloshrom.studies.fills.section import fills_section

    members = {"50": {"model": "m.npz", "main_rom": True},
               "25": {"model": "f.npz", "main_rom": False, "reused": False,
                      "train_seconds": 12.0, "val_fit": 80.0,
                      "val_mse_members": {"mean": 2.0, "std": 1.0, "n": 2,
                                          "values": [1.0, 3.0]}},
               "75": {"model": "g.npz", "main_rom": False, "reused": False,
                      "train_seconds": 11.0, "val_fit": 81.0, "val_mse_members": None}}
    o = FillsOutputs(fills=[0.25, 0.5, 0.75], unseen_fills=[], targets=dict(FILL_TARGETS),
                     members=members, family="fills/family.toml", maps=[], damping=[],
                     beam_errors=[], seconds={"members": 23.0, "maps": 1.0, "beam": 1.0})
    text = fills_section(SimpleNamespace(out=tmp_path), o).text
    assert ("25 % (trained in 12 s; validation MSE of its 2 networks 2 ± 1.41 N² (min 1, max "
            "3, max/min 3))") in text, text
    assert "75 % (trained in 11 s)" in text and "50 % (the main ROM)" in text


@pytest.mark.filterwarnings("ignore::UserWarning")
def test_reproduce_reports_the_spread_of_an_noe_ensemble(tiny_reproduce, tmp_path):
    """The rom stage with ``rom.ensemble = 2`` of a class other than the tiny run's NFIR: the
    members' validation MSE (each one's free run over the whole validation record) in the
    summary and in the report."""
    import shutil

    from sloshrom.io import read_record
    from sloshrom.pipeline import Context
    from sloshrom.pipeline.chain import identify
    from sloshrom.pipeline.report import build_sections

    out = tmp_path / "results"
    shutil.copytree(tiny_reproduce["out"], out)
    cfg = tiny_reproduce["cfg"].replace(rom={
        "arch": "noe", "ensemble": 2, "ensemble_workers": 1, "compare": [],
        "noe": {"delays": 2, "neurons": 2, "max_epochs": 2}})
    ctx = Context(out, cfg)
    results = identify(ctx)
    r = results["rom"].outputs
    assert r["n_members"] == 2 and len(r["stop_message"]) == 2
    ens = load_model(out / r["model"])
    val = read_record(out / "data" / "validation.nc")
    np.testing.assert_allclose(r["val_mse_members"]["values"],
                               ens.member_errors(val["velocity"], val["dynamic_force"]),
                               rtol=1e-12)
    stages = {**tiny_reproduce["rerun"]["stages"],
              **{k: {"reused": v.reused, **v.outputs} for k, v in results.items()}}
    section = next(s for s in build_sections(ctx, {"stages": stages})
                   if s.title.startswith("4. Validation"))
    assert ("Validation MSE of the members (each one's free run over the whole validation "
            "record): ") in section.text
    assert re.search(r"\(min [\d.e+-]+, max [\d.e+-]+, max/min [\d.e+-]+\) \(mean ± std\)",
                     section.text), section.text


def test_quiet_worker_ignores_a_category_in_a_worker_process_only(monkeypatch):
    import os

    from sloshrom.rom import parallel

    with warnings.catch_warnings():
        before = list(warnings.filters)
        parallel.quiet_worker(None, TrainingWarning)
        parallel.quiet_worker(os.getpid(), TrainingWarning)  # the caller's own process
        assert warnings.filters == before
        me = os.getpid()
        monkeypatch.setattr(parallel.os, "getpid", lambda: me + 1)  # as in a Dask worker
        parallel.quiet_worker(me, TrainingWarning)
        assert warnings.filters[0][:3] == ("ignore", None, TrainingWarning)


def test_train_seeds_scores_after_the_validation_history(smooth, tmp_path):
    """With --history N every seed's run starts from the validation record's first N samples
    and is scored after them, as its early stopping was."""
    train, val = smooth
    out = tmp_path / "best.npz"
    res = runner.invoke(app, _tiny_seeds(train, val, out, "--history", "10"))
    assert res.exit_code == 0, res.output
    assert "validation MSE (after 10 samples of history) over 2 seeds:" in res.output
    best = load_model(out)
    uv, yv = smooth_io(600, 2)
    mse = float(np.mean((best.predict(uv[10:], history=(uv[:10], yv[:10])) - yv[10:]) ** 2))
    printed = float(re.search(rf"^seed {best.seed}: validation MSE ([\d.e+-]+) N\^2",
                              res.output, re.M)[1])
    assert printed == pytest.approx(mse, rel=5e-4)
