"""The virtual rig plays the laboratory: a simulated beam test written as a test lab's files.

* :func:`write_lab_test` - a simulated free or random response as UFF 58 time histories with
  white sensor noise, one file per random level; it returns the channel map
  (:class:`~sloshrom.beam.lab.channels.ChannelMap`) that reads them back
  (:mod:`sloshrom.beam.lab.measured`).
* :func:`lab_test_paths` - the files it writes.
* :func:`write_lab_campaign` - a campaign on a beam of known modes without tank
  (:class:`~sloshrom.beam.lab.synthetic.LabBeam`): a free decay and random tests at several
  levels, as UFF 58 with channels in g or m/s^2, their unit labels written or left empty (as
  some test-lab exports leave them).

A bad argument is a :class:`~sloshrom.beam.errors.BeamError`.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from sloshrom.beam.errors import BeamError
from sloshrom.beam.lab.channels import ChannelMap, ChannelMapError
from sloshrom.beam.lab.synthetic import LabBeam, free_decay, random_test
from sloshrom.beam.lab.uff58 import BASE_NODE, FIRST_TANK_NODE
from sloshrom.beam.simulation.structure import ModalModel
from sloshrom.config import G
from sloshrom.fileio import OutputBatch
from sloshrom.io.uff import (
    DIR_PLUS_Z,
    SPEC_ACCELERATION,
    SPEC_TIME,
    dataset58,
    dataset164_si,
    write_uff_sets,
)

__all__ = ["lab_test_paths", "station_units", "write_lab_campaign", "write_lab_test"]


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
    :mod:`sloshrom.beam.lab.uff58` (station ID, else ``k + 1``), the base (``Base Z``, node 1000)
    for a random test, and the tank (``Tank Z``) when no station is at it; each with white
    sensor noise. One file per random level (:func:`lab_test_paths`).

    Parameters
    ----------
    res : mapping
        A free or random response (``sloshrom.beam.simulation.coupled``), seen through its reference
        tank (``sloshrom.beam.simulation.cases.reference_tank``) if it has several.
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


def station_units(n_stations: int) -> list[str]:
    """The default units of :func:`write_lab_campaign`'s stations: alternately g and m/s^2 (the
    base is in g)."""
    return ["g" if k % 2 == 0 else "m/s^2" for k in range(n_stations)]


def write_lab_campaign(directory: str | Path, beam: LabBeam | None = None, *,
                       levels: Sequence[float] = (0.1, 0.2, 0.4), duration: float = 120.0,
                       decay_duration: float = 20.0, decay_peak_g: float = 8.5,
                       fs: float = 500.0, units: Sequence[str] | None = None,
                       decay_units: Sequence[str] | None = None,
                       decay_nodes: Sequence[int] | None = None,
                       unit_labels: bool = True, seed: int = 0,
                       batch: OutputBatch | None = None) -> ChannelMap:
    """A laboratory's campaign on ``beam`` as UFF 58 files: ``decay.uff`` (a free decay, no
    base channel) and ``random_<level>g.uff`` (random base excitation).

    Channels ``acc1``... at ``beam.positions`` (nodes 1, 2, ..., +Z, unless ``decay_nodes``)
    and ``base`` (node
    :data:`~sloshrom.beam.lab.uff58.BASE_NODE`) on the random runs; each station in its unit of
    ``units`` (default alternately g and m/s^2, the base in g).

    Parameters
    ----------
    directory : path
        Where the files go (created).
    beam : LabBeam, optional
        Default ``LabBeam()`` (10.3 / 64.1 / 180 Hz, 1.37 / 0.62 / 0.48 %).
    levels : sequence of float
        RMS base levels, g.
    duration, decay_duration : float
        Length of each random run and of the decay, s.
    decay_peak_g : float
        Peak tip acceleration of the decay, g.
    fs : float
        Sample rate, Hz.
    units : sequence of str, optional
        ``"g"`` or ``"m/s^2"`` per station.
    decay_units, decay_nodes : sequence, optional
        The decay's sensor set-up where it differs from the random runs' (a laboratory
        changes it between tests): units (as ``units``) and node numbers of its stations;
        default those of the random runs.
    unit_labels : bool
        Write the ordinate unit labels (``False``: empty labels and no units dataset 164, so
        that a reader needs the units from the user; :func:`station_units` gives them).
    seed : int
        Seed of the excitation and the sensor noise.

    Returns
    -------
    ChannelMap
        The map of the campaign (stations, positions, base).
    """
    beam = beam or LabBeam()
    n_st = len(beam.positions)
    u = list(units) if units is not None else station_units(n_st)
    if len(u) != n_st or any(x not in ("g", "m/s^2") for x in u):
        raise BeamError(f"units: 'g' or 'm/s^2' for each of the {n_st} stations, got {u}")
    du = list(decay_units) if decay_units is not None else u
    nodes = list(range(1, n_st + 1))
    dn = [int(v) for v in decay_nodes] if decay_nodes is not None else nodes
    if len(du) != n_st or any(x not in ("g", "m/s^2") for x in du):
        raise BeamError(f"decay_units: 'g' or 'm/s^2' for each of the {n_st} stations, got "
                        f"{du}")
    if len(dn) != n_st or len(set(dn)) != n_st or any(v <= 0 or v == BASE_NODE for v in dn):
        raise BeamError(f"decay_nodes: {n_st} distinct positive node numbers other than "
                        f"{BASE_NODE}, got {dn}")
    names = [f"acc{k + 1}" for k in range(n_st)]
    d = Path(directory)

    def write(path: Path, res: Mapping[str, np.ndarray], run: str, base: bool,
              u: list[str], nodes: list[int]) -> None:
        chans = [(n, node, res["stations"][:, k], unit)
                 for k, (n, unit, node) in enumerate(zip(names, u, nodes, strict=True))]
        if base:
            chans.insert(0, ("base", BASE_NODE, res["base"], "g"))
        sets = [dataset164_si()] if unit_labels else []
        for j, (name, node, v, unit) in enumerate(chans):
            sets.append(dataset58(
                v / G if unit == "g" else v, 0.0, 1.0 / fs, id1=name, id2=run, func_type=1,
                func_id=j + 1, rsp=("beam", int(node), DIR_PLUS_Z),
                abscissa=(SPEC_TIME, "Time", "s"),
                ordinate=(SPEC_ACCELERATION, "Acceleration", unit if unit_labels else "")))
        write_uff_sets(sets, path, batch=batch)

    for i, g in enumerate(levels):
        res = random_test(beam, g, duration, fs, seed=seed + i)
        write(d / f"random_{g:g}g.uff", res, f"random base excitation, {g:g} g RMS", True, u,
              nodes)
    write(d / "decay.uff", free_decay(beam, decay_peak_g, decay_duration, fs,
                                      seed=seed + len(levels)), "free decay", False, du, dn)
    return ChannelMap(stations=tuple(names), positions=tuple(beam.positions), base="base")
