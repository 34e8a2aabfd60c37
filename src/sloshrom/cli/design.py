"""``sloshrom design``: the identification test as drive files a shaker controller plays.

The programme is the one the ``data`` stage of ``sloshrom reproduce`` records for the
configuration (:func:`sloshrom.pipeline.data.programme`); this command writes it as CSV and
UFF 58 drive files at a controller's rate, checks it against a shaker and says how long the
laboratory will take. The library is imported inside the command: ``sloshrom --help`` must not
load JAX, xarray and matplotlib.
"""

from __future__ import annotations

import dataclasses
import json
import shlex
import sys
from collections.abc import Sequence
from datetime import UTC, datetime
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Literal

import numpy as np
import typer

from sloshrom import __version__
from sloshrom.cli._app import OverwriteOpt, app, check_number, check_out, fail, warn
from sloshrom.cli.pipeline import load_config
from sloshrom.config import G
from sloshrom.errors import SloshromError
from sloshrom.fileio import OutputBatch
from sloshrom.io.programme import drive_uff_sets, exact_uff_step, resample_drive, write_drive_csv
from sloshrom.io.uff import write_uff_sets
from sloshrom.rig.limits import RIG_RATE
from sloshrom.signals import SHAKER_LIMITS, ShakerLimits

if TYPE_CHECKING:
    from rich.table import Table

    from sloshrom.pipeline.data import Peaks, ProgrammeOutputs

FORMATS = ("csv", "uff")
SPLITS = ("train", "validation")
#: Default rate of the drive files, Hz: see :func:`design_cmd`.
DRIVE_FS = 2000
#: Lowest drive rate, Hz: the files keep the programme's content to 200 Hz (the rig sensors'
#: band; the decays' third beam mode lies between 200 and 250 Hz) with a 20 % transition band.
MIN_DRIVE_FS = 500
#: The unit of a segment's level in the table (``programme.json`` says it in words).
SHORT = {"vfa": "g peak", "random": "g rms", "decay": "x tip"}
#: Longest pause between segments, s.
MAX_PAUSE = 3600.0
#: How the command records its files in OUT (it replaces only those: ``check_out``'s owner).
OWNER = "sloshrom design"


def _formats(text: str) -> list[str]:
    items = [f.strip().lower() for f in text.split(",") if f.strip()]
    unknown = [f for f in items if f not in FORMATS]
    if unknown or not items:
        fail(f"--format {text!r}: unknown format {', '.join(map(repr, unknown)) or '(none)'} "
             f"(use a comma-separated list of {', '.join(FORMATS)})")
    return list(dict.fromkeys(items))


def _hms(seconds: float) -> str:
    """A duration as ``1 h 05 min 12 s`` (what a lab plans with)."""
    s = int(round(seconds))
    h, rest = divmod(s, 3600)
    m, sec = divmod(rest, 60)
    return (f"{h} h {m:02d} min" if h else f"{m} min {sec:02d} s" if m else f"{sec} s")


def _segment_numbers(lengths: list[int], pause: int) -> np.ndarray:
    """The CSV's ``segment`` column: 1, 2, ... per sample, 0 in the pauses."""
    parts = []
    for k, n in enumerate(lengths):
        if k:
            parts.append(np.zeros(pause, dtype=int))
        parts.append(np.full(n, k + 1, dtype=int))
    return np.concatenate(parts)


def _table(split: str, out: ProgrammeOutputs, limits: ShakerLimits) -> Table:
    from rich.table import Table

    lim = {"acceleration_g": limits.max_acceleration / G, "velocity_m_s": limits.max_velocity,
           "stroke_mm": limits.max_displacement * 1e3}
    tab = Table(title=f"{split} programme: {len(out['segments'])} segments, "
                      f"{out['duration_s']:.1f} s, laboratory {_hms(out['lab_time_s'])}",
                title_justify="left")
    columns: tuple[tuple[str, Literal["left", "right"]], ...] = (
        ("#", "right"), ("segment", "left"), ("level", "right"), ("length s", "right"),
        ("accel. g", "right"), ("vel. m/s", "right"), ("stroke mm", "right"))
    for col, just in columns:
        tab.add_column(col, justify=just, no_wrap=True)

    def cells(p: Peaks) -> list[str]:
        out = []
        for key, value, fmt in (("acceleration_g", p["acceleration_g"], ".3g"),
                                ("velocity_m_s", p["velocity_m_s"], ".3g"),
                                ("stroke_mm", p["stroke_mm"], ".4g")):
            text = format(value, fmt)
            out.append(f"[bold red]{text}[/]" if value > lim[key] * (1 + 1e-9) else text)
        return out

    segs = out["segments"]
    for k, s in enumerate(segs):
        tab.add_row(str(s["index"]), s["name"], f"{s['level']:.3g} {SHORT[s['kind']]}",
                    f"{s['duration_s']:.1f}", *cells(s["peaks"]),
                    end_section=k == len(segs) - 1)
    tab.add_row("", "programme", "", f"{out['duration_s']:.1f}", *cells(out["peaks"]))
    return tab


@app.command("design")
def design_cmd(
    out: Annotated[Path, typer.Option("--out", "-o", help="Output directory (created).")],
    config: Annotated[Path | None, typer.Option(
        help="TOML file overriding the defaults of `sloshrom reproduce` (its [data] design, "
             "[beam] tests and [rig] rate make the programme).")] = None,
    quick: Annotated[bool, typer.Option(help="The --quick sizes of `sloshrom reproduce`.")
                     ] = False,
    split: Annotated[str, typer.Option(help="'train', 'validation' or 'both'.")] = "both",
    max_stroke: Annotated[float, typer.Option(
        "--max-stroke", help="Shaker stroke, mm (amplitude: half the peak-to-peak travel).")
    ] = SHAKER_LIMITS.max_displacement * 1e3,
    max_velocity: Annotated[float, typer.Option(
        "--max-velocity", help="Shaker velocity limit, m/s.")] = SHAKER_LIMITS.max_velocity,
    max_acceleration: Annotated[float, typer.Option(
        "--max-acceleration", help="Shaker acceleration limit, g (with the tank's mass on "
                                   "the table).")] = SHAKER_LIMITS.max_acceleration / G,
    max_duration: Annotated[float | None, typer.Option(
        "--max-duration", help="Longest run the shaker (amplifier duty cycle) allows, s.")
    ] = None,
    setup: Annotated[float, typer.Option(
        help="Laboratory set-up per segment, s (loading the drive, the controller's pre-test)."
    )] = 60.0,
    pause: Annotated[float, typer.Option(
        help="Rest between segments in the CSV, s (0: back to back, as `reproduce` records "
             "it).")] = 0.0,
    fs: Annotated[int, typer.Option(
        "--fs", help=f"Rate of the drive files, Hz (whole number, {MIN_DRIVE_FS} to "
                     f"{RIG_RATE:g}); e.g. 2048 or 5120 for a controller that wants them.")
    ] = DRIVE_FS,
    formats: Annotated[str, typer.Option(
        "--format", help="Files to write: a comma-separated list of csv, uff (e.g. "
                         "csv,uff for both; each is the whole programme: about 20 bytes a "
                         "sample in CSV, 20 in UFF).")] = "csv",
    segment_column: Annotated[bool, typer.Option(
        "--segment-column/--no-segment-column",
        help="Add a 'segment' column to the CSV (1, 2, ...; 0 in a pause).")] = False,
    strict: Annotated[bool, typer.Option(
        help="Exit with code 1, writing nothing, if the programme exceeds a shaker limit.")
    ] = False,
    overwrite: OverwriteOpt = False,
) -> None:
    """Write the identification test as drive files, check them against a shaker and say how
    long the laboratory will take.

    The programme is the one `sloshrom reproduce` records in its data stage for the
    configuration: the paper's VFA, with a "structure" or "use" [data] design the extension
    VFA, and with "use" the structure's own motion (narrow-band random and decay segments);
    every segment starts and ends at rest.

    Files in OUT: <split>.csv (time_s,acceleration_m_s2: the whole programme; the default
    format), with --format uff or csv,uff <split>.uff (UFF 58, m/s^2, one dataset per
    segment, each from 0 s), and programme.json (segments, peaks, the shaker check,
    laboratory time); see docs/formats.md. The console says about how large the files will be
    before it writes them, and their sizes after (the default programme: about 60 MB of CSV
    at 2000 Hz). They are resampled from the rig's 10 kHz to --fs with an 80 dB anti-alias
    filter whose pass band is 80 % of the Nyquist frequency: the default 2000 Hz keeps all of
    the programme (its content ends at 250 Hz), divides 10 kHz exactly, gives an exact UFF
    time step and 10 samples per cycle at 200 Hz.

    A limit exceeded is said in a sentence; the exit code is 0 unless --strict. A file of
    these names in OUT that `sloshrom design` did not write (a laboratory's own train.csv) is
    refused, named, unless --overwrite.

    Example: sloshrom design --out lab --config my.toml --max-acceleration 20 --max-stroke 25
    """
    if split not in (*SPLITS, "both"):
        fail(f"--split must be 'train', 'validation' or 'both', got {split!r}")
    fmts = _formats(formats)
    check_number(max_stroke, "--max-stroke", 0.0, lo_open=True, unit="mm")
    check_number(max_velocity, "--max-velocity", 0.0, lo_open=True, unit="m/s")
    check_number(max_acceleration, "--max-acceleration", 0.0, lo_open=True, unit="g")
    check_number(max_duration, "--max-duration", 0.0, lo_open=True, unit="s")
    check_number(setup, "--setup", 0.0, 86400.0, unit="s")
    check_number(pause, "--pause", 0.0, MAX_PAUSE, unit="s")
    check_number(fs, "--fs", MIN_DRIVE_FS, int(RIG_RATE), unit="Hz",
                 why="the drive keeps the programme's content to 200 Hz; the programme is "
                     "made at the rig's 10 kHz")
    splits = list(SPLITS) if split == "both" else [split]
    names = [f"{s}.{f}" for s in splits for f in fmts] + ["programme.json"]
    check_out(out, directory=True, inputs=(config,), contents=tuple(names), owner=OWNER,
              overwrite=overwrite)
    limits = ShakerLimits(max_stroke * 1e-3, max_velocity, max_acceleration * G)

    from rich.console import Console

    from sloshrom.pipeline.data import programme, programme_outputs, to_ms, training_design

    cfg = load_config(config, quick)
    if "uff" in fmts and not exact_uff_step(fs):
        warn(f"UFF stores the time step with 6 significant digits: at {fs} Hz the UFF files "
             f"read back at {1 / float(f'{1 / fs:.5e}'):.7g} Hz (the CSV is exact); a rate "
             "such as 2000, 2500, 4000 or 5000 Hz has an exact step")
    console = Console()
    summaries: dict[str, ProgrammeOutputs] = {}
    drives: dict[str, tuple[list[tuple[str, np.ndarray]], np.ndarray]] = {}
    try:
        tank = cfg.tank.tank()
        with console.status("training design (frozen beam tests)"):
            training = training_design(cfg, tank)
        for s in splits:
            with console.status(f"{s} programme at the rig's {RIG_RATE:g} Hz"):
                prog = dataclasses.replace(programme(cfg, tank, s, RIG_RATE, training=training),
                                           pause=float(pause))
                summ = programme_outputs(prog, limits, setup, max_duration)
                segs = [(g.name, resample_drive(g.acceleration, RIG_RATE, fs))
                        for g in prog.segments]
            del prog  # ~80 MB per 1000 s at 10 kHz: keep only the drive's rate
            gap = int(round(pause * fs))
            whole = np.concatenate([x for k, (_, a) in enumerate(segs)
                                    for x in ((np.zeros(gap),) if k else ()) + (a,)])
            summ["drive"] = {"fs_hz": float(fs), "samples": int(whole.size),
                             "duration_s": to_ms((whole.size - 1) / fs),
                             "peak_acceleration_g": float(np.max(np.abs(whole))) / G}
            summaries[s] = summ
            drives[s] = (segs, whole)
    except SloshromError as exc:
        fail(str(exc))

    for s in splits:
        console.print(_table(s, summaries[s], limits))
    exceeded = [(s, sentence) for s in splits for sentence in summaries[s]["exceeds"]]
    for s, sentence in exceeded:
        warn(f"{s}: {sentence}")
    total = sum(summaries[s]["duration_s"] for s in splits)
    lab = sum(summaries[s]["lab_time_s"] for s in splits)
    n_seg = sum(len(summaries[s]["segments"]) for s in splits)
    shaker = (f"{max_acceleration:.3g} g, {max_velocity:.3g} m/s, {max_stroke:.3g} mm"
              + (f", {max_duration:g} s" if max_duration is not None else ""))
    console.print(f"shaker {shaker}: " + ("[green]the programme fits[/]" if not exceeded else
                  f"[bold red]{len(exceeded)} limit(s) exceeded[/]"))
    console.print(f"total {total:.0f} s of shaking ({_hms(total)}); laboratory time "
                  f"{_hms(lab)} ({n_seg} runs with {setup:g} s set-up each)")
    segments = [(sg["name"], sg["peaks"]) for s in splits for sg in summaries[s]["segments"]]
    for line in _beyond_the_shaker(segments, max_acceleration, max_velocity, max_stroke):
        console.print(line, markup=False, highlight=False)
    if strict and exceeded:
        typer.secho("error: the programme exceeds the shaker's limits (--strict): nothing "
                    "written", fg=typer.colors.RED, err=True)
        raise typer.Exit(code=1)

    samples = sum(drives[s][1].size for s in splits)
    per_sample = {"csv": CSV_BYTES_PER_SAMPLE, "uff": UFF_BYTES_PER_SAMPLE}
    console.print(f"writing {samples:,} samples at {fs} Hz as {' and '.join(fmts)}: about "
                  f"{samples * sum(per_sample[f] for f in fmts) / 1e6:.3g} MB", highlight=False)
    summary = {
        "generator": "sloshrom design",
        "sloshrom_version": __version__,
        "command": shlex.join(["sloshrom", *sys.argv[1:]]) if sys.argv else "",
        "created_utc": datetime.now(UTC).strftime("%Y-%m-%dT%H:%M:%SZ"),
        "config": None if config is None else str(config),
        "quick": quick,
        "data_design": cfg.data.design,
        "drive": {"fs_hz": float(fs), "programme_fs_hz": RIG_RATE, "pause_s": float(pause),
                  "formats": fmts, "csv_columns": ["time_s", "acceleration_m_s2"]
                  + (["segment"] if segment_column else []),
                  "uff": "one dataset 58 per segment, m/s^2, each from 0 s",
                  "resampling": "polyphase, Kaiser FIR 80 dB, pass band 0.8 x Nyquist"},
        "shaker": {"acceleration_g": max_acceleration, "velocity_m_s": max_velocity,
                   "stroke_mm": max_stroke, "max_duration_s": max_duration},
        "splits": summaries,
        "total": {"duration_s": total, "lab_time_s": lab, "segments": n_seg},
        "exceeds": [f"{s}: {t}" for s, t in exceeded],
    }
    try:
        with OutputBatch(owner=OWNER) as batch:
            for s in splits:
                segs, whole = drives[s]
                files: dict[str, str] = {}
                if "csv" in fmts:
                    seg = (_segment_numbers([a.size for _, a in segs], int(round(pause * fs)))
                           if segment_column else None)
                    files["csv"] = write_drive_csv(out / f"{s}.csv", whole, fs, seg,
                                                   batch=batch).name
                if "uff" in fmts:
                    run = f"sloshrom design: {s} programme ({cfg.data.design} design)"
                    files["uff"] = write_uff_sets(drive_uff_sets(segs, fs, run),
                                                  out / f"{s}.uff", batch=batch).name
                summaries[s]["files"] = files
            batch.write_text(out / "programme.json", json.dumps(summary, indent=1) + "\n")
    except (SloshromError, OSError) as exc:
        fail(f"--out {out}: {exc}")
    console.print("wrote " + ", ".join(f"{out / n} ({_size(out / n)})" for n in names),
                  highlight=False)


def _beyond_the_shaker(segments: Sequence[tuple[str, Peaks]],
                       max_acceleration: float, max_velocity: float,
                       max_stroke: float) -> list[str]:
    """The segments (name, peaks) beyond each shaker limit, by name, and the two ways out: a
    programme the shaker can play, or the options of a larger shaker; [] when it fits."""
    limits = (("acceleration_g", max_acceleration, "acceleration", "g", "--max-acceleration"),
              ("velocity_m_s", max_velocity, "velocity", "m/s", "--max-velocity"),
              ("stroke_mm", max_stroke, "stroke", "mm", "--max-stroke"))
    values = [(name, {"acceleration_g": p["acceleration_g"], "velocity_m_s": p["velocity_m_s"],
                      "stroke_mm": p["stroke_mm"]}) for name, p in segments]
    lines, need = [], []
    for key, lim, word, unit, option in limits:
        over = dict.fromkeys(name for name, peaks in values if peaks[key] > lim * (1 + 1e-9))
        if over:
            top = max(peaks[key] for _, peaks in values)
            lines.append(f"beyond {lim:g} {unit} of {word}: {', '.join(over)}")
            need.append(f"{option} {_ceil(top)}")
    if lines:
        lines.append("to fit this shaker: [data] design = \"shaker\" in a --config file (the "
                     "paper's VFA alone, within the shaker; no extension, random or decay "
                     "segments); for a larger shaker: " + " ".join(need))
    return lines


#: Bytes a sample takes in each file, about (the estimate printed before writing): the CSV's
#: ``1234.5678,-12.345678`` line, UFF 58's four 20-character values a line.
CSV_BYTES_PER_SAMPLE, UFF_BYTES_PER_SAMPLE = 20.0, 20.25


def _size(path: Path) -> str:
    """A file's size for a person: ``12 kB``, ``59 MB``."""
    n = float(path.stat().st_size)
    for unit in ("B", "kB", "MB"):
        if n < 1000.0:
            return f"{n:.3g} {unit}"
        n /= 1000.0
    return f"{n:.3g} GB"


def _ceil(x: float) -> str:
    """``x`` rounded up to 2 significant figures (a limit that holds the peak)."""
    import math

    e = math.floor(math.log10(abs(x))) - 1 if x else 0
    return f"{math.ceil(x / 10**e) * 10**e:g}"
