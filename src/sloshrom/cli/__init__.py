"""Command line: ``sloshrom --help``.

Each sub-module registers its commands on the shared ``app`` of ``sloshrom.cli._app``; importing
this package imports them all.
"""

# (each import registers its commands)
from sloshrom.cli import (  # noqa: F401
    analyse,
    beam,
    compare,
    design,
    export,
    pipeline,
    rig,
    rom,
    system,
)
from sloshrom.cli._app import app

__all__ = ["app"]
