import copy
import json

import pytest

from sloshrom import ConfigError, Tank
from sloshrom.beam.damping.limits import (
    FREE_DAMPING_PERIODS,
    MIN_RANDOM_DURATION,
    WELCH_SEGMENT,
    min_free_duration,
)
from sloshrom.beam.simulation.limits import BEAM_FS, check_psd_band
from sloshrom.pipeline import settings


def test_defaults_match_objects():
    cfg = settings.defaults()
    assert Tank.from_dict(cfg["tank"]) == Tank()
    assert cfg["rom"]["nfir"]["delays"] == 70 and cfg["rom"]["nfir"]["neurons"] == 35


def test_user_file_overrides_quick_and_defaults(tmp_path):
    p = tmp_path / "my.toml"
    p.write_text("[rom.nfir]\nneurons = 20\n[tank]\nfill = 0.25\n")
    cfg = settings.load(p, quick=True)
    assert cfg.rom.nfir.neurons == 20
    assert cfg.rom.nfir.delays == settings.QUICK["rom"]["nfir"]["delays"]
    assert cfg.tank.fill == 0.25


@pytest.mark.parametrize(
    "text, match",
    [
        ("[rom]\nneuron = 3\n", "unknown configuration key 'rom.neuron'"),
        ("[rom.nfir]\nneurons = 'many'\n", "'rom.nfir.neurons' must be an integer, got 'many'"),
        ("[rom.lss]\ndelays = 3\n", "unknown configuration key 'rom.lss.delays'"),
        ("rom = 3\n", "'rom' must be a table"),
        ("[rom]\nsweep = 1\n", "true or false"),
    ],
)
def test_bad_user_config(tmp_path, text, match):
    p = tmp_path / "bad.toml"
    p.write_text(text)
    with pytest.raises(ConfigError, match=match):
        settings.load(p)


# -- validate -------------------------------------------------------------------------------------
def test_every_default_key_has_a_check():
    """defaults.toml and the schema list the same keys: a key added to one fails here."""
    cfg = settings.defaults()
    tables = settings.config_model().model_fields  # the paper's tables and the studies'
    checked = {f"{t}.{k}" for t, f in tables.items() for k in f.annotation.model_fields}
    keys = {f"{t}.{k}" for t, sec in cfg.items() for k in sec}
    optional = {f"{t}.{k}" for t, ks in settings.OPTIONAL_KEYS.items() for k in ks}
    assert keys | optional == checked and not keys & optional
    # the optional keys are exactly the schema's keys that are not required
    assert optional == {f"{t}.{k}" for t, f in tables.items()
                        for k, fi in f.annotation.model_fields.items() if not fi.is_required()}
    # both are valid, and the dict form of the typed configuration is them, keys in order
    for cfg in (settings.defaults(), settings.merge(settings.defaults(), settings.QUICK)):
        before = copy.deepcopy(cfg)
        assert json.dumps(settings.validate(cfg).as_dict()) == json.dumps(before)


@pytest.mark.parametrize(
    "edit, match",
    [
        (lambda c: c["beam"].update(rms_g=[]), r"'beam\.rms_g' must be a non-empty list"),
        (lambda c: c["beam"].update(rms_g=[0.1, True]), r"'beam\.rms_g\[1\]'"),
        (lambda c: c["beam"].update(damping=[0.01, 0.01]), r"'beam\.damping' has 2 ratio"),
        (lambda c: c["map"].update(f_min=25.0), r"'map\.f_min' \(25 Hz\) must be below"),
        (lambda c: c["rig"].update(fs=float("inf")), r"'rig\.fs' must be a record rate"),
        (lambda c: c["rom"].update(arch="lstm"), r"'rom\.arch' must be \"nfir\" or \"noe\""),
        (lambda c: c["rom"]["lss"].update(block_rows=1),
         r"'rom\.lss\.block_rows' must be an integer in \[2, 1000\], got 1"),
        (lambda c: c["rom"].update(sweep="yes"), r"'rom\.sweep' must be true or false"),
        (lambda c: c["rom"].update(sweep_nfir_delays=[50, 50]), r"must not repeat a value"),
        (lambda c: c["beam"].pop("seed"), r"configuration key 'beam\.seed' is missing"),
        (lambda c: c.pop("map"), r"configuration table \[map\] is missing"),
        (lambda c: c.update(extra={}), r"unknown configuration key 'extra'"),
        (lambda c: c["tank"].update(fill=1.5), r"\[tank\]: fill level must be in \(0, 1\)"),
        (lambda c: c["data"].update(validation_seed=-3), r"'data\.validation_seed'"),
        (lambda c: c["tank"].update(spill=1.0), r"unknown configuration key 'tank\.spill'"),
        (lambda c: c["tank"].update(fill="half"), r"'tank\.fill' must be a number, got 'half'"),
        (lambda c: c.update(rom=3), r"^'rom' must be a table$"),
        (lambda c: c["rom"]["nfir"].update(neurons=3.0),
         r"^'rom\.nfir\.neurons' must be an integer in \[1, 4096\], got 3\.0$"),
        (lambda c: c["rom"].update(sweep_noe_neurons=[3, 3]),
         r"^'rom\.sweep_noe_neurons' must not repeat a value, got \[3, 3\]$"),
        (lambda c: c["map"].update(a_bar_min=float("nan")),
         r"^'map\.a_bar_min' must be a displacement amplitude / tank height in \(0, 1\], got nan$"),
        (lambda c: c["beam"].update(f0=0.0), r"'beam\.f0' must be a frequency in Hz in \(0, inf\]"),
        (lambda c: c["rig"].update(fs=300.0), r"'rig\.fs' = 300 Hz must divide the rig's 10000 Hz"),
        (lambda c: c["beam"].update(youngs_modulus=70.0),
         r"'beam\.youngs_modulus' must be a Young's modulus in Pa in \[1e\+06, 1e\+13\]"),
        (lambda c: c["data"].update(design="lab"),
         r"'data\.design' must be \"use\" or \"structure\" or \"shaker\""),
        (lambda c: c["data"].update(margin=0.5), r"'data\.margin' must be a factor"),
        (lambda c: c["rig"].update(restitution=1.0), r"'rig\.restitution' must be a coeff"),
        (lambda c: c["rom"]["nss"].update(cycle_energy=-0.1),
         r"'rom\.nss\.cycle_energy' must be a number in \[0, 1e\+12\], got -0\.1"),
        (lambda c: (c["rom"].update(arch="noe"), c["rom"]["noe"].update(cycle_energy=0.1)),
         r"^'rom\.noe\.cycle_energy' > 0 needs 'rom\.noe\.trainer' 'adam', got 'lm': set "
         r"'rom\.noe\.cycle_energy' to 0 or 'rom\.noe\.trainer' to 'adam'$"),
        (lambda c: c["beam"].update(n_modes=5, damping=[0.01] * 5),
         r"'beam\.n_modes' = 5: mode 5 of the beam \(676 Hz\) lies above the Nyquist"),
        (lambda c: c["beyond"].update(unseen_fills=[0.502, 0.625]),
         r"'beyond\.unseen_fills' \[0\.502\] is also in 'beyond\.fills' \(within 0\.005\)"),
        (lambda c: (c["rom"].update(arch="nfir", ensemble=64),
                    c["rom"]["nfir"].update(delays=100, neurons=700)),
         r"'rom\.ensemble' = 64 members of NFIR\(100, 700\) have 64 x 70000 = 4480000 weights "
         r"\(700 neurons x 100 regressor entries each\), more than 4194304"),
        (lambda c: (c["rom"].update(arch="nfir"), c["rom"]["nfir"].update(delays=300,
                                                                          neurons=1000),
                    c["beyond"].update(enabled=True, fill_ensemble=20)),
         r"'beyond\.fill_ensemble' = 20 members of NFIR\(300, 1000\) have .* = 6000000 weights"),
        # an NOE's regressor: delays + 2 outputs
        (lambda c: (c["rom"].update(arch="noe", ensemble=21),
                    c["rom"]["noe"].update(delays=200, neurons=1000)),
         r"21 x 202000 = 4242000 weights"),
        # the studies' tables
        (lambda c: c["baseline"].update(restitution=[0.9, 0.1]),
         r"^'baseline\.restitution' bounds out of order: low 0\.9 > high 0\.1$"),
        (lambda c: c["baseline"].update(mass_fraction=[0.0, 0.5]),
         r"^'baseline\.mass_fraction' must be a \[low, high\] pair of mass fractions in "
         r"\(0, 1\]: 'baseline\.mass_fraction\[0\]' must be a mass fraction in \(0, 1\]"),
        (lambda c: c["baseline"].update(gap_factor=[0.5]), r"'baseline\.gap_factor' must be a "
                                                          r"\[low, high\] pair"),
        (lambda c: c["baseline"].update(lowpass="auto"),
         r"'baseline\.lowpass' must be \"input\", \"none\" or a cutoff in Hz"),
        (lambda c: c["baseline"].update(lowpass=-3.0),
         r"'baseline\.lowpass' must be \"input\", \"none\" or a cutoff in Hz .*got -3\.0"),
        (lambda c: c["baseline"].update(n_substeps=0),
         r"'baseline\.n_substeps' must be \"auto\" or an integer >= 1, got 0"),
        (lambda c: c["baseline"].update(maxiter=0), r"'baseline\.maxiter' must be an integer"),
        (lambda c: c["baseline"].update(colour=1), r"unknown configuration key 'baseline\.colour'"),
        (lambda c: c["multimode"].update(rms_g=[]), r"'multimode\.rms_g' must be a non-empty"),
        (lambda c: c["multimode"].update(margin=0.9), r"'multimode\.margin' must be a factor"),
        (lambda c: c["multimode"].update(rel_band=0.5), r"'multimode\.rel_band' must be a "
                                                        r"relative band in \(0, 0\.5\)"),
        (lambda c: c["multimode"].update(nperseg=2048.0), r"'multimode\.nperseg' must be a "
                                                          r"positive integer"),
        (lambda c: c["multimode"].update(hidden="relu"), r"'multimode\.hidden' must be"),
        (lambda c: c["multimode"].update(broadband_fade=20.0),
         r"'multimode\.broadband_piece_duration' must exceed four 'multimode\.broadband_fade'"),
        (lambda c: c["multimode"].pop("span"), r"configuration key 'multimode\.span' is missing"),
    ],
)
def test_validate_names_the_key(edit, match):
    cfg = settings.defaults()
    edit(cfg)
    with pytest.raises(ConfigError, match=match):
        settings.validate(cfg)


def test_missing_and_unknown_keys_come_before_values():
    """The first problem reported is a structural one, whatever the order of the tables."""
    cfg = settings.defaults()
    cfg["rig"]["fs"] = -1.0  # a bad value in an early table ...
    cfg["beam"]["colour"] = "red"  # ... and an unknown key in a later one
    with pytest.raises(ConfigError, match=r"^unknown configuration key 'beam\.colour'$"):
        settings.validate(cfg)


def test_relations_wait_for_valid_values():
    """A relation is checked only once the keys it involves are valid on their own."""
    cfg = settings.defaults()
    cfg["map"].update(f_min=30.0)  # f_min > f_max: a relation
    cfg["beam"].update(seed=-1)  # a value: reported first
    with pytest.raises(ConfigError, match=r"^'beam\.seed' must be a non-negative integer seed"):
        settings.validate(cfg)


def test_validate_returns_the_typed_configuration():
    """The stages read attributes of a frozen object; the dict given is left as it was."""
    import pydantic

    cfg = settings.defaults()
    cfg["rig"]["seed"] = 7
    snapshot = repr(cfg)
    typed = settings.validate(cfg)
    assert isinstance(typed, settings.ReproduceConfig) and repr(cfg) == snapshot
    assert typed.rig.seed == 7 and typed.beam.rms_g == [0.1, 0.2, 0.4]
    assert settings.validate(typed) is typed  # valid already
    with pytest.raises(pydantic.ValidationError):
        typed.rig.seed = 8  # frozen: a stage cannot change what the others read
    # the optional keys given, and only those, are in the dict form (the cache keys)
    assert "restitution" not in typed.as_dict()["rig"]
    rig_b = settings.validate(settings.merge(cfg, {"rig": {"beta": 0.7}}))
    assert rig_b.as_dict()["rig"] == {"seed": 7, "fs": 500.0, "twin_gain": 1.001, "beta": 0.7}
    assert rig_b.rig.overrides() == {"beta": 0.7}
    # in the order the user wrote them, as the merged dict had them (summary.json, config show)
    both = settings.merge(cfg, {"rig": {"beta": 0.7, "restitution": 0.05}})
    assert json.dumps(settings.validate(both).as_dict()) == json.dumps(both)
    assert typed.tables("map", "rig") == {"map": cfg["map"], "rig": cfg["rig"]}


def test_replace_validates_the_changes():
    cfg = settings.load()
    assert cfg.replace(rom={"sweep": True}).rom.sweep and not cfg.rom.sweep
    with pytest.raises(ConfigError, match=r"'map\.n_a' must be an integer in \[2, 200\]"):
        cfg.replace(map={"n_a": 1})
    with pytest.raises(ConfigError, match="unknown configuration key 'rom.epochs'"):
        cfg.replace(rom={"epochs": 3})


def test_the_passive_recipe_has_one_set_of_defaults():
    """Each class's table takes its loss weights from its recipe in the registry (reproduce
    trains on a velocity in m/s and a force in N); docs/examples/nfir_rom.toml picks the
    NFIR, whose table holds its recipe."""
    import tomllib
    from pathlib import Path

    from sloshrom.rom.registry import CLASSES

    cfg = settings.load()
    assert cfg.rom.arch == "grey"
    for name in ("nfir", "nss", "grey"):
        assert cfg.rom.loss_terms(name) == dict(CLASSES[name].recipe)
    nfir = Path(__file__).parents[1] / "docs" / "examples" / "nfir_rom.toml"
    assert tomllib.loads(nfir.read_text()) == {"rom": {"arch": "nfir"}}
    assert settings.load(nfir).rom.loss_terms() == dict(CLASSES["nfir"].recipe)


def test_schema_is_the_single_source_of_bounds():
    """The interval in a message is the one pydantic enforces (both come from one call)."""
    field = settings.config_model().model_fields["rig"].annotation.model_fields["fs"]
    bounds = {type(m).__name__: m for m in field.metadata}
    assert bounds["Ge"].ge == 100.0 and bounds["Le"].le == 5000.0


def test_load_validates(tmp_path):
    p = tmp_path / "c.toml"
    p.write_text("[beam]\nrms_g = []\n")
    with pytest.raises(ConfigError, match=r"'beam\.rms_g'"):
        settings.load(p)


def test_min_free_duration_is_what_the_damping_analysis_needs():
    """At the minimum the analysis runs and keeps samples; a little shorter it cannot run."""
    import numpy as np

    from sloshrom.beam.damping.analysis import instantaneous_damping

    fs, f1 = BEAM_FS, 10.19
    need = min_free_duration(f1)
    assert need == pytest.approx(FREE_DAMPING_PERIODS / f1, abs=0.1)
    t = np.arange(int(need * fs)) / fs
    x = np.exp(-0.01 * 2 * np.pi * f1 * t) * np.sin(2 * np.pi * f1 * t)
    h = instantaneous_damping(x, fs, f1)
    assert h["zeta"].size > 0
    short = x[: int((2 * 5 + 4) / f1 * fs)]  # trimmed ends + smoothing window only
    with pytest.raises(ValueError, match="too short"):
        instantaneous_damping(short, fs, f1)


def test_random_minimum_holds_one_welch_segment():
    assert MIN_RANDOM_DURATION * BEAM_FS >= WELCH_SEGMENT


@pytest.mark.parametrize(("f0", "sigma", "ok"), [(12.0, 4.0, True), (5.0, 4.0, False),
                                                 (240.0, 4.0, False), (12.0, 0.0, False)])
def test_psd_band(f0, sigma, ok):
    if ok:
        check_psd_band(f0, sigma)
    else:
        with pytest.raises(ConfigError):
            check_psd_band(f0, sigma)


def test_every_tank_the_rig_runs_at_is_checked_before_any_stage():
    from sloshrom.pipeline.context import check_rig_tanks

    cfg = settings.defaults()
    check_rig_tanks(cfg)
    cfg["tank"]["fill"] = 1e-9
    with pytest.raises(ConfigError, match=r"'tank\.fill' = 1e-09: the virtual rig cannot model "
                                          r"fill 1e-09"):
        check_rig_tanks(cfg)
    cfg = settings.defaults()
    cfg["beyond"].update(fills=[1e-9, 0.5], unseen_fills=[0.25], beam_fills=[0.5])
    check_rig_tanks(cfg)  # [beyond] off: its fills are not run
    cfg["beyond"]["enabled"] = True
    with pytest.raises(ConfigError, match=r"'beyond\.fills' = 1e-09"):
        check_rig_tanks(cfg)


def _leaves(cfg: dict, where: str = ""):
    """(dotted key, value) of every key of a configuration, its tables flattened."""
    for k, v in cfg.items():
        if isinstance(v, dict):
            yield from _leaves(v, f"{where}{k}.")
        else:
            yield f"{where}{k}", v


def _set(cfg: dict, key: str, value) -> dict:
    *tables, last = key.split(".")
    out = copy.deepcopy(cfg)
    t = out
    for name in tables:
        t = t[name]
    t[last] = value
    return out


def _user_file(key: str, value: str) -> str:
    *tables, last = key.split(".")
    return f"[{'.'.join(tables)}]\n{last} = {value}\n"


def test_a_boolean_where_a_number_goes_is_called_a_boolean(tmp_path):
    """``n_states = true`` (bool is an int in Python): the message says what the key must be,
    an integer or a number, and that true is a boolean; never "must be true or false"."""
    numbers = [(k, v) for k, v in _leaves(settings.defaults())
               if isinstance(v, int | float) and not isinstance(v, bool)]
    assert len(numbers) > 50  # every number of every table, the classes' included
    p = tmp_path / "c.toml"
    for key, ref in numbers:
        p.write_text(_user_file(key, "true"))
        with pytest.raises(ConfigError) as info:
            settings.load(p)
        what = "an integer" if isinstance(ref, int) else "a number"
        assert str(info.value) == f"'{key}' must be {what}, got true (a boolean)", key
        # a configuration built in code (no merge): the schema's words, the same value
        with pytest.raises(ConfigError) as info:
            settings.validate(_set(settings.defaults(), key, False))
        msg = str(info.value)
        assert msg.startswith(f"'{key}' must be ") and "got false (a boolean)" in msg, msg
        assert "true or false" not in msg, msg
    for key, value in [("rom.sweep_nfir_delays", "[50, true]"), ("beam.rms_g", "[true]")]:
        p.write_text(_user_file(key, value))
        with pytest.raises(ConfigError, match=r"got true \(a boolean\)"):
            settings.load(p)


def test_a_number_where_a_boolean_goes_is_refused_as_such(tmp_path):
    flags = [k for k, v in _leaves(settings.defaults()) if isinstance(v, bool)]
    assert flags
    p = tmp_path / "c.toml"
    for key in flags:
        p.write_text(_user_file(key, "1"))
        with pytest.raises(ConfigError, match=rf"^'{key}' must be true or false, got 1$"):
            settings.load(p)


@pytest.mark.parametrize(("key", "want"), [("rom.arch", "a string"), ("beam.rms_g", "a list")])
def test_a_boolean_where_text_or_a_list_goes(tmp_path, key, want):
    p = tmp_path / "c.toml"
    p.write_text(_user_file(key, "true"))
    with pytest.raises(ConfigError, match=rf"^'{key}' must be {want}, got true \(a boolean\)$"):
        settings.load(p)


def test_an_optional_key_given_a_boolean(tmp_path):
    p = tmp_path / "c.toml"
    p.write_text("[rig]\nrestitution = true\n")
    with pytest.raises(ConfigError, match=r"^'rig\.restitution' must be a number, got true "
                                          r"\(a boolean\)$"):
        settings.load(p)


def test_the_studies_own_their_part_of_the_configuration():
    """Each registered study's table, keys of ``[beyond]``, defaults and checks are its own
    (``sloshrom.pipeline.registry``), and the configuration is assembled from them where the
    paper's defaults had them: the same tables, keys and order."""
    import tomllib

    from sloshrom.pipeline.registry import study_tables

    tables = study_tables()
    fields = settings.config_model().model_fields
    own = {t.table: t.model for t in tables if t.table is not None}
    assert own and {k: fields[k].annotation for k in own} == own
    assert list(fields) == ["tank", "rig", "data", "rom", "map", "beam", "beyond", *own]
    assert list(settings.BeyondTable.model_fields) == [
        "enabled", "fills", "unseen_fills", "fill_ensemble", "beam_fills", "baseline",
        "multimode"]
    cfg = settings.defaults()
    for t in tables:  # each study's defaults, as it declares them
        for table, keys in tomllib.loads(t.defaults).items():
            assert {k: cfg[table][k] for k in keys} == keys, table
    assert list(cfg) == list(fields)
    # a study's checks run on its keys: the fill family's order, the ball's bounds
    bad = settings.defaults()
    bad["beyond"]["fills"] = [0.5]
    with pytest.raises(ConfigError, match=r"'beyond\.fills' needs two fill levels"):
        settings.validate(bad)
    bad = settings.defaults()
    bad["baseline"]["restitution"] = [0.9, 0.1]
    with pytest.raises(ConfigError, match=r"'baseline\.restitution' bounds out of order"):
        settings.validate(bad)
