"""The fill-level study: one ROM for every fill level, judged at fills no member saw.

``table`` and ``defaults.toml`` (its part of the configuration: its keys of ``[beyond]``, their
defaults and checks), ``config`` (a member's configuration, the targets), ``stage``
(:func:`~sloshrom.studies.fills.stage.stage_fills`), ``outputs``
(:class:`~sloshrom.studies.fills.outputs.FillsOutputs`), ``section`` (the report section),
``figures``, ``study`` (its declaration to the pipeline, ``STUDY``). The family itself, a
model combinator, is :mod:`sloshrom.rom.family`.

Nothing is imported here: the settings read ``table`` when they start, the chain ``study``.
"""
