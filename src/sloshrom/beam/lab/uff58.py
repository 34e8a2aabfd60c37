"""The beam's UFF 58 files, written and read in one place: the node numbering of a beam test's
channels, the writer of a run's results, and the readers' lookup of a laboratory's channel.

:func:`write_result_uff` writes one run (the xarray Dataset of
:func:`sloshrom.beam.results.to_dataset`) into one ``.uff`` file that Simcenter Testlab, m+p,
ME'scope, pyOMA or sdypy-EMA read as if it came from a test lab:

- dataset 164, SI (m, N, s);
- dataset 58, function type 1 (time response) for the base acceleration, every station
  acceleration, and per tank its acceleration, velocity, interface force and dynamic force;
- random runs only (``frf=True``): dataset 58, function type 4 (FRF, complex double) and 6
  (coherence) of every station acceleration against the base acceleration, H1 with Welch
  averaging (Hann, 50 % overlap, :func:`sloshrom.beam.damping.analysis.frf_h1`).

Node numbering (every channel +Z = vertical, up positive), shared by the writer of a simulated
lab test (:mod:`sloshrom.beam.lab.virtual`):

- the base (clamped root, the shaker table): node :data:`BASE_NODE` (1000; not 0, which UFF uses
  for "no reference");
- station ``k`` (0-based): its ``station_id`` coordinate if the dataset has one, else ``k + 1``;
- tank ``k``: its ``tank`` coordinate (integer point ID) in a multi-tank dataset, the
  ``tank_id`` attribute of a one-tank dataset, else :data:`FIRST_TANK_NODE` + ``k`` (1001 for
  the single tank). A tank at an output grid has its acceleration written once, as the
  station's.

:func:`check_result_nodes` applies these rules to a modal model before a run, so that a
structure whose numbering UFF cannot hold is refused before the work, not when the results are
written. See docs/formats.md, "Beam results as UFF58".

Reading (:mod:`sloshrom.beam.lab.measured`): a channel map names a UFF 58 channel by its label
(ID line 1) or by ``node:dir`` (``"1000:+Z"``); :func:`channel_variable` finds its record
variable in the ``uff_channels`` attribute :func:`sloshrom.io.uff.read_uff58` leaves
(:func:`uff_channels`), :func:`channel_labels` lists a file's channels for messages. The
generic dataset 58 reader and writer are :mod:`sloshrom.io.uff`'s.
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from sloshrom.beam.damping.analysis import frf_h1
from sloshrom.beam.errors import BeamError
from sloshrom.beam.simulation.structure import ModalDataError, ModalModel
from sloshrom.fileio import OutputBatch
from sloshrom.io.record import Record, RecordError
from sloshrom.io.uff import (
    DIR_PLUS_Z,
    SPEC_ACCELERATION,
    SPEC_EXCITATION_FORCE,
    SPEC_FREQUENCY,
    SPEC_GENERAL,
    SPEC_REACTION_FORCE,
    SPEC_TIME,
    SPEC_VELOCITY,
    dataset58,
    dataset164_si,
    node_dir,
    write_uff_sets,
)
from sloshrom.io.units import canonical_unit

__all__ = ["BASE_NODE", "FIRST_TANK_NODE", "ChannelIdentity", "channel_identity",
           "channel_labels", "channel_variable", "check_channel_identity",
           "check_result_nodes", "uff_channels", "write_result_uff"]

#: Node of the base (beam root on the shaker): the response node of the base acceleration and
#: the reference node of every FRF.
BASE_NODE = 1000
#: Node of tank ``k`` (0-based) when the dataset gives no tank IDs: ``FIRST_TANK_NODE + k``.
FIRST_TANK_NODE = 1001
# UFF node numbers are written in a 10-character integer field
_MAX_NODE = 2**31 - 1

# Time histories: variable, specific data type, axis label, SI unit. The dynamic force drives
# the structure (excitation force, 13); the interface force is what the load cells under the
# tank would measure (reaction force, 9).
_TIME_CHANNELS = (
    ("base_acceleration", SPEC_ACCELERATION, "Acceleration", "m/s^2"),
    ("station_acceleration", SPEC_ACCELERATION, "Acceleration", "m/s^2"),
    ("tank_acceleration", SPEC_ACCELERATION, "Acceleration", "m/s^2"),
    ("tank_velocity", SPEC_VELOCITY, "Velocity", "m/s"),
    ("interface_force", SPEC_REACTION_FORCE, "Force", "N"),
    ("dynamic_force", SPEC_EXCITATION_FORCE, "Force", "N"),
)
_TANK_VARIABLES = ("tank_acceleration", "tank_velocity", "interface_force", "dynamic_force")


@dataclass(frozen=True)
class _Channel:
    """One time history of the file (one level of a random run)."""

    label: str  # ID line 1 without the level
    variable: str
    entity: str  # response entity name ("beam", "tank")
    node: int
    spec: int
    axis: str
    unit: str
    values: np.ndarray  # (time,), SI


def write_result_uff(
    ds: xr.Dataset,
    path: str | Path,
    *,
    frf: bool = True,
    nperseg: int = 4096,
    binary: bool = False,
    batch: OutputBatch | None = None,
) -> Path:
    """Write a sloshing-beam result as one UFF file (dataset 164 + datasets 58).

    Parameters
    ----------
    ds : xarray.Dataset
        One run as :func:`sloshrom.beam.results.to_dataset` makes it: attribute ``test``
        (``"free"`` or ``"random"``) and ``fs`` (Hz); variables ``base_acceleration`` and
        ``station_acceleration`` (required), ``tank_acceleration``, ``tank_velocity``,
        ``interface_force``, ``dynamic_force`` (written if present, optionally with a trailing
        ``tank`` dimension whose coordinate holds integer point IDs); a random run has a leading
        ``level`` dimension (coordinate in g RMS). Every variable needs a ``units`` attribute of
        its dimension (converted to SI: m/s^2, m/s, N). An integer ``station_id`` coordinate
        (dimension ``station``) gives the station nodes.
    path : str or Path
        The ``.uff`` / ``.unv`` file; written to a temporary beside it, then renamed.
    frf : bool
        Random runs: add the FRF (function type 4) and coherence (type 6) of every station
        acceleration against the base acceleration, per level. A free response has no input, so
        a free run gets time histories only, whatever ``frf`` says.
    nperseg : int
        Welch segment length, samples (capped at the record length); the frequency resolution is
        ``fs / nperseg`` Hz (0.122 Hz at 500 Hz and 4096).
    binary : bool
        Binary (exact doubles) or ASCII (default; 12 significant digits) dataset-58 data.
    batch : OutputBatch, optional
        Write into this batch (the file appears when the batch commits) instead of atomically
        on its own.

    Returns
    -------
    Path
        ``path``.

    Raises
    ------
    BeamError
        ``test`` is neither ``"free"`` nor ``"random"``; a required variable is missing;
        dimensions that do not fit the test (a ``level`` dimension in a free run, none in a
        random one, unknown dimensions); a missing or wrong unit; node IDs that are not positive
        integers or that give two channels the same node, direction and data type; non-finite
        values; a time axis that disagrees with ``fs``; a base acceleration without power at some
        frequency (no H1).

    Notes
    -----
    Datasets, in order: 164; then per level (one block for a free run): the time histories
    (base, stations, then per tank acceleration, velocity, interface and dynamic force), the
    FRFs and the coherences of the stations. Random runs put the level in ID lines 1 and 3 and
    use ``load_case_id`` = level index + 1 (free runs: 0).
    """
    test = ds.attrs.get("test")
    if test not in ("free", "random"):
        raise BeamError(
            f"dataset attribute test={test!r}: expected 'free' or 'random' (a beam result of "
            "sloshrom.beam.results.to_dataset); cannot tell whether it has an input for FRFs"
        )
    for name in ("base_acceleration", "station_acceleration"):
        if name not in ds:
            raise BeamError(f"the dataset has no {name!r} variable (a beam result needs it)")
    nperseg = int(nperseg)
    if nperseg < 8:
        raise BeamError(f"nperseg={nperseg}: the Welch segments need at least 8 samples")
    random = test == "random"
    fs, t0 = _time_axis(ds)
    levels = _levels(ds, random)
    channels = _without_repeats(list(_channels(ds, random)))
    _check_nodes(channels)

    case = str(ds.attrs.get("case", ""))
    version = str(ds.attrs.get("sloshrom_version", ""))
    run = f"sloshrom{' ' + version if version else ''}: case {case}, {test} response"
    seed = ds.attrs.get("seed")
    sets = [dataset164_si()]
    func_id = 0
    for i, level in enumerate(levels):
        lvl = "" if level is None else f" {level:g} g RMS"
        load_case = 0 if level is None else i + 1
        id3 = f"level {level:g} g RMS (load case {load_case})" if level is not None else "free"
        for ch in channels:
            values = ch.values[i] if random else ch.values
            func_id += 1
            sets.append(dataset58(
                values, t0, 1.0 / fs, id1=f"{ch.label}{lvl}", id2=run, id3=id3,
                id4=f"fs {fs:g} Hz" + ("" if seed is None else f", seed {seed}"),
                id5=ch.variable, func_type=1, func_id=func_id, load_case_id=load_case,
                rsp=(ch.entity, ch.node, DIR_PLUS_Z),
                abscissa=(SPEC_TIME, "Time", "s"), ordinate=(ch.spec, ch.axis, ch.unit),
                binary=binary,
            ))
        if random and frf:
            head = {"id2": run, "id3": id3, "load_case_id": load_case, "binary": binary}
            frf_sets = _frf_sets(channels, i, fs, nperseg, lvl, head, func_id)
            func_id += len(frf_sets)
            sets += frf_sets
    return write_uff_sets(sets, path, batch=batch)


def _time_axis(ds: xr.Dataset) -> tuple[float, float]:
    """Sample rate (Hz) and first time (s) of a result, the time axis checked against ``fs``."""
    if "time" not in ds.coords:
        raise BeamError("the dataset has no 'time' coordinate")
    t = np.asarray(ds["time"].values, dtype=float)
    try:
        fs = float(ds.attrs["fs"])
    except (KeyError, TypeError, ValueError):
        raise BeamError(f"dataset attribute fs={ds.attrs.get('fs')!r}: expected the sample "
                        "rate in Hz") from None
    if not (np.isfinite(fs) and fs > 0) or t.size < 2 or not np.all(np.isfinite(t)):
        raise BeamError(f"fs = {fs} Hz and a time axis of {t.size} finite samples: need a "
                        "positive rate and at least 2 samples")
    # UFF stores start and step only: the samples must sit on that grid
    expected = t[0] + np.arange(t.size) / fs
    if np.max(np.abs(t - expected)) > 1e-6 / fs + 1e-9 * np.max(np.abs(t)):
        raise BeamError(f"the time axis is not uniform at fs = {fs:g} Hz (attribute fs)")
    return fs, float(t[0])


def _levels(ds: xr.Dataset, random: bool) -> list[float | None]:
    """The RMS levels (g) of a random run, ``[None]`` for a free run."""
    has = "level" in ds["base_acceleration"].dims if "base_acceleration" in ds else False
    if not random:
        if "level" in ds.dims:
            raise BeamError("test='free' but the dataset has a 'level' dimension (a random "
                            "run?)")
        return [None]
    if not has or "level" not in ds.coords:
        raise BeamError("test='random' but base_acceleration has no 'level' dimension with a "
                        "coordinate (RMS level, g)")
    return [float(v) for v in np.asarray(ds["level"].values, dtype=float)]


def _node_ids(ds: xr.Dataset, coord: str, dim: str, default: int) -> list[int]:
    """Node numbers along ``dim``: the integer coordinate ``coord`` if present, else ``default
    + index``."""
    n = ds.sizes[dim]
    if coord not in ds.coords:
        return [default + k for k in range(n)]
    da = ds[coord]
    if da.dims != (dim,):
        raise BeamError(f"coordinate {coord!r} has dimensions {da.dims}, expected ({dim!r},)")
    raw = np.asarray(da.values)
    ok = raw.dtype.kind in "iu" or (raw.dtype.kind == "f" and np.all(np.isfinite(raw))
                                    and np.all(raw == np.round(raw)))
    ids = raw.astype(np.int64) if ok else raw
    if not ok or np.any(ids < 1) or np.any(ids > _MAX_NODE):
        raise BeamError(f"coordinate {coord!r} = {raw.tolist()}: UFF node IDs must be integers "
                        f"in 1..{_MAX_NODE}")
    return [int(v) for v in ids]


def _si(ds: xr.Dataset, name: str, unit: str) -> tuple[xr.DataArray, str]:
    """Variable ``name`` converted to the SI ``unit`` (from its ``units`` attribute)."""
    da = ds[name]
    given = da.attrs.get("units")
    if not isinstance(given, str) or not given.strip():
        raise BeamError(f"variable {name!r} has no units attribute (expected {unit!r})")
    si, factor = canonical_unit(given)
    if si != unit:
        raise BeamError(f"variable {name!r} is in {given!r}, expected a unit of {unit!r}")
    return da * factor if factor != 1.0 else da, unit


def _channels(ds: xr.Dataset, random: bool) -> Iterator[_Channel]:
    """Every time history of the file, in file order, values in SI (``([level,] time)``)."""
    lead = ("level",) if random else ()
    for name, spec, axis, unit in _TIME_CHANNELS:
        if name not in ds:
            continue
        da, unit = _si(ds, name, unit)
        extra = {"station_acceleration": "station"}.get(name)
        if extra is None and name in _TANK_VARIABLES and "tank" in da.dims:
            extra = "tank"
        want = (*lead, "time", *((extra,) if extra else ()))
        if set(da.dims) != set(want):
            raise BeamError(f"variable {name!r} has dimensions {da.dims}, expected {want} for "
                            f"a {'random' if random else 'free'} run")
        values = np.asarray(da.transpose(*want).values, dtype=float)
        if not np.all(np.isfinite(values)):
            raise BeamError(f"variable {name!r} holds NaN or inf values: UFF cannot carry them")
        if extra is None:
            # one tank: its grid ID when the run knows it (a structure file), else 1001
            entity, node = ("beam", BASE_NODE) if name == "base_acceleration" else \
                ("tank", int(ds.attrs.get("tank_id", FIRST_TANK_NODE)))
            yield _Channel(name, name, entity, node, spec, axis, unit, values)
        elif extra == "station":
            x = np.asarray(ds["station"].values, dtype=float)
            for k, node in enumerate(_node_ids(ds, "station_id", "station", 1)):
                yield _Channel(f"{name} {x[k]:.6g} m", name, "beam", node, spec, axis, unit,
                               values[..., k])
        else:
            for k, node in enumerate(_node_ids(ds, "tank", "tank", FIRST_TANK_NODE)):
                yield _Channel(f"{name} tank {node}", name, "tank", node, spec, axis, unit,
                               values[..., k])


def _without_repeats(channels: list[_Channel]) -> list[_Channel]:
    """Drop a tank's acceleration where an output point at the tank's node already carries
    it (a tank placed at an output grid): the same signal, once, as the station's."""
    stations = {ch.node: ch.values for ch in channels if ch.variable == "station_acceleration"}
    out = []
    for ch in channels:
        same = stations.get(ch.node) if ch.variable == "tank_acceleration" else None
        if same is not None and np.allclose(ch.values, same, rtol=1e-9,
                                            atol=1e-12 * float(np.max(np.abs(same)))):
            continue
        out.append(ch)
    return out


def _check_nodes(channels: list[_Channel]) -> None:
    """Every time history must be its own degree of freedom (node, +Z, data type): a reader
    that keys channels by DOF would otherwise merge or drop two of them."""
    seen: dict[tuple[int, int], str] = {}
    for ch in channels:
        key = (ch.node, ch.spec)
        if key in seen:
            raise BeamError(f"channels {seen[key]!r} and {ch.label!r} are both at node "
                            f"{ch.node} +Z with data type {ch.spec}: give the stations and "
                            "tanks distinct IDs (and not the base node "
                            f"{BASE_NODE})")
        seen[key] = ch.label


def check_result_nodes(modal: ModalModel) -> None:
    """Refuse, before a run, a structure whose results :func:`write_result_uff` cannot number.

    The results of ``modal`` (:func:`sloshrom.beam.results.to_dataset`) give each output point
    its ``station_ids`` entry (else ``1, 2, ...``) and each tank its ``tank_ids`` entry (else
    :data:`FIRST_TANK_NODE` for one tank, ``1, 2, ...`` for several); every acceleration must
    be a degree of freedom of its own: no point at the base node :data:`BASE_NODE`, no tank at
    an output point unless it is the same point (the same mode shape row), node IDs in 1 to
    2^31 - 1.

    Raises
    ------
    ModalDataError
        The first clash, naming the node and what would share it.
    """
    stations = list(modal.station_ids or range(1, modal.stations.size + 1))
    tanks = list(modal.tank_ids or ([FIRST_TANK_NODE] if modal.n_tanks == 1
                                    else range(1, modal.n_tanks + 1)))
    for what, ids in (("output point", stations), ("tank", tanks)):
        for node in ids:
            if not 1 <= node <= _MAX_NODE:
                raise ModalDataError(f"{what} {node}: UFF node IDs must be in 1..{_MAX_NODE}")
            if node == BASE_NODE:
                raise ModalDataError(
                    f"{what} {node} is the node the UFF results give the base (the shaker "
                    f"table, node {BASE_NODE}): renumber it in the modal file, or leave out "
                    "--uff")
    row = {node: i for i, node in enumerate(stations)}
    for j, node in enumerate(tanks):
        i = row.get(node)
        if i is not None and not np.array_equal(modal.psi_stations[i], modal.psi_tanks[j]):
            raise ModalDataError(
                f"tank {j + 1} and output point {i + 1} would both be UFF node {node} with "
                "different accelerations: give the tanks and output points distinct IDs "
                "(tank_ids, station_ids)")


def _frf_sets(channels: list[_Channel], i: int, fs: float, nperseg: int, lvl: str,
              head: dict[str, Any], func_id: int) -> list[dict[str, Any]]:
    """FRF (type 4) and coherence (type 6) datasets of every station against the base, level
    ``i``; ``head`` holds the ID lines, load case and ``binary`` shared with the time
    histories, ``func_id`` the last function number used."""
    base = next(c for c in channels if c.variable == "base_acceleration").values[i]
    stations = [c for c in channels if c.variable == "station_acceleration"]
    # one call per station (not one batched call): the file then holds exactly what frf_h1
    # gives for that pair of signals. A base without power divides by zero: refused below
    with np.errstate(divide="ignore", invalid="ignore"):
        h, coh = (np.stack(a) for a in zip(*(frf_h1(base, c.values[i], fs, nperseg)[1:]
                                             for c in stations), strict=True))
    if not (np.all(np.isfinite(h)) and np.all(np.isfinite(coh))):
        raise BeamError(
            f"level{lvl or ' (free)'}: the base acceleration has no power at some frequency "
            "(zero or constant input?); the H1 FRF is not defined"
        )
    nseg = min(nperseg, base.size)
    df = fs / nseg  # the bins of frf_h1: k * fs / nseg, k = 0 .. nseg // 2
    averages = 1 + (base.size - nseg) // (nseg - nseg // 2)
    welch = (f"H1 = Sxy/Sxx, Welch Hann {nseg} samples ({df:.6g} Hz), 50 % overlap, "
             f"{averages} averages")
    sets = []
    for is_frf, values in ((True, h), (False, coh)):
        for ch, v in zip(stations, values, strict=True):
            func_id += 1
            sets.append(dataset58(
                v, 0.0, df,
                id1=f"{'H1' if is_frf else 'coherence'} {ch.label} / base_acceleration{lvl}",
                id4=welch, id5=f"{ch.variable} / base_acceleration",
                func_type=4 if is_frf else 6, func_id=func_id,
                rsp=(ch.entity, ch.node, DIR_PLUS_Z), ref=("beam", BASE_NODE, DIR_PLUS_Z),
                abscissa=(SPEC_FREQUENCY, "Frequency", "Hz"),
                ordinate=((SPEC_ACCELERATION, "Accelerance", "m/s^2") if is_frf
                          else (SPEC_GENERAL, "Coherence", "")),
                orddenom=((SPEC_ACCELERATION, "Acceleration", "m/s^2") if is_frf
                          else (0, "", "")),
                **head,
            ))
    return sets


# -- reading: a laboratory's channel by its label or node:dir ------------------------------------
def uff_channels(rec: Record, path: Path) -> list[dict[str, object]] | None:
    """The UFF 58 channels of a record read from ``path`` (label, node, direction, variable,
    where its unit came from: the ``uff_channels`` attribute of
    :func:`sloshrom.io.uff.read_uff58`); ``None`` for a file of another format."""
    # a NetCDF made from a UFF file keeps its uff_channels attribute: only UFF files use it
    return rec.attrs.get("uff_channels") if path.suffix.lower() in (".uff", ".unv") else None


def channel_variable(rec: Record, name: str, path: Path) -> str | None:
    """The record variable of the channel ``name`` (``None`` if the file lacks it): a UFF
    channel by its label (ID line 1), else by ``node:dir``; other formats by variable name
    (the label wins over node:dir)."""
    uff = uff_channels(rec, path)
    if uff:
        for ch in uff:
            if ch["label"] == name.strip():
                return str(ch["variable"])
        nd = node_dir(name)
        for ch in uff:
            if nd == (ch["node"], ch["direction"]):
                return str(ch["variable"])
        return None
    return name if name in rec.variables else None


def channel_labels(rec: Record, path: Path) -> list[str]:
    """A file's channels as a message lists them: a UFF channel as ``label (node:dir)``, any
    other as its variable name."""
    uff = uff_channels(rec, path)
    return ([f"{c['label']} ({c['node']}:{c['direction']})" for c in uff] if uff
            else list(rec.variables))


@dataclass(frozen=True)
class ChannelIdentity:
    """Which UFF 58 channel of one file a map's names found.

    Attributes
    ----------
    file : str
        The file's name.
    nodes : dict of str to str
        Every time-response channel of the file: label -> ``node:dir``.
    matched : dict of str to str
        The map's names the file holds -> the label of the channel each found.
    """

    file: str
    nodes: dict[str, str]
    matched: dict[str, str]


def channel_identity(rec: Record, path: Path, names: list[str] | tuple[str, ...]
                     ) -> ChannelIdentity | None:
    """The channels of a UFF 58 file that the map's ``names`` found (:class:`ChannelIdentity`);
    ``None`` for another format (a column or variable name is its only identity)."""
    uff = uff_channels(rec, path)
    if not uff:
        return None
    nodes = {str(c["label"]): f"{c['node']}:{c['direction']}" for c in uff}
    by_var = {str(c["variable"]): str(c["label"]) for c in uff}
    matched = {}
    for name in names:
        var = channel_variable(rec, name, path)
        if var is not None:
            matched[name] = by_var[var]
    return ChannelIdentity(path.name, nodes, matched)


def check_channel_identity(files: list[ChannelIdentity]) -> None:
    """Whether a map's ``node:dir`` names find the same channel (by label) in every file of a
    test or campaign: laboratories renumber nodes between set-ups, and a map by node numbers
    then reads another accelerometer in another file, or misses it.

    Raises
    ------
    RecordError
        A name that finds channels of different labels in two files, or a channel in one file
        that another file holds at another node; the message names both files and both nodes
        in one line and recommends naming the channels by their labels.
    """
    for i, b in enumerate(files):
        for a in files[:i]:
            for name, label in a.matched.items():
                other = b.matched.get(name)
                if node_dir(name) is None or other == label:
                    continue  # a label, or the same channel in both files
                if other is None and label not in b.nodes:
                    continue  # a sensor the other file does not have
                where = (f"is {other!r} in {b.file}" if other is not None
                         else f"finds no channel in {b.file}")
                moved = (f", where {label!r} is {b.nodes[label]}" if label in b.nodes
                         else "")
                raise RecordError(
                    f"the channel map's {name!r} is {label!r} in {a.file} but {where}{moved}: "
                    "the node numbers change between the files, so a map by node numbers fits "
                    f"one file only; name the channels by their labels ({label!r}, ...) in the "
                    "map")
