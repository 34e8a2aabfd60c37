"""Interchange commands: ``sloshrom export onnx MODEL OUT.onnx`` (a ROM into other simulators)
and ``sloshrom import uff IN.uff OUT.nc`` (test-lab UFF58 time histories into a record)."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Annotated

import typer

from sloshrom.cli._app import app, check_input, check_number, check_out, fail
from sloshrom.config import Tank
from sloshrom.errors import SloshromError
from sloshrom.fileio import not_a_regular_file
from sloshrom.io import preprocess as _preprocess
from sloshrom.io import write_record
from sloshrom.io.uff import read_uff58

if TYPE_CHECKING:
    import numpy as np

    from sloshrom.rom.estimators import NFIR, NOE

export_app = typer.Typer(help="Export a trained ROM for other simulators (ONNX).",
                         no_args_is_help=True)
app.add_typer(export_app, name="export")


@export_app.command("onnx")
def onnx_cmd(
    model: Annotated[Path, typer.Argument(help="ROM file written by sloshrom (.npz).")],
    out: Annotated[Path, typer.Argument(help="Output ONNX file (.onnx).")],
    form: Annotated[str, typer.Option(help="'step': one sample with the delay line as state "
                                      "input/output (Simulink, co-simulation); 'sequence': a "
                                      "whole record from rest.")] = "step",
    dtype: Annotated[str, typer.Option(help="'float64' (exact) or 'float32' (tools that "
                                       "take single precision only).")] = "float64",
    check: Annotated[bool, typer.Option("--check/--no-check", help="Run the exported graph "
                                        "with onnxruntime against the ROM and report the "
                                        "relative difference.")] = True,
) -> None:
    """Export a NFIR/NOE ROM to ONNX, scalers and delay line inside the graph.

    Step form: in velocity (batch,1) m/s, u_state (batch,max_delay) m/s [+ y_state for NOE];

    out dynamic_force (batch,1) N, u_state_out [+ y_state_out] to feed back (docs/interchange.md).

    A state-space ROM (NSS, ``train --arch nss``) is refused: its graph would need its state as
    input and output, which is not implemented.

    Example: ``sloshrom export onnx results/models/nfir.npz nfir_step.onnx``
    """
    import numpy as np

    if form not in ("step", "sequence"):
        fail(f"--form must be 'step' or 'sequence', got {form!r}")
    if dtype not in ("float64", "float32"):
        fail(f"--dtype must be 'float64' or 'float32', got {dtype!r}")
    if out.suffix.lower() != ".onnx":
        fail(f"output must be a .onnx file, got {out} (MODEL comes first, then OUT)")
    why = not_a_regular_file(model)
    if why is not None:
        fail(f"MODEL {model}: {why}")
    if not model.is_file():
        fail(f"model file not found: {model}")
    check_out(out, suffixes=(".onnx",), inputs=(model,), what="OUT")
    from sloshrom.rom.estimators import load_model
    from sloshrom.rom.onnx import check_exportable, export_onnx, run_onnx

    limit = 1e-6 if dtype == "float64" else 1e-4
    rel = [float("nan")]
    try:
        rom = load_model(model)
        check_exportable(rom)
        if check:
            u = _check_input(rom)
            ref = np.asarray(rom.predict(u))

            def verify(tmp: Path) -> None:
                # runs on the complete temporary file: OUT appears only once the graph is
                # verified, and an existing OUT is left as it was when the check fails
                y = run_onnx(tmp, u)
                rel[0] = float(np.max(np.abs(y - ref)) / max(np.max(np.abs(ref)), 1e-300))
                if not rel[0] <= limit:
                    fail(f"exported graph differs from the ROM by {rel[0]:.2e} (> {limit:g}); "
                         f"{out} not written")

        export_onnx(rom, out, form=form, dtype=dtype, verify=verify if check else None)
    except SloshromError as exc:
        fail(str(exc))
    msg = (f"wrote {out}: {type(rom).__name__} {form} form, {dtype}, {rom.fs_:g} Hz, "
           f"{rom.max_delay} input delays")
    if check:
        msg += f"; onnxruntime vs sloshrom on {u.size} samples: max rel. difference {rel[0]:.2e}"
    typer.echo(msg)


def _check_input(rom: NFIR | NOE) -> np.ndarray:
    """A band-limited input inside the training envelope (2 s), starting and ending at rest."""
    import numpy as np

    fs = float(rom.fs_)
    n = int(2 * fs)
    t = np.arange(n) / fs
    env = rom.envelope_ or {}
    lo, hi = env.get("frequency_band", [1.0, 0.1 * fs]) or [1.0, 0.1 * fs]
    lo, hi = max(float(lo), 0.5), max(min(float(hi), 0.4 * fs), 1.0)
    rng = np.random.default_rng(0)
    u = sum(np.sin(2 * np.pi * f * t + p) for f, p in
            zip(np.linspace(lo, hi, 7), rng.uniform(0, 2 * np.pi, 7), strict=True))
    u = u * np.sin(np.pi * t / t[-1]) ** 2  # at rest at both ends
    amp = 0.9 * min(abs(env.get("input_min", -1.0)), abs(env.get("input_max", 1.0)))
    return u / np.max(np.abs(u)) * amp


import_app = typer.Typer(help="Import test-lab files as sloshrom records (UFF dataset 58).",
                         no_args_is_help=True)
app.add_typer(import_app, name="import")


def _pairs(items: list[str], what: str) -> dict[str, str]:
    """``KEY=VALUE`` options as a mapping; a key given twice is an error naming it (never a
    silent "the last one wins")."""
    out: dict[str, str] = {}
    for item in items:
        key, sep, value = item.partition("=")
        if not sep or not key.strip() or not value.strip():
            fail(f"{what} must look like KEY=VALUE, got {item!r}")
        if key.strip() in out:
            fail(f"{what}: the key {key.strip()!r} is given twice ({out[key.strip()]!r} and "
                 f"{value.strip()!r}); give it once")
        out[key.strip()] = value.strip()
    return out


@import_app.command("uff")
def import_uff_cmd(
    uff: Annotated[Path, typer.Argument(help="UFF/UNV file with dataset-58 time responses.")],
    out: Annotated[Path, typer.Argument(help="Output record (.nc, .csv or .mat).")],
    name: Annotated[list[str], typer.Option("--name", help="CHANNEL=VARIABLE: channel label "
                                            "(ID line 1) or 0-based index -> variable name "
                                            "(repeatable).")] = [],  # noqa: B006
    unit: Annotated[list[str], typer.Option("--unit", help="VARIABLE=UNIT for channels "
                                            "without a unit in the file (repeatable).")] = [],  # noqa: B006
    preprocess: Annotated[bool, typer.Option("--preprocess/--no-preprocess", help="Add velocity "
                                             "and dynamic_force from acceleration and force.")
                          ] = True,
    tank_toml: Annotated[Path | None, typer.Option("--tank", help="TOML with a \\[tank] table "
                                                   "(masses for the dynamic force).")] = None,
    f_highpass: Annotated[float, typer.Option(help="Drift-removal corner of the velocity "
                                              "integration, Hz.")] = 1.0,
) -> None:
    """Read a UFF58 shaker test, convert to SI, preprocess and write a record for `train`.

    Example: ``sloshrom import uff run12.uff run12.nc --name "Tank Z=acceleration"
    --name "Load cell=force" --unit force=N``
    """
    names: dict[str | int, str] = {}
    for key, value in _pairs(name, "--name").items():
        names[int(key) if key.isdigit() else key] = value
    units = _pairs(unit, "--unit")
    check_number(f_highpass, "--f-highpass", 0.0, unit="Hz")
    check_input(uff, "UFF")
    check_input(tank_toml, "--tank")
    check_out(out, suffixes=(".nc", ".csv", ".mat"), inputs=(uff, tank_toml), what="OUT")
    try:
        tank = Tank.from_toml(tank_toml) if tank_toml is not None else Tank()
        rec = read_uff58(uff, names=names, units=units).to_si()
        if preprocess:
            check_number(f_highpass, "--f-highpass", 0.0, rec.fs / 2, hi_open=True, unit="Hz",
                         why=f"below the Nyquist frequency of the {rec.fs:g} Hz record")
            rec = _preprocess(rec, tank, f_highpass=f_highpass)
        write_record(rec, out)
    except SloshromError as exc:  # RecordError, ConfigError
        fail(str(exc))
    typer.echo(f"wrote {out}: {', '.join(rec.names)}; {len(rec)} samples at {rec.fs:g} Hz "
               f"({rec.duration:.1f} s)")
