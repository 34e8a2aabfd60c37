"""The damping tables of the beam tests: the first-mode decay of free responses, its damping
per amplitude band, and paper Table 2 of random responses, each estimate with its interval.

* :func:`mode1_decay`, :func:`damping_summary`, :func:`damping_band_table` - free responses:
  modal filtering, Hilbert and log-decrement damping, their medians and intervals per band.
* :func:`mode1_damping_dataset` - random responses: paper Table 2 over ``(case, level,
  estimator)`` by the estimators of ``sloshrom.beam.damping.registry`` (an ensemble's members:
  :func:`member_damping_datasets`); :func:`mode1_damping_table` - the same as its files' rows
  (``sloshrom.beam.damping.columns``, the one place that makes them).
* :func:`missing_cells`, :func:`no_estimate` - every cell without a value, with its reason.

A case whose result holds ``"members"`` (an ensemble ROM, each member coupled alone:
``sloshrom.beam.simulation.members``) gets the mean of the members' estimates with their
combined uncertainty. Result dicts in, datasets (and the free decays' rows) out; no files.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator, Mapping, Sequence
from concurrent.futures import Executor
from dataclasses import dataclass, field
from functools import partial
from typing import Any, cast

import numpy as np
import xarray as xr

from sloshrom.beam.damping.analysis import (
    AnalysisError,
    instantaneous_damping,
    log_decrement,
    modal_filter,
    noise_floor,
)
from sloshrom.beam.damping.columns import LEADING_COLUMNS, each_row, table2_rows
from sloshrom.beam.damping.registry import ESTIMATORS, estimator_names, label
from sloshrom.beam.damping.uncertainty import (
    BANDS,
    FLOOR_FACTOR,
    RandomDamping,
    amplitude_bands,
    band_damping,
    estimate_random,
)
from sloshrom.beam.errors import BeamError
from sloshrom.beam.simulation.members import Cell, Row, combine_band_rows, combine_estimates
from sloshrom.beam.simulation.structure import ModalModel
from sloshrom.config import G

__all__ = [
    "Mode1Decay", "damping_band_table", "damping_by_band", "damping_summary", "decay_floor",
    "member_damping_datasets", "missing_cells", "modal_accelerations", "mode1_damping_dataset",
    "mode1_damping_table", "mode1_decay", "no_estimate",
]


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
        ``sloshrom.beam.damping.analysis.instantaneous_damping`` of mode 1 against the tank
        acceleration amplitude (``amplitude`` in m/s^2, ``zeta`` -).
    log_decrement : dict
        ``sloshrom.beam.damping.analysis.log_decrement`` of mode 1, same reference.
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
        A free response (``sloshrom.beam.simulation.coupled.free_response``); with ``"members"``,
        each member is analysed as well (:attr:`Mode1Decay.members`).
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
    (``sloshrom.beam.damping.analysis.noise_floor``, band ``f (1 -/+ rel_band)``); NaN for a record
    too short to tell."""
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

    One row per case, band and method (``sloshrom.beam.damping.uncertainty.band_damping``, its
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
    (``sloshrom.beam.simulation.members.combine_band_rows``: mean of the members' estimates, their
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


def _estimates(r: Mapping[str, np.ndarray | float], levels: Sequence[float], f1: float,
               names: Sequence[str], pool: Executor | None
               ) -> list[Callable[[], RandomDamping]]:
    """Each level's :func:`estimate_random` of a random response, in order, as a call that
    returns it: started in ``pool`` at once (the caller starts every response's before it
    waits for one), else run when called."""
    base, tank = np.asarray(r["base_acceleration"]), np.asarray(r["tank_acceleration"])
    args = [(base[i], tank[i], float(r["fs"]), f1) for i in range(len(levels))]
    if pool is None:
        return [partial(estimate_random, *a, estimators=names) for a in args]
    return [pool.submit(estimate_random, *a, estimators=names).result for a in args]


def _case_dataset(r: Mapping[str, Any], levels: Sequence[float], f1: float,
                  estimators: Sequence[str] | None, max_tank_acceleration: bool,
                  pending: Sequence[Callable[[], RandomDamping]] | None = None) -> xr.Dataset:
    """One response's Table 2 over ``(level, estimator)``: every level through the registry's
    estimators, each with its interval (and its peak tank acceleration, g, if asked);
    ``pending``: the levels' estimates already started (:func:`_estimates`)."""
    names = estimator_names(estimators)
    per = []
    for i, estimate in enumerate(pending or _estimates(r, levels, f1, names, None)):
        d = estimate().to_dataset()
        if max_tank_acceleration:
            d["max_tank_acceleration_g"] = ((), float(
                np.max(np.abs(r["tank_acceleration"][i])) / G), {"units": "g"})
        per.append(d)
    return xr.concat(per, dim="level")


def member_damping_datasets(random: Mapping[str, Mapping[str, Any]], levels: Sequence[float],
                            f1: float, max_tank_acceleration: bool = False,
                            estimators: Sequence[str] | None = None, *,
                            pool: Executor | None = None) -> dict[str, list[xr.Dataset]]:
    """Table 2 of each member of every ensemble case (a result with ``"members"``).

    ``pool``: an executor (:class:`concurrent.futures.ProcessPoolExecutor`) that runs the
    levels' estimates, every member's at once; the same results as without it.

    Returns
    -------
    dict
        Case -> per member (in order) its Table 2 over ``(level, estimator)`` (the variables
        of :func:`mode1_damping_dataset`). Give it to :func:`mode1_damping_dataset`
        (``members``) so that the members are analysed once, for the ROM's row and for their
        own spread.
    """
    names = estimator_names(estimators)
    pending = {case: [_estimates(m, levels, f1, names, pool) for m in r["members"]]
               for case, r in random.items() if r.get("members")}
    return {case: [_case_dataset(m, levels, f1, names, max_tank_acceleration, p)
                   for m, p in zip(random[case]["members"], ps, strict=True)]
            for case, ps in pending.items()}


def mode1_damping_dataset(random: Mapping[str, Mapping[str, Any]], levels: Sequence[float],
                          f1: float, estimators: Sequence[str] | None = None, *,
                          max_tank_acceleration: bool = False,
                          members: Mapping[str, Sequence[xr.Dataset]] | None = None,
                          pool: Executor | None = None) -> xr.Dataset:
    """Paper Table 2: the first-mode damping of every random response over ``case``, ``level``
    (coordinate: RMS base acceleration, g) and ``estimator``, each estimate with its standard
    deviation and interval.

    Parameters
    ----------
    random : mapping
        Case -> random response (``base_acceleration``, ``tank_acceleration`` with a leading
        level axis, ``fs``); an ensemble's (``"members"``: each member coupled alone) gets the
        mean of its members' estimates.
    levels : sequence of float
        RMS base acceleration of each level, g.
    f1 : float
        First-mode frequency with frozen liquid, Hz.
    estimators : sequence of str, optional
        Registered names (default ``registry.TABLE2``).
    max_tank_acceleration : bool
        Add ``max_tank_acceleration_g``, the peak tank acceleration of each run, g.
    members : mapping, optional
        An ensemble case's members' tables (:func:`member_damping_datasets`): not analysed
        again.
    pool : concurrent.futures.Executor, optional
        Runs the estimates of every case and level, all started before the first is awaited
        (a :class:`~concurrent.futures.ProcessPoolExecutor`: one process a core); the same
        results as without it.

    Returns
    -------
    xarray.Dataset
        The variables of ``sloshrom.beam.damping.uncertainty.damping_dataset`` (``value``,
        ``std``, ``low``, ``high``, ``uncorrected``, ``iqr`` (-), ``frequency`` (Hz),
        ``n_poles``, ``reason``, ``note``) over ``(case, level, estimator)``; ``noise_input``,
        ``noise_output``, ``n_cycles`` (-), ``duration_s`` (s) and, if asked,
        ``max_tank_acceleration_g`` (g) over ``(case, level)``. An ensemble's case
        (``sloshrom.beam.simulation.members.combine_estimates``): every estimate the mean of
        its members' with their combined standard deviation and interval, the other numbers
        the members' mean; ``spread`` (-, the standard deviation over the members) and
        ``members`` (members with a value) over ``(case, level, estimator)`` and
        ``n_members`` over ``case`` (NaN for a single model's case). Its rows, as the files
        hold them: ``sloshrom.beam.damping.columns.table2_rows``.
    """
    members = dict(members or {})
    names = estimator_names(estimators)
    # every single model's levels started before any is awaited (with a pool)
    pending = {case: _estimates(r, levels, f1, names, pool)
               for case, r in random.items() if not r.get("members")}
    per = []
    for case, r in random.items():
        if not r.get("members"):
            per.append(_case_dataset(r, levels, f1, names, max_tank_acceleration,
                                     pending[case]))
            continue
        dss = members.get(case) or member_damping_datasets(
            {case: r}, levels, f1, max_tank_acceleration, names, pool=pool)[case]
        combined = xr.concat([_combined_dataset([m.isel(level=i) for m in dss])
                              for i in range(len(levels))], dim="level")
        per.append(combined.assign(n_members=((), len(dss))))
    cases = list(random)
    return xr.concat(per, dim="case", coords="minimal", compat="override").assign_coords(
        case=cases, level=("level", [float(x) for x in levels], {"units": "g"}))


def mode1_damping_table(random: Mapping[str, Mapping[str, Any]], levels: Sequence[float],
                        f1: float, max_tank_acceleration: bool = False,
                        estimators: Sequence[str] | None = None,
                        members: Mapping[str, Sequence[xr.Dataset]] | None = None
                        ) -> list[dict[str, Any]]:
    """Paper Table 2 as the rows of its files: :func:`mode1_damping_dataset` through
    ``sloshrom.beam.damping.columns.table2_rows`` (one row per case and level: ``case``,
    ``rms_g`` (g), ``max_tank_acceleration_g`` (g, only if ``max_tank_acceleration``), then
    Table 2's flat columns, ``columns.table2_columns``; an ensemble's rows add
    ``{est}_spread`` (-), ``{est}_members`` and ``n_members``, so that rows of several cases
    may hold different columns: :func:`~sloshrom.beam.results.write_table` writes their union).
    """
    return table2_rows(mode1_damping_dataset(random, levels, f1, estimators,
                                             max_tank_acceleration=max_tank_acceleration,
                                             members=members))


def _combined_dataset(dss: Sequence[xr.Dataset]) -> xr.Dataset:
    # the members' damping datasets of one level as the ensemble's: every estimate combined
    # (sloshrom.beam.simulation.members.combine_estimates), the other numbers the members' mean
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
    out["spread"] = ("estimator", np.array([c.spread for c in combined]), {"units": "1"})
    out["members"] = ("estimator", np.array([c.members for c in combined]))
    out.attrs = dict(dss[0].attrs)
    return out


def missing_cells(table: Sequence[Mapping[str, Cell]] | xr.Dataset,
                  estimators: Sequence[str] | None = None) -> list[str]:
    """Every damping table cell without a value, with its reason, as text lines.

    Parameters
    ----------
    table : xarray.Dataset or sequence of mapping
        A Table 2 dataset (:func:`mode1_damping_dataset`, or every mode's:
        ``sloshrom.beam.lab.every_mode.random_mode_dataset``), or the rows of
        :func:`damping_band_table` (``case``, ``band``, ``method``, ``zeta``, ``reason``).
    estimators : sequence of str, optional
        The estimators to check (default: every registered estimator the table holds, in the
        registry's order).

    Returns
    -------
    list of str
        E.g. ``"rom 0.4 g, LSCF on H1: — (no stable pole cluster in ...)"``; a value that a
        fallback attempt or part of an ensemble's members gave is listed with its note. Empty
        when every cell has a value from the primary procedure.
    """
    out = []
    for head, cells in _cells(table, estimators):
        for what, v, bounds, reason, note in cells:
            if not _finite(v):
                out.append(f"{head}, {what}: — ({reason or 'no estimate'})")
            elif any(b is not None for b in bounds) and not all(_finite(b) for b in bounds):
                why = reason or "no spread estimate"
                if not why.startswith("no interval"):
                    why = f"no interval ({why})"
                out.append(f"{head}, {what}: {100 * float(cast(float, v)):.3g} %, {why}")
            elif note:
                out.append(f"{head}, {what}: {100 * float(cast(float, v)):.3g} % ({note})")
    return out


def _finite(v: float | str | None) -> bool:
    try:
        return v is not None and bool(np.isfinite(float(v)))
    except (TypeError, ValueError):
        return False


_CellText = tuple[str, Cell | None, tuple[Cell | None, Cell | None], str, str]


def _cells(table: Sequence[Mapping[str, Cell]] | xr.Dataset, estimators: Sequence[str] | None
           ) -> Iterator[tuple[str, list[_CellText]]]:
    """A damping table's rows as their head text and cells: (what, value, interval bounds,
    reason, note) each (:func:`missing_cells`)."""
    if isinstance(table, xr.Dataset):
        names = list(estimators or [n for n in ESTIMATORS if n in table.estimator])
        for head, d in each_row(table):
            e = d.sel(estimator=names)
            yield _head(head), [
                (label(n), float(e["value"][k]), (float(e["low"][k]), float(e["high"][k])),
                 str(e["reason"].values[k]), str(e["note"].values[k]))
                for k, n in enumerate(names)]
        return
    for r in table:
        yield f"{r.get('case', '')}{_mode(r)}", [
            (f"{r['band']}, {label(str(r['method']))}", r.get("zeta"),
             (r.get("low"), r.get("high")), str(r.get("reason", "")), str(r.get("note", "")))]


def _mode(r: Mapping[str, Any]) -> str:
    return f" mode {r['mode']}" if "mode" in r else ""


def _head(r: Mapping[str, Any]) -> str:
    # a Table 2 row's head: "rom 0.4 g", "lab mode 2 0.1 g"
    return f"{r.get('case', '')}{_mode(r)} {float(r[LEADING_COLUMNS['level']]):g} g"


def no_estimate(table: Sequence[Mapping[str, Cell]] | xr.Dataset,
                estimators: Sequence[str] | None = None) -> str | None:
    """Why a damping table has no value at all: its first cell's reason as text (as
    :func:`missing_cells` gives it), or ``"no rows"``; ``None`` when a cell has a value.

    A table whose every cell is empty says nothing of the damping: its command refuses to
    write it, with this first cause."""
    first = None
    for head, cells in _cells(table, estimators):
        for what, v, _, reason, _ in cells:
            if _finite(v):
                return None
            first = first or f"{head}, {what}: {reason or 'no estimate'}"
    return first or "no rows"
