"""The two-mode wing study: do ROMs predict the damping of a structure with two active modes?

``table`` and ``defaults.toml`` (its part of the configuration: the ``[multimode]`` table, its
switch ``[beyond] multimode``, their defaults and checks), ``config`` (the study's cases, the
wing and the ROMs of its table), ``stage`` (the records, the three ROMs, the random tests and
their modal damping: :func:`~sloshrom.studies.multimode.stage.stage_multimode`), ``outputs``
(:class:`~sloshrom.studies.multimode.outputs.MultimodeOutputs`), ``section`` (the report
section), ``figures``, ``study`` (its declaration to the pipeline, ``STUDY``). The wing and its
damping analysis are domain physics, in :mod:`sloshrom.beam.simulation.wing` and
:mod:`sloshrom.beam.damping.multimode`; the broadband records' signal is
:func:`sloshrom.signals.broadband_acceleration`.

Nothing is imported here: the settings read ``table`` when they start, the chain ``study``.
"""
