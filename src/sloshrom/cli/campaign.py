"""``sloshrom analyse campaign``: a laboratory's campaign folder in one command.

Every test of the folder (free decays and the random test, from ``campaign.toml`` or from the
files' content: :mod:`sloshrom.beam.campaign`) through ``analyse free`` / ``analyse random``,
each into its own sub-folder, and one report page (``campaign.md`` and a self-contained
``campaign.html``) with every mode, every estimator, intervals and figures.
"""

from __future__ import annotations

import io
import math
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Annotated

import typer

from sloshrom.cli._app import check_input, check_number, fail, key_value_pairs
from sloshrom.cli.analyse import (
    _AnalyseModesOpt,
    _ChannelsOpt,
    _checked,
    _free_outputs,
    _free_test,
    _frequencies,
    _FrequenciesOpt,
    _Given,
    _OutOpt,
    _random_outputs,
    _random_test,
    _read,
    _run,
    _Setting,
    _Steps,
    _Test,
    _UnitOpt,
    _with_units,
    analyse_app,
)
from sloshrom.cli.beam import check_outputs, echo_missing
from sloshrom.errors import SloshromError
from sloshrom.fileio import OutputBatch

if TYPE_CHECKING:
    from matplotlib.figure import Figure

    from sloshrom.beam.campaign import CampaignTest
    from sloshrom.beam.members import Row

_DirArg = Annotated[Path, typer.Argument(
    help="The campaign folder: data files (UFF 58, CSV, NetCDF, MATLAB) and optionally "
         "campaign.toml (which file is which test).", show_default=False)]


def _cell(r: Row, key: str, low: str, high: str, reason: str) -> str:
    """``value [low, high] %`` with the digits the interval needs, or ``— (reason)``."""
    from sloshrom.beam.uncertainty import format_interval

    v, lo, hi = (_num(r.get(k)) for k in (key, low, high))
    if not math.isfinite(v):
        return f"— ({r.get(reason) or 'no estimate'})"
    if not (math.isfinite(lo) and math.isfinite(hi)):
        return f"{100 * v:.3g} % (no interval: {r.get(reason) or 'no spread estimate'})"
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
    from sloshrom.beam.registry import label

    head = ["mode", "f (Hz)", "RMS base (g)", *(f"{label(e)} (%)" for e in estimators)]
    rows = [[str(r["mode"]), f"{r['mode_frequency_Hz']:.4g}", f"{r['rms_g']:g}",
             *(_cell(r, e, f"{e}_low", f"{e}_high", f"{e}_reason") for e in estimators)]
            for r in test.rows]
    return head, rows


def _free_table(test: _Test) -> tuple[list[str], list[list[str]]]:
    from sloshrom.beam.registry import label

    head = ["mode", "f (Hz)", "band", "method", "damping (%)"]
    rows = [[str(r["mode"]), f"{r['mode_frequency_Hz']:.4g}", str(r["band"]),
             label(str(r["method"])), _cell(r, "zeta", "low", "high", "reason")]
            for r in test.rows]
    return head, rows


def _markdown(head: list[str], rows: list[list[str]]) -> str:
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    lines += ["| " + " | ".join(c.replace("|", "/") for c in r) + " |" for r in rows]
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
    from sloshrom.beam.campaign import campaign_tests
    from sloshrom.beam.channels import ChannelMap
    from sloshrom.beam.registry import estimator_names

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
        done = []
        for s in specs:
            if s.kind == "free":
                t = _free_test(list(s.files), ctx, s.name, step)
            else:
                lv = list(s.levels) if s.levels is not None else None
                t = _random_test(list(s.files), ctx, s.name, lv, names, None, step)
            done.append((s, t))
        return done

    tests = _run("analyse campaign", work)
    md, page = _report(directory, tests, names)
    with OutputBatch() as batch:  # all result files or none
        for _, t in tests:
            t.write(out / t.name, batch)
        batch.write_text(out / "campaign.md", md)
        batch.write_text(out / "campaign.html", page)
    for _, t in tests:
        echo_missing(t.rows, f"{t.name}")
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
) -> None:
    """Write a laboratory's campaign to try `analyse` on: a three-mode cantilever without tank
    (10.3 / 64.1 / 180 Hz, damping 1.37 / 0.62 / 0.48 %), five accelerometers alternately in g
    and m/s^2, a free decay and random tests at 0.1 / 0.2 / 0.4 g, as UFF 58, and its channel
    map ``channels.toml``.

    Example: ``sloshrom analyse example lab && sloshrom analyse campaign lab --channels
    lab/channels.toml --out results``
    """
    from sloshrom.beam.labfiles import write_lab_campaign

    check_number(duration, "--duration", 34.0, 3600.0, unit="s",
                 why="one 16384-sample Welch segment at 500 Hz and at most an hour")
    check_number(seed, "--seed", 0, 2**32 - 1)
    names = ["decay.uff", *(f"random_{g:g}g.uff" for g in (0.1, 0.2, 0.4)), "channels.toml"]
    check_outputs(directory, names, ())
    with OutputBatch() as batch:
        cmap = write_lab_campaign(directory, duration=duration, unit_labels=not empty_units,
                                  seed=seed, batch=batch)
        cmap.write_toml(directory / "channels.toml", batch)
    typer.echo(f"wrote {', '.join(names)} to {directory}")
