"""The ``sweep`` and ``rom`` stages of `sloshrom reproduce`: sensitivity analysis (paper Fig. 8),
then identify the configured ROM (an NFIR, NOE or NSS; with an NSS, the paper's NFIR beside it
when asked) and validate it (Fig. 10)."""

from __future__ import annotations

import time
from collections.abc import Mapping
from typing import Any

import numpy as np

from sloshrom.io import read_record
from sloshrom.limits import RECIPE
from sloshrom.pipeline.cache import StageResult
from sloshrom.pipeline.context import Context
from sloshrom.pipeline.settings import RomTable
from sloshrom.plotting import savefig
from sloshrom.plotting.rom import plot_sweep, validation_figure
from sloshrom.rom.ensemble import Ensemble, is_ensemble, spread
from sloshrom.rom.estimators import NFIR, NOE, NSS
from sloshrom.rom.sweep import run_sweep

__all__ = ["SWEEP_KEYS", "error_figures", "estimator", "model_class_text", "recipe_text",
           "stage_rom", "stage_sweep", "sweep_points"]


def error_figures(y: np.ndarray, y_hat: np.ndarray) -> dict[str, float]:
    """MSE (N^2), NRMSE (RMS error / RMS of y) and MATLAB-style fit % (100 (1 - |e|/|y - ȳ|))."""
    e = y_hat - y
    mse = float(np.mean(e**2))
    nrmse = float(np.sqrt(mse) / np.sqrt(np.mean(y**2)))
    fit = float(100.0 * (1.0 - np.linalg.norm(e) / np.linalg.norm(y - y.mean())))
    return {"mse": mse, "nrmse": nrmse, "fit": fit}


def sweep_points(rom: RomTable) -> list[tuple[str, int, int]]:
    """The sensitivity-analysis grid of the ``[rom]`` configuration as (arch, delays, neurons)."""
    return ([("nfir", d, n) for d in rom.sweep_nfir_delays for n in rom.sweep_nfir_neurons]
            + [("noe", d, n) for d in rom.sweep_noe_delays for n in rom.sweep_noe_neurons])


SWEEP_KEYS = ("sweep_nfir_delays", "sweep_nfir_neurons", "sweep_noe_delays", "sweep_noe_neurons",
              "max_epochs", "hidden", "seed")


def stage_sweep(ctx: Context, data: StageResult) -> tuple[dict[str, Any], list[str]]:
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
                     options={"max_epochs": cfg.max_epochs, "hidden": cfg.hidden,
                              "seed": cfg.seed},
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
            + ("as the paper's selection, not necessarily the lowest score." if cfg.arch != "nss"
               else "a state-space model outside this grid of NFIR/NOE networks."))
    table = [[r["arch"].upper(), r["delays"], r["neurons"],
              r["score"] if not r["unstable"] else "unstable", "no" if r["unstable"] else "yes"]
             for r in sorted(rows, key=lambda r: (r["arch"], r["delays"], r["neurons"]))]
    return {"sweep_seconds": seconds, "sweep_best": best["name"] if best else None,
            "sweep_text": text, "sweep_rows": table}, files


def model_class_text(arch: str, name: str, compared: str | None = None,
                     fits: tuple[float, float] | None = None) -> str:
    """One paragraph for the report: which model class the ROM of the report is, and why.

    ``arch``: ``"nfir"``, ``"noe"`` or ``"nss"``; ``name``: the ROM's name
    (:meth:`sloshrom.pipeline.settings.RomTable.name`); ``compared``: the name of the NFIR
    trained beside an NSS (``compare_nfir``), if any, and ``fits`` the validation fits (%) of
    the ROM and of that NFIR.
    """
    if arch != "nss":
        return (f"The ROM of this report is of the paper's class: {name}, a network of the "
                "last samples of the tank velocity"
                + (" and of its own last outputs." if arch == "noe" else "."))
    text = (f"The ROM of this report is a neural state-space model, {name}, not the paper's "
            "NFIR class. Why: the force depends on where the liquid is, how fast it moves and "
            "when it lands, a state that a finite-memory NFIR (70 samples, 0.14 s) cannot "
            "carry; the state-space model does, and with it predicts the impacts the NFIR "
            "misses while its dissipation map stays at least as close to the rig's "
            "(docs/rom.md, \"A ROM with state\", with the figures of both classes).")
    if compared:
        text += (f" The paper's class, {compared}, identified on the same records with its "
                 "own passive recipe, is set beside it in Fig. 10")
        text += (f": validation fit {fits[0]:.1f} % against {fits[1]:.1f} %." if fits
                 else ".")
    return text


def recipe_text(terms: Mapping[str, float], name: str, arch: str = "nfir") -> str:
    """One paragraph for the report: how the pipeline identified its ROM, and why.

    ``terms``: the loss weights ``amplitude_weighting`` (m/s), ``passivity`` and
    ``cycle_energy`` (absent: 0), e.g. :meth:`sloshrom.pipeline.settings.RomTable.loss_terms`;
    ``name``: the ROM's name; ``arch``: its class, ``"nfir"``, ``"noe"`` or ``"nss"`` (an NSS
    is not the paper's model, and its energy term judges training sub-sequences).
    """
    w, p = terms.get("amplitude_weighting", 0.0), terms.get("passivity", 0.0)
    c = terms.get("cycle_energy", 0.0)
    nss = arch == "nss"
    terms = []
    if w > 0:
        terms.append(f"each sample's squared error weighted by 1/(a² + ε²), a the local velocity "
                     f"amplitude, ε = {w:g} m/s (Φ_d divides by a², so small cycles count as "
                     "much as large ones)")
    if p > 0:
        terms.append(f"a penalty of weight {p:g} on energy created at harmonic probes inside "
                     "the training envelope")
    if c > 0:
        terms.append(f"a term of weight {c:g} on the error of the energy "
                     + ("each training sub-sequence exchanges with the liquid, per input "
                        "cycle in it" if nss else "each cycle of the training record exchanges "
                        "with the liquid")
                     + " (the part of the error that changes the damping)")
    paper = "rom.amplitude_weighting = 0, rom.passivity = 0 and rom.cycle_energy = 0"
    model = name if nss else f"the paper's {name}"
    if terms:
        listed = terms[0] if len(terms) == 1 else "; ".join(terms[:-1]) + "; and " + terms[-1]
        if nss:
            return (f"The ROM is {model} identified with physics in its loss: {listed}: the "
                    "terms of the NFIR's passive recipe (docs/rom.md, \"A passive ROM\"), "
                    f"applied to the state-space model. The plain MSE: {paper}.")
        return (
            f"The ROM is {model} identified with physics in its loss: {listed}. "
            "Why: with the paper's plain MSE the same network gives energy back to the tank "
            "below about 1 g and makes the beam less damped than with frozen liquid "
            f"(docs/rom.md, \"A passive ROM\"). The paper's configuration: {paper}.")
    return (f"The ROM is {model} trained on the plain MSE ({paper}): nothing in its "
            "identification prevents it from creating energy; see the passivity figures of "
            "the maps.")


def estimator(cfg: RomTable, arch: str | None = None) -> NFIR | NOE | NSS:
    """The unfitted estimator of the ``[rom]`` table: its ``arch`` (default: the configured
    one; ``"nfir"`` for the compared NFIR), seed ``seed``, the loss weights for an NFIR or NSS
    (the compared NFIR: :data:`sloshrom.limits.RECIPE`, the NFIR's passive recipe).
    """
    arch = cfg.arch if arch is None else arch
    if arch == "nss":
        return NSS(n_states=cfg.nss_states, neurons=cfg.nss_neurons, window=cfg.nss_window,
                   horizon=cfg.nss_horizon, batch=cfg.nss_batch,
                   max_epochs=cfg.nss_max_epochs, steps_per_epoch=cfg.nss_steps_per_epoch,
                   learning_rate=cfg.nss_learning_rate, seed=cfg.seed, **cfg.loss_terms())
    cls = {"nfir": NFIR, "noe": NOE}[arch]
    loss = cfg.loss_terms() if arch == "nfir" else {}
    if arch == "nfir" and cfg.arch == "nss":
        # the compared NFIR is the paper's class with its own passive recipe: the [rom] loss
        # weights are the NSS's
        loss = dict(RECIPE)
    return cls(delays=cfg.delays, neurons=cfg.neurons, hidden=cfg.hidden,
               max_epochs=cfg.max_epochs, seed=cfg.seed, **loss)


def _median_after_compile(history: dict[str, Any], key: str) -> float | None:
    """Median of a per-epoch timing over the epochs after the first (which compiles), s;
    None for a trainer that does not record it (Levenberg-Marquardt)."""
    v = history.get(key) or []
    return float(np.median(v[2:])) if len(v) > 2 else None


def _train(ctx: Context, model: Any, name: str, epochs: int, k_members: int, workers: int,
           records: tuple[np.ndarray, ...], fs: float, fill: float | None
           ) -> tuple[Any, str, float]:
    """Fit ``model`` (an ensemble of ``k_members`` of it if > 1) on ``records`` = (u, y, u
    validation, y validation); the fitted model, its name and the training time, s."""
    u, y, uv, yv = records

    def cb(epoch: int, *args: Any, **kwargs: Any) -> None:
        ctx.progress("rom", epoch, epochs, f"training {name}, epoch {epoch}")

    t0 = time.perf_counter()
    if k_members > 1:
        ctx.progress("rom", 0, k_members, f"training {k_members} x {name}")
        model = Ensemble(model, n_members=k_members).fit(
            u, y, fs=fs, validation=(uv, yv),
            scheduler="sequential" if workers == 1 else None, n_workers=workers,
            progress=lambda k, m: ctx.progress("rom", k + 1, k_members, f"member {k} done"),
            fill=fill)
        name = f"{name} x {k_members}"
    else:
        model.fit(u, y, fs=fs, validation=(uv, yv), callback=cb, fill=fill)
    return model, name, time.perf_counter() - t0


def stage_rom(ctx: Context, data: StageResult) -> tuple[dict[str, Any], list[str]]:
    """Train the configured NFIR, NOE or NSS on the training record, validate it (paper Fig. 10).

    ``data`` is the data stage's result: the records it recorded are the ones trained on. With
    ``arch = "nss"`` and ``compare_nfir``, the NFIR of ``delays``/``neurons`` (one network,
    seed ``seed``) is trained too and validated beside it.

    Returns
    -------
    outputs : dict
        Of the chosen ROM (the ROM of the report): ``model`` (its file), ``arch``, ``name``,
        ``train_seconds`` (s), MSE (N^2), NRMSE (-) and fit (%) on the validation (``val_*``)
        and training (``train_*``) records, ``epochs``, ``stop_reason``, ``epoch_seconds``
        and ``validation_seconds`` (each member's median epoch of Adam steps and of
        validation, s; None for Levenberg-Marquardt), the report's
        paragraphs ``model_class_text`` and ``recipe_text``; with the compared NFIR,
        ``compare``: its ``name``, ``val_mse``, ``val_nrmse``, ``val_fit``, ``train_seconds``
        and ``model`` (its file).
    files : list of str
        The model file(s) and Fig. 10, relative to ``ctx.out``.
    """
    cfg = ctx.cfg.rom
    train = read_record(data.output("data/train.nc"))
    val = read_record(data.output("data/validation.nc"))
    u, y = train["velocity"], train["dynamic_force"]
    uv, yv = val["velocity"], val["dynamic_force"]
    records = (u, y, uv, yv)
    files: list[str] = []
    outputs: dict[str, Any] = {}
    name = cfg.name()
    epochs = cfg.nss_max_epochs if cfg.arch == "nss" else cfg.max_epochs
    fill = train.attrs.get("fill")  # the model refuses other fills (sloshrom.rom.family)
    k_members = int(cfg.ensemble)
    recipe = recipe_text(cfg.loss_terms(), name, cfg.arch)
    model, name, train_seconds = _train(ctx, estimator(cfg), name, epochs, k_members,
                                        int(cfg.ensemble_workers), records, train.fs, fill)
    ctx.progress("rom", 1, 1, "validation")
    path = ctx.path("models", f"{cfg.arch}.npz")
    model.save(path)
    files.append(ctx.rel(path))
    yv_hat = np.asarray(model.predict(uv))
    y_hat = np.asarray(model.predict(u))
    ev, et = error_figures(yv, yv_hat), error_figures(y, y_hat)
    hists = model.history_ if is_ensemble(model) else [model.history_]
    outputs.update(
        model=ctx.rel(path), arch=cfg.arch, name=name, train_seconds=train_seconds,
        recipe_text=recipe, n_members=k_members,
        val_mse=ev["mse"], val_nrmse=ev["nrmse"], val_fit=ev["fit"],
        train_mse=et["mse"], train_nrmse=et["nrmse"], train_fit=et["fit"],
        epochs=[len(h.get("train_mse", [])) for h in hists],
        stop_reason=[h.get("stop_reason") for h in hists],
        # where each member's training went: its median epoch of Adam steps and of validation
        epoch_seconds=[_median_after_compile(h, "step_seconds") for h in hists],
        validation_seconds=[_median_after_compile(h, "validation_seconds") for h in hists],
    )
    if is_ensemble(model):
        outputs["seeds"] = [int(s) for s in model.seeds_]
        outputs["val_mse_members"] = spread(
            error_figures(yv, yh)["mse"] for yh in np.asarray(model.member_predictions(uv)))
    compared = None
    if cfg.compares_nfir:
        # the paper's class on the same records with its recipe, for the report to set beside it
        other, other_name, seconds = _train(ctx, estimator(cfg, "nfir"), cfg.name("nfir"),
                                            cfg.max_epochs, 1, 1, records, train.fs, fill)
        other_path = ctx.path("models", "nfir.npz")
        other.save(other_path)
        files.append(ctx.rel(other_path))
        other_hat = np.asarray(other.predict(uv))
        eo = error_figures(yv, other_hat)
        outputs["compare"] = {"name": other_name, "val_mse": eo["mse"],
                              "val_nrmse": eo["nrmse"], "val_fit": eo["fit"],
                              "train_seconds": seconds, "model": ctx.rel(other_path)}
        compared = (other_hat, other_name, eo["fit"])
    outputs["model_class_text"] = model_class_text(
        cfg.arch, name, compared[1] if compared is not None else None,
        (ev["fit"], compared[2]) if compared is not None else None)
    fig = validation_figure(val.time, yv, yv_hat, name, val.fs, ev["fit"], ev["nrmse"],
                            compare=compared)
    files.append(ctx.rel(savefig(fig, ctx.path("figures", "fig10_validation.png"))))
    return outputs, files
