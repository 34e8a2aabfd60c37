"""The rom stage trains the compared classes in a thread beside the ROM's members (which train
one after the other in the stage's process, or in worker processes while it waits): the same
models as trained alone, one progress line that says both, and a failure of the members that
stops the comparison."""

from __future__ import annotations

import shutil
import threading

import numpy as np
import pytest

from sloshrom.io import read_record
from sloshrom.pipeline import Context
from sloshrom.pipeline import rom as rom_stage
from sloshrom.pipeline.chain import identify
from sloshrom.rom.ensemble import Ensemble

#: two NOE members and the compared NFIR, the smallest that train in a few seconds
TINY = {"arch": "noe", "ensemble": 2, "compare": ["nfir"],
        "noe": {"delays": 2, "neurons": 2, "max_epochs": 2},
        "nfir": {"max_epochs": 3}}


class InProcess(Ensemble):
    """The members in two threads of this process (no cluster for a test), as the stage's
    LocalCluster would: the stage's thread waits meanwhile."""

    def fit(self, *args, **kw):  # type: ignore[override]
        kw["scheduler"] = "threads"
        return super().fit(*args, **kw)


@pytest.fixture
def made(monkeypatch) -> list:
    """Every estimator the rom stage makes, in order (the compared NFIR is the last)."""
    made: list = []
    real = rom_stage.estimator

    def spied(*args, **kw):
        made.append(real(*args, **kw))
        return made[-1]

    monkeypatch.setattr(rom_stage, "estimator", spied)
    return made


def _rom_stage(tiny_reproduce, out, ensemble_workers):
    """The rom stage of :data:`TINY` rerun on a copy of the tiny run in ``out``: its context,
    outputs and every progress text."""
    lines: list[str] = []
    shutil.copytree(tiny_reproduce["out"], out)
    cfg = tiny_reproduce["cfg"].replace(rom={**TINY, "ensemble_workers": ensemble_workers})
    ctx = Context(out, cfg, progress=lambda stage, done, total, text: lines.append(text))
    return ctx, identify(ctx)["rom"].outputs, lines


@pytest.mark.filterwarnings("ignore::UserWarning")
@pytest.mark.long
def test_compared_classes_beside_the_members_are_the_ones_trained_alone(
        tiny_reproduce, tmp_path, monkeypatch):
    monkeypatch.setattr(rom_stage, "Ensemble", InProcess)
    ctx, beside, lines = _rom_stage(tiny_reproduce, tmp_path / "beside", ensemble_workers=2)
    out, cfg = ctx.out, ctx.cfg
    assert any("training 2 x NOE" in t and "; beside it, training NFIR" in t for t in lines), \
        lines
    # one arithmetic, whichever thread runs it: the same weights, so the same errors
    train, val = (read_record(out / "data" / f"{k}.nc") for k in ("train", "validation"))
    alone = rom_stage.estimator(cfg.rom, "nfir", ctx.tank).fit(
        train["velocity"], train["dynamic_force"], fs=train.fs,
        validation=(val["velocity"], val["dynamic_force"]), fill=train.attrs.get("fill"))
    mse = rom_stage.error_figures(val["dynamic_force"], alone.predict(val["velocity"]))["mse"]
    assert beside["compare"]["nfir"]["val_mse"] == mse


@pytest.mark.filterwarnings("ignore::UserWarning")
@pytest.mark.long
def test_members_one_after_the_other_in_this_process_have_the_compared_classes_beside(
        tiny_reproduce, tmp_path):
    """``ensemble_workers = 1`` (the default): the members train one after the other in the
    stage's process, and the compared classes in a thread beside them, not after them."""
    _, r, lines = _rom_stage(tiny_reproduce, tmp_path / "sequential", ensemble_workers=1)
    assert r["n_members"] == 2 and set(r["compare"]) == {"nfir"}
    assert any("training 2 x NOE" in t and "; beside it, training NFIR" in t for t in lines), \
        lines


@pytest.mark.filterwarnings("ignore::UserWarning")
def test_a_failure_of_the_members_stops_the_comparison(tiny_reproduce, tmp_path, monkeypatch,
                                                       made):
    """The members' error reaches the caller, and the compared class stops at its next epoch
    instead of training on to its max_epochs (an interrupted run does not hang); while the
    members say nothing, the progress line shows the compared class's epochs."""
    epochs: list[int] = []
    running = threading.Event()

    class Failing(Ensemble):
        def fit(self, *args, started=None, **kw):  # type: ignore[override]
            started()
            # members that report nothing (a grey box's search): the line still says what
            # trains beside them
            running.wait(60)
            raise RuntimeError("a member failed")

    def progress(stage, done, total, text):
        beside = text.partition("; beside it, ")[2]
        if beside.startswith("training NFIR") and "epoch" in beside:
            epochs.append(int(beside.split("epoch ")[1].split("/")[0]))
            running.set()

    monkeypatch.setattr(rom_stage, "Ensemble", Failing)
    many = {**TINY, "nfir": {"max_epochs": 5000}}
    out = tmp_path / "failing"
    shutil.copytree(tiny_reproduce["out"], out)
    cfg = tiny_reproduce["cfg"].replace(rom={**many, "ensemble_workers": 2})
    with pytest.raises(RuntimeError, match="a member failed"):
        identify(Context(out, cfg, progress=progress))
    assert running.is_set()
    nfir = made[-1]
    assert type(nfir).__name__ == "NFIR"
    assert nfir.history_["stop_reason"] == "callback", nfir.history_["stop_reason"]
    assert 0 < len(epochs) and np.all(np.diff(epochs) >= 0)


@pytest.mark.filterwarnings("ignore::UserWarning")
def test_the_rom_is_validated_while_the_compared_classes_train(tiny_reproduce, tmp_path,
                                                                monkeypatch):
    """The stage validates its ROM (files, predictions, the frame test, the rig's twin run)
    without waiting for the compared classes, which go on in their thread: here they cannot
    end before the ROM is validated."""
    monkeypatch.setattr(rom_stage, "Ensemble", InProcess)
    validated = threading.Event()
    train_compared, validate = rom_stage._train_compared, rom_stage._validate

    def compared_after_the_validation(*args, **kw):
        trained = train_compared(*args, **kw)
        assert validated.wait(60), "the stage waited for the compared classes before the ROM"
        return trained

    def validating(*args, **kw):
        done = validate(*args, **kw)
        validated.set()
        return done

    monkeypatch.setattr(rom_stage, "_train_compared", compared_after_the_validation)
    monkeypatch.setattr(rom_stage, "_validate", validating)
    out = tmp_path / "validated"
    shutil.copytree(tiny_reproduce["out"], out)
    cfg = tiny_reproduce["cfg"].replace(rom={**TINY, "ensemble_workers": 2})
    outputs = identify(Context(out, cfg))["rom"].outputs
    assert np.isfinite(outputs["val_fit"]) and np.isfinite(outputs["compare"]["nfir"]["val_fit"])
    assert (out / outputs["model"]).is_file() and (out / "models" / "nfir.npz").is_file()


@pytest.mark.filterwarnings("ignore::UserWarning")
def test_a_failed_validation_stops_the_comparison(tiny_reproduce, tmp_path, monkeypatch, made):
    def failing(*args, **kw):
        raise RuntimeError("the validation failed")

    monkeypatch.setattr(rom_stage, "Ensemble", InProcess)
    monkeypatch.setattr(rom_stage, "_validate", failing)
    out = tmp_path / "failing"
    shutil.copytree(tiny_reproduce["out"], out)
    cfg = tiny_reproduce["cfg"].replace(rom={**TINY, "nfir": {"max_epochs": 5000},
                                             "ensemble_workers": 2})
    with pytest.raises(RuntimeError, match="the validation failed"):
        identify(Context(out, cfg))
    nfir = made[-1]
    assert type(nfir).__name__ == "NFIR"
    assert nfir.history_["stop_reason"] == "callback", nfir.history_["stop_reason"]
