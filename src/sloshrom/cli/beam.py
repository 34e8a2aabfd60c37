"""``sloshrom beam``: sloshing-beam free and random responses, damping analysis, figures.

Every run simulates the frozen-liquid reference and each requested sloshing model (``rig`` = the
virtual rig, the "experiment"; or a ROM file written by ``sloshrom train``) on the same modal
beam, writes one NetCDF per case into ``--out`` and the figures/tables of the paper's Sect. 4-5.
"""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Any

import numpy as np
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
from sloshrom.config import G, Tank
from sloshrom.fileio import OutputBatch, atomic_write
from sloshrom.pipeline.settings import (
    FREE_DAMPING_PERIODS,
    MAX_BEAM_SECONDS,
    MAX_LEVEL_SECONDS,
    MIN_RANDOM_DURATION,
    check_analysis_band,
    check_psd_band,
    min_free_duration,
)

beam_app = typer.Typer(
    help="Sloshing-beam simulations (free and random responses) and damping analysis.",
    no_args_is_help=True,
)
app.add_typer(beam_app, name="beam")

SENSOR_FS = 500.0  # Hz, output rate of the rig runs and the frozen reference
MAX_SEED = 2**32 - 1
MAX_LEVEL_G = 2.0  # RMS; the rig's calibrated envelope is 6 g peak, about 3 x RMS


def _model(name: str, tank: Tank, seed: int) -> tuple[str, Any]:
    """``(case name, sloshing model)`` of a ``--sloshing`` value; a user error if unusable."""
    from sloshrom.models import FrozenLiquid

    if name == "frozen":
        return "frozen", FrozenLiquid(1.0 / SENSOR_FS)
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
    ratio = rom.fs_ / SENSOR_FS
    if not (ratio >= 1 - 1e-9 and abs(ratio - round(ratio)) < 1e-6):
        fail(f"--sloshing {p}: the ROM runs at {rom.fs_:g} Hz; the beam needs a multiple of "
             f"{SENSOR_FS:g} Hz (the rate of its results and of the random excitation)")
    return p.stem, rom


def _models(names: list[str], tank: Tank, seed: int) -> dict[str, Any]:
    """Every sloshing model, loaded and checked before any simulation (frozen first)."""
    models: dict[str, Any] = {}
    for name in ["frozen", *[n for n in names if n != "frozen"]]:
        case, model = _model(name, tank, seed)
        if case in models:
            fail(f"--sloshing {name}: a second case named '{case}' (each case writes "
                 f"<test>_{case}.nc; rename the model file)")
        models[case] = model
    return models


def _modal(modal_toml: Path | None, tank: Tank):
    from sloshrom.beam.structure import ModalModel

    return ModalModel.from_toml(modal_toml) if modal_toml else ModalModel.from_beam(tank=tank)


def _setup(tank_toml: Path | None, modal_toml: Path | None, seed: int):
    """Tank, modal model and first frozen-liquid mode (Hz), or a user error."""
    from sloshrom.beam.structure import coupled_frozen_modes

    check_number(seed, "--seed", 0, MAX_SEED)
    check_input(tank_toml, "--tank-toml")
    check_input(modal_toml, "--modal-toml")
    try:
        tank = Tank.from_toml(tank_toml) if tank_toml else Tank()
        modal = _modal(modal_toml, tank)
        f1 = float(coupled_frozen_modes(modal, tank.liquid_mass)[0][0])
        check_analysis_band(f1)
    except user_errors() as exc:
        fail(str(exc))
    return tank, modal, f1


def _check_outputs(out: Path, names: list[str], inputs: tuple[Path | None, ...]) -> None:
    """The directory and every file the command will write, before any work."""
    check_out(out, directory=True, inputs=inputs)
    for name in names:
        check_out(out / name, inputs=inputs, what="result file")


def to_dataset(out: dict, case: str, kind: str, tank: Tank, modal, seed: int = 0) -> Any:
    """xarray Dataset of a coupled-simulation result (standard beam-result names)."""
    import xarray as xr

    from sloshrom import __version__

    lead = out["tank_acceleration"].shape[:-1]
    ldims = ("level",) if len(lead) == 1 else ()
    t = out["time"]
    ds = xr.Dataset(
        {
            "base_acceleration": (ldims + ("time",), out["base_acceleration"],
                                  {"units": "m/s^2"}),
            "tank_acceleration": (ldims + ("time",), out["tank_acceleration"],
                                  {"units": "m/s^2", "long_name": "tank absolute acceleration"}),
            "interface_force": (ldims + ("time",), out["interface_force"],
                                {"units": "N", "long_name": "-(m_struct + m_l) acc + dynamic"}),
            "dynamic_force": (ldims + ("time",), out["dynamic_force"], {"units": "N"}),
            "tank_velocity": (ldims + ("time",), out["tank_velocity"],
                              {"units": "m/s", "long_name": "tank absolute velocity"}),
            "station_acceleration": (ldims + ("time", "station"), out["station_acceleration"],
                                     {"units": "m/s^2", "long_name": "absolute"}),
            "modal_acceleration": (ldims + ("time", "mode"), out["modal_acceleration"],
                                   {"units": "m/s^2"}),
            "q": (ldims + ("time", "mode"), out["q"], {"units": "m"}),
        },
        coords={"time": ("time", t, {"units": "s"}),
                "station": ("station", modal.stations, {"units": "m"}),
                "mode": ("mode", np.arange(1, modal.n_modes + 1))},
        attrs={"case": case, "test": kind, "fs": float(out["fs"]),
               "sloshrom_version": __version__, "seed": int(seed),
               "tank_fill": tank.fill, "liquid_mass": tank.liquid_mass,
               "structure_mass": modal.structure_mass,
               "modal_frequencies_Hz": modal.frequencies,
               "modal_damping": modal.damping},
    )
    if ldims:
        ds = ds.assign_coords(level=("level", out["rms_levels_g"], {"units": "g (RMS)"}))
    return ds


def _write_nc(ds: Any, path: Path, batch: OutputBatch | None = None) -> None:
    write = batch.write if batch is not None else atomic_write
    write(path, lambda tmp: ds.to_netcdf(tmp, engine="h5netcdf"))


def _write_table(rows: list[dict], path_stem: Path, batch: OutputBatch | None = None) -> None:
    keys = list(rows[0])

    def csv(tmp):
        with open(tmp, "w", encoding="utf-8") as fh:
            fh.write(",".join(keys) + "\n")
            for r in rows:
                fh.write(",".join(f"{r[k]}" for k in keys) + "\n")

    def md(tmp):
        def fmt(v):
            return f"{v:.4g}" if isinstance(v, float) else str(v)

        with open(tmp, "w", encoding="utf-8") as fh:
            fh.write("| " + " | ".join(keys) + " |\n|" + "---|" * len(keys) + "\n")
            for r in rows:
                fh.write("| " + " | ".join(fmt(r[k]) for k in keys) + " |\n")

    write = batch.write if batch is not None else atomic_write
    write(path_stem.with_suffix(".csv"), csv)
    write(path_stem.with_suffix(".md"), md)


def _savefig(fig, path: Path, batch: OutputBatch | None = None) -> None:
    import matplotlib.pyplot as plt

    write = batch.write if batch is not None else atomic_write
    try:
        write(path, lambda tmp: fig.savefig(tmp, dpi=120, format="png"))
    finally:
        plt.close(fig)


def _run_cases(models: dict[str, Any], label: str, fn) -> dict:
    from rich.progress import Progress, SpinnerColumn, TextColumn, TimeElapsedColumn

    from sloshrom.beam.coupled import SimulationDivergedError

    results = {}
    with Progress(SpinnerColumn(), TextColumn("{task.description}"), TimeElapsedColumn(),
                  transient=True) as progress:
        for case, model in models.items():
            task = progress.add_task(f"{label}: {case}", total=None)
            out_fs = SENSOR_FS if 1.0 / model.dt > SENSOR_FS else None
            try:
                results[case] = fn(model, out_fs)
            except SimulationDivergedError as exc:  # a ROM far outside its training range
                fail(f"{label} with {case}: {exc}")
            progress.remove_task(task)
    return results


_FREE_FIGS = ("fig14_station_accelerations", "fig16_modal_accelerations",
              "fig20_tank_interface_dynamic", "fig21_instantaneous_damping")
_RANDOM_FIGS = ("fig18_tank_acceleration", "fig22_tank_acceleration_window", "fig23_psd")


# ------------------------------------------------------------------------------------------
# Figures (paper Figs. 14, 16, 18, 20-23)
# ------------------------------------------------------------------------------------------


def free_figures(res: dict, modal, tank: Tank) -> dict:
    """Figures of a free-response comparison: dict name -> matplotlib Figure."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from sloshrom.beam.analysis import instantaneous_damping, log_decrement, modal_filter
    from sloshrom.beam.structure import coupled_frozen_modes

    figs = {}
    cases = list(res)
    fig, axes = plt.subplots(len(cases), 1, figsize=(8, 2.6 * len(cases)), sharex=True,
                             squeeze=False)
    for ax, case in zip(axes[:, 0], cases, strict=True):
        r = res[case]
        for j, x in enumerate(modal.stations):
            ax.plot(r["time"], r["station_acceleration"][:, j] / G, lw=0.6, label=f"x={x:.3f} m")
        ax.set_ylabel("acceleration (g)")
        ax.set_title(f"{case}: station accelerations")
    axes[0, 0].legend(fontsize=7, ncol=3)
    axes[-1, 0].set_xlabel("time (s)")
    figs["fig14_station_accelerations"] = fig

    # modal filtering of the virtual accelerometers (relative to the base), as for measured data
    filtered = {
        case: modal_filter(r["station_acceleration"] - r["base_acceleration"][..., None],
                           modal.psi_stations)
        for case, r in res.items()
    }
    fig, axes = plt.subplots(modal.n_modes, 1, figsize=(8, 2.2 * modal.n_modes), sharex=True,
                             squeeze=False)
    for n in range(modal.n_modes):
        for case in cases:
            r = res[case]
            axes[n, 0].plot(r["time"], filtered[case][:, n], lw=0.6, label=case)
        axes[n, 0].set_ylabel(f"q''_{n + 1} (m/s²)")
    axes[0, 0].legend(fontsize=8)
    axes[-1, 0].set_xlabel("time (s)")
    fig.suptitle("Modal accelerations (modal filtering of the station accelerations)")
    figs["fig16_modal_accelerations"] = fig

    fig, axes = plt.subplots(3, 1, figsize=(8, 7), sharex=True)
    for case in cases:
        r = res[case]
        axes[0].plot(r["time"], r["tank_acceleration"] / G, lw=0.6, label=case)
        axes[1].plot(r["time"], r["interface_force"], lw=0.6, label=case)
        axes[2].plot(r["time"], r["dynamic_force"], lw=0.6, label=case)
    for ax, lab in zip(axes, ("tank acc. (g)", "interface force (N)", "dynamic force (N)"),
                       strict=True):
        ax.set_ylabel(lab)
    axes[0].legend(fontsize=8)
    axes[-1].set_xlabel("time (s)")
    figs["fig20_tank_interface_dynamic"] = fig

    f1 = float(coupled_frozen_modes(modal, tank.liquid_mass)[0][0])
    fig, ax = plt.subplots(figsize=(7, 4.5))
    for case in cases:
        r = res[case]
        h = instantaneous_damping(filtered[case][:, 0], r["fs"], f1,
                                  reference=r["tank_acceleration"])
        line, = ax.plot(h["amplitude"] / G, 100 * h["zeta"], lw=1.0, label=f"{case} (Hilbert)")
        ld = log_decrement(filtered[case][:, 0], r["fs"], f1,
                           reference=r["tank_acceleration"])
        ax.plot(ld["amplitude"] / G, 100 * ld["zeta"], "o", ms=3, color=line.get_color(),
                label=f"{case} (log decrement)")
    ax.set_xlabel("tank acceleration amplitude (g)")
    ax.set_ylabel("first-mode damping ratio (%)")
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3)
    figs["fig21_instantaneous_damping"] = fig
    return figs


def random_figures(res: dict, levels: list[float], window: tuple[float, float] = (40, 42)):
    """Figures of the random-response comparison: dict name -> Figure."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from sloshrom.beam.analysis import welch_psd

    figs = {}
    cases = list(res)
    slosh = [c for c in cases if c != "frozen"] or cases
    fig, axes = plt.subplots(len(levels), 1, figsize=(8, 2.3 * len(levels)), sharex=True,
                             squeeze=False)
    r = res[slosh[0]]
    for i, lv in enumerate(levels):
        axes[i, 0].plot(r["time"], r["tank_acceleration"][i] / G, lw=0.4)
        axes[i, 0].set_ylabel(f"{lv:g} g RMS\ntank acc. (g)")
    axes[-1, 0].set_xlabel("time (s)")
    fig.suptitle(f"Tank acceleration, {slosh[0]}")
    figs["fig18_tank_acceleration"] = fig

    fig, axes = plt.subplots(len(levels), 1, figsize=(8, 2.3 * len(levels)), sharex=True,
                             squeeze=False)
    for case in cases:
        r = res[case]
        sel = (r["time"] >= window[0]) & (r["time"] <= window[1])
        for i in range(len(levels)):
            axes[i, 0].plot(r["time"][sel], r["tank_acceleration"][i][sel] / G, lw=0.8,
                            label=case)
    for i, lv in enumerate(levels):
        axes[i, 0].set_ylabel(f"{lv:g} g RMS (g)")
    axes[0, 0].legend(fontsize=8)
    axes[-1, 0].set_xlabel("time (s)")
    figs["fig22_tank_acceleration_window"] = fig

    fig, axes = plt.subplots(1, len(levels), figsize=(4 * len(levels), 3.8), squeeze=False)
    for case in cases:
        r = res[case]
        f, p = welch_psd(r["tank_acceleration"], r["fs"], nperseg=8192)
        for i in range(len(levels)):
            axes[0, i].semilogy(f, p[i], lw=0.8, label=case)
    for i, lv in enumerate(levels):
        top = max(ln.get_ydata().max() for ln in axes[0, i].get_lines())
        axes[0, i].set_ylim(top * 1e-6, top * 3)  # six decades around the peak
        axes[0, i].set_xlim(0, 40)
        axes[0, i].set_title(f"{lv:g} g RMS")
        axes[0, i].set_xlabel("frequency (Hz)")
    axes[0, 0].set_ylabel("PSD tank acc. ((m/s²)²/Hz)")
    axes[0, 0].legend(fontsize=8)
    figs["fig23_psd"] = fig
    return figs


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
    from sloshrom.beam.structure import coupled_frozen_modes, frozen_modal_table

    check_number(tip_displacement, "--tip-displacement", -0.2, 0.2, lo_open=True, hi_open=True,
                 unit="m")
    if tip_displacement == 0:
        fail("--tip-displacement must not be 0 (0 < |tip displacement| < 0.2 m): "
             "a beam at rest has no free response")
    check_number(duration, "--duration", 0.0, MAX_BEAM_SECONDS, lo_open=True, unit="s")
    tank, modal, f1 = _setup(tank_toml, modal_toml, seed)
    need = min_free_duration(f1)
    if duration < need:
        fail(f"--duration {duration:g} s is too short for the damping analysis of mode 1 "
             f"({f1:.3g} Hz): need at least {need:g} s ({FREE_DAMPING_PERIODS} periods)")
    models = _models(sloshing, tank, seed)
    inputs = (tank_toml, modal_toml, *(Path(n) for n in sloshing if n not in ("frozen", "rig")))
    files = [*(f"free_{c}.nc" for c in models), "table1_frozen_modes.csv",
             "table1_frozen_modes.md", *(f"{f}.png" for f in _FREE_FIGS)]
    _check_outputs(out, files, inputs)
    res = _run_cases(models, "free response",
                     lambda m, fs: free_response(m, modal, tip_displacement, duration, tank, fs))
    if modal_toml is None:
        rows = frozen_modal_table(tank, n_modes=modal.n_modes)
    else:  # user modes: frozen-liquid frequencies of the coupled model only
        fc, _ = coupled_frozen_modes(modal, tank.liquid_mass)
        rows = [{"mode": n + 1, "f_dry_Hz": float(modal.frequencies[n]),
                 "f_coupled_Hz": float(fc[n]), "damping": float(modal.damping[n])}
                for n in range(modal.n_modes)]
    with OutputBatch() as batch:  # all result files or none
        for case, r in res.items():
            _write_nc(to_dataset(r, case, "free", tank, modal, seed), out / f"free_{case}.nc",
                      batch)
        _write_table(rows, out / "table1_frozen_modes", batch)
        for name, fig in free_figures(res, modal, tank).items():
            _savefig(fig, out / f"{name}.png", batch)
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
    from sloshrom.beam.analysis import mode1_damping_random
    from sloshrom.beam.coupled import random_response
    from sloshrom.config import ConfigError

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
    tank, modal, f1 = _setup(tank_toml, modal_toml, seed)
    models = _models(sloshing, tank, seed)
    inputs = (tank_toml, modal_toml, *(Path(n) for n in sloshing if n not in ("frozen", "rig")))
    files = [*(f"random_{c}.nc" for c in models), "table2_mode1_damping.csv",
             "table2_mode1_damping.md", *(f"{f}.png" for f in _RANDOM_FIGS)]
    _check_outputs(out, files, inputs)
    res = _run_cases(models, "random response",
                     lambda m, fs: random_response(m, modal, lv, duration, seed, f0, sigma,
                                                   tank=tank, output_fs=fs))
    rows = []
    for case, r in res.items():
        for i, level in enumerate(lv):
            d = mode1_damping_random(r["base_acceleration"][i], r["tank_acceleration"][i],
                                     r["fs"], f1)
            rows.append({"case": case, "rms_g": level, **d})
    with OutputBatch() as batch:  # all result files or none
        for case, r in res.items():
            _write_nc(to_dataset(r, case, "random", tank, modal, seed),
                      out / f"random_{case}.nc", batch)
        _write_table(rows, out / "table2_mode1_damping", batch)
        window = (min(40.0, duration / 2), min(42.0, duration / 2 + 2))  # inside the record
        for name, fig in random_figures(res, lv, window).items():
            _savefig(fig, out / f"{name}.png", batch)
    typer.echo(f"wrote {len(res)} result file(s), Table 2 and figures to {out}")
