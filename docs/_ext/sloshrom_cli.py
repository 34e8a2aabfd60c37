"""The click command behind sloshrom's typer app, for sphinx-click's ``click`` directive."""

import typer.main

from sloshrom.cli import app

command = typer.main.get_command(app)
