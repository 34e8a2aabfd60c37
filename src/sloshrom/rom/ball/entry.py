"""The bouncing ball's entry in the registry: its model files, without numba.

The bouncing ball (:mod:`sloshrom.rom.ball.model`) is a physics model fitted by differential
evolution, not a network class of ``sloshrom train``: what the registry knows of it is its
files (:data:`BALL_FILES`, a :class:`~sloshrom.rom.registry.FileKind`), which
:func:`sloshrom.rom.load_model` recognises by their ``[bouncing_ball]`` table, and the
constants of its format and parameters.
"""

from __future__ import annotations

import tomllib
from pathlib import Path

from sloshrom.rom.registry import FileKind

__all__ = ["BALL_FILES", "BALL_FORMAT", "BALL_FORMAT_VERSION", "LIMITS", "MAX_MODEL_STEP",
           "is_ball_file"]

#: Format tag and version of the TOML model file (table ``[bouncing_ball]``).
BALL_FORMAT = "sloshrom-bouncing-ball"
#: 2: the envelope's input range is the acceleration (version 1: the velocity)
BALL_FORMAT_VERSION = 2

#: Largest model step (s) of :class:`~sloshrom.rom.ball.model.BouncingBall` with
#: ``n_substeps=None``: the virtual rig's.
MAX_MODEL_STEP = 1e-4

#: Physical limits of the parameters and their search bounds: (low, high, low open?).
LIMITS: dict[str, tuple[float, float, bool]] = {
    "mass_fraction": (0.0, 1.0, True),  # beta in (0, 1]: the ball is part of the liquid
    "restitution": (0.0, 1.0, False),  # e in [0, 1]: an impact cannot create energy
    "gap_factor": (0.0, 10.0, True),  # gamma in (0, 10]: Gap / ullage (10: a sanity bound)
}


def is_ball_file(path: str | Path) -> bool:
    """True if ``path`` is a ``.toml`` file with a ``[bouncing_ball]`` table (for dispatch).

    Reads the file as TOML only; a file that is not valid TOML is not a ball file.
    """
    p = Path(path)
    if p.suffix.lower() != ".toml" or not p.is_file():
        return False
    try:
        return isinstance(tomllib.loads(p.read_text(encoding="utf-8")).get("bouncing_ball"),
                          dict)
    except (tomllib.TOMLDecodeError, UnicodeDecodeError, OSError):
        return False


#: Its model files, for :func:`sloshrom.rom.load_model`.
BALL_FILES = FileKind("bouncing ball", is_ball_file,
                      "sloshrom.rom.ball.model:BouncingBall.load")
