"""The studies beyond the paper (``sloshrom reproduce --beyond``), one package each.

Each study is a room of its own: its part of the configuration (``table``, with its defaults
``defaults.toml``: its own table and its keys of ``[beyond]``, their checks), its computation
and stage function, a typed outputs object, its section of the report and its figures, and, in
its module ``study``, ``STUDY``: the :class:`~sloshrom.pipeline.study.Study` that declares all
this to the pipeline:

* :mod:`~sloshrom.studies.baseline`: the bouncing-ball equivalent mechanical model beside the
  ROM (``[baseline]``);
* :mod:`~sloshrom.studies.fills`: one ROM for every fill level, judged at unseen fills
  (the fill keys of ``[beyond]``);
* :mod:`~sloshrom.studies.multimode`: a structure with two active modes, VFA-only against
  broadband-trained ROMs (``[multimode]``).

The registry that lists them, in the order the chain runs them and the report shows them, is
below the pipeline: :data:`sloshrom.pipeline.registry.STUDIES` (the settings assemble the
configuration from the studies' tables, :func:`sloshrom.pipeline.study.registered` gives the
chain and the report their declarations). A study reads the files of the stages before it
through their cache records (:meth:`sloshrom.pipeline.cache.StageResult.output`), never from
paths it assumes. Studies import the base, the domain rooms, ``plotting`` and the pipeline's
infrastructure (schema, settings, cache, context, html, the study protocol and the paper's
stage helpers they reuse), never the chain or the report; nothing below imports a study.
"""
