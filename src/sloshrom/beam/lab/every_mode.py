"""A laboratory's tests at every mode in the tested band: the modes found (or given), each
analysed as the paper analyses mode 1.

* :func:`modes_of_test` - the modes of a free decay or a random test: found from the data
  (:mod:`sloshrom.beam.damping.peaks`) or given, each with its analysis band.
* :func:`random_mode_dataset` - Table 2 at every mode: the damping estimators of
  ``sloshrom.beam.damping.registry`` with their intervals, one row per mode and level.
* :func:`free_mode_decays`, :func:`free_mode_rows` - the free decay of every mode (Hilbert and
  log decrement against the mode's own amplitude at the tank) and its damping per amplitude band.

A mode is band-passed out of the tank channel (relative to the base) unless the user's
structure gives mode shapes at the stations, in which case mode ``k`` is the modal coordinate of
the structural mode nearest in frequency (modal filtering). Pure functions on the result dicts of
:mod:`sloshrom.beam.lab.measured`; no files, no printing.
"""

from __future__ import annotations

import dataclasses
import math
import warnings
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
import xarray as xr
from scipy import signal

from sloshrom.beam.damping.analysis import (
    AnalysisError,
    instantaneous_damping,
    log_decrement,
    noise_floor,
    spectral_noise_floor,
)
from sloshrom.beam.damping.limits import FREE_DAMPING_PERIODS, WELCH_SEGMENT
from sloshrom.beam.damping.peaks import (
    MIN_PROMINENCE_DB,
    FoundMode,
    band_maximum,
    common_modes,
    find_modes,
    given_modes,
    mode_bands,
    station_modes,
)
from sloshrom.beam.damping.tables import Mode1Decay, decay_floor, modal_accelerations
from sloshrom.beam.damping.uncertainty import (
    FLOOR_FACTOR,
    ShortRecordWarning,
    amplitude_bands,
    band_damping,
    estimate_random,
)
from sloshrom.beam.lab.measured import MeasuredTest
from sloshrom.beam.simulation.members import Row
from sloshrom.beam.simulation.structure import CantileverBeam, ModalModel
from sloshrom.config import G

__all__ = ["UNIT_FACTORS", "ModeDecay", "TestModes", "check_station_amplitudes",
           "check_station_order", "number_modes",
           "describe", "free_mode_decays",
           "free_mode_rows", "modes_of_test", "random_mode_dataset"]

#: The fewest Welch segments (``limits.WELCH_SEGMENT`` samples) whose estimates and
#: intervals hold (the lab coverage benchmark runs 120 s at 500 Hz: 6 segments).
MIN_SEGMENTS = 3
#: Lines of those spectra a mode's band must hold (the LSCF fits' least).
MIN_BAND_LINES = 8
#: Half-width of the Hilbert band-pass of a free decay, relative to the mode's frequency (the
#: paper's mode-1 analysis), cut to the mode's band between its neighbours.
DECAY_REL_BAND = 0.35


@dataclass(frozen=True)
class TestModes:
    """The modes analysed in one test.

    Attributes
    ----------
    modes : list of FoundMode
        Lowest first.
    bands : list of (float, float)
        Each mode's analysis band, Hz (:func:`sloshrom.beam.damping.peaks.mode_bands`).
    how : str
        ``"found"`` (from the data) or ``"given"``.
    numbers : tuple of int, optional
        The modes' numbers, as the structure has them (:func:`number_modes`): a mode the test
        does not show leaves its number out, so that the next one keeps its own (default 1,
        2, ...: the modes found are the structure's first ones).
    """

    __test__ = False  # not a pytest class
    modes: list[FoundMode]
    bands: list[tuple[float, float]]
    how: str
    numbers: tuple[int, ...] | None = None

    @property
    def frequencies(self) -> list[float]:
        """The modes' frequencies, Hz."""
        return [m.frequency for m in self.modes]

    def number(self, k: int) -> int:
        """The number of mode ``k`` (0-based index), as the structure has it."""
        return self.numbers[k] if self.numbers is not None else k + 1

    def rel_band(self, k: int, rel: float) -> float:
        """A symmetric half-width (relative) around mode ``k`` that stays in its band, at
        most ``rel``."""
        f = self.modes[k].frequency
        lo, hi = self.bands[k]
        return min(rel, (f - lo) / f, (hi - f) / f)


def number_modes(tests: Sequence[TestModes], modal: ModalModel | None = None
                 ) -> list[TestModes]:
    """The tests' modes numbered as the structure has them, not by their order in each test.

    With ``modal``: a mode is the structure's mode nearest in frequency. Without: the modes
    any of the tests shows (peaks within 10 % one mode,
    :func:`~sloshrom.beam.damping.peaks.common_modes`), in order of frequency - a campaign
    whose decay misses mode 2 calls the random test's third mode 3 in the decay too. Numbers
    that two modes of one test would share leave that test numbered 1, 2, ...
    """
    if modal is not None:
        ref = np.asarray(modal.frequencies, dtype=float)
    else:
        ref = np.asarray([m.frequency for m in common_modes([t.modes for t in tests],
                                                             share=0.0)])
    out = []
    for t in tests:
        nums = tuple(int(np.argmin(np.abs(ref - f))) + 1 for f in t.frequencies) if ref.size \
            else None
        ok = nums is not None and len(set(nums)) == len(nums)
        out.append(dataclasses.replace(t, numbers=nums if ok else None))
    return out


def modes_of_test(res: MeasuredTest, kind: str, *,
                  frequencies: Sequence[float] | None = None,
                  max_modes: int | None = None) -> TestModes:
    """The modes of a measured test: ``frequencies`` if given, else the resonances its data
    show.

    A random test: peaks of each level's H1 (base -> station) shown by two stations at least
    (:func:`~sloshrom.beam.damping.peaks.station_modes`) that at least half of the levels
    share. A free decay: peaks of any station's output spectrum.

    Parameters
    ----------
    res : mapping
        A test of :func:`sloshrom.beam.lab.measured.read_free_test` or ``read_random_test``.
    kind : {"free", "random"}
    frequencies : sequence of float, optional
        The modes, Hz (``--f1``, ``--frequencies``).
    max_modes : int, optional
        Keep the lowest ``max_modes`` found.

    Raises
    ------
    AnalysisError
        No resonance in the data (the message says how to name one), or a mode too close to
        Nyquist.
    """
    fs = float(res["fs"])
    tank, base = np.asarray(res["tank_acceleration"]), np.asarray(res["base_acceleration"])
    if frequencies is not None:
        modes, how = given_modes(frequencies), "given"
        bands = mode_bands([m.frequency for m in modes], fs)
        for m, b in zip(modes, bands, strict=True):
            _check_given_mode(m.frequency, b, tank, base, fs, kind)
    else:
        st = np.asarray(res["station_acceleration"], dtype=float)
        if kind == "random":
            # each level's peaks of H1 at every station (two stations at least: an
            # antiresonance of one channel is no mode), those half of the levels share
            modes = common_modes([station_modes(s, fs, b) for b, s in zip(
                np.atleast_2d(base), st.reshape(-1, *st.shape[-2:]), strict=True)])
        else:
            # a decay's output spectrum has no antiresonance peaks: a mode is a peak of any
            # station (a fast-decaying mode may stand out at the tip alone)
            modes = station_modes(st - base[:, None], fs, min_stations=1)
        how = "found"
        if not modes:
            where = ("H1 (base -> tank) of the levels" if kind == "random"
                     else "spectrum of the tank channel")
            raise AnalysisError(f"no resonance found in the {where}: no peak stands "
                                "10 dB above its surroundings (with coherence >= 0.5 on H1); "
                                "name the modes with --f1 or --frequencies")
    if max_modes is not None:
        modes = modes[:max_modes]
    bands = mode_bands([m.frequency for m in modes], fs)
    if kind == "random":
        for m, (lo, hi) in zip(modes, bands, strict=True):
            _check_resolution(m.frequency, lo, hi, fs)
    return TestModes(list(modes), bands, how)


def _check_resolution(f: float, lo: float, hi: float, fs: float) -> None:
    """A random test's mode band must hold :data:`MIN_BAND_LINES` lines of its
    :data:`WELCH_SEGMENT`-sample Welch spectra (the LSCF fits need them)."""
    n = int((hi - lo) * WELCH_SEGMENT / fs)
    if n < MIN_BAND_LINES:
        raise AnalysisError(
            f"the files' sample rate fs = {fs:g} Hz leaves {n} line(s) of the "
            f"{WELCH_SEGMENT}-sample Welch spectra ({fs / WELCH_SEGMENT:.3g} Hz apart) in the "
            f"band of the mode at {f:.4g} Hz ({lo:.4g}-{hi:.4g} Hz); its analyses need "
            f"{MIN_BAND_LINES}, so fs at most {(hi - lo) * WELCH_SEGMENT / MIN_BAND_LINES:.4g} "
            "Hz: is the files' fs (their time axis) right?")


def _check_given_mode(f: float, band: tuple[float, float], tank: np.ndarray, base: np.ndarray,
                      fs: float, kind: str) -> None:
    """A mode the user names must be a resonance of the data: the spectrum's maximum in the
    band its analyses filter (``f`` -/+ :data:`DECAY_REL_BAND`, inside its band between its
    neighbours) lies inside it, not at an edge (the skirt of a resonance beside it); for a
    free decay, a peak there stands out of the noise as :func:`find_modes` requires of the
    modes it finds."""
    rel = min(DECAY_REL_BAND, (f - band[0]) / f, (band[1] - f) / f)
    lo, hi = f * (1 - rel), f * (1 + rel)
    found = (band_maximum(tank, fs, (lo, hi), base) if kind == "random"
             else band_maximum(tank - base, fs, (lo, hi)))
    if found is None:
        return
    at, top, line = found
    where = "H1 (base -> tank)" if kind == "random" else "the tank channel's spectrum"
    if not lo + 2 * line < at < hi - 2 * line:  # at an edge: the skirt of a resonance beside
        raise AnalysisError(
            f"the mode given at {f:.4g} Hz is not a resonance of the data: {where} has no peak "
            f"in {lo:.3g}-{hi:.3g} Hz, the band its analyses filter (it is largest at the "
            f"edge, {at:.4g} Hz); the data's strongest peak is at {top:.4g} Hz")
    # a decay has no coherence to tell a mode from the noise (a random test's estimators
    # refuse a mode its input does not excite): the maximum inside the band must stand out of
    # the noise as a mode the search finds does (find_modes' criteria, in that band)
    # (searched over the whole spectrum, whose noise floor is the decay's; a band alone has
    # the mode's own skirt for a floor)
    if kind == "free" and not any(lo < m.frequency < hi for m in find_modes(tank - base, fs)):
        raise AnalysisError(
            f"the mode given at {f:.4g} Hz is not a resonance of the data: {where} has no peak "
            f"in {lo:.3g}-{hi:.3g} Hz, the band its analyses filter, that stands "
            f"{MIN_PROMINENCE_DB:g} dB above its surroundings and above the spectrum's noise "
            f"floor (its largest value there, at {at:.4g} Hz, is noise); the data's strongest "
            f"peak is at {top:.4g} Hz")


def check_station_order(res: MeasuredTest, f1: float, rel_band: float,
                        modal: ModalModel | None = None) -> None:
    """Whether the channel map's stations are where the data say: at the first mode found
    (``f1``), the station that should move most moves more than the one that should move least.

    Which is which comes from the structure's mode shape at the stations (``modal``: its mode
    nearest ``f1``), else from the map's ``positions``: a cantilever's first mode grows from
    the root to the tip. Each station's motion is its acceleration relative to the base,
    band-passed around ``f1`` (``1 -/+ rel_band``, 4th-order Butterworth, zero phase), as RMS
    over the record (a random test's last level). A map without positions and structure is
    not checked.

    Parameters
    ----------
    res : mapping
        A test of :func:`sloshrom.beam.lab.measured.read_free_test` or ``read_random_test`` (its
        ``channel_map`` names the stations it holds).
    f1 : float
        The first mode found (or given), Hz.
    rel_band : float
        Half-width of the band-pass, relative to ``f1`` (-).
    modal : ModalModel, optional
        The structure at the test's stations.

    Raises
    ------
    AnalysisError
        The station that should move most moves less (both stations, their positions or
        mode-shape values and the ratio named): a map listing the stations in reverse, or
        another station order than the data's.
    """
    cmap = res["channel_map"]
    n_st = np.asarray(res["station_acceleration"]).shape[-1]
    if n_st < 2:
        return
    if modal is not None and modal.psi_stations.shape[0] == n_st:
        # the structure's mode nearest in frequency (as the modal filter takes it)
        k = int(np.argmin(np.abs(np.asarray(modal.frequencies) - f1)))
        expect = np.abs(np.asarray(modal.psi_stations, dtype=float)[:, k])
        what, ref = [f"mode shape {v:.3g}" for v in expect], "on the structure"
    elif cmap.positions is not None:
        expect = np.asarray(cmap.positions, dtype=float)
        what, ref = [f"at {x:g} m" for x in expect], "their positions"
    else:
        return
    rms = _station_rms(res, f1, rel_band)
    hi, lo = int(np.argmax(expect)), int(np.argmin(expect))
    if rms[hi] < rms[lo]:
        names = cmap.stations
        raise AnalysisError(
            f"the channel map contradicts the data: at mode 1 ({f1:.4g} Hz) station "
            f"{names[hi]!r} ({what[hi]}) moves {rms[hi] / rms[lo]:.2g} x as much as "
            f"{names[lo]!r} ({what[lo]}), and should move most; are the stations listed in "
            f"another order (reversed?) than {ref}?")


def _station_rms(res: MeasuredTest, f: float, rel_band: float, relative: bool = True
                 ) -> np.ndarray:
    """Each station's motion at the mode ``f`` (Hz): its acceleration relative to the base
    (``relative``; else absolute, which a channel's wrong unit scales exactly), band-passed
    ``f (1 -/+ rel_band)`` (4th-order Butterworth, zero phase), RMS over the record (a random
    test's last level), ``(n_stations,)``, m/s^2."""
    st = np.asarray(res["station_acceleration"], dtype=float)
    base = np.asarray(res["base_acceleration"], dtype=float)
    if st.ndim == 3:  # a random test: its last level
        st, base = st[-1], base[-1]
    sos = signal.butter(4, [(1 - rel_band) * f, (1 + rel_band) * f], btype="bandpass",
                        fs=float(res["fs"]), output="sos")
    y = signal.sosfiltfilt(sos, st - base[:, None] if relative else st, axis=0)
    return np.sqrt(np.mean(y**2, axis=0))


#: The factors a unit mix-up puts on a channel, and what each means: a channel whose motion
#: is one of them times what its mode shape and the other stations say is named.
UNIT_FACTORS: tuple[tuple[float, str], ...] = (
    (G, "data in m/s^2 read as g"), (1 / G, "data in g read as m/s^2"),
    (1000.0, "data in mm/s^2 read as m/s^2"), (1e-3, "data in m/s^2 read as mm/s^2"))
#: How close (a factor) a station's scale must be to one of :data:`UNIT_FACTORS`: the uniform
#: cantilever's first mode, which stands in for an unknown cantilever's, is within 15 % of a
#: tip-loaded one's (its static deflection shape) at 20-100 % of the length.
FACTOR_TOLERANCE = 1.3
#: Stations whose expected motion is below this fraction of the largest are not checked at a
#: mode: near a node of a structure's higher mode, a small error of its model's shape is a large
#: factor. A cantilever's first mode has no node but its root: there every station from 0.05 of
#: the tip's motion is checked (:data:`MIN_FIRST_SHAPE`).
MIN_SHAPE = 0.25
MIN_FIRST_SHAPE = 0.05


def check_station_amplitudes(res: MeasuredTest, modes: TestModes,
                             modal: ModalModel | None = None) -> None:
    """Whether every station's amplitude agrees with the others' at each mode: a channel read
    in the wrong unit (another file's sensor set-up, g taken for m/s^2) is 9.81 times off at
    every mode, which a mode shape never is.

    At each mode with a known shape - the structure's mode nearest in frequency (``modal``),
    else, for the lowest mode, a cantilever's first mode at the map's ``positions`` (root at
    0, tip at the outermost station) - each station's absolute motion (:func:`_station_rms`:
    a wrong unit scales it exactly; the mode's resonant motion dominates the base's) over its
    shape value is its scale. The stations that agree (within a factor 1.5 of one another; the
    largest such group, at least three and half of the stations: else the shape is not the
    data's, e.g. the lowest mode found is not the first, and the mode is not checked) set the
    reference; a station whose scale is one of
    :data:`UNIT_FACTORS` (within :data:`FACTOR_TOLERANCE`) times it, the same at every mode
    checked, is named. Stations whose shape value is below :data:`MIN_SHAPE`
    (:data:`MIN_FIRST_SHAPE` for a cantilever's first mode) of the largest are left out.

    Raises
    ------
    AnalysisError
        A mis-scaled station: its name, the factor and the unit mix-up it suggests, the modes.
    """
    cmap = res["channel_map"]
    n_st = np.asarray(res["station_acceleration"]).shape[-1]
    shapes: list[tuple[int, np.ndarray, float]] = []
    if modal is not None and modal.psi_stations.shape[0] == n_st:
        f_struct = np.asarray(modal.frequencies)
        shapes = [(k, np.abs(np.asarray(modal.psi_stations, dtype=float)[
            :, int(np.argmin(np.abs(f_struct - f)))]), MIN_SHAPE)
            for k, f in enumerate(modes.frequencies)]
    elif cmap.positions is not None and n_st >= 3:
        x = np.asarray(cmap.positions, dtype=float)
        psi = np.abs(CantileverBeam(length=float(x.max())).mode_shapes(x, 1)[:, 0])
        # (if the lowest mode found is not the first - one below the shaker's band - its shape
        # differs, few stations agree, and nothing is checked)
        shapes = [(0, psi, MIN_FIRST_SHAPE)]
    found: dict[int, list[tuple[float, str]]] = {}
    checked: list[int] = []
    for k, psi, least in shapes:
        use = np.flatnonzero(psi >= least * psi.max())
        if use.size < 3:
            continue
        # absolute: a wrong unit scales it exactly (the relative motion keeps the base's part)
        rms = _station_rms(res, modes.frequencies[k], modes.rel_band(k, DECAY_REL_BAND),
                           relative=False)
        scale = rms[use] / psi[use]
        if not np.all(scale > 0):
            continue
        # the largest group of stations that agree, ties to the one that moves most
        groups = [np.abs(np.log(scale / c)) <= math.log(1.5) for c in scale]
        agree = max(groups, key=lambda g: (int(np.count_nonzero(g)), float(psi[use][g].sum())))
        if np.count_nonzero(agree) < max(3, use.size / 2):  # no shape the stations show
            continue
        ref = float(np.median(scale[agree]))
        checked.append(k)
        for s, r in zip(use, scale / ref, strict=True):
            hit = next(((f, what) for f, what in UNIT_FACTORS
                        if abs(math.log(r / f)) <= math.log(FACTOR_TOLERANCE)), None)
            found.setdefault(int(s), []).append((float(r), hit[1] if hit else ""))
    bad = [(s, rs) for s, rs in found.items() if len(rs) == len(checked)
           and rs[0][1] and all(w == rs[0][1] for _, w in rs)]
    if not bad:
        return
    at = ", ".join(f"mode {modes.number(k)} ({modes.frequencies[k]:.4g} Hz)" for k in checked)
    each = "; ".join(
        f"{cmap.stations[s]!r} moves {np.exp(np.mean(np.log([r for r, _ in rs]))):.3g} x as "
        f"much as its mode shape and the other stations say ({rs[0][1]}?)" for s, rs in bad)
    raise AnalysisError(
        f"a station looks mis-scaled: {each}, at {at}; is its unit right (--unit, the map's "
        "[units] and, for files of another sensor set-up, [units.\"PATTERN\"] tables, the "
        "file's own)?")


def random_mode_dataset(res: MeasuredTest, case: str, modes: TestModes, *,
                        estimators: Sequence[str] | None = None, accuracy: float | None = None,
                        step: Callable[[str], None] | None = None) -> xr.Dataset:
    """Table 2 at every mode: the damping estimators of ``sloshrom.beam.damping.registry`` at
    every mode and level, each with its interval, the fitting band the mode's
    (:attr:`TestModes.bands`).

    ``step(text)`` is called before each analysis (progress).

    Returns
    -------
    xarray.Dataset
        The variables of ``sloshrom.beam.damping.uncertainty.damping_dataset`` over ``(mode,
        level, estimator)`` (``noise_input``, ``noise_output``, ``duration_s``, ``n_cycles``
        over ``(mode, level)``); coordinates ``case`` (the test's name), ``mode`` (1-based),
        ``mode_frequency_Hz`` (Hz, along ``mode``), ``level`` (RMS base acceleration, g) and
        ``estimator``. Its rows, as ``table2_damping.csv`` holds them (``case``, ``mode``,
        ``mode_frequency_Hz``, ``rms_g``, then Table 2's columns):
        ``sloshrom.beam.damping.columns.table2_rows``.
    """
    fs = float(res["fs"])
    n = np.asarray(res["base_acceleration"]).shape[-1]
    segments = 1 + max(n - WELCH_SEGMENT, 0) // (WELCH_SEGMENT // 2)
    if segments < MIN_SEGMENTS:
        # one or two segments: H1 and its coherence barely average, and the bootstrap's spread
        # understates the error (a 40 s record at 500 Hz: LSCF on H1 -20 % at mode 1, outside
        # its interval)
        warnings.warn(f"{n / fs:g} s per level gives H1 from {segments} Welch segment(s) of "
                      f"{WELCH_SEGMENT} samples: the estimates and their intervals need at "
                      f"least {MIN_SEGMENTS} ({(WELCH_SEGMENT // 2) * (MIN_SEGMENTS + 1) / fs:g}"
                      " s)", ShortRecordWarning, stacklevel=2)
    levels = [float(g) for g in res["rms_levels_g"]]
    per_mode = []
    for k, m in enumerate(modes.modes):
        per_level = []
        for i, g in enumerate(levels):
            if step is not None:
                step(f"damping of mode {modes.number(k)} ({m.frequency:.4g} Hz), {g:g} g")
            with warnings.catch_warnings(record=True) as caught:
                warnings.simplefilter("always", ShortRecordWarning)
                d = estimate_random(res["base_acceleration"][i], res["tank_acceleration"][i],
                                    fs, m.frequency, band=modes.bands[k], accuracy=accuracy,
                                    estimators=estimators, neighbours=modes.frequencies)
            for w in caught:  # say which mode and level each warning is about
                warnings.warn(f"mode {modes.number(k)}, {g:g} g RMS: {w.message}", w.category,
                              stacklevel=2)
            per_level.append(d.to_dataset())
        per_mode.append(xr.concat(per_level, dim="level"))
    return xr.concat(per_mode, dim="mode").assign_coords(
        case=case, mode=("mode", [modes.number(k) for k in range(len(modes.modes))]),
        mode_frequency_Hz=("mode", [float(m.frequency) for m in modes.modes], {"units": "Hz"}),
        level=("level", levels, {"units": "g"}))


@dataclass(frozen=True)
class ModeDecay:
    """The free decay of one mode.

    Attributes
    ----------
    decay : Mode1Decay
        Its Hilbert and log-decrement damping against its own amplitude at the tank
        (``decay.modal``: the modal accelerations with a structure, else the tank channel
        relative to the base, ``(n, 1)``).
    record : ndarray (n,)
        The signal analysed: the mode's modal coordinate, or the tank channel relative to the
        base (m/s^2).
    rel_band : float
        Half-width of its band-pass, relative to the mode's frequency.
    """

    decay: Mode1Decay
    record: np.ndarray
    rel_band: float


def free_mode_decays(res: MeasuredTest, modes: TestModes,
                     modal: ModalModel | None = None) -> list[ModeDecay]:
    """The free decay of every mode: Hilbert and log-decrement damping of the mode against
    its own amplitude at the tank.

    With ``modal`` (mode shapes at the stations, at least as many stations as modes), mode
    ``k`` is the modal coordinate (modal filtering) of the structural mode nearest in frequency;
    otherwise the tank channel relative to the base, band-passed around the mode. Mode 1's
    amplitude axis is the tank acceleration (paper Fig. 21); the band-pass makes it the mode's
    own share.

    Raises
    ------
    AnalysisError
        A record too short for a mode (fewer than ``limits.FREE_DAMPING_PERIODS`` periods), or the
        stations cannot separate the modes.
    """
    fs = float(res["fs"])
    n = np.asarray(res["tank_acceleration"]).size
    tank = np.asarray(res["tank_acceleration"])
    rel_x = tank - np.asarray(res["base_acceleration"])
    q = None
    if modal is not None and modal.psi_stations.shape[0] >= modal.n_modes:
        q = modal_accelerations(res, modal)
        f_struct = np.asarray(modal.frequencies)
    out = []
    for k, m in enumerate(modes.modes):
        f = m.frequency
        if n < FREE_DAMPING_PERIODS * fs / f:
            raise AnalysisError(f"the free decay is {n / fs:g} s long: mode {modes.number(k)} "
                                f"({f:.4g} Hz) needs {FREE_DAMPING_PERIODS} periods, "
                                f"{FREE_DAMPING_PERIODS / f:.3g} s")
        x = rel_x if q is None else q[:, int(np.argmin(np.abs(f_struct - f)))]
        rel = modes.rel_band(k, DECAY_REL_BAND)
        out.append(ModeDecay(Mode1Decay(
            modal=q if q is not None else rel_x[:, None],
            hilbert=instantaneous_damping(x, fs, f, rel_band=rel, reference=tank),
            log_decrement=log_decrement(x, fs, f, rel_band=rel, reference=tank)), x, rel))
    return out


def free_mode_rows(res: MeasuredTest, case: str, modes: TestModes,
                   decays: Sequence[ModeDecay], *, seed: int = 0) -> list[Row]:
    """Damping per amplitude band of every mode (``case``, ``mode``, ``mode_frequency_Hz``,
    then :func:`sloshrom.beam.damping.uncertainty.band_damping`'s columns): each mode in the bands
    of its own amplitude range above the noise floor of the tank channel around it
    (:func:`~sloshrom.beam.damping.uncertainty.amplitude_bands`), intervals from the noise-added
    bootstrap of the mode's record."""
    rows: list[Row] = []
    fs = float(res["fs"])
    for k, (m, d) in enumerate(zip(modes.modes, decays, strict=True)):
        floor = decay_floor(res, m.frequency, d.rel_band)
        ok = bool(np.isfinite(floor))
        bands = amplitude_bands(d.decay.hilbert["amplitude"] / G,
                                FLOOR_FACTOR * floor / G if ok else None)
        # the bootstrap's noise: the decay's floor, or where the record stops above it (a
        # slow mode in a short record) the noise its spectrum shows away from the modes, so
        # that every band, a short one too, has the scatter of its estimate
        try:
            noise = noise_floor(d.record, fs, m.frequency, d.rel_band)
        except AnalysisError:  # too short for the tail's fit
            noise = float("nan")
        if not np.isfinite(noise):
            noise = spectral_noise_floor(d.record, fs, m.frequency, d.rel_band)
        rows += [{"case": case, "mode": modes.number(k), "mode_frequency_Hz": m.frequency, **row}
                 for row in band_damping(d.decay.hilbert, d.decay.log_decrement, m.frequency,
                                         bands=bands, record=d.record, fs=fs, noise=noise,
                                         floor=floor if ok else None, rel_band=d.rel_band,
                                         seed=seed)]
    return rows


def describe(modes: TestModes) -> str:
    """One line naming the analysed modes and how they were found."""
    fr = ", ".join(f"{f:.4g}" for f in modes.frequencies)
    n = len(modes.modes)
    return f"{n} mode{'s' if n > 1 else ''} {modes.how}: {fr} Hz"
