"""The registry of damping estimators: the one list that analyses, tables, comparisons, the
report and the figures loop over.

:data:`ESTIMATORS` maps a name to its estimator
(``sloshrom.beam.damping.estimators.DampingEstimator``), in registration order; :func:`register`
adds one, :func:`get_estimator` finds one by name and :func:`estimator_names` checks a user's list.
:data:`TABLE2` is the default selection, paper Table 2's three estimators (what ``sloshrom
reproduce`` and ``sloshrom analyse`` compute unless told otherwise); :data:`REFERENCE` the one the
studies and the ROM ensembles quote.

Adding an estimator: a module with a class following the protocol, and one ``register`` line
at the end of this file (``docs/architecture.md``, "Damping estimators").
"""

from __future__ import annotations

from collections.abc import Iterable

from sloshrom.beam.damping.estimators import DampingEstimator, HalfPower, LscfH1, LscfOutput
from sloshrom.beam.damping.ssi import SsiCov
from sloshrom.beam.errors import BeamError

__all__ = ["ESTIMATORS", "FREE_DECAY_METHODS", "REFERENCE", "TABLE2", "estimator_names",
           "get_estimator", "label", "register"]

#: Every registered estimator, by name, in registration order.
ESTIMATORS: dict[str, DampingEstimator] = {}

#: The methods of free decays (per amplitude band,
#: ``sloshrom.beam.damping.uncertainty.band_damping``): name -> label. They are not estimators of
#: this protocol (a decay gives one value per band, not one per record); their names are the
#: ``method`` column of the band tables.
FREE_DECAY_METHODS: dict[str, str] = {"hilbert": "Hilbert", "log_decrement": "log decrement"}


def register(estimator: DampingEstimator) -> DampingEstimator:
    """Add ``estimator`` under its ``name`` (a lower-case identifier, not yet registered) and
    return it."""
    name = getattr(estimator, "name", None)
    if not (isinstance(name, str) and name.isidentifier() and name == name.lower()):
        raise BeamError(f"an estimator name must be a lower-case identifier, got {name!r}")
    if not isinstance(estimator, DampingEstimator):
        raise BeamError(f"{name!r} does not follow the DampingEstimator protocol")
    if estimator.uncertainty not in ("bootstrap", "spread", "au"):
        raise BeamError(f"{name!r}: uncertainty must be 'bootstrap', 'spread' or 'au', got "
                        f"{estimator.uncertainty!r}")
    if name in ESTIMATORS or name in FREE_DECAY_METHODS:
        raise BeamError(f"an estimator named {name!r} is already registered")
    ESTIMATORS[name] = estimator
    return estimator


def get_estimator(name: str) -> DampingEstimator:
    """The registered estimator ``name``; a BeamError naming the known ones otherwise."""
    try:
        return ESTIMATORS[name]
    except KeyError:
        raise BeamError(f"unknown damping estimator {name!r}; known: "
                        f"{', '.join(ESTIMATORS)}") from None


def estimator_names(names: Iterable[str] | None = None) -> tuple[str, ...]:
    """``names`` checked against the registry (default :data:`TABLE2`), duplicates dropped."""
    out = tuple(dict.fromkeys(TABLE2 if names is None else names))
    for n in out:
        get_estimator(n)
    if not out:
        raise BeamError("no damping estimator selected")
    return out


def label(name: str) -> str:
    """The human label of an estimator or free-decay method (the name itself if unknown)."""
    est = ESTIMATORS.get(name)
    return est.label if est is not None else FREE_DECAY_METHODS.get(name, name)


register(LscfH1())
register(LscfOutput())
register(HalfPower())
register(SsiCov())

#: Paper Table 2's estimators, in its column order: the default of every analysis and table.
TABLE2: tuple[str, ...] = (LscfH1.name, LscfOutput.name, HalfPower.name)
#: The estimator the studies and the ensemble spreads quote (LSCF on H1, the paper's).
REFERENCE: str = TABLE2[0]
