"""What a record must hold for the damping analyses: the one definition of each such rule.

* :data:`WELCH_SEGMENT` - the Welch segment of the random tests' spectra and H1, samples: the
  default of every random-test estimator (``estimators.RandomTest``, ``uncertainty``,
  ``multimode``), the check of a random record's length (``sloshrom analyse random``,
  ``sloshrom beam random``, the settings of ``sloshrom reproduce``) and the default of the
  ``[multimode] nperseg`` key.

Numbers only (no numerical library): the command line reads them when it starts.
"""

from __future__ import annotations

__all__ = ["WELCH_SEGMENT"]

#: Welch segment of the random tests' H1 and spectra, samples: the resolution of every damping
#: estimate of paper Table 2 (32.8 s at 500 Hz, 0.03 Hz lines; a 1 % mode at 10 Hz has a
#: 0.2 Hz half-power bandwidth). A random record must hold at least one segment.
WELCH_SEGMENT = 16384
