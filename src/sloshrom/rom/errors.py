"""The error and warning types of the ROM room, in one place.

:class:`ROMError` is the base of every *user* error the ROMs raise (a bad hyperparameter, a
record that cannot be identified from, a model file that cannot be loaded): command-line tools
catch it and print one line. A plain ``ValueError`` from inside is a programming error.
"""

from __future__ import annotations

# defined once, beside the model contract, for every sloshing model; re-exported here
from sloshrom.models import EnvelopeWarning

__all__ = ["EnvelopeWarning", "FillRangeError", "NotFittedError", "ROMError", "UnstableModelError"]


class ROMError(ValueError):
    """Bad input to a ROM: hyperparameters, training or prediction data, export options."""


class FillRangeError(ROMError):
    """A model was asked to run at a fill level outside the range it was identified on."""


class UnstableModelError(RuntimeError):
    """A recurrent (NOE) simulation became non-finite or left its stability bound."""


class NotFittedError(RuntimeError, AttributeError):
    """A fitted attribute (``params_``, ``dt``, ...) was asked of a model not fitted yet.

    Also an ``AttributeError``, so that ``hasattr(model, "dt")`` and the ``isinstance`` checks of
    the model protocols answer False for an unfitted model instead of raising.
    """

