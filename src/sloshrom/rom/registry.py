"""The registry of ROM classes: the machinery that says what a class is, and the list of them.

A class is one package under ``sloshrom/rom/`` (``tdnn``, ``nss``, ``lss``, ...) whose light
module ``entry`` (no JAX) declares it as a frozen :class:`ModelClass`: its name (``--arch``, the
``[rom.<name>]`` table of ``sloshrom reproduce``), the class name its model files record, its
hyperparameters with their defaults and bounds (:class:`Hyper`), its parameter arrays and their
shapes, its rules (the fewest training samples, the cost of an epoch, what its loss terms
need), its label in messages and the report, the model-file format version, the estimator that
implements it (imported when first needed) and the formats it exports to. The command line
(``sloshrom train``), the configuration of ``sloshrom reproduce``, the model-file schema, the
report and the FMU/ONNX capability checks read these entries; none of them branches on a class.

The rules of a class are checked by one function, :meth:`ModelClass.check`: the estimator's
``fit``, the command line and the settings call it, the last two naming each value by their
own words (:class:`Naming`: an option, a configuration key).

One name per quantity everywhere: a hyperparameter ``n_states`` is the estimator's argument
``n_states``, the model file's field ``hyperparameters.n_states``, the configuration key
``rom.nss.n_states`` and the option ``--n-states``.

:data:`ENTRIES` lists the classes, one line each: the entry of each package, imported the first
time :data:`CLASSES` is read (so that this module imports no class, and a class's entry may use
the machinery here). :func:`register` adds a class from outside the package (before the command
line or the settings are imported: they build their options and tables from the classes then).
A model that is no ROM class but is loaded by :func:`sloshrom.rom.load_model` (the bouncing
ball's ``.toml`` files) declares its files as a :class:`FileKind` in the list too.

This module imports nothing heavy (no JAX), so the command line and the settings read it when
they start (docs/architecture.md, "Adding a model class").
"""

from __future__ import annotations

import functools
import importlib
import math
import operator
from collections.abc import Callable, Collection, Iterator, Mapping, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any, cast

from sloshrom.limits import (
    MAX_BATCH,
    MAX_DELAY,
    MAX_EPOCHS,
    MAX_NEURONS,
    MAX_REGRESSOR,
    MAX_SEED,
    MAX_WEIGHTS,
)
from sloshrom.rom.errors import ROMError

__all__ = ["ARGUMENTS", "CLASSES", "ENTRIES", "EPOCH_WORK_SECONDS", "LOSS_HYPERS", "LOSS_TERMS",
           "MAX_EPOCH_WORK", "MAX_STATES", "OVERSIZE", "RECIPE_UNITS", "SEED", "SHOOTING_HYPERS",
           "EpochWork", "FileKind", "Hyper", "LossChoice", "ModelClass", "Naming", "adam_only",
           "file_kinds", "loss_recipe", "model_class", "model_class_of_file", "neurons",
           "packages", "paper_class", "precision", "register", "required",
           "state_space_min_samples", "swept"]

#: The classes, one line each: ``"module:attribute"`` of the entry that declares it (a
#: :class:`ModelClass`, or a :class:`FileKind` for a model loaded from its own files), in the
#: order of ``--help``, the settings' tables and the report. A new class is its package and
#: one line here.
ENTRIES: tuple[str, ...] = (
    "sloshrom.rom.tdnn.entry:NFIR_CLASS",
    "sloshrom.rom.tdnn.entry:NOE_CLASS",
    "sloshrom.rom.nss.entry:NSS_CLASS",
    "sloshrom.rom.lss.entry:LSS_CLASS",
    "sloshrom.rom.grey.entry:GREY_CLASS",
    "sloshrom.rom.ball.entry:BALL_FILES",
)

#: The passive recipe's loss terms (docs/rom.md, "A passive ROM"): the loss weight floor of
#: the amplitude weighting 1/(a^2 + eps^2), eps in m/s; the weight of the penalty on energy
#: created at harmonic probes; the weight of the error of each input cycle's exchanged energy.
LOSS_TERMS = ("amplitude_weighting", "passivity", "cycle_energy")
#: The units the recipe is written for: a velocity in, a force out (F v is a power).
RECIPE_UNITS = ("m/s", "N")
#: A user's size with more than this many times the parameters of the size rule's is warned
#: of (:meth:`ModelClass.oversize`).
OVERSIZE = 4.0

_REQUIRED = object()


@dataclass(frozen=True)
class Naming:
    """How the messages of :meth:`ModelClass.check` name what they are about, in the words of
    the caller: the estimator's arguments (:data:`ARGUMENTS`), the command line's options, the
    configuration's keys.

    Parameters
    ----------
    key : callable
        ``key(name)``: a hyperparameter (``n_states``, ``--n-states``, ``'rom.nss.n_states'``).
    input : callable
        ``input(signal)``: the signal a model reads (``names[0] = 'acceleration'``,
        ``--input acceleration``).
    arch : callable
        ``arch(model_class)``: a class (``NFIR``, ``--arch nfir``).
    samples : callable
        ``samples(n)``: the training record's samples (``train.nc: 1200 samples``).
    members : callable
        ``members(k)``: the models of one file (``'rom.ensemble' = 2 members``).
    value : callable
        ``value(v)``: a value given (``repr``; a configuration's ``true (a boolean)``).
    """

    key: Callable[[str], str] = str
    input: Callable[[str], str] = lambda signal: f"names[0] = {signal!r}"
    arch: Callable[[ModelClass], str] = lambda mc: mc.class_name
    samples: Callable[[int], str] = lambda n: f"{n} samples"
    members: Callable[[int], str] = lambda k: f"{k} members"
    value: Callable[[object], str] = repr


#: The names of the estimators' arguments (:meth:`ModelClass.check` by default).
ARGUMENTS = Naming()


@dataclass(frozen=True)
class Hyper:
    """One hyperparameter of a class: its name everywhere, its default and its domain.

    Parameters
    ----------
    name : str
        The estimator's argument, the model file's field, the configuration key; the command
        line's option is ``--`` + the name with ``-`` for ``_``.
    default : int, float or str
        The estimator's default.
    kind : {"int", "float", "choice", "delays"}
        ``"delays"``: an int n (delays 1..n) or a list of distinct delays >= 1.
    lo, hi : float, optional
        Bounds (inclusive unless ``lo_open``/``hi_open``); for ``"delays"`` the largest delay.
    choices : tuple of str, optional
        The values of a ``"choice"``.
    help : str
        One line for ``--help`` and the configuration's comments.
    what : str
        What a value is, for the configuration's schema ("a number of samples").
    file_default : optional
        The value a model file written before the field existed is read with; absent: the
        field is required in a file.
    """

    name: str
    default: Any
    kind: str = "int"
    lo: float | None = None
    hi: float | None = None
    lo_open: bool = False
    hi_open: bool = False
    choices: tuple[str, ...] = ()
    help: str = ""
    what: str = "a number"
    file_default: Any = _REQUIRED

    @property
    def option(self) -> str:
        """The command-line option, e.g. ``--n-states``."""
        return "--" + self.name.replace("_", "-")

    @property
    def required_in_file(self) -> bool:
        """Whether a model file must store this hyperparameter (no default for old files)."""
        return self.file_default is _REQUIRED

    def domain(self) -> str:
        """The domain in words, e.g. ``"an integer in [1, 1024]"``."""
        if self.kind == "choice":
            return "one of " + ", ".join(repr(c) for c in self.choices)
        if self.kind == "delays":
            return f"an integer in [1, {self.hi:g}] or a list of distinct delays in that range"
        lo = "(" if self.lo_open else "["
        hi = ")" if self.hi_open else "]"
        if self.kind == "int":
            return f"an integer in {lo}{int(self.lo or 0)}, {int(self.hi or 0)}{hi}"
        return f"a number in {lo}{self.lo:g}, {self.hi:g}{hi}"

    def check(self, value: Any, where: str | None = None,
              shown: Callable[[object], str] = repr) -> Any:
        """``value`` if it lies in the domain (ints as int, floats as float), else
        :class:`ROMError` naming ``where`` (default: the name) and the value as ``shown``
        says it.

        Raises
        ------
        ROMError
            A value of the wrong type or outside the bounds.
        """
        where = self.name if where is None else where
        bad = ROMError(f"{where} must be {self.domain()}, got {shown(value)}")
        if self.kind == "choice":
            if value not in self.choices:
                raise bad
            return value
        if self.kind == "delays":
            return _delays_value(value, where, int(self.hi or MAX_DELAY), shown)
        if self.kind == "int":
            try:
                v: float = operator.index(value)  # ints and NumPy integers, not floats
            except TypeError:
                raise bad from None
            if isinstance(value, bool):
                raise bad
        else:
            if isinstance(value, bool) or not isinstance(value, int | float) and \
                    not hasattr(value, "__float__"):
                raise bad
            v = float(value)
            if not math.isfinite(v):
                raise bad
        lo, hi = self.lo, self.hi
        if lo is not None and (v < lo or (self.lo_open and v == lo)):
            raise bad
        if hi is not None and (v > hi or (self.hi_open and v == hi)):
            raise bad
        return int(v) if self.kind == "int" else v


def _delays_value(value: Any, where: str, top: int,
                  shown: Callable[[object], str] = repr) -> int | list[int]:
    if isinstance(value, bool):
        raise ROMError(f"{where} must be an integer >= 1 or a list of delays, got {shown(value)}")
    try:
        n = operator.index(value)
    except TypeError:
        pass
    else:
        if not 1 <= n <= top:
            raise ROMError(f"{where} must be an integer in [1, {top}], got {shown(value)}")
        return int(n)
    try:
        d = [operator.index(x) for x in value]
    except TypeError:
        raise ROMError(f"{where} must be an integer >= 1 or a list of delays, got "
                       f"{shown(value)}") from None
    if not d or min(d) < 1 or max(d) > top or len(set(d)) != len(d) \
            or any(isinstance(x, bool) for x in value):
        raise ROMError(f"{where} must be distinct integers in [1, {top}], got {shown(value)}")
    return [int(x) for x in d]


@dataclass(frozen=True)
class LossChoice:
    """The loss chosen for a pair of units: the recipe's ``terms`` (all 0: plain MSE), ``why``.

    ``str()`` is the line the command line prints.
    """

    passive: bool
    terms: dict[str, float]
    why: str

    @property
    def name(self) -> str:
        """``"the passive recipe (amplitude weighting 0.05 m/s, ...)"`` or ``"the plain MSE"``."""
        if not self.passive:
            return "the plain MSE"
        return "the passive recipe (" + ", ".join(
            f"{k.replace('_', ' ')} {v:g}{' m/s' if k == 'amplitude_weighting' else ''}"
            for k, v in self.terms.items()) + ")"

    def __str__(self) -> str:
        return f"loss: {self.name}: {self.why}"


@dataclass(frozen=True)
class EpochWork:
    """The bound on the work of one training epoch of a class, and what it measures.

    Parameters
    ----------
    factors : tuple
        The work as a product of hyperparameters (a tuple in it: their sum), in the unit of
        ``limit`` (an NSS's: neuron-samples).
    limit : float
        The most work one epoch may take.
    seconds : float
        The measured time of one unit of work, s (said in the message).
    unit : str
        The unit's name, plural ("neuron-samples").
    """

    factors: tuple[str | tuple[str, ...], ...]
    limit: float
    seconds: float
    unit: str = "neuron-samples"


@dataclass(frozen=True)
class ModelClass:
    """What a ROM class is, for everything outside its own package (module docstring).

    Parameters
    ----------
    name : str
        ``--arch``, the configuration table ``[rom.<name>]``, the model file's stem in
        ``sloshrom reproduce``.
    class_name : str
        The estimator's class name, recorded in model files (``"class"``).
    estimator : str
        ``"module:attribute"`` of the estimator (imported on first use).
    summary : str
        One line: what the class is.
    hyper : tuple of Hyper
        Its hyperparameters, in the estimator's argument order (``units`` and ``names``,
        which every class has, apart).
    label : callable
        ``label(hyper) -> str``: the ROM in messages and the report, e.g. ``"NFIR(70, 35)"``.
    shapes : callable
        ``shapes(hyper) -> {array: shape}``: the parameter arrays of one model, in file order.
    history : callable
        ``history(hyper) -> int``: samples of past record a prediction reads (a validation
        record must be longer).
    min_samples : callable
        ``min_samples(hyper) -> int``: the fewest training samples (read by :meth:`check`).
    start_history : callable
        ``start_history(hyper) -> int``: samples of measured input and output a start from
        history reads beyond ``history`` (an NOE's fed-back outputs, a linear model's order);
        a start from history needs the larger of the two.
    inputs : tuple of str
        The tank signals a model may read (``"velocity"``, ``"acceleration"``).
    loss_terms : tuple of str
        The loss terms of :data:`LOSS_TERMS` it trains with (none: the plain MSE only).
    recipe : mapping
        Its passive recipe: the terms' weights on a velocity in m/s and a force in N.
    recipe_needs : callable, optional
        ``recipe_needs(hyper) -> (name, value) or None``: the hyperparameter value the loss
        terms need that this configuration lacks (``("trainer", "adam")``), None when they
        can train it.
    format_version : int
        The model-file format version its files are written with.
    read_versions : tuple of int
        Older format versions of its files that are still read (the hyperparameters they lack
        take their ``file_default``).
    exports : frozenset of str
        The formats it exports to (``"fmu"``, ``"onnx"``).
    export_notes : mapping
        ``{format: why not}`` for formats it does not export to: the exporter's refusal says
        it (a clause, e.g. ``"its column is a sub-stepped simulation ..."``); a format without a
        note gets the exporter's general reason.
    width : callable
        ``width(hyper) -> int``: entries of the vector its maps read at each step (a
        time-delay network's regressor, a state-space model's state and input): a model file
        bounds it, so that simulating a model needs bounded memory.
    sizes : tuple of str
        The hyperparameters that set the shapes of its arrays (named when arrays disagree).
    weights : callable, optional
        ``weights(hyper) -> int``: the weights that a model file's size limit counts (default:
        every parameter).
    weights_text : callable, optional
        ``weights_text(hyper) -> str``: the weights' count in words, for a message (e.g.
        ``"35 neurons x 70 regressor entries"``); default: none.
    width_text : str
        What :attr:`width` counts, for a message (``"delays + output delays"``).
    relations : callable, optional
        ``relations(hyper, naming)``: the rules between its hyperparameters beyond their
        domains (:class:`ROMError` naming them by ``naming``), e.g. an LSS's block rows above
        its order.
    ensemble : bool
        Whether members that differ by their seed make sense (a deterministic fit: no).
    paper : bool
        One of the paper's classes (the NFIR and the NOE).
    report : str
        What the report says of the class: what it is for sloshing, and why one would choose
        it (a paragraph's sentences, after "The ROM of this report is <label>: ").
    size_rule : callable, optional
        ``size_rule(n_samples, given) -> {name: value}``: the values of the hyperparameters
        of :attr:`sized_by_record` that are not in ``given`` (the user's values of the others)
        for a training record of ``n_samples`` samples. None: no rule.
    sized_by_record : tuple of str
        The hyperparameters the rule chooses when the user gives none (integers; the
        estimator's argument None: "sized by the record").
    size_words : mapping
        How :meth:`size_note` says a value of :attr:`sized_by_record` (``"{} states"``).
    epoch_work : EpochWork, optional
        The bound on the work of one training epoch (:meth:`epoch_cost`); None: not bounded.
    sweep : tuple, optional
        The grid of the sensitivity analysis (paper Fig. 8) over the class's delays and
        neurons: ``(delays, neurons)``, the defaults of ``rom.sweep_<name>_delays`` and
        ``rom.sweep_<name>_neurons``; empty: the class is not swept.
    sweep_first : bool
        Its grid points train longest (a recurrent network's Levenberg-Marquardt): a sweep
        starts them first, so that its workers finish together.
    quick : mapping
        Its table's values in ``sloshrom reproduce --quick`` (a smoke run of the chain).
    former_keys : mapping
        The flat ``[rom]`` keys of the configuration that were this class's before each class
        had its table, each the name of its key now (``rom.<name>.<key>``); read with a
        warning.
    article : str
        The article before its class name in a sentence (``"an"`` NSS, ``"a"`` GreyBox).
    tank_scales : tuple of str
        Hyperparameters that are the tank's quantity of the same name (an attribute of
        :class:`~sloshrom.config.Tank`, e.g. ``liquid_mass``): 0 means "the tank's", which
        ``reproduce`` takes from its ``[tank]`` and ``train`` from the record's tank
        (:meth:`with_tank`).
    """

    name: str
    class_name: str
    estimator: str
    summary: str
    hyper: tuple[Hyper, ...]
    label: Callable[[Mapping[str, Any]], str]
    shapes: Callable[[Mapping[str, Any]], dict[str, tuple[int, ...]]]
    history: Callable[[Mapping[str, Any]], int]
    min_samples: Callable[[Mapping[str, Any]], int]
    inputs: tuple[str, ...] = ("velocity",)
    start_history: Callable[[Mapping[str, Any]], int] = lambda h: 0
    loss_terms: tuple[str, ...] = ()
    recipe: Mapping[str, float] = field(default_factory=dict)
    recipe_needs: Callable[[Mapping[str, Any]], tuple[str, str] | None] = lambda h: None
    format_version: int = 1
    read_versions: tuple[int, ...] = ()
    exports: frozenset[str] = frozenset()
    export_notes: Mapping[str, str] = field(default_factory=dict)
    width: Callable[[Mapping[str, Any]], int] = lambda h: 1
    sizes: tuple[str, ...] = ()
    weights: Callable[[Mapping[str, Any]], int] | None = None
    weights_text: Callable[[Mapping[str, Any]], str] | None = None
    width_text: str = "its state and input"
    relations: Callable[[Mapping[str, Any], Naming], None] | None = None
    ensemble: bool = True
    paper: bool = False
    report: str = ""
    size_rule: Callable[[int, Mapping[str, int]], dict[str, int]] | None = None
    sized_by_record: tuple[str, ...] = ()
    size_words: Mapping[str, str] = field(default_factory=dict)
    epoch_work: EpochWork | None = None
    sweep: tuple[tuple[int, ...], ...] = ()
    sweep_first: bool = False
    quick: Mapping[str, int | float | str] = field(default_factory=dict)
    former_keys: Mapping[str, str] = field(default_factory=dict)
    tank_scales: tuple[str, ...] = ()
    article: str = "an"

    def size(self, n_samples: int, given: Mapping[str, int]) -> dict[str, int]:
        """The values the size rule chooses for a training record of ``n_samples`` samples:
        those of :attr:`sized_by_record` not in ``given`` (the user's values, which the rule
        may read); none without a rule."""
        if self.size_rule is None:
            return {}
        return self.size_rule(int(n_samples), given)

    def _with_sizes(self, sizes: Mapping[str, int]) -> dict[str, object]:
        return {**self.defaults(), **sizes}

    def size_note(self, sizes: Mapping[str, int], n_samples: int,
                  chosen: Collection[str]) -> str:
        """One line: the values of ``chosen`` (those the rule set) among ``sizes`` (the values
        of :attr:`sized_by_record`), the parameters and samples per parameter, e.g. ``"NSS
        sized for 819 samples: 4 states, 16 neurons, window 10, ... (697 parameters, 1.2
        samples per parameter)"``."""
        parts = [self.size_words.get(k, k + " {}").format(sizes[k]) for k in self.sized_by_record
                 if k in chosen]
        p = self.n_params(self._with_sizes(sizes))
        return (f"{self.class_name} sized for {n_samples} samples: {', '.join(parts)} "
                f"({p} parameters, {n_samples / p:.2g} samples per parameter)")

    def oversize(self, sizes: Mapping[str, int], n_samples: int) -> str | None:
        """A warning's text when the values ``sizes`` of :attr:`sized_by_record` give more
        than :data:`OVERSIZE` times the parameters the size rule gives a record of
        ``n_samples`` samples (None: they fit, or the class has no rule): the samples per
        parameter and the rule's size."""
        if self.size_rule is None:
            return None
        hyper = self._with_sizes(sizes)
        rule = self.size(n_samples, {})
        p, q = self.n_params(hyper), self.n_params(self._with_sizes(rule))
        if p <= OVERSIZE * q:
            return None
        size = ", ".join(f"{self.hyper_named(k).option} {v}" for k, v in rule.items()
                         if v != sizes.get(k))
        return (f"{self.label(hyper)} has {p} parameters for {n_samples} training samples "
                f"({n_samples / p:.2g} samples per parameter): a record this short overfits "
                f"it; the size rule suggests {size} ({q} parameters), or leave the size "
                "options out")

    def epoch_cost(self, hyper: Mapping[str, int | float | str],
                   key: Callable[[str], str] = str) -> str | None:
        """Why one training epoch of ``hyper`` costs too much, or None (within the bound of
        :attr:`epoch_work`, or a class without one).

        The message names the factors by ``key(name)`` (an option, a configuration key), their
        values, the product, the limit and the time they stand for on the measured machine.
        """
        ew = self.epoch_work
        if ew is None:
            return None

        def term(f: str | tuple[str, ...], text: Callable[[str], str]) -> str:
            return f"({' + '.join(map(text, f))})" if isinstance(f, tuple) else text(f)

        work = math.prod(sum(int(hyper[k]) for k in f) if isinstance(f, tuple)
                         else int(hyper[f]) for f in ew.factors)
        if work <= ew.limit:
            return None
        names = " x ".join(term(f, key) for f in ew.factors)
        values = " x ".join(term(f, lambda k: str(int(hyper[k]))) for f in ew.factors)
        return (f"one training epoch of {self.label(hyper)}, {names} = {values} = {work:.3g} "
                f"{ew.unit}, more than {ew.limit:.3g} (about "
                f"{work * ew.seconds / 60:.0f} min per epoch at the measured "
                f"{ew.seconds * 1e9:.0f} ns each on 2 cores; the limit is about "
                f"{ew.limit * ew.seconds / 60:.0f} min): lower one of them")

    def check(self, values: Mapping[str, object], *, n_samples: int | None = None,
              input: str = "velocity", members: int = 1, training: bool = True,
              naming: Naming = ARGUMENTS) -> dict[str, Any]:
        """The rules of the class, in one place: ``values`` checked, every hyperparameter by
        name with the defaults filled in.

        The estimator's ``fit``, the command line and the settings call this (the last two
        naming values by their options and keys, ``naming``), so that a configuration one of
        them accepts the others accept too. Always: each value in its domain (a size left
        to the record, None or absent, is the size rule's for ``n_samples`` samples, else
        its default), the class's rules between values (:attr:`relations`) and the signal
        it reads. For a training (``training``): a model file holds ``members`` models of
        them, the loss terms have what they need (:attr:`recipe_needs`, a velocity input),
        one epoch's work is within its bound (:meth:`epoch_cost`) and a record of
        ``n_samples`` samples is long enough (:attr:`min_samples`).

        Parameters
        ----------
        values : mapping
            Hyperparameters by name (a missing one takes its default).
        n_samples : int, optional
            Samples of the training record (None: not known yet).
        input : {"velocity", "acceleration"}
            The tank signal the model reads.
        members : int
            Models of these hyperparameters in one file (an ensemble's members).
        training : bool
            Check the rules of a training too (not for a model read from a file).
        naming : Naming
            How a message names a value.

        Raises
        ------
        ROMError
            The first rule broken, naming the values at fault.
        """
        key = naming.key
        names = [h.name for h in self.hyper]
        unknown = [k for k in values if k not in names]
        if unknown:
            raise ROMError(f"{self.class_name} has no hyperparameter {unknown[0]!r} (valid: "
                           f"{', '.join(names)})")
        given = {k: v for k, v in values.items()
                 if not (v is None and k in self.sized_by_record)}
        # the user's sizes first: the size rule reads them
        sized = {k: int(self.hyper_named(k).check(given[k], key(k), naming.value))
                 for k in self.sized_by_record if k in given}
        left = n_samples is not None and len(sized) < len(self.sized_by_record)
        chosen = self.size(n_samples, sized) if left and n_samples is not None else {}
        h = {p.name: p.check(given.get(p.name, chosen.get(p.name, p.default)), key(p.name),
                             naming.value)
             for p in self.hyper}
        if self.relations is not None:
            self.relations(h, naming)
        if input not in self.inputs:
            readers = " or ".join(naming.arch(mc) for mc in CLASSES.values()
                                  if input in mc.inputs)
            raise ROMError(f"{naming.input(input)}: {self.article} {self.class_name} takes the "
                           f"tank {' or '.join(self.inputs)}"
                           + (f"; the {input} needs {readers}" if readers else ""))
        if not training:
            return h
        self._check_capacity(h, members, naming)
        needs = self.recipe_needs(h)
        for k in self.loss_terms:
            if h[k] > 0 and needs is not None:
                name, value = needs
                raise ROMError(f"{key(k)} > 0 needs {key(name)} {value!r}, got {h[name]!r}: "
                               f"set {key(k)} to 0 or {key(name)} to {value!r}")
            if h[k] > 0 and input != "velocity":
                # the weights, probes and cycle energies are written for the power F v
                raise ROMError(f"{key(k)} > 0 needs a velocity input: the term is written for "
                               f"the power F v; set it to 0 for a model on the {input} (the "
                               "plain MSE)")
        cost = self.epoch_cost(h, key)
        if cost:  # each value bounded alone lets their product run for hours per epoch
            raise ROMError(cost)
        if n_samples is not None:
            need = self.min_samples(h)
            if n_samples < need:
                raise ROMError(f"{naming.samples(n_samples)} are too few for {self.label(h)} "
                               f"(training needs at least {need})")
        return h

    def _check_capacity(self, h: Mapping[str, object], members: int, naming: Naming) -> None:
        """A model file holds ``members`` models of ``h``: their regressor (each step's
        entries) and their weights are within its limits."""
        width = self.width(h)
        if width > MAX_REGRESSOR:
            raise ROMError(f"{self.label(h)} reads {width} entries at each step "
                           f"({self.width_text}), more than {MAX_REGRESSOR}, the most a model "
                           "file holds")
        w = self.file_weights(h)
        if members * w > MAX_WEIGHTS:
            each = " each" if members > 1 else ""
            text = "" if self.weights_text is None else f" ({self.weights_text(h)}{each})"
            who = (f"{naming.members(members)} of {self.label(h)} have {members} x {w} ="
                   if members > 1 else f"{self.label(h)} has")
            raise ROMError(f"{who} {members * w} weights{text}, more than {MAX_WEIGHTS} "
                           "(32 MiB), the most a model file holds: "
                           f"{'fewer members or ' if members > 1 else ''}a smaller model")

    def hyper_named(self, name: str) -> Hyper:
        """The hyperparameter ``name``; :class:`ROMError` listing the valid ones."""
        for h in self.hyper:
            if h.name == name:
                return h
        raise ROMError(f"{self.class_name} has no hyperparameter {name!r} (valid: "
                       f"{', '.join(h.name for h in self.hyper)})")

    def with_tank(self, hyper: Mapping[str, object], tank: object) -> dict[str, object]:
        """``hyper`` with each of :attr:`tank_scales` left at 0 (or absent) set to ``tank``'s
        quantity of that name; ``tank`` None leaves them (the estimator's own fallback)."""
        out = dict(hyper)
        if tank is None:
            return out
        for k in self.tank_scales:
            if not out.get(k):
                out[k] = float(getattr(tank, k))
        return out

    def defaults(self) -> dict[str, Any]:
        """Every hyperparameter's default by name (the one place they are written)."""
        return {h.name: h.default for h in self.hyper}

    def n_params(self, hyper: Mapping[str, Any]) -> int:
        """Parameters of one model of ``hyper`` (every array's size)."""
        return sum(math.prod(s) for s in self.shapes(hyper).values())

    def file_weights(self, hyper: Mapping[str, Any]) -> int:
        """The weights of one model that the model file's size limit counts."""
        return self.n_params(hyper) if self.weights is None else self.weights(hyper)

    def param_names(self) -> tuple[str, ...]:
        """The names of its parameter arrays, in file order."""
        return tuple(self.shapes(self.defaults()))

    def passive_recipe(self, input_unit: str, output_unit: str,
                       same: Callable[[str, str], bool] | None = None) -> LossChoice:
        """This class's loss for records in these units (:func:`loss_recipe`)."""
        return loss_recipe(input_unit, output_unit, same, self.recipe, self.loss_terms)

    def estimator_class(self) -> type:
        """The estimator (imports its module: JAX for the networks)."""
        module, attr = self.estimator.split(":")
        cls: type = getattr(importlib.import_module(module), attr)
        return cls


def loss_recipe(input_unit: str, output_unit: str,
                same: Callable[[str, str], bool] | None, recipe: Mapping[str, float],
                terms: Sequence[str] = LOSS_TERMS) -> LossChoice:
    """The default loss of a class trained by its recipe, chosen by the units of its records.

    The recipe's terms are written for the power F v a tank exchanges with its structure: they
    hold for a velocity in (m/s) and a force out (N) and nowhere else; any other pair trains on
    the plain MSE.

    Parameters
    ----------
    input_unit, output_unit : str
        The records' units of the model's input and output.
    same : callable, optional
        ``same(a, b)`` says whether two unit strings denote one unit (the command line passes
        ``sloshrom.io.same_unit``, which knows the spellings); None: equal once spaces are
        removed.
    recipe : mapping
        The recipe's weights.
    terms : sequence of str
        The terms the class trains with.

    Returns
    -------
    LossChoice
        ``terms`` are the recipe's or all zero; ``str()`` of it is one line saying which and
        why.
    """
    recipe = dict(recipe)

    def _same(a: str, b: str) -> bool:
        return a.replace(" ", "") == b.replace(" ", "")

    eq = same or _same
    vin, fout = RECIPE_UNITS
    off = dict.fromkeys(terms, 0.0)
    if eq(input_unit, vin) and eq(output_unit, fout):
        if not any(recipe.get(k, 0.0) for k in terms):
            return LossChoice(False, off, "its recipe sets no loss term for a velocity in m/s "
                              "and a force in N")
        return LossChoice(True, {k: float(recipe.get(k, 0.0)) for k in terms},
                          f"the input is a velocity ({vin}) and the output a force ({fout}), "
                          "so their product is the power the recipe's terms are written for")
    return LossChoice(False, off,
                      f"the input is in '{input_unit}' and the output in '{output_unit}', not a "
                      f"velocity ({vin}) in and a force ({fout}) out, so the passive recipe's "
                      "power F v does not apply")


@dataclass(frozen=True)
class FileKind:
    """A model that is loaded from its own files, not a ROM class's ``.npz`` (the bouncing
    ball's ``.toml``): how :func:`sloshrom.rom.load_model` recognises one and loads it.

    Parameters
    ----------
    name : str
        What the files hold, for messages ("bouncing ball").
    recognises : callable
        ``recognises(path) -> bool``: reads no more than a header (no heavy import).
    loader : str
        ``"module:attribute"`` of ``load(path)``, imported on first use.
    """

    name: str
    recognises: Callable[[Path], bool]
    loader: str

    def load(self, path: str | Path) -> object:
        """The model of the file ``path`` (imports the loader's module)."""
        module, attr = self.loader.split(":")
        load = cast("Callable[[str | Path], object]",
                    functools.reduce(getattr, attr.split("."), importlib.import_module(module)))
        return load(path)


# -- the list, loaded on first use -------------------------------------------------------------
_classes: dict[str, ModelClass] = {}
_file_kinds: list[FileKind] = []
_state = {"loaded": False, "loading": False}


def _add(entry: object, where: str) -> None:
    if isinstance(entry, FileKind):
        _file_kinds.append(entry)
        return
    if not isinstance(entry, ModelClass):
        raise ROMError(f"{where} is not a ModelClass or a FileKind, got {type(entry).__name__}")
    both = sorted(set(entry.export_notes) & entry.exports)
    if both:
        raise ROMError(f"{where}: {entry.class_name} exports to {both[0]!r} and has a note on why "
                       "it does not (export_notes are for the formats it does not list)")
    for mc in _classes.values():
        if entry.name in (mc.name, mc.class_name) or entry.class_name in (mc.name,
                                                                          mc.class_name):
            raise ROMError(f"{where}: a class named {entry.name!r} or {entry.class_name!r} is "
                           f"registered already ({mc.class_name})")
    _classes[entry.name] = entry


def _load() -> None:
    """Import the entries of :data:`ENTRIES` (once)."""
    if _state["loaded"]:
        return
    if _state["loading"]:  # an entry module that reads CLASSES while it is imported
        raise ROMError("a class's entry module read the registry while it was being loaded")
    _state["loading"] = True
    try:
        for line in ENTRIES:
            module, attr = line.split(":")
            _add(getattr(importlib.import_module(module), attr), line)
        _state["loaded"] = True
    finally:
        _state["loading"] = False


def register(entry: ModelClass | FileKind) -> None:
    """Add a class (or a kind of model file) to the registry, after those of :data:`ENTRIES`.

    The public hook for a class defined outside this package. Register it before importing
    the command line (``sloshrom.cli``) or the settings (``sloshrom.pipeline.settings``):
    they make their options and tables of the classes registered then.

    Raises
    ------
    ROMError
        Not a :class:`ModelClass` or :class:`FileKind`; a class whose name or class name is
        taken.
    """
    _load()
    _add(entry, f"register({getattr(entry, 'name', entry)!r})")


class _Classes(Mapping[str, ModelClass]):
    """Every registered class by its name, loaded on first use (module docstring)."""

    def __getitem__(self, name: str) -> ModelClass:
        _load()
        return _classes[name]

    def __iter__(self) -> Iterator[str]:
        _load()
        return iter(dict(_classes))

    def __len__(self) -> int:
        _load()
        return len(_classes)

    def __repr__(self) -> str:
        return f"CLASSES({', '.join(self)})"


#: Every ROM class by its name, in the order of ``--help`` and the report.
CLASSES: Mapping[str, ModelClass] = _Classes()


def file_kinds() -> tuple[FileKind, ...]:
    """The registered kinds of model file that are not a ROM class's ``.npz``."""
    _load()
    return tuple(_file_kinds)


def model_class(name: str, what: str = "--arch") -> ModelClass:
    """The class of ``name`` (``"nss"``) or of its class name (``"NSS"``).

    Raises
    ------
    ROMError
        An unknown name; the message lists the classes and names ``what``.
    """
    for mc in CLASSES.values():
        if name in (mc.name, mc.class_name):
            return mc
    raise ROMError(f"{what} must be one of {', '.join(CLASSES)}, got {name!r}")


def paper_class() -> ModelClass:
    """The class of the paper's ROM (its selection, Fig. 10): the first registered class of
    the paper (:attr:`ModelClass.paper`)."""
    return next(mc for mc in CLASSES.values() if mc.paper)


def swept() -> tuple[ModelClass, ...]:
    """The classes of the sensitivity analysis (paper Fig. 8: a grid of delays x neurons,
    :attr:`ModelClass.sweep`), in the registry's order; the first one's table trains every
    grid point (its epochs and hidden layer: the paper trained both classes with one set)."""
    return tuple(mc for mc in CLASSES.values() if mc.sweep)


def packages() -> tuple[str, ...]:
    """The packages of the registered entries (``sloshrom.rom.nss``), in :data:`ENTRIES`'
    order."""
    return tuple(dict.fromkeys(line.split(":")[0].rsplit(".", 1)[0] for line in ENTRIES))


def model_class_of_file(class_name: str) -> ModelClass | None:
    """The class a model file's ``"class"`` names, None for another."""
    return next((mc for mc in CLASSES.values() if mc.class_name == class_name), None)


# -- hyperparameters shared by several classes: one definition each --------------------------
def _weight(name: str, what: str) -> Hyper:
    return Hyper(name, 0.0, "float", 0.0, 1e12, help=what, what="a weight (0 = off)",
                 file_default=0.0)


#: The passive recipe's weights, 0 by default (a class's recipe sets them for m/s in, N out).
LOSS_HYPERS = (
    _weight("amplitude_weighting", "loss weights 1/(a^2 + eps^2), eps in input units "
            "(m/s); 0 = plain MSE"),
    _weight("passivity", "weight of the penalty on energy created at harmonic probes; 0 = off"),
    _weight("cycle_energy", "weight of the error of the energy each input cycle exchanges; "
            "0 = off"))
#: The seed of a class whose training draws.
SEED = Hyper("seed", 0, "int", 0, MAX_SEED, help="seeds the initialisation and the draws",
             what="a seed")
#: Largest state of a state-space ROM (its network part).
MAX_STATES = 1024
#: Most work of one training epoch, in neuron-samples: steps_per_epoch x batch x (window +
#: horizon) x neurons, the samples an epoch's Adam steps read times the width of the maps that
#: run on each. Each bound alone let window = horizon = 9000 through (quick reproduce still
#: training after 300 s). Measured (2026-11-28, 2 cores shared, load 3): an Adam step of the
#: default NSS (128 x (50 + 200) samples, 64 neurons) takes 27 ms, 13 ns per neuron-sample; 4x
#: the horizon, batch or neurons 2.0-2.4x, 16x 13-22x (the cost grows about as the product).
#: 1.5e10 keeps an epoch's steps within about 3 min (up to 5 at the larger sizes' rates), 37
#: times the default's 4.1e8.
MAX_EPOCH_WORK = 15_000_000_000
#: Measured cost of one neuron-sample of an epoch, s (see MAX_EPOCH_WORK).
EPOCH_WORK_SECONDS = 13e-9


def state_space_min_samples(h: Mapping[str, Any]) -> int:
    """The fewest training samples of a state-space network trained by multiple shooting:
    one encoder window and one horizon of samples after it,
    and the sample it starts from (``window + horizon + 1``)."""
    return int(h["window"]) + int(h["horizon"]) + 1


#: The Adam (multiple shooting) options of a recurrent class: its batch, its steps per
#: epoch and its learning rate (a model file of before them reads these defaults).
SHOOTING_HYPERS = (
    Hyper("batch", 128, "int", 1, MAX_BATCH, help="sub-sequences per Adam step",
          what="a number of sub-sequences", file_default=128),
    Hyper("steps_per_epoch", 200, "int", 1, MAX_EPOCHS, help="Adam steps between validations",
          what="a number of Adam steps", file_default=200),
    Hyper("learning_rate", 3e-3, "float", 0.0, 1.0, lo_open=True,
          help="initial Adam step (cosine decay to 5 % of it)", what="an Adam step",
          file_default=3e-3),
)


def neurons(default: int, help: str) -> Hyper:
    """The hidden units of a network class, up to :data:`~sloshrom.limits.MAX_NEURONS`."""
    return Hyper("neurons", default, "int", 1, MAX_NEURONS, help=help,
                 what="a number of neurons")


def precision(help: str) -> Hyper:
    """The precision of a class's Adam steps, float64 by default (its validation and its
    parameters stay float64); a model file of before it was trained in float64."""
    return Hyper("precision", "float64", "choice", choices=("float64", "float32"), help=help,
                 what="'float64' or 'float32'", file_default="float64")


def required(h: Hyper) -> Hyper:
    """``h`` required in a model file (a class whose files always held it)."""
    return replace(h, file_default=_REQUIRED)


def adam_only(h: Mapping[str, Any]) -> tuple[str, str] | None:
    """The loss terms' need of a class with a ``trainer``: ``("trainer", "adam")`` unless it
    is Adam (:attr:`ModelClass.recipe_needs`)."""
    return None if h.get("trainer", "adam") == "adam" else ("trainer", "adam")

