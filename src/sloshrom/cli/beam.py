"""``sloshrom beam``: sloshing-beam free and random responses, damping analysis, figures.

Every run simulates the frozen-liquid reference and each requested sloshing model (``rig`` = the
virtual rig, the "experiment"; or a ROM file written by ``sloshrom train``) on the same modal
beam, writes one NetCDF per case into ``--out`` and the figures/tables of the paper's Sect. 4-5.

This module parses and checks the options, builds the models and calls the library
(:mod:`sloshrom.beam.results`, :mod:`sloshrom.plotting.beam`); the library modules are imported
inside the commands, so that ``sloshrom --help`` does not load JAX, xarray and matplotlib.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any

import typer

from sloshrom.cli._app import (
    app,
    check_input,
    check_number,
    check_out,
    check_sloshing_rom,
    fail,
    user_errors,
)
from sloshrom.config import ConfigError, Tank
from sloshrom.fileio import OutputBatch
from sloshrom.models import FrozenLiquid, SloshingModel
from sloshrom.pipeline.settings import (
    BEAM_FS,
    FREE_DAMPING_PERIODS,
    MAX_BEAM_SECONDS,
    MAX_LEVEL_SECONDS,
    MIN_RANDOM_DURATION,
    check_analysis_band,
    check_psd_band,
    min_free_duration,
)
from sloshrom.plotting import savefig

if TYPE_CHECKING:
    from sloshrom.beam.structure import CantileverBeam, ModalModel

beam_app = typer.Typer(
    help="Sloshing-beam simulations (free and random responses) and damping analysis.",
    no_args_is_help=True,
)
app.add_typer(beam_app, name="beam")

MAX_SEED = 2**32 - 1
MAX_LEVEL_G = 2.0  # RMS; the rig's calibrated envelope is 6 g peak, about 3 x RMS


def _model(name: str, tank: Tank, seed: int) -> tuple[str, SloshingModel]:
    """``(case name, sloshing model)`` of a ``--sloshing`` value; a user error if unusable."""
    if name == "frozen":
        return "frozen", FrozenLiquid(1.0 / BEAM_FS)
    if name == "rig":
        from sloshrom.rig.virtual import VirtualRig

        return "rig", VirtualRig(tank=tank, seed=seed)
    p = Path(name)
    if not name.strip() or not p.is_file():
        fail(f"--sloshing must be 'frozen', 'rig' or a ROM model file; {p} does not exist")
    from sloshrom.rom.estimators import load_model

    try:
        rom = load_model(p)
    except user_errors() as exc:
        fail(str(exc))
    check_sloshing_rom(rom, p, "--sloshing", "the beam")
    ratio = rom.fs_ / BEAM_FS
    if not (ratio >= 1 - 1e-9 and abs(ratio - round(ratio)) < 1e-6):
        fail(f"--sloshing {p}: the ROM runs at {rom.fs_:g} Hz; the beam needs a multiple of "
             f"{BEAM_FS:g} Hz (the rate of its results and of the random excitation)")
    return p.stem, rom


def _models(names: list[str], tank: Tank, seed: int) -> dict[str, SloshingModel]:
    """Every sloshing model, loaded and checked before any simulation (frozen first)."""
    models: dict[str, SloshingModel] = {}
    for name in ["frozen", *[n for n in names if n != "frozen"]]:
        case, model = _model(name, tank, seed)
        if case in models:
            fail(f"--sloshing {name}: a second case named '{case}' (each case writes "
                 f"<test>_{case}.nc; rename the model file)")
        models[case] = model
    return models


def _setup(tank_toml: Path | None, modal_toml: Path | None, seed: int
           ) -> tuple[Tank, ModalModel, CantileverBeam | None, float]:
    """Tank, modal model, the beam it comes from (``None`` for the user's own modal data) and
    the first frozen-liquid mode (Hz), or a user error."""
    from sloshrom.beam.structure import CantileverBeam, ModalModel, coupled_frozen_modes

    check_number(seed, "--seed", 0, MAX_SEED)
    check_input(tank_toml, "--tank-toml")
    check_input(modal_toml, "--modal-toml")
    try:
        tank = Tank.from_toml(tank_toml) if tank_toml else Tank()
        if modal_toml:
            beam, modal = None, ModalModel.from_toml(modal_toml)
        else:
            beam = CantileverBeam.with_tank(tank)
            modal = ModalModel.from_beam(beam, tank)
        f1 = float(coupled_frozen_modes(modal, tank.liquid_mass)[0][0])
        check_analysis_band(f1)
    except user_errors() as exc:
        fail(str(exc))
    return tank, modal, beam, f1


def _check_outputs(out: Path, names: list[str], inputs: tuple[Path | None, ...]) -> None:
    """The directory and every file the command will write, before any work."""
    check_out(out, directory=True, inputs=inputs)
    for name in names:
        check_out(out / name, inputs=inputs, what="result file")


def _run_cases(models: dict[str, SloshingModel], label: str,
               simulate: Callable[[SloshingModel, float | None], dict]) -> dict[str, dict]:
    """Simulate every case at the beam's result rate, with a spinner per case."""
    from rich.progress import Progress, SpinnerColumn, TextColumn, TimeElapsedColumn

    from sloshrom.beam.coupled import SimulationDivergedError
    from sloshrom.beam.results import simulate_cases

    current: list[tuple[str, Any]] = []
    with Progress(SpinnerColumn(), TextColumn("{task.description}"), TimeElapsedColumn(),
                  transient=True) as progress:

        def on_case(case: str) -> None:
            if current:
                progress.remove_task(current[-1][1])
            current.append((case, progress.add_task(f"{label}: {case}", total=None)))

        try:
            return simulate_cases(models, simulate, BEAM_FS, on_case)
        except SimulationDivergedError as exc:  # a ROM far outside its training range
            fail(f"{label} with {current[-1][0]}: {exc}")


def _analysed(what: str, fn: Callable[[], Any]) -> Any:
    """``fn()``; a response the analysis cannot handle (``AnalysisError``) is a user error."""
    try:
        return fn()
    except user_errors() as exc:
        fail(f"{what}: {exc}")


_TankOpt = Annotated[
    Path | None, typer.Option(help="Tank TOML (\\[tank] table); default: paper.")]
_ModalOpt = Annotated[
    Path | None, typer.Option(help="Own modal data TOML (\\[modal] table, see docs/beam.md).")]
_SloshOpt = Annotated[
    list[str], typer.Option("--sloshing", help="frozen | rig | ROM model file (repeatable; "
                                               "a ROM at a multiple of 500 Hz, m/s -> N).")]


@beam_app.command("free")
def free(
    out: Annotated[Path, typer.Option(help="Output directory.")],
    sloshing: _SloshOpt = ["rig"],  # noqa: B006 (typer default)
    tip_displacement: Annotated[float, typer.Option(help="Initial tip displacement, m "
                                                         "(0 < |x| < 0.2).")] = 0.0146,
    duration: Annotated[float, typer.Option(help="s: from 18 periods of mode 1 (1.8 s for "
                                                 f"the paper beam) to {MAX_BEAM_SECONDS:g} "
                                                 "s.")] = 10.0,
    tank_toml: _TankOpt = None,
    modal_toml: _ModalOpt = None,
    seed: Annotated[int, typer.Option(help="Rig seed (>= 0).")] = 0,
) -> None:
    """Free response from a static tip deflection (paper Figs. 14, 16, 20, 21; Table 1).

    The duration must leave the instantaneous-damping analysis of mode 1 something to analyse:
    it trims 5 periods at each end and smooths over 4, hence at least 18 periods. All result
    files appear together at the end, or none if the run fails.

    Example: ``sloshrom beam free --sloshing rig --sloshing nfir.npz --out results/beam``
    """
    from sloshrom.beam.coupled import free_response
    from sloshrom.beam.results import (
        frozen_modes_table,
        mode1_decay,
        to_dataset,
        write_dataset,
        write_table,
    )
    from sloshrom.plotting.beam import FREE_FIGURES, free_figures

    check_number(tip_displacement, "--tip-displacement", -0.2, 0.2, lo_open=True, hi_open=True,
                 unit="m")
    if tip_displacement == 0:
        fail("--tip-displacement must not be 0 (0 < |tip displacement| < 0.2 m): "
             "a beam at rest has no free response")
    check_number(duration, "--duration", 0.0, MAX_BEAM_SECONDS, lo_open=True, unit="s")
    tank, modal, beam, f1 = _setup(tank_toml, modal_toml, seed)
    need = min_free_duration(f1)
    if duration < need:
        fail(f"--duration {duration:g} s is too short for the damping analysis of mode 1 "
             f"({f1:.3g} Hz): need at least {need:g} s ({FREE_DAMPING_PERIODS} periods)")
    models = _models(sloshing, tank, seed)
    inputs = (tank_toml, modal_toml, *(Path(n) for n in sloshing if n not in ("frozen", "rig")))
    files = [*(f"free_{c}.nc" for c in models), "table1_frozen_modes.csv",
             "table1_frozen_modes.md", *(f"{f}.png" for f in FREE_FIGURES)]
    _check_outputs(out, files, inputs)
    res = _run_cases(models, "free response",
                     lambda m, fs: free_response(m, modal, tip_displacement, duration, tank, fs))
    rows = frozen_modes_table(tank, modal, beam)  # user modes (no beam): coupled model only
    decays = _analysed("damping analysis of mode 1",
                       lambda: {case: mode1_decay(r, modal, f1) for case, r in res.items()})
    figs = free_figures(res, modal, decays)
    with OutputBatch() as batch:  # all result files or none
        for case, r in res.items():
            write_dataset(to_dataset(r, case, "free", tank, modal, seed),
                          out / f"free_{case}.nc", batch)
        write_table(rows, out / "table1_frozen_modes", batch)
        for name, fig in figs.items():
            savefig(fig, out / f"{name}.png", batch)
    typer.echo(f"wrote {len(res)} result file(s) and figures to {out}")


@beam_app.command("random")
def random(
    out: Annotated[Path, typer.Option(help="Output directory.")],
    sloshing: _SloshOpt = ["rig"],  # noqa: B006
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
    tank_toml: _TankOpt = None,
    modal_toml: _ModalOpt = None,
) -> None:
    """Random base excitation at several RMS levels (paper Figs. 18, 22, 23; Table 2).

    The excitation is synthesised at 500 Hz: its Gaussian PSD must lie inside (0, 250 Hz)
    (f0 - 3 sigma >= 0, f0 + 4 sigma < 250 Hz). Table 2's estimators use Welch segments of
    16384 samples (32.8 s), hence the shortest duration; duration x number of levels is at most
    1800 s (the rig holds about 2.1 MB per second and level). All result files appear together
    at the end, or none if the run fails.

    Example: ``sloshrom beam random --sloshing rig --levels 0.1,0.2,0.4 --duration 90 --out res``
    """
    from sloshrom.beam.coupled import random_response
    from sloshrom.beam.results import mode1_damping_table, to_dataset, write_dataset, write_table
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
                 why="Table 2 needs one 16384-sample Welch segment at 500 Hz")
    if duration * len(lv) > MAX_LEVEL_SECONDS:
        fail(f"--duration {duration:g} s x {len(lv)} level(s) = {duration * len(lv):g} s is "
             f"more than {MAX_LEVEL_SECONDS:g} s (memory: the rig holds about 2.1 MB per second "
             "and level at its 10 kHz step)")
    tank, modal, _, f1 = _setup(tank_toml, modal_toml, seed)
    models = _models(sloshing, tank, seed)
    inputs = (tank_toml, modal_toml, *(Path(n) for n in sloshing if n not in ("frozen", "rig")))
    files = [*(f"random_{c}.nc" for c in models), "table2_mode1_damping.csv",
             "table2_mode1_damping.md", *(f"{f}.png" for f in RANDOM_FIGURES)]
    _check_outputs(out, files, inputs)
    res = _run_cases(models, "random response",
                     lambda m, fs: random_response(m, modal, lv, duration, seed, f0, sigma,
                                                   tank=tank, output_fs=fs))
    rows = _analysed("damping analysis of mode 1",
                     lambda: mode1_damping_table(res, lv, f1))
    with OutputBatch() as batch:  # all result files or none
        for case, r in res.items():
            write_dataset(to_dataset(r, case, "random", tank, modal, seed),
                          out / f"random_{case}.nc", batch)
        write_table(rows, out / "table2_mode1_damping", batch)
        for name, fig in random_figures(res, lv, random_window(duration)).items():
            savefig(fig, out / f"{name}.png", batch)
    typer.echo(f"wrote {len(res)} result file(s), Table 2 and figures to {out}")
