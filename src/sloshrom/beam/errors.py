"""The error type of the beam room.

:class:`BeamError` is the base of every *user* error the beam raises: a bad argument of the coupled
simulation or of an analysis, a beam result that cannot be exported, the user's modal data. It is
a :class:`~sloshrom.errors.SloshromError`, which command-line tools catch and print in one line.
Its subclasses say more: :class:`~sloshrom.beam.damping.analysis.AnalysisError` (a response that
cannot be analysed as asked) and :class:`~sloshrom.beam.simulation.structure.ModalDataError` (modal
data that are inconsistent or unphysical; also a :class:`~sloshrom.config.ConfigError`, as the rest
of the structure's configuration).
"""

from __future__ import annotations

from sloshrom.errors import SloshromError

__all__ = ["BeamError"]


class BeamError(SloshromError):
    """Bad input to the beam: simulation or analysis arguments, a result to export."""
