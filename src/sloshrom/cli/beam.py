"""``sloshrom beam``: sloshing-beam free and random responses, damping analysis, figures.

Every run simulates the frozen-liquid reference and each requested sloshing model (``rig`` = the
virtual rig, the "experiment"; or a ROM file written by ``sloshrom train``) on the same modal
beam, writes one NetCDF per case into ``--out`` and the figures/tables of the paper's Sect. 4-5.

This module parses and checks the options, builds the models and calls the library
(:mod:`sloshrom.beam.results`, :mod:`sloshrom.plotting.beam`); the library modules are imported
inside the commands, so that ``sloshrom --help`` does not load JAX, xarray and matplotlib.
"""

from __future__ import annotations

import re
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any

import typer

from sloshrom.beam.damping.limits import (
    FREE_DAMPING_PERIODS,
    MIN_RANDOM_DURATION,
    WELCH_SEGMENT,
    check_analysis_band,
    min_free_duration,
)
from sloshrom.beam.simulation.limits import (
    BEAM_FS,
    MAX_BEAM_SECONDS,
    MAX_LEVEL_SECONDS,
    check_psd_band,
)
from sloshrom.beam.simulation.structure import MAX_MODES
from sloshrom.cli._app import (
    app,
    check_input,
    check_number,
    check_out,
    check_sloshing_rom,
    fail,
)
from sloshrom.cli.progress import progress_bars
from sloshrom.config import ConfigError, Tank
from sloshrom.errors import SloshromError
from sloshrom.fileio import OutputBatch, not_a_regular_file
from sloshrom.limits import MAX_SEED
from sloshrom.models import FrozenLiquid, SloshingModel
from sloshrom.plotting import savefig

if TYPE_CHECKING:
    import xarray as xr
    from rich.progress import TaskID

    from sloshrom.beam.simulation.structure import CantileverBeam, ModalModel

beam_app = typer.Typer(
    help="Sloshing-beam simulations (free and random responses) and damping analysis.",
    no_args_is_help=True,
)
app.add_typer(beam_app, name="beam")

MAX_LEVEL_G = 2.0  # RMS; the rig's calibrated envelope is 6 g peak, about 3 x RMS


def _model(name: str, tank: Tank, seed: int,
           roms: dict[Path, SloshingModel]) -> SloshingModel:
    """The sloshing model of a ``--sloshing`` value at ``tank``'s fill; a user error if unusable.

    ``roms`` caches loaded ROM files (several tanks may share one; a fill family gives each
    tank the blend at its own fill)."""
    if name == "frozen":
        return FrozenLiquid(1.0 / BEAM_FS)
    if name == "rig":
        from sloshrom.rig.virtual import VirtualRig

        try:  # a tank the rig cannot model (an extreme fill) is refused here, before any run
            return VirtualRig(tank=tank, seed=seed)
        except SloshromError as exc:
            fail(f"--sloshing rig: {exc}")
    p = Path(name)
    why = not_a_regular_file(p) if name.strip() else None
    if why is not None:
        fail(f"--sloshing {p}: {why}")
    if not name.strip() or not p.is_file():
        fail(f"--sloshing must be 'frozen', 'rig' or a ROM model file; {p} does not exist")
    from sloshrom.rom.family import at_fill
    from sloshrom.rom.loading import load_model

    if p not in roms:
        try:
            roms[p] = load_model(p)
        except SloshromError as exc:
            fail(str(exc))
    try:  # a fill family gives the model at this tank's fill; a single ROM checks it
        rom = at_fill(roms[p], tank.fill, f"{p}")
    except SloshromError as exc:
        fail(f"--sloshing {exc} (the tank's fill: --fill, --tank-toml or --tank GRID:fill=F)")
    check_sloshing_rom(rom, p, "--sloshing", "the beam")
    ratio = rom.fs_ / BEAM_FS
    if not (ratio >= 1 - 1e-9 and abs(ratio - round(ratio)) < 1e-6):
        fail(f"--sloshing {p}: the ROM runs at {rom.fs_:g} Hz; the beam needs a multiple of "
             f"{BEAM_FS:g} Hz (the rate of its results and of the random excitation)")
    return rom


@dataclass
class StructureSetup:
    """What every beam command works on: the tanks, the structure, the first frozen mode."""

    tanks: list[Tank]  # one per tank of ``modal``
    modal: ModalModel
    beam: CantileverBeam | None  # the Euler-Bernoulli beam ``modal`` comes from, if any
    f1: float  # first frozen-liquid mode, Hz
    own: list[str | None]  # each tank's own --tank model, or None

    @property
    def tank(self) -> Tank | list[Tank]:
        """What the library takes: one tank, or the list for a structure with several."""
        return self.tanks if self.modal.psi_tank.ndim == 2 else self.tanks[0]


def _models(names: list[str] | None, setup: StructureSetup, seed: int) -> dict[str, Any]:
    """Every case's sloshing model(s), loaded and checked before any simulation (frozen first).

    On the built-in beam or a ``--modal-toml`` structure a case is one model for every tank.
    With ``--structure`` a case is one model per tank: a tank with its own model (``--tank
    GRID:MODEL``) keeps it in every case but ``frozen`` (every tank frozen, the reference);
    the others take the case's ``--sloshing`` model. When every tank has its own model, the
    cases are ``frozen`` and ``tanks``.
    """
    own = setup.own
    if all(own):
        if names:
            fail("--sloshing has no tank to act on: every --tank has its own model")
        names = ["tanks"]
    names = names or ["rig"]
    roms: dict[Path, SloshingModel] = {}
    models: dict[str, Any] = {}
    for name in ["frozen", *[n for n in names if n != "frozen"]]:
        case = name if name in ("frozen", "rig", "tanks") else Path(name).stem
        if case in models:
            fail(f"--sloshing {name}: a second case named '{case}' (each case writes "
                 f"<test>_{case}.nc; rename the model file)")
        per_tank = [_model("frozen" if case == "frozen" else (o or name), t, seed, roms)
                    for o, t in zip(own, setup.tanks, strict=True)]
        models[case] = per_tank if setup.modal.psi_tank.ndim == 2 else per_tank[0]
    return models


_SPEC_KEY = re.compile(r"^([A-Za-z_]+)\s*=")


def _tank_spec(spec: str, base: Tank) -> tuple[int, str | None, Tank]:
    """``GRID[:MODEL][:fill=F]`` -> (grid ID, own model or None, the tank at its fill).

    Each part at most once: a second ``fill=`` (or model) is an error naming it, never a
    silent "the last one wins"."""
    parts = spec.split(":")
    try:
        grid = int(parts[0])
    except ValueError:
        fail(f"--tank {spec!r}: must start with the integer grid/node ID of the tank "
             "(GRID[:MODEL][:fill=F])")
    model, tank, fill_given = None, base, False
    for part in parts[1:]:
        key = _SPEC_KEY.match(part)
        if key is not None and key.group(1) != "fill":
            fail(f"--tank {spec!r}: unknown key {key.group(1)!r} (GRID[:MODEL][:fill=F]: "
                 "the only key is fill)")
        if key is not None:
            if fill_given:
                fail(f"--tank {spec!r}: the key 'fill' is given twice; give it once")
            fill_given = True
            try:
                fill = float(part[key.end():])
            except ValueError:
                fail(f"--tank {spec!r}: fill must be a number in (0, 1)")
            try:
                tank = base.replace(fill=fill)
            except ConfigError as exc:
                fail(f"--tank {spec!r}: {exc}")
        elif part and model is None:
            model = part
        elif part:
            fail(f"--tank {spec!r}: two models ({model!r} and {part!r}): expected "
                 "GRID[:MODEL][:fill=F], one MODEL (frozen, rig or a ROM file) per tank")
        else:
            fail(f"--tank {spec!r}: an empty part; expected GRID[:MODEL][:fill=F], MODEL one "
                 "of frozen, rig or a ROM file")
    return grid, model, tank


def setup_structure(tank_toml: Path | None, modal_toml: Path | None, seed: int,
           structure: StructureOptions | None = None, fill: float | None = None) -> StructureSetup:
    """Tanks, modal model, the beam it comes from (``None`` for the user's own modal data) and
    the first frozen-liquid mode (Hz), or a user error."""
    from sloshrom.beam.simulation.structure import CantileverBeam, ModalModel, coupled_frozen_modes

    check_number(seed, "--seed", 0, MAX_SEED)
    check_number(fill, "--fill", 0.0, 1.0, lo_open=True, hi_open=True,
                 why="liquid depth / tank height")
    check_input(tank_toml, "--tank-toml")
    check_input(modal_toml, "--modal-toml")
    if structure is not None and modal_toml is not None:
        fail("--structure and --modal-toml both give the structure: use one")
    try:
        tank = Tank.from_toml(tank_toml) if tank_toml else Tank()
        if fill is not None:
            tank = tank.replace(fill=fill)
        own: list[str | None] | None = None
        if structure is not None:
            modal, tanks, own = structure.load(tank)
            beam = None
        elif modal_toml:
            beam, modal = None, ModalModel.from_toml(modal_toml)
            tanks = [tank] * modal.n_tanks
        else:
            beam = CantileverBeam.with_tank(tank)
            modal = ModalModel.from_beam(beam, tank)
            tanks = [tank]
        f1 = float(coupled_frozen_modes(modal, [t.liquid_mass for t in tanks])[0][0])
        check_analysis_band(f1)
    except SloshromError as exc:
        fail(str(exc))
    return StructureSetup(tanks, modal, beam, f1, own or [None] * len(tanks))


@dataclass
class StructureOptions:
    """The ``--structure`` options: a modal file and where the tanks and sensors are on it."""

    path: Path
    tank_specs: list[str]
    outputs: str | None
    direction: str
    mode_table: Path | None
    modes: int | None
    mass_unit: str | None

    @classmethod
    def from_options(cls, path: Path | None, tanks: list[str] | None, outputs: str | None,
                     direction: str, mode_table: Path | None, modes: int | None,
                     mass_unit: str | None) -> StructureOptions | None:
        """The options checked (before any work); ``None`` without ``--structure``."""
        if path is None:
            for given, name in ((tanks, "--tank"), (outputs, "--outputs"),
                                (mode_table, "--mode-table"), (modes, "--modes"),
                                (mass_unit, "--mass-unit")):
                if given:
                    fail(f"{name} places things on a --structure; give --structure FILE")
            return None
        check_input(path, "--structure")
        check_input(mode_table, "--mode-table")
        if not tanks:
            fail("--structure needs at least one --tank GRID (the grid/node ID of a tank)")
        if modes is not None:
            check_number(modes, "--modes", 1, MAX_MODES,
                         why="the coupled simulation solves an n x n eigenproblem")
        return cls(path, tanks, outputs, direction, mode_table, modes, mass_unit)

    def load(self, base: Tank) -> tuple[ModalModel, list[Tank], list[str | None]]:
        """The modal model at the tanks and outputs, each tank at its fill, each tank's own
        model (or None)."""
        from sloshrom.beam.simulation.modal_files import read_modes

        specs = [_tank_spec(s, base) for s in self.tank_specs]
        grids = [g for g, _, _ in specs]
        if len(set(grids)) != len(grids):
            fail(f"--tank: grid {next(g for g in grids if grids.count(g) > 1)} is given twice")
        outputs = None
        if self.outputs is not None:
            try:
                outputs = [int(x) for x in self.outputs.split(",") if x.strip()]
            except ValueError:
                fail(f"--outputs must be comma-separated integer grid IDs, got {self.outputs!r}")
            if not outputs:
                fail("--outputs is empty")
        ms = read_modes(self.path, mass_unit=self.mass_unit, mode_table=self.mode_table)
        if self.modes is not None:
            ms = ms.select_modes(self.modes)
        tanks = [t for _, _, t in specs]
        one = len(grids) == 1  # one tank: results without a tank axis, as on the built-in beam
        modal = ms.to_modal_model(grids[0] if one else grids, outputs, self.direction,
                                  structure_mass=tanks[0].structure_mass if one else
                                  [t.structure_mass for t in tanks])
        return modal, tanks, [m for _, m, _ in specs]


def check_outputs(out: Path, names: list[str], inputs: tuple[Path | None, ...]) -> None:
    """The directory and every file the command will write, before any work."""
    check_out(out, directory=True, inputs=inputs)
    for name in names:
        check_out(out / name, inputs=inputs, what="result file")


def _run_cases(models: dict[str, Any], label: str,
               simulate: Callable[[Any, float | None], dict]) -> dict[str, dict]:
    """Simulate every case at the beam's result rate, with a spinner per case.

    An ensemble ROM is coupled member by member (``sloshrom.pipeline.beam.coupled_model``):
    its case is the mean of the members' responses and damping estimates."""
    from rich.progress import SpinnerColumn, TextColumn, TimeElapsedColumn

    from sloshrom.beam.simulation.cases import simulate_cases
    from sloshrom.beam.simulation.coupled import SimulationDivergedError, StepMismatchError
    from sloshrom.pipeline.beam import coupled_models

    current: list[tuple[str, TaskID]] = []
    with progress_bars(SpinnerColumn(), TextColumn("{task.description}"), TimeElapsedColumn(),
                       transient=True) as progress:

        def on_case(case: str) -> None:
            if current:
                progress.remove_task(current[-1][1])
            current.append((case, progress.add_task(f"{label}: {case}", total=None)))

        try:
            return simulate_cases(coupled_models(models), simulate, BEAM_FS, on_case)
        except SimulationDivergedError as exc:  # a ROM far outside its training range
            fail(f"{label} with {current[-1][0]}: {exc}")
        except StepMismatchError as exc:  # e.g. a rig and a ROM in two tanks
            fail(f"{label} {current[-1][0]}: {exc}")
        except SloshromError as exc:  # e.g. ensembles of different sizes in two tanks
            fail(f"{label}: {exc}")


def echo_missing(table: Sequence[Mapping[str, float | int | str]] | xr.Dataset,
                 what: str) -> None:
    """Every cell of a damping table (free-decay band rows, or a Table 2 dataset) without a
    value, with its reason (never a silent NaN), and the values a fallback attempt or part of
    an ensemble's members gave."""
    from sloshrom.beam.damping.tables import missing_cells

    lines = missing_cells(table)
    if lines:
        typer.echo(f"{what}, cells without a value or with a note:")
        for line in lines:
            typer.echo(f"  {line}")


def refuse_empty(table: Sequence[Mapping[str, float | int | str]] | xr.Dataset, what: str,
                 estimators: Sequence[str] | None = None) -> None:
    """A user error, before anything is written, when no cell of a damping table (free-decay
    band rows, or a Table 2 dataset) has a value (a table of NaN says nothing): its first
    cell's reason."""
    from sloshrom.beam.damping.tables import no_estimate

    why = no_estimate(table, estimators)
    if why is not None:
        fail(f"{what}: no damping estimate at all, nothing written; the first cell: {why}")


def _analysed(what: str, fn: Callable[[], Any]) -> Any:
    """``fn()``; a response the analysis cannot handle (``AnalysisError``) is a user error."""
    try:
        return fn()
    except SloshromError as exc:
        fail(f"{what}: {exc}")


TankOpt = Annotated[
    Path | None, typer.Option(help="Tank TOML (\\[tank] table); default: paper.")]
FillOpt = Annotated[float | None, typer.Option(
    help="Fill level d/h of the tanks, in (0, 1); overrides --tank-toml's (a --tank "
         "GRID:fill=F wins). A ROM refuses a fill it was not identified at; a fill family "
         "(.toml) runs at it.")]
ModalOpt = Annotated[
    Path | None, typer.Option(help="Own modal data TOML (\\[modal] table, see docs/beam.md).")]
_SloshOpt = Annotated[
    list[str] | None, typer.Option("--sloshing", help="frozen | rig | ROM model file "
                                                      "(repeatable; a ROM at a multiple of 500 "
                                                      "Hz, m/s or m/s^2 -> N); default: rig.")]
StructureOpt = Annotated[Path | None, typer.Option(
    help="Modal model of your structure: UFF 55 (.unv/.uff), Nastran punch (.pch), NetCDF "
         "(.nc) or CSV (.csv); see docs/formats.md. Needs --tank.")]
TankSpecOpt = Annotated[list[str] | None, typer.Option(
    "--tank", help="A tank on --structure (repeatable): GRID[:MODEL][:fill=F], the grid/node "
                   "ID, optionally its own model (frozen | rig | ROM file) and fill (0-1). The "
                   "first is the reference of the damping analysis.")]
_OutputsOpt = Annotated[str | None, typer.Option(
    help="Output grid IDs on --structure (virtual accelerometers), comma separated; default: "
         "every node, up to 64.")]
DirectionOpt = Annotated[str, typer.Option(
    help="The up axis of --structure's coordinates, along which the tanks are shaken: +Z, -Z, "
         "+Y, -Y, +X, -X.")]
ModeTableOpt = Annotated[Path | None, typer.Option(
    help="Mode table for --structure (CSV or TOML): damping, modal_mass, participation per "
         "mode.")]
ModesOpt = Annotated[int | None, typer.Option(
    help=f"Keep the first N modes of --structure (1-{MAX_MODES}; a file with more modes needs "
         "it).")]
MassUnitOpt = Annotated[str | None, typer.Option(
    help="Mass unit of --structure when the file does not say it (punch): kg, t, g, "
         "lbf*s^2/in.")]
_UffOpt = Annotated[bool, typer.Option(
    "--uff/--no-uff", help="Also write each case as UFF dataset 58 (time histories; random: "
                           "H1 FRFs and coherences), for modal-analysis tools.")]


def _inputs(setup: StructureSetup, sloshing: list[str] | None, *paths: Path | None
            ) -> tuple[Path | None, ...]:
    """Every file the command reads (no output may overwrite one)."""
    names = [*(sloshing or []), *(o for o in setup.own if o)]
    return (*paths, *(Path(n) for n in names if n not in ("frozen", "rig")))


def _uff_names(enabled: bool, test: str, cases: Any) -> list[str]:
    return [f"{test}_{c}.uff" for c in cases] if enabled else []


def _check_uff_nodes(enabled: bool, modal: ModalModel) -> None:
    """With ``--uff``: the structure's node numbering must fit the UFF results (before work)."""
    if not enabled:
        return
    from sloshrom.beam.lab.uff58 import check_result_nodes

    try:
        check_result_nodes(modal)
    except SloshromError as exc:
        fail(f"--uff: {exc}")


@beam_app.command("free")
def free(
    out: Annotated[Path, typer.Option(help="Output directory.")],
    sloshing: _SloshOpt = None,
    tip_displacement: Annotated[float, typer.Option(help="Initial tip displacement, m "
                                                         "(0 < |x| < 0.2); on --structure: of "
                                                         "the first --tank.")] = 0.0146,
    duration: Annotated[float, typer.Option(help="s: from 18 periods of mode 1 (1.8 s for "
                                                 f"the paper beam) to {MAX_BEAM_SECONDS:g} "
                                                 "s.")] = 10.0,
    tank_toml: TankOpt = None,
    fill: FillOpt = None,
    modal_toml: ModalOpt = None,
    seed: Annotated[int, typer.Option(help="Rig seed (>= 0).")] = 0,
    structure: StructureOpt = None,
    tank: TankSpecOpt = None,
    outputs: _OutputsOpt = None,
    direction: DirectionOpt = "+Z",
    mode_table: ModeTableOpt = None,
    modes: ModesOpt = None,
    mass_unit: MassUnitOpt = None,
    uff: _UffOpt = False,
) -> None:
    """Free response from a static tip deflection (paper Figs. 14, 16, 20, 21; Table 1).

    The duration must leave the instantaneous-damping analysis of mode 1 something to analyse:
    it trims 5 periods at each end and smooths over 4, hence at least 18 periods. All result
    files appear together at the end, or none if the run fails. On your own structure
    (``--structure``) the static force acts at the first ``--tank``, whose acceleration is the
    amplitude axis of the damping analysis.

    Examples: ``sloshrom beam free --sloshing rig --sloshing nfir.npz --out results/beam``;
    ``sloshrom beam free --structure wing.pch --mode-table modes.csv --tank 2001 --tank
    3001:frozen --outputs 101,102,103,2001 --sloshing rig --out results/wing``
    """
    from sloshrom.beam.damping.tables import damping_band_table, mode1_decay
    from sloshrom.beam.lab.uff58 import write_result_uff
    from sloshrom.beam.results import to_dataset, write_dataset, write_table
    from sloshrom.beam.simulation.cases import frozen_modes_table, reference_tank
    from sloshrom.beam.simulation.coupled import free_response
    from sloshrom.plotting.beam import FREE_FIGURES, free_figures

    check_number(tip_displacement, "--tip-displacement", -0.2, 0.2, lo_open=True, hi_open=True,
                 unit="m")
    if tip_displacement == 0:
        fail("--tip-displacement must not be 0 (0 < |tip displacement| < 0.2 m): "
             "a beam at rest has no free response")
    check_number(duration, "--duration", 0.0, MAX_BEAM_SECONDS, lo_open=True, unit="s")
    st = StructureOptions.from_options(structure, tank, outputs, direction, mode_table, modes,
                                 mass_unit)
    setup = setup_structure(tank_toml, modal_toml, seed, st, fill)
    modal, f1 = setup.modal, setup.f1
    _check_uff_nodes(uff, modal)
    need = min_free_duration(f1)
    if duration < need:
        fail(f"--duration {duration:g} s is too short for the damping analysis of mode 1 "
             f"({f1:.3g} Hz): need at least {need:g} s ({FREE_DAMPING_PERIODS} periods)")
    models = _models(sloshing, setup, seed)
    files = [*(f"free_{c}.nc" for c in models), *_uff_names(uff, "free", models),
             "table1_frozen_modes.csv", "table1_frozen_modes.md",
             "damping_bands.csv", "damping_bands.md",
             *(f"{f}.png" for f in FREE_FIGURES)]
    check_outputs(out, files, _inputs(setup, sloshing, tank_toml, modal_toml, structure,
                                       mode_table))
    res = _run_cases(models, "free response",
                     lambda m, fs: free_response(m, modal, tip_displacement, duration,
                                                 setup.tank, fs))
    rows = frozen_modes_table(setup.tank, modal, setup.beam)  # user modes: coupled model only
    ref = {case: reference_tank(r) for case, r in res.items()}
    decays = _analysed("damping analysis of mode 1",
                       lambda: {case: mode1_decay(r, modal, f1) for case, r in ref.items()})
    bands = damping_band_table(ref, decays, f1)
    figs = free_figures(ref, modal, decays)
    with OutputBatch() as batch:  # all result files or none
        for case, r in res.items():
            ds = to_dataset(r, case, "free", setup.tank, modal, seed, f1=f1)
            write_dataset(ds, out / f"free_{case}.nc", batch)
            if uff:
                write_result_uff(ds, out / f"free_{case}.uff", batch=batch)
        write_table(rows, out / "table1_frozen_modes", batch)
        write_table(bands, out / "damping_bands", batch)
        for name, fig in figs.items():
            savefig(fig, out / f"{name}.png", batch)
    echo_missing(bands, "damping bands")
    typer.echo(f"wrote {len(res)} result file(s) and figures to {out}")


@beam_app.command("random")
def random(
    out: Annotated[Path, typer.Option(help="Output directory.")],
    sloshing: _SloshOpt = None,
    levels: Annotated[str, typer.Option(help=f"RMS base accelerations, g, each in (0, "
                                             f"{MAX_LEVEL_G:g}], comma separated.")] = (
        "0.1,0.2,0.4"),
    duration: Annotated[float, typer.Option(help=f"s, {MIN_RANDOM_DURATION:g} (one Welch "
                                                 f"segment of Table 2) to "
                                                 f"{MAX_BEAM_SECONDS:g}.")] = 90.0,
    seed: Annotated[int, typer.Option(help="Seed of the random phases (and of the rig), "
                                           ">= 0.")] = 0,
    f0: Annotated[float, typer.Option(help="PSD centre, Hz (estimate).")] = 12.0,
    sigma: Annotated[float, typer.Option(help="PSD standard deviation, Hz (estimate); "
                                              "f0 - 3 sigma >= 0 and f0 + 4 sigma < 250 Hz.")
                     ] = 4.0,
    tank_toml: TankOpt = None,
    fill: FillOpt = None,
    modal_toml: ModalOpt = None,
    structure: StructureOpt = None,
    tank: TankSpecOpt = None,
    outputs: _OutputsOpt = None,
    direction: DirectionOpt = "+Z",
    mode_table: ModeTableOpt = None,
    modes: ModesOpt = None,
    mass_unit: MassUnitOpt = None,
    uff: _UffOpt = False,
) -> None:
    """Random base excitation at several RMS levels (paper Figs. 18, 22, 23; Table 2).

    The excitation is synthesised at 500 Hz: its Gaussian PSD must lie inside (0, 250 Hz)
    (f0 - 3 sigma >= 0, f0 + 4 sigma < 250 Hz). Table 2's estimators use Welch segments of
    16384 samples (32.8 s), hence the shortest duration; duration x number of levels is at most
    1800 s (the rig holds about 2.1 MB per second and level). All result files appear together
    at the end, or none if the run fails. On your own structure (``--structure``) the base
    excitation needs the modes' participation factors (a mode-table column), and Table 2 uses
    the first ``--tank``.

    Example: ``sloshrom beam random --sloshing rig --levels 0.1,0.2,0.4 --duration 90 --out res``
    """
    from sloshrom.beam.damping.columns import table2_rows
    from sloshrom.beam.damping.tables import mode1_damping_dataset
    from sloshrom.beam.lab.uff58 import write_result_uff
    from sloshrom.beam.results import to_dataset, write_dataset, write_table
    from sloshrom.beam.simulation.cases import reference_tank
    from sloshrom.beam.simulation.coupled import random_response
    from sloshrom.plotting.beam import RANDOM_FIGURES, random_figures, random_window

    try:
        lv = [float(x) for x in levels.split(",") if x.strip()]
    except ValueError:
        fail(f"--levels must be comma-separated numbers in g, got {levels!r}")
    if not lv or any(not (0 < x <= MAX_LEVEL_G) for x in lv):
        fail(f"--levels must be RMS values in (0, {MAX_LEVEL_G:g}] g, got {levels!r}")
    try:
        check_psd_band(f0, sigma)
    except ConfigError as exc:
        fail(str(exc))
    check_number(duration, "--duration", MIN_RANDOM_DURATION, MAX_BEAM_SECONDS, unit="s",
                 why=f"Table 2 needs one {WELCH_SEGMENT}-sample Welch segment at 500 Hz")
    if duration * len(lv) > MAX_LEVEL_SECONDS:
        fail(f"--duration {duration:g} s x {len(lv)} level(s) = {duration * len(lv):g} s is "
             f"more than {MAX_LEVEL_SECONDS:g} s (memory: the rig holds about 2.1 MB per second "
             "and level at its 10 kHz step)")
    st = StructureOptions.from_options(structure, tank, outputs, direction, mode_table, modes,
                                 mass_unit)
    setup = setup_structure(tank_toml, modal_toml, seed, st, fill)
    modal, f1 = setup.modal, setup.f1
    _check_uff_nodes(uff, modal)
    if not modal.has_participation:
        fail("the structure has no participation factors (kg), which base excitation needs: "
             "add a 'participation' column to --mode-table (see docs/formats.md)")
    models = _models(sloshing, setup, seed)
    files = [*(f"random_{c}.nc" for c in models), *_uff_names(uff, "random", models),
             "table2_mode1_damping.csv", "table2_mode1_damping.md",
             *(f"{f}.png" for f in RANDOM_FIGURES)]
    check_outputs(out, files, _inputs(setup, sloshing, tank_toml, modal_toml, structure,
                                       mode_table))
    res = _run_cases(models, "random response",
                     lambda m, fs: random_response(m, modal, lv, duration, seed, f0, sigma,
                                                   tank=setup.tank, output_fs=fs))
    ref = {case: reference_tank(r) for case, r in res.items()}
    table2 = _analysed("damping analysis of mode 1",
                       lambda: mode1_damping_dataset(ref, lv, f1))
    with OutputBatch() as batch:  # all result files or none
        for case, r in res.items():
            ds = to_dataset(r, case, "random", setup.tank, modal, seed, f1=f1)
            write_dataset(ds, out / f"random_{case}.nc", batch)
            if uff:
                write_result_uff(ds, out / f"random_{case}.uff", batch=batch)
        write_table(table2_rows(table2), out / "table2_mode1_damping", batch)
        for name, fig in random_figures(ref, lv, random_window(duration)).items():
            savefig(fig, out / f"{name}.png", batch)
    echo_missing(table2, "Table 2")
    typer.echo(f"wrote {len(res)} result file(s), Table 2 and figures to {out}")
