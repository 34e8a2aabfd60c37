"""What a record must hold for the damping analyses: the one definition of each such rule,
read by the analyses, the command line and the settings of ``sloshrom reproduce`` alike.

* :data:`WELCH_SEGMENT` - the Welch segment of the random tests' spectra and H1, samples: the
  default of every random-test estimator (``estimators.RandomTest``, ``uncertainty``,
  ``multimode``), the check of a random record's length (``sloshrom analyse random``,
  ``sloshrom beam random``, the settings) and the default of the ``[multimode] nperseg`` key;
  :data:`MIN_RANDOM_DURATION` - the shortest random test at the beam's default rate.
* :data:`TRIM_PERIODS`, :data:`SMOOTH_PERIODS` - what the instantaneous damping of a free decay
  trims and smooths (``analysis.instantaneous_damping``'s defaults);
  :data:`FREE_DAMPING_PERIODS`, :func:`min_free_duration` - the free decay it needs.
* :func:`check_analysis_band` - the analysed mode well below the results' Nyquist frequency.

Numbers and light functions only (NumPy at most): the command line reads them when it starts.
"""

from __future__ import annotations

import math

from sloshrom.beam.simulation.limits import BEAM_FS
from sloshrom.config import ConfigError

__all__ = ["FREE_DAMPING_PERIODS", "MIN_RANDOM_DURATION", "SMOOTH_PERIODS", "TRIM_PERIODS",
           "WELCH_SEGMENT", "check_analysis_band", "min_free_duration"]

#: Welch segment of the random tests' H1 and spectra, samples: the resolution of every damping
#: estimate of paper Table 2 (32.8 s at 500 Hz, 0.03 Hz lines; a 1 % mode at 10 Hz has a
#: 0.2 Hz half-power bandwidth). A random record must hold at least one segment.
WELCH_SEGMENT = 16384
#: A random response must hold at least one Welch segment (32.8 s at 500 Hz); 90 s (paper) give
#: four half-overlapping segments, hence a much smoother estimate.
MIN_RANDOM_DURATION = math.ceil(WELCH_SEGMENT / BEAM_FS)
#: Periods of the mode ``analysis.instantaneous_damping`` trims at each end of a free decay (the
#: band-pass filter's transients) and smooths its slope over.
TRIM_PERIODS = 5
SMOOTH_PERIODS = 4
#: Periods of a mode a free decay must hold for its damping analysis: the trimmed ends, one
#: smoothing window, and 4 more left to analyse (18 periods: 1.8 s for the paper beam,
#: f1 = 10.2 Hz).
FREE_DAMPING_PERIODS = 2 * TRIM_PERIODS + SMOOTH_PERIODS + 4


def min_free_duration(f1: float) -> float:
    """Shortest free response (s, rounded up to 0.1 s) whose damping at ``f1`` (Hz) can be
    analysed."""
    return math.ceil(10 * FREE_DAMPING_PERIODS / f1) / 10


def check_analysis_band(f1: float, error: type[ValueError] = ConfigError,
                        fs: float = BEAM_FS, band: tuple[float, float] | None = None) -> None:
    """The analysed mode must lie well below the results' Nyquist frequency.

    Without ``band`` (Hz) the damping analyses band-pass up to 1.5 ``f1``, which must stay below
    0.8 of the Nyquist frequency of ``fs`` (Hz). With ``band`` (a mode between neighbours), the
    band must hold ``f1`` (``0 <= low < f1 < high``) and ``f1`` must lie below 0.8 of the
    Nyquist frequency; an upper edge beyond the Nyquist frequency is clipped by the estimators.
    ``error`` is the type raised.
    """
    nyq = 0.8 * fs / 2
    if band is None:
        if not 1.5 * f1 < nyq:
            raise error(f"the first beam mode ({f1:.4g} Hz) is too high for the {fs:g} Hz "
                        f"results: the damping analyses band-pass up to 1.5 f1, which must "
                        f"stay below {nyq:g} Hz")
        return
    lo, hi = band
    if not (math.isfinite(lo) and math.isfinite(hi) and 0 <= lo < f1 < hi):
        raise error(f"the analysis band {lo:g}-{hi:g} Hz must hold the mode ({f1:.4g} Hz)")
    if not f1 < nyq:
        raise error(f"the mode ({f1:.4g} Hz) is too high for the {fs:g} Hz results: it must "
                    f"stay below {nyq:g} Hz (0.8 of the Nyquist frequency)")
