"""Configuration of `sloshrom reproduce`: the shipped defaults, merged with a user's TOML file.

:func:`load` merges and then :func:`validate`\\ s against :func:`config_model`, a pydantic
schema with one model per TOML table: every key of the defaults is checked (type, bounds, list
contents and the relations between keys) *before* any stage runs, so that a bad value costs one
error line naming the key, not a traceback after minutes of work. Unknown keys are refused.

The configuration is assembled from its owners: the paper's tables are declared here (their
defaults in ``defaults.toml``), each ROM class's table ``[rom.<class>]`` from its registry entry
(:mod:`sloshrom.rom.registry`), and each registered study's own table and keys of ``[beyond]``
from its declaration (:class:`~sloshrom.pipeline.schema.StudyTable`, through
:mod:`sloshrom.pipeline.registry`), with its defaults and checks. The beam's and the rig's
limits and checks are theirs (``beam.simulation.limits``, ``beam.damping.limits``,
``rig.limits``); the ROMs' (delays, neurons, epochs, members, weights, seeds) those of
:mod:`sloshrom.limits`.

The stages receive the validated, frozen :class:`ReproduceConfig` and read its attributes
(``cfg.rom.delays``, ``cfg.beam.rms_g``); :meth:`ReproduceConfig.as_dict` gives the dict form,
keys in the order of the defaults, that is written beside the results and hashed into the stage
cache keys.
"""

from __future__ import annotations

import copy
import tomllib
import warnings
from collections.abc import Callable
from functools import cache
from importlib import resources
from pathlib import Path
from typing import Annotated, Any, Literal, NamedTuple, get_args

from pydantic import AfterValidator, Field, ValidationError, create_model, model_validator
from pydantic_core import ErrorDetails

from sloshrom.beam.damping.limits import (
    FREE_DAMPING_PERIODS,
    WELCH_SEGMENT,
    check_analysis_band,
    min_free_duration,
)
from sloshrom.beam.simulation.limits import (
    MAX_BEAM_MODES,
    MAX_BEAM_SECONDS,
    MAX_LEVEL_SECONDS,
    check_psd_band,
    first_frozen_frequency,
)
from sloshrom.beam.simulation.structure import CantileverBeam
from sloshrom.config import ConfigError, ConfigWarning, Tank, load_toml
from sloshrom.limits import (
    MAX_DELAY,
    MAX_MEMBERS,
    MAX_NEURONS,
    MAX_WEIGHTS,
)
from sloshrom.pipeline.registry import study_tables
from sloshrom.pipeline.schema import Delays, Neurons, Seed, distinct_values, items, number
from sloshrom.pipeline.schema import Says as _Says
from sloshrom.pipeline.schema import Table as _Table
from sloshrom.pipeline.schema import shown as _shown
from sloshrom.rig.limits import MAX_FINE_SECONDS, MIN_VFA_DURATION, check_record_rate
from sloshrom.rom.errors import ROMError
from sloshrom.rom.registry import (
    CLASSES,
    LOSS_TERMS,
    Hyper,
    ModelClass,
    Naming,
    paper_class,
    swept,
)

__all__ = [
    "MAX_MODEL_WEIGHTS",
    "OPTIONAL_KEYS",
    "QUICK",
    "BeamTable",
    "BeyondTable",
    "DataTable",
    "MapTable",
    "ReproduceConfig",
    "RigTable",
    "CLASS_TABLES",
    "RomNetwork",
    "RomTable",
    "TankTable",
    "config_model",
    "default_text",
    "defaults",
    "load",
    "merge",
    "sloshing_recipe",
    "sweep_key",
    "validate",
]

# Reduced sizes for `--quick` (a smoke run of the whole chain in a few minutes); each ROM
# class's table takes its entry's quick values (``ModelClass.quick``: the paper's NFIR smaller
# and shorter, the NSS 4 epochs).
QUICK: dict[str, dict[str, Any]] = {
    "data": {"train_duration": 120.0, "validation_duration": 60.0, "design": "shaker"},
    "rom": {"ensemble": 2, **{mc.name: dict(mc.quick) for mc in CLASSES.values() if mc.quick}},
    "map": {"n_omega": 10, "n_a": 8},
    "beam": {"free_duration": 6.0, "random_duration": 70.0},
}

#: Keys a table may hold that ``defaults.toml`` leaves out (absent: a calibrated default):
#: ``[rig]`` overrides of the virtual rig's physics (``sloshrom/rig/rig_params.toml``).
OPTIONAL_KEYS: dict[str, tuple[str, ...]] = {"rig": ("restitution", "beta")}

#: Fed-back outputs of the NOE built by `reproduce` (``NOE(out_delays=2)``, the default).
NOE_OUT_DELAYS = 2
#: Most network weights one model file holds (:data:`sloshrom.limits.MAX_WEIGHTS`): an ensemble
#: that cannot be saved is refused here, before the rig data and the training.
MAX_MODEL_WEIGHTS = MAX_WEIGHTS


def _sections(text: str) -> list[list[str]]:
    """The lines of a TOML text by table, each from its header (the lines before the first table
    first), without the blank lines that end a table."""
    out: list[list[str]] = [[]]
    for line in text.splitlines():
        if line.startswith("["):
            out.append([])
        out[-1].append(line)
    for lines in out:
        while lines and not lines[-1].strip():
            lines.pop()
    return out


def _shipped_text() -> str:
    """``defaults.toml`` with the registered studies' defaults in their place: their keys of
    ``[beyond]`` after its own (the studies' switches last), their tables after it, in the
    registry's order (:func:`sloshrom.pipeline.registry.study_tables`)."""
    core = (resources.files("sloshrom.pipeline") / "defaults.toml").read_text(
        encoding="utf-8").splitlines()
    keys: list[str] = []
    switches: list[str] = []
    tables: list[str] = []
    for t in study_tables():
        for part in _sections(t.defaults)[1:]:
            if _table_name(part[0]) == "beyond":
                (switches if t.switch is not None else keys).extend(part[1:])
            else:
                tables.append("\n".join(part))
    # the studies' keys at the end of [beyond] (its blank lines after them)
    start = next(i for i, line in enumerate(core) if _table_name(line) == "beyond")
    end = next((i for i in range(start + 1, len(core)) if core[i].startswith("[")), len(core))
    while end > start + 1 and not core[end - 1].strip():
        end -= 1
    lines = [*core[:end], *keys, *switches, *core[end:]]
    while lines and not lines[-1].strip():
        lines.pop()
    return "\n\n".join(["\n".join(lines), *tables]) + "\n"


def _table_name(line: str) -> str | None:
    """The table a TOML header line opens (``"[beyond]  # ..."`` -> ``"beyond"``), else None."""
    head = line.split("#")[0].strip()
    return head[1:-1] if head.startswith("[") and head.endswith("]") else None


def _toml_value(v: Any) -> str:
    return f'"{v}"' if isinstance(v, str) else repr(v)


def _class_keys(name: str) -> list[Hyper]:
    """The keys of ``[rom.<name>]``: the class's hyperparameters but the seed (``rom.seed``)."""
    return [h for h in CLASSES[name].hyper if h.name != "seed"]


def default_text() -> str:
    """The shipped defaults, as TOML text with comments.

    ``defaults.toml`` gives each ``[rom.<class>]`` table only what `reproduce` chooses; the
    other keys take the class's defaults of :mod:`sloshrom.rom.registry` (its loss terms the
    class's passive recipe: `reproduce` trains on a velocity in m/s and a force in N), written
    here with their meaning, so that the text lists every key.
    """
    lines = _shipped_text().splitlines()
    given = tomllib.loads("\n".join(lines))["rom"]
    sections = [i for i, ln in enumerate(lines) if ln.startswith("[")]

    def filled(name: str) -> list[str]:
        mc = CLASSES[name]
        out = []
        for h in _class_keys(name):
            if h.name in given.get(name, {}):
                continue
            # reproduce's records are a velocity in m/s and a force in N: the class's recipe
            passive = h.name in mc.loss_terms and mc.recipe_needs(mc.defaults()) is None
            value = mc.recipe.get(h.name, h.default) if passive else h.default
            why = "its passive recipe" if passive else "the class's default"
            out.append(f"{h.name} = {_toml_value(value)}".ljust(28) + f"# {h.help} ({why})")
        return out

    out: list[str] = []
    last_rom = max(i for i in sections if lines[i].startswith("[rom"))
    for k, i in enumerate(sections + [len(lines)]):
        start = sections[k - 1] if k else 0
        chunk = lines[start:i]
        head = chunk[0].split("#")[0].strip() if k else ""
        if head.startswith("[rom.") and head.endswith("]"):
            # the table's own lines, then the class's defaults, before the blank line
            while chunk and not chunk[-1].strip():
                chunk = chunk[:-1]
            chunk = [*chunk, *filled(head[5:-1]), ""]
        out += chunk
        if start == last_rom:  # the classes defaults.toml leaves out, after the last one
            for name in CLASSES:
                if name not in given:
                    out += [f"[rom.{name}]", *filled(name), ""]
    return "\n".join(out) + "\n"


def sloshing_recipe(name: str) -> dict[str, object]:
    """What `reproduce` chooses for the class ``name`` beyond its defaults: the keys its
    shipped ``[rom.<name>]`` table sets (an NSS's ``feedthrough = "no"`` and
    ``velocity_offset = 0.5``, say). `train` takes them for records of a velocity in m/s and a
    force in N, the sloshing records they were chosen for; ``{}`` for a class the table does
    not tune."""
    return dict(tomllib.loads(_shipped_text())["rom"].get(name, {}))


def defaults() -> dict[str, Any]:
    """The shipped defaults as a dict of tables (every ``[rom.<class>]`` key included)."""
    return tomllib.loads(default_text())


def merge(base: dict[str, Any], override: dict[str, Any], where: str = "") -> dict[str, Any]:
    """Deep-merge ``override`` into a copy of ``base``; unknown keys or wrong types are errors.

    A number given where ``base`` holds a float becomes a float (TOML ``fs = 500`` reads as an
    integer), so a merged configuration has the types of the defaults. The optional keys of
    :data:`OPTIONAL_KEYS` (absent from the defaults) are accepted as numbers, made floats.
    """
    out = copy.deepcopy(base)
    for key, value in override.items():
        path = f"{where}{key}"
        if key not in base and key in OPTIONAL_KEYS.get(where.rstrip("."), ()):
            if not isinstance(value, int | float) or isinstance(value, bool):
                raise ConfigError(f"'{path}' must be a number, got {_shown(value)}")
            out[key] = float(value)
            continue
        if key not in base:
            raise ConfigError(f"unknown configuration key '{path}'")
        if isinstance(base[key], dict):
            if not isinstance(value, dict):
                raise ConfigError(f"'{path}' must be a table")
            out[key] = merge(base[key], value, where=f"{path}.")
            continue
        ref = base[key]
        if isinstance(ref, bool):
            if not isinstance(value, bool):
                raise ConfigError(f"'{path}' must be true or false, got {_shown(value)}")
        elif isinstance(ref, int | float):
            # bool is an int in Python: true is no number of a TOML file
            if not isinstance(value, int | float) or isinstance(value, bool):
                what = "an integer" if isinstance(ref, int) else "a number"
                raise ConfigError(f"'{path}' must be {what}, got {_shown(value)}")
            value = type(ref)(value) if isinstance(ref, float) else value
        elif isinstance(ref, str) and not isinstance(value, str):
            raise ConfigError(f"'{path}' must be a string, got {_shown(value)}")
        elif isinstance(ref, list) and not isinstance(value, list):
            raise ConfigError(f"'{path}' must be a list, got {_shown(value)}")
        out[key] = value
    return out


def load(path: str | Path | None = None, quick: bool = False) -> ReproduceConfig:
    """Defaults, then ``QUICK`` if asked, then the user's file (which wins); validated.

    Returns
    -------
    ReproduceConfig
        The typed configuration (:func:`validate`).

    Raises
    ------
    ConfigError
        Missing or malformed file, unknown key, or a value :func:`validate` rejects.
    """
    cfg = defaults()
    if quick:
        cfg = merge(cfg, QUICK)
    if path is not None:
        cfg = merge(cfg, renamed_keys(load_toml(path), cfg["rom"]["arch"]))
    return validate(cfg)


#: The keys of ``[rom]`` before each class had its table: a class's own (its entry's
#: ``former_keys``), the sizes of the paper's classes, and whether to compare with the paper's.
_FORMER_SIZES = ("delays", "neurons", "hidden", "max_epochs")
_FORMER_COMPARE = f"compare_{paper_class().name}"


def renamed_keys(user: dict[str, Any], default_arch: str) -> dict[str, Any]:
    """A user's configuration with the former flat ``[rom]`` keys under their names now.

    A class's own flat keys are its table's (the NSS's ``nss_states`` is ``rom.nss.n_states``,
    each ``nss_<key>`` ``rom.nss.<key>``: its entry's ``former_keys``); the network sizes
    ``delays``, ``neurons``, ``hidden``, ``max_epochs`` trained the ROM of ``arch`` when it was
    one of the paper's classes and the compared paper's NFIR, so they are that class's (else
    ``rom.nfir``'s); the loss weights trained the ROM of ``arch``; ``compare_nfir = true`` is
    ``compare = ["nfir"]`` (for the ROM of a class that had flat keys of its own, the NSS; it
    was ignored otherwise). Each renamed key is said in a
    :class:`~sloshrom.config.ConfigWarning` that names the new key.
    """
    rom = user.get("rom")
    if not isinstance(rom, dict):
        return user
    arch = rom.get("arch", default_arch)
    mc = CLASSES.get(arch) if isinstance(arch, str) else None
    paper = paper_class().name
    former = {k: (c.name, v) for c in CLASSES.values() for k, v in c.former_keys.items()}
    out = {k: v for k, v in rom.items()}
    for key in list(rom):
        if key in former:
            new = former[key]
        elif key in _FORMER_SIZES:
            new = (arch if mc is not None and mc.paper else paper, key)
        elif key in LOSS_TERMS:
            new = (arch if mc is not None else paper, key)
        elif key == _FORMER_COMPARE:
            value = out.pop(key)
            out["compare"] = ([paper] if value is True and mc is not None and mc.former_keys
                              else [])
            warnings.warn(ConfigWarning(
                f"'rom.{_FORMER_COMPARE}' is now 'rom.compare' (a list of classes): read as "
                f"compare = {out['compare']}"), stacklevel=2)
            continue
        else:
            continue
        value = out.pop(key)
        table = out.setdefault(new[0], {})
        if isinstance(table, dict):
            table.setdefault(new[1], value)
        warnings.warn(ConfigWarning(f"'rom.{key}' is now 'rom.{new[0]}.{new[1]}': read as such"),
                      stacklevel=2)
    return {**user, "rom": out}


# -- field types: bounds for pydantic, words for the messages -----------------------------------
def _number(lo: float | None = None, hi: float | None = None, *, lo_open: bool = False,
            hi_open: bool = False, integer: bool = False, what: str = "a number",
            why: str = "") -> Any:
    """A finite number (an integer if ``integer``) in [lo, hi] (open ends on request), its
    words those of ``schema.number``."""
    says = number(lo, hi, lo_open=lo_open, hi_open=hi_open, integer=integer, what=what, why=why)
    bounds = Field(gt=lo if lo_open else None, ge=None if lo_open else lo,
                   lt=hi if hi_open else None, le=None if hi_open else hi,
                   description=says.what, **({} if integer else {"allow_inf_nan": False}))
    return Annotated[int if integer else float, bounds, _Says(says.what, says.why)]


def _list(item: Any, what: str, distinct: bool = False) -> Any:
    """A non-empty list whose every element is an ``item``."""
    return Annotated[list[item], items(what, distinct=distinct)]


VfaSeconds = Annotated[float, number(
    MIN_VFA_DURATION, MAX_FINE_SECONDS, what="a VFA duration in s",
    why="the shortest VFA path is 10 s; 1 h at the rig's 10 kHz step needs about 6 GB of memory")]
GridSize = Annotated[int, number(2, 200, integer=True, what="an integer")]
MapFrequency = Annotated[float, number(1.0, 200.0, what="a frequency in Hz")]
ABar = Annotated[float, number(0.0, 1.0, lo_open=True,
                               what="a displacement amplitude / tank height")]
PositiveHz = Annotated[float, number(0.0, lo_open=True, what="a frequency in Hz")]
BeamSeconds = Annotated[float, number(0.0, MAX_BEAM_SECONDS, lo_open=True, what="a duration in s")]
Grid = Annotated[list[Delays], items(f"delays (integers in [1, {MAX_DELAY}])", distinct=True)]
NeuronGrid = Annotated[list[Neurons], items(f"neuron counts (integers in [1, {MAX_NEURONS}])",
                                            distinct=True)]


class TankTable(_Table):
    """``[tank]``: numbers here, values checked by :class:`sloshrom.config.Tank` itself."""

    length: int | float
    width: int | float
    height: int | float
    fill: int | float
    density: int | float
    surface_tension: int | float
    structure_mass: int | float

    def tank(self) -> Tank:
        """The :class:`Tank` of this table (its physical checks raise :class:`ConfigError`)."""
        try:
            return Tank(**self.model_dump())
        except ConfigError as exc:
            raise ConfigError(f"[tank]: {exc}") from None

    @model_validator(mode="after")
    def _physical(self) -> TankTable:
        self.tank()
        return self


class RigTable(_Table):
    """``[rig]``: the virtual rig's seed, record rate and optional physics overrides."""

    seed: Seed
    # the record rate of the rig's sensors: decimated from the 5 kHz acquisition, and the VFA
    # band (up to 25 Hz) must lie well inside the anti-alias passband 0.8 fs/2
    fs: _number(100.0, 5000.0, what="a record rate in Hz",
                why="decimated from the sensors' 5 kHz acquisition; 25 Hz must stay inside the "
                    "anti-alias passband 0.8 fs/2")
    # the input gain of the rig's twin runs (sloshrom.pipeline.waveform): how far a force the
    # laboratory could not tell from the nominal one may lie from it
    twin_gain: _number(0.9, 1.1, what="a gain factor",
                       why="the twin run repeats a test with the input scaled by a factor close "
                           "to 1: 1.001 = +0.1 %")
    # optional overrides of the calibrated physics (rig_params.toml): OPTIONAL_KEYS
    restitution: _number(0.0, 1.0, hi_open=True, what="a coefficient of restitution",
                         why="e = 1 would be a layer impact without loss") = None
    beta: _number(0.0, 1.0, lo_open=True, what="a fraction of the liquid mass",
                  why="the fraction of the liquid in the impacting column") = None

    def overrides(self) -> dict[str, float]:
        """The physics overrides given (:data:`OPTIONAL_KEYS`), by name in the order given;
        empty: calibrated."""
        return {k: v for k, v in self._given().items()
                if k in OPTIONAL_KEYS["rig"] and v is not None}

    @model_validator(mode="after")
    def _divides_rig_rate(self) -> RigTable:
        check_record_rate(self.fs, "'rig.fs'")
        return self


class DataTable(_Table):
    """``[data]``: the VFA training and validation records and their design."""

    train_duration: VfaSeconds
    validation_duration: VfaSeconds
    train_seed: Seed
    validation_seed: Seed
    design: Literal["use", "structure", "shaker"]
    margin: _number(1.0, 3.0, what="a factor over the beam tests' tank motion")
    extension_duration: _number(20.0, 3600.0, what="a duration in s")
    extension_band: _number(1.0, 5.0, lo_open=True, what="a frequency factor")
    random_factors: _list(_number(0.01, 3.0, what="a factor on a [beam] rms_g level"),
                          "factors on the [beam] rms_g levels")
    random_duration: _number(10.0, 600.0, what="a duration in s",
                             why="the validation segment, half of it, needs more than its "
                                 "two 2 s fades")
    decay_factors: _list(_number(0.01, 3.0, what="a factor on [beam] tip_displacement"),
                         "factors on [beam] tip_displacement")
    decay_duration: _number(2.0, 60.0, what="a duration in s")


class RomNetwork(NamedTuple):
    """A model the ``rom`` stage (or the sweep) trains, for the checks against the record and
    the model-file limits: its registry ``class_`` (:class:`sloshrom.rom.registry.ModelClass`),
    its hyperparameters ``hyper`` (those that train it) and ``keys``, the configuration keys
    named in a message (``key(name)``: the key of each hyperparameter)."""

    class_: ModelClass
    hyper: dict[str, Any]
    keys: str
    key: Callable[[str], str]

    def check(self, n_samples: int, samples: str, members: int = 1,
              members_key: str = "") -> None:
        """The class's rules for a training (:meth:`ModelClass.check`, the one place they
        are written) on ``n_samples`` samples (``samples``: the keys that give them), with
        ``members`` in one file (given by ``members_key``).

        Raises
        ------
        ConfigError
            The first rule broken, naming the keys.
        """
        naming = Naming(key=self.key, samples=lambda n: f"{self.keys}: {n} samples ({samples})",
                        members=lambda k: f"{members_key} = {k} members", value=_shown)
        try:
            self.class_.check(self.hyper, n_samples=n_samples, members=members, naming=naming)
        except ROMError as exc:
            raise ConfigError(str(exc)) from None


def _keys(mc: ModelClass) -> Callable[[str], str]:
    """The configuration key of each hyperparameter of ``mc``: ``'rom.<class>.<name>'``, the
    seed ``'rom.seed'``."""
    return lambda k: "'rom.seed'" if k == "seed" else f"'rom.{mc.name}.{k}'"


def _hyper_field(h: Hyper) -> Any:
    """The settings' field of a registry hyperparameter: its domain, in the settings' words."""
    if h.kind == "choice":
        return Literal[h.choices]
    if h.kind == "delays":  # a configuration gives n (delays 1..n)
        return _number(1, h.hi, integer=True, what="an integer")
    return _number(h.lo, h.hi, lo_open=h.lo_open, hi_open=h.hi_open,
                   integer=h.kind == "int", what=h.what)


def _class_table(mc: ModelClass) -> type[_Table]:
    """``[rom.<class>]``: the class's hyperparameters (the seed is ``rom.seed``), by the
    registry; the class's rules (:meth:`ModelClass.check`) check them first, their messages
    naming the keys."""
    fields = {h.name: (_hyper_field(h), ...) for h in mc.hyper if h.name != "seed"}

    def rules(cls: type[_Table], values: object) -> object:
        # a table of every key (pydantic names a missing or unknown one)
        if isinstance(values, dict) and set(values) == set(fields):
            try:
                mc.check(values, training=False, naming=Naming(key=_keys(mc), value=_shown))
            except ROMError as exc:
                raise ConfigError(str(exc)) from None
        return values

    return create_model(f"{mc.class_name}Table", __base__=_Table,
                        __doc__=f"``[rom.{mc.name}]``: {mc.summary}.",
                        __validators__={"_rules": model_validator(mode="before")(rules)},
                        **fields)


#: The table of each ROM class, ``[rom.<name>]``.
CLASS_TABLES: dict[str, type[_Table]] = {name: _class_table(mc) for name, mc in CLASSES.items()}
ClassName = Literal[tuple(CLASSES)]


def sweep_key(mc: ModelClass, what: str) -> str:
    """The ``[rom]`` key of a swept class's grid: ``sweep_<class>_delays`` or ``_neurons``."""
    return f"sweep_{mc.name}_{what}"


class _RomTableBase(_Table):
    arch: ClassName
    compare: Annotated[list[ClassName], AfterValidator(distinct_values),
                       _Says(f"a list of distinct ROM classes ({', '.join(CLASSES)})")]
    seed: Seed
    ensemble: _number(1, MAX_MEMBERS, integer=True, what="a number of ensemble members")
    ensemble_workers: _number(1, 64, integer=True, what="a number of parallel trainings")
    sweep: bool
    sweep_workers: _number(1, 64, integer=True, what="a number of parallel trainings")


#: ``[rom]``'s keys of the sensitivity analysis: the grid of each swept class
_SWEEP_GRIDS = {key: (grid, ...) for mc in swept()
                for key, grid in ((sweep_key(mc, "delays"), Grid),
                                  (sweep_key(mc, "neurons"), NeuronGrid))}


class RomTable(create_model("_RomClasses", __base__=_RomTableBase, **_SWEEP_GRIDS,
                            **{n: (t, ...) for n, t in CLASS_TABLES.items()})):
    """``[rom]``: the ROM of the report (``arch``), the classes identified beside it
    (``compare``), their training, the sensitivity sweep; ``[rom.<class>]`` the
    hyperparameters of each class of the registry."""

    @model_validator(mode="after")
    def _classes(self) -> RomTable:
        if self.ensemble > 1 and not CLASSES[self.arch].ensemble:
            raise ConfigError(f"'rom.ensemble' = {self.ensemble}: an "
                              f"{CLASSES[self.arch].class_name} is fitted deterministically, "
                              "so its members would be one model; set 'rom.ensemble' = 1")
        return self

    def compared(self) -> list[str]:
        """The classes identified beside the ROM: ``compare`` but the ROM's own class."""
        return [c for c in self.compare if c != self.arch]

    def table(self, name: str | None = None) -> _Table:
        """``[rom.<name>]`` (default: of ``arch``)."""
        return getattr(self, self.arch if name is None else name)

    def hyper(self, name: str | None = None) -> dict[str, Any]:
        """The estimator arguments of class ``name`` (default: ``arch``): its table and the
        seed."""
        name = self.arch if name is None else name
        out = self.table(name).model_dump()
        if any(h.name == "seed" for h in CLASSES[name].hyper):
            out["seed"] = self.seed
        return out

    def loss_terms(self, name: str | None = None) -> dict[str, float]:
        """The loss weights by name (:data:`sloshrom.rom.registry.LOSS_TERMS`; 0 = off) of
        class ``name`` (default: ``arch``); empty for a class without them."""
        h = self.hyper(name)
        return {k: h[k] for k in CLASSES[self.arch if name is None else name].loss_terms}

    def name(self, arch: str | None = None) -> str:
        """The ROM's name in the report, e.g. ``"NFIR(70, 35)"`` or ``"NSS(8 states, 64
        neurons)"``; ``arch`` (default: the configured one) names another class."""
        arch = self.arch if arch is None else arch
        return CLASSES[arch].label(self.hyper(arch))

    def networks(self) -> list[RomNetwork]:
        """The largest model of each kind to be trained: the ROM, the compared classes, the
        sweep's largest NFIR and NOE."""
        out = [RomNetwork(CLASSES[n], self.hyper(n), f"'rom.{n}'", _keys(CLASSES[n]))
               for n in (self.arch, *self.compared())]
        if self.sweep:
            for mc in swept():
                grid = {k: f"'rom.{sweep_key(mc, k)}'" for k in ("delays", "neurons")}
                hyper = {**self.hyper(mc.name),
                         **{k: max(getattr(self, sweep_key(mc, k))) for k in grid}}
                out.append(RomNetwork(
                    mc, hyper, f"the largest of {'/'.join(grid.values())}",
                    lambda k, mc=mc, grid=grid: grid.get(k) or _keys(mc)(k)))
        return out


class MapTable(_Table):
    """``[map]``: the harmonic-test grid of the Phi_d maps and the shaker envelope."""

    # each frequency runs n_a harmonic tests as one batch at the rig's 10 kHz step
    n_omega: GridSize
    n_a: GridSize
    f_min: MapFrequency
    f_max: MapFrequency
    a_bar_min: ABar
    a_bar_max: ABar
    gamma_max: _number(0.0, 60.0, lo_open=True, what="an acceleration amplitude in g")

    @model_validator(mode="after")
    def _ordered(self) -> MapTable:
        if not self.f_min < self.f_max:
            raise ConfigError(f"'map.f_min' ({self.f_min:g} Hz) must be below 'map.f_max' "
                              f"({self.f_max:g} Hz)")
        if not self.a_bar_min < self.a_bar_max:
            raise ConfigError(f"'map.a_bar_min' ({self.a_bar_min:g}) must be below "
                              f"'map.a_bar_max' ({self.a_bar_max:g})")
        return self


class BeamTable(_Table):
    """``[beam]``: the cantilever, its free and random tests and its modal damping."""

    # geometry and material (SI): a laboratory or wing-like beam, not a typo in mm or GPa
    length: _number(0.01, 100.0, what="a length in m")
    width: _number(1e-4, 10.0, what="a width in m")
    thickness: _number(1e-4, 1.0, what="a thickness in m")
    youngs_modulus: _number(1e6, 1e13, what="a Young's modulus in Pa")
    density: _number(1.0, 3e4, what="a density in kg/m^3")
    tip_displacement: _number(0.0, 0.2, lo_open=True, what="an initial tip displacement in m")
    free_duration: BeamSeconds
    random_duration: BeamSeconds
    rms_g: _list(_number(0.0, 2.0, lo_open=True, what="an RMS level in g"),
                 "RMS levels in g, each in (0, 2]")
    f0: PositiveHz
    sigma: PositiveHz
    seed: Seed
    damping: _list(_number(0.0, 1.0, hi_open=True, what="a damping ratio"),
                   "modal damping ratios, each in [0, 1)")
    n_modes: _number(1, MAX_BEAM_MODES, integer=True, what="an integer",
                     why="the modal filter separates at most as many modes as the beam has "
                         "accelerometer stations")
    lab_noise: _number(0.0, 10.0, what="an accelerometer noise RMS in m/s^2")

    @model_validator(mode="after")
    def _consistent(self) -> BeamTable:
        if len(self.damping) < self.n_modes:
            raise ConfigError(f"'beam.damping' has {len(self.damping)} ratio(s) but "
                              f"'beam.n_modes' is {self.n_modes}: give one damping ratio per mode")
        level_seconds = self.random_duration * len(self.rms_g)
        if level_seconds > MAX_LEVEL_SECONDS:
            raise ConfigError(
                f"'beam.random_duration' x {len(self.rms_g)} levels = {level_seconds:g} s is "
                f"more than {MAX_LEVEL_SECONDS:g} s (memory: the rig holds about 2.1 MB per "
                "second and level at its 10 kHz step)")
        return self

    def structure(self, tank: Tank) -> CantileverBeam:
        """The cantilever beam of this table carrying ``tank``."""
        try:
            return CantileverBeam.with_tank(
                tank, length=self.length, width=self.width, thickness=self.thickness,
                youngs_modulus=self.youngs_modulus, density=self.density)
        except ConfigError as exc:
            raise ConfigError(f"[beam]: {exc}") from None


class _BeyondTable(_Table):
    """``[beyond]``: the sections beyond the paper (``reproduce --beyond``): ``enabled``, then
    the registered studies' keys (:func:`_beyond_fields`), each study's checked by its own
    model."""

    enabled: bool

    @model_validator(mode="after")
    def _studies(self) -> _BeyondTable:
        for t in study_tables():
            if t.beyond is not None:  # the study's keys, by its own checks
                t.beyond.model_validate({k: getattr(self, k) for k in t.beyond_keys()})
        return self


def _beyond_fields() -> dict[str, Any]:
    """The registered studies' keys of ``[beyond]``, in the order of the defaults: each study's
    own keys (the registry's order), then their switches."""
    tables = study_tables()
    order = [t for t in tables if t.switch is None] + [t for t in tables if t.switch is not None]
    return {k: (f.annotation, f) for t in order if t.beyond is not None
            for k, f in t.beyond.model_fields.items()}


class BeyondTable(create_model("_StudyKeys", __base__=_BeyondTable, **_beyond_fields())):
    """``[beyond]``: the sections beyond the paper (``reproduce --beyond``): ``enabled``, and the
    keys and switches of the registered studies (``sloshrom.pipeline.registry``)."""


class ReproduceConfig(_Table):
    """The whole configuration of `sloshrom reproduce`, one model per table of the defaults.

    The paper's tables are declared here; a registered study's own table (``[baseline]``,
    ``[multimode]``) is added by :func:`config_model` from its declaration
    (:class:`~sloshrom.pipeline.schema.StudyTable`), and a study reads it through its own
    accessor. ``config_model().model_json_schema()`` gives the whole as a JSON schema (for an
    editor).

    Every key is required (:func:`load` starts from the defaults); the checks between tables
    (a network's training samples, the excitation band and the beam's modes against the record
    rate, the free response against the first mode, then each enabled study's) run once every
    table is valid on its own.
    """

    tank: TankTable
    rig: RigTable
    data: DataTable
    rom: RomTable
    map: MapTable
    beam: BeamTable
    beyond: BeyondTable

    def as_dict(self) -> dict[str, Any]:
        """The configuration as a dict of tables, keys in the order of ``defaults.toml``.

        The form written beside the results (``summary.json``, ``config show``) and hashed
        into the stage cache keys: the optional keys left out are left out here too.
        """
        return self._given()

    def tables(self, *names: str) -> dict[str, Any]:
        """The tables ``names`` of :meth:`as_dict` (a stage's part of the configuration)."""
        whole = self.as_dict()
        return {k: whole[k] for k in names}

    def study_table(self, name: str) -> _Table:
        """The validated table ``[name]`` of a registered study (its own accessor types it)."""
        table = getattr(self, name)
        if not isinstance(table, _Table):
            raise ConfigError(f"no study table [{name}] in the configuration")
        return table

    def replace(self, **changes: dict[str, Any]) -> ReproduceConfig:
        """A copy with some keys changed, e.g. ``cfg.replace(rom={"sweep": True})``, validated.

        Raises
        ------
        ConfigError
            An unknown key or a value :func:`validate` rejects.
        """
        return validate(merge(self.as_dict(), changes))

    @model_validator(mode="after")
    def _across_tables(self) -> ReproduceConfig:
        fs, b = self.rig.fs, self.beam
        n_train = self.data.train_duration * fs
        r = self.rom
        samples = (f"'data.train_duration' = {self.data.train_duration:g} s at 'rig.fs' = "
                   f"{fs:g} Hz")
        rom, *others = r.networks()
        # the ROM's members are one file (a study's, e.g. the fill family's, check theirs:
        # check_members)
        rom.check(int(n_train), samples, r.ensemble, "'rom.ensemble'")
        for net in others:
            net.check(int(n_train), samples)
        check_psd_band(b.f0, b.sigma, names=("'beam.f0'", "'beam.sigma'"), error=ConfigError,
                       fs=fs)
        if b.random_duration * fs < WELCH_SEGMENT:
            raise ConfigError(
                f"'beam.random_duration' = {b.random_duration:g} s must hold at least one "
                f"{WELCH_SEGMENT}-sample Welch segment at 'rig.fs' = {fs:g} Hz "
                f"({WELCH_SEGMENT / fs:.3g} s) for the damping estimates of Table 2")
        tank = self.tank.tank()
        beam = b.structure(tank)
        f1 = first_frozen_frequency(tank, b.n_modes, b.damping[: b.n_modes], beam=beam)
        need_s = min_free_duration(f1)
        if b.free_duration < need_s:
            raise ConfigError(
                f"'beam.free_duration' = {b.free_duration:g} s is too short for the damping "
                f"analysis of mode 1 ({f1:.3g} Hz): need at least {need_s:g} s "
                f"({FREE_DAMPING_PERIODS} periods)")
        check_analysis_band(f1, error=ConfigError, fs=fs)
        # the ROM and the frozen case run the structure at fs: every kept mode below Nyquist
        top = beam.frequencies(b.n_modes)[-1]
        if top >= fs / 2:
            raise ConfigError(
                f"'beam.n_modes' = {b.n_modes}: mode {b.n_modes} of the beam ({top:.4g} Hz) "
                f"lies above the Nyquist frequency of 'rig.fs' = {fs:g} Hz: raise 'rig.fs' or "
                "keep fewer modes")
        for t in study_tables():  # the studies' own checks across the tables
            t.check(self)
        return self

    def check_members(self, key: str, k: int) -> None:
        """An ensemble of ``k`` members of the ROM (``key`` names them in the message): the
        ROM class's rules for a training of that many members in one file
        (:meth:`sloshrom.rom.registry.ModelClass.check`: at most :data:`MAX_MODEL_WEIGHTS`
        weights among them).

        Raises
        ------
        ConfigError
            The first rule broken, naming the keys.
        """
        fs = self.rig.fs
        samples = (f"'data.train_duration' = {self.data.train_duration:g} s at 'rig.fs' = "
                   f"{fs:g} Hz")
        self.rom.networks()[0].check(int(self.data.train_duration * fs), samples, k, key)


@cache
def config_model() -> type[ReproduceConfig]:
    """The model that validates a whole configuration: :class:`ReproduceConfig` with the
    registered studies' own tables (``sloshrom.pipeline.registry``), after the paper's."""
    return create_model("ReproduceConfig", __base__=ReproduceConfig,
                        __doc__=ReproduceConfig.__doc__,
                        **{t.table: (t.model, ...) for t in study_tables()
                           if t.table is not None and t.model is not None})


# -- validation: pydantic's errors as one line naming the key ----------------------------------
_STRUCTURE = {"missing", "extra_forbidden", "model_type", "model_attributes_type", "dict_type"}


def validate(cfg: dict[str, Any] | ReproduceConfig) -> ReproduceConfig:
    """Check a whole configuration of `sloshrom reproduce` before any stage runs.

    Every table and key of ``defaults.toml`` must be present (and no other), of the right type
    and within bounds; lists must be non-empty with valid elements; and keys must agree with
    each other (``f_min < f_max``, ``a_bar_min < a_bar_max``, one damping ratio per mode, the
    random-excitation PSD inside the simulation's band, a free response long enough for the
    damping analysis of mode 1, ...): see :class:`ReproduceConfig`.

    Parameters
    ----------
    cfg : dict or ReproduceConfig
        A merged configuration as a dict of tables (:func:`load` returns validated ones;
        :func:`sloshrom.pipeline.run` calls this on configurations built in code). A
        :class:`ReproduceConfig` is valid already and returned as it is.

    Returns
    -------
    ReproduceConfig
        The typed configuration the stages read (``cfg.rom.delays``, ``cfg.beam.rms_g``, ...).

    Raises
    ------
    ConfigError
        The first problem found, naming the key, e.g.
        ``'beam.rms_g' must be a non-empty list of RMS levels in g, each in (0, 2], got []``.
    """
    if isinstance(cfg, ReproduceConfig):
        return cfg
    if not isinstance(cfg, dict):
        raise ConfigError(f"configuration must be a dict of tables, got {type(cfg).__name__}")
    try:
        return config_model().model_validate(cfg)
    except ValidationError as exc:
        # missing and unknown keys first, then values, then relations between keys
        errors = exc.errors(include_url=False)
        first = min(errors, key=lambda e: (e["type"] not in _STRUCTURE, _raised(e) is not None))
        if isinstance(_raised(first), ConfigError):  # a relation: the validator wrote the message
            raise _raised(first) from None
        raise ConfigError(_message(first)) from None


def _raised(error: ErrorDetails) -> Exception | None:
    return error.get("ctx", {}).get("error")


def _message(error: ErrorDetails) -> str:
    """One line for one pydantic error: the key, what it must be, and the value given."""
    loc, kind, v = error["loc"], error["type"], error["input"]
    if _raised(error) is not None:  # another ValueError of a validator
        return str(_raised(error))
    # the key down the nested tables ('rom.nss.n_states'), then a list item's index, if any
    model: Any = config_model()
    keys: list[str] = []
    field = None
    for p in loc:
        if isinstance(p, int) or model is None or p not in model.model_fields:
            break
        keys.append(str(p))
        field = model.model_fields[p]
        ann = field.annotation
        model = ann if isinstance(ann, type) and issubclass(ann, _Table) else None
    key = ".".join(keys) if keys else ".".join(str(p) for p in loc[:2])
    rest = loc[len(keys):]
    if kind == "extra_forbidden":
        return f"unknown configuration key '{'.'.join(str(p) for p in loc)}'"
    if kind == "missing":
        return (f"configuration table [{key}] is missing" if model is not None
                else f"configuration key '{key}' is missing")
    if model is not None or field is None:
        return f"'{key}' must be a table"
    says = next((m for m in field.metadata if isinstance(m, _Says)), None)
    if kind == "literal_error":
        ann = field.annotation
        if get_args(ann) and not isinstance(get_args(ann)[0], str):  # a list of choices
            ann = get_args(ann)[0]
        options = " or ".join(f'"{o}"' for o in get_args(ann))
        return f"'{key}' must be {options}, got {_shown(v)}"
    if kind == "bool_type":
        return f"'{key}' must be true or false, got {_shown(v)}"
    if says is None:  # [tank] values: Tank checks them once they are numbers
        return f"'{key}' must be a number, got {_shown(v)}"
    if kind == "distinct":
        return f"'{key}' {error['msg']}, got {_shown(v)}"
    item_says = says.item or _item_says(field.annotation)
    if rest and item_says is not None:
        item = item_says.value(f"{key}[{rest[0]}]", v)
        return f"'{key}' must be {says.what}: {item}"
    return says.value(key, v)


def _item_says(annotation: Any) -> _Says | None:
    """What the items of a list key must be, as their own annotation says
    (``list[Annotated[float, number(...)]]``); ``None`` for another key."""
    args = get_args(annotation)
    return next((m for m in get_args(args[0])[1:] if isinstance(m, _Says)), None) \
        if args else None
