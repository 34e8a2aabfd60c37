"""The shared typer application that every CLI sub-module registers its commands on."""

from __future__ import annotations

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
