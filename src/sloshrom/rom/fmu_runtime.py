"""A sloshrom FMU read back and run as a sloshing model: :func:`load_fmu`, :class:`FMUModel`.

The runtime half of the FMU support (the export, code generation and build are
:mod:`sloshrom.rom.fmu`): it checks that an ``.fmu`` is one of sloshrom's co-simulation FMUs and
steps its native binary through FMPy one communication point at a time, so that the coupled
beam and the maps run it like any other sloshing model (:mod:`sloshrom.models`). FMPy's
warnings become :class:`~sloshrom.models.EnvelopeWarning`, its errors :class:`ModelError` with
the FMU's own message.
"""

from __future__ import annotations

import ctypes
import itertools
import shutil
import threading
import warnings
import weakref
import zipfile
import zlib
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from sloshrom.models import (
    INPUT_UNITS,
    EnvelopeWarning,
    ModelError,
    model_input,
)
from sloshrom.rom.errors import ROMError

__all__ = ["GENERATOR", "FMUError", "FMUModel", "load_fmu"]

#: the generationTool of sloshrom's FMUs (the reader takes these only)
GENERATOR = "sloshrom"


class FMUError(ROMError):
    """An FMU that sloshrom cannot build or read back (the message says why)."""


# -- reading an FMU back -------------------------------------------------------------------------
def _read_checked(path: Path) -> tuple[Any, list[str]]:
    """modelDescription of a sloshrom FMU and its platforms, or FMUError saying what is wrong."""
    import fmpy

    if not path.is_file():
        raise FMUError(f"FMU not found: {path}")
    if not zipfile.is_zipfile(path):
        raise FMUError(f"{path} is not an FMU (not a zip archive: truncated or another file)")
    try:
        with zipfile.ZipFile(path) as zf:
            bad = zf.testzip()
            names = zf.namelist()
    except (zipfile.BadZipFile, OSError, EOFError, zlib.error) as exc:
        raise FMUError(f"{path} is a damaged FMU: {exc}") from exc
    if bad is not None:
        raise FMUError(f"{path} is a damaged FMU: {bad} fails its checksum")
    if "modelDescription.xml" not in names:
        raise FMUError(f"{path} is not an FMU: no modelDescription.xml")
    try:
        md = fmpy.read_model_description(str(path), validate=True)
    except Exception as exc:  # FMPy raises plain Exceptions and its ValidationError
        raise FMUError(f"{path}: modelDescription.xml is invalid: {exc}") from exc
    if not str(md.generationTool or "").startswith(GENERATOR + " ") or md.coSimulation is None:
        raise FMUError(f"{path} was not written by sloshrom ({md.generationTool!r}): "
                       "sloshrom reads back its own co-simulation FMUs only")
    ident = md.coSimulation.modelIdentifier
    platforms = sorted({n.split("/")[1] for n in names
                        if n.startswith("binaries/") and n.count("/") == 2
                        and Path(n).stem == ident})
    return md, platforms


def load_fmu(path: str | Path, name: str | None = None) -> FMUModel:
    """Read an FMU written by :func:`export_fmu` back as a sloshing model (:class:`FMUModel`).

    Unlike a model file, an FMU is code: this loads and runs its native binary. Load FMUs you
    trust (your own exports); :func:`sloshrom.rom.load_model` reads data only and does not take
    them.

    Parameters
    ----------
    path : str or Path
        The ``.fmu``.
    name : str, optional
        How the messages of a run name it (default: its file name).

    Raises
    ------
    FMUError
        Not a zip archive, a damaged archive (checksum), no or an invalid modelDescription.xml,
        an FMU of another tool, no binary for this platform (says which platforms it has).
    """
    return FMUModel(path, name)


class FMUModel:
    """A sloshrom FMU run through FMPy, as a sloshing model (:mod:`sloshrom.models` contract).

    It steps the FMU's native code one communication point per :meth:`step`: the coupled beam
    runs it in its Python loop. The FMU's state lives in the FMU instance, not in the ``state``
    argument: :meth:`init_state` resets the instance and returns the sample index, and each
    :meth:`step` takes the index it is at (another index is a :class:`ModelError`: one run at a
    time per instance).

    Parameters
    ----------
    path : str or Path
        An ``.fmu`` written by :func:`export_fmu` with a binary for this platform.
    name : str, optional
        How the messages of a run name the FMU (default: its file name; the exporter checks a
        temporary file under the name of the file it becomes).

    Attributes
    ----------
    dt : float
        The model's (and the only communication) step, s.
    fs_ : float
        ``1/dt``, Hz.
    input : {"velocity", "acceleration"}
        The signal the FMU's model reads.
    envelope_ : dict or None
        ``input_min``/``input_max`` and the other read-only parameters it has.
    names, units : tuple of str
        ``(input, "dynamic_force")`` and their SI units.
    """

    force_rule = "trapezoid"

    def __init__(self, path: str | Path, name: str | None = None) -> None:
        import fmpy
        from fmpy.fmi2 import FMU2Slave

        self.path = Path(path)
        self._name = self.path.name if name is None else name
        md, platforms = _read_checked(self.path)
        here = fmpy.platform
        if here not in platforms:
            has = ", ".join(platforms) if platforms else "none: a source-only FMU"
            raise FMUError(f"{self.path} has no binary for this platform ({here}); it has "
                           f"{has}. Build one from its sources (python -m fmpy compile "
                           f"{self.path.name}) or export it on this machine")
        self._md = md
        self._vr = {v.name: v.valueReference for v in md.modelVariables}
        needed = ("dynamic_force", "time_step", "reads_acceleration")
        # the input the model reads (earlier exports declared both, the other unused)
        if any(n not in self._vr for n in needed) or not {"velocity", "acceleration"} & {
                v.name for v in md.modelVariables if v.causality == "input"}:
            raise FMUError(f"{self.path}: not a sloshing model (no velocity or acceleration "
                           "input, or no dynamic_force output)")
        self._dir = fmpy.extract(str(self.path))
        self._finalizer = weakref.finalize(self, shutil.rmtree, self._dir, True)
        self._fmu = FMU2Slave(guid=md.guid, unzipDirectory=self._dir,
                              modelIdentifier=md.coSimulation.modelIdentifier,
                              instanceName="sloshrom")
        self._messages: list[tuple[int, str]] = []
        self._callbacks = _callbacks(self._messages)
        try:
            self._fmu.instantiate(callbacks=self._callbacks)
        except Exception as exc:  # FMPy raises a plain Exception when instantiation fails
            raise FMUError(f"{self.path}: the FMU's binary refused to instantiate "
                           f"({self._last_error() or exc})") from exc
        self._fmu_free = weakref.finalize(self, _free, self._fmu)
        self._force = self._vr["dynamic_force"]
        self._fmu.setupExperiment(startTime=0.0)
        self._fmu.enterInitializationMode()
        self._fmu.exitInitializationMode()
        values = {n: self._fmu.getReal([vr])[0] for n, vr in self._vr.items()
                  if n in ("time_step", "input_min", "input_max", "acceleration_max",
                           "frequency_min", "frequency_max", "fill_min", "fill_max")}
        self.dt = float(values["time_step"])
        self.fs_ = 1.0 / self.dt
        reads_acc = self._fmu.getBoolean([self._vr["reads_acceleration"]])[0]
        self.input = "acceleration" if reads_acc else "velocity"
        if self.input not in self._vr:
            raise FMUError(f"{self.path}: its model reads the {self.input}, which it does not "
                           "declare as an input")
        self._in = self._vr[self.input]  # the input's value reference
        self.names = (self.input, "dynamic_force")
        self.units = (INPUT_UNITS[self.input], "N")
        env: dict[str, Any] | None = None
        if "input_min" in values:
            env = {"input_min": values["input_min"], "input_max": values["input_max"]}
            for k in ("acceleration_max", "fill_min", "fill_max"):
                if k in values:
                    env[k] = values[k]
            if "frequency_min" in values:
                env["frequency_band"] = [values["frequency_min"], values["frequency_max"]]
        self.envelope_ = env
        self._k = 0
        self._run = 0

    def close(self) -> None:
        """Free the FMU instance and remove its extracted files (also done when collected)."""
        self._fmu_free()
        self._finalizer()

    def init_state(self) -> tuple[int, int]:
        """Reset the FMU to rest at time 0; the state is ``(run, sample index)``."""
        f = self._fmu
        f.reset()
        f.setupExperiment(startTime=0.0)
        f.enterInitializationMode()
        f.exitInitializationMode()
        # FMPy's proxy may have been pointed at another logger since (simulate_fmu with one)
        _point_logger_proxy()
        self._run += 1
        self._k = 0
        return (self._run, 0)

    def _last_error(self) -> str:
        errors = [m for status, m in self._messages if status >= 3]
        return errors[-1] if errors else ""

    def _call(self, fn: Callable[..., Any], *args: Any) -> Any:
        """An FMI call; a failing one raises ModelError with the FMU's own message, the FMU's
        envelope warnings become :class:`~sloshrom.models.EnvelopeWarning`."""
        from fmpy.fmi1 import FMICallException

        self._messages.clear()
        try:
            out = fn(*args)
        except FMICallException as exc:
            raise ModelError(f"FMU {self._name}: {self._last_error() or exc}") from exc
        finally:
            for status, text in self._messages:
                if status == 1:
                    warnings.warn(f"FMU {self._name}: {text}", EnvelopeWarning,
                                  stacklevel=4)
        return out

    def _advance(self) -> None:
        self._call(self._fmu.doStep, self._k * self.dt, self.dt)
        self._k += 1

    def step(self, state: tuple[int, int], velocity: Any,
             acceleration: Any = None) -> tuple[tuple[int, int], float]:
        """One sample of the contract: ``(state, dynamic_force)`` at sample k.

        A velocity model gets ``velocity`` v_k at the FMU's communication point t_k, gives the
        force there and steps; a network on the acceleration gets ``acceleration`` a_{k-1} (as
        the coupled beam passes it) at t_{k-1}, steps, and gives the force at t_k. Both equal
        the model's own :meth:`step`.
        """
        if state != (self._run, self._k):
            raise ModelError("this FMU instance has moved on since that state: an FMUModel runs "
                             "one simulation at a time (call init_state to start another)")
        f, call = self._fmu, self._call
        if self.input == "acceleration":
            call(f.setReal, [self._in], [float(0.0 if acceleration is None else acceleration)])
            self._advance()
            force = call(f.getReal, [self._force])[0]
        else:
            call(f.setReal, [self._in], [float(velocity)])
            force = call(f.getReal, [self._force])[0]
            self._advance()
        return (self._run, self._k), float(force)

    def simulate(self, velocity: Any, acceleration: Any = None) -> np.ndarray:
        """The force (N) for whole records sampled at ``1/dt`` (time on the last axis), from
        rest: at each communication point t_k the tank's signals at t_k."""
        u = np.asarray(model_input(self, velocity, acceleration), dtype=np.float64)
        if not np.all(np.isfinite(u)):
            raise ModelError(f"the tank {self.input} must be finite (no NaN or inf)")
        flat = u.reshape(-1, u.shape[-1]) if u.ndim else u.reshape(1, 1)
        out = np.empty_like(flat)
        vr = self._in
        f, call = self._fmu, self._call
        for r, row in enumerate(flat):
            self.init_state()
            for k, x in enumerate(row):
                call(f.setReal, [vr], [float(x)])
                out[r, k] = call(f.getReal, [self._force])[0]
                self._advance()
        return out.reshape(u.shape)

    def predict(self, u: Any) -> np.ndarray:
        """The force (N) for a record of the signal the model reads (``input``), from rest."""
        return self.simulate(u, u)

    def outside_envelope(self) -> tuple[bool, int]:
        """``(outside_envelope, samples_outside_envelope)`` at the current communication
        point."""
        f = self._fmu
        return (bool(f.getBoolean([self._vr["outside_envelope"]])[0]),
                int(f.getInteger([self._vr["samples_outside_envelope"]])[0]))


#: componentEnvironment -> the list the messages of the FMU instance given it go to
_LOGS: dict[int, list[tuple[int, str]]] = {}
_ENVS = itertools.count(1)
#: the one logger FMPy's proxy calls for our instances: never freed (_point_logger_proxy)
_LOGGER: object = None
_LOGGER_LOCK = threading.Lock()


def _route(env: int | None, name: bytes, status: int, category: bytes,
           message: bytes) -> None:
    """Append a message to the list of the instance whose ``componentEnvironment`` is ``env``;
    another FMU's (FMPy's default callbacks: no environment) is printed, as FMPy does."""
    messages = _LOGS.get(env or 0)
    if messages is None:
        from fmpy.fmi1 import printLogMessage

        printLogMessage(env, name, status, category, message)
    else:
        messages.append((int(status), message.decode("utf-8", "replace")))


def _point_logger_proxy(cb: ctypes.Structure | None = None) -> None:
    """Put the process's one logger behind FMPy's logger proxy, and the proxy in ``cb.logger``.

    The proxy (``fmpy.logging.addLoggerProxy``: it formats the variadic message in C, which
    ctypes cannot) keeps one global pointer, for every FMU of the process, to the logger of the
    callbacks it was given last; FMPy's default callbacks (``fmpy.simulate_fmu``) log through it
    too. So that pointer must be a ctypes function that lives as long as the process: one freed
    with a closed :class:`FMUModel`'s callbacks made the next FMU to log (FMU Manipulation
    Toolbox's container, instantiated by ``simulate_fmu``) jump into freed memory, and one per
    instance sent each instance's messages to the last one made.

    Parameters
    ----------
    cb : fmpy.fmi2.fmi2CallbackFunctions, optional
        Callbacks whose ``logger`` becomes the proxy (default: the proxy is pointed only).
    """
    global _LOGGER
    from fmpy.fmi2 import fmi2CallbackFunctions, fmi2CallbackLoggerTYPE
    from fmpy.logging import addLoggerProxy

    with _LOGGER_LOCK:  # two made at once: the one dropped could be the one pointed at
        if _LOGGER is None:
            _LOGGER = fmi2CallbackLoggerTYPE(_route)
    cb = fmi2CallbackFunctions() if cb is None else cb
    cb.logger = _LOGGER
    addLoggerProxy(ctypes.byref(cb))


def _callbacks(messages: list[tuple[int, str]]) -> Any:
    """FMI 2.0 callbacks whose logger appends ``(status, message)`` to ``messages``.

    The instance's messages find their list by the ``componentEnvironment`` the FMU passes back
    (:func:`_route`); the list is let go when the callbacks are collected. Keep the callbacks as
    long as the instance: its memory functions are theirs.
    """
    from fmpy import calloc, free
    from fmpy.fmi2 import (
        fmi2CallbackAllocateMemoryTYPE,
        fmi2CallbackFreeMemoryTYPE,
        fmi2CallbackFunctions,
    )

    cb = fmi2CallbackFunctions()
    _point_logger_proxy(cb)
    cb.allocateMemory = fmi2CallbackAllocateMemoryTYPE(calloc)
    cb.freeMemory = fmi2CallbackFreeMemoryTYPE(free)
    env = next(_ENVS)
    cb.componentEnvironment = env
    _LOGS[env] = messages
    weakref.finalize(cb, _LOGS.pop, env, None)
    return cb


def _free(fmu: Any) -> None:
    try:
        fmu.terminate()
    except Exception:  # noqa: BLE001 - an FMU in an error state may refuse; free it anyway
        pass
    fmu.freeInstance()
