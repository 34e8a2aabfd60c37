"""The beam tests of several cases: each case's model simulated, its results at the sensors'
rate, seen through one tank, against its training envelope, and paper Table 1.

* :func:`simulate_cases` - one simulation per case (an ensemble ROM member by member,
  :class:`~sloshrom.beam.simulation.members.Members`), at :func:`case_output_fs`.
* :func:`reference_tank` - a result of several tanks seen through one of them.
* :func:`envelope_table` - how far each run goes beyond its model's training envelope.
* :func:`frozen_modes_table` - paper Table 1, the modes with frozen liquid.

Shared by ``sloshrom beam`` and the ``beam`` stage of ``sloshrom reproduce``, so that both
simulate the same way. Result dicts in, result dicts and table rows out; no files.
"""

from __future__ import annotations

import functools
from collections.abc import Callable, Mapping, Sequence
from typing import Any, cast

import numpy as np

from sloshrom._threads import map_threads
from sloshrom.beam.simulation.members import Members, mean_result
from sloshrom.beam.simulation.structure import (
    TANK_KEYS,
    CantileverBeam,
    ModalModel,
    coupled_frozen_modes,
    frozen_modal_table,
)
from sloshrom.config import G, Tank
from sloshrom.models import SloshingModel

__all__ = ["CaseResults", "Simulate", "case_output_fs", "envelope_table", "frozen_modes_table",
           "reference_tank", "simulate_cases"]

#: A simulation of one case: ``simulate(model, output_fs)`` returns the result dict of
#: ``sloshrom.beam.simulation.coupled.free_response``/``random_response``; ``model`` is one sloshing
#: model or one per tank (a member of a :class:`~sloshrom.beam.simulation.members.Members` is
#: either).
Simulate = Callable[[Any, float | None], dict[str, Any]]
#: What :func:`simulate_cases` returns: case name -> its result dict.
CaseResults = dict[str, dict[str, Any]]


# -- simulation ----------------------------------------------------------------------------------
def case_output_fs(model: SloshingModel | Sequence[SloshingModel], fs: float) -> float | None:
    """Rate of a case's results, Hz: ``fs``, or ``None`` (the model's own rate) if it is slower.

    A fast model (the rig at 10 kHz) is decimated to the sensors' rate ``fs``; a model running at
    ``fs`` or below keeps its own step. With one model per tank, the fastest decides.
    """
    if isinstance(model, Members):  # the members run at one step (one ROM)
        return case_output_fs(cast("SloshingModel | Sequence[SloshingModel]", model.models[0]),
                              fs)
    models: list[SloshingModel] = (list(model) if isinstance(model, (list, tuple))
                                   else [cast("SloshingModel", model)])
    return fs if max(1.0 / m.dt for m in models) > fs else None


def _simulate_at(simulate: Simulate, output_fs: float | None, model: object
                 ) -> dict[str, object]:
    return simulate(model, output_fs)


def simulate_cases(models: Mapping[str, Any], simulate: Simulate, fs: float,
                   on_case: Callable[[str], None] | None = None) -> CaseResults:
    """Run ``simulate`` for every case, in order; results at :func:`case_output_fs`.

    Parameters
    ----------
    models : mapping
        Case name -> sloshing model, or a list of them (one per tank), or a
        :class:`~sloshrom.beam.simulation.members.Members`: each member simulated alone (in
        threads, a usable core each: :func:`sloshrom._threads.map_threads`), the case's
        result their :func:`~sloshrom.beam.simulation.members.mean_result` (the members'
        results under ``"members"``).
    simulate : callable
        ``simulate(model, output_fs)`` -> result dict.
    fs : float
        Rate of the results (the beam's sensors), Hz.
    on_case : callable, optional
        Called with the case name before its simulation (progress reports).

    Returns
    -------
    dict
        Case name -> result dict.
    """
    results = {}
    for case, model in models.items():
        if on_case is not None:
            on_case(case)
        out_fs = case_output_fs(model, fs)
        if isinstance(model, Members):
            # each member's run alone, a core each (their results as the loop's)
            results[case] = mean_result(map_threads(
                functools.partial(_simulate_at, simulate, out_fs), model.models))
        else:
            results[case] = simulate(model, out_fs)
    return results


def frozen_modes_table(tank: Tank | Sequence[Tank], modal: ModalModel,
                       beam: CantileverBeam | None = None) -> list[dict[str, float]]:
    """Paper Table 1: the beam's modes with frozen liquid, one row per mode of ``modal``.

    With the Euler-Bernoulli ``beam`` that ``modal`` was made from: the full table of
    ``sloshrom.beam.simulation.structure.frozen_modal_table`` (dry, frozen and coupled frequencies,
    Hz; damping; modal masses, kg). Without it (the user's own modal data): ``mode``, ``f_dry_Hz``,
    ``f_coupled_Hz`` (frozen liquid in the coupled model, every tank's) and ``damping`` only.
    """
    tanks: list[Tank] = list(tank) if isinstance(tank, (list, tuple)) else [cast("Tank", tank)]
    if beam is not None and len(tanks) == 1:
        return frozen_modal_table(tanks[0], beam=beam, n_modes=modal.n_modes,
                                  damping=modal.damping.tolist())
    fc, _ = coupled_frozen_modes(modal, [t.liquid_mass for t in tanks])
    return [{"mode": n + 1, "f_dry_Hz": float(modal.frequencies[n]),
             "f_coupled_Hz": float(fc[n]), "damping": float(modal.damping[n])}
            for n in range(modal.n_modes)]


def reference_tank(res: Mapping[str, Any], tank: int = 0) -> dict[str, Any]:
    """A result of several tanks seen through one of them: the per-tank signals (and their
    envelope coverage) of tank ``tank`` (0-based) only, as a one-tank result.

    The first-mode analyses and figures read ``tank_acceleration`` as the amplitude axis and
    the response; with several tanks they use the reference tank's. A one-tank result is
    returned unchanged; an ensemble's members (``"members"``) are seen through the same tank.
    """
    if np.ndim(res["tank_acceleration"]) == np.ndim(res["base_acceleration"]):
        return dict(res)
    out = dict(res)
    if res.get("members"):
        out["members"] = [reference_tank(m, tank) for m in res["members"]]
    for k in TANK_KEYS:
        out[k] = res[k][..., tank]
    for k in ("envelope_outside_fraction", "envelope_acceleration_ratio",
              "training_peak_acceleration"):
        if k in res:
            out[k] = np.asarray(res[k])[..., tank]
    return out


def envelope_table(results: Mapping[str, Mapping[str, Mapping[str, Any]]]
                   ) -> list[dict[str, Any]]:
    """How far each run goes beyond its model's training envelope: one row per test, case and
    level.

    Parameters
    ----------
    results : mapping
        Test name (``"free"``, ``"random"``) -> case -> result dict of
        :meth:`CoupledSimulator.run <sloshrom.beam.simulation.coupled.CoupledSimulator.run>` (with
        the ``envelope_*`` entries).

    Returns
    -------
    list of dict
        ``run`` (e.g. ``"free"``, ``"random 0.4 g"``), ``case``, ``peak_tank_acceleration_g``,
        ``training_peak_acceleration_g``, ``acceleration_ratio`` and ``outside_fraction``
        (-); the last three are ``None`` (n/a) for a model without an envelope or an envelope
        without ``acceleration_max``.
    """

    def value(x: Any) -> float | None:
        x = float(x)
        return x if np.isfinite(x) else None

    rows = []
    for test, cases in results.items():
        for case, r in cases.items():
            acc = np.asarray(r["tank_acceleration"])
            frac = np.asarray(r.get("envelope_outside_fraction", np.nan), dtype=float)
            ratio = np.asarray(r.get("envelope_acceleration_ratio", np.nan), dtype=float)
            train = value(r.get("training_peak_acceleration", np.nan))
            runs = ([(test, acc, frac, ratio)] if acc.ndim == 1 else
                    [(f"{test} {lv:g} g", acc[i], np.broadcast_to(frac, acc.shape[:1])[i],
                      np.broadcast_to(ratio, acc.shape[:1])[i])
                     for i, lv in enumerate(r["rms_levels_g"])])
            for run, a, f, q in runs:
                rows.append({"run": run, "case": case,
                             "peak_tank_acceleration_g": float(np.max(np.abs(a))) / G,
                             "training_peak_acceleration_g": None if train is None
                             else train / G,
                             "acceleration_ratio": value(q), "outside_fraction": value(f)})
    return rows

