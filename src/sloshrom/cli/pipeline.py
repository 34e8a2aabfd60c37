"""``sloshrom reproduce``, ``sloshrom config show`` and ``sloshrom map``."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Annotated

import typer

from sloshrom.cli._app import app

config_app = typer.Typer(help="Show the configuration of `sloshrom reproduce`.",
                         no_args_is_help=True)
app.add_typer(config_app, name="config")


def _fail(msg: str) -> None:
    typer.secho(f"error: {msg}", fg=typer.colors.RED, err=True)
    raise typer.Exit(code=2)


@config_app.command("show")
def config_show(
    config: Annotated[Path | None, typer.Option(help="Merge this TOML file over the "
                                                "defaults.")] = None,
    quick: Annotated[bool, typer.Option(help="Show the --quick sizes.")] = False,
) -> None:
    """Print the defaults (with comments), or the merged configuration as JSON.

    Example: ``sloshrom config show > my.toml``, edit, then ``sloshrom reproduce --config my.toml``.
    """
    from sloshrom import settings
    from sloshrom.config import ConfigError

    if config is None and not quick:
        typer.echo(settings.default_text())
        return
    try:
        typer.echo(json.dumps(settings.load(config, quick=quick), indent=1))
    except ConfigError as exc:
        _fail(str(exc))


@app.command()
def reproduce(
    out: Annotated[Path, typer.Option(help="Output directory.")] = Path("results"),
    config: Annotated[Path | None, typer.Option(help="TOML file overriding defaults "
                                                "(see `sloshrom config show`).")] = None,
    quick: Annotated[bool, typer.Option(help="Reduced sizes: the whole chain in a few "
                                        "minutes.")] = False,
    sweep: Annotated[bool, typer.Option(help="Run the full sensitivity sweep (paper "
                                        "Fig. 8).")] = False,
) -> None:
    """Reproduce the paper on the built-in virtual rig and write OUT/report.html.

    Stages: rig data -> ROM training -> Phi_d maps -> sloshing beam -> report. Finished stages
    are cached in OUT/.stages: an interrupted run restarts where it stopped.

    Example: ``sloshrom reproduce --out results --quick``
    """
    from rich.console import Console
    from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn

    from sloshrom import pipeline, settings
    from sloshrom.config import ConfigError

    try:
        cfg = settings.load(config, quick=quick)
    except ConfigError as exc:
        _fail(str(exc))
    if sweep:
        cfg["rom"]["sweep"] = True
    console = Console(stderr=True)
    tasks: dict[str, int] = {}
    with Progress(TextColumn("[bold]{task.fields[stage]:<7}"), BarColumn(),
                  TextColumn("{task.description}"), TimeElapsedColumn(),
                  console=console) as prog:

        def report(stage: str, done: float, total: float, text: str) -> None:
            if stage not in tasks:
                tasks[stage] = prog.add_task(text, total=total, stage=stage)
            prog.update(tasks[stage], completed=done, total=total, description=text)

        summary = pipeline.run(out, cfg, progress=report)
    for name, st in summary["stages"].items():
        console.print(f"{name:7s} {'reused' if st['reused'] else 'done'}"
                      f" ({summary['timings_s'].get(name, 0.0):.1f} s)")
    for item in summary["not_built"]:
        console.print(f"[yellow]not built yet: {item}")
    console.print(f"report: {Path(out) / 'report.html'}   summary: {Path(out) / 'summary.json'}")


@app.command("map")
def map_cmd(
    out: Annotated[Path, typer.Option(help="Output NetCDF file (a PNG is written beside it).")],
    rig: Annotated[bool, typer.Option("--rig", help="Map the virtual rig.")] = False,
    model: Annotated[Path | None, typer.Option(help="Map this ROM file instead.")] = None,
    n_omega: Annotated[int, typer.Option(help="Frequency points (5-25 Hz).")] = 30,
    n_a: Annotated[int, typer.Option(help="Amplitude points (a/h in 0.01-0.45).")] = 30,
    reference: Annotated[Path | None, typer.Option(help="A map file to compare with "
                                                   "(prints the relative L2 error).")] = None,
    seed: Annotated[int, typer.Option(help="Rig seed.")] = 0,
) -> None:
    """Dissipated-energy map Phi_d(omega_bar, a_bar) from batched harmonic tests.

    Example: ``sloshrom map --rig --out rig_map.nc`` then
    ``sloshrom map --model nfir.npz --reference rig_map.nc --out rom_map.nc``.
    """
    from rich.progress import Progress

    from sloshrom import pipeline, settings
    from sloshrom.config import Tank
    from sloshrom.energy import map_maximum

    if rig == (model is not None):
        _fail("give exactly one of --rig or --model FILE")
    if n_omega < 2 or n_a < 2:
        _fail("--n-omega and --n-a must be at least 2")
    cfg = settings.defaults()
    cfg["map"].update(n_omega=n_omega, n_a=n_a)
    tank = Tank()
    if rig:
        from sloshrom.rig import VirtualRig

        sm = VirtualRig(tank=tank, seed=seed)
        title = "virtual rig"
    else:
        from sloshrom.rom import load_model

        if not model.is_file():
            _fail(f"model file not found: {model}")
        sm = load_model(model)
        title = f"ROM {model.name}"
    with Progress(transient=True) as prog:
        task = prog.add_task("harmonic tests", total=n_omega)
        da = pipeline.compute_map(sm, cfg, tank,
                                  lambda d, t: prog.update(task, completed=d, total=t))
    out.parent.mkdir(parents=True, exist_ok=True)
    pipeline.write_map(da, out, title)
    mx = map_maximum(da)
    typer.echo(f"max Phi_d = {mx['phi_d']:.3g} at omega_bar = {mx['omega_bar']:.2f}, "
               f"a_bar = {mx['a_bar']:.3f} (Gamma = {mx['gamma']:.2f} g, "
               f"{mx['frequency']:.1f} Hz); wrote {out} and {out.with_suffix('.png')}")
    if reference is not None:
        import xarray as xr

        with xr.open_dataset(reference, engine="h5netcdf") as ref:
            r = ref["phi_d"].values
        if r.shape != da.shape:
            _fail(f"reference map has shape {r.shape}, this map {da.shape}: use the same grid")
        err = pipeline.relative_map_error(r, da.values)
        typer.echo(f"relative L2 error against {reference}: {err:.1%}")
