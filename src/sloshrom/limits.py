"""The ROMs' trainers, hyperparameter limits and the passive recipe's defaults, in one place.

The command line (``sloshrom train``, ``sweep``), the configuration of `sloshrom reproduce`
(``sloshrom.pipeline.settings``) and the model-file schema (``sloshrom.rom.modelfile``) all
take these values from here, so that a network one of them accepts the others accept too. A
base module: it imports nothing heavy (no JAX), so the command line and the settings read it
at start-up.

Where two of those places disagreed, the larger limit is kept, so that nothing that worked
before is refused: a model file written with it must still load, and the schema was the widest.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Literal

__all__ = [
    "ARCH_TRAINERS",
    "HIDDEN_KINDS",
    "MAX_BATCH",
    "MAX_DELAY",
    "MAX_EPOCHS",
    "MAX_MEMBERS",
    "MAX_NEURONS",
    "MAX_OUT_DELAYS",
    "MAX_SEED",
    "MAX_STATES",
    "MAX_WEIGHTS",
    "NSS_RECIPE",
    "RECIPE",
    "RECIPE_UNITS",
    "TRAINERS",
    "Hidden",
    "LossChoice",
    "loss_recipe",
]

#: Training algorithms of the estimators: subsampled Levenberg–Marquardt, full LM (MATLAB's
#: ``trainlm``) and optax Adam (the NFIR's default; for an NOE multiple shooting), the one with the
#: recipe's loss terms.
TRAINERS = ("fast", "lm", "adam")
#: The normalized-RBF variants of the hidden layer: MATLAB's ``radbasn`` (``W x + b``) and the
#: distance form (``b ||x - C||``); :mod:`sloshrom.rom.network`.
Hidden = Literal["matlab", "distance"]
HIDDEN_KINDS: tuple[str, ...] = ("matlab", "distance")
#: The trainers each architecture accepts (an NOE by LM or by multiple shooting with Adam).
ARCH_TRAINERS: dict[str, tuple[str, ...]] = {"nfir": ("adam", "fast", "lm"),
                                             "noe": ("fast", "lm", "adam")}

#: Largest input delay, samples. The model-file schema's 10 000 is kept (the command line and
#: the settings said 1000): a file with a sparse delay line reaching it loads today. The memory
#: of a contiguous delay line is bounded separately, by the model file's regressor limit
#: (``sloshrom.rom.modelfile.MAX_REGRESSOR``, 4096 entries).
MAX_DELAY = 10_000
#: Most hidden neurons. The schema's 4096 is kept (the command line and settings said 1000).
MAX_NEURONS = 4096
#: Most fed-back outputs of an NOE (the schema's value; `reproduce` uses 2).
MAX_OUT_DELAYS = 1000
#: Most training epochs, and so entries of each history list. The schema's 10 000 000 is kept
#: (the command line and settings said 100 000) so that every file written today loads; the
#: metadata's size limit, not this one, is what bounds a saved history (~40 000 epochs).
MAX_EPOCHS = 10_000_000
#: Most members of an ensemble.
MAX_MEMBERS = 64
#: Most network weights one model file holds, members x neurons x regressor entries (32 MiB
#: of float64).
MAX_WEIGHTS = 2**22
#: Largest state of a neural state-space ROM (NSS).
MAX_STATES = 1024
#: Most sub-sequences per Adam step of an NSS.
MAX_BATCH = 65536
#: Largest seed: JAX PRNG keys take 32-bit seeds.
MAX_SEED = 2**32 - 1

#: The passive recipe of an NFIR trained by Adam (docs/rom.md, "A passive ROM"): the loss
#: weight floor of the amplitude weighting 1/(a^2 + eps^2), eps in m/s; the weight of the
#: penalty on energy created at harmonic probes; the weight of the error of each input cycle's
#: exchanged energy. ``sloshrom.pipeline``'s ``defaults.toml`` holds the same values (a test
#: checks that they agree).
RECIPE: dict[str, float] = {"amplitude_weighting": 0.05, "passivity": 1.0, "cycle_energy": 0.1}
#: The loss recipe of a state-space ROM (NSS) trained on a velocity in m/s and a force in N:
#: the same terms as :data:`RECIPE` (the energy term judges each training sub-sequence's
#: exchanged energy); all 0 (plain MSE) until its weights are measured.
NSS_RECIPE: dict[str, float] = {"amplitude_weighting": 0.0, "passivity": 1.0,
                                "cycle_energy": 0.1}
#: The units the recipe is written for: a velocity in, a force out (F v is a power).
RECIPE_UNITS = ("m/s", "N")


@dataclass(frozen=True)
class LossChoice:
    """The loss chosen for a pair of units: the recipe's ``terms`` (all 0: plain MSE), ``why``.

    ``str()`` is the line the command line prints.
    """

    passive: bool
    terms: dict[str, float]
    why: str

    @property
    def name(self) -> str:
        """``"the passive recipe (amplitude weighting 0.05 m/s, ...)"`` or ``"the plain MSE"``."""
        if not self.passive:
            return "the plain MSE"
        return "the passive recipe (" + ", ".join(
            f"{k.replace('_', ' ')} {v:g}{' m/s' if k == 'amplitude_weighting' else ''}"
            for k, v in self.terms.items()) + ")"

    def __str__(self) -> str:
        return f"loss: {self.name}: {self.why}"


def loss_recipe(input_unit: str, output_unit: str,
                same: Callable[[str, str], bool] | None = None) -> LossChoice:
    """The default loss of an NFIR trained by Adam, chosen by the units of its records.

    The recipe's terms are written for the power F v a tank exchanges with its structure: they
    hold for a velocity in (m/s) and a force out (N) and nowhere else; any other pair trains on
    the plain MSE.

    Parameters
    ----------
    input_unit, output_unit : str
        The records' units of the network's input and output.
    same : callable, optional
        ``same(a, b)`` says whether two unit strings denote one unit (the command line passes
        ``sloshrom.io.same_unit``, which knows the spellings); default: equal once spaces are
        removed.

    Returns
    -------
    LossChoice
        ``terms`` are :data:`RECIPE` or all zero; ``str()`` of it is one line saying which and
        why.
    """
    def _same(a: str, b: str) -> bool:
        return a.replace(" ", "") == b.replace(" ", "")

    eq = same or _same
    vin, fout = RECIPE_UNITS
    if eq(input_unit, vin) and eq(output_unit, fout):
        return LossChoice(True, dict(RECIPE),
                          f"the input is a velocity ({vin}) and the output a force ({fout}), "
                          "so their product is the power the recipe's terms are written for")
    return LossChoice(False, dict.fromkeys(RECIPE, 0.0),
                      f"the input is in '{input_unit}' and the output in '{output_unit}', not a "
                      f"velocity ({vin}) in and a force ({fout}) out, so the passive recipe's "
                      "power F v does not apply")
