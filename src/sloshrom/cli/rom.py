"""``sloshrom train | predict | sweep``: identify ROMs of any registered class from records and
use them.

Records are read with :func:`sloshrom.io.read_record` (NetCDF, CSV, MATLAB) and written with
:func:`sloshrom.io.write_record`; models are ``.npz`` files (:func:`sloshrom.rom.load_model`).
Every option, file and unit is checked before reading data or training: a bad input costs one
``error:`` line, not a model trained in vain.
"""

from __future__ import annotations

import functools
import inspect
import os
import warnings
from collections.abc import Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any

import numpy as np
import typer

from sloshrom.cli._app import app, check_input, check_number, check_out, fail
from sloshrom.cli.progress import progress_bars
from sloshrom.config import FILL_TOLERANCE, Tank
from sloshrom.errors import SloshromError
from sloshrom.io import STANDARD_UNITS, Record, read_record, same_unit, write_record
from sloshrom.limits import (
    HIDDEN_KINDS,
    MAX_DELAY,
    MAX_EPOCHS,
    MAX_MEMBERS,
    MAX_NEURONS,
    MAX_SEED,
    MIN_SCORED,
    MU_MAX,
)
from sloshrom.pipeline.settings import sloshing_recipe
from sloshrom.rom.epochs import TrainingProgress
from sloshrom.rom.errors import HistoryError, ModelSizeWarning
from sloshrom.rom.registry import (
    CLASSES,
    Hyper,
    ModelClass,
    Naming,
    model_class,
    paper_class,
    swept,
)

if TYPE_CHECKING:  # annotations only: the CLI loads JAX when it trains
    from sloshrom.rom.base import Estimator
    from sloshrom.rom.ensemble import Ensemble

__all__ = ["predict", "sweep", "train"]

RECORD_SUFFIXES = (".nc", ".csv", ".mat")
def _read(path: Path, names: list[str], what: str, options: tuple[str, ...] = ()):
    """The record of ``path`` (option ``what``) with the 1-D variables ``names``; ``options``
    are the options that named them (``--input``, ``--output``): a name of the time axis is
    refused as such."""
    check_input(path, what)
    try:
        rec = read_record(path)
    except SloshromError as exc:
        fail(str(exc))
    for opt, n in zip(options, names, strict=False):
        if rec.is_time_axis(n):
            # time is the axis the signals are sampled on: a model of it predicts nothing
            fail(f"{opt} {n}: '{n}' is the time axis of {path}, not a signal; name one of its "
                 f"signals: {', '.join(rec.names)}")
    missing = [n for n in names if n not in rec]
    if missing:
        fail(f"{path}: no variable {', '.join(missing)} (has: {', '.join(rec.names)})")
    for n in names:
        if np.ndim(rec[n]) != 1:
            fail(f"{path}: variable {n} is not 1-D")
    return rec


def _same_units(a: Record, pa: Path, b: Record, pb: Path, names: list[str]) -> None:
    """Training and validation records must measure each variable in the same unit."""
    for n in names:
        ua, ub = a.units[n], b.units[n]
        if not same_unit(ua, ub):
            fail(f"unit mismatch: variable '{n}' is in '{ua}' in {pa} but in '{ub}' in {pb}")


def _standard_units(rec: Record, path: Path, names: list[str]) -> None:
    """A variable with a standard name must be in that name's unit (swapped columns, ...)."""
    for n in names:
        si = STANDARD_UNITS.get(n)
        if si is not None and not same_unit(rec.units[n], si):
            fail(f"{path}: variable '{n}' is in '{rec.units[n]}', but {n} is in '{si}' "
                 "(columns swapped? name the variables with --input/--output)")


def _read_pair(data: Path, validation: Path, names: list[str]) -> tuple[Any, Any]:
    """Training and validation records: same rate, same units, standard names in SI."""
    opts = ("--input", "--output")
    rec = _read(data, names, "--data", opts)
    val = _read(validation, names, "--validation", opts)
    _same_rate(rec.fs, val.fs, f"{data} vs {validation}")
    _same_units(rec, data, val, validation, names)
    _standard_units(rec, data, names)
    return rec, val


def _training_fill(fill: float | None, rec: Any, data: Path, val: Any,
                   validation: Path) -> float | None:
    """The fill level the model records: ``--fill``, else the records' ``fill`` attribute.

    Fails if the two records, or ``--fill`` and a record, disagree (beyond the gauge tolerance of
    :data:`sloshrom.config.FILL_TOLERANCE`): one model is identified at one fill."""
    tol = FILL_TOLERANCE
    found = {}
    for r, p in ((rec, data), (val, validation)):
        f = r.attrs.get("fill")
        if f is None:
            continue
        if isinstance(f, bool) or not isinstance(f, (int, float)) or not 0 < f < 1:
            fail(f"{p}: attribute fill must be a number in (0, 1), got {f!r}")
        found[p] = float(f)
    if len(set(found.values())) > 1 and max(found.values()) - min(found.values()) > tol:
        fail(f"the records were taken at different fills: {data} at {found[data]:.1%}, "
             f"{validation} at {found[validation]:.1%}")
    if fill is not None:
        for p, f in found.items():
            if abs(f - fill) > tol:
                fail(f"--fill {fill:g} but {p} was taken at fill {f:g} (its attribute fill)")
        return fill
    return next(iter(found.values()), None)


def _not_at_rest(rec: Record, name: str, share: float = 0.05) -> str:
    """Why a record does not start at rest (a model's rest: zero output), or "": its output
    ``name`` starts farther from zero than ``share`` of its range. (The first input sample says
    nothing: a model at rest reads it at its first step.)"""
    x = rec[name]
    span = float(np.ptp(x))
    if span > 0 and abs(float(x[0])) > share * span:
        return (f"{name} starts at {float(x[0]):.4g} {rec.units[name]}, "
                f"{abs(float(x[0])) / span:.0%} of its range")
    return ""


def _same_rate(a: float, b: float, what: str) -> None:
    if not np.isclose(a, b, rtol=1e-6):
        fail(f"sample-rate mismatch: {what} ({a:g} Hz vs {b:g} Hz); resample first")


def _parse_ints(text: str | None, name: str, hi: int) -> list[int] | None:
    if text is None:
        return None
    try:
        vals = [int(v) for v in text.replace(" ", "").split(",") if v]
    except ValueError:
        fail(f"{name} must be a comma-separated list of integers, got {text!r}")
    if not vals or min(vals) < 1 or max(vals) > hi:
        fail(f"{name} must list integers in [1, {hi}], got {text!r}")
    if len(set(vals)) != len(vals):
        fail(f"{name} must not repeat a value, got {text!r}")
    return vals


def _check_names(input_name: str, output_name: str) -> None:
    for opt, n in (("--input", input_name), ("--output", output_name)):
        if not n.strip():
            fail(f"{opt} must name a variable of the records, got an empty name")
    if input_name == output_name:
        fail(f"--input and --output must be different variables, both are {input_name!r}")


def _check_common(max_epochs: int, seed: int, hidden: str) -> None:
    check_number(max_epochs, "--max-epochs", 0, MAX_EPOCHS)
    check_number(seed, "--seed", 0, MAX_SEED)
    if hidden not in HIDDEN_KINDS:
        fail(f"--hidden must be matlab or distance, got {hidden!r}")


def _naming(record: Path | None = None) -> Naming:
    """How the class's rules name values on the command line: options, ``--input``,
    ``--arch``, ``--ensemble`` and the training record ``record``."""
    return Naming(key=lambda k: "--" + k.replace("_", "-"), input=lambda v: f"--input {v}",
                  arch=lambda m: f"--arch {m.name}",
                  samples=lambda n: f"{n} samples" if record is None else f"{record}: {n} samples",
                  members=lambda k: f"--ensemble {k}: {k} members")


def _rules(mc: ModelClass, values: Mapping[str, object], *, record: Path | None = None,
           n_samples: int | None = None, input: str = "velocity", training: bool = True
           ) -> dict[str, Any]:
    """The class's rules on the options (:meth:`sloshrom.rom.registry.ModelClass.check`, the
    one place they are written): one ``error:`` line naming the options at fault (and the
    record, ``record``, when it is too short); the other arguments as the check's."""
    try:
        return mc.check(values, n_samples=n_samples, input=input, training=training,
                        naming=_naming(record))
    except SloshromError as exc:
        fail(str(exc))


InputOpt = Annotated[str, typer.Option("--input", help="Input variable of the records.")]
OutputOpt = Annotated[str, typer.Option("--output", help="Output variable of the records.")]


def _typed(h: Hyper) -> type:
    return {"int": int, "float": float, "choice": str, "delays": int}[h.kind]


def _hyper_options() -> list[inspect.Parameter]:
    """One option per hyperparameter name of the registry's classes (``--n-states``, ...),
    with each class's default in its help; every one defaults to None (not given)."""
    by_name: dict[str, list[tuple[ModelClass, Hyper]]] = {}
    for mc in CLASSES.values():
        for h in mc.hyper:
            by_name.setdefault(h.name, []).append((mc, h))
    out = []
    for name, pairs in by_name.items():
        h0 = pairs[0][1]
        which = ", ".join(f"{mc.class_name} {h.default}" for mc, h in pairs)
        domain = "; ".join(dict.fromkeys(
            f"an integer in [1, {int(h.hi or 1)}]" if h.kind == "delays" else h.domain()
            for _, h in pairs))
        text = f"{h0.help[:1].upper()}{h0.help[1:]} (default: {which}); {domain}."
        decls = (h0.option, *_ALIASES.get(name, ()))
        out.append(inspect.Parameter(
            name, inspect.Parameter.KEYWORD_ONLY, default=None,
            annotation=Annotated[_typed(h0) | None, typer.Option(*decls, help=text)]))
    return out


#: Former spellings of an option, still read (the name everywhere else is the first).
_ALIASES = {"n_states": ("--states",)}


def _given(mc: ModelClass, given: dict[str, Any]) -> dict[str, Any]:
    """The given options of class ``mc``, refusing those of other classes (one ``error:`` line
    listing the class's own)."""
    names = [h.name for h in mc.hyper]
    for name in given:
        if name not in names:
            opts = ", ".join(h.option for h in mc.hyper)
            fail(f"{'--' + name.replace('_', '-')} does not apply to --arch {mc.name} "
                 f"({mc.class_name}: {mc.summary}); its options are {opts}")
    return given


def _train(**kw: Any) -> None:
    """Identify a ROM of any class of the registry (or an ensemble of them) from an
    input/output record.

    --arch names the class: nfir (the paper's NFIR, the default), noe (the paper's NOE), nss
    (a neural state-space ROM: a state that carries where the liquid is and how it moves) or
    lss (the best linear model: N4SID refined on its simulation error). Each class takes the
    options of its own hyperparameters (their defaults are listed with each option); an
    option of another class is refused with the list of the class's own.

    An NFIR trained by Adam (the default) on a velocity in m/s and a force in N uses the
    passive recipe: amplitude-weighted loss, a passivity penalty and a cycle-energy term
    (docs/rom.md, "A passive ROM"); an NSS its own recipe. The terms are written for the power
    F v, so records in other units (a force in, a displacement out, an acceleration in, ...)
    train on the plain MSE. One line says which loss was chosen and why; the options override
    it, and --amplitude-weighting 0 --passivity 0 --cycle-energy 0 trains the paper's plain
    MSE. --input acceleration (records' tank acceleration, m/s^2) trains an NFIR on the
    acceleration, always on the plain MSE; it runs in `beam` and `map` like any other.

    The two records must have the same sample rate and the same units of the input and of the
    output; the model file may not be one of the records. With --ensemble K, K models with
    seeds SEED..SEED+K-1 are trained in parallel (Dask) and written as one model file whose
    prediction is the mean of the members; the validation MSE of every member and their spread
    (mean +- standard deviation, min, max) are printed. With --seeds N, N models with seeds
    SEED..SEED+N-1 are trained the same way, every seed's validation MSE and their spread are
    printed, and the best single model on the validation record is written (its seed in its
    hyperparameters).

    Example: sloshrom train --data train.nc --validation validation.nc --arch nfir --delays 70
    --neurons 35 --out nfir.npz [--ensemble 5 --workers 2]
    """
    data, validation, out = kw.pop("data"), kw.pop("validation"), kw.pop("out")
    input_name, output_name = kw.pop("input_name"), kw.pop("output_name")
    arch, fill, ensemble = kw.pop("arch"), kw.pop("fill"), kw.pop("ensemble")
    seeds = kw.pop("seeds")
    scheduler, workers = kw.pop("scheduler"), kw.pop("workers")
    history = kw.pop("history")
    try:
        mc = model_class(arch)
    except SloshromError as exc:
        fail(str(exc))
    given = _given(mc, {k: v for k, v in kw.items() if v is not None})
    _check_names(input_name, output_name)
    reads = "acceleration" if input_name == "acceleration" else "velocity"
    # the class's rules on the options alone (domains, the signal read), before any data
    _rules(mc, given, input=reads, training=False)
    check_number(ensemble, "--ensemble", 1, MAX_MEMBERS)
    if ensemble > 1 and not mc.ensemble:
        fail(f"--ensemble {ensemble}: {mc.article} {mc.class_name} is fitted "
             "deterministically, so its members would be one model; train it alone")
    seed = int(given.get("seed", 0))
    if seed + ensemble - 1 > MAX_SEED:
        fail(f"--seed {seed} with --ensemble {ensemble}: the last member's seed "
             f"{seed + ensemble - 1} exceeds {MAX_SEED}")
    _check_seeds(seeds, ensemble, mc, seed)
    if ensemble > 1 or seeds > 1:
        n_cpu = os.cpu_count() or 1
        check_number(workers, "--workers", 1, n_cpu, why=f"this machine has {n_cpu} CPU(s)")
        if scheduler not in (None, "threads", "sequential"):
            check_scheduler(scheduler)
    check_number(fill, "--fill", 0.0, 1.0, lo_open=True, hi_open=True,
                 why="liquid depth / tank height")
    check_input(data, "--data")
    check_input(validation, "--validation")
    check_out(out, suffixes=(".npz",), inputs=(data, validation))
    rec, val = _read_pair(data, validation, [input_name, output_name])
    fill = _training_fill(fill, rec, data, val, validation)
    units = (rec.units[input_name], rec.units[output_name])
    # the recipe by the records' units: its terms hold for m/s in and N out only
    choice = mc.passive_recipe(*units, same=same_unit)
    set_by = [k for k in mc.loss_terms if k in given]
    values = dict(given)
    # on sloshing records (m/s in, N out) the class's other choices of `reproduce` too
    tuned = sloshing_recipe(mc.name)
    taken = {k: v for k, v in tuned.items() if k not in given} if choice.passive else {}
    values.update(taken)
    recipe = bool(mc.loss_terms) and mc.recipe_needs({**mc.defaults(), **values}) is None
    if recipe:
        for k in mc.loss_terms:
            values.setdefault(k, choice.terms.get(k, 0.0))
    # a class scaled by the tank (a grey box's column) takes the record's tank where it has one
    tank_attrs = rec.attrs.get("tank")
    values = mc.with_tank(values, Tank.from_dict(dict(tank_attrs)) if tank_attrs else None)
    try:
        model = mc.estimator_class()(**values, units=units, names=(input_name, output_name))
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always", ModelSizeWarning)
            # every rule of the class for this record, once (the fit reuses it); the options
            # left out that the class sizes by the record's length (an NSS's size and horizon)
            # are chosen here
            hyper = model.check_training(len(rec), members=ensemble, naming=_naming(data))
        model.spec  # noqa: B018 - the estimator's own checks (a unit), before training
    except SloshromError as exc:
        fail(str(exc))
    chosen = [k for k in mc.sized_by_record if k not in given]
    sizes = {k: int(hyper[k]) for k in mc.sized_by_record}
    if any(hyper[k] != mc.hyper_named(k).default for k in chosen):
        typer.echo(mc.size_note(sizes, len(rec), chosen))
    for w in caught:  # a size too big for the record: said before the training
        if issubclass(w.category, ModelSizeWarning):
            typer.echo(f"warning: {w.message}")
    if given.get("precision") == "float32" and hyper.get("trainer", "adam") != "adam":
        # asked for, and not what the training does: said (the table's float32 is not asked)
        typer.echo(f"note: --precision float32 is the precision of Adam's steps; --trainer "
                   f"{hyper['trainer']} trains in float64")
    if taken:
        typer.echo("recipe: as `sloshrom reproduce` trains it on sloshing records (m/s in, N "
                   "out): " + ", ".join(f"{k} {v}" for k, v in taken.items())
                   + f" (its [rom.{mc.name}] table; an option given wins)")
    elif tuned and not choice.passive:
        typer.echo(f"recipe: the class's defaults (`sloshrom reproduce`'s [rom.{mc.name}] "
                   "choices are for m/s in and N out)")
    if recipe:
        typer.echo(str(choice) if not set_by else
                   f"loss: {', '.join(f'{k} {hyper[k]:g}' for k in mc.loss_terms)}: "
                   f"{', '.join(set_by)} set by the options (by the records' units: "
                   f"{choice.name})")
    label = mc.label(hyper)
    n_params = mc.n_params(hyper)
    n_past = int(mc.history(hyper))
    if len(val) <= n_past:
        fail(f"{validation}: {len(val)} samples are too few for {n_past} samples of history "
             f"({label})")
    start = max(n_past, int(mc.start_history(hyper)))
    check_number(history, "--history", 0, len(val) - MIN_SCORED,
                 why=f"samples of the validation record {validation} ({len(val)}), leaving "
                     f"{MIN_SCORED} to score")
    if 0 < history < start:
        fail(f"--history {history}: a start from history reads {start} samples ({label}); "
             f"give at least {start}")
    if history == 0:
        note = _not_at_rest(val, output_name)
        if note:
            typer.echo(f"note: the validation record {validation} does not start at rest "
                       f"({note}): its run from rest is scored on that transient; give "
                       f"--history N (N >= {start}) to start it from its first N samples",
                       err=True)
    from rich.progress import BarColumn, TextColumn, TimeElapsedColumn

    if ensemble > 1 or seeds > 1:
        (_train_ensemble if ensemble > 1 else _train_seeds)(
            model, max(ensemble, seeds), rec, val, input_name, output_name, out,
            scheduler if scheduler is not None or workers > 1 else "sequential", workers, fill,
            label, history)
        return
    epochs = int(hyper.get("max_epochs", 0))
    # epoch, errors (and Levenberg-Marquardt's damping mu) and an upper bound of the time left
    pace = TrainingProgress(epochs, unit=f"{rec.units[output_name]}^2")
    with progress_bars(TextColumn("{task.description}"), BarColumn(),
                       TextColumn("{task.fields[info]}"), TimeElapsedColumn()) as progress:
        task = progress.add_task(f"training {mc.class_name}", total=epochs, info="")

        def cb(epoch: int, info: dict[str, float]) -> None:
            pace.epoch(epoch, info)
            progress.update(task, completed=epoch, info=pace.text())

        try:
            with warnings.catch_warnings():
                # said above, in the command's words
                warnings.simplefilter("ignore", ModelSizeWarning)
                model.fit(rec[input_name], rec[output_name], fs=rec.fs,
                          validation=(val[input_name], val[output_name]), callback=cb,
                          fill=fill, validation_history=history)
        except HistoryError as exc:  # the validation history, in the option's words
            fail(f"--history {exc.samples}: {exc.reason}")
        except SloshromError as exc:  # ROMError (a constant record, ...), UnstableModelError
            fail(str(exc))
    try:
        path = model.save(out)
    except SloshromError as exc:  # ROMError: a value beyond the model-file format's bounds
        fail(str(exc))
    h = model.history_
    after = f" (after {history} samples of history)" if history else ""
    typer.echo(
        f"wrote {path}: {label}, {n_params} parameters, {len(h['train_mse']) - 1} epochs "
        f"({h['stop_reason']}), best epoch {h['best_epoch']}, validation MSE{after} "
        f"{h['val_mse'][h['best_epoch']]:.4g} {rec.units[output_name]}^2, "
        f"{h['train_seconds']:.1f} s" + _stopped(h)
    )


_COMMON: list[tuple[str, Any, Any]] = [
    ("data", Annotated[Path, typer.Option("--data", help="Training record (.nc/.csv/.mat).")],
     inspect.Parameter.empty),
    ("validation", Annotated[Path, typer.Option("--validation",
                                                help="Validation record (early stopping).")],
     inspect.Parameter.empty),
    ("out", Annotated[Path, typer.Option("--out", "-o", help="Model file to write (.npz).")],
     inspect.Parameter.empty),
    ("input_name", InputOpt, "velocity"),
    ("output_name", OutputOpt, "dynamic_force"),
    ("arch", Annotated[str, typer.Option(
        "--arch", help="The ROM's class: " + "; ".join(
            f"{mc.name} ({mc.summary})" for mc in CLASSES.values()) + ".")],
     paper_class().name),
]
_AFTER: list[tuple[str, Any, Any]] = [
    ("fill", Annotated[float | None, typer.Option(
        help="Fill level d/h of the records' tank, in (0, 1): recorded in the model, which "
             "then refuses other fills. Default: the records' fill attribute (rig records "
             "carry it).")], None),
    ("ensemble", Annotated[int, typer.Option(help="Train K models that differ by their seed "
                                                  "(members have seeds SEED..SEED+K-1) and "
                                                  "save them as one ensemble file (mean of "
                                                  "the members); 1 = a single model.")], 1),
    ("seeds", Annotated[int, typer.Option(
        help="Train N models that differ only by their seed (SEED..SEED+N-1, in parallel as "
             "--ensemble), print every seed's validation MSE and their spread, and write the "
             "best single model on the validation record; 1 = one model. Not with "
             "--ensemble.")], 1),
    ("scheduler", Annotated[str | None, typer.Option(
        help="Ensemble: Dask scheduler address tcp://HOST:PORT; 'threads' or 'sequential' for "
             "no cluster; default: a new LocalCluster of --workers processes (in this process "
             "for --workers 1).")], None),
    ("workers", Annotated[int, typer.Option(help="Ensemble, seeds: models trained at once, 1 to "
                                                 "the number of CPUs.")], 2),
    ("history", Annotated[int, typer.Option(
        "--history", help="Samples at the start of the validation record taken as measured "
                          "history: its run starts from them (delay lines filled, state "
                          "encoded or fitted) instead of from rest, and is scored after them; "
                          "for a validation record that does not start at rest. At least the "
                          "samples the class reads (NFIR/NOE: the delays; NSS: --window; "
                          "LSS: --n-states). 0 = from rest.")], 0),
]


def _command(func: Any) -> Any:
    """``func(**kw)`` with the signature typer reads: the common options, one option per
    hyperparameter of the registry, then the ensemble's options."""
    params = [inspect.Parameter(n, inspect.Parameter.KEYWORD_ONLY, default=d, annotation=a)
              for n, a, d in _COMMON]
    params += _hyper_options()
    params += [inspect.Parameter(n, inspect.Parameter.KEYWORD_ONLY, default=d, annotation=a)
               for n, a, d in _AFTER]

    @functools.wraps(func)
    def command(**kw: Any) -> None:
        func(**kw)

    command.__signature__ = inspect.Signature(params)  # type: ignore[attr-defined]
    command.__annotations__ = {p.name: p.annotation for p in params}
    command.__name__ = "train"
    return command


train = app.command(name="train")(_command(_train))


def _check_seeds(seeds: int, ensemble: int, mc: ModelClass, seed: int) -> None:
    """``--seeds N``: a number of models, not with ``--ensemble``, for a class with a seed."""
    check_number(seeds, "--seeds", 1, MAX_MEMBERS)
    if seeds > 1 and ensemble > 1:
        fail(f"--seeds {seeds} with --ensemble {ensemble}: --seeds keeps the best single model, "
             "--ensemble the mean of all; give one of them")
    if seeds > 1 and not mc.ensemble:
        fail(f"--seeds {seeds}: {mc.article} {mc.class_name} is fitted deterministically, so "
             "every seed gives the same model; train it alone")
    if seed + seeds - 1 > MAX_SEED:
        fail(f"--seed {seed} with --seeds {seeds}: the last seed {seed + seeds - 1} exceeds "
             f"{MAX_SEED}")


def _stopped(h: Mapping[str, object]) -> str:
    """``; stopped: ...`` when Levenberg-Marquardt's damping reached mu_max (the training's
    warning says why), with the options to try; empty for any other stop."""
    epochs = h.get("train_mse")
    if h.get("stop_reason") != "mu_max" or not isinstance(epochs, list):
        return ""
    mu_max = f"{MU_MAX:.0e}".replace("e+", "e")
    text = (f"; stopped: Levenberg-Marquardt's damping mu passed mu_max = {mu_max} at epoch "
            f"{len(epochs) - 1}, no step lowered the training error")
    return (f"{text} (why: the warning above); try --trainer adam, fewer --neurons or --delays, "
            "or other seeds (--seeds N keeps the best of N)")


def _fit_members(template: Estimator, k: int, rec: Record, val: Record, input_name: str,
                 output_name: str, scheduler: str | None, workers: int, fill: float | None,
                 label: str, history: int) -> Ensemble:
    """K models of ``template`` with seeds SEED..SEED+K-1 through Dask (``Ensemble.fit``),
    with a progress bar of the members and their epochs; the fitted ensemble. ``history``:
    samples of the validation record each member's validation run starts from."""
    from rich.progress import BarColumn, MofNCompleteColumn, TextColumn, TimeElapsedColumn

    from sloshrom.rom.ensemble import Ensemble

    ens = Ensemble(template, n_members=k)
    arch = label.split("(")[0]
    fs = rec.fs
    if fs is None:  # unreachable after _read_pair's rate check; narrows the type
        fail(f"the training record has no sample rate; {label} needs one")
    # the members' epochs come from the workers (sloshrom.rom.epochs); members at once: the
    # workers, one in this process for "sequential"
    pace = TrainingProgress(int(template.get_params().get("max_epochs", 0)), members=k,
                            concurrent=1 if scheduler == "sequential" else workers,
                            unit=f"{rec.units[output_name]}^2")
    with progress_bars(TextColumn("{task.description}"), BarColumn(), MofNCompleteColumn(),
                       TextColumn("{task.fields[info]}"), TimeElapsedColumn()) as progress:
        task = progress.add_task(f"training {k} x {arch}", total=k, info="")

        def cb(i: int, member: Any) -> None:
            pace.finished(i)
            progress.update(task, advance=1, info=f"member {i} (seed {member.seed}) done; "
                                                  f"{pace.text()}")

        def epoch_cb(i: int, epoch: int, info: Mapping[str, float]) -> None:
            if pace.epoch(epoch, info, member=i):
                progress.update(task, info=pace.text())

        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", ModelSizeWarning)  # said by the command
                ens.fit(rec[input_name], rec[output_name], fs=fs,
                        validation=(val[input_name], val[output_name]), scheduler=scheduler,
                        n_workers=workers, progress=cb, epoch_progress=epoch_cb, fill=fill,
                        validation_history=history)
        except HistoryError as exc:  # the validation history, in the option's words
            fail(f"--history {exc.samples}: {exc.reason}")
        except SloshromError as exc:  # ROMError (a constant record, ...), UnstableModelError
            fail(str(exc))
    return ens


def _member_lines(ens: Ensemble, mse: list[float], unit: str, what: str) -> None:
    """One line per member: its seed, validation MSE over the whole validation record, epochs
    and stop reason."""
    for i, (m, e) in enumerate(zip(ens.members_, mse, strict=True)):
        h = m.history_
        err = "unstable on the validation record" if np.isnan(e) else f"{e:.4g} {unit}"
        who = f"seed {m.seed}" if what == "seed" else f"{what} {i} (seed {m.seed})"
        why = (": no step lowered the training error" if h["stop_reason"] == "mu_max" else "")
        typer.echo(f"{who}: validation MSE {err}, "
                   f"{len(h['train_mse']) - 1} epochs ({h['stop_reason']}{why})")


def _spread_text(ens: Ensemble, mse: list[float], unit: str) -> str:
    """``mean +- std, min (seed), max (seed), max/min`` of the members' validation MSE (NaN,
    an unstable member, left out and counted)."""
    from sloshrom.rom.ensemble import spread

    s = spread(mse)
    ok = [(e, m.seed) for e, m in zip(mse, ens.members_, strict=True) if not np.isnan(e)]
    if not ok:
        return "every member unstable on the validation record"
    lo, hi = min(ok), max(ok)
    ratio = f"{hi[0] / lo[0]:.3g}" if lo[0] > 0 else "inf"
    bad = len(mse) - len(ok)
    return (f"{s['mean']:.4g} +- {s['std']:.4g} {unit}, min {lo[0]:.4g} (seed {lo[1]}), max "
            f"{hi[0]:.4g} (seed {hi[1]}), max/min {ratio}"
            + (f"; {bad} unstable on the validation record" if bad else ""))


def _scored(val: Record, input_name: str, output_name: str, history: int
            ) -> tuple[tuple[np.ndarray, np.ndarray] | None, np.ndarray, np.ndarray]:
    """The validation record as the members were scored on it: its measured history (None
    from rest), then the input and output after it."""
    uv, yv = val[input_name], val[output_name]
    past = (uv[:history], yv[:history]) if history else None
    return past, uv[history:], yv[history:]


def _train_ensemble(template: Any, k: int, rec: Any, val: Any, input_name: str,
                    output_name: str, out: Path, scheduler: str | None, workers: int,
                    fill: float | None, label: str, history: int = 0) -> None:
    """``train --ensemble K``: K members through Dask, one file, per-member validation MSE;
    ``label`` names the members' architecture (``NFIR(70, 35)``)."""
    ens = _fit_members(template, k, rec, val, input_name, output_name, scheduler, workers,
                       fill, label, history)
    past, uv, yv = _scored(val, input_name, output_name, history)
    unit = f"{rec.units[output_name]}^2"
    try:
        # NaN for a member unstable on the validation record: scored, not an error
        mse = [float(e) for e in ens.member_errors(uv, yv, history=past)]
        path = ens.save(out)
    except SloshromError as exc:
        fail(str(exc))
    try:
        of_mean = f"{float(np.mean((ens.predict(uv, history=past) - yv) ** 2)):.4g} {unit}"
    except SloshromError:  # UnstableModelError of a member: the mean is unstable too
        of_mean = "n/a (a member is unstable on the validation record)"
    _member_lines(ens, mse, unit, "member")
    typer.echo(
        f"wrote {path}: ensemble of {k} {label}, "
        f"{ens.n_params} parameters; validation MSE over members {_spread_text(ens, mse, unit)}"
        f"; of the ensemble mean {of_mean}"
    )


def _train_seeds(template: Estimator, k: int, rec: Record, val: Record, input_name: str,
                 output_name: str, out: Path, scheduler: str | None, workers: int,
                 fill: float | None, label: str, history: int = 0) -> None:
    """``train --seeds N``: N models through Dask (as ``--ensemble``), each seed's validation
    MSE and their spread; the best on the validation record written as a single model.
    ``history``: the validation record's first samples each run starts from (scored after
    them)."""
    ens = _fit_members(template, k, rec, val, input_name, output_name, scheduler, workers,
                       fill, label, history)
    past, uv, yv = _scored(val, input_name, output_name, history)
    try:
        mse = [float(e) for e in ens.member_errors(uv, yv, history=past)]
        best = ens.best_member(uv, yv, history=past)
        path = best.save(out)
    except SloshromError as exc:  # every seed unstable on the validation record, ...
        fail(str(exc))
    unit = f"{rec.units[output_name]}^2"
    _member_lines(ens, mse, unit, "seed")
    i = next(j for j, m in enumerate(ens.members_) if m is best)
    h = best.history_
    after = f" (after {history} samples of history)" if history else ""
    typer.echo(f"validation MSE{after} over {k} seeds: {_spread_text(ens, mse, unit)}")
    typer.echo(
        f"wrote {path}: {label}, seed {best.get_params()['seed']} (the best of {k} on "
        f"validation), {best.n_params} parameters, {len(h['train_mse']) - 1} epochs "
        f"({h['stop_reason']}), validation MSE{after} {mse[i]:.4g} {unit}" + _stopped(h)
    )


@app.command()
def predict(
    model: Annotated[Path, typer.Option("--model", "-m", help="Model file (.npz).")],
    data: Annotated[Path, typer.Option("--data", help="Input record.")],
    out: Annotated[Path, typer.Option("--out", "-o", help="Output record (.nc/.csv/.mat); not "
                                                          "the input record.")],
    fill: Annotated[float | None, typer.Option(
        help="Fill level d/h to run the model at: a fill family (.toml) needs it, a single "
             "model refuses a fill it was not identified at. Default: the record's fill "
             "attribute, if any.")] = None,
    history: Annotated[int, typer.Option(
        "--history", help="Samples at the record's start taken as measured history (its input "
                          "and output): the run starts from them instead of from rest, and the "
                          "record after them is written and scored. At least the samples the "
                          "model reads (NFIR/NOE: the delays; NSS: its window; LSS: its "
                          "order). 0 = from rest, the whole record.")] = 0,
) -> None:
    """Simulate a ROM on an input record; writes the record plus ``<output>_pred``.

    The record's input variable must be at the model's sample rate and in the model's unit
    after conversion to SI (a record in mm/s or ft/s is converted for a model in m/s; one in
    rad/s, or in a unit sloshrom does not know, is refused).

    A run starts from rest. A record that does not start at rest (a test record cut from a
    longer run) is predicted with --history N: its first N samples of input and output are the
    measured history that the run starts from (the NSS encodes its state from them, the NFIR
    and NOE fill their delay lines, the LSS fits its state); the written record holds the
    samples after them.

    Example: sloshrom predict --model nfir.npz --data validation.nc --out prediction.nc
    [--history 50]
    """
    check_number(fill, "--fill", 0.0, 1.0, lo_open=True, hi_open=True,
                 why="liquid depth / tank height")
    check_input(model, "--model")
    check_input(data, "--data")
    check_out(out, suffixes=RECORD_SUFFIXES, inputs=(data, model))
    from sloshrom.rom.family import at_fill
    from sloshrom.rom.loading import load_model

    try:
        m = load_model(model)
    except SloshromError as exc:
        fail(str(exc))
    names = m.names  # a fill family describes its members' records
    rec = _read(data, [names[0], *([names[1]] if history else [])], "--data")
    if fill is None and isinstance(rec.attrs.get("fill"), float):
        fill = rec.attrs["fill"]
    try:
        m = at_fill(m, fill, str(model))
    except SloshromError as exc:
        fail(f"--model {exc}")
    in_name, out_name = m.names
    _same_rate(rec.fs, m.fs_, f"data {data} vs model {model}")
    if not same_unit(rec.units[in_name], m.units[0]):
        fail(f"{data}: variable '{in_name}' is in '{rec.units[in_name]}', the model {model} "
             f"expects '{m.units[0]}'")
    if out.suffix.lower() == ".csv":
        two_d = [n for n in rec.names if np.ndim(rec[n]) != 1]
        if two_d:
            fail(f"--out {out}: CSV holds 1-D variables only, {data} has 2-D {', '.join(two_d)} "
                 "(use .nc)")
    past = None
    if history:
        past = _history_of(m, rec, history, data)
        rec = _after(rec, history)
    try:
        y = m.predict(rec[in_name]) if past is None else m.predict(rec[in_name], history=past)
    except SloshromError as exc:  # UnstableModelError, ROMError (NaN in the record)
        fail(str(exc))
    attrs: dict[str, str | int] = {"prediction_model": str(model)}
    if history:
        attrs["prediction_history"] = history
    new = rec.with_variables({f"{out_name}_pred": y}, {f"{out_name}_pred": m.units[1]},
                             **attrs)
    write_record(new, out)
    msg = f"wrote {out}: {out_name}_pred ({len(y)} samples"
    msg += f" after {history} samples of history)" if history else ")"
    if out_name in rec:
        if same_unit(rec.units[out_name], m.units[1]):
            e = y - rec[out_name]
            msg += f", MSE {np.mean(e**2):.4g} {m.units[1]}^2 against {out_name}"
        else:
            msg += (f" (no MSE: {out_name} is in '{rec.units[out_name]}', the model gives "
                    f"'{m.units[1]}')")
    typer.echo(msg)


def _history_of(model: Any, rec: Record, history: int, data: Path
                ) -> tuple[np.ndarray, np.ndarray]:
    """``predict --history N``: the record's first N samples of input and output, checked
    (the model can start from history, N is enough for it and leaves samples to predict, the
    output is in the model's unit)."""
    in_name, out_name = model.names
    need = getattr(model, "history_samples", None)
    if need is None:
        fail(f"--history: a {type(model).__name__} starts from rest only")
    check_number(history, "--history", 0, len(rec) - MIN_SCORED,
                 why=f"samples of {data} ({len(rec)}), leaving {MIN_SCORED} to predict")
    if history < need:
        fail(f"--history {history}: the model reads {need} samples of measured history; "
             f"give at least {need}")
    if not same_unit(rec.units[out_name], model.units[1]):
        fail(f"{data}: variable '{out_name}' is in '{rec.units[out_name]}', the model gives "
             f"'{model.units[1]}': the measured history must be in the model's unit")
    return rec[in_name][:history], rec[out_name][:history]


def _after(rec: Record, start: int) -> Record:
    """The record from sample ``start`` on (every variable, time included)."""
    return Record(rec.time[start:], rec.fs, {k: v[start:] for k, v in rec.variables.items()},
                     dict(rec.units), dict(rec.attrs), dict(rec.dims))


def check_scheduler(address: str, timeout: float = 5.0) -> None:
    """Fail unless a Dask scheduler address is well formed and accepts a TCP connection.

    A plain socket, not a Dask client: an unreachable address costs ``timeout`` seconds and one
    line, before any data is read (a client would wait and then print its own tracebacks).
    """
    import socket
    from urllib.parse import urlsplit

    text = address.strip()
    if not text:
        fail("--scheduler: empty address (give tcp://HOST:PORT, 'threads' or 'sequential')")
    parts = urlsplit(text if "://" in text else f"tcp://{text}")
    if parts.scheme not in ("tcp", "tls"):
        fail(f"--scheduler {address!r}: unsupported protocol {parts.scheme!r} (use tcp://HOST:PORT,"
             " 'threads' or 'sequential')")
    try:
        host, port = parts.hostname, parts.port
    except ValueError:
        host, port = None, None
    if not host or port is None:
        fail(f"--scheduler {address!r}: expected tcp://HOST:PORT")
    try:
        with socket.create_connection((host, port), timeout=timeout):
            pass
    except OSError as exc:
        reason = "timed out" if isinstance(exc, TimeoutError) else (exc.strerror or str(exc))
        fail(f"--scheduler {address}: no Dask scheduler reachable ({reason}); start one with "
             "`dask scheduler` or leave --scheduler out for a local cluster")


@app.command()
def sweep(
    data: Annotated[Path, typer.Option("--data", help="Training record.")],
    validation: Annotated[Path, typer.Option("--validation", help="Validation record.")],
    out: Annotated[Path, typer.Option("--out", "-o", help="Output directory (resumable).")],
    input_name: InputOpt = "velocity",
    output_name: OutputOpt = "dynamic_force",
    arch: Annotated[str, typer.Option(help=f"{', '.join(mc.name for mc in swept())} or "
                                           "both.")] = "both",
    delays: Annotated[str | None, typer.Option(help="Delays list, e.g. 50,60,70.")] = None,
    neurons: Annotated[str | None, typer.Option(help="Neurons list, e.g. 5,10,15.")] = None,
    max_epochs: Annotated[int, typer.Option(help="Training epochs at most per model.")] = 1000,
    hidden: Annotated[str, typer.Option(help="RBF variant: matlab or distance.")] = "matlab",
    seed: Annotated[int, typer.Option(help="Initialisation seed (>= 0).")] = 0,
    scheduler: Annotated[
        str | None,
        typer.Option(help="Dask scheduler address tcp://HOST:PORT (checked before any work); "
                          "'threads' or 'sequential' for no cluster; default: a new "
                          "LocalCluster."),
    ] = None,
    workers: Annotated[int, typer.Option(help="LocalCluster workers / threads, 1 to the number "
                                              "of CPUs.")] = 2,
) -> None:
    """Sensitivity analysis over delays x neurons (paper Fig. 8); resumes an interrupted run.

    Example: sloshrom sweep --data train.nc --validation validation.nc --out sweep/ --arch nfir
    --delays 50,70 --neurons 10,20,35
    """
    if arch != "both" and arch not in [mc.name for mc in swept()]:
        fail(f"--arch must be {', '.join(mc.name for mc in swept())} or both, got {arch!r}")
    _check_names(input_name, output_name)
    _check_common(max_epochs, seed, hidden)
    dl = _parse_ints(delays, "--delays", MAX_DELAY)
    nl = _parse_ints(neurons, "--neurons", MAX_NEURONS)
    n_cpu = os.cpu_count() or 1
    check_number(workers, "--workers", 1, n_cpu, why=f"this machine has {n_cpu} CPU(s)")
    if scheduler not in (None, "threads", "sequential"):
        check_scheduler(scheduler)
    check_input(data, "--data")
    check_input(validation, "--validation")
    from sloshrom.rom.sweep import SWEEP_FIGURE, SWEEP_TABLES, point_name, sweep_grid

    pts = sweep_grid(arch)
    if dl or nl:
        archs = sorted({p[0] for p in pts})
        pts = [(a, d, n) for a in archs
               for d in (dl or sorted({p[1] for p in pts if p[0] == a}))
               for n in (nl or sorted({p[2] for p in pts if p[0] == a}))]
    # every file the sweep writes in --out (each point's model and result, the tables, the
    # figure) must not be one of the records
    written = (*SWEEP_TABLES, SWEEP_FIGURE,
               *(f"{point_name(*p)}{sfx}" for p in pts for sfx in (".npz", ".json")))
    check_out(out, directory=True, inputs=(data, validation), contents=written)
    rec, val = _read_pair(data, validation, [input_name, output_name])

    from rich.progress import BarColumn, MofNCompleteColumn, TextColumn, TimeElapsedColumn

    from sloshrom.plotting.rom import plot_sweep
    from sloshrom.rom.sweep import run_sweep

    for a in sorted({p[0] for p in pts}):  # the largest network of each class of the grid
        big = [p for p in pts if p[0] == a]
        _rules(model_class(a), {"delays": max(p[1] for p in big),
                                "neurons": max(p[2] for p in big)},
               record=data, n_samples=len(rec))
    with progress_bars(TextColumn("sweep"), BarColumn(), MofNCompleteColumn(),
                       TextColumn("{task.fields[info]}"), TimeElapsedColumn()) as progress:
        task = progress.add_task("sweep", total=len(pts), info="")

        def cb(row: dict[str, Any]) -> None:
            progress.update(task, advance=1, info=f"{row['name']}: score {row['score']:.4g}")

        rows = run_sweep((rec[input_name], rec[output_name]), (val[input_name], val[output_name]),
                         rec.fs, out, pts, scheduler=scheduler, n_workers=workers,
                         options={"max_epochs": max_epochs, "hidden": hidden, "seed": seed},
                         progress=cb)
    fig = plot_sweep(rows, out / SWEEP_FIGURE)
    best = rows[0]
    n_bad = sum(r["unstable"] for r in rows)
    stuck = sum(r.get("stop_reason") == "mu_max" for r in rows)
    typer.echo(f"wrote {out}/sweep.csv, sweep.json, {fig.name}: best {best['name']} score "
               f"{best['score']:.4g}; {n_bad} unstable"
               + (f"; {stuck} stopped at Levenberg-Marquardt's mu_max (no step lowered the "
                  "training error: stop_reason in sweep.csv)" if stuck else ""))
