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
