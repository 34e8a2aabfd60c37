"""``sloshrom analyse``: a laboratory's measured beam tests through the analyses of ``sloshrom
beam``.

``analyse free`` (a free decay) and ``analyse random`` (random base excitation, one file per
level) read UFF 58, CSV, NetCDF or MATLAB files with a channel map (:mod:`sloshrom.beam.measured`),
build the modal model of the stations (the built-in cantilever, ``--modal-toml`` or
``--structure`` as in ``sloshrom beam``) and write what ``sloshrom beam`` writes for a
simulation: the NetCDF result, the damping tables and the figures, all together or none.
"""

from __future__ import annotations

import shlex
import warnings
from collections.abc import Callable
from pathlib import Path
from typing import Annotated, Any, TypeVar

import typer

from sloshrom.cli._app import app, check_input, check_number, fail, key_value_pairs
from sloshrom.cli.beam import (
    DirectionOpt,
    FillOpt,
    MassUnitOpt,
    ModalOpt,
    ModesOpt,
    ModeTableOpt,
    StructureOpt,
    StructureOptions,
    TankOpt,
    TankSpecOpt,
    check_outputs,
    echo_missing,
    setup_structure,
)
from sloshrom.errors import SloshromError
from sloshrom.fileio import OutputBatch
from sloshrom.io.record import MissingUnitError, UnitConflictError
from sloshrom.pipeline.settings import FREE_DAMPING_PERIODS, WELCH_NPERSEG, check_analysis_band
from sloshrom.plotting import savefig

analyse_app = typer.Typer(
    help="Measured beam tests (free decays, random base excitation) through the damping "
         "analyses of `sloshrom beam`.",
    no_args_is_help=True,
)
app.add_typer(analyse_app, name="analyse")

_FilesArg = Annotated[list[Path], typer.Argument(
    help="The test's files: UFF 58 (.uff/.unv), CSV, NetCDF (.nc) or MATLAB (.mat).",
    metavar="FILE", show_default=False)]
_ChannelsOpt = Annotated[Path, typer.Option(
    "--channels", help="Channel map TOML (\\[channels]: stations, positions or ids, base, "
                       "tank; \\[units]: channel units; see docs/formats.md).",
    show_default=False)]
_OutOpt = Annotated[Path, typer.Option(help="Output directory.", show_default=False)]
_NameOpt = Annotated[str, typer.Option(
    help="Case name of the test (files free_NAME.nc / random_NAME.nc, table rows).")]
_T = TypeVar("_T")
_UnitOpt = Annotated[list[str] | None, typer.Option(
    "--unit", help="CHANNEL=UNIT for a channel whose file gives no unit, e.g. --unit acc1=g "
                   "(repeatable; wins over the channel map's \\[units]).", show_default=False)]
_F1Opt = Annotated[float | None, typer.Option(
    "--f1", help="First-mode frequency, Hz, around which the analyses band-pass; default: the "
                 "structure's first mode with frozen liquid.")]


class _Steps:
    """A spinner whose text names the step under way (reading, analysing, writing)."""

    def __init__(self, progress: Any) -> None:
        self.progress, self.task = progress, progress.add_task("", total=None)

    def __call__(self, text: str) -> None:
        self.progress.update(self.task, description=text)


def _run(label: str, work: Callable[[_Steps], Any]) -> Any:
    from rich.progress import Progress, SpinnerColumn, TextColumn, TimeElapsedColumn

    with Progress(SpinnerColumn(), TextColumn("{task.description}"), TimeElapsedColumn(),
                  transient=True) as progress:
        return work(_Steps(progress))


def _checked(what: str, fn: Callable[[], Any]) -> Any:
    """``fn()``; a ``SloshromError`` (bad file, map or data) is a user error naming ``what``."""
    try:
        return fn()
    except SloshromError as exc:
        fail(f"{what}: {exc}" if what else str(exc))


def _prepare(files: list[Path], channels: Path, out: Path, name: str, tank_toml: Path | None,
             fill: float | None, modal_toml: Path | None, structure: Path | None,
             tank: list[str] | None, direction: str, mode_table: Path | None,
             modes: int | None, mass_unit: str | None, f1: float | None,
             units: dict[str, str] | None = None) -> tuple:
    """Options, channel map (with the --unit units) and structure, checked before any file
    is read: (map, setup, station model, f1)."""
    from sloshrom.beam.channels import ChannelMap, acceleration_unit, station_model

    if not files:
        fail("give the test's file(s)")
    for f in files:
        check_input(f, "FILE")
    real = [f.resolve() for f in files]  # another spelling of a path is the same file
    for i, r in enumerate(real):
        if r in real[:i]:
            fail(f"FILE {files[i]} is given twice (also as {files[real.index(r)]})")
    check_input(channels, "--channels")
    if not name.strip() or not all(c.isalnum() or c in "-_." for c in name):
        fail(f"--name {name!r}: letters, digits, '-', '_' and '.' only (it names the files)")
    check_number(f1, "--f1", 0.0, None, lo_open=True, unit="Hz")
    cmap = _checked("--channels", lambda: ChannelMap.from_toml(channels))
    units = units or {}
    for key, u in units.items():
        if key not in cmap.channels:
            fail(f"--unit {key}={u}: {key!r} is not a channel of --channels {channels} (its "
                 f"channels: {', '.join(map(repr, cmap.channels))})")
        why = acceleration_unit(u)
        if why is not None:
            fail(f"--unit {key}={u}: {why}")
    cmap = cmap.with_units(units)
    outputs = None
    if cmap.ids is not None:
        if structure is None and modal_toml is None:
            fail(f"--channels {channels}: 'ids' name grid IDs of your structure; give "
                 "--structure (or --modal-toml), or 'positions' (m) on the built-in cantilever")
        if structure is not None:  # the map's stations are the structure's output grids
            outputs = ",".join(str(i) for i in cmap.ids)
    elif structure is not None:
        fail(f"--channels {channels}: on --structure the stations are grid IDs: give 'ids', "
             "not 'positions'")
    st = StructureOptions.from_options(structure, tank, outputs, direction, mode_table, modes,
                                 mass_unit)
    setup = setup_structure(tank_toml, modal_toml, 0, st, fill)
    if any(setup.own):
        fail("--tank GRID:MODEL: a measured test has no sloshing model; give GRID[:fill=F]")
    modal = _checked("--channels", lambda: station_model(setup.modal, cmap, setup.beam))
    _checked("--channels", lambda: cmap.tank_channel(modal))
    return cmap, setup, modal, f1 if f1 is not None else setup.f1


def _read(fn: Callable[[], _T], cli: dict[str, str], channels: Path) -> _T:
    """``fn()`` (a reader of the test's files); a unit missing or contradicting the file is a
    user error naming --unit (``cli``: its units) and the map's [units]."""
    try:
        return fn()
    except MissingUnitError as e:
        fail(f"{e.path}: channel {e.channel!r} has no unit in the file ({e.detail}); give it "
             f"with --unit {shlex.quote(e.channel + '=g')} (or m/s^2), or in the channel map's "
             "[units] table")
    except UnitConflictError as e:
        who = (f"--unit {e.channel}={e.given}" if e.channel in cli
               else f"the [units] table of --channels {channels} ({e.channel} = {e.given!r})")
        fail(f"{e.path}: channel {e.channel!r} is in {e.in_file!r} in the file but {who} "
             f"says {e.given!r}; a unit given is for a channel whose file has none: drop it")
    except SloshromError as exc:
        fail(str(exc))


def _f1_from(f1: float | None, structure: Path | None, modal_toml: Path | None) -> str:
    """Where the analyses' f1 comes from (an attribute of the result file)."""
    if f1 is not None:
        return "--f1"
    of = _structure_given(structure, modal_toml) or "the built-in cantilever model"
    return f"first mode with frozen liquid of {of}"


def _structure_given(structure: Path | None, modal_toml: Path | None) -> str | None:
    if structure is not None:
        return f"--structure {structure.name}"
    return f"--modal-toml {modal_toml.name}" if modal_toml is not None else None


def _tank_given(tank_toml: Path | None, fill: float | None) -> str | None:
    given = [f"--tank-toml {tank_toml.name}" if tank_toml is not None else "",
             f"--fill {fill:g}" if fill is not None else ""]
    return " ".join(g for g in given if g) or None


def _band(f1: float, fs: float) -> None:
    _checked("", lambda: check_analysis_band(f1, fs=fs))


@analyse_app.command("free")
def free(
    files: _FilesArg,
    channels: _ChannelsOpt,
    out: _OutOpt,
    name: _NameOpt = "measured",
    f1: _F1Opt = None,
    tank_toml: TankOpt = None,
    fill: FillOpt = None,
    modal_toml: ModalOpt = None,
    structure: StructureOpt = None,
    tank: TankSpecOpt = None,
    direction: DirectionOpt = "+Z",
    mode_table: ModeTableOpt = None,
    modes: ModesOpt = None,
    mass_unit: MassUnitOpt = None,
    unit: _UnitOpt = None,
) -> None:
    """A measured free decay (one file): modal filtering, first-mode damping by amplitude band.

    The channel map (``--channels``) says which channel is which accelerometer; the stations'
    mode shapes come from the built-in cantilever (``positions``), ``--modal-toml`` or
    ``--structure`` (``ids``). The record needs at least 18 periods of mode 1 and must decay.
    Writes ``free_NAME.nc``, ``damping_bands.csv/.md`` and the figures of ``sloshrom beam
    free`` (without Fig. 20: a measured test has no forces), all together or none.

    One map may serve a whole campaign: a base channel the file lacks is at rest, stations it
    lacks are left out of the modal filter (a note says so; the tank channel and as many
    stations as the structure has modes must remain). ``--unit CHANNEL=UNIT`` (or the map's
    ``\\[units]`` table) gives the unit of a channel whose file has none.

    Example: ``sloshrom analyse free decay.uff --channels channels.toml --out lab``
    """
    from sloshrom.beam.channels import station_model
    from sloshrom.beam.measured import check_free_decay, read_free_test
    from sloshrom.beam.results import (
        damping_band_table,
        mode1_decay,
        to_dataset,
        write_dataset,
        write_table,
    )
    from sloshrom.plotting.beam import FREE_FIGURES, free_figures

    units = key_value_pairs(unit, "--unit", "CHANNEL=UNIT")
    cmap, setup, modal, f1v = _prepare(files, channels, out, name, tank_toml, fill, modal_toml,
                                       structure, tank, direction, mode_table, modes,
                                       mass_unit, f1, units)
    figures = [f for f in FREE_FIGURES if f != "fig20_tank_interface_dynamic"]
    check_outputs(out, [f"free_{name}.nc", "damping_bands.csv", "damping_bands.md",
                         *(f"{f}.png" for f in figures)],
                   (*files, channels, tank_toml, modal_toml, structure, mode_table))

    def work(step: _Steps) -> tuple:
        nonlocal modal
        step(f"reading {files[0].name}")
        res = _read(lambda: read_free_test(files, cmap, modal), units, channels)
        if res["channel_map"].stations != cmap.stations:  # the file lacks stations
            modal = _checked("--channels", lambda: station_model(
                setup.modal, res["channel_map"], setup.beam))
        _band(f1v, res["fs"])
        n = res["time"].size
        if n < FREE_DAMPING_PERIODS * res["fs"] / f1v:
            fail(f"{files[0]}: {n / res['fs']:g} s is too short for the damping analysis of "
                 f"mode 1 ({f1v:.4g} Hz): need {FREE_DAMPING_PERIODS} periods, "
                 f"{FREE_DAMPING_PERIODS / f1v:.3g} s")
        step("damping analysis of mode 1")
        _checked(f"{files[0]}", lambda: check_free_decay(res, f1v))
        decay = _checked("damping analysis of mode 1", lambda: mode1_decay(res, modal, f1v))
        return res, decay

    res, decay = _run("analyse free", work)
    bands = damping_band_table({name: res}, {name: decay}, f1v)
    figs = free_figures({name: res}, modal, {name: decay})
    with OutputBatch() as batch:  # all result files or none
        ds = to_dataset(res, name, "free", setup.tank, modal, f1=f1v,
                        f1_from=_f1_from(f1, structure, modal_toml),
                        structure_given=_structure_given(structure, modal_toml),
                        tank_given=_tank_given(tank_toml, fill))
        write_dataset(ds, out / f"free_{name}.nc", batch)
        write_table(bands, out / "damping_bands", batch)
        for stem, fig in figs.items():
            savefig(fig, out / f"{stem}.png", batch)
    echo_missing(bands, "damping bands")
    typer.echo(f"wrote free_{name}.nc, the damping bands and figures to {out}")


def _levels(text: str | None) -> list[float] | None:
    if text is None:
        return None
    try:
        lv = [float(x) for x in text.split(",") if x.strip()]
    except ValueError:
        fail(f"--levels must be comma-separated numbers in g, got {text!r}")
    if not lv or any(not (0 < x < 100) for x in lv):
        fail(f"--levels must be RMS values in (0, 100) g, got {text!r}")
    return lv


@analyse_app.command("random")
def random(
    files: _FilesArg,
    channels: _ChannelsOpt,
    out: _OutOpt,
    levels: Annotated[str | None, typer.Option(
        help="Nominal RMS base accelerations, g, one per file, comma separated; default: each "
             "file's measured base RMS, to two significant digits.")] = None,
    name: _NameOpt = "measured",
    f1: _F1Opt = None,
    accuracy: Annotated[float | None, typer.Option(
        help="Relative 1-sigma target on the damping ratio, e.g. 0.1: a warning for a record "
             "too short to reach it.")] = None,
    estimator: Annotated[list[str] | None, typer.Option(
        "--estimator",
        help="A damping estimator of the registry (sloshrom.beam.registry), repeatable, e.g. "
             "--estimator lscf_output --estimator ssi_cov; default the three of paper Table "
             "2.")] = None,
    tank_toml: TankOpt = None,
    fill: FillOpt = None,
    modal_toml: ModalOpt = None,
    structure: StructureOpt = None,
    tank: TankSpecOpt = None,
    direction: DirectionOpt = "+Z",
    mode_table: ModeTableOpt = None,
    modes: ModesOpt = None,
    mass_unit: MassUnitOpt = None,
    unit: _UnitOpt = None,
) -> None:
    """A measured random base-excitation test (one file per level): Table 2 and its figures.

    The channel map needs the ``base`` channel (the shaker table). Each level needs one
    16384-sample Welch segment (32.8 s at 500 Hz); files of different lengths are cut to the
    shortest (with a warning), files at different sample rates refused, and a base that is
    not random (constant, or its power in a few spectral lines: a sine) refused. Stations a
    file lacks are left out (a note says so); the base and the tank channel are required.
    ``--unit CHANNEL=UNIT`` as for ``analyse free``. Writes
    ``random_NAME.nc``, ``table2_mode1_damping.csv/.md`` and the figures of ``sloshrom beam
    random``, all together or none.

    ``--estimator`` picks the damping estimators by their registered names (default the three
    of Table 2; e.g. ``ssi_cov`` adds the columns ``ssi_cov``, ``ssi_cov_std``, ``ssi_cov_low``,
    ``ssi_cov_high``, ``frequency_ssi_cov``, ``ssi_cov_uncorrected``).

    Example: ``sloshrom analyse random r01.uff r02.uff r04.uff --channels channels.toml
    --levels 0.1,0.2,0.4 --out lab``
    """
    from sloshrom.beam.channels import station_model
    from sloshrom.beam.measured import check_random_base, read_random_test
    from sloshrom.beam.registry import estimator_names
    from sloshrom.beam.results import to_dataset, write_dataset, write_table
    from sloshrom.beam.uncertainty import ShortRecordWarning, random_damping
    from sloshrom.plotting.beam import RANDOM_FIGURES, random_figures, random_window

    try:
        names = estimator_names(estimator or None)
    except SloshromError as e:
        fail(f"--estimator: {e}")
    lv = _levels(levels)
    if lv is not None and len(lv) != len(files):
        fail(f"--levels gives {len(lv)} level(s) for {len(files)} file(s): one per file")
    check_number(accuracy, "--accuracy", 0.0, 1.0, lo_open=True,
                 why="a relative 1-sigma target on the damping ratio")
    units = key_value_pairs(unit, "--unit", "CHANNEL=UNIT")
    cmap, setup, modal, f1v = _prepare(files, channels, out, name, tank_toml, fill, modal_toml,
                                       structure, tank, direction, mode_table, modes,
                                       mass_unit, f1, units)
    if cmap.base is None:
        fail(f"--channels {channels}: a random test needs the 'base' channel (the shaker "
             "table acceleration)")
    check_outputs(out, [f"random_{name}.nc", "table2_mode1_damping.csv",
                         "table2_mode1_damping.md", *(f"{f}.png" for f in RANDOM_FIGURES)],
                   (*files, channels, tank_toml, modal_toml, structure, mode_table))

    def work(step: _Steps) -> tuple:
        nonlocal modal
        step(f"reading {len(files)} file(s)")
        res = _read(lambda: read_random_test(files, cmap, modal, levels=lv), units, channels)
        if res["channel_map"].stations != cmap.stations:  # a file lacks stations
            modal = _checked("--channels", lambda: station_model(
                setup.modal, res["channel_map"], setup.beam))
        _band(f1v, res["fs"])
        n = res["time"].size
        if n < WELCH_NPERSEG:
            fail(f"the records hold {n} samples: Table 2 needs at least {WELCH_NPERSEG} per "
                 f"level (one Welch segment, {WELCH_NPERSEG / res['fs']:g} s at "
                 f"{res['fs']:g} Hz)")
        for p, b, g in zip(files, res["base_acceleration"], res["rms_levels_g"], strict=True):
            _checked(str(p), lambda b=b, g=g: check_random_base(b, res["fs"], f"({g:g} g)"))
        # Table 2's rows (results.mode1_damping_table), with the record-length check
        rows = []
        for i, g in enumerate(res["rms_levels_g"]):
            step(f"damping analysis of mode 1 (Table 2), {g:g} g")
            with warnings.catch_warnings(record=True) as caught:
                warnings.simplefilter("always", ShortRecordWarning)
                d = _checked("damping analysis of mode 1", lambda i=i: random_damping(
                    res["base_acceleration"][i], res["tank_acceleration"][i], res["fs"], f1v,
                    accuracy=accuracy, estimators=names))
            for w in caught:  # say which level each warning is about
                warnings.warn_explicit(f"{g:g} g RMS: {w.message}", w.category, w.filename,
                                       w.lineno)
            rows.append({"case": name, "rms_g": float(g), **d})
        return res, rows

    res, rows = _run("analyse random", work)
    duration = res["time"].size / res["fs"]
    levels_g = [float(x) for x in res["rms_levels_g"]]
    figs = random_figures({name: res}, levels_g, random_window(duration))
    with OutputBatch() as batch:  # all result files or none
        ds = to_dataset(res, name, "random", setup.tank, modal, f1=f1v,
                        f1_from=_f1_from(f1, structure, modal_toml),
                        structure_given=_structure_given(structure, modal_toml),
                        tank_given=_tank_given(tank_toml, fill))
        write_dataset(ds, out / f"random_{name}.nc", batch)
        write_table(rows, out / "table2_mode1_damping", batch)
        for stem, fig in figs.items():
            savefig(fig, out / f"{stem}.png", batch)
    echo_missing(rows, "Table 2")
    typer.echo(f"wrote random_{name}.nc, Table 2 and figures to {out}")
