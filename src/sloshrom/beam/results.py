"""Results of the sloshing-beam tests: simulation of every case, first-mode damping summaries,
Table 1/Table 2 rows and the result files (NetCDF datasets, CSV/Markdown tables).

Shared by ``sloshrom beam`` and the ``beam`` stage of ``sloshrom reproduce``, so that both
analyse and write their results the same way.

A case whose model is a :class:`sloshrom.beam.members.Members` (an ensemble ROM) couples each
member alone: its result is the member-mean response with the members' results under
``"members"``, and every damping analysis here (:func:`mode1_decay`, :func:`damping_summary`,
:func:`damping_band_table`, :func:`mode1_damping_table`, :func:`mode1_damping_dataset`) gives
the mean of the members' estimates with their combined uncertainty
(``sloshrom.beam.members``).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any, cast

import numpy as np
import xarray as xr

from sloshrom import __version__
from sloshrom.beam.analysis import (
    AnalysisError,
    instantaneous_damping,
    log_decrement,
    modal_filter,
    noise_floor,
)
from sloshrom.beam.channels import ChannelMap
from sloshrom.beam.errors import BeamError
from sloshrom.beam.members import (
    Cell,
    Members,
    Row,
    combine_band_rows,
    combine_estimates,
    combine_table2_rows,
    mean_result,
)
from sloshrom.beam.registry import ESTIMATORS, TABLE2, estimator_names, label
from sloshrom.beam.structure import (
    TANK_KEYS,
    CantileverBeam,
    ModalModel,
    coupled_frozen_modes,
    frozen_modal_table,
)
from sloshrom.beam.uncertainty import (
    BANDS,
    FLOOR_FACTOR,
    RandomDamping,
    amplitude_bands,
    band_damping,
    estimate_random,
    table2_columns,
)
from sloshrom.config import G, Tank
from sloshrom.fileio import OutputBatch, atomic_write, netcdf_writer
from sloshrom.models import SloshingModel

if TYPE_CHECKING:  # the readers import this module's writers' neighbours
    from sloshrom.beam.measured import MeasuredTest

__all__ = [
    "BANDS", "Mode1Decay", "damping_band_table", "damping_by_band", "damping_summary",
    "decay_floor",
    "envelope_table",
    "frozen_modes_table",
    "modal_accelerations", "mode1_damping_dataset", "mode1_damping_table", "mode1_decay",
    "case_output_fs", "member_damping_tables", "missing_cells", "no_estimate", "table2_dataset",
    "BUILT_IN_STRUCTURE", "RESULT_FORMAT_VERSION",
    "reference_tank", "simulate_cases", "to_dataset", "write_dataset", "write_table",
]

#: A simulation of one case: ``simulate(model, output_fs)`` returns the result dict of
#: ``sloshrom.beam.coupled.free_response``/``random_response``; ``model`` is one sloshing
#: model or one per tank (a member of a :class:`~sloshrom.beam.members.Members` is either).
Simulate = Callable[[Any, float | None], dict[str, Any]]


# -- simulation ----------------------------------------------------------------------------------
def case_output_fs(model: SloshingModel | Sequence[SloshingModel], fs: float) -> float | None:
    """Rate of a case's results, Hz: ``fs``, or ``None`` (the model's own rate) if it is slower.

    A fast model (the rig at 10 kHz) is decimated to the sensors' rate ``fs``; a model running at
    ``fs`` or below keeps its own step. With one model per tank, the fastest decides.
    """
    if isinstance(model, Members):  # the members run at one step (one ROM)
        return case_output_fs(model.models[0], fs)
    models = model if isinstance(model, (list, tuple)) else [model]
    return fs if max(1.0 / m.dt for m in models) > fs else None


def simulate_cases(models: Mapping[str, Any], simulate: Simulate, fs: float,
                   on_case: Callable[[str], None] | None = None) -> dict[str, dict[str, Any]]:
    """Run ``simulate`` for every case, in order; results at :func:`case_output_fs`.

    Parameters
    ----------
    models : mapping
        Case name -> sloshing model, or a list of them (one per tank), or a
        :class:`~sloshrom.beam.members.Members`: each member simulated alone (one at a time,
        each as fast as a single model), the case's result their
        :func:`~sloshrom.beam.members.mean_result` (the members' results under
        ``"members"``).
    simulate : callable
        ``simulate(model, output_fs)`` -> result dict.
    fs : float
        Rate of the results (the beam's sensors), Hz.
    on_case : callable, optional
        Called with the case name before its simulation (progress reports).

    Returns
    -------
    dict
        Case name -> result dict.
    """
    results = {}
    for case, model in models.items():
        if on_case is not None:
            on_case(case)
        out_fs = case_output_fs(model, fs)
        if isinstance(model, Members):
            results[case] = mean_result([simulate(m, out_fs) for m in model.models])
        else:
            results[case] = simulate(model, out_fs)
    return results


# -- analysis ------------------------------------------------------------------------------------
def modal_accelerations(res: Mapping[str, Any], modal: ModalModel | np.ndarray) -> np.ndarray:
    """Modal accelerations (m/s^2, shape (n, n_modes)) by modal filtering of the virtual
    accelerometers relative to the base, as for measured data.

    ``modal``: the structure, or only its mode shapes at the stations (n_stations, n_modes),
    as a beam result file holds them (``psi_stations``)."""
    psi = modal.psi_stations if isinstance(modal, ModalModel) else modal
    return modal_filter(res["station_acceleration"] - res["base_acceleration"][..., None], psi)


@dataclass
class Mode1Decay:
    """The first-mode damping of a free response (paper Fig. 21).

    Attributes
    ----------
    modal : ndarray (n, n_modes)
        Modal accelerations, m/s^2 (:func:`modal_accelerations`).
    hilbert : dict
        ``sloshrom.beam.analysis.instantaneous_damping`` of mode 1 against the tank
        acceleration amplitude (``amplitude`` in m/s^2, ``zeta`` -).
    log_decrement : dict
        ``sloshrom.beam.analysis.log_decrement`` of mode 1, same reference.
    members : list of Mode1Decay
        For the mean response of an ensemble's members (a result with ``"members"``): each
        member's own analysis, in order (the damping tables average their estimates); empty
        otherwise.
    """

    modal: np.ndarray
    hilbert: dict[str, np.ndarray]
    log_decrement: dict[str, np.ndarray]
    members: list[Mode1Decay] = field(default_factory=list)


def mode1_decay(res: Mapping[str, Any], modal: ModalModel | np.ndarray | None,
                f1: float) -> Mode1Decay:
    """Modal filtering and first-mode damping (Hilbert and log decrement) of a free response.

    Parameters
    ----------
    res : mapping
        A free response (``sloshrom.beam.coupled.free_response``); with ``"members"``, each
        member is analysed as well (:attr:`Mode1Decay.members`).
    modal : ModalModel or ndarray (n_stations, n_modes) or None
        The beam's modal model, or its mode shapes at the stations; ``None``: the tank channel
        relative to the base (band-passed around ``f1`` by the analyses).
    f1 : float
        First mode with frozen liquid, Hz (the band-pass centre).

    Raises
    ------
    AnalysisError
        The stations cannot separate the modes, or the record is too short.
    """
    ref = res["tank_acceleration"]
    # without mode shapes, mode 1 is band-passed out of the tank channel (relative to the base)
    q = (modal_accelerations(res, modal) if modal is not None
         else (np.asarray(ref) - np.asarray(res["base_acceleration"]))[:, None])
    return Mode1Decay(
        modal=q,
        hilbert=instantaneous_damping(q[:, 0], res["fs"], f1, reference=ref),
        log_decrement=log_decrement(q[:, 0], res["fs"], f1, reference=ref),
        members=[mode1_decay(m, modal, f1) for m in res.get("members", ())],
    )


def damping_by_band(zeta: np.ndarray, amplitude_g: np.ndarray,
                    bands: Sequence[tuple[float, float]] = BANDS) -> dict[str, float]:
    """Median instantaneous damping ratio (-) in each amplitude band (default :data:`BANDS`,
    or e.g. ``uncertainty.amplitude_bands`` of the decay; amplitude and bands in g).

    NaN for a band with 10 samples or fewer. Keys: ``"0.5-1 g"``, ``"1-2 g"``, ...
    """
    out = {}
    for lo, hi in bands:
        sel = (amplitude_g >= lo) & (amplitude_g < hi)
        out[f"{lo:g}-{hi:g} g"] = float(np.median(zeta[sel])) if sel.sum() > 10 else float("nan")
    return out


def damping_summary(free: Mapping[str, Mapping[str, Any]],
                    decays: Mapping[str, Mode1Decay]) -> dict[str, dict[str, float]]:
    """Per case: the banded median first-mode damping (:func:`damping_by_band`) and
    ``initial_tank_acceleration_g``, the largest tank acceleration of the free response (g).

    An ensemble's case (a result with ``"members"``): each value the mean over the members
    that have one (NaN: none has)."""
    out: dict[str, dict[str, float]] = {}
    for case, r in free.items():
        members = r.get("members")
        if members:
            per = damping_summary({str(k): m for k, m in enumerate(members)},
                                  {str(k): d for k, d in enumerate(decays[case].members)})
            out[case] = {key: _nanmean([v[key] for v in per.values()])
                         for key in next(iter(per.values()))}
            continue
        h = decays[case].hilbert
        out[case] = damping_by_band(h["zeta"], h["amplitude"] / G)
        out[case]["initial_tank_acceleration_g"] = float(np.max(np.abs(r["tank_acceleration"]))
                                                         / G)
    return out


def _nanmean(values: Sequence[float]) -> float:
    # the mean of the finite values; NaN for none
    v = np.asarray(values, dtype=float)
    return float(np.mean(v[np.isfinite(v)])) if np.isfinite(v).any() else float("nan")


def decay_floor(res: Mapping[str, Any], f: float, rel_band: float = 0.35) -> float:
    """Noise floor of a free response's tank acceleration around the mode at ``f`` (Hz), m/s^2
    (``sloshrom.beam.analysis.noise_floor``, band ``f (1 -/+ rel_band)``); NaN for a record too
    short to tell."""
    try:
        return noise_floor(np.asarray(res["tank_acceleration"], dtype=float), res["fs"], f,
                           rel_band=rel_band)
    except AnalysisError:
        return float("nan")


def _case_bands(res: Mapping[str, Any], d: Mode1Decay, f1: float,
                bands: Sequence[tuple[float, float]] | str | None, seed: int
                ) -> list[Row]:
    # one response's rows: the bootstrap on its first modal acceleration, the samples below
    # the floor of its tank acceleration dropped
    if bands is None:  # a simulation keeps the paper's bands, a measurement gets its own
        bands = BANDS if "source" not in res else "auto"
    if isinstance(bands, str):
        if bands != "auto":
            raise BeamError(f"bands must be a sequence, 'auto' or None, got {bands!r}")
        bands = None
    floor = decay_floor(res, f1)
    return band_damping(d.hilbert, d.log_decrement, f1, bands=bands, record=d.modal[:, 0],
                        fs=res["fs"], floor=floor if np.isfinite(floor) else None, seed=seed)


def damping_band_table(free: Mapping[str, Mapping[str, Any]],
                       decays: Mapping[str, Mode1Decay], f1: float,
                       bands: Sequence[tuple[float, float]] | str | None = None,
                       seed: int = 0) -> list[Row]:
    """First-mode damping per amplitude band of every free response, with intervals.

    One row per case, band and method (``sloshrom.beam.uncertainty.band_damping``, its
    intervals from a noise-added bootstrap of the first modal acceleration, the samples below
    ``FLOOR_FACTOR`` times the tank acceleration's noise floor (:func:`decay_floor`) dropped):
    ``case``, ``band``, ``method`` (``hilbert`` or ``log_decrement``), ``zeta``, ``std``,
    ``low``, ``high`` (damping ratio, -; interval at 95 %), ``n_cycles`` (-) and ``reason``
    (``""`` when the value and its interval exist, else why not).

    ``bands`` (g): default ``None``, the paper's :data:`BANDS` for a simulation and the decay's
    own (``"auto"``: ``uncertainty.amplitude_bands`` above the floor) for a measured test (a
    result with ``source``); ``"auto"`` or a sequence for every case. ``seed``: the
    bootstrap's.

    An ensemble's case (its decay with :attr:`Mode1Decay.members`): the members' rows combined
    (``sloshrom.beam.members.combine_band_rows``: mean of the members' estimates, their
    spread and combined interval, with ``note``, ``spread`` and ``members`` columns).
    """
    rows: list[Row] = []
    for case in free:
        d = decays[case]
        if d.members:
            shared = bands
            if (isinstance(bands, str) and bands == "auto") or (bands is None
                                                              and "source" in free[case]):
                # one set of bands for every member (they are combined band by band): those of
                # the members' mean response
                floor = decay_floor(free[case], f1)
                shared = amplitude_bands(d.hilbert["amplitude"] / G,
                                         FLOOR_FACTOR * floor / G if np.isfinite(floor)
                                         else None)
            rows += combine_band_rows(case, [_case_bands(r, m, f1, shared, seed) for r, m in
                                             zip(free[case]["members"], d.members,
                                                 strict=True)])
        else:
            rows += [{"case": case, **row}
                     for row in _case_bands(free[case], d, f1, bands, seed)]
    return rows


def _random_damping(random: Mapping[str, Mapping[str, Any]], levels: Sequence[float], f1: float,
                    estimators: Sequence[str] | None) -> list[tuple[str, int, RandomDamping]]:
    # every case and level through the registry's estimators, each with its interval
    names = estimator_names(estimators)
    return [(case, i, estimate_random(r["base_acceleration"][i], r["tank_acceleration"][i],
                                      r["fs"], f1, estimators=names))
            for case, r in random.items() for i in range(len(levels))]


def member_damping_tables(random: Mapping[str, Mapping[str, Any]], levels: Sequence[float],
                          f1: float, max_tank_acceleration: bool = False,
                          estimators: Sequence[str] | None = None
                          ) -> dict[str, list[list[Row]]]:
    """Table 2 of each member of every ensemble case (a result with ``"members"``).

    Returns
    -------
    dict
        Case -> per member (in order) its rows of :func:`mode1_damping_table` (case
        ``member0``, ``member1``, ...), one per level. Give it to :func:`mode1_damping_table`
        (``member_rows``) so that the members are analysed once, for the ROM's row and for
        their own figures.
    """
    return {case: [mode1_damping_table({f"member{k}": m}, levels, f1, max_tank_acceleration,
                                       estimators)
                   for k, m in enumerate(r["members"])]
            for case, r in random.items() if r.get("members")}


def mode1_damping_table(random: Mapping[str, Mapping[str, Any]], levels: Sequence[float],
                        f1: float, max_tank_acceleration: bool = False,
                        estimators: Sequence[str] | None = None,
                        member_rows: Mapping[str, list[list[Row]]] | None = None
                        ) -> list[dict[str, Any]]:
    """Paper Table 2: first-mode damping of every random response, one row per case and level,
    each estimate with its standard deviation and interval.

    Columns ``case``, ``rms_g`` (g), ``max_tank_acceleration_g`` (g, only if
    ``max_tank_acceleration``), then those of ``sloshrom.beam.uncertainty.random_damping``
    (Table 2's flat columns, ``uncertainty.table2_columns``, a file contract: every
    estimator's value, with the bootstrapped ones corrected for their bias, the uncorrected
    values, and ``{est}_std``, ``{est}_low``, ``{est}_high``, ``{est}_reason``,
    ``{est}_note``). ``estimators``: registered names (default ``registry.TABLE2``). The same
    as a Dataset: :func:`mode1_damping_dataset`; :func:`table2_dataset` turns the rows of a
    case into one.

    An ensemble's case (a result with ``"members"``): each member's rows
    (:func:`member_damping_tables`, or ``member_rows[case]`` when given: the members are not
    analysed again) combined level by level (``sloshrom.beam.members.combine_table2_rows``):
    every column the mean over the members, every estimate the mean of the members'
    estimates with the combined standard deviation and interval, plus ``{est}_spread`` (-),
    ``{est}_members`` and ``n_members``. Rows of several cases may then hold different
    columns (:func:`write_table` writes their union).
    """
    member_rows = dict(member_rows or {})
    rows: list[Row] = []
    for case, r in random.items():
        if r.get("members"):
            per = member_rows.get(case) or member_damping_tables(
                {case: r}, levels, f1, max_tank_acceleration, estimators)[case]
            rows += [combine_table2_rows(case, [m[i] for m in per]) for i in range(len(levels))]
            continue
        for _, i, d in _random_damping({case: r}, levels, f1, estimators):
            row: Row = {"case": case, "rms_g": levels[i]}
            if max_tank_acceleration:
                row["max_tank_acceleration_g"] = float(
                    np.max(np.abs(r["tank_acceleration"][i])) / G)
            rows.append({**row, **table2_columns(d)})
    return rows


def mode1_damping_dataset(random: Mapping[str, Mapping[str, Any]], levels: Sequence[float],
                          f1: float, estimators: Sequence[str] | None = None) -> xr.Dataset:
    """Paper Table 2 as a Dataset: the estimates of :func:`mode1_damping_table` over ``case``,
    ``level`` (coordinate: RMS base acceleration, g) and ``estimator``.

    Returns
    -------
    xarray.Dataset
        The variables of ``sloshrom.beam.uncertainty.damping_dataset`` (``value``, ``std``,
        ``low``, ``high``, ``uncorrected``, ``iqr`` (-), ``frequency`` (Hz), ``n_poles``,
        ``reason``, ``note``) with dimensions ``(case, level, estimator)``; ``noise_input``,
        ``noise_output``, ``n_cycles`` (-) and ``duration_s`` (s) over ``(case, level)``. An
        ensemble's case: the mean of its members' estimates with their combined uncertainty
        (``sloshrom.beam.members``; the other variables the members' mean).
    """
    per: dict[tuple[str, int], xr.Dataset] = {}
    for case, r in random.items():
        if not r.get("members"):
            per.update({(case, i): d.to_dataset()
                        for _, i, d in _random_damping({case: r}, levels, f1, estimators)})
            continue
        members = [[d.to_dataset() for _, _, d in _random_damping({"m": m}, levels, f1,
                                                                  estimators)]
                   for m in r["members"]]
        per.update({(case, i): _combined_dataset([m[i] for m in members])
                    for i in range(len(levels))})
    cases = list(random)
    return xr.concat(
        [xr.concat([per[(c, i)] for i in range(len(levels))], dim="level")
         for c in cases], dim="case", coords="minimal", compat="override",
    ).assign_coords(case=cases, level=("level", [float(x) for x in levels], {"units": "g"}))


def _combined_dataset(dss: Sequence[xr.Dataset]) -> xr.Dataset:
    # the members' damping datasets of one level as the ensemble's: every estimate combined
    # (sloshrom.beam.members.combine_estimates), the other numbers the members' mean
    names = list(dss[0].estimator.values)
    out = xr.concat([d.drop_vars(["reason", "note"]) for d in dss], dim="member",
                    coords="minimal", compat="override").mean("member")
    def col(v: str, e: str) -> list[float]:
        return [float(d[v].sel(estimator=e)) for d in dss]

    combined = [combine_estimates(col("value", e), col("std", e), col("low", e), col("high", e),
                                  [str(d["reason"].sel(estimator=e).values) for d in dss],
                                  [str(d["note"].sel(estimator=e).values) for d in dss])
                for e in names]
    for v, k in (("value", "zeta"), ("std", "std"), ("low", "low"), ("high", "high")):
        out[v] = ("estimator", np.array([getattr(c, k) for c in combined]), dss[0][v].attrs)
    for v in ("reason", "note"):
        out[v] = ("estimator", np.array([getattr(c, v) for c in combined], dtype=object))
    out.attrs = dict(dss[0].attrs)
    return out


def table2_dataset(rows: Sequence[Mapping[str, Any]]) -> xr.Dataset:
    """The Table 2 rows of one case (:func:`mode1_damping_table`, or a table read back) as a
    Dataset over RMS level and estimator.

    Returns
    -------
    xarray.Dataset
        Dimensions ``level`` (coordinate: ``rms_g``, g) and ``estimator`` (coordinates: the
        names, ``registry.TABLE2`` first and then every other registered estimator that a row
        holds, and ``label``); variables ``value``, ``std``, ``low``, ``high`` (damping ratio,
        -; NaN where a row lacks the column), ``spread`` (-: the standard deviation over an
        ensemble's members, NaN for a single model), ``reason`` and ``note`` (str; ``""``
        where a row lacks the column, as rows written before these columns existed).
    """
    keys = set().union(*(r.keys() for r in rows)) if rows else set()
    names = [*TABLE2, *(n for n in ESTIMATORS if n not in TABLE2 and n in keys)]
    nan = float("nan")

    def column(suffix: str) -> np.ndarray:
        return np.array([[float(r.get(n + suffix, nan)) for n in names] for r in rows],
                        dtype=float).reshape(len(rows), len(names))

    def text(suffix: str) -> np.ndarray:
        return np.array([[str(r.get(n + suffix, "") or "") for n in names] for r in rows],
                        dtype=object).reshape(len(rows), len(names))

    dims = ("level", "estimator")
    return xr.Dataset(
        {"value": (dims, column(""), {"units": "1"}), "std": (dims, column("_std"), {"units": "1"}),
         "low": (dims, column("_low"), {"units": "1"}),
         "high": (dims, column("_high"), {"units": "1"}),
         "spread": (dims, column("_spread"), {"units": "1"}),
         "reason": (dims, text("_reason")), "note": (dims, text("_note"))},
        coords={"level": ("level", [float(r["rms_g"]) for r in rows], {"units": "g"}),
                "estimator": names, "label": ("estimator", [label(n) for n in names])})


def frozen_modes_table(tank: Tank | Sequence[Tank], modal: ModalModel,
                       beam: CantileverBeam | None = None) -> list[dict[str, float]]:
    """Paper Table 1: the beam's modes with frozen liquid, one row per mode of ``modal``.

    With the Euler-Bernoulli ``beam`` that ``modal`` was made from: the full table of
    ``sloshrom.beam.structure.frozen_modal_table`` (dry, frozen and coupled frequencies, Hz;
    damping; modal masses, kg). Without it (the user's own modal data): ``mode``, ``f_dry_Hz``,
    ``f_coupled_Hz`` (frozen liquid in the coupled model, every tank's) and ``damping`` only.
    """
    tanks = list(tank) if isinstance(tank, (list, tuple)) else [tank]
    if beam is not None and len(tanks) == 1:
        return frozen_modal_table(tanks[0], beam=beam, n_modes=modal.n_modes,
                                  damping=modal.damping.tolist())
    fc, _ = coupled_frozen_modes(modal, [t.liquid_mass for t in tanks])
    return [{"mode": n + 1, "f_dry_Hz": float(modal.frequencies[n]),
             "f_coupled_Hz": float(fc[n]), "damping": float(modal.damping[n])}
            for n in range(modal.n_modes)]


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
        A free or random response (``sloshrom.beam.coupled``); random responses have a leading
        ``level`` dimension (``rms_levels_g``, g RMS).
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
        <sloshrom.beam.coupled.CoupledSimulator.run>`), when the result holds it:
        variables ``envelope_outside_fraction`` and ``envelope_acceleration_ratio`` (-, one
        value per level; NaN for a model without an envelope) and the attribute
        ``training_peak_acceleration`` (m/s^2, NaN if unknown). A structure with several
        tanks (2-D ``psi_tank``) gives the tank signals and the coverage a trailing ``tank``
        dimension, its coordinate the tank IDs (or 1, 2, ...), and one attribute value per
        tank (one tank: the attribute ``tank_id``, if known); output point IDs become the
        coordinate ``station_id``. The variable ``psi_stations`` (station, mode; -) holds
        the mode shapes of the modal filtering.

        A measured test (``sloshrom.beam.measured``: a result with ``source``, the file
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
    tanks = list(tank) if isinstance(tank, (list, tuple)) else [tank] * modal.n_tanks
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
        first = tank[0] if isinstance(tank, (list, tuple)) else tank
        ds.attrs.update(tank=tank_given, given_tank_fill=first.fill,
                        given_liquid_mass=first.liquid_mass)
    if modal.station_ids is not None:
        ds.coords["station_id"] = ("station", np.asarray(modal.station_ids, dtype=np.int64))


def reference_tank(res: Mapping[str, Any], tank: int = 0) -> dict[str, Any]:
    """A result of several tanks seen through one of them: the per-tank signals (and their
    envelope coverage) of tank ``tank`` (0-based) only, as a one-tank result.

    The first-mode analyses and figures read ``tank_acceleration`` as the amplitude axis and
    the response; with several tanks they use the reference tank's. A one-tank result is
    returned unchanged; an ensemble's members (``"members"``) are seen through the same tank.
    """
    if np.ndim(res["tank_acceleration"]) == np.ndim(res["base_acceleration"]):
        return dict(res)
    out = dict(res)
    if res.get("members"):
        out["members"] = [reference_tank(m, tank) for m in res["members"]]
    for k in TANK_KEYS:
        out[k] = res[k][..., tank]
    for k in ("envelope_outside_fraction", "envelope_acceleration_ratio",
              "training_peak_acceleration"):
        if k in res:
            out[k] = np.asarray(res[k])[..., tank]
    return out


def envelope_table(results: Mapping[str, Mapping[str, Mapping[str, Any]]]
                   ) -> list[dict[str, Any]]:
    """How far each run goes beyond its model's training envelope: one row per test, case and
    level.

    Parameters
    ----------
    results : mapping
        Test name (``"free"``, ``"random"``) -> case -> result dict of
        :meth:`CoupledSimulator.run <sloshrom.beam.coupled.CoupledSimulator.run>` (with the
        ``envelope_*`` entries).

    Returns
    -------
    list of dict
        ``run`` (e.g. ``"free"``, ``"random 0.4 g"``), ``case``, ``peak_tank_acceleration_g``,
        ``training_peak_acceleration_g``, ``acceleration_ratio`` and ``outside_fraction``
        (-); the last three are ``None`` (n/a) for a model without an envelope or an envelope
        without ``acceleration_max``.
    """

    def value(x: Any) -> float | None:
        x = float(x)
        return x if np.isfinite(x) else None

    rows = []
    for test, cases in results.items():
        for case, r in cases.items():
            acc = np.asarray(r["tank_acceleration"])
            frac = np.asarray(r.get("envelope_outside_fraction", np.nan), dtype=float)
            ratio = np.asarray(r.get("envelope_acceleration_ratio", np.nan), dtype=float)
            train = value(r.get("training_peak_acceleration", np.nan))
            runs = ([(test, acc, frac, ratio)] if acc.ndim == 1 else
                    [(f"{test} {lv:g} g", acc[i], np.broadcast_to(frac, acc.shape[:1])[i],
                      np.broadcast_to(ratio, acc.shape[:1])[i])
                     for i, lv in enumerate(r["rms_levels_g"])])
            for run, a, f, q in runs:
                rows.append({"run": run, "case": case,
                             "peak_tank_acceleration_g": float(np.max(np.abs(a))) / G,
                             "training_peak_acceleration_g": None if train is None
                             else train / G,
                             "acceleration_ratio": value(q), "outside_fraction": value(f)})
    return rows


def write_dataset(ds: xr.Dataset, path: str | Path, batch: OutputBatch | None = None) -> Path:
    """Write ``ds`` as NetCDF-4 (h5netcdf), atomically or into ``batch``; return the path."""
    write = batch.write if batch is not None else atomic_write
    return write(path, netcdf_writer(ds))


def write_table(rows: Sequence[Mapping[str, Any]], path_stem: str | Path,
                batch: OutputBatch | None = None) -> tuple[Path, Path]:
    """Write ``rows`` (dicts) as ``<stem>.csv`` and ``<stem>.md``.

    The columns are the union of the rows' keys, in the order they first appear (an ensemble's
    rows add columns to Table 2); a row without a column has an empty cell. The CSV holds the
    values as Python prints them, unquoted (a comma in a text, e.g. a reason, is written as a
    semicolon, so that every line splits at its commas); the Markdown table rounds floats to
    four significant digits. Returns both paths.
    """
    keys = list(dict.fromkeys(k for r in rows for k in r))

    def cell(v: object) -> str:
        # a text (a reason) keeps the file one value per comma: its commas become semicolons
        return f"{v}".replace(",", ";").replace("\n", " ")

    def csv(tmp: str) -> None:
        with open(tmp, "w", encoding="utf-8") as fh:
            fh.write(",".join(keys) + "\n")
            for r in rows:
                fh.write(",".join(cell(r[k]) if k in r else "" for k in keys) + "\n")

    def md(tmp: str) -> None:
        def fmt(v: Any) -> str:
            return f"{v:.4g}" if isinstance(v, float) else str(v).replace("|", "/")

        with open(tmp, "w", encoding="utf-8") as fh:
            fh.write("| " + " | ".join(keys) + " |\n|" + "---|" * len(keys) + "\n")
            for r in rows:
                fh.write("| " + " | ".join(fmt(r[k]) if k in r else "" for k in keys)
                         + " |\n")

    write = batch.write if batch is not None else atomic_write
    stem = Path(path_stem)
    return write(stem.with_suffix(".csv"), csv), write(stem.with_suffix(".md"), md)


def missing_cells(rows: Sequence[Mapping[str, Cell]],
                  estimators: Sequence[str] | None = None) -> list[str]:
    """Every Table 2 or free-decay band cell without a value, with its reason, as text lines.

    Parameters
    ----------
    rows : sequence of mapping
        Rows of :func:`mode1_damping_table` (``case``, ``rms_g``, ``{est}``, ``{est}_reason``)
        or of :func:`damping_band_table` (``case``, ``band``, ``method``, ``zeta``,
        ``reason``).
    estimators : sequence of str, optional
        The Table 2 columns to check (default: every registered estimator a row holds).

    Returns
    -------
    list of str
        E.g. ``"rom 0.4 g, LSCF on H1: — (no stable pole cluster in ...)"``; a value that a
        fallback attempt or part of an ensemble's members gave is listed with its note. Empty
        when every cell has a value from the primary procedure.
    """
    out = []
    for r in rows:
        head, cells = _cells(r, estimators)
        for what, v, bounds, reason, note in cells:
            if not _finite(v):
                out.append(f"{head}, {what}: — ({reason or 'no estimate'})")
            elif any(b is not None for b in bounds) and not all(_finite(b) for b in bounds):
                why = reason or "no spread estimate"
                if not why.startswith("no interval"):
                    why = f"no interval ({why})"
                out.append(f"{head}, {what}: {100 * float(v):.3g} %, {why}")
            elif note:
                out.append(f"{head}, {what}: {100 * float(v):.3g} % ({note})")
    return out


def _finite(v: float | str | None) -> bool:
    try:
        return v is not None and bool(np.isfinite(float(v)))
    except (TypeError, ValueError):
        return False


_CellText = tuple[str, Cell | None, tuple[Cell | None, Cell | None], str, str]


def _cells(r: Mapping[str, Cell], estimators: Sequence[str] | None
           ) -> tuple[str, list[_CellText]]:
    """A damping table row's head text and its cells: (what, value, interval bounds, reason,
    note) each (:func:`missing_cells`)."""
    mode = f" mode {r['mode']}" if "mode" in r else ""
    if "band" in r:
        return f"{r.get('case', '')}{mode}", [
            (f"{r['band']}, {label(str(r['method']))}", r.get("zeta"),
             (r.get("low"), r.get("high")), str(r.get("reason", "")), str(r.get("note", "")))]
    names = estimators or [n for n in ESTIMATORS if n in r]
    return f"{r.get('case', '')}{mode} {float(r['rms_g']):g} g", [
        (label(n), r.get(n), (r.get(f"{n}_low"), r.get(f"{n}_high")),
         str(r.get(f"{n}_reason", "")), str(r.get(f"{n}_note", ""))) for n in names]


def no_estimate(rows: Sequence[Mapping[str, Cell]],
                estimators: Sequence[str] | None = None) -> str | None:
    """Why a damping table has no value at all: its first cell's reason as text (as
    :func:`missing_cells` gives it), or ``"no rows"``; ``None`` when a cell has a value.

    A table whose every cell is empty says nothing of the damping: its command refuses to
    write it, with this first cause."""
    first = None
    for r in rows:
        head, cells = _cells(r, estimators)
        for what, v, _, reason, _ in cells:
            if _finite(v):
                return None
            first = first or f"{head}, {what}: {reason or 'no estimate'}"
    return first or "no rows"
