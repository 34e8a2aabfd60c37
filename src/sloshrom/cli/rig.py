"""``sloshrom rig``: virtual-rig shaker records (VFA training/validation data, harmonic tests).

Each command generates the commanded tank acceleration at the rig's fine step, runs
``sloshrom.rig.VirtualRig.measure``, preprocesses the measurement as for real shaker data
(velocity by integrating the measured acceleration, dynamic force = force + inertia) and writes a
NetCDF record with ``time``, ``acceleration``, ``velocity``, ``force``, ``dynamic_force`` (plus the
rig's noise-free ``true_velocity``/``true_dynamic_force`` unless ``--no-truth``).
"""

from __future__ import annotations

import importlib
import shlex
import sys
from datetime import UTC, datetime
from pathlib import Path
from typing import Annotated, Any

import numpy as np
import typer

from sloshrom.cli._app import app, fail
from sloshrom.config import ConfigError, G, Tank

rig_app = typer.Typer(
    help="Generate virtual-rig shaker records (the paper's VFA data and harmonic tests).",
    no_args_is_help=True,
)
app.add_typer(rig_app, name="rig")


def _tank(tank_toml: Path | None, fill: float | None) -> Tank:
    tank = Tank.from_toml(tank_toml) if tank_toml is not None else Tank()
    return tank.replace(fill=fill) if fill is not None else tank


def _make_rig(tank: Tank, seed: int) -> Any:
    # import_module (not ``from sloshrom import rig``) so that tests can substitute the module.
    try:
        rig_mod = importlib.import_module("sloshrom.rig")
    except ImportError as exc:
        fail(f"the virtual rig (sloshrom.rig) is not available: {exc}")
    return rig_mod.VirtualRig(tank=tank, seed=seed)


def _provenance(kind: str, signal: dict[str, Any], rig: Any) -> dict[str, Any]:
    from sloshrom import __version__

    return {
        "generator": f"sloshrom rig {kind}",
        "command": shlex.join(["sloshrom", *sys.argv[1:]]) if sys.argv else "",
        "sloshrom_version": __version__,
        "created_utc": datetime.now(UTC).strftime("%Y-%m-%dT%H:%M:%SZ"),
        "rig": type(rig).__name__,
        "rig_dt": float(rig.dt),
        "signal": signal,
    }


def _run(rig: Any, acceleration: np.ndarray, tank: Tank, truth: bool, label: str, **attrs: Any):
    from rich.progress import Progress, SpinnerColumn, TextColumn, TimeElapsedColumn

    from sloshrom.data import record_from_measurement

    with Progress(
        SpinnerColumn(), TextColumn("{task.description}"), TimeElapsedColumn(), transient=True
    ) as progress:
        progress.add_task(label, total=None)
        measurement = rig.measure(acceleration)
    return record_from_measurement(measurement, tank, truth=truth, **attrs)


def _write(record, out: Path) -> None:
    from sloshrom.data import write_record

    write_record(record, out)
    df = record["dynamic_force"]
    msg = (
        f"wrote {out}: {len(record)} samples at {record.fs:g} Hz ({record.duration:.1f} s), "
        f"dynamic force RMS {np.sqrt(np.mean(df**2)):.4g} N"
    )
    if "true_dynamic_force" in record:
        err = df - record["true_dynamic_force"]
        msg += f", preprocessing error RMS {np.sqrt(np.mean(err**2)):.3g} N"
    typer.echo(msg)


TankOpt = Annotated[
    Path | None, typer.Option("--tank", help="TOML file with a \\[tank] table (SI units).")
]
FillOpt = Annotated[
    float | None, typer.Option("--fill", help="Fill level d/h in (0, 1); overrides the tank's.")
]
TruthOpt = Annotated[
    bool,
    typer.Option(
        "--truth/--no-truth", help="Also store the rig's noise-free velocity and dynamic force."
    ),
]


@rig_app.command("vfa")
def vfa_cmd(
    out: Annotated[Path, typer.Option("--out", "-o", help="Output record (.nc).")],
    split: Annotated[
        str, typer.Option("--split", help="Path family: 'train' (480 s) or 'validation' (240 s).")
    ] = "train",
    seed: Annotated[int, typer.Option("--seed", help="Seed of the path phase and rig noise.")] = 0,
    duration: Annotated[
        float | None, typer.Option("--duration", help="s; default 480 (train) / 240 (validation).")
    ] = None,
    tank_toml: TankOpt = None,
    fill: FillOpt = None,
    truth: TruthOpt = True,
) -> None:
    """Variable-frequency-and-amplitude (VFA) test on the virtual rig (paper section 2.1).

    Example: sloshrom rig vfa --split validation --out data/validation.nc --seed 2
    """
    from sloshrom.signals import vfa

    if split not in ("train", "validation"):
        fail(f"--split must be 'train' or 'validation', got {split!r}")
    try:
        tank = _tank(tank_toml, fill)
        rig = _make_rig(tank, seed)
        path = vfa(1.0 / rig.dt, split, duration=duration, tank=tank, seed=seed)
        acc, t_end = path.acceleration, float(path.time[-1])
        del path  # ~40 MB per array at the rig's 10 kHz: keep only what the rig needs
        signal = {"kind": "vfa", "split": split, "seed": seed, "duration": t_end}
        rec = _run(
            rig,
            acc,
            tank,
            truth,
            f"VFA {split}: {t_end:.0f} s on the virtual rig",
            seed=seed,
            split=split,
            provenance=_provenance("vfa", signal, rig),
        )
        _write(rec, out)
    except (ConfigError, ValueError, OSError) as exc:
        fail(str(exc))


@rig_app.command("harmonic")
def harmonic_cmd(
    out: Annotated[Path, typer.Option("--out", "-o", help="Output record (.nc).")],
    frequency: Annotated[float, typer.Option("--frequency", "-f", help="Hz.")],
    amplitude: Annotated[
        float | None, typer.Option("--amplitude", "-a", help="Displacement amplitude a, m.")
    ] = None,
    accel_g: Annotated[
        float | None,
        typer.Option("--accel-g", help="Acceleration amplitude a Omega^2 in g (instead of -a)."),
    ] = None,
    cycles: Annotated[int, typer.Option("--cycles", help="Steady cycles.")] = 20,
    seed: Annotated[int, typer.Option("--seed", help="Seed of the rig noise.")] = 0,
    tank_toml: TankOpt = None,
    fill: FillOpt = None,
    truth: TruthOpt = True,
) -> None:
    """Ramped harmonic test ``w = a cos(2 pi f t)`` on the virtual rig.

    Example: sloshrom rig harmonic --frequency 12 --accel-g 4 --out h12.nc
    """
    from sloshrom.signals import harmonic

    if (amplitude is None) == (accel_g is None):
        fail("give exactly one of --amplitude (m) and --accel-g (g)")
    try:
        if frequency <= 0 or not np.isfinite(frequency):
            raise ValueError(f"--frequency must be positive, got {frequency!r}")
        om = 2.0 * np.pi * frequency
        a = float(amplitude) if amplitude is not None else float(accel_g) * G / om**2
        tank = _tank(tank_toml, fill)
        rig = _make_rig(tank, seed)
        h = harmonic(1.0 / rig.dt, frequency, a, n_cycles=cycles)
        signal = {
            "kind": "harmonic",
            "frequency": float(frequency),
            "amplitude": a,
            "accel_g": a * om**2 / G,
            "omega_bar": om / tank.reference_frequency,
            "a_bar": a / tank.height,
            "steady_start_s": h.steady.start * rig.dt,
            "steady_stop_s": h.steady.stop * rig.dt,
        }
        rec = _run(
            rig,
            h.acceleration,
            tank,
            truth,
            f"harmonic {frequency:g} Hz, {a * 1e3:.3g} mm on the virtual rig",
            seed=seed,
            frequency=float(frequency),
            amplitude=a,
            provenance=_provenance("harmonic", signal, rig),
        )
        _write(rec, out)
    except (ConfigError, ValueError, OSError) as exc:
        fail(str(exc))
