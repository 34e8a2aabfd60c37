"""`sloshrom reproduce` with the state-space ROM: ``[rom] arch = "nss"``, each class's table
``[rom.<class>]`` and the classes compared with the ROM (``compare``)."""

from __future__ import annotations

import shutil

import numpy as np
import pytest

from sloshrom.config import ConfigError
from sloshrom.pipeline import Context, settings
from sloshrom.pipeline.chain import identify
from sloshrom.pipeline.report import build_sections
from sloshrom.pipeline.rom import model_class_text, recipe_text
from sloshrom.rom.loading import load_model
from sloshrom.rom.registry import CLASSES

#: The smallest NSS and compared NFIR that train in a few seconds on the tiny records.
TINY_NSS = {"arch": "nss", "compare": ["nfir"],
            "nss": {"n_states": 2, "neurons": 4, "window": 5, "horizon": 20, "batch": 4,
                    "max_epochs": 1, "steps_per_epoch": 2},
            "nfir": {"max_epochs": 1}}


def test_each_class_has_its_table_with_the_registry_keys():
    from sloshrom.rom.registry import CLASSES

    cfg = settings.load()
    rom = cfg.as_dict()["rom"]
    for name, mc in CLASSES.items():
        assert set(rom[name]) == {h.name for h in mc.hyper} - {"seed"}, name
    nss = cfg.rom.nss
    assert (nss.n_states, nss.neurons, nss.window, nss.horizon, nss.batch, nss.max_epochs,
            nss.steps_per_epoch, nss.learning_rate) == (8, 64, 50, 200, 128, 60, 200, 0.003)
    assert cfg.rom.compare == ["nfir", "lss"] and cfg.rom.compared() == ["nfir", "lss"]
    # the ROM's own class in compare is not trained beside itself
    assert settings.load().replace(rom={"arch": "nfir"}).rom.compared() == ["lss"]
    assert settings.load().rom.name("nfir") == "NFIR(70, 35)"
    assert settings.load().rom.name("lss") == "LSS(8 states)"


def test_config_show_lists_every_class_key_with_a_comment():
    text = settings.default_text()
    for key in ("n_states", "learning_rate", "block_rows", "compare"):
        line = next(ln for ln in text.splitlines() if ln.startswith(f"{key} "))
        assert "#" in line, f"{key} has no comment"
    assert '"nss"' in text and "[rom.lss]" in text
    assert settings.defaults() == settings.load().as_dict()


@pytest.mark.parametrize(("change", "match"), [
    ({"nss": {"n_states": 0}},
     r"'rom\.nss\.n_states' must be an integer in \[1, 1024\], got 0"),
    ({"nss": {"horizon": 7}}, r"'rom\.nss\.horizon' must be an integer in \[8, 10000\]"),
    ({"nss": {"learning_rate": 0.0}}, r"'rom\.nss\.learning_rate' must be a number in "
                                      r"\(0, 1\]"),
    ({"nss": {"learning_rate": 1.5}}, r"'rom\.nss\.learning_rate' must be a number in "
                                      r"\(0, 1\]"),
    ({"nss": {"batch": 10**6}}, r"'rom\.nss\.batch' must be an integer in \[1, 65536\]"),
    ({"compare": "nfir"}, r"'rom\.compare' must be a list"),
    ({"compare": ["nfir", "nfir"]}, r"'rom\.compare' must not repeat a value"),
    ({"compare": ["rnn"]}, r"'rom\.compare' must be \"nfir\" or \"noe\" or \"nss\" or \"lss\" "
                           r"or \"grey\", got 'rnn'"),
    ({"arch": "lstm"}, r"'rom\.arch' must be \"nfir\" or \"noe\" or \"nss\" or \"lss\" "
                       r"or \"grey\", got 'lstm'"),
    ({"arch": "nss", "nss": {"window": 400_000}}, r"'rom\.nss\.window'"),
    ({"arch": "nss", "nss": {"neurons": 2000, "window": 2000}, "ensemble": 2},
     r"'rom\.ensemble' = 2 members of NSS\(8 states, 2000 neurons, strictly proper\) have "
     r".* more than 4194304"),
    ({"arch": "noe", "noe": {"passivity": 1.0}},
     r"'rom\.noe\.passivity' > 0 needs 'rom\.noe\.trainer' 'adam', got 'lm'"),
    ({"arch": "lss"}, r"'rom\.ensemble' = 2: an LSS is fitted deterministically"),
    ({"nss": {"delays": 3}}, r"unknown configuration key 'rom\.nss\.delays'"),
])
def test_bad_class_keys_are_refused_naming_the_key(change, match):
    with pytest.raises(ConfigError, match=match):
        settings.load().replace(rom=change)


def test_an_noe_trained_by_adam_takes_the_loss_terms():
    """The rule of the estimator, the command line and the settings: one rule."""
    rom = settings.load().replace(rom={"arch": "noe", "noe": {
        "trainer": "adam", "passivity": 0.5}}).rom
    assert rom.loss_terms()["passivity"] == 0.5


def test_former_flat_keys_are_read_under_their_new_names(tmp_path):
    p = tmp_path / "old.toml"
    p.write_text("[rom]\narch = \"nss\"\nnss_states = 4\ndelays = 50\npassivity = 0.5\n"
                 "compare_nfir = false\n")
    with pytest.warns(settings.ConfigWarning) as record:
        cfg = settings.load(p)
    said = " ".join(str(w.message) for w in record)
    assert "'rom.nss_states' is now 'rom.nss.n_states'" in said
    assert "'rom.delays' is now 'rom.nfir.delays'" in said
    assert "'rom.passivity' is now 'rom.nss.passivity'" in said
    assert "'rom.compare_nfir' is now 'rom.compare'" in said
    assert cfg.rom.nss.n_states == 4 and cfg.rom.nfir.delays == 50
    assert cfg.rom.nss.passivity == 0.5 and cfg.rom.compare == []


def test_a_too_short_record_for_the_nss_names_its_table():
    # (a batch of 64 keeps one epoch's work within its bound)
    with pytest.raises(ConfigError, match=r"^'rom\.nss': 10000 samples \('data\.train_duration' "
                                          r"= 20 s at 'rig\.fs' = 500 Hz\) are too few for "
                                          r"NSS\(8 states, 64 neurons, strictly proper\) "
                                          r"\(training needs at least 14001\)$"):
        settings.load().replace(data={"train_duration": 20.0},
                                rom={"arch": "nss", "nss": {"window": 5000, "horizon": 9000,
                                                            "batch": 64}})


def test_the_report_texts_describe_each_class():
    text = model_class_text("nss", "NSS(8 states, 64 neurons)",
                            [("NFIR(70, 35)", 6.9), ("LSS(8 states)", 6.5)], 43.7)
    assert "state-space" in text and "finite-memory NFIR" in text and "cannot" in text
    assert "NFIR(70, 35), fit 6.9 %; LSS(8 states), fit 6.5 %" in text and "Fig. 10" in text
    assert "against 43.7 % for NSS(8 states, 64 neurons)" in text
    assert "the paper's class" in model_class_text("nfir", "NFIR(70, 35)")
    assert "best linear model" in model_class_text("lss", "LSS(8 states)")
    nfir_recipe = dict(CLASSES["nfir"].recipe)
    recipe = recipe_text(nfir_recipe, "NSS(8 states, 64 neurons)", "nss")
    assert "the paper's NSS" not in recipe and "sub-sequence" in recipe
    plain = recipe_text({}, "NSS(8 states, 64 neurons)", "nss")
    assert plain.startswith("The ROM is NSS(8 states, 64 neurons) trained on the plain MSE")
    assert recipe_text(nfir_recipe, "NFIR(70, 35)").startswith(
        "The ROM is the paper's NFIR(70, 35) identified with physics in its loss")
    assert "without loss terms" in recipe_text({}, "LSS(8 states)", "lss")


@pytest.mark.filterwarnings("ignore::UserWarning")
@pytest.mark.long
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
    assert r["name"] == "NSS(2 states, 4 neurons, strictly proper)"
    model = load_model(out / r["model"])
    assert type(model).__name__ == "NSS" and model.n_states == 2 and model.window == 5
    # the summary contract: the chosen ROM's figures
    for key in ("val_mse", "val_nrmse", "val_fit", "train_seconds", "epochs", "stop_reason"):
        assert key in r, key
    assert r["epochs"] == [2]  # epoch 0 (the initial model) and the one epoch
    assert set(r["compare"]) == {"nfir"}
    c = r["compare"]["nfir"]
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
    assert "Beside it, on the same records" in validation.text
    assert "the paper's class NFIR(6, 3)" in validation.text
    # the ROM's frame sensitivity: in the summary and in the section
    fr = r["frame_sensitivity"]
    assert fr["offsets_m_s"] == [0.1, 0.3] and len(fr["energy_change"]) == 2
    assert all(np.isfinite(fr["energy_change"] + fr["force_change"]))
    assert f"{100 * fr['energy_change'][0]:.1f} % for 0.1 m/s" in validation.text
    assert sections[0].title == "At a glance"
    setup = sections[1].tables[0].rows
    assert ["ROM", "NSS(2 states, 4 neurons, strictly proper)", "configuration"] in setup


@pytest.mark.filterwarnings("ignore::UserWarning")
def test_without_compare_only_the_nss_is_trained(tiny_reproduce, tmp_path):
    out = tmp_path / "results"
    shutil.copytree(tiny_reproduce["out"], out)
    cfg = tiny_reproduce["cfg"].replace(rom={**TINY_NSS, "compare": []})
    r = identify(Context(out, cfg))["rom"]
    assert r.outputs["compare"] == {}
    assert sorted(r.files) == ["figures/fig10_validation.png", "models/nss.npz"]
