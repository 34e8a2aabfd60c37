"""``sloshrom rig``: virtual-rig shaker records (VFA training/validation data, harmonic tests).

Each command generates the commanded tank acceleration at the rig's fine step, runs
``sloshrom.rig.VirtualRig.measure``, preprocesses the measurement as for real shaker data
(velocity by integrating the measured acceleration, dynamic force = force + inertia) and writes a
NetCDF record with ``time``, ``acceleration``, ``velocity``, ``force``, ``dynamic_force`` (plus the
rig's noise-free ``true_velocity``/``true_dynamic_force`` unless ``--no-truth``).
"""

from __future__ import annotations

import shlex
import sys
from datetime import UTC, datetime
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any

import numpy as np
import typer

from sloshrom import __version__
from sloshrom.cli._app import app, check_input, check_number, check_out, fail, warn
from sloshrom.cli.progress import progress_bars
from sloshrom.config import G, Tank
from sloshrom.errors import SloshromError
from sloshrom.io import Record, record_from_measurement, write_record
from sloshrom.io.programme import read_drive, resample_drive
from sloshrom.limits import MAX_SEED
from sloshrom.rig.limits import MAX_FINE_SECONDS, MIN_VFA_DURATION
from sloshrom.signals import SHAKER_ENVELOPE, harmonic, vfa
from sloshrom.signals import SHAKER_LIMITS as _LIMITS

if TYPE_CHECKING:
    from sloshrom.rig.virtual import VirtualRig

rig_app = typer.Typer(
    help="Generate virtual-rig shaker records (the paper's VFA data and harmonic tests).",
    no_args_is_help=True,
)
app.add_typer(rig_app, name="rig")


RECORD_SUFFIXES = (".nc", ".csv", ".mat")
#: Passband of the rig's sensors (SensorParams: anti-alias at 0.8 x the Nyquist frequency of the
#: 500 Hz output rate); a sine above it is attenuated (300 Hz: 0.5 % of its amplitude is left).
SENSOR_PASSBAND = 0.8 * 500.0 / 2
#: The rig's calibrated domain (the paper's shaker envelope, estimates): outside it the record
#: is made but the sloshing physics is extrapolated, hence a warning.
CALIBRATED_BAND = (SHAKER_ENVELOPE.f_min, SHAKER_ENVELOPE.f_max)  # Hz
#: ``VirtualRig.measure`` needs 40 samples at the 500 Hz output rate (its sensor filters).
MIN_SENSOR_SECONDS = 40 / 500.0
SHAKER_LIMITS = {"displacement": _LIMITS.max_displacement, "velocity": _LIMITS.max_velocity,
                 "acceleration": SHAKER_ENVELOPE.gamma_max}  # m, m/s, g
#: Beyond ten times the shaker's limits the rig's model means nothing: refused.
HARD_FACTOR = 10.0
_MEMORY = ("at the rig's 10 kHz step a run needs about 1.6 MB of memory per second "
           "(1 h: about 6 GB)")


def _tank(tank_toml: Path | None, fill: float | None) -> Tank:
    """The tank of the command (a user error, naming the file, if the TOML is bad)."""
    try:
        tank = Tank.from_toml(tank_toml) if tank_toml is not None else Tank()
        return tank.replace(fill=fill) if fill is not None else tank
    except SloshromError as exc:
        msg = str(exc)
        fail(msg if tank_toml is None or str(tank_toml) in msg else f"--tank {tank_toml}: {msg}")


def _check_common(out: Path, seed: int, fill: float | None, tank_toml: Path | None) -> Tank:
    check_number(seed, "--seed", 0, MAX_SEED)
    check_number(fill, "--fill", 0.0, 1.0, lo_open=True, hi_open=True,
                 why="liquid depth / tank height")
    check_input(tank_toml, "--tank")
    check_out(out, suffixes=RECORD_SUFFIXES, inputs=(tank_toml,))
    return _tank(tank_toml, fill)


def _make_rig(tank: Tank, seed: int) -> VirtualRig:
    """The virtual rig of the command (imported here: it loads numba, slow for ``--help``)."""
    from sloshrom.rig.virtual import VirtualRig

    try:  # a tank the rig cannot model (an extreme fill) is refused before the run
        return VirtualRig(tank=tank, seed=seed)
    except SloshromError as exc:
        fail(str(exc))


def _provenance(kind: str, signal: dict[str, Any], rig: VirtualRig) -> dict[str, Any]:
    return {
        "generator": f"sloshrom rig {kind}",
        "command": shlex.join(["sloshrom", *sys.argv[1:]]) if sys.argv else "",
        "sloshrom_version": __version__,
        "created_utc": datetime.now(UTC).strftime("%Y-%m-%dT%H:%M:%SZ"),
        "rig": type(rig).__name__,
        "rig_dt": float(rig.dt),
        "signal": signal,
    }


def _run(rig: VirtualRig, acceleration: np.ndarray, tank: Tank, truth: bool, label: str,
         **attrs: Any) -> Record:
    from rich.progress import SpinnerColumn, TextColumn, TimeElapsedColumn

    with progress_bars(
        SpinnerColumn(), TextColumn("{task.description}"), TimeElapsedColumn(), transient=True
    ) as progress:
        progress.add_task(label, total=None)
        measurement = rig.measure(acceleration)
    return record_from_measurement(measurement, tank, truth=truth, **attrs)


def _write(record, out: Path) -> None:
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
    out: Annotated[Path, typer.Option("--out", "-o", help="Output record (.nc, .csv or .mat).")],
    split: Annotated[
        str, typer.Option("--split", help="Path family: 'train' (480 s) or 'validation' (240 s).")
    ] = "train",
    seed: Annotated[int, typer.Option("--seed", help="Seed of the path phase and rig noise "
                                                     "(>= 0).")] = 0,
    duration: Annotated[
        float | None, typer.Option("--duration", help="s; default 480 (train) / 240 (validation);"
                                                      f" {MIN_VFA_DURATION:g} s to "
                                                      f"{MAX_FINE_SECONDS:g} s (memory).")
    ] = None,
    tank_toml: TankOpt = None,
    fill: FillOpt = None,
    truth: TruthOpt = True,
) -> None:
    """Variable-frequency-and-amplitude (VFA) test on the virtual rig (paper section 2.1).

    Durations are bounded by memory: the rig runs at 10 kHz and holds about 20 arrays per fine
    sample (1.6 MB per second of record), so 1 h (the maximum) needs about 6 GB.

    Example: sloshrom rig vfa --split validation --out data/validation.nc --seed 2
    """
    if split not in ("train", "validation"):
        fail(f"--split must be 'train' or 'validation', got {split!r}")
    check_number(duration, "--duration", MIN_VFA_DURATION, MAX_FINE_SECONDS, unit="s",
                 why=f"the shortest VFA path is {MIN_VFA_DURATION:g} s; {_MEMORY}")
    tank = _check_common(out, seed, fill, tank_toml)
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


@rig_app.command("harmonic")
def harmonic_cmd(
    out: Annotated[Path, typer.Option("--out", "-o", help="Output record (.nc, .csv or .mat).")],
    frequency: Annotated[float, typer.Option(
        "--frequency", "-f", help=f"Hz, up to {SENSOR_PASSBAND:g} (the sensors' passband); "
                                  f"outside {CALIBRATED_BAND[0]:g}-{CALIBRATED_BAND[1]:g} Hz "
                                  "(the calibrated shaker band) with a warning.")],
    amplitude: Annotated[
        float | None, typer.Option("--amplitude", "-a", help="Displacement amplitude a, m.")
    ] = None,
    accel_g: Annotated[
        float | None,
        typer.Option("--accel-g", help="Acceleration amplitude a Omega^2 in g (instead of -a)."),
    ] = None,
    cycles: Annotated[int, typer.Option("--cycles", help="Steady cycles (>= 1).")] = 20,
    seed: Annotated[int, typer.Option("--seed", help="Seed of the rig noise (>= 0).")] = 0,
    tank_toml: TankOpt = None,
    fill: FillOpt = None,
    truth: TruthOpt = True,
) -> None:
    """Ramped harmonic test ``w = a cos(2 pi f t)`` on the virtual rig.

    Refused: frequencies above the sensors' passband (200 Hz: the 500 Hz record would hold an
    attenuated, meaningless sine), amplitudes beyond ten times the shaker's limits (60 g,
    0.125 m, 10 m/s) and tests longer than 1 h at the rig's 10 kHz step (memory). Recorded with
    a warning: tests outside the rig's calibrated domain (5-25 Hz, 6 g, 12.5 mm, 1 m/s), where
    the sloshing physics is extrapolated.

    Example: sloshrom rig harmonic --frequency 12 --accel-g 4 --out h12.nc
    """
    if (amplitude is None) == (accel_g is None):
        fail("give exactly one of --amplitude (m) and --accel-g (g)")
    check_number(frequency, "--frequency", 0.0, SENSOR_PASSBAND, lo_open=True, unit="Hz",
                 why="the rig's sensors record 500 Hz after an anti-alias filter at 200 Hz")
    hard = {k: HARD_FACTOR * v for k, v in SHAKER_LIMITS.items()}
    check_number(amplitude, "--amplitude", 0.0, hard["displacement"], lo_open=True, unit="m",
                 why="ten times the shaker's stroke")
    check_number(accel_g, "--accel-g", 0.0, hard["acceleration"], lo_open=True, unit="g",
                 why="ten times the shaker's acceleration limit")
    check_number(cycles, "--cycles", 1)
    n_ramp, n_settle = 3, 2  # the defaults of signals.harmonic
    seconds = (2 * n_ramp + n_settle + cycles) / frequency
    if seconds > MAX_FINE_SECONDS:
        fail(f"--cycles {cycles} at {frequency:g} Hz make a {seconds:.4g} s test, more than "
             f"{MAX_FINE_SECONDS:g} s ({_MEMORY})")
    if seconds < MIN_SENSOR_SECONDS:
        fail(f"--cycles {cycles} at {frequency:g} Hz make a {seconds:.3g} s test; the sensors' "
             f"filters need at least {MIN_SENSOR_SECONDS:g} s (40 samples at 500 Hz): give more "
             "--cycles")
    om = 2.0 * np.pi * frequency
    a = float(amplitude) if amplitude is not None else float(accel_g) * G / om**2
    opt = "--amplitude" if amplitude is not None else "--accel-g"
    for name, value, limit, unit in (("displacement", a, "displacement", "m"),
                                     ("acceleration", a * om**2 / G, "acceleration", "g"),
                                     ("velocity", a * om, "velocity", "m/s")):
        if value > hard[limit] * (1 + 1e-12):
            article = "an" if name[0] in "aeiou" else "a"
            fail(f"{opt} at {frequency:g} Hz gives {article} {name} amplitude of {value:.4g} "
                 f"{unit}, "
                 f"beyond ten times the shaker's limit ({SHAKER_LIMITS[limit]:g} {unit})")
    tank = _check_common(out, seed, fill, tank_toml)
    lo, hi = CALIBRATED_BAND
    if not lo <= frequency <= hi:
        warn(f"{frequency:g} Hz is outside the rig's calibrated band {lo:g}-{hi:g} Hz: the "
             "sloshing force is extrapolated")
    over = [f"{name} {value:.3g} {unit} > {SHAKER_LIMITS[limit]:g} {unit}"
            for name, value, limit, unit in (("displacement", a, "displacement", "m"),
                                             ("acceleration", a * om**2 / G, "acceleration", "g"),
                                             ("velocity", a * om, "velocity", "m/s"))
            if value > SHAKER_LIMITS[limit] * (1 + 1e-9)]
    if over:
        warn(f"beyond the shaker's limits ({', '.join(over)}): the rig is not calibrated there")
    rig = _make_rig(tank, seed)
    h = harmonic(1.0 / rig.dt, frequency, a, n_cycles=cycles, n_ramp=n_ramp, n_settle=n_settle)
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


@rig_app.command("play")
def play_cmd(
    drive: Annotated[Path, typer.Argument(
        help="Drive file as `sloshrom design` writes it: the CSV (time_s and "
             "acceleration_m_s2 or acceleration_g columns) or the UFF 58 (.uff/.unv: its "
             "segments played back to back).")],
    out: Annotated[Path, typer.Option("--out", "-o", help="Output record (.nc, .csv or .mat).")],
    seed: Annotated[int, typer.Option("--seed", help="Seed of the rig noise (>= 0).")] = 0,
    tank_toml: TankOpt = None,
    fill: FillOpt = None,
    truth: TruthOpt = True,
) -> None:
    """Play a drive file on the virtual rig, as the laboratory's shaker would.

    The time column must be uniform and the values finite; a drive at another rate than the
    rig's 10 kHz integration step is resampled to it, band-limited (80 dB anti-alias filter,
    pass band 80 % of the lower Nyquist frequency). A UFF 58 drive plays its segments back to
    back (the pauses of a CSV are not in it). Refused: NaN, a non-uniform time, unknown columns
    or units, a file that is not text (CSV) or not UFF, a rate below 50 Hz or one whose ratio
    to 10 kHz is not a fraction with a denominator up to 10,000 (a whole number of Hz always
    is; 2000.5 Hz is too, 2000.3 Hz is not), drives longer than 1 h (memory) and accelerations
    beyond ten times the shaker's limit (60 g). Recorded with a warning: a drive that does not
    start and end at rest, or beyond the shaker's limits.

    Example: sloshrom design --out lab --split train; sloshrom rig play lab/train.csv --out
    train.nc
    """
    check_input(drive, "DRIVE")
    tank = _check_common(out, seed, fill, tank_toml)
    check_out(out, suffixes=RECORD_SUFFIXES, inputs=(drive, tank_toml))
    try:
        d = read_drive(drive)
    except SloshromError as exc:
        fail(str(exc))
    if d.fs < 2 * CALIBRATED_BAND[1]:
        fail(f"{drive}: a {d.fs:.6g} Hz drive cannot carry the shaker band "
             f"{CALIBRATED_BAND[0]:g}-{CALIBRATED_BAND[1]:g} Hz (use at least "
             f"{2 * CALIBRATED_BAND[1]:g} Hz)")
    if d.duration > MAX_FINE_SECONDS:
        fail(f"{drive}: {d.duration:.6g} s of drive, more than {MAX_FINE_SECONDS:g} s "
             f"({_MEMORY})")
    if d.duration < MIN_SENSOR_SECONDS:
        fail(f"{drive}: {d.duration:.3g} s of drive; the sensors' filters need at least "
             f"{MIN_SENSOR_SECONDS:g} s")
    peak = float(np.max(np.abs(d.acceleration)))
    hard = HARD_FACTOR * SHAKER_LIMITS["acceleration"]
    if peak / G > hard:
        fail(f"{drive}: peak acceleration {peak / G:.4g} g, beyond ten times the shaker's "
             f"limit ({hard:g} g)")
    ends = max(abs(d.acceleration[0]), abs(d.acceleration[-1]))
    if peak and ends > 1e-6 * peak:
        warn(f"{drive}: the drive does not start and end at rest (first/last sample "
             f"{d.acceleration[0]:.3g}/{d.acceleration[-1]:.3g} m/s^2): a shaker would jump")
    rig = _make_rig(tank, seed)
    fine = 1.0 / rig.dt
    try:
        acc = resample_drive(d.acceleration, d.fs, fine) if d.fs != fine else d.acceleration
    except SloshromError as exc:
        fail(f"{drive}: {exc}")
    v = np.concatenate([[0.0], np.cumsum(0.5 * (acc[1:] + acc[:-1]))]) * rig.dt
    x = np.concatenate([[0.0], np.cumsum(0.5 * (v[1:] + v[:-1]))]) * rig.dt
    over = [f"{name} {value:.3g} {unit} > {SHAKER_LIMITS[name]:g} {unit}"
            for name, value, unit in (("acceleration", float(np.max(np.abs(acc))) / G, "g"),
                                      ("velocity", float(np.max(np.abs(v))), "m/s"),
                                      ("displacement", float(np.max(np.abs(x))), "m"))
            if value > SHAKER_LIMITS[name] * (1 + 1e-9)]
    if over:
        warn(f"beyond the shaker's limits ({', '.join(over)}): the rig is not calibrated there")
    del v, x
    signal = {"kind": "file", "file": str(drive), "file_fs": float(d.fs),
              "file_column": d.column, "samples": int(d.acceleration.size),
              "duration": float(d.duration)}
    rec = _run(rig, acc, tank, truth, f"{drive.name}: {d.duration:.0f} s on the virtual rig",
               seed=seed, provenance=_provenance("play", signal, rig))
    _write(rec, out)
