"""Interchange commands: ``sloshrom export onnx MODEL OUT.onnx`` and ``sloshrom export fmu
MODEL OUT.fmu`` (a ROM into other simulators) and ``sloshrom import uff IN.uff OUT.nc``
(test-lab UFF58 time histories into a record)."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any

import typer

from sloshrom.cli._app import app, check_input, check_number, check_out, fail, key_value_pairs
from sloshrom.config import Tank
from sloshrom.errors import SloshromError
from sloshrom.fileio import not_a_regular_file
from sloshrom.io import preprocess as _preprocess
from sloshrom.io import write_record
from sloshrom.io.uff import read_uff58

if TYPE_CHECKING:
    import numpy as np


export_app = typer.Typer(help="Export a trained ROM for other simulators (ONNX, FMU).",
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
    input and output, which is not implemented. A grey box is refused too, with its reason (a
    sub-stepped column with contacts): export these as FMUs.

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
    _check_out_file(out, (".onnx",), model)
    from sloshrom.rom.loading import load_model
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


def _check_out_file(out: Path, suffixes: tuple[str, ...], model: Path) -> None:
    """:func:`check_out` for an export's OUT, and an existing OUT must be a regular file: the
    export replaces it by renaming, which would silently turn a named pipe (or a device) that
    another program reads into a file."""
    check_out(out, suffixes=suffixes, inputs=(model,), what="OUT")
    why = not_a_regular_file(out)
    if why is not None:
        fail(f"OUT {out}: {why}")


def _check_input(rom: Any) -> np.ndarray:
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


#: the largest relative difference an exported FMU may show against the ROM it came from
FMU_PARITY = 1e-12


@export_app.command("fmu")
def fmu_cmd(
    model: Annotated[Path, typer.Argument(help="ROM file written by sloshrom (.npz): NFIR, "
                                          "NOE, NSS, LSS, grey box or an ensemble.")],
    out: Annotated[Path, typer.Argument(help="Output FMU (.fmu).")],
    step: Annotated[float | None, typer.Option(help="The communication step your simulator "
                                               "will use, s: checked against the model's "
                                               "own step, the only one the FMU takes.")
                    ] = None,
    source_only: Annotated[bool, typer.Option("--source-only", help="Write the C sources "
                                              "without compiling a binary (build it on the "
                                              "machine that runs it).")] = False,
    check: Annotated[bool, typer.Option("--check/--no-check", help="Validate the FMU with "
                                        "FMPy and run its binary against the ROM (a relative "
                                        "difference above 1e-12 writes nothing).")] = True,
    strictly_proper: Annotated[bool, typer.Option(
        "--strictly-proper", help="For a ROM with direct feed-through (an LSS, an NSS with "
                                  "--feedthrough yes): the FMU's force at t_k is the model's "
                                  "force of t_(k-1), read before the input of t_k enters it, so "
                                  "that every co-simulation master gets the model's force one "
                                  "step late, whatever its order of calls (docs/interchange.md)."
    )] = False,
) -> None:
    """Export a ROM as an FMI 2.0 co-simulation FMU: native C, no Python at run time.

    Input the tank signal the model reads (velocity in m/s, or acceleration in m/s2 for a
    network on it), output dynamic_force (N); the communication step is the model's own;
    outside_envelope flags inputs beyond the training range (docs/interchange.md). The C
    sources are inside, for other platforms. A ROM with direct feed-through is one input late
    in a master that reads the outputs before it sets the inputs (FMPy's simulate_fmu,
    libcosim): export it with --strictly-proper for those.

    Example: ``sloshrom export fmu results/models/nss.npz slosh.fmu``
    """
    import numpy as np

    if out.suffix.lower() != ".fmu":
        fail(f"output must be a .fmu file, got {out} (MODEL comes first, then OUT)")
    if step is not None:
        check_number(step, "--step", 0.0, lo_open=True, unit="s")
    check_input(model, "MODEL")
    _check_out_file(out, (".fmu",), model)
    from sloshrom.rom.fmu import (
        STEP_RTOL,
        check_fmu_exportable,
        export_fmu,
        fmu_platform,
        load_fmu,
    )
    from sloshrom.rom.loading import load_model

    rel = [float("nan")]
    try:
        rom = load_model(model)
        nets = check_fmu_exportable(rom)
        dt = nets[0].dt
        if step is not None and not abs(step - dt) <= STEP_RTOL * dt:
            fail(f"--step {step:g} s is not the model's step {dt:.10g} s ({1 / dt:g} Hz): the "
                 "FMU runs at the rate the ROM was identified at, and only there; use that "
                 "step, with rate transitions around the FMU if the rest of your model runs at "
                 f"another; {out} not written")
        u = _check_input(rom)

        def verify(tmp: Path) -> None:
            # on the complete temporary file: OUT appears only once it is verified
            from fmpy.validation import validate_fmu

            problems = validate_fmu(str(tmp))
            if problems:
                fail(f"FMPy finds the exported FMU invalid ({'; '.join(problems)}); "
                     f"{out} not written")
            if source_only:
                return
            fmu = load_fmu(tmp, name=out.name)  # its messages name OUT, not the temporary
            try:
                y = fmu.predict(u)
            except SloshromError as exc:
                fail(f"MODEL {model}: its FMU fails on the check input ({exc}); {out} not "
                     "written")
            finally:
                fmu.close()
            # strictly proper: the force of the sample before (at rest before the first)
            ref = (np.asarray(rom.predict(np.concatenate([[0.0], u])))[:-1] if strictly_proper
                   else np.asarray(rom.predict(u)))
            rel[0] = float(np.max(np.abs(y - ref)) / max(np.max(np.abs(ref)), 1e-300))
            if not rel[0] <= FMU_PARITY:
                fail(f"the FMU differs from the ROM by {rel[0]:.2e} (> {FMU_PARITY:g}); "
                     f"{out} not written")

        export_fmu(rom, out, binary=not source_only, verify=verify if check else None,
                   strictly_proper=strictly_proper)
    except SloshromError as exc:
        fail(str(exc))
    except OSError as exc:  # the disk: full, a file-size limit (EFBIG), ...; OUT as it was
        fail(f"OUT {out}: not written ({exc.strerror or exc}); a previous {out.name} is left "
             "as it was")
    what = (f"{len(nets)} x {rom.member_class}" if len(nets) > 1 else type(rom).__name__)
    what += ", strictly proper (its force one step late)" if strictly_proper else ""
    msg = (f"wrote {out}: {what}, {1 / dt:g} Hz (communication step {dt:.10g} s), "
           + ("sources only" if source_only else f"binary for {fmu_platform()} + sources"))
    if check:
        msg += "; FMPy validation: no problems"
        if not source_only:
            msg += (f"; FMU vs sloshrom on {u.size} samples: max rel. difference "
                    f"{rel[0]:.2e}")
    typer.echo(msg)


import_app = typer.Typer(help="Import test-lab files as sloshrom records (UFF dataset 58).",
                         no_args_is_help=True)
app.add_typer(import_app, name="import")


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
    for key, value in key_value_pairs(name, "--name", "CHANNEL=VARIABLE").items():
        names[int(key) if key.isdigit() else key] = value
    units = key_value_pairs(unit, "--unit", "VARIABLE=UNIT")
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
