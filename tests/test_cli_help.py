"""Command help reads as paragraphs: the docstring's line breaks do not cut sentences."""

from __future__ import annotations

import pytest
from typer.testing import CliRunner

from sloshrom.cli import app
from sloshrom.cli._app import help_paragraphs


def test_help_is_wrapped_by_paragraph_not_by_source_line():
    res = CliRunner().invoke(app, ["train", "--help"], env={"COLUMNS": "200"},
                             terminal_width=200)
    assert res.exit_code == 0, res.output
    # one sentence, broken over two lines of the docstring, is on one line of the help
    sentence = ("The two records must have the same sample rate and the same units of the input "
                "and of the output; the model file may not be one of the records.")
    assert any(sentence in line for line in res.output.splitlines()), res.output


@pytest.mark.parametrize(("text", "expected"), [
    ("One line.\n\n    Two lines\n    of a paragraph.\n", "One line.\n\nTwo lines of a paragraph."),
    ("Title.\n\nA list:\n- first\n- second\n", "Title.\n\nA list:\n- first\n- second"),
    ("Title.\n\n\b\nkept\nas is\n", "Title.\n\nkept\nas is"),
    (None, None),
])
def test_help_paragraphs(text, expected):
    assert help_paragraphs(text) == expected


def _commands():
    """Every command's path under the root (``[]`` the root), from typer's command tree."""
    import typer.main

    import sloshrom.cli.export  # noqa: F401  (registers `sloshrom export` and `import`)

    def walk(c, path):
        yield path, c
        if hasattr(c, "list_commands"):
            ctx = type(c).context_class(c)
            for n in c.list_commands(ctx):
                yield from walk(c.get_command(ctx, n), [*path, n])

    return list(walk(typer.main.get_command(app), []))


def test_every_help_prints_its_table_names_and_no_rst_literals():
    """rich's markup printed nothing for "[data]" or "[units]" in a help text, and the
    docstrings' ``x`` came out with both pairs of backticks: each help prints the table names
    its source holds, and no double backticks."""
    import re

    paths = [p for p, _ in _commands()]
    assert len(paths) > 20, paths
    seen_tables = 0
    for path in paths:
        res = CliRunner().invoke(app, [*path, "--help"], env={"COLUMNS": "400"},
                                 terminal_width=400)
        assert res.exit_code == 0, (path, res.output)
        out = " ".join(res.output.replace("│", " ").split())
        assert "``" not in out, (path, re.findall(r".{30}``.{30}", out))
        cmd = dict((tuple(p), c) for p, c in _commands())[tuple(path)]
        texts = [cmd.help or ""] + [getattr(q, "help", None) or "" for q in cmd.params]
        for t in texts:
            for name in re.findall(r"\[[A-Za-z_][\w.]*\]", t):
                seen_tables += 1
                assert name in out, (path, name)
    assert seen_tables >= 10, seen_tables


@pytest.mark.parametrize("empty", [False, True])
def test_analyse_example_says_what_to_run_next_and_where_the_units_are(tmp_path, empty):
    """The example campaign's command printed neither the next command nor the units; with
    empty unit labels its channel map now carries them, so the next command runs as printed."""
    import tomllib

    d = tmp_path / "lab"
    res = CliRunner().invoke(app, ["analyse", "example", str(d), "--duration", "34",
                                   *(["--empty-units"] if empty else [])])
    assert res.exit_code == 0, res.output
    out = " ".join(res.output.split())
    assert (f"next: sloshrom analyse campaign {d} --channels {d / 'channels.toml'} --out "
            f"{d / 'results'}") in out
    units = tomllib.loads((d / "channels.toml").read_text()).get("units", {})
    if empty:
        assert units == {"base": "g", "acc1": "g", "acc2": "m/s^2", "acc3": "g",
                         "acc4": "m/s^2", "acc5": "g"}
        assert "channels.toml's [units] table gives them (base g, acc1 g, acc2 m/s^2" in out
    else:
        assert units == {} and "units are in the UFF files' labels" in out


def test_an_option_shared_by_two_systems_gives_each_its_meaning():
    """`system --help` gave --noise one meaning, in m, for both systems (the tanks' is in V)."""
    res = CliRunner().invoke(app, ["system", "--help"], env={"COLUMNS": "400"},
                             terminal_width=400)
    assert res.exit_code == 0, res.output
    out = " ".join(res.output.replace("│", " ").split())
    noise = out.split("--noise <float>")[1].split(" --")[0]
    assert "bouc-wen: RMS of the output noise" in noise and ", m (" in noise
    assert "cascaded-tanks: standard deviation of the measurement noise, V" in noise
    assert "hysteretic oscillator in and" not in out
