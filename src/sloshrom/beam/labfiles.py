"""The virtual rig plays the laboratory: a simulated beam test written as a test lab's files.

* :func:`write_lab_test` - a simulated free or random response as UFF 58 time histories with
  white sensor noise, one file per random level; it returns the channel map
  (:class:`~sloshrom.beam.channels.ChannelMap`) that reads them back
  (:mod:`sloshrom.beam.measured`).
* :func:`lab_test_paths` - the files it writes.

A bad argument is a :class:`~sloshrom.beam.errors.BeamError`.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from sloshrom.beam.channels import ChannelMap, ChannelMapError
from sloshrom.beam.errors import BeamError
from sloshrom.beam.export import BASE_NODE, FIRST_TANK_NODE
from sloshrom.beam.structure import ModalModel
from sloshrom.fileio import OutputBatch
from sloshrom.io.uff import (
    DIR_PLUS_Z,
    SPEC_ACCELERATION,
    SPEC_TIME,
    dataset58,
    dataset164_si,
    write_uff_sets,
)

__all__ = ["lab_test_paths", "write_lab_test"]


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
