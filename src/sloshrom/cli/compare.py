"""``sloshrom compare MEASURED.nc PREDICTED.nc ... --out DIR``: a measured beam test beside its
predictions (paper Table 2 and Figs. 21, 23), with the intervals and a verdict per level."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Annotated, Any

import typer

from sloshrom.beam.damping.limits import check_analysis_band
from sloshrom.cli._app import app, check_input, check_out, fail, key_value_pairs
from sloshrom.errors import SloshromError
from sloshrom.fileio import OutputBatch

_SIGNALS = ("station_acceleration", "tank_acceleration", "base_acceleration")


def _check_result(path: Path, ds: Any) -> None:
    """The numbers the analyses take from a beam result dataset ``ds``, checked before they
    run: ``fs`` and ``f1_Hz`` finite and positive (Hz) with mode 1 well below Nyquist, ``fs``
    the rate of the time axis, finite signals, and a random test's levels (g) each within a
    factor 1.25 of its base RMS (``measured.check_levels``). Missing names are left to
    ``beam.compare.test_from_dataset``."""
    import numpy as np

    hz = {}
    for key in ("fs", "f1_Hz"):
        if key not in ds.attrs:
            continue
        raw = ds.attrs[key]
        raw = raw.item() if hasattr(raw, "item") and getattr(raw, "size", 1) == 1 else raw
        try:
            hz[key] = float(raw)
        except (TypeError, ValueError):
            hz[key] = math.nan
        if not (math.isfinite(hz[key]) and hz[key] > 0):
            fail(f"{path}: attribute '{key}' must be a finite positive number in Hz, got "
                 f"{raw!r}")
    if len(hz) == 2:
        try:
            check_analysis_band(hz["f1_Hz"], fs=hz["fs"])
        except SloshromError as exc:
            fail(f"{path}: {exc}")
    if "fs" in hz:
        from sloshrom.beam.compare import check_sample_rate

        try:
            check_sample_rate(ds)
        except SloshromError as exc:
            fail(f"{path}: {exc}")
    for name in _SIGNALS:
        if name in ds and not np.isfinite(ds[name].values).all():
            fail(f"{path}: variable '{name}' contains NaN/inf")
    if ds.attrs.get("test") == "random" and "level" in ds.dims and "base_acceleration" in ds:
        # the levels match the predictions to the measurement: each its run's own?
        from sloshrom.beam.lab.measured import check_levels

        base = ds["base_acceleration"].transpose("level", ...).values
        levels = [float(g) for g in ds["level"].values]
        try:
            check_levels(base.reshape(base.shape[0], -1), levels,
                         [f"level {k + 1}" for k in range(len(levels))])
        except SloshromError as exc:
            fail(f"{path}: {exc}")


@app.command("compare")
def compare(
    measured: Annotated[Path, typer.Argument(
        help="The measured test: a beam result NetCDF of 'sloshrom analyse' (or any beam "
             "result).", metavar="MEASURED", show_default=False)],
    predicted: Annotated[list[Path], typer.Argument(
        help="Predictions of the same test: beam result NetCDF files of 'sloshrom beam' (rig, "
             "ROM, frozen, ...).", metavar="PREDICTED", show_default=False)],
    out: Annotated[Path, typer.Option(help="Output directory.")],
    name: Annotated[list[str] | None, typer.Option(
        "--name", help="OLD=NEW: the case OLD of the inputs (the first file that has it) is "
                       "called NEW in the tables (repeatable), e.g. for two files of the same "
                       "case name.", show_default=False)] = None,
) -> None:
    """Measured against predicted: first-mode damping with intervals and a verdict per level.

    Re-runs the damping analyses of every file (free decays: Hilbert and log decrement per band
    of tank acceleration amplitude; random tests: LSCF on H1, output-only LSCF and half power,
    paper Table 2), each estimate with its interval, and writes ``comparison.csv/.md``: per
    level (or band), estimator and predicted case, the measurement and its interval, the
    prediction and its interval, the relative difference, the verdict (the prediction inside or
    outside the measured interval) and z, the difference over the standard deviation of the
    difference (``consistent``: |z| <= 1.96); every interval is at 95 %. Also ``analyses.csv/.md``
    (every file's estimates) and the figures (free: ``fig21_comparison.png``; random:
    ``fig23_comparison.png``, ``table2_comparison.png``). Random tests are matched by RMS
    level (within 10 %).

    Every check that needs no analysis (readable beam results, unique case names, one kind of
    test, RMS levels that match, an ``fs`` that is the time axis's rate, one structure: first
    mode frequencies within 15 %) runs before the first analysis. ``--name OLD=NEW`` renames a
    case (two files of the same case name need it).

    Example: ``sloshrom compare lab/random_measured.nc sim/random_rig.nc sim/random_rom.nc
    --out cmp``
    """
    import xarray as xr

    from sloshrom.beam.compare import (
        CaseNameError,
        analyse_test,
        check_structures,
        compare_rows,
        comparison_cases,
    )
    from sloshrom.beam.damping.uncertainty import format_interval
    from sloshrom.beam.results import write_table
    from sloshrom.plotting import savefig
    from sloshrom.plotting.beam import COMPARE_FIGURES, comparison_figures

    paths = [measured, *predicted]
    renames = key_value_pairs(name, "--name", "OLD=NEW")
    for old, new in renames.items():
        if not all(c.isalnum() or c in "-_." for c in new):
            fail(f"--name {old}={new}: a case name has letters, digits, '-', '_' and '.' only")
    for p in paths:
        check_input(p, "beam result")
    if len({p.resolve() for p in paths}) < len(paths):
        fail("the same file is given twice")
    check_out(out, directory=True, inputs=tuple(paths))  # before reading: a typo fails at once
    datasets = []
    for p in paths:
        try:  # only the reading: an error of the analyses is not the file's
            with xr.open_dataset(p, engine="h5netcdf") as ds:
                datasets.append(ds.load())
        except (OSError, ValueError) as exc:
            fail(f"{p}: not a readable NetCDF beam result ({type(exc).__name__}: {exc})")
    kind = datasets[0].attrs.get("test")
    stems = ["comparison.csv", "comparison.md", "analyses.csv", "analyses.md",
             *(f"{f}.png" for f in COMPARE_FIGURES.get(kind, ()))]
    check_out(out, directory=True, inputs=tuple(paths), contents=tuple(stems))
    for stem in stems:  # a directory in a result's place would fail the batch half-way
        check_out(out / stem, inputs=tuple(paths), what="result file")
    # every check that needs no analysis, before the first (long) one
    try:
        cases = comparison_cases(datasets, [str(p) for p in paths], renames)
    except CaseNameError as exc:
        if exc.rename is not None:
            fail(f"--name {exc.rename[0]}={exc.rename[1]}: {exc}")
        fail(f"{exc} with --name OLD=NEW")
    except SloshromError as exc:
        fail(str(exc))
    for p, ds in zip(paths, datasets, strict=True):
        _check_result(p, ds)
    try:
        check_structures(datasets, [str(p) for p in paths])
    except SloshromError as exc:
        fail(str(exc))
    tests = []
    bands = None  # the predictions in the measurement's bands (its first row's)
    for p, ds, case in zip(paths, datasets, cases, strict=True):
        try:
            tests.append(analyse_test(ds, case, bands))
        except SloshromError as exc:
            fail(f"{p}: {exc}")
        if bands is None and tests[0].kind == "free":
            bands = _bands_of(tests[0].rows)
    try:
        rows = compare_rows(tests[0], tests[1:])
    except SloshromError as exc:
        fail(str(exc))
    if all(r["verdict"] == "n/a" for r in rows):  # a table of n/a says nothing
        fail("no comparison, nothing written: " + (
            f"every row is n/a; the first, {rows[0]['case']}: {rows[0]['reason']}" if rows
            else "no level or band of a prediction matches the measurement's"))
    figs = comparison_figures(tests[0], tests[1:])
    with OutputBatch() as batch:
        write_table(rows, out / "comparison", batch)
        write_table([r for t in tests for r in t.table_rows()], out / "analyses", batch)
        for stem, fig in figs.items():
            savefig(fig, out / f"{stem}.png", batch)
    head = "rms_g" if kind == "random" else "band"
    what = "estimator" if kind == "random" else "method"
    for r in rows:
        # a missing estimate is never a silent nan: its reason instead of the number
        low, high, pred = format_interval(100 * r["measured_low"], 100 * r["measured_high"],
                                          100 * r["predicted"])
        pred = f"{pred} %" if math.isfinite(r["predicted"]) else pred
        why = f" ({r['reason']})" if r.get("reason") else ""
        typer.echo(f"{r[head]} {r[what]}: {r['case']} {pred} "
                   f"{r['verdict']} [{low}, {high}] % of {tests[0].case} "
                   f"(z = {r['z']:.2g}){why}")
    typer.echo(f"wrote the comparison of {len(tests) - 1} prediction(s) with {tests[0].case} "
               f"to {out}")


def _bands_of(rows: list[dict]) -> list[tuple[float, float]]:
    """The amplitude bands (g) of a free decay's rows, in order (``"0.5-1 g"`` -> (0.5, 1))."""
    out: list[tuple[float, float]] = []
    for r in rows:
        lo, hi = (float(x) for x in str(r["band"]).removesuffix(" g").split("-"))
        if (lo, hi) not in out:
            out.append((lo, hi))
    return out
