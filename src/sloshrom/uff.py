"""Universal File Format (UFF/UNV) dataset 58 time histories as :class:`sloshrom.data.Record`.

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
atomically; it is what the tests use to produce files "as pyuff writes them".
"""

from __future__ import annotations

import math
import re
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from sloshrom.data import STANDARD_UNITS, Record, RecordError
from sloshrom.fileio import atomic_write

__all__ = ["read_uff58", "write_uff58"]

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
        override the file), e.g. ``{"force": "kN"}``.

    Returns
    -------
    Record
        Units as in the file (convert with :meth:`Record.to_si`); ``attrs["uff_channels"]``
        lists label, node, direction, specific data type and unit source of every channel.

    Raises
    ------
    RecordError
        Unreadable file, no time-response dataset, complex or mismatched channels (length,
        start time, sample rate), uneven sampling, duplicate names, missing units.
    """
    import pyuff

    p = Path(path)
    names = dict(names or {})
    units = dict(units or {})
    if not p.is_file():
        raise RecordError(f"{p}: no such file")
    with p.open("rb") as fh:  # every UFF dataset ends with a "    -1" line
        fh.seek(max(p.stat().st_size - 64, 0))
        tail = fh.read().rstrip()
    if not tail.endswith(b"-1"):
        raise RecordError(f"{p}: truncated or not a UFF file (does not end with a '-1' line)")
    try:
        uff = pyuff.UFF(str(p))
        types = list(uff.get_set_types())
        sets = uff.read_sets() if types else []
    except Exception as exc:  # pyuff raises bare Exception/ValueError/IndexError on bad files
        raise RecordError(f"{p}: not a readable UFF file ({type(exc).__name__}: {exc})") from exc
    if isinstance(sets, dict):  # pyuff returns a dict for a single dataset
        sets = [sets]
    if not sets:
        raise RecordError(f"{p}: no UFF datasets found (not a UFF file, or truncated)")
    si_file = any(int(s.get("type", 0)) == 164 and int(s.get("units_code", 0) or 0) == 1
                  for s in sets)
    d58 = [s for s in sets if int(s.get("type", 0)) == 58]
    time_sets = [s for s in d58 if int(s.get("func_type", -1)) == 1]
    skipped = len(d58) - len(time_sets)
    if not time_sets:
        raise RecordError(
            f"{p}: no time-response channels (dataset 58 with function type 1); found dataset "
            f"types {sorted({int(s.get('type', 0)) for s in sets})}"
            + (f" and {len(d58)} dataset-58 functions of other types (FRF, spectra, ...)"
               if d58 else "")
        )
    unknown = [k for k in names if not (isinstance(k, int) and 0 <= k < len(time_sets))
               and k not in {_label(s) for s in time_sets}]
    if unknown:
        raise RecordError(
            f"{p}: names= refers to unknown channel(s) {unknown}; channels are "
            f"{[_label(s) for s in time_sets]} (or indices 0..{len(time_sets) - 1})"
        )

    spec_count: dict[str, int] = {}
    for s in time_sets:
        std = _SPEC_TYPES.get(int(s.get("ordinate_spec_data_type", 0) or 0))
        if std:
            spec_count[std[0]] = spec_count.get(std[0], 0) + 1

    variables: dict[str, np.ndarray] = {}
    var_units: dict[str, str] = {}
    channels = []
    time_ref: np.ndarray | None = None
    ref_label = ""
    for i, s in enumerate(time_sets):
        label = _label(s)
        data = np.asarray(s.get("data"))
        if np.iscomplexobj(data):
            raise RecordError(f"{p}: channel {label!r} holds complex data, not a time response")
        data = data.astype(float).ravel()
        x = np.asarray(s.get("x"), dtype=float).ravel()
        if data.size < 2 or x.size != data.size:
            raise RecordError(
                f"{p}: channel {label!r} has {data.size} samples and {x.size} abscissa values "
                "(truncated?)"
            )
        t = x
        if int(s.get("abscissa_spacing", 0) or 0) == 1:
            # even spacing: pyuff rebuilds x from the 6-digit increment; use min + k * inc
            inc = float(s.get("abscissa_inc", 0.0) or 0.0)
            if not (math.isfinite(inc) and inc > 0):
                raise RecordError(f"{p}: channel {label!r}: abscissa increment {inc!r} s invalid")
            t = float(s.get("abscissa_min", 0.0) or 0.0) + inc * np.arange(data.size)
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
        elif i in names:
            name = names[i]
        elif std and spec_count[std[0]] == 1:
            name = std[0]
        else:
            name = _sanitise(label)
        if name in variables:
            raise RecordError(
                f"{p}: two channels map to the variable {name!r} (second: {label!r}); "
                "give names= to tell them apart"
            )
        file_unit = str(s.get("ordinate_axis_units_lab", "") or "").strip()
        if name in units or label in units:
            unit, how = units.get(name, units.get(label)), "units="
        elif file_unit and file_unit.upper() != "NONE":
            unit, how = file_unit, "ordinate units label"
        elif si_file and std:
            unit, how = std[1], "dataset 164 (SI) + specific data type"
        else:
            raise RecordError(
                f"{p}: channel {label!r} ({name!r}) has no unit in the file; give "
                f"units={{{name!r}: ...}} (SI for this name: "
                f"{STANDARD_UNITS.get(name, 'unknown')!r})"
            )
        variables[name] = data
        var_units[name] = str(unit)
        channels.append({
            "index": i, "label": label, "variable": name,
            "node": int(s.get("rsp_node", 0) or 0),
            "direction": _DIRS.get(int(s.get("rsp_dir", 0) or 0), str(s.get("rsp_dir"))),
            "spec_data_type": spec, "unit": str(unit), "unit_from": how,
        })
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
    import pyuff

    rec = record.to_si()
    p = Path(path)
    two_d = [n for n, a in rec.variables.items() if a.ndim != 1]
    if two_d:
        raise RecordError(f"UFF58 holds 1-D channels only; {two_d} are 2-D")
    sets = [pyuff.prepare_164(units_code=1, units_description="SI", temp_mode=2, length=1.0,
                              force=1.0, temp=1.0, temp_offset=273.15, return_full_dict=True)]
    x = rec.time
    for k, (name, arr) in enumerate(rec.variables.items()):
        spec = _SPEC_CODES.get(name, 1)
        sets.append(pyuff.prepare_58(
            binary=int(binary), id1=name, id2="sloshrom", id3="", id4="", id5="",
            func_type=1, ver_num=0, load_case_id=0, rsp_ent_name="tank", rsp_node=k + 1,
            rsp_dir=3, ref_ent_name="tank", ref_node=0, ref_dir=0,
            ord_data_type=4, num_pts=arr.size, abscissa_spacing=1,
            abscissa_min=float(rec.time[0]), abscissa_inc=1.0 / float(rec.fs),
            z_axis_value=0.0,
            abscissa_spec_data_type=17, abscissa_len_unit_exp=0, abscissa_force_unit_exp=0,
            abscissa_temp_unit_exp=0, abscissa_axis_units_lab="s",
            ordinate_spec_data_type=spec, ordinate_len_unit_exp=0, ordinate_force_unit_exp=0,
            ordinate_temp_unit_exp=0, ordinate_axis_units_lab=rec.units[name],
            orddenom_spec_data_type=0, orddenom_len_unit_exp=0, orddenom_force_unit_exp=0,
            orddenom_temp_unit_exp=0, orddenom_axis_units_lab="",
            z_axis_spec_data_type=0, z_axis_len_unit_exp=0, z_axis_force_unit_exp=0,
            z_axis_temp_unit_exp=0, z_axis_axis_units_lab="",
            data=np.asarray(arr, dtype=float), x=x, return_full_dict=True,
        ))
        for key in ("abscissa_axis_lab", "ordinate_axis_lab", "orddenom_axis_lab",
                    "z_axis_axis_lab"):
            if sets[-1].get(key) is None:  # pyuff's writer needs every label field
                sets[-1][key] = ""
        sets[-1]["func_id"] = 0
    return atomic_write(
        p, lambda tmp: pyuff.UFF(tmp).write_sets(sets, mode="overwrite"),
        suffix=p.suffix or ".uff",
    )
