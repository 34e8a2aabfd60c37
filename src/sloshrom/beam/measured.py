"""Measured beam tests: a laboratory's free decays and random base-excitation runs, read into
the result dicts the beam analyses take.

* :func:`read_free_test`, :func:`read_random_test` - UFF 58, CSV, NetCDF or MATLAB files
  (:func:`sloshrom.io.read_record`) checked (channels present, accelerations, one sample rate,
  finite) and converted to SI, as the dict of ``sloshrom.beam.coupled.free_response`` /
  ``random_response`` holds the signals the analyses read; which channel is which
  accelerometer is a :class:`~sloshrom.beam.channels.ChannelMap`.
* :func:`check_free_decay`, :func:`check_random_base` - properties of the data the analyses
  need: a free decay that decays, a random test whose base is random.

The channel map (:mod:`sloshrom.beam.channels`: :class:`ChannelMap`, :func:`station_model`) and
the writer of a simulation as a lab's files (:mod:`sloshrom.beam.labfiles`:
:func:`write_lab_test`, :func:`lab_test_paths`) are re-exported here, where they were first
defined.

Pure functions on arrays and files (no command-line concerns); a bad map is a
:class:`ChannelMapError`, a bad file a :class:`~sloshrom.io.record.RecordError`, data the analyses
cannot use an :class:`~sloshrom.beam.analysis.AnalysisError`.
"""

from __future__ import annotations

import re
import warnings
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
from scipy import signal

from sloshrom.beam.analysis import AnalysisError
from sloshrom.beam.channels import ChannelMap, ChannelMapError, station_model
from sloshrom.beam.errors import BeamError
from sloshrom.beam.labfiles import lab_test_paths, write_lab_test
from sloshrom.beam.structure import ModalModel
from sloshrom.config import G
from sloshrom.io.read import read_record
from sloshrom.io.record import Record, RecordError
from sloshrom.io.units import canonical_unit

__all__ = [
    "DECAY_RATIO", "LINE_FRACTION", "LINE_BINS", "ChannelMap", "ChannelMapError",
    "TruncatedRecordWarning", "check_free_decay", "check_random_base", "lab_test_paths",
    "read_free_test", "read_random_test", "station_model", "write_lab_test",
]

#: A free decay must decay: the mode-1 band envelope (RMS) over its last periods must be below
#: this fraction of that over its first periods.
DECAY_RATIO = 0.7
#: A random base must not be a few spectral lines: the :data:`LINE_BINS` strongest bins of its
#: Welch PSD (Hann, 4096 samples) may hold at most this fraction of its power. A sine holds
#: about 100 %, the paper's Gaussian-PSD excitation about 14 %.
LINE_FRACTION = 0.5
LINE_BINS = 10

_NODE_DIR = re.compile(r"^\s*(\d+)\s*:\s*([+-]?)\s*([XYZxyz]|R[XYZxyz])\s*$")


class TruncatedRecordWarning(UserWarning):
    """The files of one test had different lengths; all were cut to the shortest."""


# -- reading -------------------------------------------------------------------------------------
def _channel_variable(rec: Record, name: str, path: Path) -> str:
    """The record variable of the channel ``name``: a UFF channel by its label (ID line 1),
    else by ``node:dir``; other formats by variable name (the label wins over node:dir)."""
    # a NetCDF made from a UFF file keeps its uff_channels attribute: only UFF files use it
    uff = rec.attrs.get("uff_channels") if path.suffix.lower() in (".uff", ".unv") else None
    if uff:
        for ch in uff:
            if ch["label"] == name.strip():
                return ch["variable"]
        m = _NODE_DIR.match(name)
        if m:
            node, sign, axis = int(m.group(1)), m.group(2) or "+", m.group(3).upper()
            for ch in uff:
                if ch["node"] == node and ch["direction"] == f"{sign}{axis}":
                    return ch["variable"]
        have = [f"{c['label']} ({c['node']}:{c['direction']})" for c in uff]
    else:
        if name in rec.variables:
            return name
        have = list(rec.variables)
    shown = ", ".join(repr(h) for h in have[:20]) + (" ..." if len(have) > 20 else "")
    raise RecordError(f"{path}: no channel {name!r} (the channel map names it); the file's "
                      f"channels: {shown}")


def _read_channels(path: Path, names: Sequence[str], fs: float | None,
                   units: Mapping[str, str] | None) -> tuple[Record, dict[str, np.ndarray]]:
    """One file's channels ``names`` as accelerations in m/s^2 (the file's units checked)."""
    rec = read_record(path, fs=fs, units=units, si=False)
    out = {}
    for name in names:
        var = _channel_variable(rec, name, path)
        arr = np.asarray(rec.variables[var], dtype=float)
        if arr.ndim != 1:
            raise RecordError(f"{path}: channel {name!r} is {arr.ndim}-D; a channel is one time "
                              "history")
        unit = rec.units.get(var) or ""
        si, factor = canonical_unit(unit)
        if si != "m/s^2":
            raise RecordError(f"{path}: channel {name!r} is in {unit or 'no unit'!r}, not an "
                              "acceleration (m/s^2, g, mm/s^2, ...)")
        out[name] = arr * factor
    return rec, out


def _channels_of(channels: ChannelMap, tank: str, base: bool) -> list[str]:
    names = list(channels.stations)
    if tank not in names:
        names.append(tank)
    if base and channels.base is not None:
        names.append(channels.base)
    return names


def _as_paths(paths: str | Path | Sequence[str | Path]) -> list[Path]:
    if isinstance(paths, str | Path):
        return [Path(paths)]
    out = [Path(p) for p in paths]
    if not out:
        raise BeamError("no files given for the test")
    return out


def _test_dict(time: np.ndarray, fs: float, base: np.ndarray, stations: np.ndarray,
               tank: np.ndarray, sources: list[str]) -> dict[str, Any]:
    return {"time": time, "fs": fs, "base_acceleration": base,
            "station_acceleration": stations, "tank_acceleration": tank, "source": sources}


def read_free_test(paths: str | Path | Sequence[str | Path], channels: ChannelMap,
                   modal: ModalModel | None, *, fs: float | None = None,
                   units: Mapping[str, str] | None = None) -> dict[str, Any]:
    """A measured free decay (one file) as the analyses read a simulated one.

    Parameters
    ----------
    paths : path or sequence of one path
        UFF 58 (``.uff``/``.unv``), CSV, NetCDF or MATLAB file (:func:`sloshrom.io.read_record`).
    channels : ChannelMap
        Which channel is which accelerometer.
    modal : ModalModel or None
        The structure (it says where the tank is when the map does not name its channel);
        ``None``: the reference channel is ``tank`` or the outermost station.
    fs : float, optional
        Sample rate, Hz, for a file without a time axis.
    units : dict, optional
        Units of channels whose file gives none, e.g. ``{"Acc 1": "g"}``.

    Returns
    -------
    dict
        ``time`` (s, from 0 at the first sample), ``fs`` (Hz), ``base_acceleration`` (m/s^2;
        zeros without a base channel), ``station_acceleration`` (absolute, m/s^2, (n,
        n_stations)), ``tank_acceleration`` (m/s^2), ``source`` (file names).

    Raises
    ------
    RecordError
        Missing file or channel (the message lists the file's channels), a channel that is not
        an acceleration, NaN/inf values.
    BeamError
        More than one file.
    """
    ps = _as_paths(paths)
    if len(ps) != 1:
        raise BeamError(f"a free decay is one file, got {len(ps)}")
    tank = channels.tank_channel(modal)
    rec, ch = _read_channels(ps[0], _channels_of(channels, tank, True), fs, units)
    n = rec.time.size
    base = ch[channels.base] if channels.base is not None else np.zeros(n)
    st = np.stack([ch[s] for s in channels.stations], axis=-1)
    return _test_dict(rec.time - rec.time[0], float(rec.fs), base, st, ch[tank], [ps[0].name])


def read_random_test(paths: str | Path | Sequence[str | Path], channels: ChannelMap,
                     modal: ModalModel | None, *, levels: Sequence[float] | None = None,
                     fs: float | None = None, units: Mapping[str, str] | None = None
                     ) -> dict[str, Any]:
    """A measured random base-excitation test, one file per level, as the analyses read a
    simulated one.

    Parameters
    ----------
    paths : path or sequence of paths
        One file per RMS level (formats as :func:`read_free_test`).
    channels : ChannelMap
        Needs ``base``.
    modal : ModalModel
        The structure (where the tank is).
    levels : sequence of float, optional
        Nominal RMS base accelerations, g, one per file; default: each file's measured base
        RMS in g, rounded to two significant digits (0.1013 -> 0.1, 0.387 -> 0.39).
    fs, units
        As :func:`read_free_test`.

    Returns
    -------
    dict
        As :func:`read_free_test` with a leading level axis on every signal, and
        ``rms_levels_g``. Files of different lengths are cut to the shortest
        (a :class:`TruncatedRecordWarning` says so).

    Raises
    ------
    RecordError
        As :func:`read_free_test`; files with different sample rates (both named).
    ChannelMapError
        No ``base`` channel.
    BeamError
        ``levels`` not one per file, or levels that are not distinct.
    """
    ps = _as_paths(paths)
    if channels.base is None:
        raise ChannelMapError("channels: a random test needs the 'base' channel (the shaker "
                              "table acceleration: the input of H1)")
    if levels is not None and len(levels) != len(ps):
        raise BeamError(f"{len(levels)} level(s) for {len(ps)} file(s): one level per file")
    tank = channels.tank_channel(modal)
    names = _channels_of(channels, tank, True)
    runs = []
    for p in ps:
        rec, ch = _read_channels(p, names, fs, units)
        if runs and abs(rec.fs - runs[0][0].fs) > 1e-6 * runs[0][0].fs:
            raise RecordError(f"{p} is sampled at {rec.fs:g} Hz, {ps[0]} at "
                              f"{runs[0][0].fs:g} Hz: one test has one sample rate")
        runs.append((rec, ch))
    n = min(r.time.size for r, _ in runs)
    if any(r.time.size != n for r, _ in runs):
        sizes = ", ".join(f"{p.name} {r.time.size}" for p, (r, _) in zip(ps, runs, strict=True))
        warnings.warn(f"the files of the random test have different lengths ({sizes} samples): "
                      f"all cut to the shortest, {n} samples", TruncatedRecordWarning,
                      stacklevel=2)
    rec0 = runs[0][0]
    base = np.stack([ch[channels.base][:n] for _, ch in runs])
    if levels is None:
        lv = [float(f"{np.sqrt(np.mean(b**2)) / G:.2g}") for b in base]
    else:
        lv = [float(v) for v in levels]
    if len(set(lv)) != len(lv):
        raise BeamError(f"RMS levels {lv} g are not distinct (one row per level in Table 2): "
                        "give the levels (--levels)")
    st = np.stack([np.stack([ch[s][:n] for s in channels.stations], axis=-1) for _, ch in runs])
    out = _test_dict(rec0.time[:n] - rec0.time[0], float(rec0.fs), base, st,
                     np.stack([ch[tank][:n] for _, ch in runs]), [p.name for p in ps])
    out["rms_levels_g"] = np.asarray(lv)
    return out



# -- properties of the data ----------------------------------------------------------------------
def check_free_decay(res: Mapping[str, Any], f1: float, *, rel_band: float = 0.5,
                     mode: int = 1) -> float:
    """Whether a free response decays: the envelope ratio (end / start) of a mode.

    The tank acceleration relative to the base is band-passed around ``f1`` (``1 -/+
    rel_band`` of it: 0.5-1.5 f1 for mode 1, as the damping analyses); its RMS over periods 2-5
    is the start, over the last 4 periods but one the end.

    Parameters
    ----------
    res : mapping
        The free decay (:func:`read_free_test`).
    f1 : float
        The mode's frequency, Hz.
    rel_band : float
        Half-width of the band-pass, relative to ``f1``.
    mode : int
        The mode's number (messages).

    Returns
    -------
    float
        End / start RMS (-).

    Raises
    ------
    AnalysisError
        Fewer than 12 periods of the mode, or a ratio of :data:`DECAY_RATIO` or more (not a
        free decay: a forced or random run, or the wrong channel).
    """
    fs = float(res["fs"])
    x = np.asarray(res["tank_acceleration"]) - np.asarray(res["base_acceleration"])
    per = fs / f1
    if x.size < 12 * per:
        raise AnalysisError(f"the free decay holds {x.size / per:.1f} periods of mode {mode} "
                            f"({f1:.4g} Hz): need at least 12")
    # the damping analyses' band: 4th-order Butterworth, zero phase
    sos = signal.butter(4, [(1 - rel_band) * f1, (1 + rel_band) * f1], btype="bandpass",
                        fs=fs, output="sos")
    y = signal.sosfiltfilt(sos, x)
    start = y[int(2 * per):int(5 * per)]
    end = y[int(x.size - 5 * per):int(x.size - per)]
    a, b = float(np.sqrt(np.mean(start**2))), float(np.sqrt(np.mean(end**2)))
    ratio = b / a if a > 0 else float("inf")
    if not ratio < DECAY_RATIO:
        raise AnalysisError(
            f"the tank acceleration does not decay: its mode-{mode} band ({f1:.4g} Hz) ends at "
            f"{ratio:.2f} x its start (a free decay needs < {DECAY_RATIO:g}); a forced or "
            "random run, or the wrong tank channel?")
    return ratio


def check_random_base(base: np.ndarray, fs: float, level: str = "") -> float:
    """Whether a base acceleration is random: the fraction of its power in its
    :data:`LINE_BINS` strongest Welch bins (Hann, 4096 samples or the record, 50 % overlap,
    the mean removed).

    Returns
    -------
    float
        That fraction (-).

    Raises
    ------
    AnalysisError
        A constant (e.g. zero) base, or a fraction above :data:`LINE_FRACTION` (a sine or a
        few sines: its power sits in a few spectral lines).
    """
    b = np.asarray(base, dtype=float)
    where = f"the base acceleration{' ' + level if level else ''}"
    if not np.std(b) > 1e-12 * max(float(np.max(np.abs(b))), 1e-300):
        raise AnalysisError(f"{where} is constant ({float(b[0]):.3g} m/s^2): a random test "
                            "needs a random base excitation")
    _, p = signal.welch(b, fs, window="hann", nperseg=min(4096, b.size), detrend="constant")
    p = p[1:]  # without the DC bin
    frac = float(np.sort(p)[-LINE_BINS:].sum() / p.sum())
    if frac > LINE_FRACTION:
        raise AnalysisError(
            f"{where} is not random: {100 * frac:.0f} % of its power sits in {LINE_BINS} "
            f"spectral lines (at most {100 * LINE_FRACTION:g} % for a random excitation; a "
            "sine?)")
    return frac
