"""One rules path: a class's entry checks its hyperparameters, the fewest training samples, the
cost of an epoch and what its loss terms need (``ModelClass.check``); the estimator's ``fit``,
the command line and the settings call it, each naming a value in its own words (an argument,
an option, a key). Defaults are written once, in the entries.

Each test here failed while a rule lived in several places that disagreed (issue 49)."""

from __future__ import annotations

import ast
import dataclasses
import functools
import importlib
import inspect
import re
import tomllib
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

import sloshrom
from sloshrom.cli import app
from sloshrom.config import ConfigError
from sloshrom.io import Record, write_record
from sloshrom.pipeline import settings
from sloshrom.rom import NOE, NSS, Ensemble, ROMError
from sloshrom.rom.registry import CLASSES, ModelClass

FS = 100.0
SRC = Path(sloshrom.__file__).parent


def _io(n: int, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    u = np.convolve(rng.standard_normal(n), np.ones(8) / 8, mode="same") * 0.3
    return u, 0.01 * np.tanh(5 * np.concatenate([[0.0, 0.0], u[:-2]]))


def _records(tmp_path: Path, n: int) -> tuple[Path, Path]:
    paths = []
    for name, seed in (("train", 1), ("validation", 2)):
        u, y = _io(n, seed)
        rec = Record(np.arange(n) / FS, FS, {"velocity": u, "dynamic_force": y},
                     {"velocity": "m/s", "dynamic_force": "N"}, {})
        paths.append(write_record(rec, tmp_path / f"{name}.nc"))
    return paths[0], paths[1]


def _train(tmp_path: Path, n: int, *options: str) -> str:
    data, val = _records(tmp_path, n)
    res = CliRunner().invoke(app, ["train", "--data", str(data), "--validation", str(val),
                                   "--out", str(tmp_path / "m.npz"), *options])
    return res.output


def test_an_noe_trained_by_adam_needs_one_horizon_everywhere(tmp_path):
    """The entry's fewest samples is what ``fit`` refuses below: the command line and the
    settings no longer pass a record that ``fit`` then refuses (15 against 301)."""
    noe = CLASSES["noe"]
    h = {**noe.defaults(), "trainer": "adam", "horizon": 500}
    assert noe.min_samples(h) == 501
    assert noe.min_samples({**h, "trainer": "lm"}) < 50  # LM reads the delay lines only
    u, y = _io(500)
    with pytest.raises(ROMError, match=r"^500 samples are too few for NOE\(2, 10\) "
                                       r"\(training needs at least 501\)$"):
        NOE(trainer="adam", horizon=500, max_epochs=1).fit(u, y, FS)
    out = _train(tmp_path, 500, "--arch", "noe", "--trainer", "adam", "--horizon", "500")
    assert re.search(r"error: .*train\.nc: 500 samples are too few for NOE\(2, 10\) "
                     r"\(training needs at least 501\)", out), out
    with pytest.raises(ConfigError, match=r"^'rom\.noe': 5000 samples .* are too few for "
                                          r"NOE\(2, 10\) \(training needs at least 6001\)$"):
        settings.load().replace(data={"train_duration": 10.0},
                                rom={"arch": "noe", "noe": {"trainer": "adam",
                                                            "horizon": 6000}})


def test_one_nss_epoch_is_bounded_from_python_and_in_ensembles():
    """The bound on an epoch's work holds for ``NSS.fit`` and ``Ensemble.fit`` too (it held
    for the command line and the settings only), before the record's length is looked at."""
    u, y = _io(300)
    big = {"batch": 65536, "window": 100, "horizon": 10_000, "neurons": 64}
    epoch = r"one training epoch of NSS\(\d+ states, 64 neurons\), steps_per_epoch x batch x "
    with pytest.raises(ROMError, match=epoch):
        NSS(**big).fit(u, y, FS)
    with pytest.raises(ROMError, match=epoch):
        Ensemble(NSS(**big), n_members=2).fit(u, y, FS, scheduler="sequential")
    # the issue's example: refused for what it is, not for the record's length
    issue = {"batch": 65536, "neurons": 4096, "window": 10_000, "horizon": 10_000}
    for fit in (NSS(**issue).fit,
                Ensemble(NSS(**issue), n_members=2).fit):
        with pytest.raises(ROMError, match="one training epoch|the most a model file holds"):
            fit(u, y, FS)


def test_loss_terms_need_adam_in_one_sentence(tmp_path):
    """One rule, one wording, with the argument's, option's or key's name."""
    tdnn = importlib.import_module(NOE.__module__)  # the time-delay networks' estimators
    training, spec = tdnn.training, tdnn.NetworkSpec("noe", (1, 2), 4, "matlab", 2)

    def sentence(key):
        p, t = key("passivity"), key("trainer")
        return f"{p} > 0 needs {t} 'adam', got 'lm': set {p} to 0 or {t} to 'adam'"

    u, y = _io(400)
    with pytest.raises(ROMError) as exc:
        NOE(passivity=1.0).fit(u, y, FS)
    assert str(exc.value) == sentence(str)
    with pytest.raises(ROMError) as exc:
        training.train(spec, u, y, tdnn.MinMaxScaler.fit(u, y), trainer="lm", passivity=1.0,
                       fs=FS)
    assert str(exc.value) == sentence(str)
    out = _train(tmp_path, 400, "--arch", "noe", "--passivity", "1")
    assert f"error: {sentence(lambda k: '--' + k.replace('_', '-'))}" in " ".join(out.split())
    with pytest.raises(ConfigError) as cexc:
        settings.load().replace(rom={"arch": "noe", "noe": {"passivity": 1.0}})
    assert str(cexc.value) == sentence(lambda k: f"'rom.noe.{k}'")


def test_a_float_where_an_integer_goes_is_said_to_be_no_integer():
    """``horizon = 200.0`` (a TOML float) is refused as the estimator refuses it, saying that
    it must be an integer (it said "must be a number of samples in [8, 10000]", and 200 is)."""
    cfg = settings.defaults()
    cfg["rom"]["nss"]["horizon"] = 200.0
    with pytest.raises(ConfigError) as exc:
        settings.validate(cfg)
    assert str(exc.value) == "'rom.nss.horizon' must be an integer in [8, 10000], got 200.0"
    with pytest.raises(ROMError) as rexc:
        NSS(horizon=200.0).fit(*_io(400), FS)
    assert str(rexc.value) == "horizon must be an integer in [8, 10000], got 200.0"


#: The hyperparameters of the multiple-shooting recipe (the NOE's by Adam, the NSS's).
RECIPE = ("horizon", "batch", "max_epochs", "steps_per_epoch", "learning_rate",
          "velocity_offset", "weight_decay")


def _literal_defaults(func) -> list[str]:
    """The parameters of ``func`` whose default is written as a literal in its source."""
    tree = ast.parse(inspect.getsource(func).lstrip())
    fn = next(n for n in ast.walk(tree) if isinstance(n, ast.FunctionDef))
    args = fn.args.args[-len(fn.args.defaults):] if fn.args.defaults else []
    pairs = [*zip(args, fn.args.defaults, strict=True),
             *zip(fn.args.kwonlyargs, fn.args.kw_defaults, strict=True)]
    return [a.arg for a, d in pairs if isinstance(d, ast.Constant) and d.value is not None
            and a.arg not in ("units", "names")]


def test_defaults_are_written_once_in_the_entries():
    """Each estimator's defaults are its entry's, read from it (``batch = 128`` and
    ``learning_rate = 3e-3`` were written five times, ``velocity_offset = 0.0`` three);
    the shooting recipe has no default of its own; ``defaults.toml`` repeats none."""
    from sloshrom.rom.shooting import ShootingOptions

    training = importlib.import_module(NOE.__module__).training

    for mc in CLASSES.values():
        init = mc.estimator_class().__init__
        params = inspect.signature(init).parameters
        for h in mc.hyper:
            expected = None if h.name in mc.sized_by_record else h.default
            assert params[h.name].default == expected, (mc.name, h.name)
        assert _literal_defaults(init) == [], mc.name
    missing = dataclasses.MISSING
    fields = {f.name: f.default for f in dataclasses.fields(ShootingOptions)}
    assert all(fields[k] is missing for k in RECIPE), fields
    noe = CLASSES["noe"].defaults()
    sig = inspect.signature(training.train).parameters
    assert all(sig[k].default == noe[k] for k in ("horizon", "batch", "steps_per_epoch",
                                                 "learning_rate"))
    assert not {"horizon", "batch", "steps_per_epoch", "learning_rate"} & set(
        _literal_defaults(training.train))
    shipped = tomllib.loads((SRC / "pipeline" / "defaults.toml").read_text())["rom"]
    for name, mc in CLASSES.items():
        for key, value in shipped.get(name, {}).items():
            assert value != mc.hyper_named(key).default, (
                f"defaults.toml repeats the entry's default of rom.{name}.{key}")
        # the sensitivity analysis's grid: the configuration's keys, the entry's values
        for grid, what in zip(getattr(mc, "sweep", ()), ("delays", "neurons"), strict=False):
            assert shipped[f"sweep_{name}_{what}"] == list(grid), (name, what)


@functools.cache
def _arithmetic() -> tuple[tuple[str, int, str], ...]:
    """``(module, line, source)`` of every outermost arithmetic expression of ``src``, read
    once (parsing the package takes seconds)."""
    out = []
    for path in sorted(SRC.rglob("*.py")):
        tree = ast.parse(path.read_text(encoding="utf-8"))
        inner = {id(c) for n in ast.walk(tree) if isinstance(n, ast.BinOp)
                 for c in (n.left, n.right)}
        out += [(str(path.relative_to(SRC)), node.lineno, ast.unparse(node))
                for node in ast.walk(tree) if isinstance(node, ast.BinOp) and id(node) not in inner]
    return tuple(out)


def _rule_written(pattern: str) -> list[str]:
    """Where an arithmetic expression of ``src`` reads as ``pattern`` (regex on its source)."""
    return [f"{module}:{line}: {text}" for module, line, text in _arithmetic()
            if re.fullmatch(pattern, text)]


def test_the_fewest_samples_of_a_shooting_training_are_written_once():
    """``window + horizon + 1`` (an NSS) was written three times, ``horizon + 1`` (an NOE by
    Adam) twice: each is written once (the state-space rule in the registry, which the NSS and the
    grey box share; the NOE's in its entry)."""
    nss = _rule_written(r".*window.*\+.*(horizon|\bT\b).*\+ 1")
    assert [w.split(":")[0] for w in nss] == ["rom/registry.py"], nss
    noe = _rule_written(r"(int\()?(self\.)?(horizon|\bT\b)\)? \+ 1")
    assert [w.split(":")[0] for w in noe] == ["rom/tdnn/entry.py"], noe


def test_the_size_rule_runs_once_on_the_command_line_path(tmp_path, monkeypatch):
    """``sloshrom train --arch nss`` on a short record sizes the network once: the command
    line's check chooses the sizes, the fit reuses them (it ran the rule five times)."""
    calls = []
    size = ModelClass.size

    def counted(self, n_samples, given):
        calls.append((self.name, n_samples, dict(given)))
        return size(self, n_samples, given)

    monkeypatch.setattr(ModelClass, "size", counted)
    out = _train(tmp_path, 600, "--arch", "nss", "--max-epochs", "0")
    assert "wrote" in out and "NSS sized for 600 samples" in out, out
    assert calls == [("nss", 600, {})], calls
