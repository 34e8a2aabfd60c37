"""Progress of the long commands: rich's bars on a terminal, plain log lines otherwise.

Without a terminal (CI, ``nohup``, a pipe, ``make reproduce > log``) rich's live bars print
nothing until the command ends. :func:`progress_bars` then returns a :class:`PlainProgress`
instead, with the same methods (:class:`Bars`), which writes one flushed line per event on
stderr::

    [  12.3 s] rom: start
    [  42.3 s] rom: training NFIR(70, 35): epoch 12/200, train 0.0123, val 0.0151 N^2, ...
    [ 205.1 s] rom: done in 192.8 s

A task's first report is a line at once; later ones at most every ``every`` seconds (30 s):
the latest is kept, and a heartbeat prints it when nothing was printed for ``heartbeat``
seconds (30 s), so that a log shows a line at least every 30 s while the command runs.
"""

from __future__ import annotations

import sys
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from types import TracebackType
from typing import TYPE_CHECKING, Protocol, Self, TextIO, cast

if TYPE_CHECKING:  # rich's progress loads at the command, not at --help
    from rich.console import Console
    from rich.progress import ProgressColumn, TaskID

__all__ = ["Bars", "PlainProgress", "progress_bars", "stage_events"]

#: Seconds between two progress lines of a task at least, in a log.
EVERY = 30.0
#: Seconds without a line after which the heartbeat prints one.
HEARTBEAT = 30.0


class Bars(Protocol):
    """What the commands use of rich's ``Progress``: :class:`PlainProgress` has it too.

    ``stage`` and ``info`` are the task fields the commands' columns show
    (``{task.fields[stage]}``, ``{task.fields[info]}``).
    """

    def __enter__(self) -> Self: ...

    def __exit__(self, exc_type: type[BaseException] | None, exc: BaseException | None,
                 tb: TracebackType | None) -> None: ...

    def add_task(self, description: str, *, total: float | None = ..., info: str = ...,
                 stage: str = ...) -> TaskID:
        """A new task (a bar, a spinner without ``total``); its id."""
        ...

    def update(self, task_id: TaskID, *, total: float | None = ..., completed: float | None = ...,
               advance: float | None = ..., description: str | None = ...,
               info: str = ...) -> None:
        """Change a task's total, progress, description or info."""
        ...

    def remove_task(self, task_id: TaskID) -> None:
        """Forget a task."""
        ...

    def stop(self) -> None:
        """Stop the display (before an error line)."""
        ...


@dataclass
class _Task:
    head: str  # what starts its lines: its stage, else its first description
    description: str
    info: str
    total: float | None
    completed: float = 0.0
    printed: float = -float("inf")  # when its last line was printed (clock time)

    def text(self) -> str:
        """``head: description, info (done/total)``; the count only where the text lacks it."""
        body = ", ".join(p for p in (self.description if self.description != self.head
                                     else "", self.info) if p)
        if self.total:
            count = f"{self.completed:g}/{self.total:g}"
            if count not in body:
                body = f"{body} ({count})" if body else count
        return f"{self.head}: {body}" if body else self.head


class PlainProgress:
    """Progress as plain log lines ``[  12.3 s] text`` on a stream (default: stderr).

    Parameters
    ----------
    stream : text stream, optional
        Where the lines go (default: ``sys.stderr`` when created), flushed after each line.
    every : float
        Seconds between two progress lines of one task at least (the throttle).
    heartbeat : float
        Seconds without a line after which the latest state is printed again (the
        heartbeat thread, started by :meth:`start` or ``with``).
    clock : callable
        Seconds, monotonic (tests pass their own).
    """

    def __init__(self, stream: TextIO | None = None, *, every: float = EVERY,
                 heartbeat: float = HEARTBEAT, clock: Callable[[], float] = time.monotonic
                 ) -> None:
        self.stream = sys.stderr if stream is None else stream
        self.every, self.heartbeat, self.clock = float(every), float(heartbeat), clock
        self._t0 = clock()
        self._lock = threading.RLock()
        self._tasks: dict[int, _Task] = {}
        self._next = 0
        # the latest news (a task's state or an event line), when it came, whether printed
        self._latest: tuple[int | None, str, float, bool] | None = None
        self._last_line = self._t0
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None

    # -- lines -----------------------------------------------------------------------------------
    def _write(self, text: str, now: float) -> None:
        self._last_line = now
        try:
            self.stream.write(f"[{now - self._t0:7.1f} s] {text}\n")
            self.stream.flush()
        except (OSError, ValueError):  # the reader went away (a closed pipe): not the run's end
            pass

    def line(self, text: str) -> None:
        """Print ``text`` now (an event: not throttled)."""
        with self._lock:
            now = self.clock()
            self._write(text, now)
            self._latest = (None, text, now, True)

    def stage(self, stage: str, event: str, seconds: float) -> None:
        """A stage of ``sloshrom reproduce`` started, is done or was reused
        (:data:`sloshrom.pipeline.context.StageEvents`)."""
        if event == "start":
            self.line(f"{stage}: start")
        elif event == "reused":
            self.line(f"{stage}: reused (cached)")
        else:
            self.line(f"{stage}: {event} in {seconds:.1f} s")

    def _news(self, tid: int, first: bool) -> None:
        """Task ``tid`` changed: print it if it is new or its last line is ``every`` old."""
        task = self._tasks[tid]
        now = self.clock()
        due = first or now - task.printed >= self.every
        if due:
            self._write(task.text(), now)
            task.printed = now
        self._latest = (tid, task.text(), now, due)

    def beat(self) -> None:
        """The heartbeat: nothing printed for ``heartbeat`` s, print the latest news (a task's
        state the throttle held back), or say again the last one printed and how old it is."""
        with self._lock:
            now = self.clock()
            if self._latest is None or now - self._last_line < self.heartbeat:
                return
            tid, text, when, printed = self._latest
            if tid is not None:
                self._tasks[tid].printed = now
            self._write(f"still running, last news {now - when:.0f} s ago: {text}"
                        if printed else text, now)
            self._latest = (tid, text, when, True)

    # -- rich's Progress interface ---------------------------------------------------------------
    def add_task(self, description: str, *, total: float | None = None, info: str = "",
                 stage: str = "") -> TaskID:
        """A new task (its line is printed at once); its id."""
        with self._lock:
            tid = self._next
            self._next += 1
            self._tasks[tid] = _Task(stage or description, description, info, total)
            self._news(tid, first=True)
        return cast("TaskID", tid)

    def update(self, task_id: TaskID, *, total: float | None = None,
               completed: float | None = None, advance: float | None = None,
               description: str | None = None, info: str | None = None) -> None:
        """Change a task as rich's ``Progress.update`` does; a line if one is due."""
        with self._lock:
            task = self._tasks.get(task_id)
            if task is None:
                return
            if total is not None:
                task.total = total
            if completed is not None:
                task.completed = completed
            if advance is not None:
                task.completed += advance
            if description is not None:
                task.description = description
            if info is not None:
                task.info = info
            self._news(task_id, first=False)

    def remove_task(self, task_id: TaskID) -> None:
        """Forget a task (its last state stays the latest news until another comes)."""
        with self._lock:
            self._tasks.pop(task_id, None)
            if self._latest is not None and self._latest[0] == task_id:
                self._latest = (None, *self._latest[1:])

    def start(self) -> None:
        """Start the heartbeat thread (a daemon: it never keeps the process alive); none for
        a heartbeat <= 0."""
        if self._thread is not None or self.heartbeat <= 0:
            return
        self._stop.clear()

        def due() -> float:
            # wake when the heartbeat is due (not on a coarse tick: a log's gaps stay <= 30 s)
            with self._lock:
                wait = self._last_line + self.heartbeat - self.clock()
            return min(max(wait, 0.005), self.heartbeat)

        def loop() -> None:
            while not self._stop.wait(due()):
                self.beat()

        self._thread = threading.Thread(target=loop, name="sloshrom-heartbeat", daemon=True)
        self._thread.start()

    def stop(self) -> None:
        """Stop the heartbeat thread (idempotent)."""
        if self._thread is None:
            return
        self._stop.set()
        self._thread.join()
        self._thread = None

    def __enter__(self) -> Self:
        self.start()
        return self

    def __exit__(self, exc_type: type[BaseException] | None, exc: BaseException | None,
                 tb: TracebackType | None) -> None:
        self.stop()


def progress_bars(*columns: str | ProgressColumn, console: Console | None = None,
                  transient: bool = False) -> Bars:
    """rich's ``Progress(*columns, console=console, transient=transient)`` when ``console``
    (default: rich's, on stdout) is an interactive terminal, where its bars are drawn as
    today; else a :class:`PlainProgress` on stderr (module docstring).

    ``console.is_interactive`` is rich's own test of whether it can animate (a terminal, and
    not a dumb one; ``TTY_COMPATIBLE=0``/``1`` forces it).
    """
    from rich.console import Console
    from rich.progress import Progress

    console = Console() if console is None else console
    if console.is_interactive or console.is_jupyter:
        return Progress(*columns, console=console, transient=transient)
    return PlainProgress(every=EVERY, heartbeat=HEARTBEAT)  # read here: tests change them


def _unsaid(stage: str, event: str, seconds: float) -> None:
    """Stage events on a terminal: rich's bars show the stages as they are."""


def stage_events(bars: Bars) -> Callable[[str, str, float], None]:
    """The stage events of ``sloshrom reproduce``
    (:data:`~sloshrom.pipeline.context.StageEvents`): lines of a :class:`PlainProgress`, nothing
    beside rich's bars."""
    return bars.stage if isinstance(bars, PlainProgress) else _unsaid
