"""`sloshrom reproduce` with the state-space ROM: ``[rom] arch = "nss"`` and ``compare_nfir``."""

from __future__ import annotations

import math
import shutil

import pytest

from sloshrom import limits
from sloshrom.config import ConfigError
from sloshrom.pipeline import Context, settings
from sloshrom.pipeline.chain import identify
from sloshrom.pipeline.report import build_sections
from sloshrom.pipeline.rom import model_class_text, recipe_text
from sloshrom.rom.estimators import load_model
from sloshrom.rom.modelfile import nss_param_shapes

#: The smallest NSS and compared NFIR that train in a few seconds on the tiny records.
TINY_NSS = {"arch": "nss", "nss_states": 2, "nss_neurons": 4, "nss_window": 5,
            "nss_horizon": 20, "nss_batch": 4, "nss_max_epochs": 1, "nss_steps_per_epoch": 2,
            "max_epochs": 1}


def test_the_new_keys_follow_cycle_energy_in_order():
    keys = list(settings.load().as_dict()["rom"])
    i = keys.index("cycle_energy")
    assert keys[i + 1:i + 10] == ["nss_states", "nss_neurons", "nss_window", "nss_horizon",
                                  "nss_batch", "nss_max_epochs", "nss_steps_per_epoch",
                                  "nss_learning_rate", "compare_nfir"]
    rom = settings.load().rom
    assert (rom.nss_states, rom.nss_neurons, rom.nss_window, rom.nss_horizon, rom.nss_batch,
            rom.nss_max_epochs, rom.nss_steps_per_epoch, rom.nss_learning_rate,
            rom.compare_nfir) == (8, 64, 50, 300, 128, 40, 200, 0.003, True)
    # compare_nfir is ignored for an NFIR or NOE
    assert rom.compares_nfir == (rom.arch == "nss")
    assert not settings.load().replace(rom={"arch": "nfir"}).rom.compares_nfir
    assert settings.load().rom.name("nfir") == "NFIR(70, 35)"


def test_config_show_lists_the_nss_keys():
    text = settings.default_text()
    for key in ("nss_states", "nss_learning_rate", "compare_nfir"):
        line = next(ln for ln in text.splitlines() if ln.startswith(f"{key} "))
        assert "#" in line, f"{key} has no comment"
    assert '"nss"' in text


@pytest.mark.parametrize(("change", "match"), [
    ({"nss_states": 0}, r"'rom\.nss_states' must be a state dimension in \[1, 1024\], got 0"),
    ({"nss_horizon": 7}, r"'rom\.nss_horizon' must be a number of samples in \[8, 10000\]"),
    ({"nss_learning_rate": 0.0}, r"'rom\.nss_learning_rate' must be an Adam step in \(0, 1\]"),
    ({"nss_learning_rate": 1.5}, r"'rom\.nss_learning_rate' must be an Adam step in \(0, 1\]"),
    ({"nss_batch": 10**6}, r"'rom\.nss_batch' must be a number of sub-sequences in "
                           r"\[1, 65536\]"),
    ({"compare_nfir": 1}, r"'rom\.compare_nfir' must be true or false"),
    ({"arch": "lstm"}, r"""'rom\.arch' must be "nfir" or "noe" or "nss", got 'lstm'"""),
    ({"arch": "nss", "nss_window": 400_000}, r"'rom\.nss_window'"),
    ({"arch": "nss", "nss_neurons": 2000, "nss_window": 2000, "ensemble": 2},
     r"'rom\.ensemble' x the weights of an NSS .* more than 4194304"),
    ({"arch": "noe", "passivity": 1.0}, r"set them to 0 for arch = 'noe'"),
])
def test_bad_nss_keys_are_refused_naming_the_key(change, match):
    with pytest.raises(ConfigError, match=match):
        settings.load().replace(rom=change)


def test_the_loss_keys_train_an_nss():
    rom = settings.load().replace(rom={"arch": "nss", "passivity": 0.5}).rom
    assert rom.loss_terms()["passivity"] == 0.5
    assert rom.recipe() == limits.NSS_RECIPE
    assert set(limits.NSS_RECIPE) == set(limits.RECIPE)


def test_the_nss_weight_count_is_the_model_files():
    """settings counts an NSS's weights without importing the ROM room: the same count."""
    for n_states, neurons, window in ((8, 64, 50), (1, 1, 1), (3, 7, 11)):
        net = settings.RomNetwork("nss", window, neurons, "", 20, n_states)
        shapes = nss_param_shapes(n_states, neurons, window)
        assert settings.network_weights(net) == sum(math.prod(s) for s in shapes.values())


def test_a_too_short_record_for_the_nss_names_its_keys():
    with pytest.raises(ConfigError, match=r"'rom\.nss_window'/'rom\.nss_horizon' = 5000/9000 "
                                          r"\(NSS\) need at least 14001 training samples"):
        settings.load().replace(data={"train_duration": 20.0},
                                rom={"arch": "nss", "nss_window": 5000, "nss_horizon": 9000})


def test_the_report_texts_describe_an_nss():
    text = model_class_text("nss", "NSS(8 states, 64 neurons)", "NFIR(70, 35)")
    assert "state-space" in text and "finite-memory NFIR cannot" in text
    assert "NFIR(70, 35)" in text and "Fig. 10" in text
    assert "the paper's class: NFIR(70, 35)" in model_class_text("nfir", "NFIR(70, 35)")
    recipe = recipe_text(limits.RECIPE, "NSS(8 states, 64 neurons)", "nss")
    assert "the paper's NSS" not in recipe and "sub-sequence" in recipe
    plain = recipe_text({}, "NSS(8 states, 64 neurons)", "nss")
    assert plain.startswith("The ROM is NSS(8 states, 64 neurons) trained on the plain MSE")
    # the NFIR's paragraph is unchanged
    assert recipe_text(limits.RECIPE, "NFIR(70, 35)").startswith(
        "The ROM is the paper's NFIR(70, 35) identified with physics in its loss")


@pytest.mark.filterwarnings("ignore::UserWarning")
def test_rom_stage_with_an_nss_and_the_compared_nfir(tiny_reproduce, tmp_path):
    """The tiny run's data reused, the rom stage trains the NSS and the NFIR beside it."""
    out = tmp_path / "results"
    shutil.copytree(tiny_reproduce["out"], out)
    cfg = tiny_reproduce["cfg"].replace(rom=TINY_NSS)
    ctx = Context(out, cfg)
    results = identify(ctx)
    assert results["data"].reused and not results["rom"].reused
    r = results["rom"].outputs
    assert r["model"] == "models/nss.npz" and r["arch"] == "nss"
    assert r["name"] == "NSS(2 states, 4 neurons)"
    model = load_model(out / r["model"])
    assert type(model).__name__ == "NSS" and model.n_states == 2 and model.window == 5
    # the summary contract: the chosen ROM's figures
    for key in ("val_mse", "val_nrmse", "val_fit", "train_seconds", "epochs", "stop_reason"):
        assert key in r, key
    assert r["epochs"] == [2]  # epoch 0 (the initial model) and the one epoch
    c = r["compare"]
    assert set(c) == {"name", "val_mse", "val_nrmse", "val_fit", "train_seconds", "model"}
    assert c["name"] == "NFIR(6, 3)" and c["model"] == "models/nfir.npz"
    assert type(load_model(out / c["model"])).__name__ == "NFIR"
    assert c["val_fit"] != r["val_fit"]
    assert "state-space" in r["model_class_text"] and "NFIR(6, 3)" in r["model_class_text"]
    assert (out / "figures" / "fig10_validation.png").stat().st_size > 10_000
    # the report's validation section introduces the NSS and sets the NFIR beside it
    # (the maps and beam of the tiny run: the report's other sections)
    stages = {**tiny_reproduce["rerun"]["stages"],
              **{k: {"reused": v.reused, **v.outputs} for k, v in results.items()}}
    sections = build_sections(ctx, {"stages": stages})
    validation = next(s for s in sections if s.title.startswith("4. Validation"))
    assert "neural state-space model" in validation.text
    assert "Beside it, the paper's class NFIR(6, 3)" in validation.text
    setup = sections[0].tables[0].rows
    assert ["ROM", "NSS(2 states, 4 neurons)", "configuration"] in setup


@pytest.mark.filterwarnings("ignore::UserWarning")
def test_without_compare_nfir_only_the_nss_is_trained(tiny_reproduce, tmp_path):
    out = tmp_path / "results"
    shutil.copytree(tiny_reproduce["out"], out)
    cfg = tiny_reproduce["cfg"].replace(rom={**TINY_NSS, "compare_nfir": False})
    r = identify(Context(out, cfg))["rom"]
    assert "compare" not in r.outputs
    assert sorted(r.files) == ["figures/fig10_validation.png", "models/nss.npz"]
