"""Export a fitted ROM as an FMI 2.0 co-simulation FMU: native code, no Python at run time.

The FMU implements the sloshing-model contract of :mod:`sloshrom.models` for any tool that
imports FMUs (Simulink's FMU Import block, Dymola/OpenModelica, Simcenter Amesim, MSC Adams, FMPy,
a time-marching code of one's own):

============================  ==========  ==================================================
variable                      causality   meaning
============================  ==========  ==================================================
``velocity``                  input       tank vertical velocity at the communication point, m/s
                                          (a model on the velocity)
``acceleration``              input       tank vertical acceleration there, m/s2 (a network on
                                          the acceleration)
``dynamic_force``             output      dynamic sloshing force, N (``f_S + m_l * acc``, up +)
``outside_envelope``          output      the signal the model reads lies outside its training
                                          range at this communication point (Boolean)
``samples_outside_envelope``  output      communication points so far with that flag (Integer)
``time_step``                 read-only   the model's step ``dt``, s: the only communication step
``sample_rate``               read-only   ``1/dt``, Hz
``input_min``/``_max``        read-only   training range of the signal read (m/s or m/s2)
``acceleration_max``          read-only   peak |tank acceleration| of the training, m/s2
``frequency_min``/``_max``    read-only   band of the training excitation, Hz
``fill_min``/``fill_max``     read-only   fill levels d/h of the training records (-)
``reads_acceleration``        read-only   the model reads ``acceleration``, not ``velocity``
============================  ==========  ==================================================

(Read-only parameters are FMI *calculated parameters*; one the model does not know is left
out, and so is the input it does not read.) At a communication point ``t_k``, the input is the
tank's signal at ``t_k`` and ``dynamic_force`` is the model's force at sample k: an NFIR, an
NOE or a strictly proper NSS reads past inputs only (no direct feed-through), an NSS with
feed-through and an LSS also the input at ``t_k``; a grey box reads its state only (its
column's step runs once ``t_k``'s input is set, in ``fmi2DoStep``). A model with feed-through
exported *strictly proper* (``export_fmu(..., strictly_proper=True)``, ``sloshrom export fmu
--strictly-proper``) gives at ``t_k`` the model's force of ``t_{k-1}``, held from the last step
(its description says so): no output reads an input of its own point, so every master gets the
model's force, one step late, whatever order it calls in.
``fmi2DoStep(t_k, dt)`` moves the state to ``t_{k+1}``; the state starts at rest. Another step
size, or a communication point more than half a step from the last one plus its step (a skipped
or repeated step; a master's clock ``t += h`` is fine however long it runs), is an
``fmi2Error`` with a message that says so; so is a call the FMI 2.0 co-simulation state machine
does not allow. A step outside the training envelope returns ``fmi2Warning``. A model with direct
feed-through exported as it is says so in its description and :func:`export_fmu` warns
(:class:`~sloshrom.rom.errors.FeedthroughWarning`). A network on the acceleration reads
``acceleration``, every other model ``velocity``: the FMU declares that input only (an unused
input declared made masters report it missing on every run).

What is inside (:func:`export_fmu`):

``sources/``
    ``sloshrom_model.h``, ``sloshrom_kernels.c`` (delay lines, scaler, normalised RBF layer, the
    NOE's and the NSS's recurrences, the grey box's column and network, an ensemble's mean),
    ``sloshrom_fmi2.c`` (the FMI 2.0
    co-simulation functions), the generated ``sloshrom_model_data.c`` (architecture and every
    parameter, written to 17 significant digits: the doubles exactly) and the FMI 2.0 headers
    (the standard's: ``FMI2_FUNCTION_PREFIX`` prefixes the internal names too, so several
    source FMUs link into one program).
    A user on another platform builds the binary from them (``fmpy`` ``compile``, or any C99
    compiler: ``cc -shared -fPIC -O2 -I sources sources/*.c -lm``).
``binaries/<platform>/<modelIdentifier>.so|.dll|.dylib``
    Compiled here with the machine's C compiler through CMake (FMPy's build project), unless a
    source-only FMU is asked for. It exports the ``fmi2`` functions only, and on Linux needs
    glibc 2.17 at most (``exp`` and ``pow`` bound to their oldest versions:
    ``sloshrom_kernels.c``).

:func:`load_fmu` (:mod:`sloshrom.rom.fmu_runtime`, the runtime half; re-exported here) reads
such an FMU back as a sloshing model (:class:`FMUModel`) that steps the native code through
FMPy: the coupled beam with it equals the coupled beam with the ROM itself.
"""

from __future__ import annotations

import hashlib
import os
import re
import shutil
import subprocess
import tempfile
import time
import uuid
import warnings
import zipfile
from collections.abc import Callable, Sequence
from importlib import resources
from pathlib import Path
from typing import Any
from xml.sax.saxutils import escape, quoteattr

import numpy as np

from sloshrom import __version__
from sloshrom.fileio import atomic_write, pid_alive
from sloshrom.io.units import same_unit
from sloshrom.models import (
    INPUT_UNITS,
    envelope_of,
    input_of,
)
from sloshrom.rom.ensemble import is_ensemble
from sloshrom.rom.errors import FeedthroughWarning, NotFittedError, ROMError
from sloshrom.rom.fmu_runtime import GENERATOR, FMUError, FMUModel, load_fmu
from sloshrom.rom.network import FittedNetwork, network_of
from sloshrom.rom.registry import CLASSES

__all__ = ["FMU_SOURCES", "STALE_BUILD_AGE", "STEP_RTOL", "VR", "FMUError", "FMUModel",
           "check_fmu_exportable", "export_fmu", "fmu_platform", "load_fmu", "model_data_source",
           "model_description", "model_identifier", "remove_stale_builds"]

#: the static C sources shipped in every FMU (package data of ``sloshrom.rom``)
FMU_SOURCES = ("sloshrom_model.h", "sloshrom_kernels.c", "sloshrom_fmi2.c")
_DATA_SOURCE = "sloshrom_model_data.c"
_FMI_HEADERS = ("fmi2Functions.h", "fmi2FunctionTypes.h", "fmi2TypesPlatform.h")
#: value references (sloshrom_fmi2.c)
VR = {"velocity": 0, "acceleration": 1, "dynamic_force": 2, "outside_envelope": 3,
      "samples_outside_envelope": 4, "time_step": 10, "sample_rate": 11, "input_min": 12,
      "input_max": 13, "acceleration_max": 14, "frequency_min": 15, "frequency_max": 16,
      "fill_min": 17, "fill_max": 18, "reads_acceleration": 19}
#: relative tolerance of the FMU on its communication step (sloshrom_fmi2.c, STEP_RTOL)
STEP_RTOL = 1e-6
#: the build folders in the temporary directory: ``sloshrom-fmu-<pid>-...``
_BUILD_PREFIX = "sloshrom-fmu-"
#: s: a build folder of a process that is gone is removed once it is this old (a reused PID)
STALE_BUILD_AGE = 600.0
_NAMESPACE = uuid.UUID("5c1a3b5e-2f0d-4d0e-9a57-6f6d5e0a51f0")


# -- what can be exported ------------------------------------------------------------------------
def _networks(model: Any) -> list[FittedNetwork]:
    """The fitted networks whose mean ``model`` is (one for a single ROM)."""
    if is_ensemble(model):
        try:
            members = model.members_
        except AttributeError:
            raise ROMError("the ensemble is not fitted: nothing to export") from None
    else:
        members = [model]
    try:
        nets = [network_of(m) for m in members]
    except NotFittedError:
        raise ROMError(f"the {type(model).__name__} is not fitted: nothing to export") from None
    if any(n is None for n in nets):
        raise ROMError(_refusal(model))
    return nets  # type: ignore[return-value]


def _refusal(model: Any) -> str:
    name = type(model).__name__
    held = ", ".join(mc.class_name for mc in CLASSES.values() if "fmu" in mc.exports)
    return (f"a {name} cannot be exported to an FMU: an FMU holds fitted ROMs ({held}) or an "
            "ensemble of them. A fill family or blend mixes networks by the fill "
            "level: export the member identified at your fill (its own model file). The "
            "bouncing ball is a physics model run by sloshrom's integrator: export a ROM "
            "identified on its records")


def check_fmu_exportable(model: Any) -> list[FittedNetwork]:
    """The networks of ``model`` if it can be exported, else :class:`ROMError` saying why.

    Exportable: a fitted model of a class that lists ``"fmu"`` among its exports (NFIR, NOE,
    NSS, LSS, the grey box), or an ensemble of them, mapping the tank velocity (m/s) or, for a
    network on it, the tank acceleration (m/s^2) to the dynamic force (N).

    Raises
    ------
    ROMError
        An unfitted model, a fill family or blend, the bouncing ball, a model of other units,
        a class that does not export to an FMU (with its note on why, if it has one).
    """
    nets = _networks(model)
    kind = input_of(model)
    units = tuple(str(u) for u in getattr(model, "units", (INPUT_UNITS[kind], "N")))
    if not (same_unit(units[0], INPUT_UNITS[kind]) and same_unit(units[1], "N")):
        raise ROMError(f"the model maps '{units[0]}' to '{units[1]}'; an FMU's interface is "
                       f"SI (the tank {kind} in {INPUT_UNITS[kind]}, the force in N): retrain "
                       "it on records converted to SI (Record.to_si)")
    for net in nets:
        if "fmu" not in net.model_class.exports:
            note = net.model_class.export_notes.get("fmu")
            raise ROMError(f"the {net.describe()} cannot be exported to an FMU"
                           + (f": {note}" if note is not None else ""))
        if net.input != kind:
            raise ROMError("the ensemble's members read different signals")
    return nets


# -- the generated C -----------------------------------------------------------------------------
def _num(v: float) -> str:
    """A double in C, exactly (17 significant digits)."""
    v = float(v)
    if np.isnan(v):
        return "NAN"
    if not np.isfinite(v):
        raise ROMError(f"a parameter of the model is {v}: the model file is damaged")
    text = format(v, ".17g")
    return text if any(ch in text for ch in ".eEn") else text + ".0"


def _array(name: str, values: Any, ctype: str = "double") -> str:
    flat = np.asarray(values).ravel()
    conv = _num if ctype == "double" else (lambda x: str(int(x)))
    items = [conv(x) for x in flat] or ["0"]
    lines = [", ".join(items[i : i + 4]) for i in range(0, len(items), 4)]
    body = ",\n    ".join(lines)
    return f"static const {ctype} {name}[{max(flat.size, 1)}] = {{\n    {body}\n}};\n"


def _member_source(j: int, net: FittedNetwork) -> tuple[str, str]:
    """Arrays and the SlMember initialiser of member ``j`` (the network's
    :meth:`~sloshrom.rom.network.FittedNetwork.fmu_member`)."""
    arch, arrays, scalars = net.fmu_member()
    s = net.scaler
    out: list[str] = []
    fields = {"in_min": _num(s.in_min), "in_max": _num(s.in_max), "out_min": _num(s.out_min),
              "out_max": _num(s.out_max), "unstable_bound": _num(net.unstable_bound),
              "arch": arch}
    for k, v in scalars.items():
        # a C identifier (an enumerator), an int or a double
        fields[k] = v if isinstance(v, str) else str(v) if isinstance(v, int) else _num(v)
    for k, a in arrays.items():
        a = np.asarray(a)
        out.append(_array(f"m{j}_{k}", a, "int" if a.dtype.kind in "iu" else "double"))
        fields[k] = f"m{j}_{k}"
    init = "    {" + ", ".join(f".{k} = {v}" for k, v in fields.items()) + "}"
    return "".join(out), init


def _envelope_values(model: Any) -> dict[str, float]:
    """The read-only parameters of ``model`` (NaN: unknown)."""
    env = envelope_of(model)
    nan = float("nan")
    band = (nan, nan) if env is None or env.frequency_band is None else env.frequency_band

    def val(v: Any) -> float:
        return nan if v is None else float(v)

    return {
        "input_min": nan if env is None else env.input_min,
        "input_max": nan if env is None else env.input_max,
        "acceleration_max": nan if env is None else val(env.acceleration_max),
        "frequency_min": val(band[0]), "frequency_max": val(band[1]),
        "fill_min": nan if env is None else val(env.fill_min),
        "fill_max": nan if env is None else val(env.fill_max),
    }


def _description(model: Any, nets: Sequence[FittedNetwork], strictly_proper: bool = False
                 ) -> str:
    net = nets[0]
    arch = net.describe()
    what = f"ensemble of {len(nets)} {arch}" if len(nets) > 1 else arch
    kind = input_of(model)
    text = (f"sloshrom sloshing ROM, {what}, at {net.fs:.10g} Hz: tank vertical {kind} "
            f"({INPUT_UNITS[kind].replace('^', '')}, up +) -> dynamic sloshing force (N, up +)")
    if strictly_proper:
        text += (f"; exported strictly proper: the force at t_k is the model's force of "
                 f"t_(k-1) (one step, {net.dt:.10g} s, late), read before the {kind} of t_k "
                 "enters it, so no output depends on an input of its own point")
    elif _feedthrough(nets):
        text += (f"; direct feed-through: the force at t_k reads the {kind} at t_k (set the "
                 "inputs before reading the outputs; an algebraic loop in a feedback coupling)")
    return text


def _feedthrough(nets: Sequence[FittedNetwork]) -> bool:
    """Whether the force at a communication point reads the input of that point."""
    return any(n.feedthrough for n in nets)


def _check_strictly_proper(nets: Sequence[FittedNetwork], strictly_proper: bool) -> None:
    """A strictly proper export is for a model with feed-through: another would only be
    delayed by a step for nothing."""
    if strictly_proper and not _feedthrough(nets):
        raise ROMError(f"the {nets[0].describe()} has no direct feed-through (its force at t_k "
                       "reads no input of t_k): it is strictly proper as it is, and a strictly "
                       "proper export would only delay its force by one step; export it "
                       "without that option")


def _warn_feedthrough(model: object, nets: Sequence[FittedNetwork]) -> None:
    if _feedthrough(nets):
        warnings.warn(FeedthroughWarning(
            f"the {nets[0].describe()} has direct feed-through (its force at t_k reads the "
            f"{input_of(model)} at t_k): a co-simulation master that reads the outputs before "
            "it sets the inputs of the same point (FMPy's simulate_fmu, libcosim) gets the "
            "force one input late, and a feedback coupling through the FMU is an algebraic "
            "loop; a strictly proper export has neither (sloshrom export fmu "
            "--strictly-proper: the model's force one step late, in every master), nor has a "
            "strictly proper model (an NSS: train --arch nss --feedthrough no)"),
            stacklevel=3)


def model_data_source(model: Any, guid: str = "", strictly_proper: bool = False) -> str:
    """The generated C file of ``model``: its architecture and parameters as constant data.

    Parameters
    ----------
    model : ROM or Ensemble
        Fitted (:func:`check_fmu_exportable`).
    guid : str
        The FMU's GUID, compiled in (the binary refuses a modelDescription of another export).
    strictly_proper : bool
        Export a model with feed-through strictly proper (:func:`export_fmu`).

    Returns
    -------
    str
        C99 source defining ``SL_MODEL`` (``sloshrom_model.h``).
    """
    nets = check_fmu_exportable(model)
    _check_strictly_proper(nets, strictly_proper)
    arrays, inits = [], []
    for j, net in enumerate(nets):
        a, i = _member_source(j, net)
        arrays.append(a)
        inits.append(i)
    env = _envelope_values(model)
    has_env = not np.isnan(env["input_min"])
    text = _description(model, nets, strictly_proper)
    head = (f"/* Generated by sloshrom {__version__}: {text}.\n"
            " * Every parameter is written to 17 significant digits (the doubles exactly). */\n"
            "#include <math.h>\n#include \"sloshrom_model.h\"\n\n")
    members = "static const SlMember members[] = {\n" + ",\n".join(inits) + "\n};\n\n"
    fields = {
        "guid": f"\"{guid}\"", "description": _c_string(text),
        "n_members": str(len(nets)), "members": "members", "dt": _num(nets[0].dt),
        "reads_acceleration": "1" if input_of(model) == "acceleration" else "0",
        "strictly_proper": "1" if strictly_proper else "0",
        "has_envelope": "1" if has_env else "0",
        **{k: _num(env[k] if has_env or k not in ("input_min", "input_max") else 0.0)
           for k in ("input_min", "input_max", "acceleration_max", "frequency_min",
                     "frequency_max", "fill_min", "fill_max")},
    }
    model_init = ("const SlModel SL_MODEL = {\n"
                  + ",\n".join(f"    .{k} = {v}" for k, v in fields.items()) + "\n};\n")
    return head + "\n".join(arrays) + "\n" + members + model_init


def _c_string(text: str) -> str:
    return '"' + text.replace("\\", "\\\\").replace('"', '\\"') + '"'


# -- modelDescription.xml ------------------------------------------------------------------------
_UNITS = {  # name: SI base-unit exponents
    "m/s": 'm="1" s="-1"', "m/s2": 'm="1" s="-2"', "N": 'kg="1" m="1" s="-2"', "s": 's="1"',
    "Hz": 's="-1"', "1": "",
}


def model_identifier(path: str | Path) -> str:
    """The FMU's model identifier (the binary's file name) from its file name: a C identifier."""
    stem = re.sub(r"[^A-Za-z0-9_]", "_", Path(path).stem)
    return stem if re.match(r"[A-Za-z_]", stem or "0") else f"sloshrom_{stem}"


def model_description(model: Any, identifier: str, guid: str, sources: Sequence[str],
                      strictly_proper: bool = False) -> str:
    """The ``modelDescription.xml`` (FMI 2.0, co-simulation) of ``model`` (module docstring).

    Parameters
    ----------
    model : ROM or Ensemble
        Fitted.
    identifier : str
        ``modelIdentifier``: the name of the binary.
    guid : str
        The GUID compiled into the binary.
    sources : sequence of str
        The C files under ``sources/`` that build the binary.
    strictly_proper : bool
        A model with feed-through exported strictly proper (:func:`export_fmu`): its force
        depends on no input of its own point (``ModelStructure``), and the description says so.
    """
    nets = check_fmu_exportable(model)
    _check_strictly_proper(nets, strictly_proper)
    kind = input_of(model)
    feedthrough = _feedthrough(nets) and not strictly_proper
    dt = nets[0].dt
    env = _envelope_values(model)
    in_unit = INPUT_UNITS[kind].replace("^", "")
    # the input the model reads, only: an unused input declared is one a master must feed
    # (FMPy's simulate_fmu said "missing input" on every run that gave the velocity alone)
    inputs = {
        "velocity": f'<ScalarVariable name="velocity" valueReference="{VR["velocity"]}" '
                    'causality="input" variability="continuous" '
                    'description="tank vertical velocity, up positive">'
                    '<Real unit="m/s" start="0"/></ScalarVariable>',
        "acceleration": f'<ScalarVariable name="acceleration" '
                        f'valueReference="{VR["acceleration"]}" causality="input" '
                        'variability="continuous" description="tank vertical acceleration, up '
                        'positive"><Real unit="m/s2" start="0"/></ScalarVariable>',
    }
    force_text = ("dynamic sloshing force f_S + m_l * acceleration, up positive"
                  + (f": the model's force of the previous communication point (strictly "
                     f"proper export: one step, {dt:.10g} s, late)" if strictly_proper else ""))
    variables: list[tuple[str, str]] = [
        (kind, inputs[kind]),
        ("dynamic_force", f'<ScalarVariable name="dynamic_force" '
         f'valueReference="{VR["dynamic_force"]}" causality="output" variability="continuous" '
         f'initial="calculated" description={quoteattr(force_text)}>'
         '<Real unit="N"/></ScalarVariable>'),
        ("outside_envelope", f'<ScalarVariable name="outside_envelope" '
         f'valueReference="{VR["outside_envelope"]}" causality="output" '
         'variability="discrete" initial="calculated" description='
         f'{quoteattr(f"the tank {kind} is outside the training range [input_min, input_max]")}>'
         '<Boolean/></ScalarVariable>'),
        ("samples_outside_envelope", f'<ScalarVariable name="samples_outside_envelope" '
         f'valueReference="{VR["samples_outside_envelope"]}" causality="output" '
         'variability="discrete" initial="calculated" description="communication points so '
         'far with outside_envelope true"><Integer/></ScalarVariable>'),
    ]
    params = [("time_step", dt, "s", "the model's time step: the only communication step"),
              ("sample_rate", 1.0 / dt, "Hz", "the model's sample rate"),
              ("input_min", env["input_min"], in_unit, f"lowest tank {kind} of the training"),
              ("input_max", env["input_max"], in_unit, f"highest tank {kind} of the training"),
              ("acceleration_max", env["acceleration_max"], "m/s2",
               "peak |tank acceleration| of the training"),
              ("frequency_min", env["frequency_min"], "Hz", "lowest frequency of the training "
               "excitation"),
              ("frequency_max", env["frequency_max"], "Hz", "highest frequency of the training "
               "excitation"),
              ("fill_min", env["fill_min"], "1", "lowest fill level d/h of the training"),
              ("fill_max", env["fill_max"], "1", "highest fill level d/h of the training")]
    reads = (f"true if the model reads the tank acceleration, false if it reads the velocity "
             f"(this model: {'true' if kind == 'acceleration' else 'false'}, the {kind})")
    variables.append(("reads_acceleration", '<ScalarVariable name="reads_acceleration" '
                      f'valueReference="{VR["reads_acceleration"]}" '
                      'causality="calculatedParameter" variability="fixed" initial="calculated" '
                      f'description={quoteattr(reads)}><Boolean/></ScalarVariable>'))
    for name, value, unit, text in params:
        if np.isnan(value):
            continue
        # a dimensionless value is a number alone ("(0.5)", not "(0.5 1)")
        shown = f"{value:.6g}" if unit == "1" else f"{value:.6g} {unit}"
        variables.append((name, f'<ScalarVariable name="{name}" valueReference="{VR[name]}" '
                          'causality="calculatedParameter" variability="fixed" '
                          f'initial="calculated" description={quoteattr(f"{text} ({shown})")}>'
                          f'<Real unit="{unit}"/></ScalarVariable>'))
    index = {name: i + 1 for i, (name, _) in enumerate(variables)}
    read = str(index[kind])
    outputs = [f'<Unknown index="{index["dynamic_force"]}" '
               + (f'dependencies="{read}" dependenciesKind="dependent"/>' if feedthrough
                  else 'dependencies=""/>'),
               f'<Unknown index="{index["outside_envelope"]}" dependencies="{read}" '
               'dependenciesKind="dependent"/>',
               f'<Unknown index="{index["samples_outside_envelope"]}" dependencies=""/>']
    initial = outputs + [f'<Unknown index="{index[n]}" dependencies=""/>'
                         for n in ("reads_acceleration", *(q[0] for q in params))
                         if n in index]
    used_units = sorted({u for *_, u, _ in params} | {in_unit, "N"})
    units = "\n".join(f'    <Unit name="{u}"><BaseUnit {_UNITS[u]}/></Unit>'
                      if _UNITS[u] else f'    <Unit name="{u}"/>' for u in used_units)
    files = "".join(f'<File name="{escape(s)}"/>' for s in sources)
    n = "\n    "
    return f"""<?xml version="1.0" encoding="UTF-8"?>
<fmiModelDescription fmiVersion="2.0" modelName="{escape(identifier)}" guid="{guid}"
  description={quoteattr(_description(model, nets, strictly_proper))}
  generationTool="{GENERATOR} {escape(__version__)}" variableNamingConvention="flat"
  numberOfEventIndicators="0">
  <CoSimulation modelIdentifier="{escape(identifier)}" needsExecutionTool="false"
    canHandleVariableCommunicationStepSize="false" canInterpolateInputs="false"
    maxOutputDerivativeOrder="0" canRunAsynchronuously="false"
    canBeInstantiatedOnlyOncePerProcess="false" canNotUseMemoryManagementFunctions="false"
    canGetAndSetFMUstate="true" canSerializeFMUstate="true"
    providesDirectionalDerivative="false">
    <SourceFiles>{files}</SourceFiles>
  </CoSimulation>
  <UnitDefinitions>
{units}
  </UnitDefinitions>
  <LogCategories>
    <Category name="logStatusError" description="errors: a wrong communication step, a \
non-finite input, an unstable simulation, a call out of order"/>
    <Category name="logStatusWarning" description="the input left the training envelope"/>
    <Category name="logAll" description="every message: logStatusError and logStatusWarning"/>
  </LogCategories>
  <DefaultExperiment startTime="0" stepSize="{_num(dt)}"/>
  <ModelVariables>
    {n.join(v for _, v in variables)}
  </ModelVariables>
  <ModelStructure>
    <Outputs>
      {(n + "  ").join(outputs[:3])}
    </Outputs>
    <InitialUnknowns>
      {(n + "  ").join(initial)}
    </InitialUnknowns>
  </ModelStructure>
</fmiModelDescription>
"""


# -- building ------------------------------------------------------------------------------------
def fmu_platform() -> str:
    """This machine's FMI 2.0 platform folder (``linux64``, ``win64``, ``darwin64``, ...)."""
    import fmpy

    return str(fmpy.platform)


def _cmake() -> str:
    try:
        import cmake  # the pinned CMake that FMPy depends on

        exe = Path(cmake.CMAKE_BIN_DIR) / ("cmake.exe" if os.name == "nt" else "cmake")
        if exe.is_file():
            return str(exe)
    except (ImportError, AttributeError):
        pass
    found = shutil.which("cmake")
    if found is None:
        raise FMUError("CMake is not installed (the Python package 'cmake', a dependency of "
                       "FMPy): cannot build the FMU's binary")
    return found


def _has_c_compiler() -> bool:
    if os.name == "nt":
        return True  # CMake finds Visual Studio itself and says so when it cannot
    names = [os.environ["CC"]] if os.environ.get("CC") else ["cc", "gcc", "clang"]
    return any(shutil.which(n.split()[0]) for n in names)


def _build_binary(root: Path) -> None:
    """Compile ``root/sources`` into ``root/binaries/<platform>`` with FMPy's CMake project."""
    import fmpy
    from fmpy.build import create_cmake_settings

    if not _has_c_compiler():
        raise FMUError("no C compiler found (cc, gcc or clang on PATH, or $CC) to build the "
                       "FMU's binary: install one (Debian/Ubuntu: apt install gcc), or export "
                       "a source-only FMU (--source-only) and build it where it runs")
    with tempfile.TemporaryDirectory(prefix=f"{_BUILD_PREFIX}{os.getpid()}-build-") as build:
        # only the fmi2 functions leave the shared library (sloshrom_model.h hides the rest too)
        options = {} if os.name == "nt" else {"CMAKE_C_STANDARD_LIBRARIES:STRING": "-lm",
                                              "CMAKE_C_VISIBILITY_PRESET:STRING": "hidden"}
        create_cmake_settings(root, build, cmake_options=options)
        source = Path(fmpy.__file__).parent / "c-code"
        for cmd in ([_cmake(), "-S", source.as_posix(), "-B", build],
                    [_cmake(), "--build", build, "--target", "install", "--config",
                     "Release"]):
            run = subprocess.run(cmd, capture_output=True, text=True, check=False)
            if run.returncode != 0:
                tail = "\n".join((run.stdout + run.stderr).strip().splitlines()[-15:])
                raise FMUError(f"building the FMU's binary failed ({' '.join(cmd[1:3])}):\n"
                               f"{tail}")


def remove_stale_builds(root: str | Path | None = None, *,
                        age: float = STALE_BUILD_AGE) -> list[Path]:
    """Remove the build folders of exports that were killed before they could clean up.

    A build folder ``sloshrom-fmu-<pid>-...`` in the temporary directory ``root`` (default:
    :func:`tempfile.gettempdir`) goes when its process ``pid`` is gone and it was last modified
    more than ``age`` seconds ago (a PID may be reused by then: a live one always keeps its
    folder). POSIX only (another system's export cleans up after itself only).

    Returns
    -------
    list of Path
        The folders removed.
    """
    if os.name != "posix":
        return []
    gone = []
    for d in Path(root or tempfile.gettempdir()).glob(f"{_BUILD_PREFIX}*"):
        m = re.fullmatch(rf"{_BUILD_PREFIX}(\d+)-.+", d.name)
        try:
            stale = (m is not None and d.is_dir() and not d.is_symlink()
                     and time.time() - d.stat().st_mtime > age and not pid_alive(int(m.group(1))))
        except OSError:  # went away meanwhile, or not ours to look at
            continue
        if stale:
            shutil.rmtree(d, ignore_errors=True)
            gone.append(d)
    return gone


def _guid(data_without_guid: str, identifier: str) -> str:
    """The FMU's GUID: a digest of the model's data and its ``modelIdentifier`` (two exports of
    one model under two names are two FMUs)."""
    digest = hashlib.sha256((identifier + "\n" + data_without_guid).encode()).hexdigest()
    return "{" + str(uuid.uuid5(_NAMESPACE, digest)) + "}"


def _write_zip(root: Path, path: str) -> None:
    with zipfile.ZipFile(path, "w", compression=zipfile.ZIP_DEFLATED) as zf:
        for f in sorted(root.rglob("*")):
            if f.is_file():
                # fixed time stamps: the archive depends on its content only
                info = zipfile.ZipInfo(f.relative_to(root).as_posix(), (1980, 1, 1, 0, 0, 0))
                info.compress_type = zipfile.ZIP_DEFLATED
                info.external_attr = 0o644 << 16
                zf.writestr(info, f.read_bytes())


def export_fmu(model: Any, path: str | Path, *, binary: bool = True,
               verify: Callable[[Path], None] | None = None,
               strictly_proper: bool = False) -> Path:
    """Write ``model`` as an FMI 2.0 co-simulation FMU, atomically.

    The sources are generated and (``binary``) compiled in a temporary folder, zipped to a
    temporary file beside ``path``, optionally verified there, and only then renamed onto
    ``path``: a failure at any step leaves a previous ``path``, if any, as it was.

    Parameters
    ----------
    model : ROM or Ensemble
        Fitted, SI units (:func:`check_fmu_exportable`).
    path : str or Path
        Output ``.fmu``; its stem, made a C identifier, is the model identifier.
    binary : bool
        Compile the binary for this platform (default); False writes a source-only FMU.
    verify : callable, optional
        ``verify(tmp_path)`` is called with the complete temporary ``.fmu``; raising rejects
        the export (e.g. a parity check against the model that fails).
    strictly_proper : bool
        For a model with direct feed-through (an LSS, an NSS with feed-through): the FMU's
        force at ``t_k`` is the model's force of ``t_{k-1}``, held from the last step, so that
        no output depends on an input of its own point (declared so in ``ModelStructure``
        and said in the description). Every master then gets the model's force one step
        late, whatever its order of calls; without it, a master that reads the outputs
        before it sets the inputs gets a force one input late, which is no force of the
        model's. A model without feed-through is refused (it is strictly proper as it is).

    Returns
    -------
    Path

    Warns
    -----
    FeedthroughWarning
        A model with direct feed-through exported as it is (an LSS; an NSS whose force reads
        the current input).

    Raises
    ------
    ROMError
        A model that cannot be exported (says why); ``strictly_proper`` for a model without
        feed-through.
    OSError
        The disk refused a file (full, a file-size limit): nothing written.
    FMUError
        No C compiler or CMake, or the build failed (the compiler's last lines).
    """
    nets = check_fmu_exportable(model)
    _check_strictly_proper(nets, strictly_proper)
    if not strictly_proper:
        _warn_feedthrough(model, nets)
    p = Path(path)
    if p.suffix.lower() != ".fmu":
        raise FMUError(f"an FMU file ends in .fmu, got {p.name}")
    identifier = model_identifier(p)
    guid = _guid(model_data_source(model, strictly_proper=strictly_proper), identifier)
    sources = [*(n for n in FMU_SOURCES if n.endswith(".c")), _DATA_SOURCE]
    here = resources.files("sloshrom.rom") / "fmu_c"
    remove_stale_builds()
    # the PID in the name: a killed export's folder is recognised as stale by the next one
    with tempfile.TemporaryDirectory(prefix=f"{_BUILD_PREFIX}{os.getpid()}-") as tmp:
        root = Path(tmp) / "fmu"
        src = root / "sources"
        src.mkdir(parents=True)
        for name in FMU_SOURCES:
            (src / name).write_text((here / name).read_text(encoding="utf-8"), encoding="utf-8")
        (src / _DATA_SOURCE).write_text(model_data_source(model, guid, strictly_proper),
                                        encoding="utf-8")
        for name in _FMI_HEADERS:  # the standard's, honouring FMI2_FUNCTION_PREFIX
            (src / name).write_bytes((here / name).read_bytes())
        (root / "modelDescription.xml").write_text(
            model_description(model, identifier, guid, sources, strictly_proper),
            encoding="utf-8")
        if binary:
            _build_binary(root)

        def write(tmp_fmu: str) -> None:
            _write_zip(root, tmp_fmu)
            if verify is not None:
                verify(Path(tmp_fmu))

        return atomic_write(p, write, suffix=".fmu")
