"""``sloshrom train | predict | sweep``: identify NFIR, NOE and NSS ROMs from records and use them.

Records are read with :func:`sloshrom.io.read_record` (NetCDF, CSV, MATLAB) and written with
:func:`sloshrom.io.write_record`; models are ``.npz`` files (:func:`sloshrom.rom.load_model`).
Every option, file and unit is checked before reading data or training: a bad input costs one
``error:`` line, not a model trained in vain.
"""

from __future__ import annotations

import math
import os
from pathlib import Path
from typing import Annotated, Any

import numpy as np
import typer

from sloshrom.cli._app import app, check_input, check_number, check_out, fail
from sloshrom.config import FILL_TOLERANCE
from sloshrom.errors import SloshromError
from sloshrom.io import STANDARD_UNITS, read_record, same_unit, write_record
from sloshrom.limits import (
    ARCH_TRAINERS,
    HIDDEN_KINDS,
    MAX_BATCH,
    MAX_DELAY,
    MAX_EPOCHS,
    MAX_MEMBERS,
    MAX_NEURONS,
    MAX_SEED,
    MAX_STATES,
    MAX_WEIGHTS,
    NSS_RECIPE,
    RECIPE,
    LossChoice,
    loss_recipe,
)
from sloshrom.pipeline.settings import training_samples

__all__ = ["predict", "sweep", "train"]

RECORD_SUFFIXES = (".nc", ".csv", ".mat")
#: The architectures of ``train --arch``.
ARCHS = ("nfir", "noe", "nss")
#: Defaults of the options a state-space ROM (``--arch nss``) takes: those of ``NSS()``.
NSS_DEFAULTS: dict[str, int | float] = {"states": 8, "neurons": 64, "window": 50,
                                        "horizon": 300, "batch": 128, "learning_rate": 0.003,
                                        "steps_per_epoch": 200, "max_epochs": 40}
#: Why each option of an NFIR/NOE does not apply to an NSS.
NOT_FOR_NSS = {"--delays": "it has no delay line; its encoder reads --window samples",
               "--hidden": "its layers are tanh, not RBF",
               "--trainer": "it trains by Adam on sub-sequences (multiple shooting)"}


def _read(path: Path, names: list[str], what: str):
    check_input(path, what)
    try:
        rec = read_record(path)
    except SloshromError as exc:
        fail(str(exc))
    missing = [n for n in names if n not in rec]
    if missing:
        fail(f"{path}: no variable {', '.join(missing)} (has: {', '.join(rec.names)})")
    for n in names:
        if np.ndim(rec[n]) != 1:
            fail(f"{path}: variable {n} is not 1-D")
    return rec


def _same_units(a: Any, pa: Path, b: Any, pb: Path, names: list[str]) -> None:
    """Training and validation records must measure each variable in the same unit."""
    for n in names:
        ua, ub = a.units[n], b.units[n]
        if not same_unit(ua, ub):
            fail(f"unit mismatch: variable '{n}' is in '{ua}' in {pa} but in '{ub}' in {pb}")


def _standard_units(rec: Any, path: Path, names: list[str]) -> None:
    """A variable with a standard name must be in that name's unit (swapped columns, ...)."""
    for n in names:
        si = STANDARD_UNITS.get(n)
        if si is not None and not same_unit(rec.units[n], si):
            fail(f"{path}: variable '{n}' is in '{rec.units[n]}', but {n} is in '{si}' "
                 "(columns swapped? name the variables with --input/--output)")


def _read_pair(data: Path, validation: Path, names: list[str]) -> tuple[Any, Any]:
    """Training and validation records: same rate, same units, standard names in SI."""
    rec = _read(data, names, "--data")
    val = _read(validation, names, "--validation")
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


def _check_length(rec: Any, path: Path, arch: str, delays: int, neurons: int, what: str,
                  horizon: int = 0) -> None:
    """The record must hold enough samples for the network (the check of ``fit``, before it);
    an NSS's ``delays`` is its encoder window, ``horizon`` its training sub-sequence."""
    need = training_samples(arch, delays, neurons, horizon)
    if len(rec) < need:
        name = (f"NSS(window {delays}, horizon {horizon})" if arch == "nss"
                else f"{arch.upper()}({delays}, {neurons})")
        fail(f"{path}: {len(rec)} samples are too few for {name} ({what} needs at least {need})")


def _label(arch: str, model: Any) -> str:
    """``NFIR(70, 35)`` or ``NSS(8 states, 64 neurons, window 50)``: a ROM in a message."""
    if arch == "nss":
        return f"NSS({model.n_states} states, {model.neurons} neurons, window {model.window})"
    return f"{arch.upper()}({model.delays}, {model.neurons})"


def _nss_options(given: dict[str, Any], arch: str) -> None:
    """Check the options of a state-space ROM; for an NFIR/NOE, refuse them."""
    if arch != "nss":
        for opt, value in given.items():
            if value is not None:
                fail(f"{opt} applies to --arch nss (a state-space ROM), not to --arch {arch}")
        return
    check_number(given["--states"], "--states", 1, MAX_STATES)
    check_number(given["--window"], "--window", 1, MAX_DELAY)
    check_number(given["--horizon"], "--horizon", 8, MAX_DELAY)
    check_number(given["--batch"], "--batch", 1, MAX_BATCH)
    check_number(given["--steps-per-epoch"], "--steps-per-epoch", 1, MAX_EPOCHS)
    check_number(given["--learning-rate"], "--learning-rate", 0.0, 1.0, lo_open=True,
                 why="the initial Adam step")


def _nss_recipe(choice: LossChoice) -> LossChoice:
    """The loss of an NSS for the records' units: :data:`sloshrom.limits.NSS_RECIPE` where the
    NFIR's recipe applies (a velocity in m/s, a force in N), else the plain MSE."""
    if not choice.passive:
        return choice
    if any(NSS_RECIPE.values()):
        return LossChoice(True, dict(NSS_RECIPE), choice.why)
    return LossChoice(False, dict(NSS_RECIPE), "the NSS recipe (sloshrom.limits.NSS_RECIPE) "
                      "sets no loss term for a velocity in m/s and a force in N")


InputOpt = Annotated[str, typer.Option("--input", help="Input variable of the records.")]
OutputOpt = Annotated[str, typer.Option("--output", help="Output variable of the records.")]


@app.command()
def train(
    data: Annotated[Path, typer.Option("--data", help="Training record (.nc/.csv/.mat).")],
    validation: Annotated[
        Path, typer.Option("--validation", help="Validation record (early stopping).")
    ],
    out: Annotated[Path, typer.Option("--out", "-o", help="Model file to write (.npz).")],
    input_name: InputOpt = "velocity",
    output_name: OutputOpt = "dynamic_force",
    arch: Annotated[str, typer.Option("--arch", help="nfir, noe or nss (a neural "
                                                     "state-space ROM).")] = "nfir",
    delays: Annotated[
        int | None, typer.Option(help=f"Input delays (NFIR 70, NOE 2), 1-{MAX_DELAY}.")
    ] = None,
    neurons: Annotated[
        int | None, typer.Option(help=f"Hidden neurons (NFIR 35, NOE 10, NSS 64), "
                                      f"1-{MAX_NEURONS}.")
    ] = None,
    hidden: Annotated[str | None, typer.Option(
        help="NFIR/NOE: RBF variant, matlab (default) or distance.")] = None,
    max_epochs: Annotated[int | None, typer.Option(
        help="Training epochs at most (NFIR/NOE 1000, NSS 40 epochs of --steps-per-epoch "
             "Adam steps).")] = None,
    trainer: Annotated[
        str | None, typer.Option(help="NFIR: adam (default), fast (subsampled LM) or lm (trainlm);"
                                      " NOE: lm.")
    ] = None,
    states: Annotated[int | None, typer.Option(
        help=f"NSS: dimension of the state (default 8), 1-{MAX_STATES}.")] = None,
    window: Annotated[int | None, typer.Option(
        help="NSS: samples of past input and output its encoder reads (default 50).")] = None,
    horizon: Annotated[int | None, typer.Option(
        help="NSS: samples simulated from each encoded start in training (default 300, "
             ">= 8).")] = None,
    batch: Annotated[int | None, typer.Option(
        help="NSS: sub-sequences per Adam step (default 128).")] = None,
    learning_rate: Annotated[float | None, typer.Option(
        help="NSS: initial Adam step, in (0, 1] (default 0.003).")] = None,
    steps_per_epoch: Annotated[int | None, typer.Option(
        help="NSS: Adam steps between validations (default 200).")] = None,
    fill: Annotated[float | None, typer.Option(
        help="Fill level d/h of the records' tank, in (0, 1): recorded in the model, which "
             "then refuses other fills. Default: the records' fill attribute (rig records "
             "carry it).")] = None,
    seed: Annotated[int, typer.Option(help="Seed of the initialisation (>= 0); an ensemble's "
                                           "members have seeds SEED..SEED+K-1.")] = 0,
    ensemble: Annotated[int, typer.Option(help="Train K networks that differ by their seed and "
                                               "save them as one ensemble file (mean of the "
                                               "members); 1 = a single network.")] = 1,
    scheduler: Annotated[
        str | None,
        typer.Option(help="Ensemble: Dask scheduler address tcp://HOST:PORT; 'threads' or "
                          "'sequential' for no cluster; default: a new LocalCluster of --workers "
                          "processes (in this process for --workers 1)."),
    ] = None,
    workers: Annotated[int, typer.Option(help="Ensemble: members trained at once, 1 to the "
                                              "number of CPUs.")] = 2,
    amplitude_weighting: Annotated[
        float | None, typer.Option(help="NFIR/Adam or NSS: loss weights 1/(a^2 + eps^2), eps "
                                        "in input units (default for m/s in and N out: NFIR "
                                        f"{RECIPE['amplitude_weighting']:g}, NSS "
                                        f"{NSS_RECIPE['amplitude_weighting']:g}; else 0 = plain "
                                        "MSE, as the paper).")
    ] = None,
    passivity: Annotated[
        float | None, typer.Option(help="NFIR/Adam or NSS: weight of the penalty on energy "
                                        "created at harmonic probes (default for m/s in and N "
                                        f"out: NFIR {RECIPE['passivity']:g}, NSS "
                                        f"{NSS_RECIPE['passivity']:g}; else 0 = off, as the "
                                        "paper).")
    ] = None,
    cycle_energy: Annotated[
        float | None, typer.Option(help="NFIR/Adam or NSS: weight of the error of the energy "
                                        "each input cycle exchanges (NSS: per cycle of each "
                                        "training sub-sequence); default for m/s in and N out: "
                                        f"NFIR {RECIPE['cycle_energy']:g}, NSS "
                                        f"{NSS_RECIPE['cycle_energy']:g}; else 0 = off, as the "
                                        "paper.")
    ] = None,
) -> None:
    """Identify an NFIR, NOE or NSS ROM (or an ensemble of them) from an input/output record.

    An NFIR trained by Adam (the default) on a velocity in m/s and a force in N uses the
    passive recipe: amplitude-weighted loss, a passivity penalty and a cycle-energy term
    (docs/rom.md, "A passive ROM"); its terms are written for the power F v, so records in
    other units (a force in, a displacement out, an acceleration in, ...) train on the plain
    MSE. One line says which loss was chosen and why; the options below override it, and
    --amplitude-weighting 0 --passivity 0 --cycle-energy 0 trains the paper's plain MSE.
    --input acceleration (records' tank acceleration, m/s^2) trains a network on the
    acceleration, always on the plain MSE; it runs in `beam` and `map` like any other.

    --arch nss trains a neural state-space ROM (sloshrom.rom.NSS: a state that carries where
    the liquid is and how it moves) on the tank velocity, by Adam on sub-sequences of
    --horizon samples, each started by an encoder of the --window samples before it. Its
    options are --states, --neurons, --window, --horizon, --batch, --learning-rate,
    --steps-per-epoch and --max-epochs (--delays, --hidden and --trainer are the networks'
    and refused); its loss by units is the NSS recipe (sloshrom.limits.NSS_RECIPE), and the
    three loss options set its terms as for an NFIR.

    The two records must have the same sample rate and the same units of the input and of the
    output; the model file may not be one of the records. With --ensemble K, K networks with
    seeds SEED..SEED+K-1 are trained in parallel (Dask) and written as one model file whose
    prediction is the mean of the members; the validation MSE of every member and their mean
    +- standard deviation are printed.

    Example: sloshrom train --data train.nc --validation validation.nc --arch nfir --delays 70
    --neurons 35 --out nfir.npz [--ensemble 5 --workers 2]
    """
    if arch not in ARCHS:
        fail(f"--arch must be nfir, noe or nss, got {arch!r}")
    nss = arch == "nss"
    if nss:
        for opt, value in (("--delays", delays), ("--hidden", hidden), ("--trainer", trainer)):
            if value is not None:
                fail(f"{opt} does not apply to --arch nss: {NOT_FOR_NSS[opt]}")
    _nss_options({"--states": states, "--window": window, "--horizon": horizon,
                  "--batch": batch, "--learning-rate": learning_rate,
                  "--steps-per-epoch": steps_per_epoch}, arch)
    _check_names(input_name, output_name)
    if arch == "noe" and input_name == "acceleration":
        fail("--input acceleration needs --arch nfir: an NOE takes the tank velocity")
    if nss and input_name != "velocity":
        fail(f"--arch nss reads the tank velocity: --input must be velocity, got "
             f"{input_name!r} (a network on another input is an NFIR)")
    if max_epochs is None:
        max_epochs = int(NSS_DEFAULTS["max_epochs"]) if nss else 1000
    hidden = "matlab" if hidden is None else hidden
    check_number(delays, "--delays", 1, MAX_DELAY)
    check_number(neurons, "--neurons", 1, MAX_NEURONS)
    _check_common(max_epochs, seed, hidden)
    check_number(ensemble, "--ensemble", 1, MAX_MEMBERS)
    if seed + ensemble - 1 > MAX_SEED:
        fail(f"--seed {seed} with --ensemble {ensemble}: the last member's seed "
             f"{seed + ensemble - 1} exceeds {MAX_SEED}")
    if ensemble > 1:
        n_cpu = os.cpu_count() or 1
        check_number(workers, "--workers", 1, n_cpu, why=f"this machine has {n_cpu} CPU(s)")
        if scheduler not in (None, "threads", "sequential"):
            check_scheduler(scheduler)
    trainers = ARCH_TRAINERS.get(arch, ())
    if trainer is not None and trainer not in trainers:
        fail(f"--trainer for {arch.upper()} must be {', '.join(trainers)}, got {trainer!r}")
    check_number(fill, "--fill", 0.0, 1.0, lo_open=True, hi_open=True,
                 why="liquid depth / tank height")
    check_input(data, "--data")
    check_input(validation, "--validation")
    check_out(out, suffixes=(".npz",), inputs=(data, validation))
    rec, val = _read_pair(data, validation, [input_name, output_name])
    fill = _training_fill(fill, rec, data, val, validation)

    from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn

    from sloshrom.rom.estimators import NFIR, NOE, NSS

    kw: dict[str, Any] = {"max_epochs": max_epochs, "seed": seed,
                          "units": (rec.units[input_name], rec.units[output_name]),
                          "names": (input_name, output_name)}
    if nss:
        sizes = {"n_states": states, "neurons": neurons, "window": window, "horizon": horizon,
                 "batch": batch, "learning_rate": learning_rate,
                 "steps_per_epoch": steps_per_epoch}
        kw.update({k: v for k, v in sizes.items() if v is not None})
    else:
        kw["hidden"] = hidden
        if delays is not None:
            kw["delays"] = delays
        if neurons is not None:
            kw["neurons"] = neurons
        if trainer is not None:
            kw["trainer"] = trainer
    # the loss terms train an NFIR by Adam and an NSS (Adam too); an NOE trains by LM
    adam = (arch == "nfir" and trainer in (None, "adam")) or nss
    # the recipe by the records' units: its terms hold for m/s in and N out only
    choice = loss_recipe(*kw["units"], same=same_unit)
    if nss:
        choice = _nss_recipe(choice)
    given = {"amplitude_weighting": amplitude_weighting, "passivity": passivity,
             "cycle_energy": cycle_energy}
    for opt, value in given.items():
        flag = "--" + opt.replace("_", "-")
        if value is not None and not (math.isfinite(value) and value >= 0):
            fail(f"{flag} must be a finite number >= 0, got {value!r}")
        if value and not adam:
            fail(f"{flag} needs an NFIR trained by adam or an NSS (got --arch {arch}"
                 f"{'' if trainer is None else f' --trainer {trainer}'})")
        if value and input_name == "acceleration":
            fail(f"{flag} needs a velocity input: the term is written for the power F v "
                 "(a network on the acceleration trains on the plain MSE)")
        if adam:
            kw[opt] = choice.terms[opt] if value is None else value
    if adam:
        set_by = [k for k, v in given.items() if v is not None]
        typer.echo(str(choice) if not set_by else
                   f"loss: {', '.join(f'{k} {kw[k]:g}' for k in given)}: "
                   f"{', '.join(set_by)} set by the options (by the records' units: "
                   f"{choice.name})")
    cls = {"nfir": NFIR, "noe": NOE, "nss": NSS}[arch]
    try:
        model = cls(**kw)  # the hyperparameters are checked above, the file limits here
        n_params = model.n_params if nss else 0  # an NSS checks its file limits here
    except SloshromError as exc:  # ROMError: a network no model file holds
        fail(str(exc))
    if ensemble * n_params > MAX_WEIGHTS:  # the model file's limit, before the training
        fail(f"{_label(arch, model)}{f' x {ensemble} members' if ensemble > 1 else ''} has "
             f"{ensemble * n_params} weights, more than {MAX_WEIGHTS}, the most a model file "
             "holds")
    if nss:
        _check_length(rec, data, arch, model.window, model.neurons, "training",
                      horizon=model.horizon)
    else:
        _check_length(rec, data, arch, model.max_delay, int(model.neurons), "training")
    if len(val) <= model.max_delay:
        what = f"an encoder window of {model.window}" if nss else f"{model.max_delay} delays"
        fail(f"{validation}: {len(val)} samples are too few for {what}")
    if ensemble > 1:
        _train_ensemble(model, ensemble, rec, val, input_name, output_name, out,
                        scheduler if scheduler is not None or workers > 1 else "sequential",
                        workers, fill, _label(arch, model))
        return
    with Progress(TextColumn("{task.description}"), BarColumn(), TextColumn("{task.fields[info]}"),
                  TimeElapsedColumn()) as progress:
        task = progress.add_task(f"training {arch.upper()}", total=max_epochs, info="")

        def cb(epoch: int, info: dict[str, float]) -> None:
            # Levenberg–Marquardt reports its damping mu; Adam (an NSS) has none
            mu = f" mu {info['mu']:.1e}" if "mu" in info else ""
            progress.update(task, completed=epoch,
                            info=f"epoch {epoch} train {info['train_mse']:.4g} "
                                 f"val {info['val_mse']:.4g}{mu}")

        try:
            model.fit(rec[input_name], rec[output_name], fs=rec.fs,
                      validation=(val[input_name], val[output_name]), callback=cb, fill=fill)
        except SloshromError as exc:  # ROMError (a constant record, ...), UnstableModelError
            fail(str(exc))
    try:
        path = model.save(out)
    except SloshromError as exc:  # ROMError: a value beyond the model-file format's bounds
        fail(str(exc))
    h = model.history_
    typer.echo(
        f"wrote {path}: {_label(arch, model)}, {model.n_params} "
        f"parameters, {len(h['train_mse']) - 1} epochs ({h['stop_reason']}), best epoch "
        f"{h['best_epoch']}, validation MSE {h['val_mse'][h['best_epoch']]:.4g} "
        f"{rec.units[output_name]}^2, {h['train_seconds']:.1f} s"
    )


def _train_ensemble(template: Any, k: int, rec: Any, val: Any, input_name: str,
                    output_name: str, out: Path, scheduler: str | None, workers: int,
                    fill: float | None, label: str) -> None:
    """``train --ensemble K``: K members through Dask, one file, per-member validation MSE;
    ``label`` names the members' architecture (``NFIR(70, 35)``)."""
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

    from sloshrom.rom.ensemble import Ensemble, spread

    ens = Ensemble(template, n_members=k)
    arch = label.split("(")[0]
    with Progress(TextColumn("{task.description}"), BarColumn(), MofNCompleteColumn(),
                  TextColumn("{task.fields[info]}"), TimeElapsedColumn()) as progress:
        task = progress.add_task(f"training {k} x {arch}", total=k, info="")

        def cb(i: int, member: Any) -> None:
            progress.update(task, advance=1, info=f"member {i} (seed {member.seed}) done")

        try:
            ens.fit(rec[input_name], rec[output_name], fs=rec.fs,
                    validation=(val[input_name], val[output_name]), scheduler=scheduler,
                    n_workers=workers, progress=cb, fill=fill)
        except SloshromError as exc:  # ROMError (a constant record, ...), UnstableModelError
            fail(str(exc))
    try:
        path = ens.save(out)
        uv, yv = val[input_name], val[output_name]
        preds = ens.member_predictions(uv)
    except SloshromError as exc:
        fail(str(exc))
    unit = f"{rec.units[output_name]}^2"
    mse = [float(np.mean((p - yv) ** 2)) for p in preds]
    for i, (m, e) in enumerate(zip(ens.members_, mse, strict=True)):
        h = m.history_
        typer.echo(f"member {i} (seed {m.seed}): validation MSE {e:.4g} {unit}, "
                   f"{len(h['train_mse']) - 1} epochs ({h['stop_reason']})")
    s = spread(mse)
    mean_mse = float(np.mean((np.mean(preds, axis=0) - yv) ** 2))
    typer.echo(
        f"wrote {path}: ensemble of {k} {label}, "
        f"{ens.n_params} parameters; validation MSE over members {s['mean']:.4g} +- "
        f"{s['std']:.4g} {unit}, of the ensemble mean {mean_mse:.4g} {unit}"
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
) -> None:
    """Simulate a ROM on an input record; writes the record plus ``<output>_pred``.

    The record's input variable must be at the model's sample rate and in the model's unit
    after conversion to SI (a record in mm/s or ft/s is converted for a model in m/s; one in
    rad/s, or in a unit sloshrom does not know, is refused).

    Example: sloshrom predict --model nfir.npz --data validation.nc --out prediction.nc
    """
    check_number(fill, "--fill", 0.0, 1.0, lo_open=True, hi_open=True,
                 why="liquid depth / tank height")
    check_input(model, "--model")
    check_input(data, "--data")
    check_out(out, suffixes=RECORD_SUFFIXES, inputs=(data, model))
    from sloshrom.rom.estimators import load_model
    from sloshrom.rom.family import at_fill

    try:
        m = load_model(model)
    except SloshromError as exc:
        fail(str(exc))
    names = m.names  # a fill family describes its members' records
    rec = _read(data, [names[0]], "--data")
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
    try:
        y = m.predict(rec[in_name])
    except SloshromError as exc:  # UnstableModelError, ROMError (NaN in the record)
        fail(str(exc))
    new = rec.with_variables({f"{out_name}_pred": y}, {f"{out_name}_pred": m.units[1]},
                             prediction_model=str(model))
    write_record(new, out)
    msg = f"wrote {out}: {out_name}_pred ({len(y)} samples)"
    if out_name in rec:
        if same_unit(rec.units[out_name], m.units[1]):
            e = y - rec[out_name]
            msg += f", MSE {np.mean(e**2):.4g} {m.units[1]}^2 against {out_name}"
        else:
            msg += (f" (no MSE: {out_name} is in '{rec.units[out_name]}', the model gives "
                    f"'{m.units[1]}')")
    typer.echo(msg)


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
    arch: Annotated[str, typer.Option(help="nfir, noe or both.")] = "both",
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
    if arch not in ("nfir", "noe", "both"):
        fail(f"--arch must be nfir, noe or both, got {arch!r}")
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

    from rich.progress import (
        BarColumn,
        MofNCompleteColumn,
        Progress,
        TextColumn,
        TimeElapsedColumn,
    )

    from sloshrom.plotting.rom import plot_sweep
    from sloshrom.rom.sweep import run_sweep

    for a in sorted({p[0] for p in pts}):
        big = [p for p in pts if p[0] == a]
        _check_length(rec, data, a, max(p[1] for p in big), max(p[2] for p in big),
                      "the largest network of the grid")
    with Progress(TextColumn("sweep"), BarColumn(), MofNCompleteColumn(),
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
    typer.echo(f"wrote {out}/sweep.csv, sweep.json, {fig.name}: best {best['name']} score "
               f"{best['score']:.4g}; {n_bad} unstable")
