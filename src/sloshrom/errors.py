"""The base of every error sloshrom raises for bad user input.

Each room raises its own subclasses (``ConfigError``, ``RecordError``, ``ROMError``, ...), each
naming the key, variable or file at fault; all derive from :class:`SloshromError`, which is also
a ``ValueError``. The command line catches this one base and prints one line; anything else that
escapes is a programming error and keeps its traceback.
"""

from __future__ import annotations

__all__ = ["Note", "SloshromError"]


class SloshromError(ValueError):
    """Bad input to sloshrom: a value, a file, a record or an option that cannot be used."""


class Note(UserWarning):
    """Information about the user's input that changes no result they asked for (a file
    without a channel the test can do without, ...): the command line prints it as one
    ``note: ...`` line."""
