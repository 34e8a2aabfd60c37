"""The bouncing-ball baseline: an equivalent mechanical model beside the ROM.

``table`` and ``defaults.toml`` (its part of the configuration: the ``[baseline]`` table, its
switch ``[beyond] baseline``, their defaults and checks), ``config`` (the ball's arguments, the
study's names), ``stage`` (the fit, the map, the beam tests and the comparison:
:func:`~sloshrom.studies.baseline.stage.stage_baseline`), ``outputs``
(:class:`~sloshrom.studies.baseline.outputs.BaselineOutputs`), ``section`` (the report
section), ``figures``, ``study`` (its declaration to the pipeline, ``STUDY``). The model
itself is :class:`sloshrom.rom.ball.model.BouncingBall`.

Nothing is imported here: the settings read ``table`` when they start, the chain ``study``.
"""
