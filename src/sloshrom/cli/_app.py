"""The shared typer application that every CLI sub-module registers its commands on, and the
helpers that keep every user error to one line.

A user error (bad option, bad file, bad configuration) ends in ONE red ``error: ...`` line on
stderr naming the option, file or key, with exit code 2, no traceback, and before any work or any
output (:func:`fail`, :func:`check_out`, :func:`check_number`). The package's errors all derive
from :class:`~sloshrom.errors.SloshromError`: commands catch that one base where they can add the
option at fault, and the root group turns one that escapes a command into the same line; anything
else (a plain ``ValueError`` from inside) is a bug and keeps its traceback. Warnings are routed too
(:func:`route_warnings`): one yellow ``warning: ...`` line each, third-party deprecation noise
silenced.

Command help is the command's docstring read as paragraphs (:func:`help_paragraphs`): typer's
rich help keeps every line break of a docstring, so the breaks of the source would cut sentences
in the middle of a terminal line.
"""

from __future__ import annotations

import importlib
import inspect
import math
import re
import signal
import sys
import warnings
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from pathlib import Path
from typing import Annotated, Any, NoReturn

import typer
from typer.core import TyperGroup

from sloshrom import __version__
from sloshrom._memory import without_huge_pages
from sloshrom.errors import Note, SloshromError
from sloshrom.fileio import OutputPathError, check_output, not_a_regular_file
from sloshrom.io import same_unit
from sloshrom.models import INPUT_UNITS, input_of

__all__ = [
    "OverwriteOpt", "app", "check_input", "check_number", "check_out", "check_sloshing_rom",
    "fail", "key_value_pairs", "route_warnings", "warn",
]

#: ``--overwrite`` of a command that writes fixed names into a folder the user names: without
#: it, a file there that the command did not write is refused (``check_out``'s ``owner``).
OverwriteOpt = Annotated[bool, typer.Option(
    "--overwrite", help="Replace files of the same names in the folder that this command did "
                        "not write (without it they are refused, named).")]


def _click_exceptions() -> Any:
    """The click exceptions module typer uses (its vendored copy in recent versions)."""
    base = typer.Context.__mro__[1].__module__.rsplit(".", 1)[0]  # "typer._click" or "click"
    return importlib.import_module(f"{base}.exceptions")


_LIST_ITEM = re.compile(r"^\s*([-*•]|\d+[.)])\s")


def help_paragraphs(text: str | None) -> str | None:
    """A docstring as help text: the lines of each paragraph joined into one line.

    typer's rich help prints a docstring's line breaks as they are; joined, each paragraph is
    wrapped to the terminal instead. A paragraph that is a list (a line after the first starts
    with ``-``, ``*``, ``•`` or ``1.``) or that starts with click's ``\\b`` marker keeps its lines.
    """
    if not text:
        return text
    out = []
    for para in inspect.cleandoc(text).split("\n\n"):
        lines = para.split("\n")
        keep = para.startswith("\b") or any(_LIST_ITEM.match(line) for line in lines[1:])
        out.append(para.removeprefix("\b\n") if keep else " ".join(ln.strip() for ln in lines))
    return "\n\n".join(out)


#: ``x`` (reStructuredText in the docstrings) printed as `x`; a table name such as [data]
#: escaped from rich's markup, which would print nothing for it (an escaped one left alone).
_RST_LITERAL = re.compile(r"``(.+?)``")
_TABLE_NAME = re.compile(r"(?<!\\)\[(?=[A-Za-z_][\w.]*\])")


def help_markup(text: str | None) -> str | None:
    """A help text as typer's rich help should get it: reStructuredText literals as `x`, and
    every ``[table]`` escaped so that rich's markup prints it (idempotent)."""
    if not text:
        return text
    return _TABLE_NAME.sub(r"\\[", _RST_LITERAL.sub(r"`\1`", text))


def _paragraph_help(group: Any) -> None:
    """:func:`help_paragraphs` and :func:`help_markup` on the help of every command, group and
    parameter under ``group``."""
    for cmd in getattr(group, "commands", {}).values():
        cmd.help = help_markup(help_paragraphs(cmd.help))
        cmd.short_help = help_markup(cmd.short_help)
        for p in getattr(cmd, "params", []):
            if getattr(p, "help", None):
                p.help = help_markup(p.help)
        _paragraph_help(cmd)


class _OneLineErrors(TyperGroup):
    """Root group whose usage errors (missing option, not a number, ...) are one line too.

    typer prints them in a framed panel over several lines; users (and scripts grepping
    ``error:``) get the same one-line form as the commands' own errors, exit code 2. So does a
    :class:`~sloshrom.errors.SloshromError` that a command did not catch itself. The help of
    every command reads as paragraphs (:func:`help_paragraphs`).
    """

    def main(self, args: Any = None, prog_name: str | None = None,
             complete_var: str | None = None, standalone_mode: bool = True,
             **extra: Any) -> Any:
        self.help = help_markup(help_paragraphs(self.help))
        _paragraph_help(self)
        _ignore_file_size_signal()
        without_huge_pages()  # (sloshrom._memory: seconds where huge pages are slow to come)
        if not standalone_mode:
            return super().main(args, prog_name, complete_var, standalone_mode=False, **extra)
        exc = _click_exceptions()
        try:
            rv = super().main(args, prog_name, complete_var, standalone_mode=False, **extra)
        except exc.ClickException as e:
            if type(e).__name__ == "NoArgsIsHelpError":  # `sloshrom rig`: the help, as before
                typer.echo(e.format_message(), err=True)
                sys.exit(e.exit_code)
            msg = " ".join(e.format_message().split())
            ctx = getattr(e, "ctx", None)
            if ctx is not None and isinstance(e, exc.UsageError):
                msg += f" (see '{ctx.command_path} --help')"
            typer.secho(f"error: {msg}", fg=typer.colors.RED, err=True)
            sys.exit(e.exit_code)
        except SloshromError as e:  # bad user input met deep inside: one line, not a traceback
            _error_line(str(e))
            sys.exit(2)
        except typer.Abort:  # (the vendored click of recent typers has no Abort of its own)
            typer.secho("error: aborted", fg=typer.colors.RED, err=True)
            sys.exit(1)
        sys.exit(rv if isinstance(rv, int) else 0)


def _ignore_file_size_signal() -> None:
    """Let a write beyond the file-size limit fail with ``EFBIG`` instead of killing us.

    ``SIGXFSZ``'s default action ends the process (with a core dump) before the failed write can
    be reported; ignored, the write raises an ``OSError`` that becomes one ``error:`` line and
    leaves the previous result intact (:mod:`sloshrom.fileio`). The command line owns its process.
    """
    if hasattr(signal, "SIGXFSZ"):
        try:
            signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
        except ValueError:  # not the main thread (the app run from a caller's thread)
            pass


app = typer.Typer(
    name="sloshrom",
    help="Neural-network reduced-order models of vertical sloshing and the sloshing beam.",
    no_args_is_help=True,
    add_completion=False,
    cls=_OneLineErrors,
)


def _print_version(value: bool) -> None:
    """``--version``: print the package version (pyproject.toml's, as installed) and stop."""
    if value:
        typer.echo(__version__)
        raise typer.Exit()


@app.callback()
def _main(ctx: typer.Context,
          version: Annotated[bool, typer.Option(
              "--version", callback=_print_version, is_eager=True,
              help="Print the package version and exit.")] = False) -> None:
    """Identify sloshing ROMs from shaker data and couple them with a flexible beam."""
    # for the whole command: closed (filters restored) when the command ends, however it ends
    ctx.with_resource(route_warnings())


@app.command()
def version() -> None:
    """Print the package version.

    Example: ``sloshrom version``
    """
    typer.echo(__version__)


def _error_line(msg: str) -> None:
    typer.secho(f"error: {' '.join(str(msg).split())}", fg=typer.colors.RED, err=True)


def fail(msg: str, paste: Sequence[str] = ()) -> NoReturn:
    """Report a user error in one red line on stderr and exit with code 2 (no traceback).

    ``paste``: lines printed verbatim after it (options or a table to copy into the command
    or a file), each indented by two spaces."""
    _error_line(msg)
    for line in paste:
        typer.echo(f"  {line}", err=True)
    raise typer.Exit(code=2)


def warn(msg: str) -> None:
    """One yellow ``warning: ...`` line on stderr (the command goes on)."""
    typer.secho(f"warning: {' '.join(str(msg).split())}", fg=typer.colors.YELLOW, err=True)


def check_out(
    path: Path,
    *,
    suffixes: tuple[str, ...] | None = None,
    inputs: tuple[Path | None, ...] = (),
    directory: bool = False,
    what: str = "--out",
    contents: tuple[str, ...] = (),
    owner: str | None = None,
    overwrite: bool = False,
) -> Path:
    """:func:`sloshrom.fileio.check_output` before any work; a user error if it fails.

    ``contents``: what a command writes inside the directory ``path`` (names; ``dir/`` for a
    whole tree): no input may be among it. ``owner``: the command (as its ``OutputBatch``
    records its files), which may replace only its own files there unless ``overwrite``
    (``--overwrite``)."""
    try:
        return check_output(path, suffixes=suffixes, inputs=tuple(i for i in inputs if i),
                            directory=directory, what=what, contents=contents, owner=owner,
                            overwrite=overwrite)
    except OutputPathError as exc:
        fail(str(exc))


def check_number(
    value: float | int | None,
    name: str,
    lo: float | None = None,
    hi: float | None = None,
    *,
    lo_open: bool = False,
    hi_open: bool = False,
    unit: str = "",
    why: str = "",
) -> None:
    """Fail unless ``value`` is finite and in the range (``None`` means: option not given).

    The message names the option, the accepted range with its unit, the value given and, if
    given, why the range is what it is.
    """
    if value is None:
        return
    ok = math.isfinite(value)
    ok = ok and (lo is None or (value > lo if lo_open else value >= lo))
    ok = ok and (hi is None or (value < hi if hi_open else value <= hi))
    if ok:
        return
    def g(v: float) -> str:
        return str(v) if isinstance(v, int) else f"{v:g}"

    u = f" {unit}" if unit else ""
    if lo is not None and hi is not None:
        rng = f"in {'(' if lo_open else '['}{g(lo)}, {g(hi)}{')' if hi_open else ']'}{u}"
    elif lo is not None:
        rng = f"{'>' if lo_open else '>='} {g(lo)}{u}"
    elif hi is not None:
        rng = f"{'<' if hi_open else '<='} {g(hi)}{u}"
    else:
        rng = "a finite number"
    fail(f"{name} must be {rng}, got {value!r}" + (f" ({why})" if why else ""))


def key_value_pairs(items: list[str] | None, what: str,
                    form: str = "KEY=VALUE") -> dict[str, str]:
    """Repeatable ``KEY=VALUE`` options as a mapping (both sides stripped, neither empty); a
    key given twice is an error naming it (never a silent "the last one wins").

    ``form`` names the two sides in the message, e.g. ``"NAME=UNIT"``.
    """
    out: dict[str, str] = {}
    for item in items or []:
        key, sep, value = item.partition("=")
        if not sep or not key.strip() or not value.strip():
            fail(f"{what} must look like {form}, got {item!r}")
        if key.strip() in out:
            fail(f"{what}: the key {key.strip()!r} is given twice ({out[key.strip()]!r} and "
                 f"{value.strip()!r}); give it once")
        out[key.strip()] = value.strip()
    return out


def check_input(path: Path | None, what: str) -> None:
    """Fail unless ``path`` (if given) is an existing regular file (not a directory, a named
    pipe, a socket or a device: each said as such)."""
    if path is None:
        return
    if not str(path).strip():
        fail(f"{what}: empty path")
    why = not_a_regular_file(path)
    if why is not None:
        fail(f"{what} {path}: {why}")
    if not path.is_file():
        fail(f"{what} {path}: no such file")


# -- warnings ------------------------------------------------------------------------------------
_NOISE = (DeprecationWarning, PendingDeprecationWarning, FutureWarning)
_SITE = re.compile(r"(?:site|dist)-packages[/\\]([A-Za-z0-9_]+)")


def _origin(filename: str) -> str:
    """The package a warning comes from (``sloshrom``, ``numpy``, ...; ``""`` if unknown)."""
    m = _SITE.search(filename)
    if m:
        return m.group(1)
    return "sloshrom" if re.search(r"[/\\]sloshrom[/\\]", filename) else ""


@contextmanager
def route_warnings() -> Iterator[None]:
    """Warnings as one yellow ``warning: ...`` line each, while the block runs.

    Our own warnings (``EnvelopeWarning``, a ROM leaving its training envelope, a test outside
    the rig's calibrated domain) and third-party warnings about the user's data (numpy
    ``RuntimeWarning``, scipy's "nperseg is greater than the input length", ...) are shown
    once each, the latter with their origin; a :class:`~sloshrom.errors.Note` (information that
    changes no result) is one plain ``note: ...`` line; third-party ``DeprecationWarning``/
    ``FutureWarning`` (xarray, JAX, ... talking to developers) are silenced.
    """
    seen: set[str] = set()

    def show(message: Any, category: type[Warning], filename: str, lineno: int,
             file: Any = None, line: str | None = None) -> None:
        text = " ".join(str(message).split())
        if issubclass(category, Note):  # information, not a warning: one plain line
            if text not in seen:
                seen.add(text)
                typer.echo(f"note: {text}", err=True)
            return
        origin = _origin(filename)
        if origin != "sloshrom":
            text += f" ({category.__name__}{' from ' + origin if origin else ''})"
        if text not in seen:
            seen.add(text)
            warn(text)

    with warnings.catch_warnings():
        warnings.simplefilter("default")
        for cat in _NOISE:  # not ours: a module name that does not start with "sloshrom"
            warnings.filterwarnings("ignore", category=cat, module=r"(?!sloshrom\b)")
        warnings.showwarning = show
        yield


def check_sloshing_rom(rom: Any, path: Path, what: str, user: str) -> None:
    """A ROM used as a sloshing model must map the tank velocity (m/s), or for a network on it
    the tank acceleration (m/s^2), to a force (N).

    ``user`` says who feeds it, as the subject of "feeds it the tank velocity ...".
    """
    # the records it was identified from: their input is the tank velocity or acceleration
    var = str(rom.names[0]) if str(rom.names[0]) in INPUT_UNITS else input_of(rom)
    unit = INPUT_UNITS[var]
    if not (same_unit(rom.units[0], unit) and same_unit(rom.units[1], "N")):
        fail(f"{what} {path}: the ROM maps '{rom.units[0]}' to '{rom.units[1]}'; {user} feeds "
             f"it the tank {var} in {unit} and reads the dynamic force in N")
