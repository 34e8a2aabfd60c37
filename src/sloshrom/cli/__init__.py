"""Command line: ``sloshrom --help``.

Each sub-module registers its commands on the shared ``app`` of ``sloshrom.cli._app``; importing
this package imports them all.
"""

from sloshrom.cli import analyse, beam, export, pipeline, rig, rom  # noqa: F401  (register commands)
from sloshrom.cli._app import app

__all__ = ["app"]
