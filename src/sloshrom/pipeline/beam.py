"""The ``beam`` stage of `sloshrom reproduce`: sloshing-beam tests with rig, ROM and frozen liquid
(paper Sect. 4-5: Table 1, Figs. 14, 16-18, 20-23, Table 2)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from sloshrom.beam.coupled import free_response, random_response
from sloshrom.beam.results import (
    Simulate,
    damping_summary,
    envelope_table,
    frozen_modes_table,
    mode1_damping_table,
    mode1_decay,
    simulate_cases,
    to_dataset,
    write_dataset,
    write_table,
)
from sloshrom.beam.structure import CantileverBeam, ModalModel, coupled_frozen_modes
from sloshrom.config import Tank
from sloshrom.fileio import OutputBatch
from sloshrom.models import FrozenLiquid, SloshingModel
from sloshrom.pipeline.context import Context
from sloshrom.pipeline.settings import BeamTable
from sloshrom.plotting import savefig
from sloshrom.plotting.beam import free_figures, random_figures, random_window
from sloshrom.plotting.signals import base_excitation_figure
from sloshrom.rom.ensemble import Ensemble, is_ensemble, spread
from sloshrom.rom.estimators import load_model

__all__ = ["BEAM_KEYS", "beam_structure", "beam_tests", "member_spread", "stage_beam"]

#: Keys of the ``[beam]`` table that define the Euler-Bernoulli beam.
BEAM_KEYS = ("length", "width", "thickness", "youngs_modulus", "density")


def beam_structure(cfg: BeamTable, tank: Tank) -> tuple[CantileverBeam, ModalModel]:
    """The dry beam of the ``[beam]`` configuration and its modal model.

    Virtual accelerometers at the default stations, 1/5, 2/5, ..., 5/5 of the length (the last
    at the tank).
    """
    beam = CantileverBeam.with_tank(tank, **{k: getattr(cfg, k) for k in BEAM_KEYS})
    damping = cfg.damping[: cfg.n_modes]  # one ratio per kept mode (extra ones unused)
    modal = ModalModel.from_beam(beam, tank, n_modes=cfg.n_modes, damping=damping)
    return beam, modal


def beam_tests(cfg: BeamTable, modal: ModalModel, tank: Tank,
               fs: float) -> dict[str, Simulate]:
    """The beam tests of the ``[beam]`` configuration, as ``simulate(model, output_fs)``.

    ``"free"``: release from the static tip deflection ``tip_displacement`` for
    ``free_duration``; ``"random"``: Gaussian-PSD base acceleration at every ``rms_g`` (``seed``,
    ``f0``, ``sigma``, ``random_duration``), made at ``fs`` (Hz). The ``beam`` stage runs them
    with every model, the ``data`` stage with frozen liquid to design the training
    (:func:`sloshrom.pipeline.data.training_design`): one definition, the same signals.
    """
    return {
        "free": lambda m, out_fs: free_response(m, modal, cfg.tip_displacement,
                                                cfg.free_duration, tank, out_fs),
        "random": lambda m, out_fs: random_response(m, modal, cfg.rms_g,
                                                    cfg.random_duration, cfg.seed,
                                                    cfg.f0, cfg.sigma, signal_fs=fs,
                                                    tank=tank, output_fs=out_fs),
    }


def stage_beam(ctx: Context, rom_path: Path | None) -> tuple[dict[str, Any], list[str]]:
    """Free and random responses of the beam with frozen liquid, the rig and the ROM.

    Returns
    -------
    outputs : dict
        ``f1_frozen_hz`` (Hz), ``table1`` (rows of Table 1), ``instantaneous_damping`` (per case:
        banded median first-mode damping, ``sloshrom.beam.results.damping_summary``),
        ``table2`` (rows of Table 2) and ``envelope`` (per run and case: peak tank acceleration
        against the model's training envelope, ``sloshrom.beam.results.envelope_table``;
        ``None`` = n/a for a model without an envelope).
    files : list of str
        ``beam/{free,random}_<case>.nc`` (with the envelope coverage,
        ``sloshrom.beam.results.to_dataset``), the tables and the figures, relative to ``ctx.out``;
        they appear together once everything has succeeded.
    """
    cfg = ctx.cfg.beam
    fs = float(ctx.cfg.rig.fs)  # the beam's sensors record at the rig's record rate
    tank = ctx.tank
    out = ctx.out / "beam"
    out.mkdir(parents=True, exist_ok=True)
    beam, modal = beam_structure(cfg, tank)
    models: dict[str, SloshingModel] = {"frozen": FrozenLiquid(1.0 / fs), "rig": ctx.rig()}
    if rom_path is not None:
        models["rom"] = load_model(rom_path)
    outputs: dict[str, Any] = {}
    f1 = float(coupled_frozen_modes(modal, tank.liquid_mass)[0][0])
    outputs["f1_frozen_hz"] = f1
    rows = frozen_modes_table(tank, modal, beam)
    outputs["table1"] = rows

    steps = 2 * len(models)
    done = [0]

    def report(test: str):
        def on_case(case: str) -> None:
            ctx.progress("beam", done[0], steps, f"{test} response: {case}")
            done[0] += 1
        return on_case

    tests = beam_tests(cfg, modal, tank, fs)
    free_res = simulate_cases(models, tests["free"], fs, report("free"))
    rand_res = simulate_cases(models, tests["random"], fs, report("random"))
    ctx.progress("beam", steps, steps, "analysis and figures")

    decays = {case: mode1_decay(r, modal, f1) for case, r in free_res.items()}
    outputs["instantaneous_damping"] = damping_summary(free_res, decays)
    table2 = mode1_damping_table(rand_res, cfg.rms_g, f1, max_tank_acceleration=True)
    outputs["table2"] = table2
    outputs["envelope"] = envelope_table({"free": free_res, "random": rand_res})

    if is_ensemble(models.get("rom")):
        outputs["rom_members"] = member_spread(models["rom"], tests, modal, cfg.rms_g, fs,
                                               f1, ctx)

    figs = {**free_figures(free_res, modal, decays),
            **random_figures(rand_res, cfg.rms_g, random_window(cfg.random_duration))}
    figs["fig17_base_excitation"] = base_excitation_figure(rand_res["frozen"], cfg.rms_g,
                                                           cfg.f0, cfg.sigma, fs)
    # every result file of the stage appears together, once everything above has succeeded
    with OutputBatch() as batch:
        for case in models:
            for kind, res in (("free", free_res), ("random", rand_res)):
                write_dataset(to_dataset(res[case], case, kind, tank, modal, cfg.seed),
                              out / f"{kind}_{case}.nc", batch)
        write_table(rows, out / "table1_frozen_modes", batch)
        write_table(table2, out / "table2_mode1_damping", batch)
        for name, fig in figs.items():
            savefig(fig, ctx.path("figures", f"{name}.png"), batch)
        files = [ctx.rel(p) for p in batch.paths]
    return outputs, files


def member_spread(ens: Ensemble, tests: dict[str, Simulate], modal: ModalModel,
                  levels: list[float], fs: float, f1: float,
                  ctx: Context | None = None) -> dict[str, Any]:
    """The beam tests (:func:`beam_tests`) with each member of an ensemble ROM alone.

    Returns
    -------
    dict
        ``table2``: per RMS level (g, as text) the spread (mean ± std over members,
        ``sloshrom.rom.ensemble.spread``) of the first-mode damping ratio, LSCF on H1 (-);
        ``instantaneous_damping``: per amplitude band the spread of the banded median
        first-mode damping of the free response (-).
    """
    members = {f"member{k}": m for k, m in enumerate(ens.members_)}
    if ctx is not None:
        ctx.progress("beam", 0, 1, f"beam tests of the {len(members)} members")
    free = simulate_cases(members, tests["free"], fs)
    rand = simulate_cases(members, tests["random"], fs)
    rows = mode1_damping_table(rand, levels, f1)
    table2 = {f"{lv:g}": spread(r["lscf_h1"] for r in rows if r["rms_g"] == lv)
              for lv in levels}
    inst = damping_summary(free, {c: mode1_decay(r, modal, f1) for c, r in free.items()})
    bands = [k for k in next(iter(inst.values())) if k != "initial_tank_acceleration_g"]
    return {"table2": table2,
            "instantaneous_damping": {b: spread(v[b] for v in inst.values()) for b in bands}}
