"""The FMU runtime's logger (``sloshrom.rom.fmu_runtime``) beside FMPy's.

FMPy formats an FMU's variadic log message in C, in a proxy that keeps one global pointer to
the Python logger it was last given, for every FMU of the process (FMPy's default callbacks,
which ``fmpy.simulate_fmu`` uses, included). A logger freed with a closed ``FMUModel``'s
callbacks left that pointer dangling: the next FMU to log through FMPy's defaults crashed the
process (the slow tier's segmentation fault, in FMU Manipulation Toolbox's container run by
``simulate_fmu`` after the grey box FMU tests). No FMU is built here: the proxy is called as an
FMU calls it.
"""

from __future__ import annotations

import ctypes
import gc
import subprocess
import sys

from fmpy.fmi2 import fmi2CallbackFunctions, fmi2CallbackLoggerTYPE
from fmpy.logging import addLoggerProxy

from sloshrom.rom import fmu_runtime
from sloshrom.rom.fmu_runtime import _callbacks

ERROR = 3  # fmi2Error

#: an FMUModel's callbacks made and collected, then an FMU logging through FMPy's defaults
AFTER_CLOSE = """
import gc
from fmpy.fmi2 import defaultCallbacks
from sloshrom.rom.fmu_runtime import _callbacks

cb = _callbacks([])
del cb
gc.collect()
defaultCallbacks.logger(None, b"box", 3, b"logStatusError", b"after the close")
"""


def _log(cb, text: str) -> None:
    """What an FMU's ``logger(componentEnvironment, name, status, category, "%s", text)`` does
    (the proxy formats the message; a text without ``%`` is its own format)."""
    cb.logger(cb.componentEnvironment, b"t", ERROR, b"logStatusError", text.encode())


def test_fmpys_default_logger_outlives_the_callbacks_of_a_closed_fmu_model():
    # in a process of its own: the bug is a segmentation fault (return code -11)
    run = subprocess.run([sys.executable, "-c", AFTER_CLOSE], capture_output=True, text=True,
                         timeout=120, check=False)
    assert run.returncode == 0, (run.returncode, run.stderr[-2000:])
    assert "[ERROR] after the close" in run.stdout  # printed as FMPy prints it


def test_each_instance_gets_its_own_messages_and_other_fmus_are_printed(capsys):
    a: list[tuple[int, str]] = []
    b: list[tuple[int, str]] = []
    cb_a, cb_b = _callbacks(a), _callbacks(b)
    _log(cb_a, "to a")
    _log(cb_b, "to b")
    assert a == [(ERROR, "to a")] and b == [(ERROR, "to b")]  # not both to the last one made
    # an FMU without our environment (FMPy's default callbacks): printed, as FMPy does
    cb_a.logger(None, b"other", ERROR, b"logStatusError", b"to nobody")
    assert "[ERROR] to nobody" in capsys.readouterr().out
    env = cb_a.componentEnvironment
    del cb_a
    gc.collect()
    assert env not in fmu_runtime._LOGS  # the list is let go with its callbacks
    _log(cb_b, "still b")
    assert b[-1] == (ERROR, "still b")


def test_the_proxy_is_pointed_back_at_our_logger(capsys):
    """``fmpy.simulate_fmu`` with a logger points the proxy at that logger; a run of an
    ``FMUModel`` (``init_state``) points it back."""
    theirs: list[bytes] = []
    logger = fmi2CallbackLoggerTYPE(lambda env, name, status, cat, text: theirs.append(text))

    def as_simulate_fmu() -> None:  # simulate_fmu(logger=...): fresh callbacks, proxied
        other = fmi2CallbackFunctions()
        other.logger = logger
        addLoggerProxy(ctypes.byref(other))

    ours: list[tuple[int, str]] = []
    cb = _callbacks(ours)
    as_simulate_fmu()
    try:
        _log(cb, "lost")
        assert theirs == [b"lost"] and not ours  # FMPy's one pointer: the logger given last
    finally:
        fmu_runtime._point_logger_proxy()  # `logger` goes with this test
    _log(cb, "found")
    assert ours == [(ERROR, "found")] and theirs == [b"lost"]
