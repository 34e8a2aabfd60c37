"""The seam of a model class: a toy class defined outside ``src/`` (``tests/toyrom``: its entry,
fitted model and estimator) and added by the public hook ``registry.register`` is a class of
sloshrom like the others, with no change in ``src/``: ``sloshrom train --arch toy`` has its
options, ``reproduce`` its table ``[rom.toy]`` checked by its rules, its model files save and
load, and it runs through the step contract (the coupled beam).

The toy is registered in a process of its own (the command line and the settings make their
options and tables of the classes registered when they are imported)."""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

import sloshrom

TESTS = Path(__file__).resolve().parent
SRC = Path(sloshrom.__file__).resolve().parent

SCRIPT = textwrap.dedent("""
    import json, sys, warnings
    from pathlib import Path

    import numpy as np

    from sloshrom.rom import registry
    from toyrom.entry import TOY_CLASS

    registry.register(TOY_CLASS)  # the one line a class needs, here from outside src/

    from typer.testing import CliRunner

    from sloshrom.beam.simulation.coupled import free_response
    from sloshrom.beam.simulation.structure import ModalModel
    from sloshrom.cli import app
    from sloshrom.config import ConfigError
    from sloshrom.io import Record, write_record
    from sloshrom.models import SloshingModel, is_jax_model
    from sloshrom.pipeline import settings
    from sloshrom.pipeline.rom import estimator
    from sloshrom.rom import ROMError, load_model

    tmp, out = Path(sys.argv[1]), {}
    runner = CliRunner()
    out["help"] = runner.invoke(app, ["train", "--help"]).output
    fs, n = 200.0, 800
    rng = np.random.default_rng(0)
    u = np.convolve(rng.standard_normal(n), np.ones(6) / 6, mode="same") * 0.2
    y = 3.0 * u + 1.5 * np.concatenate([[0.0], u[:-1]]) - 0.5 * np.concatenate([[0.0, 0.0],
                                                                                u[:-2]])
    units = {"velocity": "m/s", "dynamic_force": "N"}
    paths = [write_record(Record(np.arange(n) / fs, fs, {"velocity": u, "dynamic_force": y},
                                 units, {}), tmp / f"{k}.nc") for k in ("train", "val")]
    model = tmp / "toy.npz"
    args = ["train", "--data", str(paths[0]), "--validation", str(paths[1]), "--arch", "toy"]
    res = runner.invoke(app, [*args, "--taps", "3", "--out", str(model)])
    out["train"] = [res.exit_code, res.output]
    res = runner.invoke(app, [*args, "--taps", "12", "--ridge", "0", "--out", str(model) + "x"])
    out["train_rule"] = [res.exit_code, res.output]
    res = runner.invoke(app, [*args, "--delays", "3", "--out", str(model) + "x"])
    out["train_other"] = [res.exit_code, res.output]

    m = load_model(model)
    out["loaded"] = [type(m).__name__, m.taps, m.get_params()["ridge"]]
    out["weights"] = np.asarray(m.params_["w"]).tolist()
    out["contract"] = [isinstance(m, SloshingModel), is_jax_model(m)]
    state, steps = m.init_state(), []
    for v in u[:50]:
        state, f = m.step(state, v)
        steps.append(float(f))
    out["step_error"] = float(np.max(np.abs(np.asarray(steps) - m.predict(u)[:50])))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        beam = free_response(m, ModalModel.from_beam(), duration=0.1)
    out["beam"] = bool(np.all(np.isfinite(beam["tank_acceleration"])))

    out["table"] = "[rom.toy]" in settings.default_text()
    cfg = settings.load().replace(rom={"arch": "toy", "ensemble": 1, "compare": [],
                                       "toy": {"taps": 4}})
    out["settings"] = [cfg.rom.name(), type(estimator(cfg.rom)).__name__,
                       estimator(cfg.rom).taps]
    for change in ({"taps": 0}, {"taps": 12, "ridge": 0.0}):
        try:
            settings.load().replace(rom={"toy": change})
        except ConfigError as exc:
            out.setdefault("settings_errors", []).append(str(exc))
    try:
        type(m)(taps=12, ridge=0.0).fit(u, y, fs)
    except ROMError as exc:
        out["fit_error"] = str(exc)
    print(json.dumps(out))
""")


@pytest.mark.long
def test_a_class_from_outside_src_is_one_package_and_one_registration(tmp_path):
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(
        [str(TESTS), *filter(None, [os.environ.get("PYTHONPATH")])])}
    res = subprocess.run([sys.executable, "-c", SCRIPT, str(tmp_path)], capture_output=True,
                         text=True, env=env, timeout=600)
    assert res.returncode == 0, res.stderr[-3000:]
    out = json.loads(res.stdout.strip().splitlines()[-1])
    help_text = " ".join(re.sub(r"[│╭╮╰╯─]", " ", out["help"]).split())  # rich's box
    assert "--taps" in help_text and "--ridge" in help_text
    assert "toy (a toy: the force a FIR filter of the last velocity samples)" in help_text
    code, text = out["train"]
    assert code == 0 and "wrote" in text and "Toy(3 taps)" in text, text
    code, text = out["train_rule"]  # its own rule, in the command line's words
    assert code == 2 and "--taps > 8 needs --ridge > 0" in text, text
    code, text = out["train_other"]
    assert code == 2 and "--delays does not apply to --arch toy" in text, text
    assert out["loaded"] == ["Toy", 3, 1e-9]
    assert abs(out["weights"][0] - 3.0) < 1e-3 and abs(out["weights"][1] - 1.5) < 1e-3
    # (step follows the caller's JAX precision, float32 here: predict runs in float64)
    assert out["contract"] == [True, True] and out["step_error"] < 1e-5
    assert out["beam"] is True
    assert out["table"] is True
    assert out["settings"] == ["Toy(4 taps)", "Toy", 4]
    assert out["settings_errors"] == [
        "'rom.toy.taps' must be an integer in [1, 16], got 0",
        "'rom.toy.taps' > 8 needs 'rom.toy.ridge' > 0"]
    assert out["fit_error"] == "taps > 8 needs ridge > 0"


def test_the_toy_class_touches_nothing_in_src():
    """The seam holds: no module of the package knows the toy (its name, its package)."""
    for path in SRC.rglob("*.py"):
        text = path.read_text(encoding="utf-8")
        assert "toyrom" not in text and '"toy"' not in text, path
