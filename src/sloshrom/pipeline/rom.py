"""The ``sweep`` and ``rom`` stages of `sloshrom reproduce`: sensitivity analysis (paper Fig. 8),
then identify the configured ROM (any class of the registry) and the classes compared with it
(the paper's NFIR, the best linear model) and validate them (Fig. 10)."""

from __future__ import annotations

import contextlib
import contextvars
import threading
import time
from collections.abc import Callable, Mapping, Sequence
from concurrent.futures import Future, ThreadPoolExecutor
from typing import Any, TypeVar

import numpy as np
from threadpoolctl import threadpool_limits

from sloshrom._threads import map_threads, numba_threadsafe
from sloshrom.config import Tank
from sloshrom.energy import frame_change, frame_probes
from sloshrom.fidelity import point_errors
from sloshrom.io import read_record
from sloshrom.models import check_envelope, envelope_quiet, input_of
from sloshrom.pipeline.cache import StageResult
from sloshrom.pipeline.context import Context, StageRecord, in_thread
from sloshrom.pipeline.data import replay_record
from sloshrom.pipeline.settings import RomTable, sweep_key
from sloshrom.pipeline.waveform import validation_fidelity
from sloshrom.plotting import savefig
from sloshrom.plotting.rom import plot_sweep, validation_figure
from sloshrom.rom.base import Estimator
from sloshrom.rom.ensemble import Ensemble, is_ensemble, spread
from sloshrom.rom.epochs import TrainingProgress
from sloshrom.rom.registry import CLASSES, paper_class, swept
from sloshrom.rom.sweep import run_sweep

__all__ = ["error_figures", "estimator", "model_class_text", "recipe_text",
           "stage_rom", "stage_sweep", "sweep_keys", "sweep_options", "sweep_points"]


def error_figures(y: np.ndarray, y_hat: np.ndarray) -> dict[str, float]:
    """MSE (N^2), NRMSE (RMS error / RMS of y) and MATLAB-style fit % (100 (1 - |e|/|y - ȳ|))
    (:func:`sloshrom.fidelity.point_errors`)."""
    return point_errors(y, y_hat)


#: The keys of the first swept class's table (``[rom.nfir]``) every grid point trains with.
_SWEEP_OPTIONS = ("max_epochs", "hidden", "precision")


def sweep_options(rom: RomTable) -> dict[str, object]:
    """The estimator arguments every grid point of the sweep trains with: the seed, and the
    epochs, hidden layer and precision of the first swept class's table (``[rom.nfir]``; the
    precision reaches the classes that have one, :func:`sloshrom.rom.sweep.run_sweep`)."""
    lead = rom.hyper(swept()[0].name)
    return {**{k: lead[k] for k in _SWEEP_OPTIONS}, "seed": rom.seed}


def sweep_points(rom: RomTable) -> list[tuple[str, int, int]]:
    """The sensitivity-analysis grid of the ``[rom]`` configuration as (arch, delays, neurons):
    each swept class's ``rom.sweep_<class>_delays`` x ``rom.sweep_<class>_neurons``."""
    return [(mc.name, d, n) for mc in swept() for d in getattr(rom, sweep_key(mc, "delays"))
            for n in getattr(rom, sweep_key(mc, "neurons"))]


def sweep_keys(rom: Mapping[str, Any]) -> dict[str, Any]:
    """What the sweep's result depends on (its cache key), from the ``[rom]`` dict: its grids,
    the seed, and the epochs, hidden layer and precision of the first swept class's table
    (``[rom.nfir]``), which every grid point trains with (the precision: each class that has
    one)."""
    keys = [sweep_key(mc, k) for mc in swept() for k in ("delays", "neurons")]
    lead = rom[swept()[0].name]
    return {**{k: rom[k] for k in [*keys, "seed"]},
            **{k: lead[k] for k in _SWEEP_OPTIONS}}


def stage_sweep(ctx: Context, data: StageResult) -> StageRecord:
    """Paper Fig. 8: train every grid point, score = mean of train and validation MSE.

    ``data`` is the data stage's result: the records it recorded are the ones trained on.

    Points run in parallel (Dask LocalCluster, ``sweep_workers`` processes; 1 = in this
    process). Each finished point is kept in ``OUT/sweep/``, so an interrupted sweep resumes.
    """
    cfg = ctx.cfg.rom
    pts = sweep_points(cfg)
    train = read_record(data.output("data/train.nc"))
    val = read_record(data.output("data/validation.nc"))
    out_dir = ctx.out / "sweep"
    done = [0]

    def prog(row: dict[str, Any]) -> None:
        done[0] += 1
        ctx.progress("sweep", done[0], len(pts), f"{done[0]}/{len(pts)}: {row['name']}")

    ctx.progress("sweep", 0, len(pts), f"{len(pts)} networks")
    t0 = time.perf_counter()
    workers = int(cfg.sweep_workers)
    rows = run_sweep((train["velocity"], train["dynamic_force"]),
                     (val["velocity"], val["dynamic_force"]), train.fs, out_dir, pts,
                     scheduler="sequential" if workers == 1 else None, n_workers=workers,
                     options=sweep_options(cfg),
                     progress=prog)
    seconds = time.perf_counter() - t0
    fig = plot_sweep(rows, ctx.path("figures", "fig08_sensitivity.png"))
    files = [ctx.rel(fig), "sweep/sweep.csv", "sweep/sweep.json"]
    files += [f"sweep/{r['model']}" for r in rows if r.get("model")]
    stable = [r for r in rows if not r["unstable"]]
    best = stable[0] if stable else None
    n_bad = len(rows) - len(stable)
    text = (f"Sensitivity analysis over {len(rows)} networks in {seconds:.0f} s: "
            + (f"lowest score {best['name']} ({best['score']:.4g} N²)" if best else
               "no stable network")
            + f"; {n_bad} unstable NOE network(s). The ROM of the next sections is the "
            f"configured {cfg.name()}, "
            + ("as the paper's selection, not necessarily the lowest score."
               if cfg.arch in {p[0] for p in pts}
               else f"{CLASSES[cfg.arch].article} {CLASSES[cfg.arch].class_name} outside this "
                    f"grid of {'/'.join(mc.class_name for mc in swept())} networks."))
    table = [[r["arch"].upper(), r["delays"], r["neurons"],
              r["score"] if not r["unstable"] else "unstable", "no" if r["unstable"] else "yes"]
             for r in sorted(rows, key=lambda r: (r["arch"], r["delays"], r["neurons"]))]
    return {"sweep_seconds": seconds, "sweep_best": best["name"] if best else None,
            "sweep_text": text, "sweep_rows": table}, files


def model_class_text(arch: str, name: str,
                     compared: Sequence[tuple[str, float]] = (), fit: float | None = None
                     ) -> str:
    """One paragraph for the report: which model class the ROM of the report is, and why.

    ``arch``: its class (:data:`sloshrom.rom.registry.CLASSES`); ``name``: the ROM's name
    (:meth:`sloshrom.pipeline.settings.RomTable.name`); ``compared``: the name and the
    validation fit (%) of each class identified beside it (``rom.compare``), and ``fit`` the
    ROM's.
    """
    text = f"The ROM of this report is {name}: {CLASSES[arch].report}"
    if compared:
        others = "; ".join(f"{n}, fit {f:.1f} %" for n, f in compared)
        text += (" Identified on the same records, each with its own configuration, and set "
                 f"beside it in Fig. 10 (validation fit): {others}"
                 + (f"; against {fit:.1f} % for {name}." if fit is not None else "."))
    return text


def recipe_text(terms: Mapping[str, float], name: str, arch: str | None = None) -> str:
    """One paragraph for the report: how the pipeline identified its ROM, and why.

    ``terms``: the loss weights ``amplitude_weighting`` (m/s), ``passivity`` and
    ``cycle_energy`` (absent: 0), e.g. :meth:`sloshrom.pipeline.settings.RomTable.loss_terms`;
    ``name``: the ROM's name; ``arch``: its class (default: the paper's, or another one to
    which the NFIR's recipe is applied).
    """
    arch = paper_class().name if arch is None else arch
    w, p = terms.get("amplitude_weighting", 0.0), terms.get("passivity", 0.0)
    c = terms.get("cycle_energy", 0.0)
    paper = CLASSES[arch].paper
    parts = []
    if w > 0:
        parts.append(f"each sample's squared error weighted by 1/(a² + ε²), a the local velocity "
                     f"amplitude, ε = {w:g} m/s (Φ_d divides by a², so small cycles count as "
                     "much as large ones)")
    if p > 0:
        parts.append(f"a penalty of weight {p:g} on energy created at harmonic probes inside "
                     "the training envelope")
    if c > 0:
        parts.append(f"a term of weight {c:g} on the error of the energy "
                     + ("each cycle of the training record exchanges" if paper else
                        "each training sub-sequence exchanges, per input cycle in it,")
                     + " with the liquid (the part of the error that changes the damping)")
    off = (f"rom.{arch}.amplitude_weighting = 0, rom.{arch}.passivity = 0 and "
           f"rom.{arch}.cycle_energy = 0")
    model = f"the paper's {name}" if paper else name
    if not CLASSES[arch].loss_terms:
        return (f"The ROM is {model}, identified by its own method "
                f"({CLASSES[arch].summary}), without loss terms.")
    if parts:
        listed = parts[0] if len(parts) == 1 else "; ".join(parts[:-1]) + "; and " + parts[-1]
        if not paper:
            return (f"The ROM is {model} identified with physics in its loss: {listed}: the "
                    "terms of the NFIR's passive recipe (docs/rom.md, \"A passive ROM\"), "
                    f"applied to it. The plain MSE: {off}.")
        return (
            f"The ROM is {model} identified with physics in its loss: {listed}. "
            "Why: with the paper's plain MSE the same network gives energy back to the tank "
            "below about 1 g and makes the beam less damped than with frozen liquid "
            f"(docs/rom.md, \"A passive ROM\"). The paper's configuration: {off}.")
    return (f"The ROM is {model} trained on the plain MSE ({off}): nothing in its "
            "identification prevents it from creating energy; see the passivity figures of "
            "the maps.")


def estimator(cfg: RomTable, arch: str | None = None, tank: Tank | None = None) -> Any:
    """The unfitted estimator of class ``arch`` (default: the configured one) as its table
    ``[rom.<arch>]`` and ``rom.seed`` say (:mod:`sloshrom.rom.registry`), its tank's
    quantities left at 0 taken from ``tank``
    (:meth:`~sloshrom.rom.registry.ModelClass.with_tank`)."""
    arch = cfg.arch if arch is None else arch
    mc = CLASSES[arch]
    return mc.estimator_class()(**mc.with_tank(cfg.hyper(arch), tank))


R = TypeVar("R")
#: A class compared with the ROM, trained: its name in the registry, the model, its name and its
#: training time (s)
Compared = tuple[str, Estimator, str, float]


def _median_after_compile(history: dict[str, Any], key: str) -> float | None:
    """Median of a per-epoch timing over the epochs after the first (which compiles), s;
    None for a trainer that does not record it (Levenberg-Marquardt)."""
    v = history.get(key) or []
    return float(np.median(v[2:])) if len(v) > 2 else None


class _Beside:
    """The progress of the classes compared with the ROM while they train in a thread beside
    its members: their line is added to the members' until these finish, then shown alone."""

    def __init__(self, ctx: Context) -> None:
        self.ctx = ctx
        self.text = ""
        self.alone = False
        self.stop = threading.Event()  # the members failed: the comparison ends at its epoch
        # the members' line, shown again with this text (their search reports no epochs)
        self.members: Callable[[], None] | None = None

    def suffix(self) -> str:
        return f"; beside it, {self.text}" if self.text else ""

    def report(self, done: int, total: int, text: str) -> None:
        self.text = text
        if self.alone:
            self.ctx.progress("rom", done, total, text)
        elif self.members is not None:
            self.members()


class _ValidationRuns:
    """The runs the validation makes of each member of the ROM (or of the ROM alone): on the
    validation and training records and on the frame probes
    (:func:`sloshrom.energy.frame_probes`).

    A member's runs are queued to a thread of this process as soon as it has trained
    (:meth:`start`), for the core it leaves while the other members still train; the rig's
    twin run of the validation record starts in a thread of its own with the first. At the
    validation (:meth:`results`) the runs not yet begun are shared among the cores. Each run
    is the call the model's own ``predict``/``simulate`` would make, so the ROM's outputs are
    its own to the bit; the ensemble's are the mean of its members' runs, as its ``predict``."""

    def __init__(self, records: tuple[np.ndarray, ...], fs: float,
                 twin: Callable[[], tuple[np.ndarray, float]]) -> None:
        u, _, uv, _ = records
        self.probes, self.acc = frame_probes(uv, fs)
        # (name, input, whether a frame probe): a record's velocity, or a probe's
        self.jobs: list[tuple[str, np.ndarray, bool]] = [
            ("validation", uv, False), ("training", u, False),
            *((f"frame {i}", p, True) for i, p in enumerate(self.probes))]
        self._twin = twin
        self.twin_run: Future[tuple[np.ndarray, float]] | None = None
        self.pool = ThreadPoolExecutor(max_workers=1, thread_name_prefix="sloshrom-validation")
        self.queued: dict[tuple[int, str], Future[np.ndarray]] = {}

    def todo(self, model: Estimator) -> list[tuple[str, np.ndarray, bool]]:
        # a model of the velocity: the record's run is its first probe's
        same = input_of(model) == "velocity"
        return [j for j in self.jobs if not (same and j[0] == "frame 0")]

    def run(self, model: Estimator, job: tuple[str, np.ndarray, bool]) -> np.ndarray:
        """One run of ``model``, without the envelope's warning (the caller checks the
        ensemble's envelope; the frame probes leave it on purpose)."""
        _, x, probe = job
        with envelope_quiet():
            if probe:
                return np.asarray(model.simulate(x, self.acc), dtype=float)
            return np.asarray(model.predict(x))

    def start(self, k: int, member: Estimator) -> None:
        """Member ``k`` has trained: its runs are queued; the twin run starts with the
        first. (Not with numba's workqueue layer: the runs then wait for the validation.)"""
        if not numba_threadsafe():
            return
        self.start_twin()
        for job in self.todo(member):
            self.queued[k, job[0]] = self.pool.submit(contextvars.copy_context().run,
                                                      self.run, member, job)

    def start_twin(self) -> None:
        if self.twin_run is None and numba_threadsafe():
            self.twin_run = in_thread(self._twin, "sloshrom-twin-run")

    def twin(self) -> tuple[np.ndarray, float]:
        """The twin run's force (N) and its time (s), once it has ended (run here where it
        could not run beside the others)."""
        self.start_twin()
        return self._twin() if self.twin_run is None else self.twin_run.result()

    def results(self, models: Sequence[Estimator]) -> list[dict[str, np.ndarray]]:
        """Every model's runs: the queued ones that have begun, as they end; the others here,
        a core each."""
        begun = {key: f for key, f in self.queued.items() if not f.cancel()}
        here = [(k, job) for k, m in enumerate(models) for job in self.todo(m)
                if (k, job[0]) not in begun]
        done = map_threads(lambda kj: self.run(models[kj[0]], kj[1]), here)
        out: list[dict[str, np.ndarray]] = [{} for _ in models]
        for (k, job), y in zip(here, done, strict=True):
            out[k][job[0]] = y
        for (k, key), f in begun.items():
            out[k][key] = f.result()
        for r in out:
            r.setdefault("frame 0", r["validation"])
        return out

    def close(self) -> None:
        self.pool.shutdown(wait=False, cancel_futures=True)


def _train(ctx: Context, model: Any, name: str, epochs: int, k_members: int, workers: int,
           records: tuple[np.ndarray, ...], fs: float, fill: float | None,
           beside: _Beside | None = None, started: Callable[[], object] | None = None,
           on_member: Callable[[int, Estimator], None] | None = None,
           ) -> tuple[Any, str, float]:
    """Fit ``model`` (an ensemble of ``k_members`` of it if > 1) on ``records`` = (u, y, u
    validation, y validation); the fitted model, its name and the training time, s.

    ``beside``: an ensemble's progress line carries its text; a single model trained by a
    thread beside the members reports into it (and stops when it is told to). ``started``:
    called once an ensemble's members are on their workers (or at once for one model).
    ``on_member(k, member)``: as member k of an ensemble has trained."""
    u, y, uv, yv = records
    # epoch, errors and time left of the training (of every member of an ensemble)
    pace = TrainingProgress(epochs, members=k_members, concurrent=workers, unit="N^2")
    what = f"training {name}" if k_members == 1 else f"training {k_members} x {name}"
    beside_thread = beside is not None and k_members == 1

    def show() -> None:
        text = f"{what}: {pace.text()}"
        if beside_thread and beside is not None:
            beside.report(pace.done, max(pace.total, 1), text)
        else:
            ctx.progress("rom", pace.done, max(pace.total, 1),
                         text + (beside.suffix() if beside is not None else ""))

    def cb(epoch: int, info: Mapping[str, float]) -> bool:
        pace.epoch(epoch, info)
        show()
        return beside_thread and beside is not None and beside.stop.is_set()

    def member_epoch(k: int, epoch: int, info: Mapping[str, float]) -> None:
        if pace.epoch(epoch, info, member=k):  # (not a late file of a finished member)
            show()

    def member_done(k: int, member: Estimator) -> None:
        pace.finished(k)
        show()
        if on_member is not None:
            on_member(k, member)

    t0 = time.perf_counter()
    if beside_thread and beside is not None:
        beside.report(0, max(pace.total, 1), what)
    else:
        if beside is not None:
            beside.members = show
        ctx.progress("rom", 0, max(pace.total, 1), what)
    if k_members > 1:
        model = Ensemble(model, n_members=k_members).fit(
            u, y, fs=fs, validation=(uv, yv),
            scheduler="sequential" if workers == 1 else None, n_workers=workers,
            progress=member_done, epoch_progress=member_epoch, fill=fill, started=started)
        name = f"{name} x {k_members}"
    else:
        if started is not None:
            started()
        model.fit(u, y, fs=fs, validation=(uv, yv), callback=cb, fill=fill)
    return model, name, time.perf_counter() - t0


def _timed(fn: Callable[[], R]) -> tuple[R, float]:
    """``fn()`` and the seconds it took."""
    t0 = time.perf_counter()
    return fn(), time.perf_counter() - t0


def _train_compared(ctx: Context, records: tuple[np.ndarray, ...], fs: float,
                    fill: float | None, beside: _Beside | None = None
                    ) -> list[Compared]:
    """Train each class of ``rom.compare`` (one model each, as its table says): (class, model,
    name, training time in s) each."""
    cfg = ctx.cfg.rom
    out = []
    for arch in cfg.compared():
        if beside is not None and beside.stop.is_set():
            break
        hyper = cfg.hyper(arch)
        other, other_name, seconds = _train(ctx, estimator(cfg, arch, ctx.tank), cfg.name(arch),
                                            int(hyper.get("max_epochs", 0)), 1, 1, records,
                                            fs, fill, beside)
        out.append((arch, other, other_name, seconds))
    return out


def _validate(ctx: Context, model: Any, name: str, train_seconds: float, recipe: str,
              k_members: int, records: tuple[np.ndarray, ...], fs: float,
              runs: _ValidationRuns) -> tuple[dict[str, object], np.ndarray, dict[str, float]]:
    """Save the trained ROM and validate it on ``records`` (u, y, u validation, y validation;
    the validation record's rate ``fs``, Hz) from ``runs`` (those of its members already
    started): the stage's outputs of the ROM itself (its file as ``model``), its prediction of
    the validation record and that prediction's error figures."""
    cfg = ctx.cfg.rom
    u, y, uv, yv = records
    ctx.progress("rom", 1, 1, "validation")
    # the rig's twin run of the validation record needs no model: it runs in a thread while
    # this one validates the ROM (each on a core)
    runs.start_twin()
    path = ctx.path("models", f"{cfg.arch}.npz")
    model.save(path)
    ensemble = is_ensemble(model)
    # the runs are quiet: the ROM's envelope (an ensemble's: its members' union) is checked
    # here, once a record
    check_envelope(model, uv)
    check_envelope(model, u)
    res = runs.results(model.members_ if ensemble else [model])

    def mean(key: str) -> np.ndarray:  # an ensemble's output is its members' mean
        return np.stack([r[key] for r in res]).mean(axis=0) if ensemble else res[0][key]

    yv_hat, y_hat = mean("validation"), mean("training")
    ev, et = error_figures(yv, yv_hat), error_figures(y, y_hat)
    hists = model.history_ if ensemble else [model.history_]
    outputs: dict[str, object] = dict(
        model=ctx.rel(path), arch=cfg.arch, name=name, train_seconds=train_seconds,
        recipe_text=recipe, n_members=k_members,
        val_mse=ev["mse"], val_nrmse=ev["nrmse"], val_fit=ev["fit"],
        train_mse=et["mse"], train_nrmse=et["nrmse"], train_fit=et["fit"],
        epochs=[len(h.get("train_mse", [])) for h in hists],
        stop_reason=[h.get("stop_reason") for h in hists],
        # why a training stopped where its result is probably poor (LM at mu_max), else None
        stop_message=[h.get("stop_message") for h in hists],
        # where each member's training went: its median epoch of Adam steps and of validation
        epoch_seconds=[_median_after_compile(h, "step_seconds") for h in hists],
        validation_seconds=[_median_after_compile(h, "validation_seconds") for h in hists],
    )
    # the force must not depend on the frame: a drift of the tank's velocity (a beam under
    # random base excitation has one) must not change the dissipation
    outputs["frame_sensitivity"] = frame_change(
        runs.probes, fs, [mean(f"frame {i}") for i in range(len(runs.probes))])
    # the force as a physicist judges it, beside the rig's own twin run (docs/rom.md,
    # "Waveform fidelity"): what a point-wise fit cannot say of a chaotic rig
    ctx.progress("rom", 1, 1, "the rig's twin run of the validation record")
    twin, twin_seconds = runs.twin()
    outputs["waveform_fidelity"] = validation_fidelity(yv, yv_hat, twin, fs,
                                                       float(ctx.cfg.rig.twin_gain),
                                                       twin_seconds)
    if ensemble:
        outputs["seeds"] = [int(s) for s in model.seeds_]
        outputs["val_mse_members"] = spread(
            error_figures(yv, r["validation"])["mse"] for r in res)
    return outputs, yv_hat, ev


def stage_rom(ctx: Context, data: StageResult) -> StageRecord:
    """Train the configured ROM on the training record, validate it (paper Fig. 10).

    ``data`` is the data stage's result: the records it recorded are the ones trained on. Each
    class of ``rom.compare`` (one model each, as its table says) is trained too and validated
    beside it.

    Returns
    -------
    outputs : dict
        Of the chosen ROM (the ROM of the report): ``model`` (its file), ``arch``, ``name``,
        ``train_seconds`` (s), MSE (N^2), NRMSE (-) and fit (%) on the validation (``val_*``)
        and training (``train_*``) records, ``epochs``, ``stop_reason``, ``stop_message`` (per
        member: why Levenberg-Marquardt stopped at mu_max, else None), ``epoch_seconds``
        and ``validation_seconds`` (each member's median epoch of Adam steps and of
        validation, s; None for Levenberg-Marquardt), the report's
        paragraphs ``model_class_text`` and ``recipe_text``; ``compare``: for each compared
        class by name, its ``name``, ``val_mse``, ``val_nrmse``, ``val_fit``,
        ``train_seconds`` and ``model`` (its file); ``frame_sensitivity``: how much the
        ROM's force and dissipation on the validation record change when its velocity is
        shifted by a constant (:func:`sloshrom.energy.frame_sensitivity`; 0 = invariant, as
        the physics); ``waveform_fidelity``: the ROM's and the rig's twin run's waveform
        figures on the validation record
        (:func:`sloshrom.pipeline.waveform.validation_fidelity`); for an ensemble, ``seeds``
        and ``val_mse_members`` (:func:`sloshrom.rom.ensemble.spread` of each member's MSE,
        N^2, its free run over the whole validation record), whatever its class.
    files : list of str
        The model file(s) and Fig. 10, relative to ``ctx.out``.
    """
    cfg = ctx.cfg.rom
    train = read_record(data.output("data/train.nc"))
    val = read_record(data.output("data/validation.nc"))
    u, y = train["velocity"], train["dynamic_force"]
    uv, yv = val["velocity"], val["dynamic_force"]
    records = (u, y, uv, yv)
    name = cfg.name()
    epochs = int(cfg.hyper().get("max_epochs", 0))
    fill = train.attrs.get("fill")  # the model refuses other fills (sloshrom.rom.family)
    k_members = int(cfg.ensemble)
    recipe = recipe_text(cfg.loss_terms(), name, cfg.arch)
    workers = int(cfg.ensemble_workers)
    # the compared classes train in a thread of this process beside the members: the members
    # one after the other in this process, each on every core (ensemble_workers = 1), or in
    # worker processes, one a core, while this process waits
    beside = _Beside(ctx) if k_members > 1 and cfg.compared() else None
    gain = float(ctx.cfg.rig.twin_gain)
    runs = _ValidationRuns(records, float(val.fs),
                           lambda: _timed(lambda: replay_record(ctx, "validation", gain)))
    # BLAS on one thread for the whole stage, as in a one-core worker: the members and the
    # compared classes train side by side in this process, and BLAS's thread count is the
    # process's (a limit one of them set and another restored would change another's products
    # in their last bits, from run to run); their BLAS products are small, and a thread more
    # only waited (docs/performance.md)
    with ThreadPoolExecutor(max_workers=1) as pool, contextlib.closing(runs), \
            threadpool_limits(limits=1, user_api="blas"):
        future: list[Future[list[Compared]]] = []

        def start_compared() -> None:
            if beside is not None and not future:
                future.append(pool.submit(_train_compared, ctx, records, train.fs, fill,
                                          beside))

        try:
            model, name, train_seconds = _train(ctx, estimator(cfg, tank=ctx.tank), name,
                                                epochs, k_members, workers, records, train.fs,
                                                fill, beside, start_compared, runs.start)
        except BaseException:
            if beside is not None:
                beside.stop.set()
            raise
        if beside is not None:
            start_compared()  # (a scheduler that never said it started)
            beside.alone = True
        else:
            others = _train_compared(ctx, records, train.fs, fill)
        # the ROM is validated while the compared classes finish in their thread: its work
        # takes the core the members left
        try:
            outputs, yv_hat, ev = _validate(ctx, model, name, train_seconds, recipe,
                                            k_members, records, float(val.fs), runs)
        except BaseException:
            if beside is not None:
                beside.stop.set()
            raise
        if beside is not None:
            others = future[0].result()
    files = [str(outputs["model"])]
    compared = []
    compare: dict[str, dict[str, object]] = {}
    outputs["compare"] = compare
    for arch, other, other_name, seconds in others:
        # another class on the same records, as its own table says, for the report to set
        # beside the ROM (the paper's NFIR, the best linear model)
        other_path = ctx.path("models", f"{arch}.npz")
        other.save(other_path)
        files.append(ctx.rel(other_path))
        other_hat = np.asarray(other.predict(uv))
        eo = error_figures(yv, other_hat)
        compare[arch] = {"name": other_name, "val_mse": eo["mse"], "val_nrmse": eo["nrmse"],
                         "val_fit": eo["fit"], "train_seconds": seconds,
                         "model": ctx.rel(other_path)}
        compared.append((other_hat, other_name, eo["fit"]))
    outputs["model_class_text"] = model_class_text(
        cfg.arch, name, [(n, f) for _, n, f in compared], ev["fit"])
    fig = validation_figure(val.time, yv, yv_hat, name, val.fs, ev["fit"], ev["nrmse"],
                            compare=compared)
    files.append(ctx.rel(savefig(fig, ctx.path("figures", "fig10_validation.png"))))
    return outputs, files
