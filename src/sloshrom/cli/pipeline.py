"""``sloshrom reproduce``, ``sloshrom config show`` and ``sloshrom map``.

The library modules are imported inside the commands: ``sloshrom --help`` must not load JAX,
xarray and matplotlib.
"""

from __future__ import annotations

import json
import math
from collections.abc import Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any

import typer

if TYPE_CHECKING:  # rich loads at the command, not at --help
    from rich.console import Console
    from rich.progress import TaskID

from sloshrom.cli._app import (
    app,
    check_input,
    check_number,
    check_out,
    check_sloshing_rom,
    fail,
)
from sloshrom.cli.progress import progress_bars, stage_events
from sloshrom.config import Tank
from sloshrom.errors import SloshromError
from sloshrom.limits import MAX_SEED
from sloshrom.pipeline import settings
from sloshrom.signals import DEFAULT_A_BAR_MIN
from sloshrom.signals import SHAKER_ENVELOPE as _ENV

config_app = typer.Typer(help="Show the configuration of `sloshrom reproduce`.",
                         no_args_is_help=True)
app.add_typer(config_app, name="config")


def load_config(config: Path | None, quick: bool) -> settings.ReproduceConfig:
    """The merged configuration, validated by :func:`sloshrom.pipeline.settings.validate`, its
    tanks checked against the virtual rig (what ``reproduce`` would fail on, ``config show``
    refuses too)."""
    check_input(config, "--config")
    try:
        cfg = settings.load(config, quick=quick)
        if config is not None:  # the defaults' tanks are the rig's own
            from sloshrom.pipeline.context import check_rig_tanks

            check_rig_tanks(cfg)
        return cfg
    except SloshromError as exc:
        fail(str(exc))


@config_app.command("show")
def config_show(
    config: Annotated[Path | None, typer.Option(help="Merge this TOML file over the "
                                                "defaults.")] = None,
    quick: Annotated[bool, typer.Option(help="Show the --quick sizes.")] = False,
) -> None:
    """Print the defaults (with comments), or the merged configuration as JSON.

    Example: ``sloshrom config show > my.toml``, edit, then ``sloshrom reproduce --config my.toml``.
    """
    if config is None and not quick:
        typer.echo(settings.default_text())
        return
    typer.echo(json.dumps(load_config(config, quick).as_dict(), indent=1))


def _print_missing(console: Console, beam: Mapping[str, object]) -> None:
    """Table 2's and the damping bands' cells without a value (each with its reason), and the
    values a fallback attempt or part of an ensemble's members gave (with their note)."""
    from sloshrom.beam.damping.columns import table2_dataset
    from sloshrom.beam.damping.tables import missing_cells

    for what, key in (("Table 2", "table2"), ("damping bands", "damping_bands")):
        rows = beam.get(key)
        if not isinstance(rows, list):
            continue
        if key == "table2":  # the record's rows as each case's Table 2 over the estimators
            lines = [line for case in dict.fromkeys(r["case"] for r in rows)
                     for line in missing_cells(table2_dataset(
                         [r for r in rows if r["case"] == case]).assign_coords(case=case))]
        else:
            lines = missing_cells(rows)
        if lines:
            console.print(f"{what}, cells without a value or with a note:", markup=False)
            for line in lines:
                console.print(f"  {line}", markup=False, highlight=False)


@app.command()
def reproduce(
    out: Annotated[Path, typer.Option(help="Output directory.")] = Path("results"),
    config: Annotated[Path | None, typer.Option(help="TOML file overriding defaults "
                                                "(see `sloshrom config show`).")] = None,
    quick: Annotated[bool, typer.Option(help="Reduced sizes: the whole chain in a few "
                                        "minutes.")] = False,
    sweep: Annotated[bool, typer.Option(help="Run the full sensitivity sweep (paper "
                                        "Fig. 8).")] = False,
    beyond: Annotated[bool, typer.Option(help="Also run the sections beyond the paper "
                                         "([beyond]: fill family, bouncing-ball baseline, "
                                         "two-mode structure; docs/reproduce.md).")] = False,
) -> None:
    """Reproduce the paper on the built-in virtual rig and write OUT/report.html.

    Stages: rig data -> ROM training -> Phi_d maps -> sloshing beam -> report. Finished stages
    are cached in OUT/.stages: an interrupted run restarts where it stopped.

    Example: ``sloshrom reproduce --out results --quick``
    """
    from rich.console import Console
    from rich.progress import BarColumn, TextColumn, TimeElapsedColumn

    from sloshrom.pipeline import run
    from sloshrom.pipeline.chain import RESULT_ENTRIES

    cfg = load_config(config, quick)
    changes = {**({"rom": {"sweep": True}} if sweep else {}),
               **({"beyond": {"enabled": True}} if beyond else {})}
    if changes:
        try:  # validated again: the sweep grid must fit the data too
            cfg = cfg.replace(**changes)
        except SloshromError as exc:
            fail(str(exc))
    # the configuration is protected from every file the run writes, not only from --out
    check_out(out, directory=True, inputs=(config,), contents=RESULT_ENTRIES)
    console = Console(stderr=True)
    tasks: dict[str, TaskID] = {}
    # without a terminal: a log line per stage start and end, progress every 30 s at most
    with progress_bars(TextColumn("[bold]{task.fields[stage]:<7}"), BarColumn(),
                       TextColumn("{task.description}"), TimeElapsedColumn(),
                       console=console) as prog:

        def report(stage: str, done: float, total: float, text: str) -> None:
            if stage not in tasks:
                tasks[stage] = prog.add_task(text, total=total, stage=stage)
            prog.update(tasks[stage], completed=done, total=total, description=text)

        try:
            summary = run(out, cfg, progress=report, on_stage=stage_events(prog))
        except (SloshromError, OSError) as exc:  # user input or disk, not a bug: one line
            prog.stop()
            fail(str(exc))
    for name, st in summary["stages"].items():
        console.print(f"{name:7s} {'reused' if st['reused'] else 'done'}"
                      f" ({summary['timings_s'].get(name, 0.0):.1f} s)")
    _print_missing(console, summary["stages"].get("beam") or {})
    console.print(f"report: {Path(out) / 'report.html'}   summary: {Path(out) / 'summary.json'}")


MAP_SUFFIXES = (".nc",)
MAX_GRID = 200  # points per axis: each frequency runs n_a harmonic tests as one 10 kHz batch
_N_OMEGA_HELP = f"Frequency points ({_ENV.f_min:g}-{_ENV.f_max:g} Hz), 2-{MAX_GRID}."
_N_A_HELP = (f"Amplitude points (a/h in {DEFAULT_A_BAR_MIN:g}-{_ENV.a_bar_max:g}), "
             f"2-{MAX_GRID}.")


@app.command("map")
def map_cmd(
    out: Annotated[Path, typer.Option(help="Output NetCDF file (a PNG is written beside it).")],
    rig: Annotated[bool, typer.Option("--rig", help="Map the virtual rig.")] = False,
    model: Annotated[Path | None, typer.Option(help="Map this ROM file instead.")] = None,
    n_omega: Annotated[int, typer.Option(help=_N_OMEGA_HELP)] = 30,
    n_a: Annotated[int, typer.Option(help=_N_A_HELP)] = 30,
    reference: Annotated[Path | None, typer.Option(help="A map file on the same grid to "
                                                   "compare with (prints the relative L2 "
                                                   "error over the whole map and over the "
                                                   "dissipative region, and the passivity)."
                                                   )] = None,
    seed: Annotated[int, typer.Option(help="Rig seed (>= 0).")] = 0,
    fill: Annotated[float | None, typer.Option(
        help="Fill level d/h in (0, 1): the rig's tank, or the fill to run --model at (a "
             "fill family .toml needs it; a single ROM refuses any other fill than its "
             "training records'). Default: the ROM's training fill, else 0.5.")] = None,
) -> None:
    """Dissipated-energy map Phi_d(omega_bar, a_bar) from batched harmonic tests.

    The NetCDF file and its PNG appear together at the end, or neither if the run fails; the
    reference map is read and compared with the grid before the (long) map starts. With
    --reference the comparison is printed whole map first: relative L2 error over every point,
    over the dissipative region (reference Phi_d > 10 % of its maximum), and the points where
    the new map is not passive (Phi_d below -2 % of the reference maximum).

    Example: ``sloshrom map --rig --out rig_map.nc`` then
    ``sloshrom map --model nfir.npz --reference rig_map.nc --out rom_map.nc``.
    """
    if rig == (model is not None):
        fail("give exactly one of --rig or --model FILE")
    for name, n in (("--n-omega", n_omega), ("--n-a", n_a)):
        check_number(n, name, 2, MAX_GRID,
                     why="each frequency runs the amplitudes as one batch at the rig's 10 kHz "
                         "step; the grid size sets memory and time")
    check_number(seed, "--seed", 0, MAX_SEED)
    check_number(fill, "--fill", 0.0, 1.0, lo_open=True, hi_open=True,
                 why="liquid depth / tank height")
    check_input(model, "--model")
    check_input(reference, "--reference")
    check_out(out, suffixes=MAP_SUFFIXES, inputs=(model, reference))
    check_out(out.with_suffix(".png"), inputs=(model, reference), what="--out (its PNG)")
    cfg = settings.load().replace(map={"n_omega": n_omega, "n_a": n_a})
    sm = None
    if not rig:  # the ROM first: its training fill is the default fill of the map
        sm, fill = _load_rom(model, 8 * cfg.map.f_max, fill)
    tank = Tank() if fill is None else Tank(fill=fill)
    ref = None
    if reference is not None:  # read it first: a bad reference must not cost a whole map
        ref = _read_reference(reference, cfg, tank)
    if rig:
        from sloshrom.rig.virtual import VirtualRig

        try:  # a tank the rig cannot model (an extreme fill) is refused before the map
            sm = VirtualRig(tank=tank, seed=seed)
        except SloshromError as exc:
            fail(f"--rig: {exc}")
        title = "virtual rig"
    else:
        title = f"ROM {model.name}"
    if fill is not None:
        title += f", fill {tank.fill:.1%}"
    from sloshrom.energy import map_fidelity, map_maximum
    from sloshrom.pipeline.maps import compute_map, fidelity_lines, write_map

    with progress_bars(transient=True) as prog:
        task = prog.add_task("harmonic tests", total=n_omega)
        da = compute_map(sm, cfg, tank, lambda d, t: prog.update(task, completed=d, total=t))
    fid = map_fidelity(ref, da) if ref is not None else None
    # with a reference, the PNG marks exactly the points counted as non-passive (an all-NaN
    # reference has no threshold: the map's own default then)
    thr = fid["passivity_threshold"] if fid is not None else float("nan")
    write_map(da, out, title, negative_below=thr if math.isfinite(thr) else None)
    mx = map_maximum(da)
    typer.echo(f"max Phi_d = {mx['phi_d']:.3g} at omega_bar = {mx['omega_bar']:.2f}, "
               f"a_bar = {mx['a_bar']:.3f} (Gamma = {mx['gamma']:.2f} g, "
               f"{mx['frequency']:.1f} Hz); wrote {out} and {out.with_suffix('.png')}")
    if fid is not None:
        typer.echo("\n".join(fidelity_lines(fid, str(reference))))


def _load_rom(path: Path, min_fs: float, fill: float | None) -> tuple[Any, float | None]:
    """A ROM usable for harmonic tests (m/s or m/s^2 -> N, fast enough for the top frequency) at
    ``fill``, and the fill (default: the one its training records had, if it says)."""
    from sloshrom.rom.family import at_fill, training_fills
    from sloshrom.rom.loading import load_model

    try:
        m = load_model(path)
        trained = training_fills(m)
        if fill is None and trained is not None and trained[0] == trained[1]:
            fill = trained[0]
        m = at_fill(m, fill, str(path))
    except SloshromError as exc:  # ModelFileError, a fill outside the model's
        fail(f"--model {exc}" if str(exc).startswith(str(path)) else str(exc))
    check_sloshing_rom(m, path, "--model", "the map")
    if m.fs_ < min_fs:
        fail(f"--model {path}: the ROM runs at {m.fs_:g} Hz, too slow for harmonic tests up to "
             f"{min_fs / 8:g} Hz (need at least {min_fs:g} Hz, 8 samples per cycle)")
    return m, fill


def _read_reference(path: Path, cfg: settings.ReproduceConfig, tank: Tank):
    """``phi_d`` of a map file written by ``sloshrom map`` on this grid, or a clear error."""
    import numpy as np
    import xarray as xr

    from sloshrom.pipeline.maps import map_grid

    try:
        with xr.open_dataset(path, engine="h5netcdf") as ds:
            r = np.asarray(ds["phi_d"].values)
            coords = {k: np.asarray(ds[k].values) for k in ("omega_bar", "a_bar") if k in ds}
    except KeyError:
        fail(f"{path}: not a map file (no 'phi_d' variable)")
    except Exception as exc:  # h5py/xarray raise many types for corrupt files
        fail(f"{path}: not a readable NetCDF map ({type(exc).__name__}: {exc})")
    ob, ab = map_grid(cfg, tank)
    if r.shape != (ob.size, ab.size):
        fail(f"--reference {path}: map of shape {r.shape}, this map will be "
             f"({ob.size}, {ab.size}): use the same --n-omega and --n-a")
    for name, mine in (("omega_bar", ob), ("a_bar", ab)):
        theirs = coords.get(name)
        if theirs is None or theirs.shape != mine.shape or not np.allclose(theirs, mine,
                                                                           rtol=1e-6):
            fail(f"--reference {path}: its {name} grid differs from this map's (another tank "
                 "or envelope): the maps cannot be compared point by point")
    return r
