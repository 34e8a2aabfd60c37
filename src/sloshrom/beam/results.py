"""The result files of the sloshing-beam tests: a run (simulated or measured) as a NetCDF
dataset, and the tables as CSV and Markdown.

* :func:`to_dataset`, :func:`write_dataset` - a free or random response as an xarray Dataset
  (the standard beam-result names, format :data:`RESULT_FORMAT_VERSION`) and its NetCDF file.
* :func:`write_table` - rows as ``<stem>.csv`` and ``<stem>.md``.

Shared by ``sloshrom beam``, ``sloshrom analyse`` and the ``beam`` stage of ``sloshrom
reproduce``, so that every result file is written the same way. File names, variables,
attributes and columns are contracts.
"""

from __future__ import annotations

import csv
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any, cast

import numpy as np
import xarray as xr

from sloshrom import __version__
from sloshrom.beam.errors import BeamError
from sloshrom.beam.lab.channels import ChannelMap
from sloshrom.beam.simulation.structure import ModalModel
from sloshrom.config import Tank
from sloshrom.fileio import OutputBatch, atomic_write, netcdf_writer

if TYPE_CHECKING:  # the readers import this module's writers' neighbours
    from sloshrom.beam.lab.measured import MeasuredTest

__all__ = ["BUILT_IN_STRUCTURE", "MEASURED_MODES_ONLY", "RESULT_FORMAT_VERSION",
           "markdown_cell", "to_dataset", "write_dataset", "write_table"]


# -- result files --------------------------------------------------------------------------------
#: Version of the beam result files :func:`to_dataset` writes (attribute ``format_version``):
#: 2 since a measured test's file holds only what was measured or given (files without the
#: attribute are version 1).
RESULT_FORMAT_VERSION = 2


#: What a measured test's ``structure`` attribute says on the built-in cantilever.
BUILT_IN_STRUCTURE = "built-in cantilever model (not measured)"


#: ... and without a structure (each mode band-passed out of the reference channel).
MEASURED_MODES_ONLY = "none: the measured modes alone (no mode shapes)"


def to_dataset(res: Mapping[str, Any], case: str, kind: str,
               tank: Tank | Sequence[Tank] | None, modal: ModalModel | None, seed: int = 0,
               f1: float | None = None, *,
               f1_from: str | None = None, structure_given: str | None = None,
               tank_given: str | None = None) -> xr.Dataset:
    """xarray Dataset of a coupled-simulation result (the standard beam-result names).

    Parameters
    ----------
    res : mapping
        A free or random response (``sloshrom.beam.simulation.coupled``); random responses have a
        leading ``level`` dimension (``rms_levels_g``, g RMS).
    case : str
        The sloshing model's case name (``frozen``, ``rig``, a ROM's name).
    kind : str
        ``"free"`` or ``"random"`` (the ``test`` attribute).
    tank : Tank or sequence of Tank or None
        The tank(s) (fill level and liquid mass go into the attributes).
    modal : ModalModel or None
        The structure's modal model (stations, modes, frequencies, damping; tank and output
        point IDs when it has them). ``None`` (with ``tank``) for a measured test of a
        structure known by its measured modes alone: stations numbered 1, 2, ..., no mode
        shapes (``structure`` = :data:`MEASURED_MODES_ONLY`).
    seed : int
        Seed of the run (attribute).
    f1 : float, optional
        The first-mode frequency the damping analyses band-pass around, Hz (attribute
        ``f1_Hz``), so that the file can be re-analysed alone.
    f1_from : str, optional
        Where ``f1`` comes from (attribute ``f1_from``), e.g. ``"--f1"``.
    structure_given, tank_given : str, optional
        A measured test only: what the user gave for the structure (``"--structure
        plate.pch"``) and the tank (``"--tank tank.toml"``). Without them the structure and
        tank are models the measurement does not confirm, and their values are not written.

    Returns
    -------
    xarray.Dataset
        Accelerations in m/s^2, forces in N, velocity in m/s, ``q`` in m; time in s. The
        coverage of the model's training envelope (:meth:`CoupledSimulator.run
        <sloshrom.beam.simulation.coupled.CoupledSimulator.run>`), when the result holds it:
        variables ``envelope_outside_fraction`` and ``envelope_acceleration_ratio`` (-, one
        value per level; NaN for a model without an envelope) and the attribute
        ``training_peak_acceleration`` (m/s^2, NaN if unknown). A structure with several
        tanks (2-D ``psi_tank``) gives the tank signals and the coverage a trailing ``tank``
        dimension, its coordinate the tank IDs (or 1, 2, ...), and one attribute value per
        tank (one tank: the attribute ``tank_id``, if known); output point IDs become the
        coordinate ``station_id``. The variable ``psi_stations`` (station, mode; -) holds
        the mode shapes of the modal filtering.

        A measured test (``sloshrom.beam.lab.measured``: a result with ``source``, the file
        names) has only the variables it holds (base, station and tank accelerations; no
        forces, no ``q``), one tank (the reference) and only what was measured or given: the
        attributes ``source``, ``channel_map`` (TOML text of the channels used),
        ``channel_units`` (their units as read), ``fs``, ``f1_Hz`` and ``f1_from``,
        ``structure`` (what gave the mode shapes ``psi_stations``: the user's structure or
        :data:`BUILT_IN_STRUCTURE`) and, only when the user gave them,
        ``given_modal_frequencies_Hz``, ``given_modal_damping``, ``given_structure_mass``
        (structure) and ``tank``, ``given_tank_fill``, ``given_liquid_mass`` (tank); no seed.
        The attribute ``origin`` is ``"measured"`` or ``"simulation"``; ``format_version``
        is :data:`RESULT_FORMAT_VERSION`.

        An ensemble's case (a result with ``"members"``, each member coupled alone): the
        variables hold the member-mean response, the attribute ``n_members`` the number of
        members.
    """
    measured = "source" in res
    if modal is None or tank is None:
        if not measured:
            raise BeamError("a simulation's result needs its tank and modal model")
        return _measured_only(cast("MeasuredTest", res), case, kind, f1, f1_from)
    multi = modal.psi_tank.ndim == 2 and (
        np.ndim(res["tank_acceleration"]) > np.ndim(res["base_acceleration"]))
    lead = res["base_acceleration"].shape[:-1]
    ldims = ("level",) if len(lead) == 1 else ()
    tdims = ldims + (("time", "tank") if multi else ("time",))
    tanks: list[Tank] = (list(tank) if isinstance(tank, (list, tuple))
                         else [cast("Tank", tank)] * modal.n_tanks)
    t = res["time"]
    # a measured test holds only its accelerations: the other signals where the result has them
    specs = {
        "base_acceleration": (ldims + ("time",), {"units": "m/s^2"}),
        "tank_acceleration": (tdims, {"units": "m/s^2",
                                      "long_name": "tank absolute acceleration"}),
        "interface_force": (tdims, {"units": "N",
                                    "long_name": "-(m_struct + m_l) acc + dynamic"}),
        "dynamic_force": (tdims, {"units": "N"}),
        "tank_velocity": (tdims, {"units": "m/s", "long_name": "tank absolute velocity"}),
        "station_acceleration": (ldims + ("time", "station"),
                                 {"units": "m/s^2", "long_name": "absolute"}),
        "modal_acceleration": (ldims + ("time", "mode"), {"units": "m/s^2"}),
        "q": (ldims + ("time", "mode"), {"units": "m"}),
    }
    data = {name: (dims, res[name], attrs) for name, (dims, attrs) in specs.items()
            if name in res}
    data["psi_stations"] = (("station", "mode"), modal.psi_stations,
                            {"units": "1",
                             "long_name": "mode shapes at the stations (modal filtering)"})
    if measured:
        data["psi_stations"][2]["from"] = structure_given or BUILT_IN_STRUCTURE
    ds = xr.Dataset(
        data,
        coords={"time": ("time", t, {"units": "s"}),
                "station": ("station", modal.stations, {"units": "m"}),
                "mode": ("mode", np.arange(1, modal.n_modes + 1))},
        attrs={"case": case, "test": kind, "fs": float(res["fs"]),
               "sloshrom_version": __version__, "format_version": RESULT_FORMAT_VERSION,
               "origin": "measured" if measured else "simulation"},
    )
    if f1 is not None:
        ds.attrs["f1_Hz"] = float(f1)
    if f1_from is not None:
        ds.attrs["f1_from"] = f1_from
    if res.get("members"):  # the member-mean response of an ensemble's members coupled alone
        ds.attrs["n_members"] = len(res["members"])
    if measured:
        _measured_attrs(ds, [str(x) for x in res["source"]], res.get("channel_map"),
                        res.get("channel_units"), tank, modal, structure_given, tank_given)
        if ldims:
            ds = ds.assign_coords(level=("level", res["rms_levels_g"], {"units": "g (RMS)"}))
        return ds
    ds.attrs.update(seed=int(seed), modal_frequencies_Hz=modal.frequencies,
                    modal_damping=modal.damping)
    if multi:
        ids = modal.tank_ids or tuple(range(1, modal.n_tanks + 1))
        ds = ds.assign_coords(tank=("tank", np.asarray(ids, dtype=np.int64)))
        ds.attrs.update(tank_fill=np.array([tk.fill for tk in tanks]),
                        liquid_mass=np.array([tk.liquid_mass for tk in tanks]),
                        structure_mass=modal.structure_masses)
    else:
        ds.attrs.update(tank_fill=tanks[0].fill, liquid_mass=tanks[0].liquid_mass,
                        structure_mass=float(modal.structure_masses[0]))
        if modal.tank_ids is not None:
            ds.attrs["tank_id"] = modal.tank_ids[0]
    if modal.station_ids is not None:
        ds = ds.assign_coords(station_id=("station", np.asarray(modal.station_ids,
                                                                dtype=np.int64)))
    if "envelope_outside_fraction" in res:
        edims = ldims + (("tank",) if multi else ())
        ds["envelope_outside_fraction"] = (edims, np.asarray(res["envelope_outside_fraction"]), {
            "units": "1", "long_name": "fraction of samples outside the ROM's training envelope "
                                       "(NaN: the model has none)"})
        ds["envelope_acceleration_ratio"] = (edims, np.asarray(
            res["envelope_acceleration_ratio"]), {
            "units": "1", "long_name": "peak tank acceleration / training peak acceleration "
                                       "(NaN: unknown)"})
        peak = np.asarray(res["training_peak_acceleration"], dtype=float)
        ds.attrs["training_peak_acceleration"] = peak if multi else float(peak)
    if ldims:
        ds = ds.assign_coords(level=("level", res["rms_levels_g"], {"units": "g (RMS)"}))
    return ds


def _measured_only(res: MeasuredTest, case: str, kind: str, f1: float | None,
                   f1_from: str | None) -> xr.Dataset:
    # a measured test without a structure: what the files held, and nothing of a model
    lead = ("level",) if np.ndim(res["base_acceleration"]) == 2 else ()
    acc = {"units": "m/s^2"}
    cmap = res.get("channel_map")
    # the map's positions (m) of the stations the files held, else their numbers
    stations: tuple = (("station", np.asarray(cmap.positions), {"units": "m"})
                       if cmap is not None and cmap.positions is not None else
                       ("station", np.arange(1, res["station_acceleration"].shape[-1] + 1)))
    ds = xr.Dataset(
        {"base_acceleration": (lead + ("time",), res["base_acceleration"], acc),
         "tank_acceleration": (lead + ("time",), res["tank_acceleration"],
                               {**acc, "long_name": "reference (tank) absolute acceleration"}),
         "station_acceleration": (lead + ("time", "station"), res["station_acceleration"],
                                  {**acc, "long_name": "absolute"})},
        coords={"time": ("time", res["time"], {"units": "s"}), "station": stations},
        attrs={"case": case, "test": kind, "fs": float(res["fs"]),
               "sloshrom_version": __version__, "format_version": RESULT_FORMAT_VERSION,
               "origin": "measured", "structure": MEASURED_MODES_ONLY,
               "source": "; ".join(str(x) for x in res["source"])})
    if f1 is not None:
        ds.attrs["f1_Hz"] = float(f1)
    if f1_from is not None:
        ds.attrs["f1_from"] = f1_from
    if cmap is not None:
        ds.attrs["channel_map"] = cmap.to_toml()
        if cmap.ids is not None:
            ds.coords["station_id"] = ("station", np.asarray(cmap.ids, dtype=np.int64))
    if res.get("channel_units"):
        ds.attrs["channel_units"] = res["channel_units"]
    if lead:
        ds = ds.assign_coords(level=("level", res["rms_levels_g"], {"units": "g (RMS)"}))
    return ds


def _measured_attrs(ds: xr.Dataset, sources: list[str], cmap: ChannelMap | None,
                    channel_units: str | None, tank: Tank | Sequence[Tank], modal: ModalModel,
                    structure_given: str | None, tank_given: str | None) -> None:
    """The attributes of a measured test: what was measured, read or given (in place)."""
    ds.attrs["source"] = "; ".join(sources)
    if cmap is not None:
        ds.attrs["channel_map"] = cmap.to_toml()
    if channel_units:
        ds.attrs["channel_units"] = channel_units
    ds.attrs["structure"] = structure_given or BUILT_IN_STRUCTURE
    if structure_given:
        ds.attrs.update(given_modal_frequencies_Hz=modal.frequencies,
                        given_modal_damping=modal.damping,
                        given_structure_mass=float(modal.structure_masses[0]))
        if modal.tank_ids is not None:
            ds.attrs["tank_id"] = modal.tank_ids[0]
    if tank_given:
        first = cast("Tank", tank[0] if isinstance(tank, (list, tuple)) else tank)
        ds.attrs.update(tank=tank_given, given_tank_fill=first.fill,
                        given_liquid_mass=first.liquid_mass)
    if modal.station_ids is not None:
        ds.coords["station_id"] = ("station", np.asarray(modal.station_ids, dtype=np.int64))


def write_dataset(ds: xr.Dataset, path: str | Path, batch: OutputBatch | None = None) -> Path:
    """Write ``ds`` as NetCDF-4 (h5netcdf), atomically or into ``batch``; return the path."""
    write = batch.write if batch is not None else atomic_write
    return write(path, netcdf_writer(ds))


def markdown_cell(text: object) -> str:
    """``text`` as one cell of a Markdown table: a ``|`` escaped (``\\|``, so that ``|H1|``
    stays ``|H1|`` on the page instead of splitting the cell), line breaks as spaces."""
    return " ".join(str(text).split()).replace("|", "\\|")


def write_table(rows: Sequence[Mapping[str, Any]], path_stem: str | Path,
                batch: OutputBatch | None = None) -> tuple[Path, Path]:
    """Write ``rows`` (dicts) as ``<stem>.csv`` and ``<stem>.md``.

    The columns are the union of the rows' keys, in the order they first appear (an ensemble's
    rows add columns to Table 2); a row without a column has an empty cell. The CSV holds the
    values as Python prints them, quoted where a text (a reason) holds a comma or a quote
    (RFC 4180, Python's ``csv`` module: every reader splits it right and the reason keeps its
    commas); line breaks in a text are written as spaces. The Markdown table rounds floats to
    four significant digits and escapes ``|`` (:func:`markdown_cell`). Returns both paths.
    """
    keys = list(dict.fromkeys(k for r in rows for k in r))

    def cell(v: object) -> str:
        return " ".join(f"{v}".splitlines())

    def csv_file(tmp: str) -> None:
        with open(tmp, "w", encoding="utf-8", newline="") as fh:
            out = csv.writer(fh, lineterminator="\n")
            out.writerow(keys)
            out.writerows([cell(r[k]) if k in r else "" for k in keys] for r in rows)

    def md(tmp: str) -> None:
        def fmt(v: Any) -> str:
            return f"{v:.4g}" if isinstance(v, float) else markdown_cell(v)

        with open(tmp, "w", encoding="utf-8") as fh:
            fh.write("| " + " | ".join(keys) + " |\n|" + "---|" * len(keys) + "\n")
            for r in rows:
                fh.write("| " + " | ".join(fmt(r[k]) if k in r else "" for k in keys)
                         + " |\n")

    write = batch.write if batch is not None else atomic_write
    stem = Path(path_stem)
    return write(stem.with_suffix(".csv"), csv_file), write(stem.with_suffix(".md"), md)

