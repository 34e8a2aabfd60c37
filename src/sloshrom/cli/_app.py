"""The shared typer application that every CLI sub-module registers its commands on."""

from __future__ import annotations

from pathlib import Path
from typing import NoReturn

import typer

app = typer.Typer(
    name="sloshrom",
    help="Neural-network reduced-order models of vertical sloshing and the sloshing beam.",
    no_args_is_help=True,
    add_completion=False,
)


@app.callback()
def _main() -> None:
    """Identify sloshing ROMs from shaker data and couple them with a flexible beam."""


@app.command()
def version() -> None:
    """Print the package version."""
    from sloshrom import __version__

    typer.echo(__version__)


def fail(msg: str) -> NoReturn:
    """Report a user error in one red line on stderr and exit with code 2 (no traceback)."""
    typer.secho(f"error: {msg}", fg=typer.colors.RED, err=True)
    raise typer.Exit(code=2)


def check_out(
    path: Path,
    *,
    suffixes: tuple[str, ...] | None = None,
    inputs: tuple[Path | None, ...] = (),
    directory: bool = False,
    what: str = "--out",
) -> Path:
    """:func:`sloshrom.fileio.check_output` before any work; a user error if it fails."""
    from sloshrom.fileio import OutputPathError, check_output

    try:
        return check_output(path, suffixes=suffixes, inputs=tuple(i for i in inputs if i),
                            directory=directory, what=what)
    except OutputPathError as exc:
        fail(str(exc))
