"""``sloshrom train | predict | sweep``: identify NFIR/NOE ROMs from records and use them.

Records are read with :func:`sloshrom.data.read_record` (NetCDF, CSV, MATLAB) and written with
:func:`sloshrom.data.write_record`; models are ``.npz`` files (:func:`sloshrom.rom.load_model`).
"""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Any

import numpy as np
import typer

from sloshrom.cli._app import app, fail

__all__ = ["predict", "sweep", "train"]


def _read(path: Path, names: list[str]):
    from sloshrom.data import read_record

    try:
        rec = read_record(path)
    except ValueError as exc:
        fail(str(exc))
    missing = [n for n in names if n not in rec]
    if missing:
        fail(f"{path}: no variable {', '.join(missing)} (has: {', '.join(rec.names)})")
    for n in names:
        if np.ndim(rec[n]) != 1:
            fail(f"{path}: variable {n} is not 1-D")
    return rec


def _same_rate(a: float, b: float, what: str) -> None:
    if not np.isclose(a, b, rtol=1e-6):
        fail(f"sample-rate mismatch: {what} ({a:g} Hz vs {b:g} Hz); resample first")


def _parse_ints(text: str | None, name: str) -> list[int] | None:
    if text is None:
        return None
    try:
        vals = [int(v) for v in text.replace(" ", "").split(",") if v]
    except ValueError:
        fail(f"{name} must be a comma-separated list of integers, got {text!r}")
    if not vals or min(vals) < 1:
        fail(f"{name} must list positive integers, got {text!r}")
    return vals


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
    arch: Annotated[str, typer.Option("--arch", help="nfir or noe.")] = "nfir",
    delays: Annotated[int | None, typer.Option(help="Input delays (NFIR 70, NOE 2).")] = None,
    neurons: Annotated[int | None, typer.Option(help="Hidden neurons (NFIR 35, NOE 10).")] = None,
    hidden: Annotated[str, typer.Option(help="RBF variant: matlab or distance.")] = "matlab",
    max_epochs: Annotated[int, typer.Option(help="Levenberg-Marquardt epochs at most.")] = 1000,
    trainer: Annotated[
        str | None, typer.Option(help="NFIR: adam (default), fast (subsampled LM) or lm (trainlm).")
    ] = None,
    seed: Annotated[int, typer.Option(help="Seed of the initialisation.")] = 0,
) -> None:
    """Identify an NFIR or NOE ROM from an input/output record.

    Example: sloshrom train --data train.nc --validation validation.nc --arch nfir --delays 70
    --neurons 35 --out nfir.npz
    """
    from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn

    from sloshrom.data import RecordError
    from sloshrom.rom import NFIR, NOE, UnstableModelError

    if arch not in ("nfir", "noe"):
        fail(f"--arch must be nfir or noe, got {arch!r}")
    rec = _read(data, [input_name, output_name])
    val = _read(validation, [input_name, output_name])
    _same_rate(rec.fs, val.fs, f"{data} vs {validation}")
    cls = NFIR if arch == "nfir" else NOE
    kw: dict[str, Any] = {"hidden": hidden, "max_epochs": max_epochs, "seed": seed,
                          "units": (rec.units[input_name], rec.units[output_name]),
                          "names": (input_name, output_name)}
    if delays is not None:
        kw["delays"] = delays
    if neurons is not None:
        kw["neurons"] = neurons
    if trainer is not None:
        kw["trainer"] = trainer
    try:
        model = cls(**kw)
    except ValueError as exc:
        fail(str(exc))
    with Progress(TextColumn("{task.description}"), BarColumn(), TextColumn("{task.fields[info]}"),
                  TimeElapsedColumn()) as progress:
        task = progress.add_task(f"training {arch.upper()}", total=max_epochs, info="")

        def cb(epoch: int, info: dict[str, float]) -> None:
            progress.update(task, completed=epoch,
                            info=f"epoch {epoch} train {info['train_mse']:.4g} "
                                 f"val {info['val_mse']:.4g} mu {info['mu']:.1e}")

        try:
            model.fit(rec[input_name], rec[output_name], fs=rec.fs,
                      validation=(val[input_name], val[output_name]), callback=cb)
        except (ValueError, RecordError, UnstableModelError) as exc:
            fail(str(exc))
    path = model.save(out)
    h = model.history_
    typer.echo(
        f"wrote {path}: {arch.upper()}({model.delays}, {model.neurons}), {model.n_params} "
        f"parameters, {len(h['train_mse']) - 1} epochs ({h['stop_reason']}), best epoch "
        f"{h['best_epoch']}, validation MSE {h['val_mse'][h['best_epoch']]:.4g} "
        f"{rec.units[output_name]}^2, {h['train_seconds']:.1f} s"
    )


@app.command()
def predict(
    model: Annotated[Path, typer.Option("--model", "-m", help="Model file (.npz).")],
    data: Annotated[Path, typer.Option("--data", help="Input record.")],
    out: Annotated[Path, typer.Option("--out", "-o", help="Output record (.nc/.csv/.mat).")],
) -> None:
    """Simulate a ROM on an input record; writes the record plus ``<output>_pred``.

    Example: sloshrom predict --model nfir.npz --data validation.nc --out prediction.nc
    """
    import warnings

    from sloshrom.data import write_record
    from sloshrom.rom import ModelFileError, UnstableModelError, load_model

    try:
        m = load_model(model)
    except ModelFileError as exc:
        fail(str(exc))
    in_name, out_name = m.names
    rec = _read(data, [in_name])
    _same_rate(rec.fs, m.fs_, f"data {data} vs model {model}")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            y = m.predict(rec[in_name])
        except UnstableModelError as exc:
            fail(str(exc))
    for w in caught:
        typer.secho(f"warning: {w.message}", fg=typer.colors.YELLOW, err=True)
    new = rec.with_variables({f"{out_name}_pred": y}, {f"{out_name}_pred": m.units[1]},
                             prediction_model=str(model))
    write_record(new, out)
    msg = f"wrote {out}: {out_name}_pred ({len(y)} samples)"
    if out_name in rec:
        e = y - rec[out_name]
        msg += f", MSE {np.mean(e**2):.4g} {m.units[1]}^2 against {out_name}"
    typer.echo(msg)


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
    max_epochs: Annotated[int, typer.Option(help="LM epochs at most per model.")] = 1000,
    hidden: Annotated[str, typer.Option(help="RBF variant: matlab or distance.")] = "matlab",
    seed: Annotated[int, typer.Option(help="Initialisation seed.")] = 0,
    scheduler: Annotated[
        str | None,
        typer.Option(help="Dask scheduler address; 'threads' or 'sequential' for no cluster; "
                          "default: a new LocalCluster."),
    ] = None,
    workers: Annotated[int, typer.Option(help="LocalCluster workers / threads.")] = 2,
) -> None:
    """Sensitivity analysis over delays x neurons (paper Fig. 8); resumes an interrupted run.

    Example: sloshrom sweep --data train.nc --validation validation.nc --out sweep/ --arch nfir
    --delays 50,70 --neurons 10,20,35
    """
    from rich.progress import (
        BarColumn,
        MofNCompleteColumn,
        Progress,
        TextColumn,
        TimeElapsedColumn,
    )

    from sloshrom.sweep import default_grid, plot_sweep, run_sweep

    rec = _read(data, [input_name, output_name])
    val = _read(validation, [input_name, output_name])
    _same_rate(rec.fs, val.fs, f"{data} vs {validation}")
    try:
        pts = default_grid(arch)
    except ValueError as exc:
        fail(str(exc))
    dl, nl = _parse_ints(delays, "--delays"), _parse_ints(neurons, "--neurons")
    if dl or nl:
        archs = sorted({p[0] for p in pts})
        pts = [(a, d, n) for a in archs
               for d in (dl or sorted({p[1] for p in pts if p[0] == a}))
               for n in (nl or sorted({p[2] for p in pts if p[0] == a}))]
    with Progress(TextColumn("sweep"), BarColumn(), MofNCompleteColumn(),
                  TextColumn("{task.fields[info]}"), TimeElapsedColumn()) as progress:
        task = progress.add_task("sweep", total=len(pts), info="")

        def cb(row: dict[str, Any]) -> None:
            progress.update(task, advance=1, info=f"{row['name']}: score {row['score']:.4g}")

        rows = run_sweep((rec[input_name], rec[output_name]), (val[input_name], val[output_name]),
                         rec.fs, out, pts, scheduler=scheduler, n_workers=workers,
                         options={"max_epochs": max_epochs, "hidden": hidden, "seed": seed},
                         progress=cb)
    fig = plot_sweep(rows, out / "fig8_sweep.png")
    best = rows[0]
    n_bad = sum(r["unstable"] for r in rows)
    typer.echo(f"wrote {out}/sweep.csv, sweep.json, {fig.name}: best {best['name']} score "
               f"{best['score']:.4g}; {n_bad} unstable")
