"""The studies beyond the paper, one package each (``sloshrom reproduce --beyond``).

Each study is a room of its own: its configuration (a table of ``defaults.toml``, validated by
:mod:`sloshrom.pipeline.settings`), its computation and stage function, a typed outputs object,
its section of the report and its figures:

* :mod:`~sloshrom.studies.baseline`: the bouncing-ball equivalent mechanical model beside the
  ROM (``[baseline]``);
* :mod:`~sloshrom.studies.fills`: one ROM for every fill level, judged at unseen fills
  (the fill keys of ``[beyond]``);
* :mod:`~sloshrom.studies.multimode`: a structure with two active modes, VFA-only against
  broadband-trained ROMs (``[multimode]``).

A study reads the files of the stages before it through their cache records
(:meth:`sloshrom.pipeline.cache.StageResult.output`), never from paths it assumes. Studies import
the base, the domain rooms, ``plotting`` and the pipeline's infrastructure (settings, cache,
context, html and the paper's stage helpers they reuse); only ``pipeline.chain`` and
``pipeline.report`` import the studies.
"""
