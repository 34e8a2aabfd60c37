"""The error and warning types of the ROM room, in one place.

:class:`ROMError` is the base of every *user* error the ROMs raise (a bad hyperparameter, a
record that cannot be identified from, a model file that cannot be loaded, a model that goes
unstable on the user's input): a :class:`~sloshrom.errors.SloshromError`, which command-line
tools catch and print in one line. A plain ``ValueError`` from inside is a programming error.
:class:`TrainingWarning` says that a training ended where its result is probably poor (and why).
"""

from __future__ import annotations

from contextvars import ContextVar

from sloshrom.errors import SloshromError

# defined once, beside the model contract, for every sloshing model; re-exported here
from sloshrom.models import EnvelopeWarning

__all__ = ["EnvelopeWarning", "FeedthroughWarning", "FillRangeError", "HistoryError",
           "ModelSizeWarning", "NotFittedError", "ROMError", "TrainingWarning",
           "UnstableModelError", "members_quiet"]


class ROMError(SloshromError):
    """Bad input to a ROM: hyperparameters, training or prediction data, export options."""


class FillRangeError(ROMError):
    """A model was asked to run at a fill level outside the range it was identified on."""


class HistoryError(ROMError):
    """A fit's validation history (its first samples taken as measured history) that the fit
    cannot take: fewer samples than the class reads, or so many that too little is left to
    score.

    The message names the estimator's argument ``validation_history``; :attr:`samples` and
    :attr:`reason` let a caller name it in its own words (the command line's ``--history``).
    """

    def __init__(self, samples: int, reason: str) -> None:
        super().__init__(f"validation_history {samples}: {reason}")
        self.samples, self.reason = samples, reason

    def __reduce__(self) -> tuple[type[HistoryError], tuple[int, str]]:
        # rebuilt from its two fields (an ensemble's member raises it in a worker process)
        return type(self), (self.samples, self.reason)


class UnstableModelError(ROMError):
    """A recurrent (NOE) simulation became non-finite or left its stability bound.

    A property of the identified model on the input it was given (the user's model and data),
    not a bug: hence a :class:`ROMError`.
    """


class NotFittedError(ROMError, AttributeError):
    """A fitted attribute (``params_``, ``dt``, ...) was asked of a model not fitted yet.

    Also an ``AttributeError`` (as scikit-learn's), so that ``hasattr(model, "dt")`` and the
    ``isinstance`` checks of the model protocols answer False for an unfitted model instead of
    raising.
    """



class TrainingWarning(UserWarning):
    """A training stopped where its result is probably poor: Levenberg-Marquardt's damping
    passed ``mu_max`` (no step lowered the training error).

    The model is still fitted (the best parameters on validation so far); the message says at
    which epoch, why no step was taken and what to try. The reason is also in the model's
    ``history_`` (``stop_reason``, ``stop_message``). The command line prints it as one
    ``warning: ...`` line. Not issued while :data:`members_quiet` is set: an ensemble training
    its members in this process says it once for all of them.
    """


#: True while an ensemble trains its members in this process (in this context only: a thread
#: training another model beside it still warns, where a process-wide warnings filter would
#: silence it): a member's :class:`TrainingWarning` is then left to the ensemble.
members_quiet: ContextVar[bool] = ContextVar("sloshrom_members_quiet", default=False)


class FeedthroughWarning(UserWarning):
    """An exported model (an FMU) has direct feed-through: its force at a communication point
    reads the input of that point. A co-simulation master that reads the outputs before it
    sets the inputs gets the force one input late, and a feedback coupling through it is an
    algebraic loop; exported strictly proper it has neither (its force one step late). The
    command line prints it as one ``warning: ...`` line."""


class ModelSizeWarning(UserWarning):
    """A model the user sized has many more parameters than its training record supports
    (the size rule's, :meth:`sloshrom.rom.registry.ModelClass.oversize`): it will overfit.
    The message gives the samples per parameter and the rule's size."""
