"""Run a command and say which of its processes and threads used the CPU, and when.

A stage that keeps both cores busy can still spend its time on the wrong work: a scheduler's
threads, a second XLA thread, a worker's imports. This runs ``CMD`` and reads, every
``--interval`` seconds, the CPU time of every thread of it and of its descendants
(``/proc/PID/task/TID/stat``: user + system), then prints one line per thread that used at
least ``--min`` CPU seconds (on standard error: the command keeps its own output): its
process and thread ids, its name, its CPU seconds in all, and in each of ``--buckets`` equal
slices of the run (or of ``--window START END``, seconds after the start). A process's line
sums its threads.

Linux only (``/proc``). Threads that live shorter than an interval are not seen; CPU time is
counted in the kernel's clock ticks (10 ms on most systems). The sampling itself costs well
under 1 % of a core (0.07 CPU s in a 10 s run, a few hundred processes on the machine).

Usage::

    python tools/thread_cpu.py [--interval 0.5] [--buckets 10] [--min 0.5] -- CMD [ARG ...]

Example: the ROM stage of a results folder, rerun::

    rm r/.stages/rom.json && python tools/thread_cpu.py --window 0 100 -- \\
        .venv/bin/sloshrom reproduce --out r

The exit status is the command's (128 + N when signal N killed it). Ctrl-C stops the command
and prints what was sampled until then.
"""

from __future__ import annotations

import argparse
import os
import signal
import subprocess
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

PROC = Path("/proc")


@dataclass
class Thread:
    """CPU ticks of one thread, sampled over time."""

    pid: int
    tid: int
    name: str
    command: str
    samples: list[tuple[float, int]] = field(default_factory=list)

    def used(self, start: float, end: float, tick: float) -> float:
        """CPU seconds between ``start`` and ``end`` (seconds of the run), as sampled."""
        before = [v for t, v in self.samples if t <= start]
        upto = [v for t, v in self.samples if t <= end]
        first = self.samples[0][1]
        return ((upto[-1] if upto else first) - (before[-1] if before else first)) * tick


def _stat(path: Path) -> tuple[str, int, int] | None:
    """(name, parent pid, user + system ticks) of a /proc stat file, or None if it is gone."""
    try:
        text = path.read_text()
    except (FileNotFoundError, ProcessLookupError, PermissionError):
        return None
    # the name is in parentheses and may hold spaces or parentheses itself
    name = text[text.index("(") + 1:text.rindex(")")]
    rest = text[text.rindex(")") + 2:].split()
    return name, int(rest[1]), int(rest[11]) + int(rest[12])


def _descendants(root: int) -> set[int]:
    """``root`` and every process below it."""
    parent: dict[int, int] = {}
    for entry in PROC.iterdir():
        if entry.name.isdigit():
            st = _stat(entry / "stat")
            if st is not None:
                parent[int(entry.name)] = st[1]
    found, grew = {root}, True
    while grew:
        new = {p for p, pp in parent.items() if pp in found and p not in found}
        found |= new
        grew = bool(new)
    return found


def _command(pid: int) -> str:
    try:
        raw = (PROC / str(pid) / "cmdline").read_bytes()
    except (FileNotFoundError, ProcessLookupError, PermissionError):
        return "?"
    return " ".join(raw.replace(b"\0", b" ").decode(errors="replace").split()) or "?"


def sample(root: int, threads: dict[tuple[int, int], Thread], now: float) -> None:
    """Add one sample of every thread of ``root``'s process tree to ``threads``."""
    for pid in _descendants(root):
        try:
            tids = [int(t.name) for t in (PROC / str(pid) / "task").iterdir()]
        except (FileNotFoundError, ProcessLookupError, PermissionError):
            continue
        for tid in tids:
            st = _stat(PROC / str(pid) / "task" / str(tid) / "stat")
            if st is None:
                continue
            key = (pid, tid)
            if key not in threads:
                threads[key] = Thread(pid, tid, st[0], _command(pid))
            threads[key].name = st[0]
            threads[key].samples.append((now, st[2]))


def report(threads: dict[tuple[int, int], Thread], start: float, end: float, buckets: int,
           minimum: float, tick: float) -> str:
    """The table: per process, its threads that used at least ``minimum`` CPU seconds."""
    width = (end - start) / buckets
    edges = [start + k * width for k in range(buckets + 1)]
    lines = [f"CPU seconds from {start:.1f} to {end:.1f} s of the run, in {buckets} slices of "
             f"{width:.1f} s"]
    used = {key: th.used(start, end, tick) for key, th in threads.items()}
    by_pid: dict[int, list[Thread]] = {}
    for th in sorted(threads.values(), key=lambda t: -used[t.pid, t.tid]):
        by_pid.setdefault(th.pid, []).append(th)
    per_pid = {pid: sum(used[t.pid, t.tid] for t in ths) for pid, ths in by_pid.items()}
    total = 0.0
    for pid in sorted(per_pid, key=lambda p: -per_pid[p]):
        if per_pid[pid] < minimum:
            continue
        total += per_pid[pid]
        lines.append(f"process {pid}: {per_pid[pid]:.2f} s  {by_pid[pid][0].command[:100]}")
        for th in by_pid[pid]:
            u = used[th.pid, th.tid]
            if u < minimum:
                continue
            # to the clock's tick (10 ms), so that the slices add up to the thread's total
            slices = " ".join(f"{th.used(a, b, tick):5.2f}"
                              for a, b in zip(edges[:-1], edges[1:], strict=True))
            lines.append(f"  {th.tid:>8} {th.name[:15]:15s} {u:7.2f}  [{slices}]")
    lines.append(f"all processes shown: {total:.1f} CPU s in {end - start:.1f} s "
                 f"({os.cpu_count()} CPUs)")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--interval", type=float, default=0.5, help="seconds between samples")
    ap.add_argument("--buckets", type=int, default=10, help="slices of the run to show")
    ap.add_argument("--min", type=float, default=0.5, dest="minimum",
                    help="CPU seconds a thread must use to be shown")
    ap.add_argument("--window", type=float, nargs=2, metavar=("START", "END"),
                    help="seconds of the run to report (default: all of it)")
    ap.add_argument("command", nargs=argparse.REMAINDER, help="-- CMD [ARG ...]")
    a = ap.parse_args(argv)
    cmd = a.command[1:] if a.command[:1] == ["--"] else a.command
    if not cmd:
        ap.error("no command: give it after --")
    if not (PROC / "self" / "task").is_dir():
        ap.error("this tool reads /proc: Linux only")
    if not a.interval > 0 or a.buckets < 1:
        ap.error("--interval must be > 0 and --buckets >= 1")
    if a.window and not a.window[1] > a.window[0] >= 0:
        ap.error("--window: START must be >= 0 and END after START")
    tick = 1.0 / os.sysconf("SC_CLK_TCK")
    threads: dict[tuple[int, int], Thread] = {}
    t0 = time.perf_counter()
    try:
        proc = subprocess.Popen(cmd)
    except OSError as err:
        ap.error(f"cannot run {cmd[0]!r}: {err}")
    try:
        while proc.poll() is None:
            sample(proc.pid, threads, time.perf_counter() - t0)
            time.sleep(a.interval)
    except KeyboardInterrupt:
        # Ctrl-C at a terminal reaches the command too (one process group); an interrupt
        # sent to this process alone is passed on
        try:
            proc.wait(timeout=2)
        except subprocess.TimeoutExpired:
            proc.send_signal(signal.SIGINT)
            proc.wait()
    elapsed = time.perf_counter() - t0
    start, end = a.window if a.window else (0.0, elapsed)
    if start >= elapsed:
        print(f"the run lasted {elapsed:.1f} s: nothing in --window {start:g} {end:g}",
              file=sys.stderr)
    else:
        print(report(threads, start, min(end, elapsed), a.buckets, a.minimum, tick),
              file=sys.stderr)
    # a command killed by signal N exits as a shell reports it: 128 + N
    return proc.returncode if proc.returncode >= 0 else 128 - proc.returncode


if __name__ == "__main__":
    sys.exit(main())
