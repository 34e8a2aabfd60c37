"""Measured against predicted: the first-mode damping of beam tests side by side, with intervals.

A beam result file (the NetCDF of ``sloshrom beam``, ``sloshrom analyse`` or the ``beam`` stage
of ``sloshrom reproduce``) holds the station, base and tank accelerations, the mode shapes at the
stations used for modal filtering (``psi_stations``) and the first-mode frequency the analyses
band-pass around (attribute ``f1_Hz``). :func:`test_from_dataset` turns one into the result dict
the analyses read, :func:`analyse_test` runs them (free decay: damping per amplitude band with
intervals; random test: paper Table 2 with intervals), and :func:`compare_rows` sets the
predictions beside the measurement with a verdict per level (or band) and estimator:

* ``inside`` / ``outside``: the prediction lies inside / outside the measurement's interval
  (``no interval`` when the measurement has none, ``n/a`` when an estimate is missing);
* ``z``: the difference in units of the standard deviation of the difference of two uncertain
  numbers, ``(zeta_p - zeta_m) / sqrt(std_m^2 + std_p^2)``; ``consistent`` when ``|z| <= z_c``
  (1.96 at 95 %). For an ensemble ROM ``std_p`` is its combined standard deviation (the
  members' estimation error and their spread, ``sloshrom.beam.simulation.members``);
* ``reason``: why a verdict is ``n/a`` or ``no interval``, or ``z`` is missing (the
  estimates' own reasons); ``""`` otherwise.

Pure functions: datasets and dicts in, rows out; no files are read or written here.
"""

from __future__ import annotations

import warnings
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import xarray as xr
from scipy import stats

from sloshrom.beam.damping.analysis import welch_psd
from sloshrom.beam.damping.columns import table2_rows
from sloshrom.beam.damping.tables import (
    Mode1Decay,
    damping_band_table,
    mode1_damping_dataset,
    mode1_decay,
)
from sloshrom.beam.damping.uncertainty import CONFIDENCE
from sloshrom.beam.errors import BeamError
from sloshrom.beam.results import MEASURED_MODES_ONLY
from sloshrom.beam.simulation.members import Row

__all__ = ["FS_TOLERANCE", "STRUCTURE_TOLERANCE", "AnalysedTest", "CaseNameError", "analyse_test",
           "analysed_test", "check_sample_rate", "check_structures", "compare_rows",
           "comparison_cases", "match_levels", "test_from_dataset"]
# the relative difference of RMS levels that still counts as the same level (a measured base
# RMS is never exactly the nominal one)
LEVEL_TOLERANCE = 0.1
#: The relative difference of a result's ``fs`` attribute from its time axis's rate (1 / the
#: mean step) that still counts as the same rate (that of ``sloshrom.io.Record``).
FS_TOLERANCE = 1e-3
#: The relative difference of first-mode frequencies (``f1_Hz``) of a prediction and the
#: measurement that still counts as the same structure. The frequency an analysis finds is
#: within 1 % (the 0.05 Hz lines of a random test's H1 peak search, the zero-padded
#: periodogram of a 2 s decay: 0.06 Hz, at 10 Hz); a prediction's may differ from the
#: measured by the liquid's share of the modal mass (the paper beam's f1 is 10.19 Hz with the
#: liquid frozen, 10.85 Hz without it: 6.5 %) and by a mode's drift with level (the peaks
#: of a test's levels count as one mode within 10 %, ``sloshrom.beam.damping.peaks.common_modes``).
#: Beyond 15 % the mode-1 analyses of the two filter different bands: another structure.
STRUCTURE_TOLERANCE = 0.15


class CaseNameError(BeamError):
    """Case names of a comparison that clash, or a rename of a case no input has (attribute
    ``rename``: the ``(old, new)`` at fault, else ``None``)."""

    def __init__(self, message: str, rename: tuple[str, str] | None = None) -> None:
        super().__init__(message)
        self.rename = rename


@dataclass
class AnalysedTest:
    """One beam test (measured or simulated) and its first-mode damping analyses.

    Attributes
    ----------
    case : str
        Its name (``measured``, ``rig``, ``rom``, ``frozen``, ...).
    kind : str
        ``"free"`` or ``"random"``.
    fs, f1 : float
        Sample rate and first-mode frequency of the analyses, Hz.
    rows : list of dict
        Free tests: ``tables.damping_band_table`` rows (band, method, zeta, std, low, high,
        ...); empty for a random test.
    decay : Mode1Decay or None
        Free tests: the mode-1 analysis (Fig. 21 curves).
    psd : tuple or None
        Random tests: ``(f (Hz), P (level, f) ((m/s^2)^2/Hz))`` Welch PSDs of the tank
        acceleration (Fig. 23).
    levels : list of float
        Random tests: RMS base acceleration per level, g.
    source : str
        Where the test came from (the dataset's ``source`` attribute, else its case).
    table2 : xarray.Dataset or None
        Random tests: paper Table 2 over ``level`` (coordinate: RMS base acceleration, g) and
        ``estimator`` (``tables.mode1_damping_dataset`` of this case: ``value``, ``std``,
        ``low``, ``high``, ``reason``, ...).
    """

    case: str
    kind: str
    fs: float
    f1: float
    rows: list[dict[str, Any]]
    decay: Mode1Decay | None = None
    psd: tuple[np.ndarray, np.ndarray] | None = None
    levels: list[float] = field(default_factory=list)
    source: str = ""
    table2: xr.Dataset | None = None

    @property
    def damping(self) -> xr.Dataset:
        """Random tests: the Table 2 estimates over ``level`` and ``estimator``
        (:attr:`table2`)."""
        if self.table2 is None:
            raise BeamError(f"{self.case!r}: a {self.kind} test has no Table 2")
        return self.table2

    def table_rows(self) -> list[Row]:
        """The test's damping table as its files hold it: the band rows of a free decay, the
        Table 2 rows of a random test (``sloshrom.beam.damping.columns.table2_rows``)."""
        return self.rows if self.table2 is None else table2_rows(self.table2)


def test_from_dataset(ds: xr.Dataset) -> tuple[dict[str, Any], np.ndarray | None]:
    """The result dict of a beam result dataset, and the station mode shapes of its analysis.

    Parameters
    ----------
    ds : xarray.Dataset
        A beam result (``sloshrom.beam.results.to_dataset``): attributes ``test``, ``fs``,
        ``f1_Hz``; variables ``station_acceleration``, ``tank_acceleration``,
        ``base_acceleration`` (m/s^2) and ``psi_stations`` (station, mode). With several tanks
        the first is the reference (as in ``sloshrom beam``).

    Returns
    -------
    res : dict
        ``time`` (s), ``fs`` (Hz), ``base_acceleration``, ``station_acceleration``,
        ``tank_acceleration`` (m/s^2; random tests with a leading level axis) and, for random
        tests, ``rms_levels_g`` (g).
    psi : ndarray (n_stations, n_modes) or None
        ``None`` for a measured test of a structure known by its measured modes alone (no
        ``psi_stations``: mode 1 is band-passed out of the tank channel).

    Raises
    ------
    BeamError
        The dataset is not a beam result of this version (a name it lacks), or a unit is not
        m/s^2.
    """
    kind = _check_dataset(ds)
    need = _NEED
    if "tank" in ds.dims:
        ds = ds.isel(tank=0)
    res: dict[str, Any] = {
        "time": np.asarray(ds["time"].values, float), "fs": float(ds.attrs["fs"]),
        **{v: np.asarray(ds[v].values, float) for v in need[:3]}}
    if kind == "random":
        res["rms_levels_g"] = [float(x) for x in ds["level"].values]
    psi = ds["psi_stations"].values if "psi_stations" in ds.variables else None
    return res, None if psi is None else np.asarray(psi, float)


_NEED = ("station_acceleration", "tank_acceleration", "base_acceleration", "psi_stations")


def _needs(ds: xr.Dataset) -> tuple[str, ...]:
    # a measured test without a structure has no mode shapes: nothing to filter with
    if ds.attrs.get("structure") == MEASURED_MODES_ONLY:
        return _NEED[:3]
    return _NEED


def _check_dataset(ds: xr.Dataset) -> str:
    """The kind of a beam result dataset (``"free"`` or ``"random"``), its names and units
    checked (every format version: only what every version holds is read)."""
    kind = ds.attrs.get("test")
    if kind not in ("free", "random"):
        raise BeamError(f"not a beam test result: attribute 'test' is {kind!r}, not 'free' or "
                        "'random'")
    missing = [v for v in _needs(ds) if v not in ds.variables]
    if "f1_Hz" not in ds.attrs or "fs" not in ds.attrs:
        missing += [a for a in ("f1_Hz", "fs") if a not in ds.attrs]
    if missing:
        raise BeamError(f"the beam result lacks {', '.join(missing)} (written by an older "
                        "sloshrom? run the test again with this version)")
    for v in _NEED[:3]:
        unit = ds[v].attrs.get("units")
        if unit != "m/s^2":
            raise BeamError(f"{v} is in {unit!r}, expected 'm/s^2'")
    if kind == "random" and "level" not in ds.dims:
        raise BeamError("a random-test result needs a 'level' dimension")
    if kind == "free" and "level" in ds["base_acceleration"].dims:
        raise BeamError(f"attribute 'test' says 'free', but the file holds a random test, not "
                        f"a free decay: its signals have a 'level' dimension "
                        f"({ds.sizes['level']} RMS base level(s))")
    return str(kind)


def comparison_cases(datasets: Sequence[xr.Dataset], sources: Sequence[str],
                     renames: Mapping[str, str] | None = None) -> list[str]:
    """The case names of a comparison's inputs, after every check that needs no analysis.

    Parameters
    ----------
    datasets : sequence of xarray.Dataset
        The measurement first, then the predictions (beam results, :func:`test_from_dataset`).
    sources : sequence of str
        Their names in messages (the file names).
    renames : mapping, optional
        ``{old: new}`` case names: ``old`` is the case of the first input (in order) that has
        it, ``new`` its name in the tables; every ``old`` is a name as given (``{"a": "b",
        "b": "a"}`` swaps two names).

    Returns
    -------
    list of str
        The case name of each input, in order (``case`` attribute, default ``"test"``, after
        ``renames``).

    Raises
    ------
    BeamError
        An input that is not a beam result (or lacks what the analyses read; the message
        starts with its source), a rename of a case no input has, case names that are not
        unique (both a :class:`CaseNameError`), kinds of test that differ, or a prediction of
        a random test at none of the measured RMS levels (within 10 %).
    """
    kinds = []
    for ds, src in zip(datasets, sources, strict=True):
        try:
            kinds.append(_check_dataset(ds))
        except BeamError as exc:
            raise BeamError(f"{src}: {exc}") from None
    given = [str(ds.attrs.get("case", "test")) for ds in datasets]
    names = list(given)
    for old, new in (renames or {}).items():  # all on the names as given: no chains
        if old not in given:
            raise CaseNameError(f"no input has the case {old!r} (their cases: "
                                f"{', '.join(map(repr, given))})", (old, new))
        names[given.index(old)] = new
    for i, n in enumerate(names):
        if n in names[:i]:
            j = names.index(n)
            raise CaseNameError(f"{sources[j]} and {sources[i]} both have the case name {n!r} "
                                "(the tables would mix them): rename one")
    for k, src in zip(kinds[1:], sources[1:], strict=True):
        if k != kinds[0]:
            raise BeamError(f"{src} is a {k} test, the measurement {sources[0]} a {kinds[0]} "
                            "test")
    if kinds[0] == "random":
        measured = [float(x) for x in datasets[0]["level"].values]
        for ds, src in zip(datasets[1:], sources[1:], strict=True):
            levels = [float(x) for x in ds["level"].values]
            if all(i is None for i in match_levels(measured, levels)):
                raise BeamError(
                    f"{src} has no RMS level within {100 * LEVEL_TOLERANCE:.0f} % of the "
                    f"measured ones: {', '.join(f'{x:.3g}' for x in levels)} g against "
                    f"{', '.join(f'{x:.3g}' for x in measured)} g")
    return names


def check_sample_rate(ds: xr.Dataset) -> None:
    """Whether a beam result's ``fs`` attribute (Hz, finite and positive) is the rate of its
    time axis (within :data:`FS_TOLERANCE`); a result without a time axis passes.

    Raises
    ------
    BeamError
        Both rates named.
    """
    if "time" not in ds.variables or ds["time"].size < 2:
        return
    t = np.asarray(ds["time"].values, dtype=float)
    fs, fs_time = float(ds.attrs["fs"]), (t.size - 1) / float(t[-1] - t[0])
    if not (np.isfinite(fs_time) and abs(fs - fs_time) <= FS_TOLERANCE * fs):
        raise BeamError(f"attribute 'fs' says {fs:g} Hz but the time axis is sampled at "
                        f"{fs_time:g} Hz ({t.size} samples over {float(t[-1] - t[0]):g} s): "
                        "one of them is wrong")


def check_structures(datasets: Sequence[xr.Dataset], sources: Sequence[str]) -> None:
    """Whether the predictions are of the measured structure: each first-mode frequency
    (attribute ``f1_Hz``, Hz) within :data:`STRUCTURE_TOLERANCE` of the measurement's (the
    first dataset).

    Raises
    ------
    BeamError
        A prediction of another structure (both frequencies named).
    """
    fm = float(datasets[0].attrs["f1_Hz"])
    for ds, src in zip(datasets[1:], sources[1:], strict=True):
        fp = float(ds.attrs["f1_Hz"])
        if abs(fp / fm - 1) > STRUCTURE_TOLERANCE:
            raise BeamError(
                f"{src} predicts a structure whose first mode is at {fp:.4g} Hz, the "
                f"measurement {sources[0]} has it at {fm:.4g} Hz ({100 * (fp / fm - 1):+.0f} "
                f"%, beyond the {100 * STRUCTURE_TOLERANCE:.0f} % of one structure): a "
                "prediction of another structure")


def analyse_test(ds: xr.Dataset, case: str | None = None,
                 bands: Sequence[tuple[float, float]] | None = None) -> AnalysedTest:
    """Run the first-mode damping analyses of a beam result dataset, with intervals.

    Free decays: modal filtering with the dataset's ``psi_stations``, Hilbert and log-decrement
    damping per amplitude band (``tables.damping_band_table``). Random tests: paper Table 2
    (``tables.mode1_damping_dataset``) and the Welch PSDs of the tank acceleration (8192
    samples, as Fig. 23).

    Parameters
    ----------
    ds : xarray.Dataset
        See :func:`test_from_dataset`.
    case : str, optional
        Name of the test in the tables; default the dataset's ``case`` attribute.
    bands : sequence of (float, float), optional
        Free decays: the amplitude bands, g (a prediction in the measurement's bands); default
        the decay's own bands for a measurement, the paper's for a simulation.
    """
    res, psi = test_from_dataset(ds)
    name = str(case or ds.attrs.get("case", "test"))
    if ds.attrs.get("n_members"):
        # the file holds the members' mean response only: its estimates are not the mean of
        # the members' estimates (the ROM's values of the run that wrote it)
        warnings.warn(f"{name}: the result of an ensemble's {int(ds.attrs['n_members'])} "
                      "members is their mean response; analysed again it gives the estimates "
                      "of that mean, not the mean of the members' estimates of the run's "
                      "Table 2 (docs/beam.md)", UserWarning, stacklevel=2)
    f1, kind = float(ds.attrs["f1_Hz"]), str(ds.attrs["test"])
    if kind == "free":
        decay = mode1_decay(res, psi, f1)
        if bands is None and ds.attrs.get("origin") == "measured":
            # a measurement in the bands of its own amplitude range, as `analyse` gave them
            res["source"] = [str(ds.attrs.get("source", name))]
        table: list[Row] | xr.Dataset = damping_band_table(
            {name: res}, {name: decay}, f1, bands=bands)
    else:
        decay = None
        table = mode1_damping_dataset({name: res}, res["rms_levels_g"], f1).sel(case=name)
    return analysed_test(name, kind, res, f1, table, decay,
                         source=str(ds.attrs.get("source", name)))


def analysed_test(case: str, kind: str, res: Mapping[str, Any], f1: float,
                  table: list[dict[str, Any]] | xr.Dataset, decay: Mode1Decay | None = None,
                  source: str = "") -> AnalysedTest:
    """An :class:`AnalysedTest` from analyses already made: ``table`` is this case's rows of
    ``tables.damping_band_table`` (a free test, with ``decay``, its ``tables.mode1_decay``)
    or its Table 2 over ``(level, estimator)`` (a random test: its case of
    ``tables.mode1_damping_dataset``); random tests get their Welch PSDs here."""
    if kind == "free":
        if decay is None:
            raise BeamError("a free test needs its mode-1 decay analysis")
        if isinstance(table, xr.Dataset):
            raise BeamError("a free test's damping is its band rows, not a Table 2")
        return AnalysedTest(case, kind, float(res["fs"]), f1, table, decay=decay,
                            source=source or case)
    if not isinstance(table, xr.Dataset):
        raise BeamError("a random test's damping is its Table 2 over (level, estimator)")
    return AnalysedTest(case, kind, float(res["fs"]), f1, [],
                        psd=welch_psd(res["tank_acceleration"], res["fs"], nperseg=8192),
                        levels=[float(x) for x in res["rms_levels_g"]], source=source or case,
                        table2=table)


def match_levels(measured: Sequence[float], predicted: Sequence[float],
                 tolerance: float = LEVEL_TOLERANCE) -> list[int | None]:
    """For each measured RMS level (g), the index of the predicted level within ``tolerance``
    (relative) of it, the nearest one; ``None`` when there is none."""
    out: list[int | None] = []
    p = np.asarray(predicted, float)
    for lv in measured:
        if p.size == 0:
            out.append(None)
            continue
        i = int(np.argmin(np.abs(p - lv)))
        out.append(i if abs(p[i] - lv) <= tolerance * lv else None)
    return out


def _verdict(zm: float, lo: float, hi: float, sm: float, zp: float, sp: float,
             z_crit: float, why_m: str = "", why_p: str = "") -> dict[str, Any]:
    missing = [f"{who}: {why or 'no estimate'}" for who, v, why in
               (("measured", zm, why_m), ("predicted", zp, why_p)) if not np.isfinite(v)]
    if missing:
        return {"verdict": "n/a", "z": float("nan"), "consistent": "n/a",
                "reason": "; ".join(missing)}
    no_interval = not (np.isfinite(lo) and np.isfinite(hi))
    verdict = "no interval" if no_interval else "inside" if lo <= zp <= hi else "outside"
    # the verdict already says "no interval": the reason says why, once
    reason = (f"measured: {why_m.removeprefix('no interval: ') or 'no spread estimate'}"
              if no_interval else "")
    var = sum(s**2 for s in (sm, sp) if np.isfinite(s))
    if var == 0:  # neither estimate states its uncertainty
        return {"verdict": verdict, "z": float("nan"), "consistent": "n/a",
                "reason": reason or "neither estimate states its standard deviation"}
    z = float((zp - zm) / np.sqrt(var))
    return {"verdict": verdict, "z": z, "consistent": "yes" if abs(z) <= z_crit else "no",
            "reason": reason}


def compare_rows(measured: AnalysedTest, predicted: Sequence[AnalysedTest],
                 confidence: float = CONFIDENCE) -> list[dict[str, Any]]:
    """The measurement beside each prediction, one row per level (or band), estimator and case.

    Parameters
    ----------
    measured : AnalysedTest
        The reference (a laboratory test, or the virtual rig playing one).
    predicted : sequence of AnalysedTest
        Simulations of the same test (same kind; random tests at the same RMS levels within
        10 %).
    confidence : float
        Level of the intervals (their ``low``/``high`` columns are at this level).

    Returns
    -------
    list of dict
        Random tests: ``rms_g``, ``estimator``, ``measured``, ``measured_low``,
        ``measured_high``, ``case``, ``predicted``, ``predicted_low``, ``predicted_high``,
        ``difference`` (relative, -), ``verdict`` (inside/outside the measured interval),
        ``z``, ``consistent`` and ``reason`` (see the module docstring). Free decays: ``band`` and
        ``method`` instead of ``rms_g`` and ``estimator``. Damping ratios are in -.

    Raises
    ------
    BeamError
        A prediction of another kind of test, or at levels the measurement does not have.
    """
    z_crit = float(stats.norm.ppf(0.5 + confidence / 2))
    rows: list[dict[str, Any]] = []
    for p in predicted:
        if p.kind != measured.kind:
            raise BeamError(f"{p.case!r} is a {p.kind} test, the measurement "
                            f"{measured.case!r} a {measured.kind} test")
    if measured.kind == "random":
        for p in predicted:
            idx = match_levels(measured.levels, p.levels)
            if all(i is None for i in idx):
                raise BeamError(
                    f"{p.case!r} has no RMS level within {100 * LEVEL_TOLERANCE:.0f} % of the "
                    f"measured ones: {', '.join(f'{x:.3g}' for x in p.levels)} g against "
                    f"{', '.join(f'{x:.3g}' for x in measured.levels)} g")
        dm = measured.damping
        dp = {p.case: p.damping for p in predicted}
        for k, rms_g in enumerate(dm.level.values):
            for est in dm.estimator.values:
                for p in predicted:
                    i = match_levels([measured.levels[k]], p.levels)[0]
                    if i is None:
                        continue
                    pe = dp[p.case]
                    if est not in pe.estimator:  # a prediction without this estimator
                        continue
                    rows.append(_row({"rms_g": float(rms_g), "estimator": str(est)},
                                     _stats(dm, k, est), p.case, _stats(pe, i, est),
                                     z_crit))
        return rows
    for m in measured.rows:
        for p in predicted:
            q = next((r for r in p.rows if r["band"] == m["band"]
                      and r["method"] == m["method"]), None)
            if q is not None:
                rows.append(_row({"band": m["band"], "method": m["method"]}, m, p.case, q,
                                 z_crit))
    return rows


def _stats(ds: xr.Dataset, level: int, est: str) -> dict[str, float | str]:
    # one estimate of a Table 2 dataset with the names of a band row
    e = ds.isel(level=level).sel(estimator=est)
    out: dict[str, float | str] = {"zeta": float(e["value"]), "std": float(e["std"]),
                           "low": float(e["low"]), "high": float(e["high"])}
    if "reason" in e:
        out["reason"] = str(e["reason"].values)
    return out


def _row(head: dict[str, Any], m: Mapping[str, Any], case: str, p: Mapping[str, Any],
         z_crit: float) -> dict[str, Any]:
    def g(r: Mapping[str, Any], key: str) -> float:
        # band rows and the estimates of a Table 2 dataset (_stats) name them zeta/std/low/high
        return float(r.get(key, np.nan))

    zm, zp = g(m, "zeta"), g(p, "zeta")
    diff = zp / zm - 1 if np.isfinite(zm) and zm != 0 and np.isfinite(zp) else float("nan")
    return {**head, "measured": zm, "measured_low": g(m, "low"),
            "measured_high": g(m, "high"), "case": case, "predicted": zp,
            "predicted_low": g(p, "low"), "predicted_high": g(p, "high"),
            "difference": diff,
            **_verdict(zm, g(m, "low"), g(m, "high"), g(m, "std"), zp, g(p, "std"),
                       z_crit, str(m.get("reason", "") or ""), str(p.get("reason", "") or ""))}

