"""Epoch-by-epoch progress of a training: its pace, the time left, and the epochs of ensemble
members that train in other processes.

A trainer calls ``callback(epoch, info)`` after every epoch (:func:`sloshrom.rom.engine.
adam_epochs`, :func:`sloshrom.rom.lm.levenberg_marquardt`); ``info`` holds ``train_mse`` and
``val_mse`` (the output unit squared) and ``seconds`` (since the training started).
:class:`TrainingProgress` turns these reports into one line of text: the epoch, both errors and
the time left, (max_epochs - epoch) x the median epoch time, an upper bound (early stopping may
end the training sooner).

The members of an :class:`~sloshrom.rom.ensemble.Ensemble` train in Dask worker processes,
which report only when a member has finished. Their epochs reach the parent through files:
each member's callback (:class:`EpochFile`, picklable) replaces ``member-K.json`` in a temporary
directory with its latest epoch, and a thread of the parent (:func:`epoch_reports`) polls the
directory. Files work with every scheduler on one machine (processes, threads, sequential);
a worker on another machine cannot write there and its member reports only when it finishes.
"""

from __future__ import annotations

import json
import math
import os
import statistics
import tempfile
import threading
import time
from collections.abc import Callable, Iterator, Mapping
from contextlib import contextmanager
from pathlib import Path

__all__ = ["EpochFile", "EpochPace", "EpochReport", "TrainingProgress", "duration_text",
           "epoch_reports", "poll_once"]

#: Called as ``report(member, epoch, info)`` with a member's latest epoch and its ``info``.
EpochReport = Callable[[int, int, Mapping[str, float]], object]


def duration_text(seconds: float) -> str:
    """``42 s``, ``3 min 10 s``, ``1 h 05 min``: a duration for a log line."""
    s = max(0, round(seconds))
    if s < 60:
        return f"{s} s"
    if s < 3600:
        return f"{s // 60} min {s % 60:02d} s"
    return f"{s // 3600} h {s % 3600 // 60:02d} min"


class EpochPace:
    """The time per epoch of one training, from its reports ``(epoch, seconds)``.

    Reports may skip epochs (a member's file is read about once a second): each pair of
    successive reports gives the mean epoch time between them. The median of these ignores the
    first epoch's compilation once a few epochs have run.
    """

    def __init__(self) -> None:
        self._last: tuple[int, float] | None = None
        #: mean seconds per epoch between successive reports
        self.durations: list[float] = []

    def observe(self, epoch: int, seconds: float) -> None:
        """A report: ``epoch`` finished ``seconds`` after the training started."""
        if not math.isfinite(seconds):
            return
        if self._last is not None and epoch > self._last[0]:
            self.durations.append((seconds - self._last[1]) / (epoch - self._last[0]))
        if self._last is None or epoch > self._last[0]:
            self._last = (epoch, seconds)


class TrainingProgress:
    """What a training, or the members of an ensemble, reported so far, as one line of text.

    Thread-safe: an ensemble's members report from a polling thread while the caller's thread
    says which member finished.

    Parameters
    ----------
    max_epochs : int
        The epochs at most of each training (its ``max_epochs``; 0: no epochs, no time left).
    members : int
        Trainings reported on: 1, or the members of an ensemble.
    concurrent : int
        Members that train at once (the workers); divides the time left of an ensemble.
    unit : str
        The unit of the errors (e.g. ``N^2``), printed after the validation error.
    """

    def __init__(self, max_epochs: int, members: int = 1, concurrent: int = 1,
                 unit: str = "") -> None:
        self.max_epochs = max(0, int(max_epochs))
        self.members = max(1, int(members))
        self.concurrent = max(1, int(concurrent))
        self.unit = unit
        self._lock = threading.Lock()
        self._epoch = [0] * self.members
        self._finished = [False] * self.members
        self._paces = [EpochPace() for _ in range(self.members)]
        self._latest: tuple[int, int, dict[str, float]] | None = None

    def epoch(self, epoch: int, info: Mapping[str, float], member: int = 0) -> bool:
        """A training callback's report: ``epoch`` of ``member`` and its ``info``; False
        (ignored) when the member has finished already (a late file)."""
        with self._lock:
            if self._finished[member]:
                return False
            self._epoch[member] = max(self._epoch[member], int(epoch))
            self._paces[member].observe(int(epoch), float(info.get("seconds", math.nan)))
            self._latest = (member, int(epoch), {k: float(v) for k, v in info.items()})
            return True

    def finished(self, member: int) -> None:
        """Member ``member`` returned (its early stop counts as its last epoch)."""
        with self._lock:
            self._finished[member] = True

    @property
    def total(self) -> int:
        """Epochs of every training at most (the length of a progress bar)."""
        return self.members * self.max_epochs

    @property
    def done(self) -> int:
        """Epochs run, a finished training counting as all its epochs."""
        with self._lock:
            return sum(self.max_epochs if f else min(e, self.max_epochs)
                       for e, f in zip(self._epoch, self._finished, strict=True))

    def epoch_seconds(self) -> float | None:
        """The median epoch time over every training so far, s (None before two reports)."""
        with self._lock:
            d = [x for p in self._paces for x in p.durations]
        return statistics.median(d) if d else None

    def seconds_left(self) -> float | None:
        """(max_epochs - epoch) x the median epoch time, summed over the unfinished trainings
        and divided among the ``concurrent`` ones: an upper bound (early stopping may end a
        training sooner); None while unknown."""
        per_epoch = self.epoch_seconds()
        if per_epoch is None or self.max_epochs == 0:
            return None
        with self._lock:
            left = [self.max_epochs - min(e, self.max_epochs)
                    for e, f in zip(self._epoch, self._finished, strict=True) if not f]
        return sum(left) * per_epoch / max(1, min(self.concurrent, len(left)))

    def text(self) -> str:
        """``epoch 12/200, train 1.2e-03, val 2.3e-03 N^2, at most 1 min 10 s left``; for an
        ensemble, the members done first and the latest member's epoch."""
        with self._lock:
            latest = self._latest
            n_done = sum(self._finished)
        parts = []
        if self.members > 1:
            parts.append(f"{n_done}/{self.members} members done")
        if latest is not None:
            member, epoch, info = latest
            who = f"member {member} " if self.members > 1 else ""
            of = f"/{self.max_epochs}" if self.max_epochs else ""
            # the errors it has (Adam's epoch 0 has no training error yet; no validation
            # record, none), then Levenberg-Marquardt's damping: whether it still progresses
            shown = [f"{label} {info[key]:.3g}" for label, key in
                     (("train", "train_mse"), ("val", "val_mse"))
                     if math.isfinite(info.get(key, math.nan))]
            if shown and self.unit:
                shown[-1] += f" {self.unit}"
            if math.isfinite(info.get("mu", math.nan)):
                shown.append(f"mu {info['mu']:.1e}")
            parts.append(", ".join([f"{who}epoch {epoch}{of}", *shown]))
        left = self.seconds_left()
        if left is not None:
            parts.append(f"at most {duration_text(left)} left")
        return "; ".join(parts) if self.members > 1 else ", ".join(parts)


class EpochFile:
    """A training callback that writes the latest epoch of member ``member`` to
    ``directory/member-<member>.json`` (replaced atomically), at most every ``min_interval``
    seconds; picklable, for Dask worker processes.

    It returns None (a true value would stop the training) and never raises: a directory it
    cannot write (a worker on another machine) only loses the progress.
    """

    def __init__(self, directory: str, member: int, min_interval: float = 0.25) -> None:
        self.directory = directory
        self.member = int(member)
        self.min_interval = float(min_interval)
        self._last = -math.inf

    def __call__(self, epoch: int, info: Mapping[str, float]) -> None:
        """The trainer's callback after ``epoch``: write it (unless one was written within
        ``min_interval`` s)."""
        now = time.monotonic()
        if now - self._last < self.min_interval:
            return
        self._last = now
        path = Path(self.directory) / f"member-{self.member}.json"
        tmp = path.with_suffix(".tmp")
        try:
            tmp.write_text(json.dumps({"epoch": int(epoch),
                                       "info": {k: float(v) for k, v in info.items()}}))
            os.replace(tmp, path)
        except (OSError, TypeError, ValueError):  # progress only: the training goes on
            return


def _read(path: Path) -> tuple[int, dict[str, float]] | None:
    """The epoch and info of a member's file; None if unreadable (being replaced, foreign)."""
    try:
        rec = json.loads(path.read_text())
        return int(rec["epoch"]), {str(k): float(v) for k, v in rec["info"].items()}
    except (OSError, ValueError, TypeError, KeyError, AttributeError):
        return None


def poll_once(directory: Path, seen: dict[int, int], report: EpochReport) -> None:
    """Report every member whose file in ``directory`` holds an epoch after ``seen[member]``
    (updated)."""
    for path in sorted(directory.glob("member-*.json")):
        try:
            member = int(path.stem.removeprefix("member-"))
        except ValueError:
            continue
        got = _read(path)
        if got is not None and got[0] > seen.get(member, -1):
            seen[member] = got[0]
            report(member, got[0], got[1])


@contextmanager
def epoch_reports(report: EpochReport | None, interval: float = 1.0) -> Iterator[str | None]:
    """A temporary directory for :class:`EpochFile` callbacks, polled every ``interval``
    seconds by a daemon thread that calls ``report(member, epoch, info)`` with each new epoch
    (a last time when the block ends without an error); yields its path, or None (and no
    thread) when ``report`` is None.
    """
    if report is None:
        yield None
        return
    with tempfile.TemporaryDirectory(prefix="sloshrom-epochs-",
                                     ignore_cleanup_errors=True) as d:
        seen: dict[int, int] = {}
        stop = threading.Event()

        def loop() -> None:
            while not stop.wait(interval):
                poll_once(Path(d), seen, report)

        thread = threading.Thread(target=loop, name="sloshrom-epochs", daemon=True)
        thread.start()
        try:
            yield d
        finally:
            stop.set()
            thread.join()
        poll_once(Path(d), seen, report)  # the last epochs (not after an error: it goes on up)
