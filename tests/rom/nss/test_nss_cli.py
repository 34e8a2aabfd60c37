"""`sloshrom train --arch nss` and the commands that take its model file (predict, map,
export onnx): trained on tiny records, a few seconds each."""

from __future__ import annotations

import numpy as np
import pytest
from typer.testing import CliRunner

from helpers import check_cli
from sloshrom.cli import app
from sloshrom.io import Record, read_record, write_record
from sloshrom.rom.loading import load_model
from sloshrom.rom.registry import CLASSES

runner = CliRunner()
#: The smallest state-space ROM: a few Adam steps.
TINY = ["--states", "2", "--neurons", "4", "--window", "5", "--horizon", "20", "--batch", "4",
        "--steps-per-epoch", "2", "--max-epochs", "1"]


def _records(d, fs: float, n: int = 1200):
    """Train and validation records: a smooth random velocity (m/s) and a delayed saturating
    force of it (N), at ``fs``."""
    paths = []
    for split, size, seed in (("train", n, 1), ("validation", n // 3, 2)):
        rng = np.random.default_rng(seed)
        u = np.convolve(rng.standard_normal(size), np.ones(8) / 8, mode="same") * 0.3
        y = 0.5 * np.tanh(5 * np.concatenate([[0.0, 0.0], u[:-2]]))
        rec = Record(np.arange(size) / fs, fs, {"velocity": u, "dynamic_force": y},
                     {"velocity": "m/s", "dynamic_force": "N"}, {})
        paths.append(write_record(rec, d / f"{split}.nc"))
    return paths


@pytest.fixture(scope="module")
def trained(tmp_path_factory):
    """An NSS trained by ``sloshrom train --arch nss`` on 500 Hz records (a rate the maps
    take); its directory, the command's output and the model file."""
    d = tmp_path_factory.mktemp("nss")
    train, val = _records(d, 500.0)
    res = runner.invoke(app, ["train", "--data", str(train), "--validation", str(val),
                              "--arch", "nss", *TINY, "--out", str(d / "nss.npz")])
    assert res.exit_code == 0, res.output
    return {"dir": d, "output": res.output, "model": d / "nss.npz"}


def test_train_nss_writes_a_model_that_loads_as_an_nss(trained):
    out = trained["output"]
    assert "wrote" in out and "NSS(2 states, 4 neurons, strictly proper)" in out
    # the recipe by units is the NSS's (no amplitude weighting), said on one line
    assert ("loss: the passive recipe (amplitude weighting 0 m/s, passivity 1, cycle energy "
            "0.1)") in out
    assert " mu " not in out
    m = load_model(trained["model"])
    assert type(m).__name__ == "NSS"
    assert (m.n_states, m.neurons, m.window, m.horizon, m.batch, m.max_epochs,
            m.steps_per_epoch) == (2, 4, 5, 20, 4, 1, 2)
    assert m.learning_rate == 0.003 and m.fs_ == 500.0
    recipe = dict(CLASSES["nss"].recipe)
    assert dict((k, getattr(m, k)) for k in recipe) == recipe


def test_predict_with_an_nss_file(trained, tmp_path):
    d = trained["dir"]
    out = tmp_path / "pred.nc"
    res = runner.invoke(app, ["predict", "--model", str(trained["model"]), "--data",
                              str(d / "validation.nc"), "--out", str(out)])
    assert res.exit_code == 0, res.output
    rec = read_record(out)
    y = load_model(trained["model"]).predict(rec["velocity"])
    np.testing.assert_array_equal(rec["dynamic_force_pred"], y)
    assert "MSE" in res.output


def test_map_with_an_nss_file(trained, tmp_path):
    res = runner.invoke(app, ["map", "--model", str(trained["model"]), "--n-omega", "2",
                              "--n-a", "2", "--out", str(tmp_path / "m.nc")])
    assert res.exit_code == 0, res.output
    assert (tmp_path / "m.nc").is_file() and (tmp_path / "m.png").is_file()


@pytest.mark.filterwarnings("ignore::UserWarning")  # the beam leaves the tiny envelope
def test_beam_with_an_nss_file(trained, tmp_path):
    res = runner.invoke(app, ["beam", "free", "--sloshing", str(trained["model"]),
                              "--duration", "2", "--out", str(tmp_path / "beam")])
    assert res.exit_code == 0, res.output
    assert list((tmp_path / "beam").glob("*.nc"))


@pytest.mark.long  # 3.2-3.5 s in the fast tier under load
def test_loss_options_set_the_nss_terms(tmp_path):
    train, val = _records(tmp_path, 100.0)
    res = runner.invoke(app, ["train", "--data", str(train), "--validation", str(val),
                              "--arch", "nss", *TINY, "--amplitude-weighting", "0.05",
                              "--ensemble", "2", "--workers", "1",
                              "--out", str(tmp_path / "ens.npz")])
    assert res.exit_code == 0, res.output
    assert "amplitude_weighting 0.05, passivity 1, cycle_energy 0.1" in res.output
    assert "ensemble of 2 NSS(2 states, 4 neurons, strictly proper)" in res.output
    ens = load_model(tmp_path / "ens.npz")
    assert [m.amplitude_weighting for m in ens.members_] == [0.05, 0.05]
    assert [m.seed for m in ens.members_] == [0, 1]


def test_the_nss_recipe_applies_to_a_velocity_in_and_a_force_out():
    from dataclasses import replace

    from sloshrom.rom.registry import CLASSES, LOSS_TERMS

    nss = CLASSES["nss"]
    passive = nss.passive_recipe("m/s", "N")
    assert passive.passive and passive.terms == dict(nss.recipe)
    assert passive.terms["amplitude_weighting"] == 0.0 and passive.terms["passivity"] == 1.0
    assert not nss.passive_recipe("N", "m").passive
    assert nss.passive_recipe("N", "m").terms == dict.fromkeys(LOSS_TERMS, 0.0)
    # a recipe of zeros is the plain MSE, and says why
    off = replace(nss, recipe=dict.fromkeys(LOSS_TERMS, 0.0)).passive_recipe("m/s", "N")
    assert not off.passive and "sets no loss term" in off.why
    weights = {"amplitude_weighting": 0.1, "passivity": 2.0, "cycle_energy": 0.0}
    chosen = replace(nss, recipe=weights).passive_recipe("m/s", "N")
    assert chosen.passive and chosen.terms == weights


TR = ["train", "--data", "{tmp}/train.nc", "--validation", "{tmp}/validation.nc",
      "--out", "{tmp}/m.npz"]


@pytest.mark.parametrize(("argv", "match"), [
    ([*TR, "--arch", "nss", "--delays", "4"],
     r"--delays does not apply to --arch nss \(NSS: a neural state-space model.*\); its options "
     r"are --n-states, --neurons, --window, --horizon"),
    ([*TR, "--arch", "nss", "--hidden", "matlab"], r"--hidden does not apply to --arch nss"),
    ([*TR, "--arch", "nss", "--trainer", "adam"], r"--trainer does not apply to --arch nss"),
    # --states: the former name of --n-states, still read
    ([*TR, "--arch", "nss", "--states", "0"],
     r"--n-states must be an integer in \[1, 1024\], got 0"),
    ([*TR, "--arch", "nss", "--n-states", "0"],
     r"--n-states must be an integer in \[1, 1024\], got 0"),
    ([*TR, "--arch", "nss", "--horizon", "7"],
     r"--horizon must be an integer in \[8, 10000\], got 7"),
    ([*TR, "--arch", "nss", "--learning-rate", "0"],
     r"--learning-rate must be a number in \(0, 1\]"),
    ([*TR, "--arch", "nss", "--batch", "100000"], r"--batch must be an integer in \[1, 65536\]"),
    ([*TR, "--arch", "nss", "--steps-per-epoch", "0"],
     r"--steps-per-epoch must be an integer in \[1, "),
    ([*TR, "--arch", "nss", "--input", "acceleration"],
     r"--input acceleration: an NSS takes the tank velocity; the acceleration needs --arch "
     r"nfir"),
    ([*TR, "--n-states", "3"], r"--n-states does not apply to --arch nfir \(NFIR: .*\); its "
                               r"options are --delays, --neurons"),
    ([*TR, "--arch", "noe", "--window", "3"], r"--window does not apply to --arch noe"),
    # (the size not given is the size rule's for 1200 samples: 4 states, 17 neurons; m/s in
    # and N out: reproduce's recipe, strictly proper)
    ([*TR, "--arch", "nss", "--window", "1000", "--horizon", "200"],
     r"train\.nc: 1200 samples are too few for NSS\(4 states, 17 neurons, strictly proper\) "
     r"\(training "
     r"needs at least 1201\)"),
    ([*TR, "--arch", "nss", "--window", "500", "--horizon", "20"],
     r"validation\.nc: 400 samples are too few for 500 samples of history \(NSS\(4 states, "
     r"17 neurons, strictly proper\)\)"),
    ([*TR, "--arch", "nss", "--n-states", "8", "--neurons", "4096", "--window", "4096"],
     r"NSS\(8 states, 4096 neurons, strictly proper\) has \d+ weights, more than 4194304"),
    ([*TR, "--arch", "nss", "--passivity", "-1"],
     r"--passivity must be a number in \[0, 1e\+12\], got -1"),
])
def test_bad_nss_options_fail_clearly_and_write_nothing(tmp_path, argv, match):
    check_cli(tmp_path, tmp_path, lambda d: _records(d, 100.0), argv, match)


def test_export_onnx_refuses_an_nss(trained, tmp_path):
    import shutil

    shutil.copy(trained["model"], tmp_path / "nss.npz")
    check_cli(tmp_path, tmp_path, None, ["export", "onnx", "{tmp}/nss.npz", "{tmp}/nss.onnx"],
              r"an NSS \(\d+ states, \d+ neurons\) cannot be exported to ONNX: a graph holds "
              r"one NFIR or NOE network; a state-space ROM's step graph would need its state "
              r"as input and output, which is not implemented. Export it as an FMU")
