"""tools/thread_cpu.py: a busy thread of a child process is found, with its CPU time."""

from __future__ import annotations

import re
import subprocess
import sys

import pytest

from helpers import REPO

TOOL = REPO / "tools" / "thread_cpu.py"

pytestmark = pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads /proc")

# a child that spins one thread for about 1.2 s of CPU, prints its id, and exits with status 3
SPIN = """
import threading, time
def spin():
    print(threading.get_native_id(), flush=True)
    t0 = time.process_time()
    while time.process_time() - t0 < 1.2:
        pass
th = threading.Thread(target=spin)
th.start(); th.join()
raise SystemExit(3)
"""


def _run(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, str(TOOL), *args], capture_output=True, text=True,
                          check=False, timeout=60)


def test_a_busy_thread_is_found_with_its_cpu_and_the_exit_status_kept():
    out = _run("--interval", "0.1", "--buckets", "3", "--", sys.executable, "-c", SPIN)
    assert out.returncode == 3, out.stderr
    # the thread's line: tid, name, CPU seconds, then the three slices
    tid = out.stdout.split()[0]
    line = next(ln for ln in out.stderr.splitlines() if ln.split()[:1] == [tid])
    used = float(line.split()[2])
    slices = [float(x) for x in re.search(r"\[(.*)\]", line).group(1).split()]
    assert 0.8 <= used <= 1.4  # 1.2 s spun, less at most the last interval before it ended
    # printed to the 10 ms tick: the slices add up to the total (they were printed to 0.1 s,
    # and a spin spread over two slices then missed it by up to 0.15 s)
    assert len(slices) == 3 and sum(slices) == pytest.approx(used, abs=0.011)
    proc = next(ln for ln in out.stderr.splitlines() if ln.startswith("process "))
    assert float(proc.split()[2]) >= used


def test_a_command_killed_by_a_signal_exits_as_a_shell_says():
    out = _run("--", sys.executable, "-c",
               "import os, signal; os.kill(os.getpid(), signal.SIGTERM)")
    assert out.returncode == 128 + 15, out.stderr
    assert "CPU seconds from" in out.stderr


def test_no_command_or_a_bad_one_is_a_clear_error():
    out = _run("--")
    assert out.returncode == 2 and "no command" in out.stderr
    out = _run("--", "/nonexistent/binary")
    assert out.returncode == 2 and "cannot run" in out.stderr
    out = _run("--window", "5", "1", "--", sys.executable, "-c", "pass")
    assert out.returncode == 2 and "END after START" in out.stderr
    out = _run("--window", "50", "60", "--", sys.executable, "-c", "pass")
    assert out.returncode == 0 and "nothing in --window" in out.stderr
