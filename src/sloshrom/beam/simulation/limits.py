"""What the beam tests can run: the one definition of each limit and check of a beam simulation,
read by the command line (``sloshrom beam``) and the settings of ``sloshrom reproduce`` alike.

* :data:`BEAM_FS`, :data:`MAX_BEAM_SECONDS`, :data:`MAX_LEVEL_SECONDS`, :data:`MAX_BEAM_MODES` -
  the results' default rate, the longest run, the longest random test over its levels and the
  most modes of the built-in beam;
* :func:`check_psd_band` - a random test's Gaussian PSD inside the band of its rate;
* :func:`first_frozen_frequency` - the first mode with frozen liquid, the mode the damping
  analyses follow.

Numbers and light functions only (no numerical library beyond NumPy): the command line reads
them when it starts.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path

from sloshrom.beam.simulation.structure import (
    N_STATIONS,
    CantileverBeam,
    ModalModel,
    coupled_frozen_modes,
)
from sloshrom.config import ConfigError, Tank

__all__ = ["BEAM_FS", "MAX_BEAM_MODES", "MAX_BEAM_SECONDS", "MAX_LEVEL_SECONDS", "check_psd_band",
           "first_frozen_frequency"]

#: Default rate of the beam results (``sloshrom beam``), Hz; `reproduce` uses ``rig.fs``.
BEAM_FS = 500.0
#: Longest beam simulation, s (the rig runs at 10 kHz inside the coupled loop).
MAX_BEAM_SECONDS = 600.0
#: Random responses of the rig hold about 2.1 MB per second and per level at its 10 kHz step
#: (measured): duration x number of levels is bounded to keep a run within about 4 GB.
MAX_LEVEL_SECONDS = 1800.0
#: Accelerometer stations of the built-in beam: the modal filter separates at most this many
#: modes.
MAX_BEAM_MODES = N_STATIONS


def first_frozen_frequency(tank: Tank, n_modes: int = 3, damping: Sequence[float] | None = None,
                           modal_toml: str | Path | None = None,
                           beam: CantileverBeam | None = None) -> float:
    """First mode (Hz) of the beam with frozen liquid: the mode the damping analyses follow.

    The beam ``beam`` (default: the paper's) with ``n_modes`` modes of ``damping`` carrying
    ``tank``, or the modal model of ``modal_toml``."""
    if modal_toml is not None:
        modal = ModalModel.from_toml(modal_toml)
    else:
        modal = ModalModel.from_beam(beam, tank=tank, n_modes=n_modes, damping=damping)
    return float(coupled_frozen_modes(modal, tank.liquid_mass)[0][0])


def check_psd_band(f0: float, sigma: float, names: tuple[str, str] = ("--f0", "--sigma"),
                   error: type[ValueError] = ConfigError, fs: float = BEAM_FS) -> None:
    """The random-excitation PSD (paper Eq. 8) must lie inside (0, Nyquist) of the signal at fs.

    The base acceleration is synthesised at ``fs`` (Hz; then upsampled band-limited for the
    rig): ``sloshrom.signals.random_base_acceleration`` needs ``f0 + 4 sigma`` below the
    Nyquist frequency, and a band reaching below 0 Hz (``f0 - 3 sigma < 0``) would fold onto
    positive frequencies and no longer be the Gaussian asked for. ``names`` are the option's or
    the keys' names in the message, ``error`` its type.
    """
    n0, ns = names
    for name, v in ((n0, f0), (ns, sigma)):
        if not (isinstance(v, int | float) and not isinstance(v, bool) and math.isfinite(v)
                and v > 0):
            raise error(f"{name} must be a positive frequency in Hz, got {v!r}")
    nyq = fs / 2
    if f0 + 4 * sigma >= nyq:
        raise error(f"{n0} + 4 {ns} = {f0 + 4 * sigma:g} Hz must stay below {nyq:g} Hz, the "
                    f"Nyquist frequency of the {fs:g} Hz excitation (got f0 = {f0:g} Hz, "
                    f"sigma = {sigma:g} Hz)")
    if f0 - 3 * sigma < -1e-9:
        raise error(f"{n0} - 3 {ns} = {f0 - 3 * sigma:g} Hz must not be below 0 Hz (the PSD "
                    f"would fold onto positive frequencies; got f0 = {f0:g} Hz, "
                    f"sigma = {sigma:g} Hz)")
