"""Ensemble ROMs in the beam tests: every member coupled alone, the ROM's prediction their mean.

An ensemble ROM is K networks (members). Coupled to the beam as one model (its force the mean of
the members' forces in one closed loop) it is not the mean of the members' predictions: the
loop is nonlinear in the force, and at 0.2 g the ensemble's first-mode damping was 1.97 % while
its members alone gave 1.87 ± 0.00 %. So a case whose model is a :class:`Members` runs each
member in its own coupled simulation (``sloshrom.beam.simulation.cases.simulate_cases``), and:

* its result dict holds the member-mean of every response array (:func:`mean_result`), with the
  members' own results under ``"members"``: the time histories, files and figures of the case;
* its damping estimates (Table 2, the free-decay bands) are the **mean of the members'
  estimates**, not the estimates of the mean response (:func:`combine_estimates`: Table 2's
  through ``sloshrom.beam.damping.tables.mode1_damping_dataset``, the bands' through
  :func:`combine_band_rows`).

**The ROM's uncertainty.** Each member's estimate has its own estimation standard deviation
``s_k`` (the record's statistical error, from the bootstrap, Au's law or the band's scatter);
the members scatter about their mean by ``s_b`` (standard deviation over members, ``ddof=1``:
the spread of the training draw). The ROM's standard deviation is

    std = sqrt(mean_k(s_k^2) + s_b^2)

(the law of total variance: the prediction of a network of this kind, drawn at random, read
through an uncertain estimator). The estimation part is *not* divided by K: the members see the
same base excitation and give nearly the same response, so their estimation errors are almost
fully correlated and averaging them does not shrink them (for fully correlated errors the
variance of the mean is ``(mean s_k)^2 <= mean s_k^2``: the mean of the variances is the
slightly conservative bound). The between-member part is not divided by K either: with K = 2 or
3 members ``s_b`` is itself poorly known, and the question the interval answers is where a
retrained ROM of this kind would land, not where the mean of infinitely many would. The
interval is ``mean -/+ q std``, ``q`` the mean over members of their own interval's quantile
``(high_k - low_k) / (2 s_k)`` (Student's t of the bootstrap, 1.96 of Au's law, ...).

Where some members have no estimate (NaN), the mean is over those that have one; ``members``
says how many and ``note`` why the others have none. With one estimate out of K > 1 members
the between-member spread is unknown: the standard deviation is that member's own, and the
note says so. A member estimate without a standard deviation (a band shorter than one
smoothing window) leaves the ROM without one too. A one-member ensemble has ``s_b = 0``.

Pure functions: result dicts, estimates and band rows in, the same out.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from sloshrom.beam.errors import BeamError

__all__ = ["ENVELOPE_KEYS", "Cell", "Combined", "Members", "Row", "combine_band_rows",
           "combine_estimates", "mean_result"]

#: A cell of a damping table: a number (damping ratio -, frequency Hz, count) or a text.
Cell = float | int | str
#: A row of a damping table (Table 2 or the free-decay bands): column name -> cell.
Row = dict[str, Cell]

#: Result entries of the training-envelope coverage: the worst member's (largest) is the
#: case's, so that averaging never hides a member that left its envelope.
ENVELOPE_KEYS = ("envelope_outside_fraction", "envelope_acceleration_ratio",
                 "training_peak_acceleration")
#: Result entries every member shares (the test's signals and axes): member 0's.
_SHARED_KEYS = ("time", "fs", "stations", "rms_levels_g", "q0", "base_acceleration")


@dataclass(frozen=True)
class Members:
    """The members of an ensemble ROM, to be coupled to the structure one at a time as one case.

    Attributes
    ----------
    models : tuple
        One entry per member: a sloshing model, or one per tank (a list) for a structure with
        several tanks.
    names : tuple of str
        The members' names (``member0``, ``member1``, ...), in the order of ``models``.
    """

    models: tuple[object, ...]
    names: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        if not self.models:
            raise BeamError("an ensemble needs at least one member")
        if not self.names:
            object.__setattr__(self, "names",
                               tuple(f"member{k}" for k in range(len(self.models))))
        if len(self.names) != len(self.models):
            raise BeamError(f"{len(self.names)} names for {len(self.models)} members")

    def __len__(self) -> int:
        return len(self.models)


def mean_result(results: Sequence[Mapping[str, object]]) -> dict[str, object]:
    """The result of a case whose members were coupled one at a time.

    Parameters
    ----------
    results : sequence of mapping
        Each member's result dict (``sloshrom.beam.simulation.coupled.free_response`` /
        ``random_response``), the same test.

    Returns
    -------
    dict
        Every response array (accelerations m/s^2, velocities m/s, forces N, ``q`` m) the mean
        over the members; the test's signals and axes (``time``, ``fs``, ``base_acceleration``,
        ...) member 0's; the envelope coverage (:data:`ENVELOPE_KEYS`) the largest over the
        members (NaN where no member has one); ``members`` (the members' result dicts, in
        order) and ``n_members``.
    """
    if not results:
        raise BeamError("no member results to average")
    first = results[0]
    out: dict[str, object] = {}
    for key, v in first.items():
        if key in ("members", "n_members") or key in _SHARED_KEYS:
            out[key] = v
        elif key in ENVELOPE_KEYS:
            stack = np.stack([np.asarray(r[key], dtype=float) for r in results])
            # the largest number (NaN where no member has one), without nanmax's all-NaN
            # warning: no warnings filter to change, which threads would share
            out[key] = np.fmax.reduce(stack, axis=0)
        elif isinstance(v, np.ndarray) and np.issubdtype(v.dtype, np.floating):
            out[key] = np.mean(np.stack([np.asarray(r[key]) for r in results]), axis=0)
        else:
            out[key] = v
    out["members"] = list(results)
    out["n_members"] = len(results)
    return out


def _listed_reasons(names: Sequence[str], reasons: Sequence[str]) -> str:
    # "member0: why; member1: why", members with the same reason named together
    groups: dict[str, list[str]] = {}
    for n, r in zip(names, reasons, strict=True):
        groups.setdefault(r or "no estimate", []).append(n)
    return "; ".join(f"{', '.join(ns)}: {r}" for r, ns in groups.items())


@dataclass(frozen=True)
class Combined:
    """One damping estimate of an ensemble ROM from its members' (:func:`combine_estimates`).

    Attributes
    ----------
    zeta : float
        Mean over the members with a value, -.
    std, low, high : float
        Combined standard deviation and interval, - (NaN where it cannot be formed).
    spread : float
        Standard deviation over the members' values (``ddof=1``), -; 0 for a one-member
        ensemble, NaN with one value out of several.
    members : int
        Members that gave a value.
    reason : str
        ``""`` when the value and its interval exist, else why not.
    note : str
        How the value was formed when not from every member; the members' notes.
    """

    zeta: float
    std: float
    low: float
    high: float
    spread: float
    members: int
    reason: str = ""
    note: str = ""


def combine_estimates(values: Sequence[float], stds: Sequence[float], lows: Sequence[float],
                      highs: Sequence[float], reasons: Sequence[str],
                      notes: Sequence[str] | None = None,
                      names: Sequence[str] | None = None) -> Combined:
    """One damping estimate of an ensemble ROM from its members' estimates (module docstring).

    Parameters
    ----------
    values, stds, lows, highs : sequence of float
        Each member's damping ratio, its standard deviation and interval, -; NaN where none.
    reasons : sequence of str
        Each member's reason for a missing value or interval (``""`` where both exist).
    notes : sequence of str, optional
        Each member's note (how a value was obtained, e.g. a fallback attempt).
    names : sequence of str, optional
        The members' names (default ``member0``, ...).

    Returns
    -------
    Combined
    """
    z = np.asarray(values, dtype=float)
    s = np.asarray(stds, dtype=float)
    lo, hi = np.asarray(lows, dtype=float), np.asarray(highs, dtype=float)
    k = z.size
    names = list(names) if names is not None else [f"member{i}" for i in range(k)]
    notes = list(notes) if notes is not None else [""] * k
    ok = np.isfinite(z)
    have = [int(i) for i in np.nonzero(ok)[0]]
    n = len(have)
    nan = float("nan")
    if n == 0:
        return Combined(nan, nan, nan, nan, nan, 0,
                        reason=f"no member has an estimate ({_listed_reasons(names, reasons)})")
    mean = float(np.mean(z[ok]))
    spread = float(np.std(z[ok], ddof=1)) if n > 1 else (0.0 if k == 1 else nan)
    parts = []
    missing = [i for i in range(k) if not ok[i]]
    if missing:
        parts.append(f"mean of {n} of {k} members; without an estimate: "
                     + _listed_reasons([names[i] for i in missing],
                                       [reasons[i] for i in missing]))
        if n == 1 and k > 1:
            parts.append("between-member spread unknown (one estimate): the interval is that "
                         "member's own")
    parts += [f"{names[i]}: {notes[i]}" for i in have if notes[i]]
    note = "; ".join(parts)
    bad = [i for i in have if not (np.isfinite(s[i]) and s[i] > 0)]
    if bad:
        why = _listed_reasons([names[i] for i in bad], [reasons[i] for i in bad])
        return Combined(mean, nan, nan, nan, spread, n, note=note,
                        reason=f"no interval: a member's estimate has none ({why})")
    own = s[ok]
    q = float(np.mean((hi[ok] - lo[ok]) / (2 * own)))
    std = math.sqrt(float(np.mean(own**2)) + (spread**2 if np.isfinite(spread) else 0.0))
    return Combined(mean, std, mean - q * std, mean + q * std, spread, n, note=note)


def _number(v: Cell) -> float:
    # a numeric cell as float; a text one (a reason) as NaN
    return float(v) if isinstance(v, (int, float, np.integer, np.floating)) else float("nan")


def combine_band_rows(case: str, member_rows: Sequence[Sequence[Mapping[str, Cell]]],
                      names: Sequence[str] | None = None) -> list[Row]:
    """The free-decay band rows of an ensemble ROM from its members' rows.

    Parameters
    ----------
    case : str
        The ROM's case name.
    member_rows : sequence of sequence of mapping
        Per member, its rows of ``sloshrom.beam.damping.tables.damping_band_table`` (``band``,
        ``method``, ``zeta``, ``std``, ``low``, ``high``, ``n_cycles``, ``reason``).
    names : sequence of str, optional
        The members' names.

    Returns
    -------
    list of dict
        One row per band and method, in member 0's order: ``case``, ``band``, ``method``, the
        combined ``zeta``, ``std``, ``low``, ``high`` (-), ``n_cycles`` (mean, -),
        ``reason``, ``note``, ``spread`` (-) and ``members`` (:func:`combine_estimates`).
    """
    out: list[Row] = []
    for row in member_rows[0]:
        same = [next(r for r in rows if r["band"] == row["band"]
                     and r["method"] == row["method"]) for rows in member_rows]
        c = combine_estimates([_number(r["zeta"]) for r in same],
                              [_number(r["std"]) for r in same],
                              [_number(r["low"]) for r in same],
                              [_number(r["high"]) for r in same],
                              [str(r.get("reason", "")) for r in same], None, names)
        cyc = np.array([_number(r["n_cycles"]) for r in same])
        out.append({"case": case, "band": row["band"], "method": row["method"],
                    "zeta": c.zeta, "std": c.std, "low": c.low, "high": c.high,
                    "n_cycles": float(np.mean(cyc)), "reason": c.reason, "note": c.note,
                    "spread": c.spread, "members": c.members})
    return out
