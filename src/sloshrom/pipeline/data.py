"""The ``data`` stage of `sloshrom reproduce`: VFA training and validation records from the
virtual rig (paper Figs. 5-7), their amplitudes designed from the beam tests they serve."""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any, NotRequired, TypedDict

import numpy as np

from sloshrom import __version__, signals
from sloshrom._threads import map_threads
from sloshrom.beam.simulation.envelope import TankMotion, frozen_tank_motion
from sloshrom.beam.simulation.programme import (
    Programme,
    Segment,
    concatenate,
    structure_segments,
)
from sloshrom.config import ConfigError, G, Tank
from sloshrom.io import Record, record_from_measurement, write_record
from sloshrom.pipeline.beam import beam_structure, beam_tests
from sloshrom.pipeline.context import Context, StageRecord
from sloshrom.pipeline.settings import DataTable, ReproduceConfig
from sloshrom.plotting import savefig
from sloshrom.plotting.signals import record_io_figure, vfa_paths_figure

__all__ = ["LAB_SETUP", "Peaks", "ProgrammeOutputs", "SegmentOutputs", "design_outputs",
           "programme", "programme_outputs", "record_acceleration", "replay_record",
           "SPLITS", "split_settings", "stage_data", "training_design", "use_segments",
           "to_ms", "vfa_pieces"]

#: Laboratory set-up per segment, s: loading the drive file and the controller's low-level
#: pre-test (equalisation) before each run
#: (:meth:`sloshrom.beam.simulation.programme.Programme.lab_time`).
LAB_SETUP = 60.0


class Peaks(TypedDict):
    """Peak amplitudes of a motion from rest: g, m/s, mm."""

    acceleration_g: float
    velocity_m_s: float
    stroke_mm: float


class SegmentOutputs(TypedDict):
    """One segment of :class:`ProgrammeOutputs` (``start_s``, ``duration_s`` in s, to the
    millisecond; ``first_sample`` and ``samples`` exact, at the programme's rate)."""

    index: int
    name: str
    kind: str
    level: float
    level_unit: str
    start_s: float
    duration_s: float
    first_sample: int
    samples: int
    peaks: Peaks


class ProgrammeOutputs(TypedDict):
    """A programme as JSON (:func:`programme_outputs`); ``drive`` and ``files`` are added by
    ``sloshrom design`` (the drive files' rate, samples and names)."""

    segments: list[SegmentOutputs]
    peaks: Peaks
    duration_s: float
    pause_s: float
    fs_hz: float
    lab_time_s: float
    setup_s: float
    limits: dict[str, float | None]
    exceeds: list[str]
    fits: bool
    verdict: str
    drive: NotRequired[dict[str, float]]
    files: NotRequired[dict[str, str]]


#: What a segment's ``level`` means, by kind.
LEVEL_UNITS = {"vfa": "g peak (design)", "random": "g RMS base",
               "decay": "x tip displacement"}


def training_design(cfg: ReproduceConfig, tank: Tank
                    ) -> tuple[signals.VFADesign, TankMotion | None]:
    """The amplitude limits of the VFA records (``[data] design``).

    ``"shaker"``: the paper's shaker (:data:`sloshrom.signals.SHAKER_DESIGN`: 6 g, 1 m/s,
    12.5 mm, a_bar 0.45). ``"structure"``: the configured beam tests (free response and random
    excitation at every ``[beam] rms_g``, the very signals of the ``beam`` stage,
    :func:`sloshrom.pipeline.beam.beam_tests`) are run first with frozen liquid, the
    least-damped case whose tank motion bounds that of the rig and ROM runs; the VFA then
    covers ``[data] margin`` times their peak tank acceleration and velocity
    (:func:`sloshrom.signals.vfa_design`), never less than the paper's shaker.

    Parameters
    ----------
    cfg : ReproduceConfig
        The validated configuration.
    tank : Tank

    Returns
    -------
    design : VFADesign
    motion : TankMotion or None
        The frozen beam tests' tank motion (``None`` for ``"shaker"``).
    """
    if cfg.data.design == "shaker":
        return signals.SHAKER_DESIGN, None
    fs = float(cfg.rig.fs)  # the beam stage's record rate, hence its signals
    _, modal = beam_structure(cfg.beam, tank)
    motion = frozen_tank_motion(beam_tests(cfg.beam, modal, tank, fs), fs)
    design = signals.vfa_design(motion.peak_acceleration, motion.peak_velocity,
                                motion.peak_displacement, motion.frequency, tank,
                                margin=float(cfg.data.margin))
    return design, motion


def design_outputs(design: signals.VFADesign, motion: TankMotion | None,
                   programmes: Mapping[str, ProgrammeOutputs] | None = None
                   ) -> dict[str, Any]:
    """The designed envelope as JSON-able outputs (g, m/s, m) and how it compares with the
    paper's shaker (``exceeds_shaker``: the limits a laboratory shaker would have to exceed).

    ``programmes``: per split, the shaker programme of the record
    (:func:`programme_outputs`), stored as ``programme``."""
    lim, paper = design.limits, signals.SHAKER_LIMITS
    out = {
        "rule": design.rule,
        "margin": design.margin,
        "gamma_max_g": design.gamma_max,
        "a_bar_max": design.a_bar_max,
        "max_velocity_m_s": lim.max_velocity,
        "max_displacement_m": lim.max_displacement,
        "paper_shaker": {"gamma_max_g": paper.max_acceleration / G,
                         "max_velocity_m_s": paper.max_velocity,
                         "max_displacement_m": paper.max_displacement},
        "exceeds_shaker": design.exceeds(),
        "frozen_beam_tests": None if motion is None else motion.as_dict(),
    }
    if programmes is not None:
        out["programme"] = dict(programmes)
    return out


def vfa_pieces(data: DataTable | None, split: str, duration: float, seed: int,
               design: signals.VFADesign, motion: TankMotion | None, fs: float,
               tank: Tank) -> list[signals.VFA]:
    """The VFA tank motions of one record, played one after the other (each starts and ends at
    rest).

    Always the paper's path over the paper's shaker domain (``duration`` s): the domain of the
    Phi_d maps, sampled as densely as in the paper. With a structure design
    (``motion`` given) it is followed by an extension of ``extension_duration`` s (half of it
    for the validation record) whose amplitude limits are ``design``'s and whose frequency
    sweeps ``f1 / extension_band .. f1 * extension_band`` (within the shaker's 5-25 Hz band),
    f1 the frozen beam tests' frequency: the structure's own range, without thinning the data
    of the map's domain (a single path over 0-20 g left the network less detail below 6 g:
    docs/rom.md). ``data`` (the ``[data]`` table) is read only for the extension.
    """
    pieces = [signals.vfa(fs, split=split, duration=duration, tank=tank, seed=seed,
                          **signals.SHAKER_DESIGN.kwargs())]
    if motion is not None:
        ext = float(data.extension_duration) * (1.0 if split == "train" else 0.5)
        band = float(data.extension_band)
        f_lo = max(signals.SHAKER_ENVELOPE.f_min, motion.frequency / band)
        f_hi = min(signals.SHAKER_ENVELOPE.f_max, motion.frequency * band)
        pieces.append(signals.vfa(fs, split=split, duration=ext,
                                  tank=tank, seed=seed, f_min=f_lo, f_max=f_hi,
                                  **design.kwargs()))
    return pieces


def use_segments(cfg: ReproduceConfig, tank: Tank, split: str, fs: float) -> list[Segment]:
    """The structure's own kinds of motion for a ``"use"`` design
    (:mod:`sloshrom.beam.simulation.programme`).

    Narrow-band random segments (the frozen structure's tank motion under the ``[beam]``
    random test's PSD) at every ``[beam] rms_g`` level times every ``[data] random_factors``,
    ``random_duration`` s each (half for validation), then decays from ``[data]
    decay_factors`` times ``[beam] tip_displacement``. The phase seeds, ``1000 x`` the split's
    ``[data]`` seed plus the segment's index, are apart from the beam tests' (``[beam] seed``)
    so that no test signal is trained on. ``fs``: the rig's rate, Hz.
    """
    data, beam = cfg.data, cfg.beam
    _, modal = beam_structure(beam, tank)
    levels = sorted({round(float(g) * float(c), 6) for g in beam.rms_g
                     for c in data.random_factors})
    seed = 1000 * int(data.train_seed if split == "train" else data.validation_seed)
    duration = float(data.random_duration) * (1.0 if split == "train" else 0.5)
    return structure_segments(modal, tank, fs, float(cfg.rig.fs), levels, duration, seed,
                              float(beam.f0), float(beam.sigma), float(beam.tip_displacement),
                              [float(c) for c in data.decay_factors],
                              float(data.decay_duration))


#: The records of the data stage, in the order it records them.
SPLITS = ("train", "validation")


def split_settings(data: DataTable, split: str) -> tuple[float, int]:
    """The duration (s) and seed of the paper's VFA path of record ``split`` (:data:`SPLITS`)."""
    if split == "train":
        return float(data.train_duration), int(data.train_seed)
    if split == "validation":
        return float(data.validation_duration), int(data.validation_seed)
    raise ConfigError(f"no record {split!r}: one of {SPLITS}")


def programme(cfg: ReproduceConfig, tank: Tank, split: str, fs: float, *,
              training: tuple[signals.VFADesign, TankMotion | None] | None = None
              ) -> Programme:
    """The shaker programme of a split's record: what the rig (or a laboratory) plays.

    The VFA pieces (:func:`vfa_pieces`: the paper's path, then with a structure or use design
    the extension), then with ``[data] design = "use"`` the structure's own motion
    (:func:`use_segments`); every segment starts and ends at rest, played back to back (no
    pause). The data stage records exactly this; ``sloshrom design`` writes it as drive files.

    Parameters
    ----------
    cfg : ReproduceConfig
    tank : Tank
    split : str
        ``"train"`` or ``"validation"``.
    fs : float
        Rate of the programme, Hz (the rig's integration rate, 10 kHz).
    training : (VFADesign, TankMotion or None), optional
        :func:`training_design`'s result if already computed (it runs the frozen beam tests).

    Returns
    -------
    Programme
        Segments ``"vfa"`` (level: the paper shaker's 6 g), ``"vfa extension"`` (the design's
        peak, g), ``"random <level> g"`` and ``"decay <factor>"``.
    """
    duration, seed = split_settings(cfg.data, split)
    design, motion = training_design(cfg, tank) if training is None else training
    pieces = vfa_pieces(cfg.data, split, duration, seed, design, motion, fs, tank)
    names = [("vfa", signals.SHAKER_DESIGN.gamma_max), ("vfa extension", design.gamma_max)]
    segments = [Segment(name, "vfa", p.acceleration, float(level))
                for (name, level), p in zip(names, pieces, strict=False)]
    if cfg.data.design == "use":
        segments += use_segments(cfg, tank, split, fs)
    return concatenate(fs, segments)


def _peaks(m: Mapping[str, float]) -> Peaks:
    return {"acceleration_g": m["acceleration"] / G, "velocity_m_s": m["velocity"],
            "stroke_mm": m["displacement"] * 1e3}


def to_ms(t: float) -> float:
    """A time in s to the millisecond (what the programme's outputs show a person)."""
    return round(float(t), 3)


def programme_outputs(prog: Programme, limits: signals.ShakerLimits = signals.SHAKER_LIMITS,
                      setup: float = LAB_SETUP, max_duration: float | None = None
                      ) -> ProgrammeOutputs:
    """A programme as JSON-able outputs: its segments, peaks, duration, laboratory time and the
    shaker limits it exceeds.

    Parameters
    ----------
    prog : Programme
    limits : ShakerLimits
        The shaker it is checked against (default the paper's: 6 g, 1 m/s, 12.5 mm).
    setup : float
        Laboratory set-up per segment, s.
    max_duration : float, optional
        Longest run the shaker allows, s.

    Returns
    -------
    dict
        ``segments`` (``index`` from 1, ``name``, ``kind``, ``level`` and ``level_unit``,
        ``start_s``, ``duration_s``, ``peaks``), ``peaks`` (``acceleration_g``,
        ``velocity_m_s``, ``stroke_mm``: amplitudes from rest), ``duration_s``, ``pause_s``,
        ``fs_hz``, ``lab_time_s``, ``setup_s``, ``limits``, ``exceeds`` (one sentence per
        limit, :meth:`Programme.check`), ``fits`` and ``verdict`` (a sentence: whether the
        shaker can play it, and what a shaker that can must reach).
    """
    segs: list[SegmentOutputs] = []
    start = 0  # the segment's first sample in the programme
    for k, s in enumerate(prog.segments):
        one = concatenate(prog.fs, [s])
        n = int(np.size(s.acceleration))
        # to the millisecond: a VFA of 480 s holds 480 fs + 1 samples (at rest at both
        # ends), a random test of 25 s 25 fs; a person reads 480 s, not 480.0001 s
        segs.append({"index": k + 1, "name": s.name, "kind": s.kind, "level": s.level,
                     "level_unit": LEVEL_UNITS[s.kind], "start_s": to_ms(start / prog.fs),
                     "duration_s": to_ms(one.duration), "first_sample": start, "samples": n,
                     "peaks": _peaks(one.motion())})
        start += n + round(prog.pause * prog.fs)
    exceeds = prog.check(limits, max_duration)
    peaks = _peaks(prog.motion())
    shaker = (f"{limits.max_acceleration / G:.3g} g, {limits.max_velocity:.3g} m/s, "
              f"{limits.max_displacement * 1e3:.3g} mm")
    verdict = (f"fits the shaker ({shaker})" if not exceeds else
               f"needs a bigger shaker than {shaker}: it reaches "
               f"{peaks['acceleration_g']:.3g} g, {peaks['velocity_m_s']:.3g} m/s and "
               f"{peaks['stroke_mm']:.4g} mm")
    return {
        "segments": segs,
        "peaks": peaks,
        "duration_s": to_ms(prog.duration),
        "pause_s": prog.pause,
        "fs_hz": prog.fs,
        "lab_time_s": to_ms(prog.lab_time(setup)),
        "setup_s": setup,
        "limits": {"acceleration_g": limits.max_acceleration / G,
                   "velocity_m_s": limits.max_velocity,
                   "stroke_mm": limits.max_displacement * 1e3,
                   "max_duration_s": max_duration},
        "exceeds": exceeds,
        "fits": not exceeds,
        "verdict": verdict,
    }


def record_acceleration(cfg: ReproduceConfig, tank: Tank, split: str,
                        fs: float) -> np.ndarray:
    """The tank acceleration the data stage plays on the rig for record ``split``, m/s^2.

    Its :func:`programme` at ``fs`` (Hz, the rig's integration rate): the very signal of the
    record, made again (deterministic), e.g. to play it once more with another gain.
    """
    return programme(cfg, tank, split, fs).acceleration()


def replay_record(ctx: Context, split: str, gain: float) -> np.ndarray:
    """Record ``split``'s dynamic force (N, at the record rate) from the rig with the record's
    input times ``gain``: the rig's twin run (:mod:`sloshrom.pipeline.waveform`).

    The input is made again (:func:`record_acceleration`) and goes through the same rig,
    sensors and preprocessing as in :func:`stage_data`: with ``gain = 1`` the result equals the
    record's ``dynamic_force`` exactly.
    """
    rig = ctx.rig()
    acc = record_acceleration(ctx.cfg, ctx.tank, split, 1.0 / rig.dt)
    rec = record_from_measurement(rig.measure(acc * gain), ctx.tank, truth=False)
    return np.asarray(rec["dynamic_force"])


def stage_data(ctx: Context) -> StageRecord:
    """Record the training and validation VFA tests on the rig; write records and figures.

    Both records share one amplitude design (:func:`training_design`); each plays the split's
    :func:`programme`.

    Returns
    -------
    outputs : dict
        Per split: ``duration_s`` (s), ``fs_hz`` (Hz), ``samples``, ``max_acceleration_g`` (g),
        ``max_velocity_m_s`` (m/s, the ROM's input), ``max_dynamic_force_n`` (N) and, with a
        structure design, ``covers_acceleration``/``covers_velocity`` (record peak / frozen
        beam tests' peak, -); ``design``: :func:`design_outputs`, with ``programme``: per
        split the shaker programme played (:func:`programme_outputs` against the paper's
        shaker); ``rig``: the ``[rig]`` physics overrides in use (empty: calibrated).
    files : list of str
        ``data/train.nc``, ``data/validation.nc`` and the figures, relative to ``ctx.out``.
    """
    cfg, tank = ctx.cfg, ctx.tank
    rig = ctx.rig()
    ctx.progress("data", 0, 3, "training design (frozen beam tests)")
    design, motion = training_design(cfg, tank)
    fs_rig = 1.0 / rig.dt

    def record(split: str) -> tuple[Record, ProgrammeOutputs, list[signals.VFA], Path]:
        duration, seed = split_settings(cfg.data, split)
        prog = programme(cfg, tank, split, fs_rig, training=(design, motion))
        meas = rig.measure(prog.acceleration())
        played = programme_outputs(prog)
        del prog  # ~80 MB per 1000 s at the rig's 10 kHz
        rec = record_from_measurement(
            meas, tank, truth=True, split=split, seed=int(seed),
            rig_seed=int(cfg.rig.seed),
            provenance=f"sloshrom {__version__} reproduce: virtual rig VFA {split} "
                       f"({design.rule} design, {design.gamma_max:.3g} g)",
        )
        del meas
        p = ctx.path("data", f"{split}.nc")
        write_record(rec, p)
        # the paths of Fig. 5 at the record rate: the same path, 20 times fewer samples
        paths = vfa_pieces(cfg.data, split, duration, seed, design, motion,
                           float(cfg.rig.fs), tank)
        return rec, played, paths, p

    ctx.progress("data", 1, 3, "rig VFA " + ", ".join(
        f"{split} ({split_settings(cfg.data, split)[0]:.0f} s)" for split in SPLITS))
    # the records in threads, a core each: the rig's and the filters' loops release the GIL
    done = map_threads(record, SPLITS)
    files, paths, records = [], [], {}
    outputs: dict[str, Any] = {"rig": cfg.rig.overrides()}
    programmes: dict[str, ProgrammeOutputs] = {}
    for split, (rec, played, pieces, p) in zip(SPLITS, done, strict=True):
        programmes[split] = played
        files.append(ctx.rel(p))
        paths.extend(pieces)
        records[split] = rec
        peak_acc = float(np.max(np.abs(rec["acceleration"])))
        peak_vel = float(np.max(np.abs(rec["velocity"])))
        outputs[split] = {
            "duration_s": float(rec.duration),
            "fs_hz": float(rec.fs),
            "samples": len(rec),
            "max_acceleration_g": peak_acc / G,
            "max_velocity_m_s": peak_vel,
            "max_dynamic_force_n": float(np.max(np.abs(rec["dynamic_force"]))),
        }
        if motion is not None:
            outputs[split]["covers_acceleration"] = peak_acc / motion.peak_acceleration
            outputs[split]["covers_velocity"] = peak_vel / motion.peak_velocity
    outputs = {"design": design_outputs(design, motion, programmes), **outputs}
    ctx.progress("data", 2, 3, "figures")
    p = savefig(vfa_paths_figure(paths), ctx.path("figures", "fig05_vfa_paths.png"))
    files.append(ctx.rel(p))
    for split, name in (("train", "fig06_train_io.png"), ("validation", "fig07_validation_io.png")):
        p = savefig(record_io_figure(records[split], split), ctx.path("figures", name))
        files.append(ctx.rel(p))
    return outputs, files
