"""The registry of the studies beyond the paper: which studies ``sloshrom reproduce`` runs, and
in which order.

:data:`STUDIES` names each study's package (``sloshrom.studies.<name>``), in the order the chain
runs them and the report shows them. Each package holds ``table`` (``TABLE``, a
:class:`~sloshrom.pipeline.schema.StudyTable`: its part of the configuration, light) and
``study`` (``STUDY``, a :class:`~sloshrom.pipeline.study.Study`: its stage and section, which
load what the stage needs). :func:`study_tables` gives the settings the former, from which
they assemble the configuration; :func:`sloshrom.pipeline.study.registered` gives the chain
and the report the latter.

The modules are named here as strings and imported on first use: no module of the pipeline
imports a study (``tests/test_architecture.py``), a study imports the pipeline's
infrastructure.
"""

from __future__ import annotations

import importlib
from functools import cache

from sloshrom.pipeline.schema import StudyTable

__all__ = ["STUDIES", "study_tables"]

#: The registry: one line per study, its package, in the order of the chain and the report.
STUDIES = (
    "sloshrom.studies.baseline",
    "sloshrom.studies.fills",
    "sloshrom.studies.multimode",
)


@cache
def study_tables() -> tuple[StudyTable, ...]:
    """Each registered study's part of the configuration (its module ``table``'s ``TABLE``), in
    the order of :data:`STUDIES`.

    Raises
    ------
    TypeError
        A registered package without a ``TABLE`` (a programming error of the registry).
    """
    out = []
    for package in STUDIES:
        table = getattr(importlib.import_module(f"{package}.table"), "TABLE", None)
        if not isinstance(table, StudyTable):
            raise TypeError(f"{package}.table declares no TABLE (a "
                            "sloshrom.pipeline.schema.StudyTable)")
        out.append(table)
    return tuple(out)
