"""The ``beam`` stage of `sloshrom reproduce`: sloshing-beam tests with rig, ROM and frozen liquid
(paper Sect. 4-5: Table 1, Figs. 14, 16-18, 20-23, Table 2).

The rig plays the laboratory as well: its beam runs are written as the UFF 58 files a test lab
hands over (station and base accelerometers, with sensor noise), read back and analysed as a
measurement (``sloshrom analyse``), and the predictions are compared with it, interval by
interval (``sloshrom compare``).

An ensemble ROM is coupled member by member (:func:`coupled_model`): the ROM's prediction is
the mean of its members' responses and of their damping estimates, with their spread in its
uncertainty (``sloshrom.beam.simulation.members``).
"""

from __future__ import annotations

import contextvars
import functools
import multiprocessing
import os
import tempfile
import time
import warnings
from collections.abc import Callable, Iterator, Mapping, Sequence
from concurrent.futures import Executor, Future, ProcessPoolExecutor
from concurrent.futures.process import BrokenProcessPool
from contextlib import contextmanager
from pathlib import Path
from typing import TYPE_CHECKING, Any, TypeVar, cast

import xarray as xr

from sloshrom._threads import numba_threadsafe, usable_cores
from sloshrom._workers import worker_init
from sloshrom.beam.compare import analysed_test, compare_rows
from sloshrom.beam.damping.columns import table2_rows
from sloshrom.beam.damping.registry import REFERENCE, TABLE2
from sloshrom.beam.damping.tables import (
    Mode1Decay,
    damping_band_table,
    damping_summary,
    member_damping_datasets,
    mode1_damping_dataset,
    mode1_decay,
)
from sloshrom.beam.damping.uncertainty import BANDS
from sloshrom.beam.errors import BeamError
from sloshrom.beam.lab.channels import station_model
from sloshrom.beam.lab.measured import (
    check_free_decay,
    check_random_base,
    read_free_test,
    read_random_test,
)
from sloshrom.beam.lab.virtual import lab_test_paths, write_lab_test
from sloshrom.beam.results import to_dataset, write_dataset, write_table
from sloshrom.beam.simulation.cases import (
    CaseResults,
    Simulate,
    envelope_table,
    frozen_modes_table,
    simulate_cases,
)
from sloshrom.beam.simulation.coupled import free_response, random_response
from sloshrom.beam.simulation.members import Members
from sloshrom.beam.simulation.structure import CantileverBeam, ModalModel, coupled_frozen_modes
from sloshrom.config import Tank
from sloshrom.errors import Note
from sloshrom.fileio import OutputBatch
from sloshrom.models import FrozenLiquid
from sloshrom.pipeline.context import Context, StageRecord, in_thread
from sloshrom.pipeline.settings import BeamTable
from sloshrom.pipeline.waveform import free_fidelity, random_fidelity
from sloshrom.plotting import savefig
from sloshrom.plotting.beam import (
    comparison_figures,
    free_figures,
    random_figures,
    random_window,
)
from sloshrom.plotting.force import force_figures
from sloshrom.plotting.signals import base_excitation_figure
from sloshrom.rom.ensemble import Ensemble, is_ensemble, spread
from sloshrom.rom.loading import load_model

if TYPE_CHECKING:
    from matplotlib.figure import Figure

__all__ = ["ANALYSIS_WORKERS", "BEAM_KEYS", "EXPERIMENT", "analysis_pool", "beam_structure",
           "beam_tests", "collected", "coupled_model", "coupled_models", "laboratory",
           "member_spread", "stage_beam"]

R = TypeVar("R")

#: Case name of the rig playing the laboratory (its runs read back from the lab's files).
EXPERIMENT = "experiment"
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
               fs: float, gain: float = 1.0) -> dict[str, Simulate]:
    """The beam tests of the ``[beam]`` configuration, as ``simulate(model, output_fs)``.

    ``"free"``: release from the static tip deflection ``tip_displacement`` for
    ``free_duration``; ``"random"``: Gaussian-PSD base acceleration at every ``rms_g`` (``seed``,
    ``f0``, ``sigma``, ``random_duration``), made at ``fs`` (Hz). The ``beam`` stage runs them
    with every model, the ``data`` stage with frozen liquid to design the training
    (:func:`sloshrom.pipeline.data.training_design`): one definition, the same signals.
    ``gain`` scales the random tests' base excitation (the rig's twin run,
    :mod:`sloshrom.pipeline.waveform`; 1 = as configured).
    """
    return {
        "free": lambda m, out_fs: free_response(m, modal, cfg.tip_displacement,
                                                cfg.free_duration, tank, out_fs),
        "random": lambda m, out_fs: random_response(m, modal, cfg.rms_g,
                                                    cfg.random_duration, cfg.seed,
                                                    cfg.f0, cfg.sigma, signal_fs=fs,
                                                    tank=tank, output_fs=out_fs, gain=gain),
    }


def coupled_model(model: object) -> object:
    """A beam case's model as it is coupled to the structure.

    An ensemble ROM (``sloshrom.rom.ensemble.Ensemble``) becomes its
    :class:`~sloshrom.beam.simulation.members.Members`: each member coupled alone, the case's
    response the members' mean (``sloshrom.beam.simulation.cases.simulate_cases``), never the
    ensemble's mean force in one closed loop. With one model per tank (a list), member k of every
    ensemble runs together, the other tanks' models in every member's run; the ensembles must then
    have as many members. Any other model is returned as it is.

    Raises
    ------
    BeamError
        Ensembles of different sizes in the tanks of one case.
    """
    if is_ensemble(model):
        return Members(tuple(cast(Ensemble, model).members_))
    if isinstance(model, (list, tuple)) and any(is_ensemble(m) for m in model):
        ens = {i: cast(Ensemble, m) for i, m in enumerate(model) if is_ensemble(m)}
        sizes = {len(e.members_) for e in ens.values()}
        if len(sizes) > 1:
            raise BeamError(f"the tanks' ensemble ROMs have {sorted(sizes)} members: coupling "
                            "member by member needs as many members in each")
        return Members(tuple([ens[i].members_[k] if i in ens else m
                              for i, m in enumerate(model)] for k in range(sizes.pop())))
    return model


def coupled_models(models: Mapping[str, object]) -> dict[str, object]:
    """:func:`coupled_model` of every case (case name -> model or list of models)."""
    return {case: coupled_model(m) for case, m in models.items()}


#: Processes of the random tests' damping analyses at most: the cases and levels of one table
#: (rig and frozen liquid, or the ROM's two members, at three levels).
ANALYSIS_WORKERS = 6


@contextmanager
def analysis_pool(workers: int | None = None) -> Iterator[Executor | None]:
    """Processes that run the damping analyses of the random tests (Table 2), one a core.

    The bootstrap of each interval (~1.6 s a case and level, NumPy and SciPy: threads share one
    core under the GIL) runs in a process of its own; the processes start at once and import
    the analysis while the caller simulates. ``None`` (the analyses run in the caller) with one
    core. The results are those of the caller's own run, to the bit. A script that runs the
    stage from Python needs the ``if __name__ == "__main__":`` guard, as for the ROM's Dask
    workers (a spawned process imports the script again); without it the pool breaks and the
    stage analyses in its own process (:func:`collected`).

    Parameters
    ----------
    workers : int, optional
        Processes; default: the usable cores, at most :data:`ANALYSIS_WORKERS`.
    """
    n = min(len(usable_cores()), ANALYSIS_WORKERS) if workers is None else int(workers)
    if n < 2:
        yield None
        return
    # spawn, not fork: the caller runs XLA's and numba's threads. Each worker imports the
    # analysis as it starts; a process starts per task submitted while none is idle, so n
    # empty tasks start them all now
    # the workers end with this process, however it ends (a pool's workers would stay)
    pool = ProcessPoolExecutor(n, mp_context=multiprocessing.get_context("spawn"),
                               initializer=worker_init,
                               initargs=(os.getpid(), "sloshrom.beam.damping.tables"))
    failed = True
    try:
        for _ in range(n):
            pool.submit(time.sleep, 0.0)
        yield pool
        failed = False
    finally:
        pool.shutdown(wait=True, cancel_futures=failed)  # the caller failed: no analysis more


def collected(work: Future[R] | None, analyses: Callable[[Executor | None], R]) -> R:
    """The result of ``work`` (``analyses(pool)`` started in a thread), or ``analyses(None)``
    run here: without ``work``, or when the pool's processes failed. A process that cannot
    start (a script run without ``if __name__ == "__main__":``, which a spawned process
    imports again) or that died breaks the pool; the same analyses then run in this process,
    and a :class:`~sloshrom.errors.Note` says so."""
    if work is None:
        return analyses(None)
    try:
        return work.result()
    except BrokenProcessPool as exc:
        warnings.warn(Note(f"the damping analyses ran in this process: their worker processes "
                           f"failed ({exc})"), stacklevel=2)
        return analyses(None)


def stage_beam(ctx: Context, rom_path: Path | None) -> StageRecord:
    """Free and random responses of the beam with frozen liquid, the rig and the ROM.

    Returns
    -------
    outputs : dict
        ``f1_frozen_hz`` (Hz), ``table1`` (rows of Table 1), ``instantaneous_damping`` (per case:
        banded median first-mode damping, ``sloshrom.beam.damping.tables.damping_summary``),
        ``table2`` (rows of Table 2 with 95 % intervals, the simulated cases and the
        :data:`EXPERIMENT`), ``damping_bands`` (free decays: damping per amplitude band and
        method with intervals, ``sloshrom.beam.damping.tables.damping_band_table``), ``experiment``
        (the rig as the laboratory, :func:`laboratory`: ``noise_rms`` (m/s^2), ``files``, and
        ``free``/``random``: the rows of ``sloshrom.beam.compare.compare_rows``, each
        prediction against the experiment's intervals) and ``envelope`` (per run and case: peak
        tank acceleration against the model's training envelope,
        ``sloshrom.beam.simulation.cases.envelope_table``; ``None`` = n/a for a model without an
        envelope), ``waveform_fidelity`` (the random tests' forces of the ROM and of the rig's
        twin run against the rig's, per level:
        :func:`sloshrom.pipeline.waveform.random_fidelity`), ``free_fidelity`` (the ROM's
        free-decay force over its first seconds against the rig's, paper Fig. 20c:
        :func:`sloshrom.pipeline.waveform.free_fidelity`). An ensemble ROM (each member
        coupled alone, :func:`coupled_model`): its rows are the mean of the members'
        estimates with the combined uncertainty, and ``rom_members`` (:func:`member_spread`)
        the members' own values.
    files : list of str
        ``beam/{free,random}_<case>.nc`` (with the envelope coverage,
        ``sloshrom.beam.results.to_dataset``; the experiment's too), the lab files
        ``beam/lab/*.uff`` and their channel maps, the tables and the figures, relative to
        ``ctx.out``; they appear together once everything has succeeded.
    """
    with analysis_pool() as pool:
        return _stage_beam(ctx, rom_path, pool)


def _stage_beam(ctx: Context, rom_path: Path | None, pool: Executor | None
                ) -> StageRecord:
    cfg = ctx.cfg.beam
    fs = float(ctx.cfg.rig.fs)  # the beam's sensors record at the rig's record rate
    tank = ctx.tank
    out = ctx.out / "beam"
    out.mkdir(parents=True, exist_ok=True)
    beam, modal = beam_structure(cfg, tank)
    models: dict[str, object] = {"frozen": FrozenLiquid(1.0 / fs), "rig": ctx.rig()}
    if rom_path is not None:
        models["rom"] = coupled_model(load_model(rom_path))
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
    gain = float(ctx.cfg.rig.twin_gain)

    def free_and_twin() -> tuple[CaseResults, CaseResults, float]:
        free = simulate_cases(models, tests["free"], fs, report("free"))
        # the rig's twin run of the random tests, the scale of the ROM's waveform figures
        # (docs/rom.md, "Waveform fidelity"); measured 1.4-3.7 s for 3 x 90 s
        t0 = time.perf_counter()
        twin = simulate_cases({"twin": models["rig"]},
                              beam_tests(cfg, modal, tank, fs, gain=gain)["random"], fs)
        return free, twin, time.perf_counter() - t0

    # the free decays and the twin run in a thread beside the random tests (every run is
    # independent and its own to the bit): the frozen liquid's and the rig's runs are one
    # core's work each, and the analysis pool's processes are still starting
    side = (in_thread(functools.partial(contextvars.copy_context().run, free_and_twin),
                      "sloshrom-beam-free")
            if pool is not None and numba_threadsafe() else None)
    rand_res = simulate_cases(models, tests["random"], fs, report("random"))

    def tables(runner: Executor | None) -> tuple[dict[str, list[xr.Dataset]], xr.Dataset]:
        # the members' Table 2 once: the ROM's estimates and rom_members both read it
        members = member_damping_datasets(rand_res, cfg.rms_g, f1, max_tank_acceleration=True,
                                          pool=runner)
        return members, mode1_damping_dataset(rand_res, cfg.rms_g, f1,
                                              max_tank_acceleration=True, members=members,
                                              pool=runner)

    # Table 2's analyses run in the pool's processes while this one goes on (a thread waits
    # for them); in this process alone, after the rest (warnings' filters are process-wide)
    table_work = (in_thread(lambda: tables(pool), "sloshrom-beam-tables") if pool is not None
                  else None)
    free_res, twins, twin_seconds = side.result() if side is not None else free_and_twin()
    twin = twins["twin"]
    outputs["waveform_fidelity"] = random_fidelity(rand_res, twin, cfg.rms_g, gain,
                                                   twin_seconds)
    # the free decay's first seconds, the violent part (paper Fig. 20c)
    outputs["free_fidelity"] = free_fidelity(free_res)
    ctx.progress("beam", steps, steps, "analysis and figures")

    decays = {case: mode1_decay(r, modal, f1) for case, r in free_res.items()}
    outputs["instantaneous_damping"] = damping_summary(free_res, decays)
    bands = damping_band_table(free_res, decays, f1)
    outputs["envelope"] = envelope_table({"free": free_res, "random": rand_res})

    predicted_free = [analysed_test(c, "free", free_res[c], f1,
                                    [r for r in bands if r["case"] == c], decays[c])
                      for c in models]
    # the figures that need no Table 2, drawn while its analyses run in the pool's processes
    # (this process would wait for them, then draw on one core)
    ff = outputs["free_fidelity"].get("rom")
    figs: dict[str, Figure | bytes] = {
        **free_figures(free_res, modal, decays),
        **random_figures(rand_res, cfg.rms_g, random_window(cfg.random_duration))}
    figs["fig17_base_excitation"] = base_excitation_figure(rand_res["frozen"], cfg.rms_g,
                                                           cfg.f0, cfg.sigma, fs)
    figs.update(force_figures(
        {c: free_res[c] for c in ("rig", "rom") if c in free_res},
        {**{c: rand_res[c] for c in ("rig", "rom") if c in rand_res}, "twin": twin},
        cfg.rms_g, fs, {"rom": ff} if isinstance(ff, dict) else None))
    # every result file of the stage appears together, once everything has succeeded; those
    # that need no analysis of the pool are written while its processes work
    with OutputBatch() as batch:
        for case in models:
            for kind, res in (("free", free_res), ("random", rand_res)):
                write_dataset(to_dataset(res[case], case, kind, tank, modal, cfg.seed, f1=f1),
                              out / f"{kind}_{case}.nc", batch)
        write_table(rows, out / "table1_frozen_modes", batch)
        for name, fig in figs.items():
            savefig(fig, ctx.path("figures", f"{name}.png"), batch)

        ctx.progress("beam", steps, steps,
                     "the rig as the laboratory: files, analyses, comparison")
        with tempfile.TemporaryDirectory() as tmp:
            lab = laboratory(free_res["rig"], rand_res["rig"], modal, beam, cfg, f1, Path(tmp),
                             pool)
        exp_free, exp_random = lab["free"], lab["random"]
        for kind in ("free", "random"):
            write_dataset(to_dataset(lab[f"{kind}_result"], EXPERIMENT, kind, tank,
                                     lab["modal"], cfg.seed, f1=f1),
                          out / f"{kind}_{EXPERIMENT}.nc", batch)
        for name, data in lab["files"].items():
            batch.write(out / "lab" / name, lambda tmp, data=data: Path(tmp).write_bytes(data))

        members, table2 = collected(table_work, tables)
        predicted_random = [analysed_test(c, "random", rand_res[c], f1, table2.sel(case=c))
                            for c in models]
        # Table 2 as its file and record hold it: the simulated cases, then the experiment
        t2_rows = [*table2_rows(table2), *exp_random.table_rows()]
        bands += exp_free.rows
        outputs["table2"] = t2_rows
        outputs["damping_bands"] = bands
        outputs["experiment"] = {
            "noise_rms": cfg.lab_noise, "files": [f"lab/{n}" for n in lab["files"]],
            "free": compare_rows(exp_free, predicted_free),
            "random": compare_rows(exp_random, predicted_random)}
        if "rom" in members:
            outputs["rom_members"] = member_spread(members["rom"], free_res["rom"]["members"],
                                                   decays["rom"], cfg.rms_g)
        write_table(t2_rows, out / "table2_mode1_damping", batch)
        write_table(bands, out / "damping_bands", batch)
        for kind in ("free", "random"):
            write_table(outputs["experiment"][kind], out / f"comparison_{kind}", batch)
        for name, fig in {**comparison_figures(exp_free, predicted_free),
                          **comparison_figures(exp_random, predicted_random)}.items():
            savefig(fig, ctx.path("figures", f"{name}.png"), batch)
        files = [ctx.rel(p) for p in batch.paths]
    return outputs, files


def laboratory(free: Mapping[str, Any], random: Mapping[str, Any], modal: ModalModel,
               beam: CantileverBeam, cfg: BeamTable, f1: float, folder: Path,
               pool: Executor | None = None) -> dict[str, Any]:
    """The rig plays the laboratory: its beam runs as a test lab's files, analysed as measured.

    The free and random responses are written as UFF 58 files (``sloshrom.beam.lab.measured.
    write_lab_test``: the station accelerometers, and the base for the random tests, each with
    white noise of ``cfg.lab_noise`` m/s^2 RMS) into ``folder``, read back with their channel
    map and analysed exactly as ``sloshrom analyse`` analyses a measurement. ``pool``: the
    processes of :func:`analysis_pool` that run the random tests' analyses (the same results to
    the bit; in this process when the pool's processes failed, as :func:`collected`).

    Returns
    -------
    dict
        ``free``, ``random``: the :class:`~sloshrom.beam.compare.AnalysedTest` of the
        experiment (case :data:`EXPERIMENT`); ``free_result``, ``random_result``: the result
        dicts read from the files; ``modal``: the structure seen by the map's stations;
        ``files``: file name -> content (bytes) of the lab files and their channel map
        (``channels_free.toml``, ``channels_random.toml``).
    """
    free_path, random_path = folder / "free_rig.uff", folder / "random_rig.uff"
    cmap_free = write_lab_test(free, modal, free_path, kind="free", noise_rms=cfg.lab_noise,
                               seed=cfg.seed)
    cmap_random = write_lab_test(random, modal, random_path, kind="random",
                                 noise_rms=cfg.lab_noise, seed=cfg.seed + 1, levels=cfg.rms_g)
    cmap_free.write_toml(folder / "channels_free.toml")
    cmap_random.write_toml(folder / "channels_random.toml")
    lab_modal = station_model(modal, cmap_free, beam)
    res_free = read_free_test(free_path, cmap_free, lab_modal)
    res_random = read_random_test(lab_test_paths(random_path, "random", cfg.rms_g), cmap_random,
                                  lab_modal, levels=cfg.rms_g)
    # the checks `sloshrom analyse` makes of a laboratory's data
    check_free_decay(res_free, f1)
    for b, g in zip(res_random["base_acceleration"], cfg.rms_g, strict=True):
        check_random_base(b, res_random["fs"], f"({g:g} g)")
    decay = mode1_decay(res_free, lab_modal, f1)
    # the paper's bands, as the predictions it is compared with (a lab's own decay gets its own)
    bands = damping_band_table({EXPERIMENT: res_free}, {EXPERIMENT: decay}, f1, bands=BANDS)

    def table2_of(runner: Executor | None) -> xr.Dataset:
        return mode1_damping_dataset({EXPERIMENT: res_random}, cfg.rms_g, f1,
                                     max_tank_acceleration=True, pool=runner)

    table2 = collected(None if pool is None else in_thread(lambda: table2_of(pool)),
                       table2_of).sel(case=EXPERIMENT)
    exp_free = analysed_test(EXPERIMENT, "free", res_free, f1, bands, decay)
    exp_random = analysed_test(EXPERIMENT, "random", res_random, f1, table2)
    files = {p.name: p.read_bytes() for p in sorted(folder.iterdir())}
    return {"free": exp_free, "random": exp_random, "free_result": res_free,
            "random_result": res_random, "modal": lab_modal, "files": files}


def member_spread(member_tables: Sequence[xr.Dataset],
                  free_members: Sequence[Mapping[str, object]], decay: Mode1Decay,
                  levels: list[float]) -> dict[str, Any]:
    """The beam tests of each member of an ensemble ROM alone, from the ROM's own results.

    The members were coupled one at a time for the ROM's case (:func:`coupled_model`); their
    results and estimates are reused here, not simulated or analysed again. The ``mean`` of
    each spread is the ROM's value in Table 2 and in the free-decay summary (the mean over the
    members that have a value).

    Parameters
    ----------
    member_tables : sequence of xarray.Dataset
        Per member, its Table 2 over ``(level, estimator)``
        (``sloshrom.beam.damping.tables.member_damping_datasets``).
    free_members : sequence of mapping
        The members' free responses (``"members"`` of the ROM's).
    decay : Mode1Decay
        Its mode-1 analysis (with :attr:`~sloshrom.beam.damping.tables.Mode1Decay.members`).
    levels : list of float
        RMS levels, g.

    Returns
    -------
    dict
        ``table2``: per RMS level (g, as text) the spread (mean ± std over members,
        ``sloshrom.rom.ensemble.spread``, with every member's value) of the first-mode
        damping ratio, LSCF on H1 (-); ``estimators``: the same for each of Table 2's
        estimators (name -> level -> spread); ``instantaneous_damping``: per amplitude band
        the spread of the banded median first-mode damping of the free response (-).
    """
    by_est = {est: {f"{lv:g}": spread(float(t["value"].isel(level=i).sel(estimator=est))
                                      for t in member_tables)
                    for i, lv in enumerate(levels)}
              for est in TABLE2 if est in member_tables[0].estimator}
    names = [f"member{k}" for k in range(len(decay.members))]
    inst = damping_summary(dict(zip(names, free_members, strict=True)),
                           dict(zip(names, decay.members, strict=True)))
    bands = [k for k in next(iter(inst.values())) if k != "initial_tank_acceleration_g"]
    return {"table2": by_est[REFERENCE], "estimators": by_est,
            "instantaneous_damping": {b: spread(v[b] for v in inst.values()) for b in bands}}
