"""Configuration of `sloshrom reproduce`: the shipped defaults, merged with a user's TOML file.

:func:`load` merges and then :func:`validate`\\ s: every key of ``defaults.toml`` is checked
(type, bounds, list contents and the relations between keys) *before* any stage runs, so that a
bad value costs one error line naming the key, not a traceback after minutes of work.
"""

from __future__ import annotations

import copy
import math
import tomllib
from collections.abc import Callable
from importlib import resources
from pathlib import Path
from typing import Any

from sloshrom.config import ConfigError, Tank, load_toml

__all__ = [
    "FREE_DAMPING_PERIODS",
    "MAX_FINE_SECONDS",
    "MIN_RANDOM_DURATION",
    "MIN_VFA_DURATION",
    "QUICK",
    "default_text",
    "defaults",
    "load",
    "merge",
    "min_free_duration",
    "validate",
]

# Reduced sizes for `--quick` (a smoke run of the whole chain in a few minutes).
QUICK: dict[str, dict[str, Any]] = {
    "data": {"train_duration": 120.0, "validation_duration": 60.0},
    "rom": {"delays": 40, "neurons": 15, "max_epochs": 60},
    "map": {"n_omega": 10, "n_a": 8},
    "beam": {"free_duration": 6.0, "random_duration": 70.0},
}

#: Shortest VFA path, s (``sloshrom.signals.vfa``: 2 s fade in and out plus the sweep).
MIN_VFA_DURATION = 10.0
#: Longest run at the virtual rig's fine step (10 kHz), s. A VFA record holds about 20 float64
#: arrays per fine sample at its peak (path, derivatives, filtered sensor channels): measured
#: 1.6 MB per second of record, so one hour needs about 6 GB of memory and a minute of CPU.
MAX_FINE_SECONDS = 3600.0
#: The virtual rig's integration rate (``VirtualRig.dt`` = 1e-4 s): ``rig.fs`` must divide it.
RIG_RATE = 10_000.0
#: Fed-back outputs of the NOE built by `reproduce` (``NOE(out_delays=2)``, the default).
NOE_OUT_DELAYS = 2
#: Default rate of the beam results (``sloshrom beam``); `reproduce` uses ``rig.fs``.
BEAM_FS = 500.0
#: Welch segment of the random-response damping estimators (``analysis.mode1_damping_random``).
WELCH_NPERSEG = 16384
#: A random response must hold at least one Welch segment (32.8 s at 500 Hz); 90 s (paper) give
#: four half-overlapping segments, hence a much smoother estimate.
MIN_RANDOM_DURATION = math.ceil(WELCH_NPERSEG / BEAM_FS)
#: Bounds of the beam's geometry and material (SI): a laboratory or wing-like beam, not a typo
#: in mm or GPa.
_BEAM_BOUNDS = {"length": (0.01, 100.0, "a length in m"), "width": (1e-4, 10.0, "a width in m"),
                "thickness": (1e-4, 1.0, "a thickness in m"),
                "youngs_modulus": (1e6, 1e13, "a Young's modulus in Pa"),
                "density": (1.0, 3e4, "a density in kg/m^3")}
#: ``analysis.instantaneous_damping`` trims 5 periods of mode 1 at each end and smooths over 4;
#: 4 more periods leave a decay to analyse (18 periods: 1.8 s for the paper beam, f1 = 10.2 Hz).
FREE_DAMPING_PERIODS = 2 * 5 + 4 + 4
#: Longest beam simulation, s (the rig runs at 10 kHz inside the coupled loop).
MAX_BEAM_SECONDS = 600.0
#: Random responses of the rig hold about 2.1 MB per second and per level at its 10 kHz step
#: (measured): duration x number of levels is bounded to keep a run within about 4 GB.
MAX_LEVEL_SECONDS = 1800.0
#: Accelerometer stations of the beam: the modal filter separates at most this many modes.
MAX_MODES = 5


def default_text() -> str:
    """The shipped defaults, as TOML text with comments."""
    return (resources.files("sloshrom.pipeline") / "defaults.toml").read_text(encoding="utf-8")


def defaults() -> dict[str, Any]:
    """The shipped defaults as a dict of tables."""
    return tomllib.loads(default_text())


def merge(base: dict[str, Any], override: dict[str, Any], where: str = "") -> dict[str, Any]:
    """Deep-merge ``override`` into a copy of ``base``; unknown keys or wrong types are errors."""
    out = copy.deepcopy(base)
    for key, value in override.items():
        path = f"{where}{key}"
        if key not in base:
            raise ConfigError(f"unknown configuration key '{path}'")
        if isinstance(base[key], dict):
            if not isinstance(value, dict):
                raise ConfigError(f"'{path}' must be a table")
            out[key] = merge(base[key], value, where=f"{path}.")
            continue
        ref = base[key]
        if isinstance(ref, bool) != isinstance(value, bool):
            raise ConfigError(f"'{path}' must be true or false, got {value!r}")
        if isinstance(ref, int | float) and not isinstance(ref, bool):
            if not isinstance(value, int | float) or isinstance(value, bool):
                raise ConfigError(f"'{path}' must be a number, got {value!r}")
            value = type(ref)(value) if isinstance(ref, float) else value
        elif isinstance(ref, str) and not isinstance(value, str):
            raise ConfigError(f"'{path}' must be a string, got {value!r}")
        elif isinstance(ref, list) and not isinstance(value, list):
            raise ConfigError(f"'{path}' must be a list, got {value!r}")
        out[key] = value
    return out


def load(path: str | Path | None = None, quick: bool = False) -> dict[str, Any]:
    """Defaults, then ``QUICK`` if asked, then the user's file (which wins); validated.

    Raises
    ------
    ConfigError
        Missing or malformed file, unknown key, or a value :func:`validate` rejects.
    """
    cfg = defaults()
    if quick:
        cfg = merge(cfg, QUICK)
    if path is not None:
        cfg = merge(cfg, load_toml(path))
    return validate(cfg)


# -- validation --------------------------------------------------------------------------------
Check = Callable[[str, Any], None]


def _is_number(v: Any) -> bool:
    return isinstance(v, int | float) and not isinstance(v, bool)


def _fmt(v: float) -> str:
    return str(v) if isinstance(v, int) else f"{v:g}"


def _number(lo: float | None = None, hi: float | None = None, *, lo_open: bool = False,
            hi_open: bool = False, integer: bool = False, what: str = "a number",
            why: str = "") -> Check:
    """A finite number (an integer if ``integer``) in [lo, hi] (open ends on request)."""

    def check(key: str, v: Any) -> None:
        ok = isinstance(v, int) and not isinstance(v, bool) if integer else _is_number(v)
        ok = ok and math.isfinite(v)
        ok = ok and (lo is None or (v > lo if lo_open else v >= lo))
        ok = ok and (hi is None or (v < hi if hi_open else v <= hi))
        if not ok:
            ends = ("-inf" if lo is None else _fmt(lo), "inf" if hi is None else _fmt(hi))
            rng = f"{'(' if lo_open else '['}{ends[0]}, {ends[1]}{')' if hi_open else ']'}"
            raise ConfigError(f"'{key}' must be {what} in {rng}, got {v!r}"
                              + (f" ({why})" if why else ""))

    return check


def _choice(*options: str) -> Check:
    def check(key: str, v: Any) -> None:
        if v not in options:
            raise ConfigError(
                f"'{key}' must be " + " or ".join(f'"{o}"' for o in options) + f", got {v!r}")

    return check


def _boolean(key: str, v: Any) -> None:
    if not isinstance(v, bool):
        raise ConfigError(f"'{key}' must be true or false, got {v!r}")


def _list(element: Check, what: str, distinct: bool = False) -> Check:
    """A non-empty list whose every element passes ``element``."""

    def check(key: str, v: Any) -> None:
        if not isinstance(v, list) or not v:
            raise ConfigError(f"'{key}' must be a non-empty list of {what}, got {v!r}")
        for i, x in enumerate(v):
            try:
                element(f"{key}[{i}]", x)
            except ConfigError as exc:
                raise ConfigError(f"'{key}' must be a non-empty list of {what}: {exc}") from None
        if distinct and len(set(v)) != len(v):
            raise ConfigError(f"'{key}' must not repeat a value, got {v!r}")

    return check


_SEED = _number(0, 2**32 - 1, integer=True, what="a non-negative integer seed")
_VFA_SECONDS = _number(MIN_VFA_DURATION, MAX_FINE_SECONDS, what="a VFA duration in s",
                       why="the shortest VFA path is 10 s; 1 h at the rig's 10 kHz step needs "
                           "about 6 GB of memory")
_GRID_DELAYS = _list(_number(1, 1000, integer=True, what="an integer"),
                     "delays (integers in [1, 1000])", distinct=True)
_GRID_NEURONS = _list(_number(1, 1000, integer=True, what="an integer"),
                      "neuron counts (integers in [1, 1000])", distinct=True)

# Every key of defaults.toml, with its check. The [tank] table is checked by ``Tank`` itself.
_SPEC: dict[str, dict[str, Check]] = {
    "rig": {
        "seed": _SEED,
        # the record rate of the rig's sensors: decimated from the 5 kHz acquisition, and the
        # VFA band (up to 25 Hz) must lie well inside the anti-alias passband 0.8 fs/2
        "fs": _number(100.0, 5000.0, what="a record rate in Hz",
                      why="decimated from the sensors' 5 kHz acquisition; 25 Hz must stay "
                          "inside the anti-alias passband 0.8 fs/2"),
    },
    "data": {
        "train_duration": _VFA_SECONDS,
        "validation_duration": _VFA_SECONDS,
        "train_seed": _SEED,
        "validation_seed": _SEED,
    },
    "rom": {
        "arch": _choice("nfir", "noe"),
        "delays": _number(1, 1000, integer=True, what="an integer"),
        "neurons": _number(1, 1000, integer=True, what="an integer"),
        "hidden": _choice("matlab", "distance"),
        "max_epochs": _number(0, 100_000, integer=True, what="an integer"),
        "seed": _SEED,
        "sweep": _boolean,
        "sweep_nfir_delays": _GRID_DELAYS,
        "sweep_nfir_neurons": _GRID_NEURONS,
        "sweep_noe_delays": _GRID_DELAYS,
        "sweep_noe_neurons": _GRID_NEURONS,
        "sweep_workers": _number(1, 64, integer=True, what="a number of parallel trainings"),
    },
    "map": {
        # each frequency runs n_a harmonic tests as one batch at the rig's 10 kHz step
        "n_omega": _number(2, 200, integer=True, what="an integer"),
        "n_a": _number(2, 200, integer=True, what="an integer"),
        "f_min": _number(1.0, 200.0, what="a frequency in Hz"),
        "f_max": _number(1.0, 200.0, what="a frequency in Hz"),
        "a_bar_min": _number(0.0, 1.0, lo_open=True, what="a displacement amplitude / tank "
                                                          "height"),
        "a_bar_max": _number(0.0, 1.0, lo_open=True, what="a displacement amplitude / tank "
                                                          "height"),
        "gamma_max": _number(0.0, 60.0, lo_open=True, what="an acceleration amplitude in g"),
    },
    "beam": {
        **{k: _number(lo, hi, what=what) for k, (lo, hi, what) in _BEAM_BOUNDS.items()},
        "tip_displacement": _number(0.0, 0.2, lo_open=True, what="an initial tip displacement "
                                                                 "in m"),
        "free_duration": _number(0.0, MAX_BEAM_SECONDS, lo_open=True, what="a duration in s"),
        "random_duration": _number(0.0, MAX_BEAM_SECONDS, lo_open=True, what="a duration in s"),
        "rms_g": _list(_number(0.0, 2.0, lo_open=True, what="an RMS level in g"),
                       "RMS levels in g, each in (0, 2]"),
        "f0": _number(0.0, lo_open=True, what="a frequency in Hz"),
        "sigma": _number(0.0, lo_open=True, what="a frequency in Hz"),
        "seed": _SEED,
        "damping": _list(_number(0.0, 1.0, hi_open=True, what="a damping ratio"),
                         "modal damping ratios, each in [0, 1)"),
        "n_modes": _number(1, MAX_MODES, integer=True, what="an integer",
                           why="the modal filter separates at most as many modes as the beam "
                               "has accelerometer stations"),
    },
}


def validate(cfg: dict[str, Any]) -> dict[str, Any]:
    """Check a whole configuration of `sloshrom reproduce` before any stage runs.

    Every table and key of ``defaults.toml`` must be present (and no other), of the right type
    and within bounds; lists must be non-empty with valid elements; and keys must agree with
    each other (``f_min < f_max``, ``a_bar_min < a_bar_max``, one damping ratio per mode, the
    random-excitation PSD inside the simulation's band, a free response long enough for the
    damping analysis of mode 1, ...).

    Parameters
    ----------
    cfg : dict
        A merged configuration (:func:`load` returns validated ones; :func:`sloshrom.pipeline.run`
        should call this on configurations built in code).

    Returns
    -------
    dict
        ``cfg`` itself, unchanged.

    Raises
    ------
    ConfigError
        The first problem found, naming the key, e.g.
        ``'beam.rms_g' must be a non-empty list of RMS levels in g, each in (0, 2], got []``.
    """
    ref = defaults()
    if not isinstance(cfg, dict):
        raise ConfigError(f"configuration must be a dict of tables, got {type(cfg).__name__}")
    for table in cfg:
        if table not in ref:
            raise ConfigError(f"unknown configuration key '{table}'")
    for table, keys in ref.items():
        sec = cfg.get(table)
        if not isinstance(sec, dict):
            raise ConfigError(f"'{table}' must be a table" if table in cfg
                              else f"configuration table [{table}] is missing")
        for key in sec:
            if key not in keys:
                raise ConfigError(f"unknown configuration key '{table}.{key}'")
        for key in keys:
            if key not in sec:
                raise ConfigError(f"configuration key '{table}.{key}' is missing")
    try:
        tank = Tank.from_dict(dict(cfg["tank"]))
    except ConfigError as exc:
        raise ConfigError(f"[tank]: {exc}") from None
    for table, checks in _SPEC.items():
        for key, check in checks.items():
            check(f"{table}.{key}", cfg[table][key])
    _relations(cfg, tank)
    return cfg


def _relations(cfg: dict[str, Any], tank: Tank) -> None:
    """Checks that involve several keys (each value is already valid on its own)."""
    rig, m, b = cfg["rig"], cfg["map"], cfg["beam"]
    fs = rig["fs"]
    if not 25.0 <= 0.8 * fs / 2:  # implied by fs >= 100 Hz; kept explicit for the reason
        raise ConfigError(f"'rig.fs' = {fs:g} Hz leaves the VFA band (up to 25 Hz) "
                          "outside the anti-alias passband 0.8 fs/2")
    if abs(RIG_RATE / fs - round(RIG_RATE / fs)) > 1e-9:
        raise ConfigError(f"'rig.fs' = {fs:g} Hz must divide the rig's {RIG_RATE:g} Hz "
                          "integration rate (e.g. 250, 500, 1000, 2000 Hz): the beam's random "
                          "excitation is made at fs and upsampled exactly for the rig")
    if not m["f_min"] < m["f_max"]:
        raise ConfigError(f"'map.f_min' ({m['f_min']:g} Hz) must be below 'map.f_max' "
                          f"({m['f_max']:g} Hz)")
    if not m["a_bar_min"] < m["a_bar_max"]:
        raise ConfigError(f"'map.a_bar_min' ({m['a_bar_min']:g}) must be below 'map.a_bar_max' "
                          f"({m['a_bar_max']:g})")
    rom, n_train = cfg["rom"], cfg["data"]["train_duration"] * fs
    grid = [(rom["arch"], rom["delays"], rom["neurons"], "'rom.delays'/'rom.neurons'")]
    if rom["sweep"]:
        grid += [(a, max(rom[f"sweep_{a}_delays"]), max(rom[f"sweep_{a}_neurons"]),
                  f"the largest of 'rom.sweep_{a}_delays'/'rom.sweep_{a}_neurons'")
                 for a in ("nfir", "noe")]
    for arch, delays, neurons, names in grid:
        need = training_samples(arch, delays, neurons)
        if need > n_train:
            raise ConfigError(
                f"{names} = {delays}/{neurons} ({arch.upper()}) need at least {need} training "
                f"samples, but 'data.train_duration' gives {n_train:.0f} at {fs:g} Hz")
    if len(b["damping"]) < b["n_modes"]:
        raise ConfigError(f"'beam.damping' has {len(b['damping'])} ratio(s) but 'beam.n_modes' "
                          f"is {b['n_modes']}: give one damping ratio per mode")
    check_psd_band(b["f0"], b["sigma"], names=("'beam.f0'", "'beam.sigma'"), error=ConfigError,
                   fs=fs)
    if b["random_duration"] * fs < WELCH_NPERSEG:
        raise ConfigError(
            f"'beam.random_duration' = {b['random_duration']:g} s must hold at least one "
            f"{WELCH_NPERSEG}-sample Welch segment at 'rig.fs' = {fs:g} Hz "
            f"({WELCH_NPERSEG / fs:.3g} s) for the damping estimates of Table 2")
    level_seconds = b["random_duration"] * len(b["rms_g"])
    if level_seconds > MAX_LEVEL_SECONDS:
        raise ConfigError(
            f"'beam.random_duration' x {len(b['rms_g'])} levels = {level_seconds:g} s is more "
            f"than {MAX_LEVEL_SECONDS:g} s (memory: the rig holds about 2.1 MB per second and "
            "level at its 10 kHz step)")
    from sloshrom.beam.structure import CantileverBeam

    try:
        beam = CantileverBeam.with_tank(tank, **{k: b[k] for k in _BEAM_BOUNDS})
    except ConfigError as exc:
        raise ConfigError(f"[beam]: {exc}") from None
    f1 = first_frozen_frequency(tank, b["n_modes"], b["damping"][: b["n_modes"]], beam=beam)
    need = min_free_duration(f1)
    if b["free_duration"] < need:
        raise ConfigError(
            f"'beam.free_duration' = {b['free_duration']:g} s is too short for the damping "
            f"analysis of mode 1 ({f1:.3g} Hz): need at least {need:g} s "
            f"({FREE_DAMPING_PERIODS} periods)")
    check_analysis_band(f1, error=ConfigError, fs=fs)
    # the ROM and the frozen case run the structure at fs: every kept mode below Nyquist
    modes = beam.frequencies(b["n_modes"])
    if modes[-1] >= fs / 2:
        raise ConfigError(
            f"'beam.n_modes' = {b['n_modes']}: mode {b['n_modes']} of the beam "
            f"({modes[-1]:.4g} Hz) lies above the Nyquist frequency of 'rig.fs' = {fs:g} Hz: "
            "raise 'rig.fs' or keep fewer modes")


def training_samples(arch: str, delays: int, neurons: int) -> int:
    """Samples a training record needs for a ROM (the check of ``NFIR.fit``)."""
    out_delays = NOE_OUT_DELAYS if arch == "noe" else 0
    n_params = neurons * (delays + out_delays + 2) + 1  # RBF network: H (D + 2) + 1
    return delays + out_delays + 2 * n_params // 100 + 10


def first_frozen_frequency(tank: Tank, n_modes: int = 3, damping: Any = None,
                           modal_toml: str | Path | None = None, beam: Any = None) -> float:
    """First mode (Hz) of the beam with frozen liquid: the mode the damping analyses follow."""
    from sloshrom.beam.structure import ModalModel, coupled_frozen_modes

    if modal_toml is not None:
        modal = ModalModel.from_toml(modal_toml)
    else:
        modal = ModalModel.from_beam(beam, tank=tank, n_modes=n_modes, damping=damping)
    return float(coupled_frozen_modes(modal, tank.liquid_mass)[0][0])


def min_free_duration(f1: float) -> float:
    """Shortest free response (s, rounded up to 0.1 s) whose mode-1 damping can be analysed."""
    return math.ceil(10 * FREE_DAMPING_PERIODS / f1) / 10


def check_analysis_band(f1: float, error: type[ValueError] = ConfigError,
                        fs: float = BEAM_FS) -> None:
    """Mode 1 must lie well below the results' Nyquist frequency (band-pass up to 1.5 f1)."""
    if not 1.5 * f1 < 0.8 * fs / 2:
        raise error(f"the first beam mode ({f1:.4g} Hz) is too high for the {fs:g} Hz results: "
                    f"the damping analyses band-pass up to 1.5 f1, which must stay below "
                    f"{0.8 * fs / 2:g} Hz")


def check_psd_band(f0: float, sigma: float, names: tuple[str, str] = ("--f0", "--sigma"),
                   error: type[ValueError] = ConfigError, fs: float = BEAM_FS) -> None:
    """The random-excitation PSD (paper Eq. 8) must lie inside (0, Nyquist) of the signal at fs.

    The base acceleration is synthesised at ``fs`` (then upsampled band-limited for the rig):
    ``sloshrom.signals.random_base_acceleration`` needs ``f0 + 4 sigma`` below the Nyquist
    frequency, and a band reaching below 0 Hz (``f0 - 3 sigma < 0``) would fold onto positive
    frequencies and no longer be the Gaussian asked for.
    """
    n0, ns = names
    for name, v in ((n0, f0), (ns, sigma)):
        if not (_is_number(v) and math.isfinite(v) and v > 0):
            raise error(f"{name} must be a positive frequency in Hz, got {v!r}")
    nyq = fs / 2
    if f0 + 4 * sigma >= nyq:
        raise error(f"{n0} + 4 {ns} = {f0 + 4 * sigma:g} Hz must stay below {nyq:g} Hz, the "
                    f"Nyquist frequency of the {fs:g} Hz excitation (got f0 = {f0:g} Hz, "
                    f"sigma = {sigma:g} Hz)")
    if f0 - 3 * sigma < -1e-9:
        raise error(f"{n0} - 3 {ns} = {f0 - 3 * sigma:g} Hz must not be below 0 Hz (the PSD "
                    f"would fold onto positive frequencies; got f0 = {f0:g} Hz, "
                    f"sigma = {sigma:g} Hz)")
