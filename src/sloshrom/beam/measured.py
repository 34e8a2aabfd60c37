"""Measured beam tests: a laboratory's free decays and random base-excitation runs, read into
the result dicts the beam analyses take, and the reverse (a simulation written as a lab's files).

* :class:`ChannelMap` - which channel of the files is which accelerometer (a small TOML file,
  ``[channels]``: ``stations`` with their ``positions`` on the built-in cantilever or ``ids`` on
  the user's structure, ``base``, ``tank``).
* :func:`read_free_test`, :func:`read_random_test` - UFF 58, CSV, NetCDF or MATLAB files
  (:func:`sloshrom.io.read_record`) checked (channels present, accelerations, one sample rate,
  finite) and converted to SI, as the dict of ``sloshrom.beam.coupled.free_response`` /
  ``random_response`` holds the signals the analyses read.
* :func:`station_model` - the modal model seen by the map's stations (modal filtering).
* :func:`check_free_decay`, :func:`check_random_base` - properties of the data the analyses
  need: a free decay that decays, a random test whose base is random.
* :func:`write_lab_test`, :func:`lab_test_paths` - the virtual rig plays the laboratory: a
  simulated response as UFF 58 time histories with sensor noise, and the map that reads them.

Pure functions on arrays and files (no command-line concerns); a bad map is a
:class:`ChannelMapError`, a bad file a :class:`~sloshrom.io.record.RecordError`, data the analyses
cannot use an :class:`~sloshrom.beam.analysis.AnalysisError`.
"""

from __future__ import annotations

import dataclasses
import math
import re
import warnings
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from scipy import signal

from sloshrom.beam.analysis import AnalysisError
from sloshrom.beam.errors import BeamError
from sloshrom.beam.export import BASE_NODE, FIRST_TANK_NODE
from sloshrom.beam.structure import CantileverBeam, ModalModel
from sloshrom.config import ConfigError, G, load_toml_table
from sloshrom.fileio import OutputBatch, atomic_write
from sloshrom.io.read import read_record
from sloshrom.io.record import Record, RecordError
from sloshrom.io.uff import (
    DIR_PLUS_Z,
    SPEC_ACCELERATION,
    SPEC_TIME,
    dataset58,
    dataset164_si,
    write_uff_sets,
)
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

_KEYS = ("stations", "positions", "ids", "base", "tank")
_NODE_DIR = re.compile(r"^\s*(\d+)\s*:\s*([+-]?)\s*([XYZxyz]|R[XYZxyz])\s*$")


class ChannelMapError(ConfigError, BeamError):
    """A channel map is invalid (unknown or missing keys, duplicates, wrong types)."""


class TruncatedRecordWarning(UserWarning):
    """The files of one test had different lengths; all were cut to the shortest."""


@dataclass(frozen=True)
class ChannelMap:
    """Which channel of a test's files is which accelerometer.

    Parameters
    ----------
    stations : tuple of str
        Channel names of the beam accelerometers, in order (the label the file gives: UFF ID
        line 1, CSV column, NetCDF/MAT variable; for UFF also ``node:dir``, e.g. ``"101:+Z"``).
    positions : tuple of float, optional
        Their positions along the built-in cantilever, m (from the root).
    ids : tuple of int, optional
        Their grid/node IDs on the user's structure (``--structure``, ``--modal-toml``).
        Exactly one of ``positions`` and ``ids``.
    base : str, optional
        Channel of the base (shaker table) acceleration: required for random tests; a free
        decay without it has a base at rest.
    tank : str, optional
        Channel of the tank acceleration (the amplitude axis of the damping analyses);
        default: the station at the tank (position = beam length, or the tank's grid ID).
    """

    stations: tuple[str, ...]
    positions: tuple[float, ...] | None = None
    ids: tuple[int, ...] | None = None
    base: str | None = None
    tank: str | None = None

    def __post_init__(self) -> None:
        st = self.stations
        if isinstance(st, str) or not isinstance(st, Sequence) or not st:
            raise ChannelMapError(f"channels.stations must be a non-empty list of channel "
                                  f"names, got {st!r}")
        st = tuple(st)
        for s in st:
            if not isinstance(s, str) or not s.strip():
                raise ChannelMapError(f"channels.stations: {s!r} is not a channel name")
        dup = [s for s in st if st.count(s) > 1]
        if dup:
            raise ChannelMapError(f"channels.stations: {dup[0]!r} is given twice")
        object.__setattr__(self, "stations", st)
        if (self.positions is None) == (self.ids is None):
            raise ChannelMapError("channels: give exactly one of 'positions' (m, the built-in "
                                  "cantilever) and 'ids' (grid IDs on --structure)")
        if self.positions is not None:
            pos = _list(self.positions, "positions", len(st))
            try:
                x = tuple(float(v) for v in pos)
            except (TypeError, ValueError):
                raise ChannelMapError(f"channels.positions must be numbers (m), got "
                                      f"{list(pos)!r}") from None
            if any(isinstance(v, bool) for v in pos) or not all(
                    math.isfinite(v) and v >= 0 for v in x):
                raise ChannelMapError(f"channels.positions must be finite and >= 0 m, got "
                                      f"{list(pos)!r}")
            if len(set(x)) != len(x):
                raise ChannelMapError(f"channels.positions: {next(v for v in x if x.count(v) > 1)}"
                                      " m is given twice")
            object.__setattr__(self, "positions", x)
        else:
            ids = _list(self.ids, "ids", len(st))
            if not all(isinstance(v, int | np.integer) and not isinstance(v, bool) and v > 0
                       for v in ids):
                raise ChannelMapError(f"channels.ids must be positive integer grid IDs, got "
                                      f"{list(ids)!r}")
            ids = tuple(int(v) for v in ids)
            if len(set(ids)) != len(ids):
                raise ChannelMapError(f"channels.ids: {next(v for v in ids if ids.count(v) > 1)}"
                                      " is given twice")
            object.__setattr__(self, "ids", ids)
        for key in ("base", "tank"):
            v = getattr(self, key)
            if v is not None and (not isinstance(v, str) or not v.strip()):
                raise ChannelMapError(f"channels.{key} must be a channel name, got {v!r}")
        if self.base is not None and self.base in st:
            raise ChannelMapError(f"channels.base {self.base!r} is also a station: the base "
                                  "is the shaker table, not a point of the beam")
        if self.base is not None and self.base == self.tank:
            raise ChannelMapError(f"channels.base and channels.tank are both {self.base!r}")

    # -- files ------------------------------------------------------------------------------
    @classmethod
    def from_dict(cls, data: Mapping[str, Any], where: str = "channels") -> ChannelMap:
        """From the ``[channels]`` table (keys ``stations``, ``positions`` or ``ids``,
        ``base``, ``tank``); unknown or missing keys are errors naming them."""
        if not isinstance(data, Mapping):
            raise ChannelMapError(f"{where}: [channels] must be a table")
        unknown = [k for k in data if k not in _KEYS]
        if unknown:
            raise ChannelMapError(f"{where}: unknown key(s) {', '.join(map(repr, unknown))} in "
                                  f"[channels] (known: {', '.join(_KEYS)})")
        if "stations" not in data:
            raise ChannelMapError(f"{where}: [channels] has no 'stations' (the channel names "
                                  "of the beam accelerometers)")
        try:
            return cls(**{k: (tuple(v) if isinstance(v, list) else v) for k, v in data.items()})
        except ChannelMapError as exc:
            raise ChannelMapError(f"{where}: {exc}") from None

    @classmethod
    def from_toml(cls, path: str | Path) -> ChannelMap:
        """Read the ``[channels]`` table of a TOML file (see the module docstring)."""
        try:
            table = load_toml_table(path, "channels", ChannelMapError)
        except ChannelMapError:
            raise
        except ConfigError as exc:
            raise ChannelMapError(str(exc)) from None
        return cls.from_dict(table, str(path))

    def to_toml(self) -> str:
        """The map as TOML text (``[channels]`` table) that :meth:`from_toml` reads back."""
        import tomli_w

        d: dict[str, Any] = {}
        for key in ("base", "tank"):
            if getattr(self, key) is not None:
                d[key] = getattr(self, key)
        d["stations"] = list(self.stations)
        if self.positions is not None:
            d["positions"] = list(self.positions)
        else:
            d["ids"] = list(self.ids or ())
        return tomli_w.dumps({"channels": d})

    def write_toml(self, path: str | Path, batch: OutputBatch | None = None) -> Path:
        """Write :meth:`to_toml` to ``path``, atomically or into ``batch``."""
        text = self.to_toml()

        def write(tmp: str) -> None:
            Path(tmp).write_text(text, encoding="utf-8")

        return (batch.write if batch is not None else atomic_write)(Path(path), write)

    # -- the tank ---------------------------------------------------------------------------
    def tank_channel(self, modal: ModalModel) -> str:
        """The channel of the tank acceleration: ``tank``, or the station at the tank (the
        beam's tip, or the first tank's grid ID); a :class:`ChannelMapError` if neither."""
        if self.tank is not None:
            return self.tank
        if self.positions is not None and modal.length is not None:
            at = [s for s, x in zip(self.stations, self.positions, strict=True)
                  if abs(x - modal.length) <= 1e-6 * max(modal.length, 1.0)]
            if at:
                return at[0]
            raise ChannelMapError(f"channels: no station at the tank (x = {modal.length:g} m) "
                                  "and no 'tank' channel: name the tank's channel")
        if self.ids is not None and modal.tank_ids is not None:
            if modal.tank_ids[0] in self.ids:
                return self.stations[self.ids.index(modal.tank_ids[0])]
            raise ChannelMapError(f"channels: no station at the tank (grid {modal.tank_ids[0]})"
                                  " and no 'tank' channel: name the tank's channel")
        raise ChannelMapError("channels: name the tank's channel ('tank'): the structure does "
                              "not say where its tank is")


def _list(value: Any, key: str, n: int) -> tuple:
    if isinstance(value, str) or not isinstance(value, Sequence):
        raise ChannelMapError(f"channels.{key} must be a list, got {value!r}")
    if len(value) != n:
        raise ChannelMapError(f"channels.{key} has {len(value)} value(s) for {n} station(s)")
    return tuple(value)


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
                   modal: ModalModel, *, fs: float | None = None,
                   units: Mapping[str, str] | None = None) -> dict[str, Any]:
    """A measured free decay (one file) as the analyses read a simulated one.

    Parameters
    ----------
    paths : path or sequence of one path
        UFF 58 (``.uff``/``.unv``), CSV, NetCDF or MATLAB file (:func:`sloshrom.io.read_record`).
    channels : ChannelMap
        Which channel is which accelerometer.
    modal : ModalModel
        The structure (it says where the tank is when the map does not name its channel).
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
                     modal: ModalModel, *, levels: Sequence[float] | None = None,
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


# -- the structure seen by the stations ----------------------------------------------------------
def station_model(modal: ModalModel, channels: ChannelMap,
                  beam: CantileverBeam | None = None) -> ModalModel:
    """``modal`` with the map's stations: mode shapes at its ``positions`` on ``beam`` (the
    built-in cantilever), or the rows of ``modal``'s output points with its ``ids`` (or, without
    a beam, its stations at ``positions``), in the map's order.

    Raises
    ------
    ChannelMapError
        Positions without a beam and not among ``modal``'s stations, IDs not among its output
        points, or positions for a structure that has only IDs (and the reverse).
    """
    if channels.positions is not None:
        x = np.asarray(channels.positions)
        if beam is not None:
            off = x[(x < 0) | (x > beam.length)]
            if off.size:
                raise ChannelMapError(f"channels.positions {off.tolist()} m lie off the beam "
                                      f"[0, {beam.length:g}] m")
            return dataclasses.replace(modal, stations=x,
                                       psi_stations=beam.mode_shapes(x, modal.n_modes),
                                       station_ids=None)
        rows = []
        for v in x:
            hit = np.flatnonzero(np.abs(modal.stations - v) <= 1e-6)
            if hit.size == 0:
                raise ChannelMapError(f"channels.positions: no station of the structure at "
                                      f"{v:g} m (its stations: {modal.stations.tolist()} m)")
            rows.append(int(hit[0]))
    else:
        ids = modal.station_ids
        if ids is None:
            raise ChannelMapError("channels.ids: the structure has no output point IDs; give "
                                  "'positions' (m)")
        missing = [i for i in channels.ids or () if i not in ids]
        if missing:
            raise ChannelMapError(f"channels.ids {missing} are not output points of the "
                                  f"structure (its IDs: {list(ids)[:20]})")
        rows = [ids.index(i) for i in channels.ids or ()]
    return dataclasses.replace(
        modal, stations=modal.stations[rows], psi_stations=modal.psi_stations[rows],
        station_ids=None if modal.station_ids is None else tuple(modal.station_ids[r]
                                                                 for r in rows))


# -- properties of the data ----------------------------------------------------------------------
def check_free_decay(res: Mapping[str, Any], f1: float) -> float:
    """Whether a free response decays: the envelope ratio (end / start) of mode 1.

    The tank acceleration relative to the base is band-passed around ``f1`` (0.5-1.5 f1, as
    the damping analyses); its RMS over periods 2-5 is the start, over the last 4 periods but
    one the end.

    Returns
    -------
    float
        End / start RMS (-).

    Raises
    ------
    AnalysisError
        Fewer than 12 periods of mode 1, or a ratio of :data:`DECAY_RATIO` or more (not a free
        decay: a forced or random run, or the wrong channel).
    """
    fs = float(res["fs"])
    x = np.asarray(res["tank_acceleration"]) - np.asarray(res["base_acceleration"])
    per = fs / f1
    if x.size < 12 * per:
        raise AnalysisError(f"the free decay holds {x.size / per:.1f} periods of mode 1 "
                            f"({f1:.4g} Hz): need at least 12")
    # the damping analyses' band: 4th-order Butterworth, zero phase, 0.5-1.5 f1
    sos = signal.butter(4, [0.5 * f1, 1.5 * f1], btype="bandpass", fs=fs, output="sos")
    y = signal.sosfiltfilt(sos, x)
    start = y[int(2 * per):int(5 * per)]
    end = y[int(x.size - 5 * per):int(x.size - per)]
    a, b = float(np.sqrt(np.mean(start**2))), float(np.sqrt(np.mean(end**2)))
    ratio = b / a if a > 0 else float("inf")
    if not ratio < DECAY_RATIO:
        raise AnalysisError(
            f"the tank acceleration does not decay: its mode-1 band ({f1:.4g} Hz) ends at "
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


# -- the virtual rig plays the laboratory --------------------------------------------------------
def lab_test_paths(path: str | Path, kind: str, levels: Sequence[float] | None = None
                   ) -> list[Path]:
    """The files :func:`write_lab_test` writes: ``path`` for a free decay; for a random test
    one per level, ``<stem>_<level>g<suffix>`` (``random_0.1g.uff``)."""
    p = Path(path)
    if kind == "free":
        return [p]
    if kind != "random" or levels is None:
        raise BeamError(f"kind={kind!r}: 'free', or 'random' with its levels")
    return [p.with_name(f"{p.stem}_{lv:g}g{p.suffix or '.uff'}") for lv in levels]


def write_lab_test(res: Mapping[str, Any], modal: ModalModel, path: str | Path, *, kind: str,
                   noise_rms: float = 0.0, seed: int = 0,
                   levels: Sequence[float] | None = None,
                   batch: OutputBatch | None = None) -> ChannelMap:
    """Write a simulated free or random response as a test lab hands it over.

    UFF 58 time responses (dataset 164, SI; ASCII, 12 significant digits): the station
    accelerations, labelled ``Acc 1``, ``Acc 2``, ... at the nodes of
    :mod:`sloshrom.beam.export` (station ID, else ``k + 1``), the base (``Base Z``, node 1000)
    for a random test, and the tank (``Tank Z``) when no station is at it; each with white
    sensor noise. One file per random level (:func:`lab_test_paths`).

    Parameters
    ----------
    res : mapping
        A free or random response (``sloshrom.beam.coupled``), seen through its reference tank
        (``sloshrom.beam.results.reference_tank``) if it has several.
    modal : ModalModel
        The structure it ran on (station positions or IDs).
    path : str or Path
        The ``.uff`` file (free), or the name the level files derive from (random).
    kind : str
        ``"free"`` or ``"random"``.
    noise_rms : float
        RMS of the white sensor noise, m/s^2 (0: none).
    seed : int
        Seed of the noise.
    levels : sequence of float, optional
        RMS levels (g) of a random response; default: ``res["rms_levels_g"]``.
    batch : OutputBatch, optional
        Write into this batch instead of atomically file by file.

    Returns
    -------
    ChannelMap
        The map that reads the files back (:meth:`ChannelMap.write_toml` writes it).
    """
    if kind not in ("free", "random"):
        raise BeamError(f"kind={kind!r}: expected 'free' or 'random'")
    if not (math.isfinite(noise_rms) and noise_rms >= 0):
        raise BeamError(f"noise_rms={noise_rms!r}: must be >= 0 m/s^2")
    random = kind == "random"
    lv = list(levels if levels is not None else res.get("rms_levels_g", [])) if random else []
    base = np.asarray(res["base_acceleration"], dtype=float)
    st = np.asarray(res["station_acceleration"], dtype=float)
    tank = np.asarray(res["tank_acceleration"], dtype=float)
    if tank.ndim > base.ndim:  # several tanks: the reference (first) tank
        tank = tank[..., 0]
    if random != (base.ndim == 2) or (random and len(lv) != base.shape[0]):
        raise BeamError(f"a {kind} response needs {'one level per row' if random else 'no '}"
                        f"level axis: base_acceleration has shape {base.shape}")
    labels = [f"Acc {k + 1}" for k in range(st.shape[-1])]
    nodes = list(modal.station_ids or range(1, st.shape[-1] + 1))
    if modal.station_ids is not None:
        cmap = ChannelMap(stations=tuple(labels), ids=tuple(modal.station_ids),
                          base="Base Z" if random else None)
    else:
        cmap = ChannelMap(stations=tuple(labels),
                          positions=tuple(float(f"{x:.12g}") for x in modal.stations),
                          base="Base Z" if random else None)
    try:
        cmap.tank_channel(modal)
        extra = []
    except ChannelMapError:  # no station at the tank: the tank has its own channel
        tid = modal.tank_ids[0] if modal.tank_ids else FIRST_TANK_NODE
        cmap = dataclasses.replace(cmap, tank="Tank Z")
        extra = [("Tank Z", "tank", tid, tank)]
    fs = float(res["fs"])
    t0 = float(np.asarray(res["time"])[0])
    rng = np.random.default_rng(seed)
    paths = lab_test_paths(path, kind, lv)
    for i, p in enumerate(paths):
        chans = [(lab, "beam", node, st[i, :, k] if random else st[:, k])
                 for k, (lab, node) in enumerate(zip(labels, nodes, strict=True))]
        chans += [(lab, ent, node, v[i] if random else v) for lab, ent, node, v in extra]
        if random:
            chans.insert(0, ("Base Z", "beam", BASE_NODE, base[i]))
        run = f"sloshrom virtual lab: {kind} test" + (f", {lv[i]:g} g RMS" if random else "")
        sets = [dataset164_si()]
        for j, (lab, ent, node, v) in enumerate(chans):
            noisy = v + noise_rms * rng.standard_normal(v.size) if noise_rms > 0 else v
            sets.append(dataset58(
                noisy, t0, 1.0 / fs, id1=lab, id2=run, id3=f"noise {noise_rms:g} m/s^2 RMS",
                id4=f"fs {fs:g} Hz", func_type=1, func_id=j + 1, load_case_id=i + 1 if random
                else 0, rsp=(ent, int(node), DIR_PLUS_Z), abscissa=(SPEC_TIME, "Time", "s"),
                ordinate=(SPEC_ACCELERATION, "Acceleration", "m/s^2")))
        write_uff_sets(sets, p, batch=batch)
    return cmap
