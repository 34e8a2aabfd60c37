"""The ``data`` stage of `sloshrom reproduce`: VFA training and validation records from the
virtual rig (paper Figs. 5-7), their amplitudes designed from the beam tests they serve."""

from __future__ import annotations

from typing import Any

import numpy as np

from sloshrom import __version__, signals
from sloshrom.beam.envelope import TankMotion, frozen_tank_motion
from sloshrom.config import ConfigError, G, Tank
from sloshrom.io import record_from_measurement, write_record
from sloshrom.pipeline.beam import beam_structure, beam_tests
from sloshrom.pipeline.context import Context
from sloshrom.pipeline.settings import DataTable, ReproduceConfig
from sloshrom.plotting import savefig
from sloshrom.plotting.signals import record_io_figure, vfa_paths_figure

__all__ = ["SPLITS", "design_outputs", "record_acceleration", "replay_record", "split_settings",
           "stage_data", "training_design", "vfa_pieces"]


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


def design_outputs(design: signals.VFADesign, motion: TankMotion | None) -> dict[str, Any]:
    """The designed envelope as JSON-able outputs (g, m/s, m) and how it compares with the
    paper's shaker (``exceeds_shaker``: the limits a laboratory shaker would have to exceed)."""
    lim, paper = design.limits, signals.SHAKER_LIMITS
    return {
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


#: The records of the data stage, in the order it records them.
SPLITS = ("train", "validation")


def split_settings(data: DataTable, split: str) -> tuple[float, int]:
    """The duration (s) and seed of the paper's VFA path of record ``split`` (:data:`SPLITS`)."""
    if split == "train":
        return float(data.train_duration), int(data.train_seed)
    if split == "validation":
        return float(data.validation_duration), int(data.validation_seed)
    raise ConfigError(f"no record {split!r}: one of {SPLITS}")


def record_acceleration(cfg: ReproduceConfig, tank: Tank, split: str,
                        fs: float) -> np.ndarray:
    """The tank acceleration the data stage plays on the rig for record ``split``, m/s^2.

    Its VFA pieces (:func:`vfa_pieces`, designed by :func:`training_design`) one after the
    other at ``fs`` (Hz, the rig's integration rate): the very signal of the record, made
    again (deterministic), e.g. to play it once more with another gain.
    """
    design, motion = training_design(cfg, tank)
    duration, seed = split_settings(cfg.data, split)
    pieces = vfa_pieces(cfg.data, split, duration, seed, design, motion, fs, tank)
    return np.concatenate([p.acceleration for p in pieces])


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


def stage_data(ctx: Context) -> tuple[dict[str, Any], list[str]]:
    """Record the training and validation VFA tests on the rig; write records and figures.

    Both records share one amplitude design (:func:`training_design`).

    Returns
    -------
    outputs : dict
        Per split: ``duration_s`` (s), ``fs_hz`` (Hz), ``samples``, ``max_acceleration_g`` (g),
        ``max_velocity_m_s`` (m/s, the ROM's input), ``max_dynamic_force_n`` (N) and, with a
        structure design, ``covers_acceleration``/``covers_velocity`` (record peak / frozen
        beam tests' peak, -); ``design``: :func:`design_outputs`; ``rig``: the ``[rig]``
        physics overrides in use (empty: calibrated).
    files : list of str
        ``data/train.nc``, ``data/validation.nc`` and the figures, relative to ``ctx.out``.
    """
    cfg, tank = ctx.cfg, ctx.tank
    rig = ctx.rig()
    ctx.progress("data", 0, 3, "training design (frozen beam tests)")
    design, motion = training_design(cfg, tank)
    files, paths, records = [], [], {}
    outputs: dict[str, Any] = {"design": design_outputs(design, motion),
                               "rig": cfg.rig.overrides()}
    splits = [(split, *split_settings(cfg.data, split)) for split in SPLITS]
    fs_rig = 1.0 / rig.dt
    for k, (split, duration, seed) in enumerate(splits):
        ctx.progress("data", k + 1, len(splits) + 1, f"rig VFA {split} ({duration:.0f} s)")
        pieces = vfa_pieces(cfg.data, split, duration, seed, design, motion, fs_rig, tank)
        meas = rig.measure(np.concatenate([p.acceleration for p in pieces]))
        sig = pieces[0]
        rec = record_from_measurement(
            meas, tank, truth=True, split=split, seed=int(seed),
            rig_seed=int(cfg.rig.seed),
            provenance=f"sloshrom {__version__} reproduce: virtual rig VFA {split} "
                       f"({design.rule} design, {design.gamma_max:.3g} g)",
        )
        p = ctx.path("data", f"{split}.nc")
        write_record(rec, p)
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
        del sig, meas
    ctx.progress("data", len(splits) + 1, len(splits) + 1, "figures")
    p = savefig(vfa_paths_figure(paths), ctx.path("figures", "fig05_vfa_paths.png"))
    files.append(ctx.rel(p))
    for split, name in (("train", "fig06_train_io.png"), ("validation", "fig07_validation_io.png")):
        p = savefig(record_io_figure(records[split], split), ctx.path("figures", name))
        files.append(ctx.rel(p))
    return outputs, files
