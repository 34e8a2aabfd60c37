"""``sloshrom analyse``: a laboratory's measured beam tests through the analyses of ``sloshrom
beam``, at every mode the data show.

``analyse free`` (a free decay) and ``analyse random`` (random base excitation, one file per
level) read UFF 58, CSV, NetCDF or MATLAB files with a channel map
(:mod:`sloshrom.beam.lab.measured`), find the modes in the data
(:mod:`sloshrom.beam.lab.every_mode`), optionally take the stations' mode shapes from a structure
(the built-in cantilever, ``--modal-toml`` or ``--structure`` as in ``sloshrom beam``) and write the
NetCDF result, the damping tables and the figures, all together or none. ``analyse campaign`` runs
every test of a folder (:mod:`sloshrom.beam.lab.campaign`) and writes one report page; ``analyse
example`` writes a campaign to try it on.
"""

from __future__ import annotations

import io
import math
import shlex
import warnings
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any, NoReturn, TypeVar, cast

import typer

from sloshrom.beam.damping.limits import FREE_DAMPING_PERIODS, WELCH_SEGMENT
from sloshrom.cli._app import (
    OverwriteOpt,
    app,
    check_input,
    check_number,
    check_out,
    fail,
    key_value_pairs,
)
from sloshrom.cli.beam import (
    DirectionOpt,
    FillOpt,
    MassUnitOpt,
    ModalOpt,
    ModeTableOpt,
    StructureOpt,
    StructureOptions,
    TankOpt,
    TankSpecOpt,
    check_outputs,
    echo_missing,
    refuse_empty,
    setup_structure,
)
from sloshrom.cli.progress import Bars, progress_bars
from sloshrom.errors import SloshromError
from sloshrom.fileio import OutputBatch
from sloshrom.io.record import MissingUnitError, UnitConflictError
from sloshrom.plotting import savefig

if TYPE_CHECKING:  # the heavy modules load when a command runs
    import xarray as xr
    from matplotlib.figure import Figure

    from sloshrom.beam.lab.campaign import CampaignTest
    from sloshrom.beam.lab.channels import ChannelMap
    from sloshrom.beam.lab.every_mode import TestModes
    from sloshrom.beam.lab.measured import MeasuredTest
    from sloshrom.beam.lab.uff58 import ChannelIdentity
    from sloshrom.beam.simulation.members import Row
    from sloshrom.beam.simulation.structure import ModalModel
    from sloshrom.cli.beam import StructureSetup

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
    "--f1", help="Analyse this one mode, Hz (the band-pass centre); default: every mode found "
                 "in the data.")]
_FrequenciesOpt = Annotated[str | None, typer.Option(
    "--frequencies", help="The modes to analyse, Hz, comma separated (e.g. 10.3,64.1); "
                          "default: every mode found in the data (peaks of H1, or of the "
                          "decay's spectrum).", show_default=False)]
_BuiltinOpt = Annotated[bool, typer.Option(
    "--builtin-beam", help="The stations are on the built-in tip-tank cantilever (the map's "
                           "positions; --tank-toml/--fill its tank): its mode shapes filter "
                           "them. Implied by --tank-toml and --fill.")]
_AnalyseModesOpt = Annotated[int | None, typer.Option(
    "--modes", help="Analyse the lowest N modes found in the data (and, with --structure, keep "
                    "its first N modes).", show_default=False)]


class _Steps:
    """A spinner whose text names the step under way (reading, analysing, writing); in a log,
    the lines of the step start with ``label`` (``analyse free: ...``)."""

    def __init__(self, progress: Bars, label: str) -> None:
        self.progress, self.task = progress, progress.add_task("", total=None, stage=label)

    def __call__(self, text: str) -> None:
        self.progress.update(self.task, description=text)


def _run(label: str, work: Callable[[_Steps], Any]) -> Any:
    from rich.progress import SpinnerColumn, TextColumn, TimeElapsedColumn

    with progress_bars(SpinnerColumn(), TextColumn("{task.description}"), TimeElapsedColumn(),
                       transient=True) as progress:
        return work(_Steps(progress, label))


def _checked(what: str, fn: Callable[[], Any]) -> Any:
    """``fn()``; a ``SloshromError`` (bad file, map or data) is a user error naming ``what``."""
    try:
        return fn()
    except SloshromError as exc:
        fail(f"{what}: {exc}" if what else str(exc))


def _frequencies(f1: float | None, text: str | None) -> list[float] | None:
    """The modes the user names (``--f1``, ``--frequencies``), Hz; ``None``: find them."""
    if f1 is not None and text is not None:
        fail("--f1 and --frequencies both name the modes: use one")
    check_number(f1, "--f1", 0.0, None, lo_open=True, unit="Hz")
    if f1 is not None:
        return [f1]
    if text is None:
        return None
    try:
        fr = [float(x) for x in text.split(",") if x.strip()]
    except ValueError:
        fail(f"--frequencies must be comma-separated numbers of Hz, got {text!r}")
    if not fr or not all(math.isfinite(v) and v > 0 for v in fr):
        fail(f"--frequencies must be positive numbers of Hz, got {text!r}")
    if len(set(fr)) != len(fr):
        fail(f"--frequencies {text!r} names a mode twice")
    return fr


def _prepare(files: list[Path], channels: Path, out: Path, name: str, tank_toml: Path | None,
             fill: float | None, modal_toml: Path | None, structure: Path | None,
             tank: list[str] | None, direction: str, mode_table: Path | None,
             modes: int | None, mass_unit: str | None, builtin: bool,
             units: dict[str, str] | None = None) -> tuple:
    """Options, channel map and structure, checked before any file is read: (map, setup,
    station model). Without a structure option (``--builtin-beam``, ``--structure``,
    ``--modal-toml``, ``--tank-toml``, ``--fill``), the structure is known by its measured
    modes alone: setup and station model are ``None``."""
    from sloshrom.beam.lab.channels import ChannelMap, station_model

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
    check_number(modes, "--modes", 1, None)
    cmap = _checked("--channels", lambda: ChannelMap.from_toml(channels))
    cmap = _with_units(cmap, units or {}, channels)
    if not builtin and all(v is None for v in (tank_toml, fill, modal_toml, structure)):
        for given, opt in ((tank, "--tank"), (mode_table, "--mode-table"),
                           (mass_unit, "--mass-unit")):
            if given:
                fail(f"{opt} places things on a --structure; give --structure FILE")
        _checked("--channels", lambda: cmap.tank_channel(None))
        return cmap, None, None
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
    st = StructureOptions.from_options(structure, tank, outputs, direction, mode_table,
                                       modes if structure is not None else None, mass_unit)
    setup = setup_structure(tank_toml, modal_toml, 0, st, fill)
    if any(setup.own):
        fail("--tank GRID:MODEL: a measured test has no sloshing model; give GRID[:fill=F]")
    modal = _checked("--channels", lambda: station_model(setup.modal, cmap, setup.beam))
    _checked("--channels", lambda: cmap.tank_channel(modal))
    return cmap, setup, modal


def _with_units(cmap: ChannelMap, units: dict[str, str], channels: Path) -> ChannelMap:
    """The map with the --unit units (each a channel of the map, an acceleration unit)."""
    from sloshrom.beam.lab.channels import acceleration_unit

    for key, u in units.items():
        if key not in cmap.channels:
            fail(f"--unit {key}={u}: {key!r} is not a channel of --channels {channels} (its "
                 f"channels: {', '.join(map(repr, cmap.channels))})")
        why = acceleration_unit(u)
        if why is not None:
            fail(f"--unit {key}={u}: {why}")
    return cmap.with_units(units)


def _missing_units(e: MissingUnitError) -> NoReturn:
    """Every channel of a file without a unit in one error, with the options and the [units]
    table to paste (``UNIT`` to replace: a placeholder that no run accepts, so that a channel
    is never read in a unit nobody chose)."""
    from sloshrom.beam.lab.channels import ACCELERATION_UNITS

    if len(e.channels) == 1:
        fail(f"{e.path}: channel {e.channel!r} has no unit in the file ({e.detail}); give it "
             f"with --unit {shlex.quote(e.channel + '=g')} (or m/s^2), or in the channel map's "
             "[units] table")
    names = ", ".join(repr(c) for c in e.channels)
    fail(f"{e.path}: {len(e.channels)} channels have no unit in the file ({e.detail}): "
         f"{names}; give each its unit (UNIT: {', '.join(ACCELERATION_UNITS)}) with the "
         "options below, or in the channel map's [units] table below it",
         [" ".join(f"--unit {shlex.quote(c + '=UNIT')}" for c in e.channels), "[units]",
          *(f'{_toml_key(c)} = "UNIT"' for c in e.channels)])


def _toml_key(name: str) -> str:
    """A channel name as a TOML key (quoted unless bare)."""
    import tomli_w

    return tomli_w.dumps({name: 0}).split(" = ")[0]


def _read(fn: Callable[[], _T], cli: dict[str, str], channels: Path) -> _T:
    """``fn()`` (a reader of the test's files); a unit missing or contradicting the file is a
    user error naming --unit (``cli``: its units) and the map's [units]."""
    try:
        return fn()
    except MissingUnitError as e:
        _missing_units(e)
    except UnitConflictError as e:
        who = (f"--unit {e.channel}={e.given}" if e.channel in cli
               else f"the [units] table of --channels {channels} ({e.channel} = {e.given!r})")
        fail(f"{e.path}: channel {e.channel!r} is in {e.in_file!r} in the file but {who} "
             f"says {e.given!r}; a unit given is for a channel whose file has none: drop it")
    except SloshromError as exc:
        fail(str(exc))


@dataclass(frozen=True)
class _Given:
    """What the user gave for the structure and the tank (result-file attributes)."""

    structure: str | None = None
    tank: str | None = None

    @classmethod
    def of(cls, structure: Path | None, modal_toml: Path | None, tank_toml: Path | None,
           fill: float | None) -> _Given:
        st = (f"--structure {structure.name}" if structure is not None else
              f"--modal-toml {modal_toml.name}" if modal_toml is not None else None)
        tk = [f"--tank-toml {tank_toml.name}" if tank_toml is not None else "",
              f"--fill {fill:g}" if fill is not None else ""]
        return cls(st, " ".join(t for t in tk if t) or None)


def _modes(res: MeasuredTest, kind: str, ctx: _Setting, modal: ModalModel | None
           ) -> TestModes:
    """The modes to analyse (given or found), each inside the record's band, numbered as the
    structure (``modal``) has them, or a user error."""
    from sloshrom.beam.lab.every_mode import describe, modes_of_test, number_modes

    found = _checked("modes", lambda: modes_of_test(res, kind, frequencies=ctx.frequencies,
                                                 max_modes=ctx.modes))
    if modal is not None:
        found = number_modes([found], modal)[0]
    typer.echo(describe(found))
    return found


@analyse_app.command("free")
def free(
    files: _FilesArg,
    channels: _ChannelsOpt,
    out: _OutOpt,
    name: _NameOpt = "measured",
    f1: _F1Opt = None,
    frequencies: _FrequenciesOpt = None,
    modes: _AnalyseModesOpt = None,
    builtin_beam: _BuiltinOpt = False,
    tank_toml: TankOpt = None,
    fill: FillOpt = None,
    modal_toml: ModalOpt = None,
    structure: StructureOpt = None,
    tank: TankSpecOpt = None,
    direction: DirectionOpt = "+Z",
    mode_table: ModeTableOpt = None,
    mass_unit: MassUnitOpt = None,
    unit: _UnitOpt = None,
) -> None:
    """A measured free decay (one file): the damping of every mode by amplitude band.

    The modes are the peaks of the tank channel's spectrum (``--f1``, ``--frequencies`` or
    ``--modes`` choose). The channel map (``--channels``) says which channel is which
    accelerometer; the reference (tank) channel is ``tank`` or the outermost station. Without
    a structure option each mode is band-passed out of the reference channel; with
    ``--structure``, ``--modal-toml`` or ``--tank-toml`` its mode shapes filter the stations
    (modal filtering). The record needs 18 periods of each mode and must decay. Writes
    ``free_NAME.nc``, ``damping_bands.csv/.md`` (a row per mode, band and method) and the
    figures, all together or none.

    Example: ``sloshrom analyse free decay.uff --channels channels.toml --out lab``
    """
    ctx = _setting(files, channels, out, name, f1, frequencies, unit, tank_toml, fill,
                   modal_toml, structure, tank, direction, mode_table, modes, mass_unit,
                   builtin_beam)
    check_outputs(out, _free_outputs(name, ctx.modal),
                  (*files, channels, tank_toml, modal_toml, structure, mode_table))
    test = _run("analyse free", lambda step: _free_test(files, ctx, name, step))
    with OutputBatch() as batch:  # all result files or none
        test.write(out, batch)
    echo_missing(test.damping, "damping bands")
    typer.echo(f"wrote free_{name}.nc, the damping bands and figures to {out}")


@dataclass(frozen=True)
class _Setting:
    """What every test of a command is read and analysed with."""

    cmap: ChannelMap  # with the --unit units
    setup: StructureSetup | None  # the structure (None: known by its measured modes alone)
    modal: ModalModel | None  # its modal model at the map's stations
    channels: Path  # the map's file (messages)
    units: dict[str, str]  # the --unit units (messages)
    given: _Given
    frequencies: list[float] | None  # the modes named by the user, Hz
    modes: int | None  # --modes
    # the UFF channels the map's names found in every file read so far (a campaign's tests
    # too): a map by node numbers must find the same accelerometers in all of them
    identities: list[ChannelIdentity] = field(default_factory=list)

    def check_identity(self, res: MeasuredTest) -> None:
        """Add the test's files to :attr:`identities`; a user error if the map's node numbers
        find other channels in them than in the files before."""
        from sloshrom.beam.lab.uff58 import check_channel_identity

        self.identities.extend(res.get("channel_identity", []))
        _checked(f"--channels {self.channels}",
                 lambda: check_channel_identity(self.identities))


def _setting(files: list[Path], channels: Path, out: Path, name: str, f1: float | None,
             frequencies: str | None, unit: list[str] | None, tank_toml: Path | None,
             fill: float | None, modal_toml: Path | None, structure: Path | None,
             tank: list[str] | None, direction: str, mode_table: Path | None,
             modes: int | None, mass_unit: str | None, builtin: bool) -> _Setting:
    """The options of ``analyse free``/``random`` checked, as the setting of their test."""
    freqs = _frequencies(f1, frequencies)
    units = key_value_pairs(unit, "--unit", "CHANNEL=UNIT")
    cmap, setup, modal = _prepare(files, channels, out, name, tank_toml, fill, modal_toml,
                                  structure, tank, direction, mode_table, modes, mass_unit,
                                  builtin, units)
    return _Setting(cmap, setup, modal, channels, units,
                    _Given.of(structure, modal_toml, tank_toml, fill), freqs, modes)


@dataclass
class _Test:
    """One analysed test: its result dataset, its damping (a free decay's band rows, a random
    test's Table 2 over ``(mode, level, estimator)``) and figures."""

    kind: str
    name: str
    ds: xr.Dataset
    damping: list[Row] | xr.Dataset
    figs: dict[str, Figure]
    modes: TestModes

    @property
    def table(self) -> str:
        return "damping_bands" if self.kind == "free" else "table2_damping"

    def rows(self) -> list[Row]:
        """The damping as its file's rows (a random test's: the one place that makes them,
        ``sloshrom.beam.damping.columns.table2_rows``)."""
        from sloshrom.beam.damping.columns import table2_rows

        return table2_rows(self.damping) if not isinstance(self.damping, list) else self.damping

    def write(self, out: Path, batch: OutputBatch) -> None:
        from sloshrom.beam.results import write_dataset, write_table

        write_dataset(self.ds, out / f"{self.kind}_{self.name}.nc", batch)
        write_table(self.rows(), out / self.table, batch)
        for stem, fig in self.figs.items():
            savefig(fig, out / f"{stem}.png", batch)


def _free_figures(modal: ModalModel | None) -> list[str]:
    from sloshrom.plotting.beam import FREE_FIGURES

    return [f for f in FREE_FIGURES if f != "fig20_tank_interface_dynamic"
            and (modal is not None or f != "fig16_modal_accelerations")] + ["damping_by_mode"]


def _free_outputs(name: str, modal: ModalModel | None) -> list[str]:
    return [f"free_{name}.nc", "damping_bands.csv", "damping_bands.md",
            *(f"{f}.png" for f in _free_figures(modal))]


def _random_outputs(name: str) -> list[str]:
    from sloshrom.plotting.beam import RANDOM_FIGURES

    return [f"random_{name}.nc", "table2_damping.csv", "table2_damping.md",
            "damping_by_mode.png", *(f"{f}.png" for f in RANDOM_FIGURES)]


def _station_model(ctx: _Setting, res: MeasuredTest) -> ModalModel | None:
    """The modal model at the stations the files hold (a campaign's map may name more)."""
    from sloshrom.beam.lab.channels import station_model

    setup = ctx.setup
    if setup is None or res["channel_map"].stations == ctx.cmap.stations:
        return ctx.modal
    return _checked("--channels", lambda: station_model(setup.modal, res["channel_map"],
                                                        setup.beam))


def _dataset(ctx: _Setting, res: MeasuredTest, name: str, kind: str, found: TestModes,
             modal: ModalModel | None) -> xr.Dataset:
    from sloshrom.beam.results import to_dataset

    f1_from = ("--f1" if found.how == "given" and len(found.modes) == 1
               else "--frequencies" if found.how == "given" else "the data (spectral peak)")
    ds = to_dataset(res, name, kind, ctx.setup.tank if ctx.setup else None, modal,
                    f1=found.frequencies[0], f1_from=f1_from,
                    structure_given=ctx.given.structure, tank_given=ctx.given.tank)
    ds.attrs["mode_frequencies_Hz"] = found.frequencies
    ds.attrs["modes_from"] = found.how
    return ds


def _check_stations(ctx: _Setting, res: MeasuredTest, found: TestModes,
                    modal: ModalModel | None) -> None:
    """The map's station order against the data at mode 1 (``lab.check_station_order``), then
    every station's amplitude against the others' at each mode
    (``lab.check_station_amplitudes``: a channel read in another unit)."""
    from sloshrom.beam.lab.every_mode import (
        DECAY_REL_BAND,
        check_station_amplitudes,
        check_station_order,
    )

    _checked(f"--channels {ctx.channels}", lambda: check_station_order(
        res, found.frequencies[0], found.rel_band(0, DECAY_REL_BAND), modal))
    _checked(", ".join(res["source"]), lambda: check_station_amplitudes(res, found, modal))


@dataclass
class _Read:
    """A test read and its modes found, before its analysis (a campaign numbers the modes of
    all its tests first)."""

    kind: str
    files: list[Path]
    name: str
    res: MeasuredTest
    modal: ModalModel | None
    found: TestModes


def _read_free(files: list[Path], ctx: _Setting, name: str, step: _Steps) -> _Read:
    """Read a free decay and find its modes (user errors end the command)."""
    from sloshrom.beam.lab.measured import read_free_test

    step(f"reading {files[0].name}")
    res = _read(lambda: read_free_test(files, ctx.cmap, ctx.modal), ctx.units, ctx.channels)
    ctx.check_identity(res)
    modal = _station_model(ctx, res)
    return _Read("free", files, name, res, modal, _modes(res, "free", ctx, modal))


def _free_test(files: list[Path], ctx: _Setting, name: str, step: _Steps) -> _Test:
    """Read and analyse a free decay at every mode (user errors end the command)."""
    return _analyse_free(_read_free(files, ctx, name, step), ctx, step)


def _analyse_free(r: _Read, ctx: _Setting, step: _Steps) -> _Test:
    """Analyse a free decay read by :func:`_read_free` at every mode."""
    from sloshrom.beam.lab.every_mode import free_mode_decays, free_mode_rows
    from sloshrom.beam.lab.measured import check_free_decay
    from sloshrom.plotting.beam import free_figures, mode_decay_figure

    files, name, res, modal, found = r.files, r.name, r.res, r.modal, r.found
    _check_stations(ctx, res, found, modal)
    n = res["time"].size
    for k, f in enumerate(found.frequencies):
        if n < FREE_DAMPING_PERIODS * res["fs"] / f:
            fail(f"{files[0]}: {n / res['fs']:g} s is too short for the damping analysis "
                 f"of mode {found.number(k)} ({f:.4g} Hz): need {FREE_DAMPING_PERIODS} "
                 f"periods, {FREE_DAMPING_PERIODS / f:.3g} s")
    for k, f in enumerate(found.frequencies):
        _checked(f"{files[0]}", lambda k=k, f=f: check_free_decay(
            res, f, rel_band=found.rel_band(k, 0.5), mode=found.number(k)))
    step(f"{name}: damping analysis of every mode")
    decays = _checked("damping analysis", lambda: free_mode_decays(res, found, modal))
    rows = free_mode_rows(res, name, found, decays)
    refuse_empty(rows, f"{files[0]}: damping bands")
    figs = free_figures({name: res}, modal, {name: decays[0].decay},
                        labels=None if modal is not None else res["channel_map"].stations)
    figs["damping_by_mode"] = mode_decay_figure(name, found.frequencies,
                                                [d.decay for d in decays])
    figs = {k: figs[k] for k in _free_figures(modal)}
    return _Test("free", name, _dataset(ctx, res, name, "free", found, modal), rows, figs,
                 found)


def _levels(text: str | None) -> list[float] | None:
    if text is None:
        return None
    try:
        lv = [float(x) for x in text.split(",") if x.strip()]
    except ValueError:
        fail(f"--levels must be comma-separated numbers in g, got {text!r}")
    if not lv or any(not (0 < x < 100) for x in lv):
        fail(f"--levels must be RMS values in (0, 100) g, got {text!r}")
    if len(set(lv)) != len(lv):
        fail(f"--levels {text!r} names a level twice: one level per file, each file's own")
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
    frequencies: _FrequenciesOpt = None,
    modes: _AnalyseModesOpt = None,
    builtin_beam: _BuiltinOpt = False,
    accuracy: Annotated[float | None, typer.Option(
        help="Relative 1-sigma target on the damping ratio, e.g. 0.1: a warning for a record "
             "too short to reach it.")] = None,
    estimator: Annotated[list[str] | None, typer.Option(
        "--estimator",
        help="A damping estimator of the registry (sloshrom.beam.damping.registry), repeatable, "
             "e.g. --estimator lscf_output --estimator ssi_cov; default the three of paper Table "
             "2.")] = None,
    tank_toml: TankOpt = None,
    fill: FillOpt = None,
    modal_toml: ModalOpt = None,
    structure: StructureOpt = None,
    tank: TankSpecOpt = None,
    direction: DirectionOpt = "+Z",
    mode_table: ModeTableOpt = None,
    mass_unit: MassUnitOpt = None,
    unit: _UnitOpt = None,
) -> None:
    """A measured random base-excitation test (one file per level): Table 2 at every mode.

    The modes are the peaks of H1 (base -> tank) that the levels share (``--f1``,
    ``--frequencies`` or ``--modes`` choose); each is analysed in its band between its
    neighbours. The channel map needs the ``base`` channel (the shaker table). Each level
    needs one 16384-sample Welch segment (32.8 s at 500 Hz); files of different lengths are
    cut to the shortest (with a warning), files at different sample rates refused, and a base
    that is not random (constant, or its power in a few spectral lines: a sine) refused.
    Writes ``random_NAME.nc``, ``table2_damping.csv/.md`` (a row per mode and level) and the
    figures, all together or none.

    ``--estimator`` picks the damping estimators by their registered names (default the three
    of Table 2; e.g. ``ssi_cov`` adds the columns ``ssi_cov``, ``ssi_cov_std``, ``ssi_cov_low``,
    ``ssi_cov_high``, ``frequency_ssi_cov``, ``ssi_cov_uncorrected``).

    Example: ``sloshrom analyse random r01.uff r02.uff r04.uff --channels channels.toml
    --levels 0.1,0.2,0.4 --out lab``
    """
    from sloshrom.beam.damping.registry import estimator_names

    try:
        names = estimator_names(estimator or None)
    except SloshromError as e:
        fail(f"--estimator: {e}")
    lv = _levels(levels)
    if lv is not None and len(lv) != len(files):
        fail(f"--levels gives {len(lv)} level(s) for {len(files)} file(s): one per file")
    check_number(accuracy, "--accuracy", 0.0, 1.0, lo_open=True,
                 why="a relative 1-sigma target on the damping ratio")
    ctx = _setting(files, channels, out, name, f1, frequencies, unit, tank_toml, fill,
                   modal_toml, structure, tank, direction, mode_table, modes, mass_unit,
                   builtin_beam)
    if ctx.cmap.base is None:
        fail(f"--channels {channels}: a random test needs the 'base' channel (the shaker "
             "table acceleration)")
    check_outputs(out, _random_outputs(name),
                  (*files, channels, tank_toml, modal_toml, structure, mode_table))
    test = _run("analyse random", lambda step: _random_test(
        files, ctx, name, lv, names, accuracy, step))
    with OutputBatch() as batch:  # all result files or none
        test.write(out, batch)
    echo_missing(test.damping, "Table 2")
    typer.echo(f"wrote random_{name}.nc, Table 2 at every mode and figures to {out}")


def _random_test(files: list[Path], ctx: _Setting, name: str, lv: list[float] | None,
                 names: Sequence[str], accuracy: float | None, step: _Steps,
                 levels_from: str = "--levels") -> _Test:
    """Read and analyse a random test (one file per level) at every mode (``levels_from``:
    where ``lv`` came from, for messages)."""
    return _analyse_random(_read_random(files, ctx, name, lv, step, levels_from), ctx, names,
                           accuracy, step)


def _read_random(files: list[Path], ctx: _Setting, name: str, lv: list[float] | None,
                 step: _Steps, levels_from: str = "--levels") -> _Read:
    """Read a random test (one file per level), check it and find its modes."""
    from sloshrom.beam.lab.measured import check_levels, check_random_base, read_random_test

    step(f"reading {len(files)} file(s)")
    res = _read(lambda: read_random_test(files, ctx.cmap, ctx.modal, levels=lv), ctx.units,
                ctx.channels)
    ctx.check_identity(res)
    modal = _station_model(ctx, res)
    n = res["time"].size
    if n < WELCH_SEGMENT:
        fail(f"the records hold {n} samples: Table 2 needs at least {WELCH_SEGMENT} per "
             f"level (one Welch segment, {WELCH_SEGMENT / res['fs']:g} s at "
             f"{res['fs']:g} Hz)")
    for p, b, g in zip(files, res["base_acceleration"], res["rms_levels_g"], strict=True):
        _checked(str(p), lambda b=b, g=g: check_random_base(b, res["fs"], f"({g:g} g)"))
    if lv is not None:  # nominal levels label Table 2 and match the predictions: theirs?
        _checked(levels_from, lambda: check_levels(res["base_acceleration"], lv,
                                                   [p.name for p in files]))
    return _Read("random", files, name, res, modal, _modes(res, "random", ctx, modal))


def _analyse_random(r: _Read, ctx: _Setting, names: Sequence[str], accuracy: float | None,
                    step: _Steps) -> _Test:
    """Analyse a random test read by :func:`_read_random`: Table 2 at every mode."""
    from sloshrom.beam.damping.uncertainty import ShortRecordWarning
    from sloshrom.beam.lab.every_mode import random_mode_dataset
    from sloshrom.plotting.beam import mode_damping_figure, random_figures, random_window

    files, name, res, modal, found = r.files, r.name, r.res, r.modal, r.found
    _check_stations(ctx, res, found, modal)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", ShortRecordWarning)
        damping = _checked("damping analysis", lambda: random_mode_dataset(
            res, name, found, estimators=names, accuracy=accuracy, step=step))
    for w in caught:  # once each, after the analyses
        warnings.warn_explicit(str(w.message), w.category, w.filename, w.lineno)
    refuse_empty(damping, f"{', '.join(p.name for p in files)}: Table 2", names)
    duration = res["time"].size / res["fs"]
    figs = random_figures({name: res}, [float(x) for x in res["rms_levels_g"]],
                          random_window(duration))
    figs["damping_by_mode"] = mode_damping_figure(damping)
    return _Test("random", name, _dataset(ctx, res, name, "random", found, modal), damping,
                 figs, found)


# -- a campaign folder (sloshrom.beam.lab.campaign) ---------------------------------------------
_DirArg = Annotated[Path, typer.Argument(
    help="The campaign folder: data files (UFF 58, CSV, NetCDF, MATLAB) and optionally "
         "campaign.toml (which file is which test).", show_default=False)]


def _cell(v: float | str | None, lo: float | str | None, hi: float | str | None,
          reason: object) -> str:
    """``value [low, high] %`` with the digits the interval needs, or ``— (reason)``."""
    from sloshrom.beam.damping.uncertainty import format_interval

    v, lo, hi = (_num(x) for x in (v, lo, hi))
    if not math.isfinite(v):
        return f"— ({reason or 'no estimate'})"
    if not (math.isfinite(lo) and math.isfinite(hi)):
        return f"{100 * v:.3g} % (no interval: {reason or 'no spread estimate'})"
    a, b, c = format_interval(100 * lo, 100 * hi, 100 * v)
    return f"{c} [{a}, {b}] %"


def _num(v: float | str | None) -> float:
    if v is None:
        return math.nan
    try:
        return float(v)
    except (TypeError, ValueError):
        return math.nan


def _random_table(test: _Test, estimators: Sequence[str]) -> tuple[list[str], list[list[str]]]:
    from sloshrom.beam.damping.registry import label

    t2 = cast("xr.Dataset", test.damping)  # a random test's Table 2
    head = ["mode", "f (Hz)", "RMS base (g)", *(f"{label(e)} (%)" for e in estimators)]
    rows = []
    for k, mode in enumerate(t2.mode.values):
        for i, level in enumerate(t2.level.values):
            d = t2.isel(mode=k, level=i)
            cells = [_cell(*(float(d[v].sel(estimator=e)) for v in ("value", "low", "high")),
                           reason=str(d["reason"].sel(estimator=e).values))
                     for e in estimators]
            rows.append([str(int(mode)), f"{float(t2.mode_frequency_Hz[k]):.4g}",
                         f"{float(level):g}", *cells])
    return head, rows


def _free_table(test: _Test) -> tuple[list[str], list[list[str]]]:
    from sloshrom.beam.damping.registry import label

    head = ["mode", "f (Hz)", "band", "method", "damping (%)"]
    rows = [[str(r["mode"]), f"{r['mode_frequency_Hz']:.4g}", str(r["band"]),
             label(str(r["method"])),
             _cell(r.get("zeta"), r.get("low"), r.get("high"), r.get("reason"))]
            for r in test.rows()]
    return head, rows


def _markdown(head: list[str], rows: list[list[str]]) -> str:
    from sloshrom.beam.results import markdown_cell

    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    lines += ["| " + " | ".join(markdown_cell(c) for c in r) + " |" for r in rows]
    return "\n".join(lines) + "\n"


def _png(fig: Figure) -> bytes:
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=110)
    return buf.getvalue()


def _report(directory: Path, tests: list[tuple[CampaignTest, _Test]],
            estimators: Sequence[str]
            ) -> tuple[str, str]:
    """The campaign page as Markdown (figures linked) and self-contained HTML."""
    from sloshrom.pipeline.html import Figure, Section, Table, render

    md = [f"# Campaign {directory.name}\n",
          f"{len(tests)} test(s) from `{directory}`; damping ratios in %, each with its 95 % "
          "interval, or — with the reason it has none.\n"]
    sections = []
    for spec, t in tests:
        files = ", ".join(p.name for p in spec.files)
        modes = ", ".join(f"{f:.4g}" for f in t.modes.frequencies)
        text = (f"{'Free decay' if t.kind == 'free' else 'Random base excitation'} "
                f"({files}, classified by {spec.how}); modes {t.modes.how}: {modes} Hz.")
        head, rows = (_free_table(t) if t.kind == "free" else _random_table(t, estimators))
        title = f"{t.name}: {'free decay' if t.kind == 'free' else 'random test'}"
        md += [f"## {title}\n", text + "\n", _markdown(head, rows),
               f"\n![damping by mode]({t.name}/damping_by_mode.png)\n"]
        figs = [Figure(Path(f"{t.name}/damping_by_mode.png"), "damping of every mode",
                       data=_png(t.figs["damping_by_mode"]))]
        sections.append(Section(title, f"<p>{text}</p>", figs, [Table(head, rows)]))
    page = render(f"Campaign {directory.name}", "<p>" + md[1].strip() + "</p>", sections)
    return "\n".join(md), page


@analyse_app.command("campaign")
def campaign(
    directory: _DirArg,
    channels: _ChannelsOpt,
    out: _OutOpt,
    frequencies: _FrequenciesOpt = None,
    modes: _AnalyseModesOpt = None,
    estimator: Annotated[list[str] | None, typer.Option(
        "--estimator", help="A damping estimator of the registry, repeatable; default the "
                            "three of paper Table 2.")] = None,
    unit: _UnitOpt = None,
) -> None:
    """A campaign folder in one command: every free decay and the random test, every mode.

    Which file is which test: ``campaign.toml`` in the folder (``[[test]]`` tables with
    ``file``/``files``, ``kind``, optional ``name`` and ``levels``; see docs/beam.md), else
    by content (a file with the map's random ``base`` is a level of the random test, any
    other a free decay). One channel map serves every test. Each test is written as
    ``analyse free``/``random`` write it, into ``OUT/<case>/``; ``OUT/campaign.md`` and
    ``OUT/campaign.html`` hold every mode, estimator and interval. All files or none.

    Example: ``sloshrom analyse campaign lab/ --channels lab/channels.toml --out results``
    """
    from sloshrom.beam.damping.registry import estimator_names
    from sloshrom.beam.lab.campaign import campaign_tests
    from sloshrom.beam.lab.channels import ChannelMap

    try:
        names = estimator_names(estimator or None)
    except SloshromError as e:
        fail(f"--estimator: {e}")
    if not directory.is_dir():
        fail(f"DIRECTORY {directory}: not a folder")
    check_input(channels, "--channels")
    check_number(modes, "--modes", 1, None)
    freqs = _frequencies(None, frequencies)
    units = key_value_pairs(unit, "--unit", "CHANNEL=UNIT")
    cmap = _with_units(_checked("--channels", lambda: ChannelMap.from_toml(channels)), units,
                       channels)
    _checked("--channels", lambda: cmap.tank_channel(None))
    specs = _read(lambda: campaign_tests(directory, cmap), units, channels)
    ctx = _Setting(cmap, None, None, channels, units, _Given(), freqs, modes)
    planned = ["campaign.md", "campaign.html"]
    for s in specs:
        if s.kind == "random" and cmap.base is None:
            fail(f"--channels {channels}: the random test ({', '.join(p.name for p in s.files)})"
                 " needs the 'base' channel")
        planned += [f"{s.name}/{f}" for f in (_free_outputs(s.name, None) if s.kind == "free"
                                              else _random_outputs(s.name))]
    check_outputs(out, planned, (channels, *(p for s in specs for p in s.files)))
    typer.echo(f"{directory}: " + "; ".join(
        f"{s.name} ({s.kind}: {', '.join(p.name for p in s.files)})" for s in specs))

    def work(step: _Steps) -> list[tuple[CampaignTest, _Test]]:
        from sloshrom.beam.lab.every_mode import number_modes

        read = []
        for s in specs:  # every test read, its modes found ...
            if s.kind == "free":
                read.append(_read_free(list(s.files), ctx, s.name, step))
            else:
                lv = list(s.levels) if s.levels is not None else None
                read.append(_read_random(list(s.files), ctx, s.name, lv, step,
                                         f"{directory / 'campaign.toml'}: test {s.name!r}: "
                                         "levels"))
        # ... then numbered as the campaign's structure has them: a decay that misses mode 2
        # calls the random test's mode 3 mode 3 too
        for r, m in zip(read, number_modes([r.found for r in read]), strict=True):
            r.found = m
        return [(s, _analyse_free(r, ctx, step) if r.kind == "free"
                 else _analyse_random(r, ctx, names, None, step))
                for s, r in zip(specs, read, strict=True)]

    tests = _run("analyse campaign", work)
    md, page = _report(directory, tests, names)
    with OutputBatch() as batch:  # all result files or none
        for _, t in tests:
            t.write(out / t.name, batch)
        batch.write_text(out / "campaign.md", md)
        batch.write_text(out / "campaign.html", page)
    for _, t in tests:
        echo_missing(t.damping, f"{t.name}")
    typer.echo(f"wrote {len(tests)} test(s) and campaign.md / campaign.html to {out}")


@analyse_app.command("example")
def example(
    directory: Annotated[Path, typer.Argument(help="Folder to write the campaign into.",
                                              show_default=False)],
    empty_units: Annotated[bool, typer.Option(
        "--empty-units", help="Leave the UFF unit labels empty (the units then come from "
                              "--unit or the map's [units]).")] = False,
    duration: Annotated[float, typer.Option(help="Length of each random run, s.")] = 120.0,
    seed: Annotated[int, typer.Option(help="Seed of the excitation and noise.")] = 0,
    overwrite: OverwriteOpt = False,
) -> None:
    """Write a laboratory's campaign to try `analyse` on: a three-mode cantilever without tank
    (10.3 / 64.1 / 180 Hz, damping 1.37 / 0.62 / 0.48 %), five accelerometers alternately in g
    and m/s^2, a free decay and random tests at 0.1 / 0.2 / 0.4 g, as UFF 58, and its channel
    map ``channels.toml``. A file of these names in DIRECTORY that this command did not write
    (a laboratory's real decay.uff or channels.toml) is refused, named, unless --overwrite.

    Example: ``sloshrom analyse example lab && sloshrom analyse campaign lab --channels
    lab/channels.toml --out results``
    """
    from sloshrom.beam.lab.virtual import station_units, write_lab_campaign

    check_number(duration, "--duration", 34.0, 3600.0, unit="s",
                 why=f"one {WELCH_SEGMENT}-sample Welch segment at 500 Hz and at most an hour")
    check_number(seed, "--seed", 0, 2**32 - 1)
    names = ["decay.uff", *(f"random_{g:g}g.uff" for g in (0.1, 0.2, 0.4)), "channels.toml"]
    owner = "sloshrom analyse example"  # it replaces only its own files (check_out's owner)
    check_outputs(directory, names, ())
    check_out(directory, directory=True, what="DIRECTORY", contents=tuple(names), owner=owner,
              overwrite=overwrite)
    with OutputBatch(owner=owner) as batch:
        cmap = write_lab_campaign(directory, duration=duration, unit_labels=not empty_units,
                                  seed=seed, batch=batch)
        if empty_units:  # the map carries the units the files leave out, as a laboratory's
            cmap = cmap.with_units({"base": "g", **dict(zip(
                cmap.stations, station_units(len(cmap.stations)), strict=True))})
        cmap.write_toml(directory / "channels.toml", batch)
    typer.echo(f"wrote {', '.join(names)} to {directory}")
    # what to run next, and what the files leave to the user
    units = ("the accelerometers' units are in the UFF files' labels" if not empty_units else
             "the UFF unit labels are empty: channels.toml's [units] table gives them ("
             + ", ".join(f"{k} {v}" for k, v in cmap.units.items())
             + "; --unit NAME=UNIT would win over it)")
    typer.echo(f"{units}; next: sloshrom analyse campaign {directory} --channels "
               f"{directory / 'channels.toml'} --out {directory / 'results'}")
