"""The studies beyond the paper, one package each (``sloshrom reproduce --beyond``), and their
registry.

Each study is a room of its own: its configuration (a table of ``defaults.toml``, validated by
:mod:`sloshrom.pipeline.settings`), its computation and stage function, a typed outputs object,
its section of the report and its figures, and, in its module ``study``, ``STUDY``: the
:class:`~sloshrom.pipeline.study.Study` that declares all this to the pipeline:

* :mod:`~sloshrom.studies.baseline`: the bouncing-ball equivalent mechanical model beside the
  ROM (``[baseline]``);
* :mod:`~sloshrom.studies.fills`: one ROM for every fill level, judged at unseen fills
  (the fill keys of ``[beyond]``);
* :mod:`~sloshrom.studies.multimode`: a structure with two active modes, VFA-only against
  broadband-trained ROMs (``[multimode]``).

:data:`STUDIES` is the registry: the module of each study's declaration, in the order the chain
runs them and the report shows them. The pipeline reads it through :func:`registered` and
imports no study by name. A study reads the files of the stages before it through their cache
records (:meth:`sloshrom.pipeline.cache.StageResult.output`), never from paths it assumes.
Studies import the base, the domain rooms, ``plotting`` and the pipeline's infrastructure
(settings, cache, context, html, the study protocol and the paper's stage helpers they reuse),
never the chain or the report.
"""

from __future__ import annotations

import importlib
from functools import cache

from sloshrom.pipeline.study import Study

__all__ = ["STUDIES", "registered"]

#: The registry: one line per study, the module holding its ``STUDY``.
STUDIES = (
    "sloshrom.studies.baseline.study",
    "sloshrom.studies.fills.study",
    "sloshrom.studies.multimode.study",
)


@cache
def registered() -> tuple[Study, ...]:
    """The registered studies, in the order of :data:`STUDIES`.

    Each study's modules are imported here, on the first call (they load what their stages
    need: JAX, xarray, matplotlib).

    Returns
    -------
    tuple of Study

    Raises
    ------
    TypeError
        A registered module without a ``STUDY``, or two studies of one name (a programming
        error of the registry).
    """
    out: list[Study] = []
    for path in STUDIES:
        study = getattr(importlib.import_module(path), "STUDY", None)
        if not isinstance(study, Study):
            raise TypeError(f"{path} declares no STUDY (a sloshrom.pipeline.study.Study)")
        if any(s.name == study.name for s in out):
            raise TypeError(f"{path}: a second study named {study.name!r}")
        out.append(study)
    return tuple(out)
