"""One set of ROM limits and recipe defaults (``sloshrom.limits``): the command line, the
configuration of `reproduce` and the model-file schema use the same values; `train` chooses
the passive recipe by the records' units."""

from __future__ import annotations

import numpy as np
import pytest
from typer.testing import CliRunner

from sloshrom import limits
from sloshrom.cli import app
from sloshrom.config import ConfigError
from sloshrom.io import Record, write_record
from sloshrom.pipeline import settings

FS = 200.0


def test_one_value_per_limit():
    from sloshrom.cli import rom as cli_rom
    from sloshrom.rom import estimators, modelfile, training

    for name in ("MAX_DELAY", "MAX_NEURONS", "MAX_OUT_DELAYS", "MAX_EPOCHS", "MAX_MEMBERS",
                 "MAX_WEIGHTS"):
        assert getattr(modelfile, name) is getattr(limits, name), name
    for name in ("MAX_DELAY", "MAX_NEURONS", "MAX_EPOCHS", "MAX_MEMBERS", "MAX_SEED"):
        assert getattr(cli_rom, name) is getattr(limits, name), name
    assert training.TRAINERS is estimators.TRAINERS is limits.TRAINERS
    assert settings.MAX_MODEL_WEIGHTS == limits.MAX_WEIGHTS
    # the settings schema's bounds are the same numbers
    rom = settings.RomTable.model_fields

    def upper(field):
        return next(m.le for m in rom[field].metadata if type(m).__name__ == "Le")

    assert upper("delays") == limits.MAX_DELAY and upper("neurons") == limits.MAX_NEURONS
    assert upper("max_epochs") == limits.MAX_EPOCHS and upper("ensemble") == limits.MAX_MEMBERS
    assert upper("seed") == limits.MAX_SEED


@pytest.mark.parametrize(("key", "limit"), [("delays", limits.MAX_DELAY),
                                            ("neurons", limits.MAX_NEURONS),
                                            ("max_epochs", limits.MAX_EPOCHS)])
def test_settings_and_cli_refuse_one_past_the_limit(tmp_path, key, limit):
    lo = 0 if key == "max_epochs" else 1
    with pytest.raises(ConfigError, match=rf"'rom\.{key}' must be an integer in \[{lo}, "
                                          rf"{limit}\], got {limit + 1}"):
        settings.validate(settings.merge(settings.defaults(), {"rom": {key: limit + 1}}))
    flag = "--" + key.replace("_", "-")
    res = CliRunner().invoke(app, ["train", "--data", str(tmp_path / "a.nc"), "--validation",
                                   str(tmp_path / "b.nc"), "--out", str(tmp_path / "m.npz"),
                                   flag, str(limit + 1)])
    assert res.exit_code == 2
    assert f"{flag} must be in [{lo}, {limit}], got {limit + 1}" in res.output, res.output


def test_model_file_schema_takes_the_largest_values():
    """A network at the limits is one a model file holds (the schema checks the same bounds)."""
    from sloshrom.rom.errors import ROMError
    from sloshrom.rom.modelfile import check_file_limits

    check_file_limits(limits.MAX_DELAY, 1, 1)  # a sparse delay line reaching the limit
    with pytest.raises(ROMError, match=str(limits.MAX_DELAY)):
        check_file_limits(limits.MAX_DELAY + 1, 1, 1)
    with pytest.raises(ROMError, match=str(limits.MAX_NEURONS)):
        check_file_limits(10, limits.MAX_NEURONS + 1, 10)


def test_recipe_defaults_are_those_of_the_configuration():
    # the configuration's default class is the NSS: its recipe, without amplitude weighting
    assert settings.load().rom.loss_terms() == limits.NSS_RECIPE
    assert settings.defaults()["rom"]["amplitude_weighting"] == 0.0
    assert limits.RECIPE["amplitude_weighting"] == 0.05


@pytest.mark.parametrize(("units", "passive"), [(("m/s", "N"), True), (("N", "m"), False),
                                                (("m/s^2", "N"), False), (("m/s", "m"), False)])
def test_the_recipe_applies_to_a_velocity_in_and_a_force_out(units, passive):
    choice = limits.loss_recipe(*units)
    assert choice.passive is passive
    assert choice.terms == (limits.RECIPE if passive else dict.fromkeys(limits.RECIPE, 0.0))
    line = str(choice)
    assert "\n" not in line and line.startswith("loss: ")
    assert ("passive recipe (amplitude weighting 0.05 m/s" in line) is passive
    assert ("plain MSE" in line) is not passive


def _records(tmp_path, names, units, seed=1):
    """A smooth random input and a delayed saturating output of it, train and validation."""
    paths = []
    for split, n in (("train", 1200), ("validation", 400)):
        rng = np.random.default_rng(seed + n)
        u = np.convolve(rng.standard_normal(n), np.ones(8) / 8, mode="same") * 0.3
        y = 0.01 * np.tanh(5 * np.concatenate([[0.0, 0.0], u[:-2]]))
        rec = Record(np.arange(n) / FS, FS, {names[0]: u, names[1]: y},
                     dict(zip(names, units, strict=True)), {})
        paths.append(write_record(rec, tmp_path / f"{split}.nc"))
    return paths


def _train(tmp_path, names, units, *extra):
    from sloshrom.rom.estimators import load_model

    data, val = _records(tmp_path, names, units)
    out = tmp_path / "m.npz"
    res = CliRunner().invoke(app, ["train", "--data", str(data), "--validation", str(val),
                                   "--input", names[0], "--output", names[1], "--delays", "4",
                                   "--neurons", "3", "--max-epochs", "2", "--out", str(out),
                                   *extra])
    assert res.exit_code == 0, res.output
    m = load_model(out)
    return res.output, (m.amplitude_weighting, m.passivity, m.cycle_energy)


def test_train_uses_the_plain_mse_on_a_system_that_is_not_a_tank(tmp_path):
    """A force in N driving a displacement in m: F x is no power, the recipe does not hold."""
    output, terms = _train(tmp_path, ("force", "displacement"), ("N", "m"))
    assert terms == (0.0, 0.0, 0.0)
    assert ("loss: the plain MSE: the input is in 'N' and the output in 'm', not a velocity "
            "(m/s) in and a force (N) out") in output


def test_train_keeps_the_passive_recipe_for_a_velocity_and_a_force(tmp_path):
    output, terms = _train(tmp_path, ("velocity", "dynamic_force"), ("m/s", "N"))
    assert terms == (0.05, 1.0, 0.1)
    assert "loss: the passive recipe (amplitude weighting 0.05 m/s, passivity 1, cycle " \
           "energy 0.1): the input is a velocity (m/s) and the output a force (N)" in output


def test_train_options_override_the_choice(tmp_path):
    output, terms = _train(tmp_path, ("force", "displacement"), ("N", "m"), "--passivity", "0.5")
    assert terms == (0.0, 0.5, 0.0)
    assert "passivity set by the options (by the records' units: the plain MSE)" in output


def test_the_hidden_layer_kinds_are_written_once():
    from typing import get_args

    from sloshrom import limits
    from sloshrom.pipeline.settings import RomTable
    from sloshrom.rom import modelfile

    assert get_args(limits.Hidden) == limits.HIDDEN_KINDS
    assert modelfile.HIDDEN_KINDS is limits.HIDDEN_KINDS
    assert get_args(RomTable.model_fields["hidden"].annotation) == limits.HIDDEN_KINDS
