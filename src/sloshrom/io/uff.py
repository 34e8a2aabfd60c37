"""Universal File Format (UFF/UNV) dataset 58 time histories as :class:`sloshrom.io.Record`.

Test-lab software (LMS/Siemens Testlab, m+p, Dewesoft, ...) exports measured channels as UFF
dataset 58 ("function at nodal DOF"). Each dataset is one channel; function type 1 is a time
response. :func:`read_uff58` reads every time-response dataset of a file with ``pyuff``, checks
that all channels share one uniform time axis, and builds a record:

- variable name: from ``names`` (keyed by channel label or by 0-based channel index), else the
  standard name of the channel's specific data type when exactly one channel has it
  (8 displacement, 11 velocity, 12 acceleration, 9/13 force), else the sanitised channel label
  (ID line 1, or ``node<N>_<dir>``).
- unit: from ``units`` (keyed by variable name or channel label), else the ordinate units label
  of the dataset, else (dataset 164 declaring SI) the SI unit of the specific data type; a
  channel with none of these is an error asking for ``units=``.

The response direction (``+Z``, ``-Z``, ...) is stored in ``attrs["uff_channels"]``, the data
are NOT sign-flipped: sloshrom expects the vertical tank acceleration positive up.

:func:`write_uff58` writes a record as ASCII dataset 58 time responses (plus dataset 164, SI),
atomically; it is what the tests use to produce files "as pyuff writes them". Its building
blocks are shared with the beam-result export (:mod:`sloshrom.beam.lab.uff58`): :func:`dataset58`
(a complete dataset-58 dict: every field pyuff's writer needs, header widths checked, unit
exponents from the specific data type), :func:`dataset164_si` and :func:`write_uff_sets`
(atomic, or into an :class:`~sloshrom.fileio.OutputBatch`).
"""

from __future__ import annotations

import math
import re
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from sloshrom.fileio import OutputBatch, atomic_write
from sloshrom.io.record import (
    MissingUnitError,
    Record,
    RecordError,
    UnitConflictError,
    _show,
    _unit_text,
    _why,
    require_file,
)
from sloshrom.io.units import STANDARD_UNITS, _time_unit, is_known_unit, same_unit

__all__ = ["dataset58", "dataset164_si", "id_line", "node_dir", "read_uff58", "write_uff58",
           "write_uff_sets"]

# UFF "specific data type" codes -> (standard variable name, SI unit)
_SPEC_TYPES: dict[int, tuple[str, str]] = {
    8: ("displacement", "m"),
    11: ("velocity", "m/s"),
    12: ("acceleration", "m/s^2"),
    9: ("force", "N"),  # reaction force
    13: ("force", "N"),  # excitation force
}
_SPEC_CODES = {"displacement": 8, "velocity": 11, "acceleration": 12, "force": 9,
               "dynamic_force": 9, "interface_force": 9, "true_dynamic_force": 9,
               "true_velocity": 11, "tank_acceleration": 12, "base_acceleration": 12}
_DIRS = {0: "scalar", 1: "+X", 2: "+Y", 3: "+Z", 4: "+RX", 5: "+RY", 6: "+RZ",
         -1: "-X", -2: "-Y", -3: "-Z", -4: "-RX", -5: "-RY", -6: "-RZ"}


_NODE_DIR = re.compile(r"^\s*(\d+)\s*:\s*([+-]?)\s*([XYZxyz]|R[XYZxyz])\s*$")


def node_dir(name: str) -> tuple[int, str] | None:
    """A channel named ``node:dir`` (``"101:+Z"``, ``"101:z"``) as ``(101, "+Z")``; ``None``
    for any other name."""
    m = _NODE_DIR.match(name) if isinstance(name, str) else None
    if m is None:
        return None
    return int(m.group(1)), f"{m.group(2) or '+'}{m.group(3).upper()}"


def _label(ds: Mapping[str, Any]) -> str:
    lab = str(ds.get("id1", "") or "").strip()
    if lab and lab.upper() != "NONE":
        return lab
    d = _DIRS.get(int(ds.get("rsp_dir", 0) or 0), str(ds.get("rsp_dir")))
    return f"node{int(ds.get('rsp_node', 0) or 0)}_{d.replace('+', 'p').replace('-', 'm')}"


def _sanitise(label: str) -> str:
    s = re.sub(r"[^0-9A-Za-z_]+", "_", label).strip("_").lower()
    return s if s and not s[0].isdigit() else f"ch_{s}"


def read_uff58(
    path: str | Path,
    names: Mapping[str | int, str] | None = None,
    units: Mapping[str, str] | None = None,
    *,
    shared_units: bool = False,
) -> Record:
    """Read the time-response (function type 1) dataset-58 channels of a UFF file.

    Parameters
    ----------
    path : str or Path
        ``.uff`` / ``.unv`` file (ASCII or binary dataset 58).
    names : dict, optional
        Variable name per channel, keyed by the channel label (ID line 1, stripped) or by the
        0-based index among the time-response channels, e.g. ``{"Tank accel": "acceleration",
        1: "force"}``.
    units : dict, optional
        Unit per variable name or channel label, for channels whose file gives none (or to
        override the file), e.g. ``{"force": "kN"}``; a key that is neither is an error.
    shared_units : bool
        ``units`` are shared by the files of a test campaign (a channel map's): keys may also be
        ``node:dir`` (``"101:+Z"``), a key that names no channel of this file is ignored, and a
        unit only fills an empty ordinate label: one that contradicts a non-empty label is a
        :class:`~sloshrom.io.record.UnitConflictError` naming both.

    Returns
    -------
    Record
        Units as in the file (convert with :meth:`Record.to_si`); ``attrs["uff_channels"]``
        lists dataset number, label, node, direction, specific data type and unit source of
        every channel.

    Raises
    ------
    RecordError
        One line naming the file, the dataset/channel and the problem: unreadable or truncated
        file, a non-numeric data line (its line number), a header that declares more or fewer
        points than the dataset holds, a non-positive abscissa increment, an abscissa that is not
        time, no time-response dataset, complex or mismatched channels (length, start time,
        sample rate), uneven sampling, duplicate names, missing units.
    """

    p = Path(path)
    names = dict(names or {})
    units = {k: _given_unit(p, k, v) for k, v in dict(units or {}).items()}
    require_file(p)
    uff, types = open_uff(p)
    sets: list[tuple[int, dict[str, Any]]] = []
    for i, typ in enumerate(types):
        try:
            sets.append((i, uff.read_sets(i)))  # one at a time: a failure names its dataset
        except Exception as exc:
            raise RecordError(_unreadable_dataset(p, uff, i, typ, len(types), exc)) from exc
    if not sets:
        raise RecordError(f"{p}: no UFF datasets found (not a UFF file, or truncated)")
    si_file = any(int(s.get("type", 0)) == 164 and int(s.get("units_code", 0) or 0) == 1
                  for _, s in sets)
    d58 = [(i, s) for i, s in sets if int(s.get("type", 0)) == 58]
    time_sets = [(i, s) for i, s in d58 if int(s.get("func_type", -1)) == 1]
    skipped = len(d58) - len(time_sets)
    if not time_sets:
        raise RecordError(
            f"{p}: no time-response channels (dataset 58 with function type 1); found dataset "
            f"types {sorted(set(types))}"
            + (f" and {len(d58)} dataset-58 functions of other types (FRF, spectra, ...)"
               if d58 else "")
        )
    labels = [_label(s) for _, s in time_sets]
    unknown = [k for k in names if not (isinstance(k, int) and 0 <= k < len(time_sets))
               and k not in labels]
    if unknown:
        raise RecordError(
            f"{p}: names= refers to unknown channel(s) {_show(unknown)}; channels are "
            f"{_show(labels)} (or indices 0..{len(time_sets) - 1})"
        )

    spec_count: dict[str, int] = {}
    for _, s in time_sets:
        std = _SPEC_TYPES.get(int(s.get("ordinate_spec_data_type", 0) or 0))
        if std:
            spec_count[std[0]] = spec_count.get(std[0], 0) + 1

    variables: dict[str, np.ndarray] = {}
    var_units: dict[str, str] = {}
    channels = []
    unitless: list[tuple[int, str, str]] = []  # dataset number, label, variable
    time_ref: np.ndarray | None = None
    ref_label = ""
    for k, ((i, s), label) in enumerate(zip(time_sets, labels, strict=True)):
        where = f"{p}: dataset {i + 1} (channel {label!r})"
        data, t = _channel(where, s)
        if time_ref is None:
            time_ref, ref_label = t, label
        else:
            if t.size != time_ref.size:
                raise RecordError(
                    f"{p}: channels have different lengths: {label!r} {t.size} samples, "
                    f"{ref_label!r} {time_ref.size}"
                )
            step, step_ref = np.diff(t).mean(), np.diff(time_ref).mean()
            if abs(step - step_ref) > 1e-6 * step_ref:
                raise RecordError(
                    f"{p}: channels have different sample rates: {label!r} {1 / step:.6g} Hz, "
                    f"{ref_label!r} {1 / step_ref:.6g} Hz (resample to one rate first)"
                )
            if abs(t[0] - time_ref[0]) > 0.5 * step_ref:
                raise RecordError(
                    f"{p}: channels start at different times: {label!r} at {t[0]:g} s, "
                    f"{ref_label!r} at {time_ref[0]:g} s"
                )
        spec = int(s.get("ordinate_spec_data_type", 0) or 0)
        std = _SPEC_TYPES.get(spec)
        if label in names:
            name = names[label]
        elif k in names:
            name = names[k]
        elif std and spec_count[std[0]] == 1:
            name = std[0]
        else:
            name = _sanitise(label)
        if name in variables:
            raise RecordError(
                f"{p}: two channels map to the variable {name!r} (second: {label!r}); "
                "give names= to tell them apart"
            )
        file_unit = _unit_text(s.get("ordinate_axis_units_lab", "") or "", where)
        if file_unit is not None and file_unit.upper() == "NONE":
            file_unit = None
        node, direction = int(s.get("rsp_node", 0) or 0), _DIRS.get(
            int(s.get("rsp_dir", 0) or 0), str(s.get("rsp_dir")))
        keys = [k for k in (label, name) if k in units]
        if shared_units:
            keys += [k for k in units if node_dir(k) == (node, direction) and k not in keys]
        given = units[keys[0]] if keys else None
        if given is not None and shared_units and file_unit is not None:
            if not same_unit(given, file_unit):
                raise UnitConflictError(p, label, given, file_unit, kind="channel")
            given = None  # the file's spelling, as read
        if given is not None:
            unit, how = given, "units="
        elif file_unit is not None:
            unit, how = file_unit, "ordinate units label"
        elif si_file and std:
            unit, how = std[1], "dataset 164 (SI) + specific data type"
        else:
            # every channel without a unit is named in one error (below), not one per run
            unitless.append((i + 1, label, name))
            unit, how = "", ""
        variables[name] = data
        var_units[name] = str(unit)
        channels.append({
            "index": k, "dataset": i + 1, "label": label, "variable": name,
            "node": node, "direction": direction,
            "spec_data_type": spec, "unit": str(unit), "unit_from": how,
        })
    if unitless:
        sets_text = ", ".join(str(i) for i, _, _ in unitless)
        raise MissingUnitError(
            p, unitless[0][1], f"UFF 58 dataset{'s' if len(unitless) > 1 else ''} {sets_text}, "
            f"ordinate unit label{'s' if len(unitless) > 1 else ''} empty",
            STANDARD_UNITS.get(unitless[0][2]) if len(unitless) == 1 else None,
            channels=[label for _, label, _ in unitless])
    stray = [u for u in units if u not in variables and u not in labels]
    if stray and not shared_units:
        raise RecordError(
            f"{p}: units= names {_show(stray)}, neither a variable nor a channel label (variables "
            f"{_show(list(variables))}, channels {_show(labels)})"
        )
    assert time_ref is not None  # time_sets is not empty
    step = (time_ref[-1] - time_ref[0]) / (time_ref.size - 1)
    fs = 1.0 / step
    # UFF stores the increment with 6 significant digits: snap to an integer rate when close
    if abs(fs - round(fs)) < 1e-5 * fs:
        fs = float(round(fs))
        time_ref = time_ref[0] + np.arange(time_ref.size) / fs
    attrs: dict[str, Any] = {"source": str(p), "uff_channels": channels}
    if skipped:
        attrs["uff_skipped_non_time_datasets"] = skipped
    try:
        return Record(time_ref, fs, variables, var_units, attrs)
    except RecordError as exc:
        raise RecordError(f"{p}: {exc}") from None


def open_uff(p: Path, error: type[Exception] = RecordError) -> tuple[Any, list[int]]:
    """A ``pyuff.UFF`` of an existing file and its dataset types; ``error`` for a truncated
    file or one pyuff cannot index."""
    import pyuff

    with p.open("rb") as fh:  # every UFF dataset ends with a "    -1" line
        fh.seek(max(p.stat().st_size - 64, 0))
        tail = fh.read().rstrip()
    if not tail.endswith(b"-1"):
        raise error(f"{p}: truncated or not a UFF file (does not end with a '-1' line)")
    try:
        uff = pyuff.UFF(str(p))
        return uff, [int(t) for t in uff.get_set_types()]
    except Exception as exc:  # pyuff raises bare Exception/ValueError/IndexError on bad files
        raise error(f"{p}: not a readable UFF file ({_why(exc)})") from exc


def _given_unit(p: Path, key: Any, value: Any) -> str:
    """A unit of ``units=``: a non-empty string."""
    unit = _unit_text(value, f"{p}: units={{{key!r}: ...}}")
    if unit is None:
        raise RecordError(f"{p}: units={{{key!r}: ...}} is empty")
    return unit


# Abscissa specific data types that are not time: a "time response" over them is mislabelled.
_NOT_TIME = {18: "frequency", 19: "rpm", 20: "order"}


def _channel(where: str, s: Mapping[str, Any]) -> tuple[np.ndarray, np.ndarray]:
    """Ordinate values and time (s) of one dataset 58, with its header checked against its data.

    ``where`` names the file, dataset and channel in messages.
    """
    data = np.asarray(s.get("data"))
    if np.iscomplexobj(data):
        raise RecordError(f"{where}: complex data (ordinate type "
                          f"{s.get('ord_data_type')}): a time response must be real")
    data = data.astype(float).ravel()
    declared = s.get("num_pts")
    if declared is not None and int(declared) != data.size:
        raise RecordError(
            f"{where}: the header declares {declared} points but the dataset holds "
            f"{data.size} (truncated or edited file)"
        )
    if data.size < 2:
        raise RecordError(f"{where}: {data.size} sample(s); a record needs at least 2")
    spacing = s.get("abscissa_spacing")
    aspec = int(s.get("abscissa_spec_data_type", 0) or 0)
    if aspec in _NOT_TIME:
        raise RecordError(
            f"{where}: the abscissa is {_NOT_TIME[aspec]} (specific data type {aspec}), not time"
        )
    k = _abscissa_factor(where, s, aspec)
    if spacing == 1:
        # even spacing: pyuff rebuilds x from the 6-digit increment; use min + k * inc
        inc = float(s.get("abscissa_inc", float("nan")) or 0.0)
        t0 = float(s.get("abscissa_min", 0.0) or 0.0)
        if not (math.isfinite(inc) and inc > 0):
            raise RecordError(
                f"{where}: abscissa increment {inc!r} s; it must be a finite positive step"
            )
        if not math.isfinite(t0):
            raise RecordError(f"{where}: abscissa minimum {t0!r} s is not finite")
        return data, (t0 + inc * np.arange(data.size)) * k
    if spacing == 0:
        x = np.asarray(s.get("x"), dtype=float).ravel()
        if x.size != data.size:
            raise RecordError(f"{where}: {x.size} abscissa values for {data.size} samples")
        bad = ~np.isfinite(x)
        bad[1:] |= ~(np.diff(x) > 0)
        if np.any(bad):
            j = int(np.flatnonzero(bad)[0])
            after = f" after {float(x[j - 1])!r}" if j else ""
            raise RecordError(
                f"{where}: abscissa (time) value {float(x[j])!r} at sample {j}{after}: the "
                "abscissa must be finite and strictly increasing"
            )
        return data, x * k
    raise RecordError(
        f"{where}: abscissa spacing code {s.get('abscissa_spacing')!r} (0 uneven, 1 even)"
    )


def _abscissa_factor(where: str, s: Mapping[str, Any], aspec: int) -> float:
    """Seconds per abscissa unit, from the abscissa units label.

    Time in every UFF unit system is in seconds; the label is checked so that a file labelled
    ``ms`` is converted and one labelled ``Hz`` is refused. An empty label, or an unknown one on
    an abscissa typed as time (specific data type 17), means seconds.
    """
    label = _unit_text(s.get("abscissa_axis_units_lab", "") or "", f"{where}: abscissa")
    if label is None or label.upper() == "NONE":
        return 1.0
    conv = _time_unit(label)
    if conv is not None:
        return conv[0]
    if is_known_unit(label) or aspec != 17:
        raise RecordError(
            f"{where}: abscissa units {label!r} are not a time unit (specific data type {aspec})"
        )
    return 1.0


def _unreadable_dataset(p: Path, uff: Any, i: int, typ: int, n: int, exc: Exception) -> str:
    """Message for a dataset pyuff cannot parse: its number, channel and the bad line."""
    label = ""
    try:
        head = uff.read_sets(i, header_only=True)
        label = f", channel {_label(head)!r}"
    except Exception:  # the header itself is broken: the line scan below says where
        pass
    where = f"{p}: dataset {i + 1} of {n} (type {typ}{label})"
    bad = _first_bad_line(p, i) if typ == 58 else None
    return f"{where}: {bad}" if bad else f"{where}: unreadable header or data ({_why(exc, 80)})"


def _first_bad_line(p: Path, index: int) -> str | None:
    """What is wrong in dataset ``index`` (ASCII 58) that pyuff cannot parse, with its line."""
    lines = p.read_bytes().decode("latin-1").splitlines()
    # datasets are delimited by "    -1" lines (as pyuff finds them)
    marks = [j for j, ln in enumerate(lines) if ln.rstrip() == "    -1"]
    if len(marks) < 2 * index + 2:
        return None
    start, end = marks[2 * index], marks[2 * index + 1]
    block = lines[start:end]
    if len(block) > 1 and len(block[1]) > 6 and block[1][6].lower() == "b":
        return None  # binary data: no lines to point at
    # record 7 (line 9 of the block: data type, num_pts, spacing, min, increment, z) and the
    # data lines (from line 14) must be numbers
    for j in [start + 8, *range(start + 13, end)]:
        what = "header record 7" if j == start + 8 else "data"
        for tok in lines[j].split() if j < end else []:
            try:
                float(tok)
            except ValueError:
                return f"line {j + 1} ({what}): {_show(tok, 40)} is not a number"
    fields = lines[start + 8].split() if start + 8 < end else []
    if len(fields) >= 3:
        ord_type, spacing = int(float(fields[0])), int(float(fields[2]))
        if ord_type not in (2, 4, 5, 6):
            return (f"line {start + 9} (header record 7): ordinate data type {ord_type} "
                    "(2/4 real, 5/6 complex)")
        if spacing not in (0, 1):
            return (f"line {start + 9} (header record 7): abscissa spacing code {spacing} "
                    "(0 uneven, 1 even)")
    return None


# -- writing ------------------------------------------------------------------------------------
# UFF specific data type codes used by the writers.
SPEC_GENERAL, SPEC_DISPLACEMENT, SPEC_REACTION_FORCE = 1, 8, 9
SPEC_VELOCITY, SPEC_ACCELERATION, SPEC_EXCITATION_FORCE = 11, 12, 13
SPEC_TIME, SPEC_FREQUENCY = 17, 18
#: Response/reference direction code of +Z (sloshrom's vertical, up positive).
DIR_PLUS_Z = 3

# (length, force) unit exponents of a specific data type: with dataset 164 they tell a reader how
# to convert the values to another unit system (m/s^2 has length^1, N force^1).
_UNIT_EXPONENTS = {SPEC_DISPLACEMENT: (1, 0), SPEC_VELOCITY: (1, 0), SPEC_ACCELERATION: (1, 0),
                   SPEC_REACTION_FORCE: (0, 1), SPEC_EXCITATION_FORCE: (0, 1)}


def _field(text: str, width: int, what: str) -> str:
    """A fixed-width text field of a UFF header: printable ASCII, at most ``width`` characters.

    pyuff pads but never truncates: a longer text (or a newline) would shift every following
    field of the dataset and make the file unreadable.
    """
    if len(text) > width or not all(" " <= c <= "~" for c in text):
        raise RecordError(f"UFF {what} {text!r}: at most {width} printable ASCII characters")
    return text


def id_line(text: str) -> str:
    """``text`` as a UFF ID line: non-printable or non-ASCII characters become ``?``, and the
    text is cut to the 80 characters of the line."""
    return "".join(c if " " <= c <= "~" else "?" for c in str(text))[:80]


def dataset164_si() -> dict[str, Any]:
    """Dataset 164 (units) declaring SI: every dataset 58 after it is in m, N, s."""
    import pyuff

    return pyuff.prepare_164(units_code=1, units_description="SI", temp_mode=2, length=1.0,
                             force=1.0, temp=1.0, temp_offset=273.15, return_full_dict=True)


def dataset58(
    data: Any,
    start: float,
    step: float,
    *,
    id1: str,
    id2: str = "",
    id3: str = "",
    id4: str = "",
    id5: str = "",
    func_type: int = 1,
    func_id: int = 0,
    load_case_id: int = 0,
    rsp: tuple[str, int, int] = ("NONE", 0, 0),
    ref: tuple[str, int, int] = ("NONE", 0, 0),
    abscissa: tuple[int, str, str] = (SPEC_TIME, "", "s"),
    ordinate: tuple[int, str, str] = (0, "", ""),
    orddenom: tuple[int, str, str] = (0, "", ""),
    binary: bool = False,
) -> dict[str, Any]:
    """A complete, evenly spaced dataset-58 dict for ``pyuff.UFF.write_sets``.

    Every field pyuff's writer needs is set (pyuff's ``prepare_58`` leaves the axis labels and
    ``func_id`` out, and its writer then fails), header texts are checked against their widths,
    and the unit exponents follow the specific data types.

    Parameters
    ----------
    data : array_like
        Ordinate values, real (written as type 4, double) or complex (type 6, complex double).
    start, step : float
        First abscissa value and increment (s for time, Hz for frequency). UFF stores both with
        6 significant digits.
    id1, id2, id3, id4, id5 : str
        ID lines 1-5 (:func:`id_line` makes any text fit).
    func_type : int
        1 time response, 4 FRF, 6 coherence, ...
    func_id, load_case_id : int
        Function identification number and load case.
    rsp, ref : tuple
        Response and reference ``(entity name, node, direction)``; direction 3 is +Z, node and
        direction 0 mean "none" (a reference of a time response).
    abscissa, ordinate, orddenom : tuple
        ``(specific data type, axis label, units label)`` of the abscissa, the ordinate
        (numerator) and the ordinate denominator (0 for none).
    binary : bool
        Binary (``True``) or ASCII data lines.

    Returns
    -------
    dict
    """
    import pyuff

    values = np.asarray(data)
    values = values.astype(complex if np.iscomplexobj(values) else float).ravel()
    axes: dict[str, Any] = {}
    for name, (spec, label, unit) in (("abscissa", abscissa), ("ordinate", ordinate),
                                      ("orddenom", orddenom)):
        length, force = _UNIT_EXPONENTS.get(int(spec), (0, 0))
        axes |= {f"{name}_spec_data_type": int(spec), f"{name}_len_unit_exp": length,
                 f"{name}_force_unit_exp": force, f"{name}_temp_unit_exp": 0,
                 f"{name}_axis_lab": _field(label, 20, f"{name} axis label"),
                 f"{name}_axis_units_lab": _field(unit, 20, f"{name} units label")}
    d = pyuff.prepare_58(
        binary=int(binary), id1=id_line(id1), id2=id_line(id2), id3=id_line(id3),
        id4=id_line(id4), id5=id_line(id5), func_type=int(func_type), ver_num=0,
        load_case_id=int(load_case_id),
        rsp_ent_name=_field(rsp[0], 10, "entity name"), rsp_node=int(rsp[1]),
        rsp_dir=int(rsp[2]),
        ref_ent_name=_field(ref[0], 10, "entity name"), ref_node=int(ref[1]),
        ref_dir=int(ref[2]),
        ord_data_type=6 if np.iscomplexobj(values) else 4, num_pts=values.size,
        abscissa_spacing=1, abscissa_min=float(start), abscissa_inc=float(step),
        z_axis_value=0.0, z_axis_spec_data_type=0, z_axis_len_unit_exp=0,
        z_axis_force_unit_exp=0, z_axis_temp_unit_exp=0, z_axis_axis_units_lab="",
        data=values, x=float(start) + float(step) * np.arange(values.size),
        return_full_dict=True,
        **{k: v for k, v in axes.items() if not k.endswith("_axis_lab")},
    )
    # pyuff's writer needs every label field and func_id, which prepare_58 does not set
    d |= {k: v for k, v in axes.items() if k.endswith("_axis_lab")}
    d |= {"z_axis_axis_lab": "", "func_id": int(func_id)}
    return d


def write_uff_sets(sets: Sequence[Mapping[str, Any]], path: str | Path,
                   batch: OutputBatch | None = None) -> Path:
    """Write prepared UFF datasets to ``path``, atomically or into ``batch``.

    The first dataset must not be a binary dataset 58: pyuff writes the first dataset in
    "overwrite" mode, and for binary data it reopens the file, truncating the header it has just
    written (start with :func:`dataset164_si`).
    """
    import pyuff

    if not sets:
        raise RecordError("no UFF datasets to write")
    first = sets[0]
    if int(first.get("type", 0)) == 58 and first.get("binary"):
        raise RecordError("the first UFF dataset must not be a binary dataset 58 (pyuff "
                          "truncates it); write dataset 164 first")
    p = Path(path)
    write = batch.write if batch is not None else atomic_write
    return write(p, lambda tmp: pyuff.UFF(tmp).write_sets(list(sets), mode="overwrite"),
                 suffix=p.suffix or ".uff")


def write_uff58(record: Record, path: str | Path, binary: bool = False) -> Path:
    """Write a record's 1-D variables as dataset-58 time responses (with dataset 164, SI).

    Parameters
    ----------
    record : Record
        Written in SI (converted with :meth:`Record.to_si`).
    path : str or Path
        ``.uff`` / ``.unv``; written to a temporary name, then renamed.
    binary : bool
        Binary (``True``) or ASCII (default) dataset 58.

    Returns
    -------
    Path
    """
    rec = record.to_si()
    two_d = [n for n, a in rec.variables.items() if a.ndim != 1]
    if two_d:
        raise RecordError(f"UFF58 holds 1-D channels only; {two_d} are 2-D")
    sets = [dataset164_si()]
    for k, (name, arr) in enumerate(rec.variables.items()):
        sets.append(dataset58(
            arr, float(rec.time[0]), 1.0 / float(rec.fs), id1=name, id2="sloshrom",
            rsp=("tank", k + 1, DIR_PLUS_Z), ref=("tank", 0, 0),
            ordinate=(_SPEC_CODES.get(name, SPEC_GENERAL), "", rec.units[name]),
            binary=binary,
        ))
    return write_uff_sets(sets, path)
