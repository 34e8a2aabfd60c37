"""The registry of ROM classes: one entry per class, the one place that says what a class is.

Each entry is a frozen :class:`ModelClass`: its name (``--arch``, the ``[rom.<name>]`` table
of ``sloshrom reproduce``), the class name its model files record, its hyperparameters with
their defaults and bounds (:class:`Hyper`), its parameter arrays and their shapes, the
shortest training record and the history it reads, its label in messages and the report,
the loss terms and the inputs it can be trained on, its trainers, the model-file format
version, the estimator that implements it (imported when first needed) and the formats it
exports to. The command line (``sloshrom train``), the configuration of
``sloshrom reproduce``, the model-file schema, the report and the FMU/ONNX capability checks
read these entries; none of them branches on a class.

One name per quantity everywhere: a hyperparameter ``n_states`` is the estimator's argument
``n_states``, the model file's field ``hyperparameters.n_states``, the configuration key
``rom.nss.n_states`` and the option ``--n-states``.

This module imports nothing heavy (no JAX), so the command line and the settings read it when
they start. Adding a class is its own module and one entry in :data:`CLASSES`
(docs/architecture.md, "Adding a model class").
"""

from __future__ import annotations

import importlib
import math
import operator
from collections.abc import Callable, Collection, Mapping, Sequence
from dataclasses import dataclass, field, replace
from typing import Any

from sloshrom.limits import (
    EPOCH_WORK_SECONDS,
    MAX_BATCH,
    MAX_DELAY,
    MAX_EPOCH_WORK,
    MAX_EPOCHS,
    MAX_NEURONS,
    MAX_OUT_DELAYS,
    MAX_SEED,
    MAX_STATES,
)
from sloshrom.rom.errors import ROMError

__all__ = ["CLASSES", "LOSS_TERMS", "NSS_FULL_SIZE_SAMPLES", "NSS_SHORT_SAMPLES",
           "NSS_SHORT_SIZE", "OVERSIZE", "RECIPE_UNITS", "Hyper", "LossChoice", "ModelClass",
           "check_delays", "check_hyperparameters", "loss_recipe",
           "model_class", "model_class_of_file", "nss_size"]

#: The passive recipe's loss terms (docs/rom.md, "A passive ROM"): the loss weight floor of
#: the amplitude weighting 1/(a^2 + eps^2), eps in m/s; the weight of the penalty on energy
#: created at harmonic probes; the weight of the error of each input cycle's exchanged energy.
LOSS_TERMS = ("amplitude_weighting", "passivity", "cycle_energy")
#: The units the recipe is written for: a velocity in, a force out (F v is a power).
RECIPE_UNITS = ("m/s", "N")

_REQUIRED = object()


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
        What a value is, for messages ("a number of samples").
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

    def check(self, value: Any, where: str | None = None) -> Any:
        """``value`` if it lies in the domain (ints as int, floats as float), else
        :class:`ROMError` naming ``where`` (default: the name).

        Raises
        ------
        ROMError
            A value of the wrong type or outside the bounds.
        """
        where = self.name if where is None else where
        if self.kind == "choice":
            if value not in self.choices:
                raise ROMError(f"{where} must be {self.domain()}, got {value!r}")
            return value
        if self.kind == "delays":
            return _delays_value(value, where, int(self.hi or MAX_DELAY))
        if self.kind == "int":
            try:
                v: float = operator.index(value)  # ints and NumPy integers, not floats
            except TypeError:
                raise ROMError(f"{where} must be {self.domain()}, got {value!r}") from None
            if isinstance(value, bool):
                raise ROMError(f"{where} must be {self.domain()}, got {value!r}")
        else:
            if isinstance(value, bool) or not isinstance(value, int | float) and \
                    not hasattr(value, "__float__"):
                raise ROMError(f"{where} must be {self.domain()}, got {value!r}")
            v = float(value)
            if not math.isfinite(v):
                raise ROMError(f"{where} must be {self.domain()}, got {value!r}")
        lo, hi = self.lo, self.hi
        if lo is not None and (v < lo or (self.lo_open and v == lo)):
            raise ROMError(f"{where} must be {self.domain()}, got {value!r}")
        if hi is not None and (v > hi or (self.hi_open and v == hi)):
            raise ROMError(f"{where} must be {self.domain()}, got {value!r}")
        return int(v) if self.kind == "int" else v


def _delays_value(value: Any, where: str, top: int) -> int | list[int]:
    if isinstance(value, bool):
        raise ROMError(f"{where} must be an integer >= 1 or a list of delays, got {value!r}")
    try:
        n = operator.index(value)
    except TypeError:
        pass
    else:
        if not 1 <= n <= top:
            raise ROMError(f"{where} must be an integer in [1, {top}], got {value!r}")
        return int(n)
    try:
        d = [operator.index(x) for x in value]
    except TypeError:
        raise ROMError(f"{where} must be an integer >= 1 or a list of delays, got "
                       f"{value!r}") from None
    if not d or min(d) < 1 or max(d) > top or len(set(d)) != len(d) \
            or any(isinstance(x, bool) for x in value):
        raise ROMError(f"{where} must be distinct integers in [1, {top}], got {value!r}")
    return [int(x) for x in d]


def check_delays(delays: int | Sequence[int], name: str = "delays") -> tuple[int, ...]:
    """Delays (samples) as a tuple: ``n`` means ``1..n`` (MATLAB ``timedelaynet``).

    Raises
    ------
    ROMError
        ``n < 1``, an empty list, a delay < 1 or a repeated delay.
    """
    try:
        n = operator.index(delays)  # type: ignore[arg-type]
    except TypeError:
        d = tuple(int(x) for x in delays)  # type: ignore[union-attr]
        if not d or min(d) < 1 or len(set(d)) != len(d):
            raise ROMError(f"{name} must be distinct integers >= 1, got {delays!r}") from None
        return d
    if n < 1:
        raise ROMError(f"{name} must be >= 1, got {delays}")
    return tuple(range(1, n + 1))


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
class ModelClass:
    """What a ROM class is, for everything outside its own module (module docstring).

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
        ``min_samples(hyper) -> int``: the fewest training samples.
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
        ``recipe_needs(hyper) -> str or None``: what the loss terms need that this
        configuration lacks (e.g. ``"trainer 'adam'"``), None when they can train it.
    format_version : int
        The model-file format version its files are written with.
    read_versions : tuple of int
        Older format versions of its files that are still read (the hyperparameters they lack
        take their ``file_default``).
    exports : frozenset of str
        The formats it exports to (``"fmu"``, ``"onnx"``).
    width : callable
        ``width(hyper) -> int``: entries of the vector its maps read at each step (a
        time-delay network's regressor, a state-space model's state and input): a model file
        bounds it, so that simulating a model needs bounded memory.
    sizes : tuple of str
        The hyperparameters that set the shapes of its arrays (named when arrays disagree).
    weights : callable, optional
        ``weights(hyper) -> int``: the weights that a model file's size limit counts (default:
        every parameter).
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
    epoch_work : tuple
        The work of one training epoch as a product of hyperparameters (a tuple in it: their
        sum), in neuron-samples, bounded by :data:`sloshrom.limits.MAX_EPOCH_WORK`
        (:meth:`epoch_cost`); empty: not bounded.
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
    recipe_needs: Callable[[Mapping[str, Any]], str | None] = lambda h: None
    format_version: int = 1
    read_versions: tuple[int, ...] = ()
    exports: frozenset[str] = frozenset()
    width: Callable[[Mapping[str, Any]], int] = lambda h: 1
    sizes: tuple[str, ...] = ()
    weights: Callable[[Mapping[str, Any]], int] | None = None
    ensemble: bool = True
    paper: bool = False
    report: str = ""
    size_rule: Callable[[int, Mapping[str, int]], dict[str, int]] | None = None
    sized_by_record: tuple[str, ...] = ()
    epoch_work: tuple[str | tuple[str, ...], ...] = ()

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
        words = {"n_states": "{} states", "neurons": "{} neurons", "window": "window {}",
                 "horizon": "horizon {}"}
        parts = [words.get(k, k + " {}").format(sizes[k]) for k in self.sized_by_record
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
        """Why one training epoch of ``hyper`` costs too much, or None (within
        :data:`~sloshrom.limits.MAX_EPOCH_WORK`, or a class without :attr:`epoch_work`).

        The message names the factors by ``key(name)`` (an option, a configuration key), their
        values, the product, the limit and the time they stand for on the measured machine.
        """
        if not self.epoch_work:
            return None

        def term(f: str | tuple[str, ...], text: Callable[[str], str]) -> str:
            return f"({' + '.join(map(text, f))})" if isinstance(f, tuple) else text(f)

        work = math.prod(sum(int(hyper[k]) for k in f) if isinstance(f, tuple)
                         else int(hyper[f]) for f in self.epoch_work)
        if work <= MAX_EPOCH_WORK:
            return None
        names = " x ".join(term(f, key) for f in self.epoch_work)
        values = " x ".join(term(f, lambda k: str(int(hyper[k]))) for f in self.epoch_work)
        return (f"one training epoch of {self.label(hyper)}, {names} = {values} = {work:.3g} "
                f"neuron-samples, more than {MAX_EPOCH_WORK:.3g} (about "
                f"{work * EPOCH_WORK_SECONDS / 60:.0f} min per epoch at the measured "
                f"{EPOCH_WORK_SECONDS * 1e9:.0f} ns each on 2 cores; the limit is about "
                f"{MAX_EPOCH_WORK * EPOCH_WORK_SECONDS / 60:.0f} min): lower one of them")

    def hyper_named(self, name: str) -> Hyper:
        """The hyperparameter ``name``; :class:`ROMError` listing the valid ones."""
        for h in self.hyper:
            if h.name == name:
                return h
        raise ROMError(f"{self.class_name} has no hyperparameter {name!r} (valid: "
                       f"{', '.join(h.name for h in self.hyper)})")

    def defaults(self) -> dict[str, Any]:
        """Every hyperparameter's default by name."""
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
                same: Callable[[str, str], bool] | None = None,
                recipe: Mapping[str, float] | None = None,
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
        ``sloshrom.io.same_unit``, which knows the spellings); default: equal once spaces are
        removed.
    recipe : mapping, optional
        The recipe's weights (default: the NFIR's).
    terms : sequence of str
        The terms the class trains with.

    Returns
    -------
    LossChoice
        ``terms`` are the recipe's or all zero; ``str()`` of it is one line saying which and
        why.
    """
    recipe = dict(CLASSES["nfir"].recipe if recipe is None else recipe)

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


# -- the classes ----------------------------------------------------------------------------
def _weight(name: str, what: str) -> Hyper:
    return Hyper(name, 0.0, "float", 0.0, 1e12, help=what, what="a weight (0 = off)",
                 file_default=0.0)


_LOSS = (_weight("amplitude_weighting", "loss weights 1/(a^2 + eps^2), eps in input units "
                 "(m/s); 0 = plain MSE"),
         _weight("passivity", "weight of the penalty on energy created at harmonic probes; "
                 "0 = off"),
         _weight("cycle_energy", "weight of the error of the energy each input cycle "
                 "exchanges; 0 = off"))
_SEED = Hyper("seed", 0, "int", 0, MAX_SEED, help="seeds the initialisation and the draws",
              what="a seed")
_EPOCHS = "training epochs at most"


def _delays(default: int, help: str) -> Hyper:
    return Hyper("delays", default, "delays", 1, MAX_DELAY, help=help, what="delays")


def _neurons(default: int, help: str) -> Hyper:
    return Hyper("neurons", default, "int", 1, MAX_NEURONS, help=help,
                 what="a number of neurons")


_HIDDEN = Hyper("hidden", "matlab", "choice", choices=("matlab", "distance"),
                help="normalized-RBF variant: matlab (radbasn, W x + b) or distance")
# the Adam (multiple shooting) options of a recurrent class
_SHOOTING = (
    Hyper("batch", 128, "int", 1, MAX_BATCH, help="sub-sequences per Adam step",
          what="a number of sub-sequences", file_default=128),
    Hyper("steps_per_epoch", 200, "int", 1, MAX_EPOCHS, help="Adam steps between validations",
          what="a number of Adam steps", file_default=200),
    Hyper("learning_rate", 3e-3, "float", 0.0, 1.0, lo_open=True,
          help="initial Adam step (cosine decay to 5 % of it)", what="an Adam step",
          file_default=3e-3),
)


def _required(h: Hyper) -> Hyper:
    return replace(h, file_default=_REQUIRED)


def _rbf_shapes(h: Mapping[str, Any], out_delays: int = 0) -> dict[str, tuple[int, ...]]:
    d = len(check_delays(h["delays"])) + out_delays
    n = int(h["neurons"])
    return {"W": (n, d), "b": (n,), "c": (n,), "c0": ()}


def _max_delay(h: Mapping[str, Any]) -> int:
    return max(check_delays(h["delays"]))


def _rbf_min_samples(mc_shapes: Callable[[Mapping[str, Any]], dict[str, tuple[int, ...]]],
                     out: Callable[[Mapping[str, Any]], int]
                     ) -> Callable[[Mapping[str, Any]], int]:
    # the delay line and two samples per hundred parameters
    def need(h: Mapping[str, Any]) -> int:
        n_params = sum(math.prod(s) for s in mc_shapes(h).values())
        return _max_delay(h) + out(h) + 2 * n_params // 100 + 10
    return need


def _rbf_width(h: Mapping[str, Any]) -> int:
    return len(check_delays(h["delays"])) + int(h.get("out_delays", 0))


def _rbf_weights(h: Mapping[str, Any]) -> int:
    return int(h["neurons"]) * _rbf_width(h)


def _nfir_shapes(h: Mapping[str, Any]) -> dict[str, tuple[int, ...]]:
    return _rbf_shapes(h)


def _noe_shapes(h: Mapping[str, Any]) -> dict[str, tuple[int, ...]]:
    return _rbf_shapes(h, int(h["out_delays"]))


def nss_shapes(h: Mapping[str, Any]) -> dict[str, tuple[int, ...]]:
    """Every array of a state-space network: state map ``A``, ``W1``, ``b1``, ``W2``, output
    map ``C``, ``V1``, ``d1``, ``V2``, encoder ``E1``, ``e1``, ``E2``."""
    nx, n, w = int(h["n_states"]), int(h["neurons"]), int(h["window"])
    nz = nx + 1
    return {"A": (nz, nx), "W1": (nz, n), "b1": (n,), "W2": (n, nx),
            "C": (nz,), "V1": (nz, n), "d1": (n,), "V2": (n,),
            "E1": (2 * w, n), "e1": (n,), "E2": (n, nx)}


#: A user's size with more than this many times the parameters of the size rule's is warned
#: of (:meth:`ModelClass.oversize`).
OVERSIZE = 4.0
#: Training samples from which an NSS keeps the size of its defaults exactly (8 states, 64
#: neurons, window 50): the sloshing records they were sized for have 240,000.
NSS_FULL_SIZE_SAMPLES = 100_000
#: Training samples of the short-record anchor: the Cascaded Tanks sweep's 819
#: (docs/rom.md, "Short records").
NSS_SHORT_SAMPLES = 1_000
#: The NSS's size on a record of :data:`NSS_SHORT_SAMPLES` samples or fewer: the best of the
#: short-record sweep (benchmarks/short_record.py, docs/rom.md, "Short records"). The shooting
#: recipe (horizon 200, batch 128, 200 steps per epoch) stays: on the short record it was worth more
#: than any smaller one.
NSS_SHORT_SIZE: dict[str, int] = {"n_states": 4, "neurons": 16, "window": 10}


def nss_size(n_samples: int, given: Mapping[str, int]) -> dict[str, int]:
    """The NSS's size rule: the values of ``n_states``, ``neurons``, ``window`` and
    ``horizon`` not in ``given`` (the user's values) for a training record of ``n_samples``
    samples.

    From :data:`NSS_FULL_SIZE_SAMPLES` samples on, the defaults (those the sloshing pipeline
    depends on); at :data:`NSS_SHORT_SAMPLES` and below, the sweep's best size
    (:data:`NSS_SHORT_SIZE`); in between, each value interpolated geometrically in the
    record's length (a straight line on log-log axes between the two measured anchors;
    nothing between them was measured). The horizon is the default's, shortened on a record
    too short for it so that at least half of the record's samples start a sub-sequence.
    """
    n = int(n_samples)
    names = (*NSS_SHORT_SIZE, "horizon")
    default = {k: int(NSS_CLASS.hyper_named(k).default) for k in names}
    out = {k: v for k, v in default.items() if k not in given}
    if n >= NSS_FULL_SIZE_SAMPLES:
        return out
    t = min(1.0, max(0.0, math.log(max(n, 1) / NSS_SHORT_SAMPLES)
                     / math.log(NSS_FULL_SIZE_SAMPLES / NSS_SHORT_SAMPLES)))
    for k, small in NSS_SHORT_SIZE.items():
        if k in out:
            out[k] = max(1, round(small * (default[k] / small) ** t))
    if "horizon" in out:
        # a horizon near the record's length leaves a handful of distinct sub-sequences
        window = int(given.get("window", out.get("window", default["window"])))
        out["horizon"] = max(8, min(out["horizon"], (n - window) // 2))
    return out


def _lss_shapes(h: Mapping[str, Any]) -> dict[str, tuple[int, ...]]:
    n = int(h["n_states"])
    return {"A": (n, n), "B": (n,), "C": (n,), "D": ()}


def _adam_only(h: Mapping[str, Any]) -> str | None:
    t = h.get("trainer", "adam")
    return None if t == "adam" else "trainer 'adam'"


NFIR_CLASS = ModelClass(
    name="nfir", class_name="NFIR", estimator="sloshrom.rom.estimators:NFIR",
    summary="the paper's time-delay network: the force from the last `delays` inputs "
            "through a normalized radial-basis layer",
    hyper=(_delays(70, "input delays: n for 1..n (MATLAB timedelaynet) or a list"),
           _neurons(35, "hidden normalized-RBF neurons"), _HIDDEN,
           Hyper("max_epochs", 1000, "int", 0, MAX_EPOCHS, help=_EPOCHS, what="an integer"),
           _SEED,
           Hyper("trainer", "adam", "choice", choices=("adam", "fast", "lm"),
                 help="adam (minibatch, the loss terms), fast (subsampled LM) or lm (trainlm)"),
           *_LOSS),
    label=lambda h: f"NFIR({h['delays']}, {h['neurons']})",
    shapes=_nfir_shapes, history=_max_delay,
    min_samples=_rbf_min_samples(_nfir_shapes, lambda h: 0),
    inputs=("velocity", "acceleration"), loss_terms=LOSS_TERMS,
    recipe={"amplitude_weighting": 0.05, "passivity": 1.0, "cycle_energy": 0.1},
    recipe_needs=_adam_only, format_version=1, exports=frozenset({"fmu", "onnx"}),
    width=_rbf_width, weights=_rbf_weights, sizes=("neurons", "delays"),
    paper=True, report="the paper's class, a network of the last samples of the tank velocity.",
)

NOE_CLASS = ModelClass(
    name="noe", class_name="NOE", estimator="sloshrom.rom.estimators:NOE",
    summary="the paper's recurrent network: the force from the last inputs and its own last "
            "outputs",
    hyper=(_delays(2, "input delays: n for 1..n or a list"),
           _neurons(10, "hidden normalized-RBF neurons"), _HIDDEN,
           Hyper("max_epochs", 1000, "int", 0, MAX_EPOCHS, help=_EPOCHS, what="an integer"),
           _SEED,
           Hyper("trainer", "lm", "choice", choices=("lm", "fast", "adam"),
                 help="lm (Levenberg-Marquardt on the simulation error) or adam (multiple "
                      "shooting, the loss terms)"),
           Hyper("out_delays", 2, "int", 1, MAX_OUT_DELAYS, help="fed-back past outputs",
                 what="a number of outputs"),
           Hyper("unstable_bound", 10.0, "float", 0.0, 1e12, lo_open=True,
                 help="|scaled output| beyond which a simulation is unstable",
                 what="a bound"),
           *_LOSS,
           Hyper("horizon", 300, "int", 8, MAX_DELAY,
                 help="adam: samples simulated from each start", what="a number of samples",
                 file_default=300),
           *_SHOOTING),
    label=lambda h: f"NOE({h['delays']}, {h['neurons']})",
    shapes=_noe_shapes, history=_max_delay,
    min_samples=_rbf_min_samples(_noe_shapes, lambda h: int(h["out_delays"])),
    start_history=lambda h: int(h["out_delays"]),
    loss_terms=LOSS_TERMS, recipe=dict.fromkeys(LOSS_TERMS, 0.0), recipe_needs=_adam_only,
    format_version=1, exports=frozenset({"fmu", "onnx"}), width=_rbf_width,
    weights=_rbf_weights, sizes=("neurons", "delays", "out_delays"),
    paper=True,
    report="the paper's recurrent class, a network of the last samples of the tank velocity "
           "and of its own last outputs.",
)

NSS_CLASS = ModelClass(
    name="nss", class_name="NSS", estimator="sloshrom.rom.estimators:NSS",
    summary="a neural state-space model: a state that carries where the liquid is and how "
            "it moves, identified by multiple shooting from an encoder",
    hyper=(Hyper("n_states", 8, "int", 1, MAX_STATES, help="dimension of the state",
                 what="a state dimension"),
           _neurons(64, "tanh units of each of the state map, output map and encoder"),
           Hyper("window", 50, "int", 1, MAX_DELAY,
                 help="samples of past input and output the encoder reads",
                 what="a number of samples"),
           Hyper("horizon", 200, "int", 8, MAX_DELAY,
                 help="samples simulated from each encoded start in training",
                 what="a number of samples"),
           _required(_SHOOTING[0]),
           Hyper("max_epochs", 60, "int", 0, MAX_EPOCHS,
                 help="epochs of steps_per_epoch Adam steps at most", what="an integer"),
           _required(_SHOOTING[1]), _required(_SHOOTING[2]),
           _SEED, *_LOSS,
           Hyper("feedthrough", "yes", "choice", choices=("yes", "no"),
                 help="whether the force reads the current velocity directly; 'no': a "
                      "strictly proper model (the force from the state alone): no algebraic "
                      "loop in a coupling, and a co-simulation master that reads outputs "
                      "before setting inputs gets the same force",
                 what="'yes' or 'no'", file_default="yes"),
           Hyper("velocity_offset", 0.0, "float", 0.0, 10.0,
                 help="Galilean augmentation, m/s: each training sub-sequence's velocity "
                      "shifted by a uniform draw in +-this, its force kept (0 = off)",
                 what="a velocity in m/s", file_default=0.0),
           Hyper("weight_decay", 0.0, "float", 0.0, 100.0,
                 help="AdamW's decoupled weight decay per unit learning rate: each Adam step "
                      "also shrinks every weight by learning_rate x this (0 = plain Adam)",
                 what="a decay rate (0 = off)", file_default=0.0)),
    label=lambda h: (f"NSS({h['n_states']} states, {h['neurons']} neurons"
                     + (", strictly proper)" if h.get("feedthrough", "yes") == "no" else ")")),
    shapes=nss_shapes, history=lambda h: int(h["window"]),
    min_samples=lambda h: int(h["window"]) + int(h["horizon"]) + 1,
    loss_terms=LOSS_TERMS,
    recipe={"amplitude_weighting": 0.0, "passivity": 1.0, "cycle_energy": 0.1},
    # version 5 added feedthrough and velocity_offset, version 6 weight_decay; version 3 and 5
    # files read with their defaults
    format_version=6, read_versions=(3, 5), exports=frozenset({"fmu"}),
    width=lambda h: int(h["n_states"]) + 1,
    sizes=("neurons", "n_states", "window"),
    report="a neural state-space model, not the paper's NFIR class. Why: the force depends "
           "on where the liquid is, how fast it moves and when it lands, a state that a "
           "finite-memory NFIR (70 samples, 0.14 s) cannot carry; the state-space model "
           "does, and with it predicts the impacts the NFIR misses while its dissipation map "
           "stays at least as close to the rig's (docs/rom.md, \"A ROM with state\", with the "
           "figures of both classes).",
    size_rule=nss_size, sized_by_record=(*NSS_SHORT_SIZE, "horizon"),
    epoch_work=("steps_per_epoch", "batch", ("window", "horizon"), "neurons"),
)

LSS_CLASS = ModelClass(
    name="lss", class_name="LSS", estimator="sloshrom.rom.lss:LSS",
    summary="the best linear model: a linear state-space model identified by a subspace "
            "method (N4SID) and refined on its simulation error",
    hyper=(Hyper("n_states", 8, "int", 1, 64, help="order of the linear model",
                 what="a state dimension"),
           Hyper("block_rows", 20, "int", 2, 1000,
                 help="block rows of the subspace method's Hankel matrices (> n_states)",
                 what="a number of samples"),
           Hyper("max_epochs", 20, "int", 0, 10_000,
                 help="iterations of the output-error refinement (0 = the subspace estimate)",
                 what="an integer")),
    label=lambda h: f"LSS({h['n_states']} states)",
    shapes=_lss_shapes, history=lambda h: 0,
    # the block Hankel matrices need 2 i samples per column and 8 i columns (i block rows)
    min_samples=lambda h: 10 * int(h["block_rows"]) - 1,
    start_history=lambda h: int(h["n_states"]),
    format_version=4, exports=frozenset({"fmu"}), width=lambda h: int(h["n_states"]),
    sizes=("n_states",), ensemble=False,
    report="the best linear model of the records (N4SID refined on its simulation error): "
           "what any nonlinear ROM buys is measured against it.",
)

#: Every ROM class by its name, in the order of ``--help`` and the report.
CLASSES: dict[str, ModelClass] = {mc.name: mc for mc in
                                  (NFIR_CLASS, NOE_CLASS, NSS_CLASS, LSS_CLASS)}


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


def model_class_of_file(class_name: str) -> ModelClass | None:
    """The class a model file's ``"class"`` names, None for another."""
    return next((mc for mc in CLASSES.values() if mc.class_name == class_name), None)


def check_hyperparameters(mc: ModelClass, values: Mapping[str, Any],
                          where: Callable[[Hyper], str] | None = None) -> dict[str, Any]:
    """``values`` checked against ``mc``'s domains, defaults filled in, by name.

    Parameters
    ----------
    mc : ModelClass
    values : mapping
        Hyperparameters by name; a missing one takes its default.
    where : callable, optional
        ``where(hyper) -> str``: how a message names a value (default: its name; the command
        line passes the option, the settings the key).

    Raises
    ------
    ROMError
        An unknown name, or the first value outside its domain, named.
    """
    names = {h.name for h in mc.hyper}
    unknown = [k for k in values if k not in names]
    if unknown:
        raise ROMError(f"{mc.class_name} has no hyperparameter {unknown[0]!r} (valid: "
                       f"{', '.join(h.name for h in mc.hyper)})")
    out = {}
    for h in mc.hyper:
        v = values.get(h.name, h.default)
        out[h.name] = h.check(v, None if where is None else where(h))
    return out
