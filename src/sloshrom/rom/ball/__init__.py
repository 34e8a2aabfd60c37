"""The bouncing-ball equivalent mechanical model of vertical sloshing: the physics baseline.

One package, as every model of the registry: ``entry`` (its model files and constants, no
numba) and ``model`` (the kernel, the fitted :class:`Ball` and the estimator
:class:`BouncingBall`, fitted by differential evolution). The names below are resolved on
first use, so that the entry loads alone.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from sloshrom.rom.lazy import exports

if TYPE_CHECKING:
    from sloshrom.rom.ball.entry import (
        BALL_FILES as BALL_FILES,
    )
    from sloshrom.rom.ball.entry import (
        is_ball_file as is_ball_file,
    )
    from sloshrom.rom.ball.model import (
        Ball as Ball,
    )
    from sloshrom.rom.ball.model import (
        BouncingBall as BouncingBall,
    )
    from sloshrom.rom.ball.model import (
        ball_kernel_step as ball_kernel_step,
    )
    from sloshrom.rom.ball.model import (
        forward_acceleration as forward_acceleration,
    )
    from sloshrom.rom.ball.model import (
        lowpass_gain as lowpass_gain,
    )

_NAMES = {"BALL_FILES": "entry", "is_ball_file": "entry", "Ball": "model",
          "BouncingBall": "model", "ball_kernel_step": "model", "forward_acceleration": "model",
          "lowpass_gain": "model"}
__all__ = sorted(_NAMES)
__getattr__, __dir__ = exports(__name__, _NAMES)
