"""Worker processes end with the process that started them (``sloshrom._workers``).

Each test starts a parent process that opens a pool, prints its workers' process ids and kills
itself; the test then watches the workers, now orphans, from outside. A control pool without the
initializer shows that its workers stay: the situation the initializer exists for.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import pytest

from sloshrom._workers import ORPHAN_EXIT, POLL_SECONDS

pytestmark = pytest.mark.skipif(sys.platform != "linux", reason="reads /proc")

#: Seconds an orphan may take to end: a few polls, and a loaded machine's scheduling.
GRACE = 20 * POLL_SECONDS


def _ended(pid: int) -> bool:
    """True once ``pid`` has exited (gone, or a zombie that nobody reaps)."""
    try:
        stat = Path(f"/proc/{pid}/stat").read_text()
    except (FileNotFoundError, ProcessLookupError):
        return True
    return stat.rsplit(")", 1)[1].split()[0] in ("Z", "X")


def _wait_ended(pids: list[int], seconds: float) -> list[int]:
    """The pids still running after ``seconds``."""
    deadline = time.monotonic() + seconds
    while time.monotonic() < deadline:
        left = [p for p in pids if not _ended(p)]
        if not left:
            return []
        time.sleep(0.1)
    return [p for p in pids if not _ended(p)]


def _orphans(body: str, kill: signal.Signals, tmp_path: Path) -> list[int]:
    """Run ``body`` in a parent killed by ``kill`` where the body calls ``report(pids)`` (its
    workers' ids); return those ids."""
    script = textwrap.dedent("""
        import os, signal, sys
        def report(pids):
            print(" ".join(map(str, pids)), flush=True)
            os.kill(os.getpid(), signal.{kill})
        if __name__ == "__main__":
        {body}
    """).format(body=textwrap.indent(textwrap.dedent(body), "    "), kill=kill.name)
    # the first line only, then the parent's end: an orphan keeps the inherited pipes open
    err = tmp_path / "stderr.txt"
    with open(err, "w") as fh:
        proc = subprocess.Popen([sys.executable, "-c", script], stdout=subprocess.PIPE,
                                stderr=fh, text=True)
        assert proc.stdout is not None
        line = proc.stdout.readline()
        proc.stdout.close()
        assert proc.wait(timeout=120) == -kill, err.read_text()
    return [int(p) for p in line.split()]


def _kill(pids: list[int]) -> None:
    for p in pids:
        try:
            os.kill(p, signal.SIGKILL)
        except ProcessLookupError:
            pass


POOL = """
    import multiprocessing
    from concurrent.futures import ProcessPoolExecutor
    from sloshrom._workers import worker_init
    ctx = multiprocessing.get_context("spawn")
    {pool}
    futures = [pool.submit(os.getpid) for _ in range(8)]
    report(sorted({{f.result() for f in futures}}))
"""


@pytest.mark.parametrize("kill", [signal.SIGKILL, signal.SIGTERM])
def test_a_pools_workers_end_when_their_parent_is_killed(kill: signal.Signals,
                                                        tmp_path: Path) -> None:
    pids = _orphans(POOL.format(pool="pool = ProcessPoolExecutor(1, mp_context=ctx, "
                                     "initializer=worker_init, initargs=(os.getpid(),))"), kill,
                    tmp_path)
    try:
        assert pids
        assert _wait_ended(pids, GRACE) == []
    finally:
        _kill(pids)


@pytest.mark.long
def test_without_the_initializer_the_orphans_stay(tmp_path: Path) -> None:
    """The control: a plain pool's worker outlives its killed parent."""
    pids = _orphans(POOL.format(pool="pool = ProcessPoolExecutor(1, mp_context=ctx)"),
                    signal.SIGKILL, tmp_path)
    try:
        assert pids
        assert _wait_ended(pids, 6 * POLL_SECONDS) == pids
    finally:
        _kill(pids)


@pytest.mark.long
def test_the_beam_stages_analysis_workers_end_with_the_stage(tmp_path: Path) -> None:
    body = """
        import time
        from sloshrom.pipeline.beam import analysis_pool
        with analysis_pool(2) as pool:
            # both workers up (past their start, which a parent's death would also end)
            seen, deadline = set(), time.monotonic() + 60
            while len(seen) < 2 and time.monotonic() < deadline:
                seen |= {f.result() for f in [pool.submit(os.getpid) for _ in range(50)]}
            report(sorted(seen))  # in the pool's block: the pool still open
    """
    pids = _orphans(body, signal.SIGTERM, tmp_path)
    try:
        assert len(pids) == 2
        assert _wait_ended(pids, GRACE) == []
    finally:
        _kill(pids)


def test_a_watch_whose_parent_has_already_gone_ends_the_process_at_once() -> None:
    """A parent id passed in that is not the process's parent (it died before the worker
    started): the worker ends at the first look, with ``ORPHAN_EXIT``; the watching thread is
    a daemon, which never keeps a finished worker alive."""
    code = ("import os, time\nfrom sloshrom._workers import exit_with_parent\n"
            "assert exit_with_parent(os.getppid() + 10**7).daemon\ntime.sleep(30)\n")
    # without the watch the script sleeps its 30 s and exits 0
    out = subprocess.run([sys.executable, "-c", code], timeout=60)
    assert out.returncode == ORPHAN_EXIT
