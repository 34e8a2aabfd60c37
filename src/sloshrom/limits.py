"""The ROMs' size limits, in one place: the bounds that the registry of ROM classes
(``sloshrom.rom.registry``) gives their hyperparameters, and the limits of a model file.

The registry's hyperparameters, and so the command line (``sloshrom train``, ``sweep``), the
configuration of `sloshrom reproduce` and the model-file schema, take these values, so that a
model one of them accepts the others accept too. A base module: it imports nothing heavy (no
JAX), so the command line and the settings read it at start-up.

Where places once disagreed, the larger limit is kept, so that nothing that worked before is
refused: a model file written with it must still load, and the schema was the widest.
"""

from __future__ import annotations

from typing import Literal

__all__ = [
    "EPOCH_WORK_SECONDS",
    "HIDDEN_KINDS",
    "MAX_BATCH",
    "MAX_DELAY",
    "MAX_EPOCHS",
    "MAX_EPOCH_WORK",
    "MAX_MEMBERS",
    "MAX_NEURONS",
    "MAX_OUT_DELAYS",
    "MAX_SEED",
    "MAX_STATES",
    "MAX_WEIGHTS",
    "TRAINERS",
    "MU_MAX",
    "Hidden",
]

#: Training algorithms of the estimators: subsampled Levenberg–Marquardt, full LM (MATLAB's
#: ``trainlm``) and optax Adam (the NFIR's default; for an NOE multiple shooting), the one with the
#: recipe's loss terms.
TRAINERS = ("fast", "lm", "adam")
#: Levenberg–Marquardt stops when its damping mu passes this (``trainlm``'s ``mu_max``): no step
#: lowered the training error at any damping up to it.
MU_MAX = 1e10
#: The normalized-RBF variants of the hidden layer: MATLAB's ``radbasn`` (``W x + b``) and the
#: distance form (``b ||x - C||``); :mod:`sloshrom.rom.network`.
Hidden = Literal["matlab", "distance"]
HIDDEN_KINDS: tuple[str, ...] = ("matlab", "distance")

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
#: Most work of one training epoch of a multiple-shooting class (an NSS), in neuron-samples:
#: steps_per_epoch x batch x (window + horizon) x neurons, the samples an epoch's Adam steps
#: read times the width of the maps that run on each. Each bound alone let window = horizon =
#: 9000 through (quick reproduce still training after 300 s). Measured (2026-11-28, 2 cores
#: shared, load 3): an Adam step of the default NSS (128 x (50 + 200) samples, 64 neurons)
#: takes 27 ms, 13 ns per neuron-sample; 4x the horizon, batch or neurons 2.0-2.4x, 16x 13-22x
#: (the cost grows about as the product). 1.5e10 keeps an epoch's steps within about 3 min
#: (up to 5 at the larger sizes' rates), 37 times the default's 4.1e8.
MAX_EPOCH_WORK = 15_000_000_000
#: Measured cost of one neuron-sample of a multiple-shooting epoch, s (see MAX_EPOCH_WORK).
EPOCH_WORK_SECONDS = 13e-9
#: Largest seed: JAX PRNG keys take 32-bit seeds.
MAX_SEED = 2**32 - 1
