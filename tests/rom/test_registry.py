"""One registry of ROM classes (``sloshrom.rom.registry``): the command line, the
configuration of `reproduce`, the model-file schema and the estimators take each class's
hyperparameters, defaults and bounds from it; `train` chooses the passive recipe by the
records' units."""

from __future__ import annotations

import numpy as np
import pytest
from typer.testing import CliRunner

from sloshrom import limits
from sloshrom.cli import app
from sloshrom.config import ConfigError
from sloshrom.io import Record, write_record
from sloshrom.pipeline import settings
from sloshrom.rom.registry import CLASSES, LOSS_TERMS, MAX_EPOCH_WORK

FS = 200.0

#: (class, hyperparameter) pairs whose upper bound each reader is checked at
BOUNDED = [("nfir", "delays"), ("nfir", "neurons"), ("nfir", "max_epochs"),
           ("nss", "n_states"), ("nss", "window"), ("noe", "out_delays"),
           ("lss", "n_states"), ("lss", "block_rows")]


def test_every_class_names_its_estimator_and_its_arrays():
    for name, mc in CLASSES.items():
        est = mc.estimator_class()
        assert est.model_class is mc and est.__name__ == mc.class_name
        params = set(est().get_params()) - {"units", "names"}
        assert params == {h.name for h in mc.hyper}, name  # one name everywhere
        # a hyperparameter sized by the record is None (its default on a long record)
        assert est().get_params() | {} and all(
            getattr(est(), h.name) == (None if h.name in mc.sized_by_record else h.default)
            for h in mc.hyper), name
        assert est().effective_params() | {} == {**est().get_params(), **mc.defaults()}
        assert mc.n_params(mc.defaults()) == sum(
            int(np.prod(s)) for s in mc.shapes(mc.defaults()).values())


@pytest.mark.parametrize(("arch", "name"), BOUNDED)
def test_cli_settings_and_estimator_refuse_one_past_the_bound(tmp_path, arch, name):
    mc = CLASSES[arch]
    h = mc.hyper_named(name)
    past = int(h.hi) + 1
    lo = int(h.lo)
    with pytest.raises(ConfigError, match=rf"'rom\.{arch}\.{name}' must be .* in \[{lo}, "
                                          rf"{int(h.hi)}\], got {past}"):
        settings.load().replace(rom={arch: {name: past}})
    res = CliRunner().invoke(app, ["train", "--data", str(tmp_path / "a.nc"), "--validation",
                                   str(tmp_path / "b.nc"), "--out", str(tmp_path / "m.npz"),
                                   "--arch", arch, h.option, str(past)])
    assert res.exit_code == 2
    assert f"{h.option} must be an integer in [{lo}, {int(h.hi)}], got {past}" in res.output, \
        res.output
    with pytest.raises(Exception, match=name):
        mc.check({name: past})


def test_the_settings_bounds_are_the_registry_s():
    for name, mc in CLASSES.items():
        fields = settings.CLASS_TABLES[name].model_fields
        for h in mc.hyper:
            if h.kind not in ("int", "float") or h.name == "seed":
                continue
            meta = fields[h.name].metadata
            hi = next(getattr(m, "le", None) or getattr(m, "lt", None) for m in meta
                      if type(m).__name__ in ("Le", "Lt"))
            assert hi == h.hi, (name, h.name)


def test_the_model_file_schema_takes_the_registry_bounds(tmp_path):
    """A file whose hyperparameter lies one past the registry's bound is refused by name."""
    from helpers import model_parts, write_model_parts
    from sloshrom.rom import LSS, load_model
    from sloshrom.rom.modelfile import ModelFileError

    rng = np.random.default_rng(0)
    u = np.convolve(rng.standard_normal(3000), np.ones(5) / 5, mode="same")
    y = np.convolve(u, [0.0, 0.5, 0.3], mode="full")[: u.size]
    path = LSS(n_states=2, block_rows=5, max_epochs=0).fit(u, y, FS).save(tmp_path / "l.npz")
    meta, arrays = model_parts(path)
    meta["hyperparameters"]["block_rows"] = int(CLASSES["lss"].hyper_named("block_rows").hi) + 1
    bad = write_model_parts(tmp_path / "bad.npz", meta, arrays)
    with pytest.raises(ModelFileError, match=r"hyperparameters\.block_rows"):
        load_model(bad)


def test_recipe_defaults_are_those_of_the_configuration():
    cfg = settings.load()
    assert cfg.rom.arch == "grey" and cfg.rom.loss_terms() == dict(CLASSES["grey"].recipe)
    assert cfg.rom.loss_terms("nss") == dict(CLASSES["nss"].recipe)
    assert cfg.rom.loss_terms("nfir") == dict(CLASSES["nfir"].recipe)
    assert CLASSES["nfir"].recipe["amplitude_weighting"] == 0.05


@pytest.mark.parametrize(("units", "passive"), [(("m/s", "N"), True), (("N", "m"), False),
                                                (("m/s^2", "N"), False), (("m/s", "m"), False)])
def test_the_recipe_applies_to_a_velocity_in_and_a_force_out(units, passive):
    recipe = CLASSES["nfir"].recipe
    choice = CLASSES["nfir"].passive_recipe(*units)
    assert choice.passive is passive
    assert choice.terms == (dict(recipe) if passive else dict.fromkeys(LOSS_TERMS, 0.0))
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
    from sloshrom.rom.loading import load_model

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


@pytest.mark.long  # 3.2-3.5 s in the fast tier under load
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

    assert get_args(limits.Hidden) == limits.HIDDEN_KINDS
    for arch in ("nfir", "noe"):
        assert CLASSES[arch].hyper_named("hidden").choices == limits.HIDDEN_KINDS
        field = settings.CLASS_TABLES[arch].model_fields["hidden"]
        assert get_args(field.annotation) == limits.HIDDEN_KINDS


def test_lss_trains_from_the_command_line_and_exports(tmp_path):
    """The seam's proof: the linear baseline through train, predict and the model file."""
    from sloshrom.rom import load_model

    data, val = _records(tmp_path, ("velocity", "dynamic_force"), ("m/s", "N"))
    out = tmp_path / "lss.npz"
    res = CliRunner().invoke(app, ["train", "--data", str(data), "--validation", str(val),
                                   "--arch", "lss", "--n-states", "3", "--block-rows", "8",
                                   "--out", str(out)])
    assert res.exit_code == 0, res.output
    assert "LSS(3 states)" in res.output and "loss:" not in res.output
    m = load_model(out)
    assert type(m).__name__ == "LSS" and m.n_states == 3
    res = CliRunner().invoke(app, ["train", "--data", str(data), "--validation", str(val),
                                   "--arch", "lss", "--passivity", "1", "--out", str(out)])
    assert res.exit_code == 2 and "--passivity does not apply to --arch lss" in res.output
    res = CliRunner().invoke(app, ["train", "--data", str(data), "--validation", str(val),
                                   "--arch", "lss", "--ensemble", "2", "--out", str(out)])
    assert res.exit_code == 2 and "fitted deterministically" in res.output


def test_one_epoch_of_an_nss_is_bounded_as_the_product_of_its_options():
    """steps_per_epoch x batch x (window + horizon) x neurons: the defaults (and QUICK's, which
    keep the sizes) far inside the limit; just past it refused, naming each factor; a class
    without a shooting epoch not bounded."""
    nss = CLASSES["nss"]
    d = nss.defaults()
    work = d["steps_per_epoch"] * d["batch"] * (d["window"] + d["horizon"]) * d["neurons"]
    assert work * 30 < MAX_EPOCH_WORK and nss.epoch_cost(d) is None
    # the largest horizon the limit takes at the other defaults, then one sample more
    per = d["steps_per_epoch"] * d["batch"] * d["neurons"]
    h = MAX_EPOCH_WORK // per - d["window"]
    assert nss.epoch_cost({**d, "horizon": h}) is None
    msg = nss.epoch_cost({**d, "horizon": h + 1}, key=lambda k: k.upper())
    assert msg is not None and (f"STEPS_PER_EPOCH x BATCH x (WINDOW + HORIZON) x NEURONS = "
                                f"200 x 128 x (50 + {h + 1}) x 64 = ") in msg
    assert "more than 1.5e+10" in msg
    for name in ("nfir", "noe", "lss"):
        assert not CLASSES[name].epoch_work
        assert CLASSES[name].epoch_cost(CLASSES[name].defaults()) is None


def test_the_settings_bound_an_nss_epoch_of_the_rom_and_of_the_compared_classes():
    cfg = settings.defaults()
    settings.validate(cfg)
    # the default class is bounded too (its 32 neurons let 9000 + 9000 through: 1.47e10)
    cfg["rom"]["grey"].update(window=9000, horizon=9000, neurons=64)
    with pytest.raises(ConfigError, match=r"\('rom\.grey\.window' \+ 'rom\.grey\.horizon'\) x "
                                          r"'rom\.grey\.neurons' = 200 x 128 x \(9000 \+ 9000\) x "
                                          r"64 = 2\.95e\+10 neuron-samples"):
        settings.validate(cfg)
    cfg = settings.defaults()
    cfg["rom"].update(arch="nss")
    cfg["rom"]["nss"].update(window=9000, horizon=9000)
    with pytest.raises(ConfigError, match=r"\('rom\.nss\.window' \+ 'rom\.nss\.horizon'\) x "
                                          r"'rom\.nss\.neurons' = 200 x 128 x \(9000 \+ 9000\) x "
                                          r"64 = 2\.95e\+10 neuron-samples"):
        settings.validate(cfg)
    cfg["rom"].update(arch="nfir", compare=["lss"])  # an NSS no stage trains: not bounded
    settings.validate(cfg)


@pytest.mark.parametrize(("units", "recipe"), [(("m/s", "N"), True), (("N", "m"), False)])
def test_train_on_sloshing_records_takes_the_reproduce_recipe(tmp_path, units, recipe):
    """`train --arch nss` on m/s in and N out built a model with feed-through and no Galilean
    augmentation, not the one `reproduce` builds: on such records it takes reproduce's
    [rom.nss] choices and says so; on other records the class's defaults, also said."""
    from sloshrom.rom.loading import load_model

    names = ("velocity", "dynamic_force") if recipe else ("force", "displacement")
    data, val = _records(tmp_path, names, units)
    out = tmp_path / "nss.npz"
    res = CliRunner().invoke(app, [
        "train", "--data", str(data), "--validation", str(val), "--input", names[0],
        "--output", names[1], "--arch", "nss", "--n-states", "2", "--neurons", "4",
        "--window", "5", "--horizon", "20", "--max-epochs", "0", "--out", str(out)])
    assert res.exit_code == 0, res.output
    m = load_model(out)
    shipped = settings.sloshing_recipe("nss")
    assert shipped == {"feedthrough": "no", "velocity_offset": 0.5}
    if recipe:
        assert (m.feedthrough, m.velocity_offset) == ("no", 0.5)
        assert ("recipe: as `sloshrom reproduce` trains it on sloshing records (m/s in, N out): "
                "feedthrough no, velocity_offset 0.5") in res.output
    else:
        assert (m.feedthrough, m.velocity_offset) == ("yes", 0.0)
        assert "recipe: the class's defaults" in res.output


def test_train_says_when_its_precision_is_not_what_the_trainer_runs(tmp_path):
    # --precision float32 is Adam's: asked with Levenberg-Marquardt, said, not silently
    # dropped; the shipped table's float32 (not asked) says nothing beyond the recipe line
    data, val = _records(tmp_path, ("velocity", "dynamic_force"), ("m/s", "N"))
    base = ["train", "--data", str(data), "--validation", str(val), "--arch", "nfir",
            "--delays", "3", "--neurons", "2", "--max-epochs", "1", "--trainer", "lm",
            "--amplitude-weighting", "0", "--passivity", "0", "--cycle-energy", "0"]
    res = CliRunner().invoke(app, [*base, "--precision", "float32",
                                   "--out", str(tmp_path / "a.npz")])
    assert res.exit_code == 0, res.output
    assert ("note: --precision float32 is the precision of Adam's steps; --trainer lm trains "
            "in float64") in res.output
    res = CliRunner().invoke(app, [*base, "--out", str(tmp_path / "b.npz")])
    assert res.exit_code == 0, res.output
    assert "note: --precision" not in res.output
