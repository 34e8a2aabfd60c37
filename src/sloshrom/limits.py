"""The ROMs' shared size limits: the bounds that several classes of the registry
(``sloshrom.rom.registry``) give their hyperparameters, and the limits of a model file. A limit
of one class alone is in its package's entry (the NSS's largest state and epoch:
``sloshrom.rom.nss.entry``).

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
    "HIDDEN_KINDS",
    "MAX_BATCH",
    "MAX_DELAY",
    "MAX_EPOCHS",
    "MAX_MEMBERS",
    "MAX_NEURONS",
    "MAX_OUT_DELAYS",
    "MAX_REGRESSOR",
    "MAX_SEED",
    "MIN_SCORED",
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
#: distance form (``b ||x - C||``); :mod:`sloshrom.rom.tdnn.network`.
Hidden = Literal["matlab", "distance"]
HIDDEN_KINDS: tuple[str, ...] = ("matlab", "distance")

#: Largest input delay, samples. The model-file schema's 10 000 is kept (the command line and
#: the settings said 1000): a file with a sparse delay line reaching it loads today. The memory
#: of a contiguous delay line is bounded separately, by the model file's regressor limit
#: (:data:`MAX_REGRESSOR`).
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
#: Most entries a model reads at each step (a time-delay network's regressor: its delays and
#: fed-back outputs; a state-space model's state and input): a free run builds chunks of 8192
#: regressor rows, so this bounds its memory to well under 1 GB.
MAX_REGRESSOR = 4096
#: Most network weights one model file holds, members x neurons x regressor entries (32 MiB
#: of float64).
MAX_WEIGHTS = 2**22
#: Most sub-sequences per Adam step of a multiple-shooting class (the NOE's, the NSS's).
MAX_BATCH = 65536
#: Largest seed: JAX PRNG keys take 32-bit seeds.
MAX_SEED = 2**32 - 1
#: Samples of a record that a start from measured history must leave to score or predict (a
#: run of one sample has no slope: the amplitude weights and the energy cycles need two).
MIN_SCORED = 2
