"""``sloshrom reproduce``, ``sloshrom config show`` and ``sloshrom map``."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Annotated

import typer

from sloshrom.cli._app import app, fail

config_app = typer.Typer(help="Show the configuration of `sloshrom reproduce`.",
                         no_args_is_help=True)
app.add_typer(config_app, name="config")


def _check_config(cfg: dict) -> None:
    """Validate values that would otherwise fail deep inside a stage, after minutes of work.

    Raises ``ConfigError`` naming the key (bad-input suite, tests/test_bad_input.py).
    """
    import math

    from sloshrom.config import ConfigError, Tank

    try:
        Tank.from_dict(dict(cfg["tank"]))
    except ConfigError as exc:
        raise ConfigError(f"[tank]: {exc}") from None
    positive = {"rig": ("fs",), "data": ("train_duration", "validation_duration"),
                "map": ("f_min", "f_max", "gamma_max", "a_bar_min", "a_bar_max"),
                "beam": ("free_duration", "random_duration")}
    for sec, keys in positive.items():
        for key in keys:
            v = cfg.get(sec, {}).get(key)
            if v is not None and not (math.isfinite(v) and v > 0):
                raise ConfigError(f"'{sec}.{key}' must be a finite positive number, got {v!r}")
    for sec, key, lo in (("rom", "delays", 1), ("rom", "neurons", 1), ("rom", "max_epochs", 0),
                         ("map", "n_omega", 2), ("map", "n_a", 2), ("beam", "n_modes", 1)):
        v = cfg.get(sec, {}).get(key)
        if v is not None and not (isinstance(v, int) and v >= lo):
            raise ConfigError(f"'{sec}.{key}' must be an integer >= {lo}, got {v!r}")
    rom = cfg.get("rom", {})
    if rom.get("arch", "nfir") not in ("nfir", "noe"):
        raise ConfigError(f"'rom.arch' must be \"nfir\" or \"noe\", got {rom['arch']!r}")
    if rom.get("hidden", "matlab") not in ("matlab", "distance"):
        raise ConfigError(f"'rom.hidden' must be \"matlab\" or \"distance\", "
                          f"got {rom['hidden']!r}")


def _load_config(config: Path | None, quick: bool) -> dict:
    from sloshrom import settings
    from sloshrom.config import ConfigError

    try:
        cfg = settings.load(config, quick=quick)
        _check_config(cfg)
    except ConfigError as exc:
        fail(str(exc))
    return cfg


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

    if config is None and not quick:
        typer.echo(settings.default_text())
        return
    typer.echo(json.dumps(_load_config(config, quick), indent=1))


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

    from sloshrom import pipeline
    from sloshrom.config import ConfigError
    from sloshrom.data import RecordError

    cfg = _load_config(config, quick)
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

        try:
            summary = pipeline.run(out, cfg, progress=report)
        except (ConfigError, RecordError, OSError) as exc:  # user input, not a bug: no traceback
            prog.stop()
            fail(str(exc))
        except ValueError as exc:  # a config value a stage rejects (e.g. a too short duration)
            prog.stop()
            fail(f"{exc} (check the configuration: sloshrom config show --config FILE)")
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
        fail("give exactly one of --rig or --model FILE")
    if n_omega < 2 or n_a < 2:
        fail("--n-omega and --n-a must be at least 2")
    ref = None
    if reference is not None:  # read it first: a bad reference must not cost a whole map
        ref = _read_reference(reference)
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
            fail(f"model file not found: {model}")
        try:
            sm = load_model(model)
        except ValueError as exc:  # ModelFileError: wrong format/version, tampered arrays
            fail(str(exc))
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
    if ref is not None:
        r = ref
        if r.shape != da.shape:
            fail(f"reference map has shape {r.shape}, this map {da.shape}: use the same grid")
        err = pipeline.relative_map_error(r, da.values)
        typer.echo(f"relative L2 error against {reference}: {err:.1%}")


def _read_reference(path: Path):
    """``phi_d`` of a map file written by ``sloshrom map``, or a clear error."""
    import numpy as np
    import xarray as xr

    if not path.is_file():
        fail(f"reference map not found: {path}")
    try:
        with xr.open_dataset(path, engine="h5netcdf") as ds:
            r = np.asarray(ds["phi_d"].values)
    except KeyError:
        fail(f"{path}: not a map file (no 'phi_d' variable)")
    except Exception as exc:  # h5py/xarray raise many types for corrupt files
        fail(f"{path}: not a readable NetCDF map ({type(exc).__name__}: {exc})")
    return r
