"""Measured beam tests: a laboratory's free decays and random base-excitation runs, read into
the result dicts the beam analyses take.

* :func:`read_free_test`, :func:`read_random_test` - UFF 58, CSV, NetCDF or MATLAB files
  (:func:`sloshrom.io.read_record`) checked (channels present, accelerations, one sample rate,
  finite) and converted to SI, as the dict of ``sloshrom.beam.simulation.coupled.free_response`` /
  ``random_response`` holds the signals the analyses read; which channel is which
  accelerometer is a :class:`~sloshrom.beam.lab.channels.ChannelMap`.
* :func:`check_free_decay`, :func:`check_random_base` - properties of the data the analyses
  need: a free decay that decays, a random test whose base is random.

The channel map (:mod:`sloshrom.beam.lab.channels`: :class:`ChannelMap`, :func:`station_model`)
and the writer of a simulation as a lab's files (:mod:`sloshrom.beam.lab.virtual`:
:func:`write_lab_test`, :func:`lab_test_paths`) are re-exported here, where they were first
defined. Which channel of a UFF 58 file a map's name denotes (its label, or ``node:dir``) is
:mod:`sloshrom.beam.lab.uff58`'s, beside the writers of such files.

Pure functions on arrays and files (no command-line concerns); a bad map is a
:class:`ChannelMapError`, a bad file a :class:`~sloshrom.io.record.RecordError`, data the analyses
cannot use an :class:`~sloshrom.beam.damping.analysis.AnalysisError`.
"""

from __future__ import annotations

import warnings
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any, TypedDict

import numpy as np
from scipy import signal

from sloshrom.beam.damping.analysis import AnalysisError
from sloshrom.beam.errors import BeamError
from sloshrom.beam.lab.channels import ChannelMap, ChannelMapError, station_model
from sloshrom.beam.lab.uff58 import (
    ChannelIdentity,
    channel_identity,
    channel_labels,
    channel_variable,
    check_channel_identity,
    uff_channels,
)
from sloshrom.beam.lab.virtual import lab_test_paths, write_lab_test
from sloshrom.beam.simulation.structure import ModalModel
from sloshrom.config import G
from sloshrom.errors import Note
from sloshrom.io.read import read_record
from sloshrom.io.record import NoTimeAxisError, Record, RecordError
from sloshrom.io.units import canonical_unit

__all__ = [
    "DECAY_RATIO", "LEVEL_FACTOR", "LINE_FRACTION", "LINE_BINS", "ChannelMap",
    "ChannelMapError", "MeasuredTest", "MissingChannelNote", "TruncatedRecordWarning",
    "base_rms_g", "check_free_decay", "check_levels", "check_random_base", "lab_test_paths",
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
#: A nominal RMS level (g) given for a random run must lie within this factor of the run's
#: measured base RMS: the virtual lab's runs read within 0.14 % of their nominal levels (sensor
#: noise; 18 campaign runs and 12 simulated ones, 34-120 s), a laboratory's shaker controls
#: its RMS to a few per cent, and a campaign's levels double (0.1, 0.2, 0.4 g), so that a
#: label of the neighbouring level is a factor 2 off: 1.25 stays below the halfway factor
#: sqrt(2) = 1.41 with room for a shaker's control error.
LEVEL_FACTOR = 1.25


class TruncatedRecordWarning(UserWarning):
    """The files of one test had different lengths; all were cut to the shortest."""


class MissingChannelNote(Note):
    """A file of a test lacks channels its (campaign's) channel map names, and the test does
    without them: a free decay's base (then at rest), stations beyond those the modal filter
    needs."""


# -- reading -------------------------------------------------------------------------------------
def _no_channel(rec: Record, path: Path, names: Sequence[str], why: str) -> RecordError:
    """The error of channels ``names`` the file lacks, listing the file's channels."""
    have = channel_labels(rec, path)
    shown = ", ".join(repr(h) for h in have[:20]) + (" ..." if len(have) > 20 else "")
    which = ", ".join(repr(n) for n in names)
    return RecordError(f"{path}: no channel {which} (the channel map names "
                       f"{'it' if len(names) == 1 else 'them'}{why}); the file's channels: "
                       f"{shown}")


def _read_channels(path: Path, names: Sequence[str], fs: float | None,
                   units: Mapping[str, str] | None
                   ) -> tuple[Record, dict[str, np.ndarray], dict[str, str]]:
    """One file's channels among ``names`` as accelerations in m/s^2 (the file's units
    checked), and their units as read; the channels the file lacks are left out."""
    try:
        rec = read_record(path, fs=fs, units=units, si=False, shared_units=True)
    except NoTimeAxisError as exc:  # said in a laboratory's words, not read_record's fs=
        raise RecordError(f"{exc.source}: no time axis: a test's file needs a 'time' column "
                          "(e.g. 'time [s]') or variable beside its channels") from None
    out, read_units = {}, {}
    uff = {c["variable"]: c for c in uff_channels(rec, path) or ()}
    for name in names:
        var = channel_variable(rec, name, path)
        if var is None:
            continue
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
        # UFF says where each unit came from; elsewhere a given unit agrees with the file's
        given = uff[var]["unit_from"] == "units=" if var in uff else name in (units or {})
        read_units[name] = f"{unit} (given)" if given else unit
    return rec, out, read_units


def _channels_of(channels: ChannelMap, tank: str, base: bool) -> list[str]:
    names = list(channels.stations)
    if tank not in names:
        names.append(tank)
    if base and channels.base is not None:
        names.append(channels.base)
    return names


def _stations_left(channels: ChannelMap, tank: str, modal: ModalModel | None,
                   found: Sequence[tuple[Path, Record, Mapping[str, np.ndarray]]]) -> list[str]:
    """The map's stations every file holds (a :class:`MissingChannelNote` per file that lacks
    some); errors when a file lacks the tank, or too few stations are left for the modes."""
    for path, rec, ch in found:
        if tank not in ch:
            raise _no_channel(rec, path, [tank], ": the tank channel, the amplitude axis of the "
                                                 "damping analyses")
    kept = [s for s in channels.stations if all(s in ch for _, _, ch in found)]
    # a map with few stations is the user's choice; a file that leaves too few is refused
    need = max(modal.n_modes, 1) if modal is not None else 1  # no structure: no modal filter
    if len(kept) < len(channels.stations) and len(kept) < need:
        path, rec, ch = next(f for f in found if any(s not in f[2] for s in channels.stations))
        raise _no_channel(rec, path, [s for s in channels.stations if s not in ch],
                          f"; {len(kept)} station(s) are left, and the modal filter needs at "
                          f"least {need} for the {need} modes of the structure")
    for path, _, ch in found:
        lost = [s for s in channels.stations if s not in ch]
        if lost:
            warnings.warn(f"{path.name} has no channel {', '.join(map(repr, lost))} (the map "
                          f"names {'it' if len(lost) == 1 else 'them'}): the analyses use "
                          f"the stations {', '.join(map(repr, kept))}", MissingChannelNote,
                          stacklevel=3)
    return kept


def _units_as_read(paths: Sequence[Path], units: Sequence[Mapping[str, str]]) -> str:
    """The channels' units as read, ``"Acc 1=g, Acc 2=g"`` (per file when they differ)."""
    texts = [", ".join(f"{k}={v}" for k, v in u.items()) for u in units]
    if len(set(texts)) == 1:
        return texts[0]
    return "; ".join(f"{p.name}: {t}" for p, t in zip(paths, texts, strict=True))


def _units_of(channels: ChannelMap, units: Mapping[str, str] | None,
              path: Path) -> dict[str, str]:
    """The map's units of the file ``path`` (its ``[units]`` and the file patterns' tables)
    with the caller's ``units`` over them."""
    return {**channels.units_for(path), **dict(units or {})}


def _as_paths(paths: str | Path | Sequence[str | Path]) -> list[Path]:
    if isinstance(paths, str | Path):
        return [Path(paths)]
    out = [Path(p) for p in paths]
    if not out:
        raise BeamError("no files given for the test")
    return out


class MeasuredTest(TypedDict, total=False):
    """A measured test as the analyses read it (:func:`read_free_test`, :func:`read_random_test`:
    every key but ``rms_levels_g``, which random tests have). Signals in m/s^2, random tests
    with a leading level axis."""

    time: np.ndarray  # s, from 0
    fs: float  # Hz
    base_acceleration: np.ndarray
    station_acceleration: np.ndarray  # absolute, (..., n, n_stations)
    tank_acceleration: np.ndarray
    source: list[str]  # the file names
    channel_map: ChannelMap  # the map's channels the files held
    channel_units: str  # the channels' units as read
    rms_levels_g: np.ndarray  # random tests: RMS base levels, g
    channel_identity: list[ChannelIdentity]  # UFF files: the channels the map's names found


def _test_dict(time: np.ndarray, fs: float, base: np.ndarray, stations: np.ndarray,
               tank: np.ndarray, sources: list[str]) -> MeasuredTest:
    return {"time": time, "fs": fs, "base_acceleration": base,
            "station_acceleration": stations, "tank_acceleration": tank, "source": sources}


def read_free_test(paths: str | Path | Sequence[str | Path], channels: ChannelMap,
                   modal: ModalModel | None, *, fs: float | None = None,
                   units: Mapping[str, str] | None = None) -> MeasuredTest:
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
        Units of channels whose file gives none, e.g. ``{"Acc 1": "g"}``; they win over the
        map's ``[units]``. A unit that contradicts the file's own is an error.

    Returns
    -------
    dict
        ``time`` (s, from 0 at the first sample), ``fs`` (Hz), ``base_acceleration`` (m/s^2;
        zeros without a base channel), ``station_acceleration`` (absolute, m/s^2, (n,
        n_stations)), ``tank_acceleration`` (m/s^2), ``source`` (file names),
        ``channel_map`` (the :class:`ChannelMap` of the channels used: the file's stations,
        its base if it has one) and ``channel_units`` (the channels' units as read, text).

        A base the file lacks is at rest, stations it lacks are left out (the modal filter
        then uses the others: build its model with ``station_model`` of ``channel_map``);
        a :class:`MissingChannelNote` says so.

    Raises
    ------
    RecordError
        Missing file, a file without the tank channel or with fewer stations than the
        structure's modes (the message lists the file's channels), a channel that is not an
        acceleration, a channel without a unit (:class:`~sloshrom.io.record.MissingUnitError`)
        or whose given unit contradicts the file's
        (:class:`~sloshrom.io.record.UnitConflictError`), NaN/inf values.
    BeamError
        More than one file.
    """
    ps = _as_paths(paths)
    if len(ps) != 1:
        raise BeamError(f"a free decay is one file, got {len(ps)}")
    tank = channels.tank_channel(modal)
    rec, ch, read_units = _read_channels(ps[0], _channels_of(channels, tank, True), fs,
                                         _units_of(channels, units, ps[0]))
    kept = _stations_left(channels, tank, modal, [(ps[0], rec, ch)])
    n = rec.time.size
    has_base = channels.base is not None and channels.base in ch
    if channels.base is not None and not has_base:
        warnings.warn(f"{ps[0].name} has no channel {channels.base!r} (the map names it): a "
                      "free decay without a base channel has its base at rest",
                      MissingChannelNote, stacklevel=2)
    base = ch[channels.base] if channels.base is not None and has_base else np.zeros(n)
    st = np.stack([ch[s] for s in kept], axis=-1)
    out = _test_dict(rec.time - rec.time[0], float(rec.fs), base, st, ch[tank], [ps[0].name])
    out["channel_map"] = channels.only(kept, base=has_base)
    out["channel_units"] = _units_as_read(ps, [read_units])
    ident = channel_identity(rec, ps[0], _channels_of(channels, tank, True))
    out["channel_identity"] = [ident] if ident is not None else []
    return out


def read_random_test(paths: str | Path | Sequence[str | Path], channels: ChannelMap,
                     modal: ModalModel | None, *, levels: Sequence[float] | None = None,
                     fs: float | None = None, units: Mapping[str, str] | None = None
                     ) -> MeasuredTest:
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
        (a :class:`TruncatedRecordWarning` says so). Stations a file lacks are left out of
        every level (a :class:`MissingChannelNote` says so).

    Raises
    ------
    RecordError
        As :func:`read_free_test`; a file without the base channel; files with different
        sample rates (both named).
    ChannelMapError
        No ``base`` channel in the map.
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
    runs, read_units, idents = [], [], []
    for p in ps:
        rec, ch, ru = _read_channels(p, names, fs, _units_of(channels, units, p))
        ident = channel_identity(rec, p, names)
        if ident is not None:
            idents.append(ident)
            check_channel_identity(idents)
        if channels.base not in ch:
            raise _no_channel(rec, p, [channels.base], ": a random test needs the base, the "
                                                       "input of H1")
        if runs and abs(rec.fs - runs[0][0].fs) > 1e-6 * runs[0][0].fs:
            raise RecordError(f"{p} is sampled at {rec.fs:g} Hz, {ps[0]} at "
                              f"{runs[0][0].fs:g} Hz: one test has one sample rate")
        runs.append((rec, ch))
        read_units.append(ru)
    kept = _stations_left(channels, tank, modal,
                          [(p, r, ch) for p, (r, ch) in zip(ps, runs, strict=True)])
    n = min(r.time.size for r, _ in runs)
    if any(r.time.size != n for r, _ in runs):
        sizes = ", ".join(f"{p.name} {r.time.size}" for p, (r, _) in zip(ps, runs, strict=True))
        warnings.warn(f"the files of the random test have different lengths ({sizes} samples): "
                      f"all cut to the shortest, {n} samples", TruncatedRecordWarning,
                      stacklevel=2)
    rec0 = runs[0][0]
    base = np.stack([ch[channels.base][:n] for _, ch in runs])
    if levels is None:
        lv = [float(f"{g:.2g}") for g in base_rms_g(base)]
    else:
        lv = [float(v) for v in levels]
    if len(set(lv)) != len(lv):
        if levels is not None:
            raise BeamError(f"the RMS levels given, {lv} g, are not distinct (one row per level "
                            "in Table 2): one level per file, each file's own")
        raise BeamError(f"the files' base RMS levels round to {lv} g, not distinct (one row "
                        "per level in Table 2): give the levels (--levels)")
    st = np.stack([np.stack([ch[s][:n] for s in kept], axis=-1) for _, ch in runs])
    out = _test_dict(rec0.time[:n] - rec0.time[0], float(rec0.fs), base, st,
                     np.stack([ch[tank][:n] for _, ch in runs]), [p.name for p in ps])
    out["rms_levels_g"] = np.asarray(lv)
    out["channel_map"] = channels.only(kept)
    out["channel_units"] = _units_as_read(ps, read_units)
    out["channel_identity"] = idents
    return out



# -- properties of the data ----------------------------------------------------------------------
def base_rms_g(base: np.ndarray) -> np.ndarray:
    """The RMS of each run's base acceleration (m/s^2, ``(..., n)``), g."""
    b = np.asarray(base, dtype=float)
    return np.sqrt(np.mean(b**2, axis=-1)) / G


def check_levels(base: np.ndarray, levels: Sequence[float], sources: Sequence[str]) -> None:
    """Whether the nominal RMS levels given for a random test's runs are theirs: each within
    :data:`LEVEL_FACTOR` of its run's measured base RMS.

    Parameters
    ----------
    base : array (n_levels, n)
        The runs' base accelerations, m/s^2.
    levels : sequence of float
        The nominal RMS levels given, g, one per run.
    sources : sequence of str
        The runs' names in messages (file names, or ``"FILE level 1"``).

    Raises
    ------
    AnalysisError
        A level not within the factor of its run's base RMS (both values named, per run: a
        swapped or mistyped level, or a base channel in another unit than its file says).
    """
    measured = base_rms_g(base)
    bad = [(src, g, float(m)) for src, g, m in zip(sources, levels, measured, strict=True)
           if not (m > 0 and 1 / LEVEL_FACTOR <= g / m <= LEVEL_FACTOR)]
    if bad:
        each = "; ".join(f"{src}: {g:g} g given, its base RMS {m:.3g} g" for src, g, m in bad)
        raise AnalysisError(
            f"the levels given do not match the measured base RMS ({each}); each level must "
            f"be within a factor {LEVEL_FACTOR:g} of its run's (in order: a swapped level, or "
            "a base in another unit than its file says?)")


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
