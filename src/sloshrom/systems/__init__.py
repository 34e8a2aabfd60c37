"""Benchmark systems beyond sloshing: simulators that write input/output records for any ROM.

Each system is one module and one entry of :data:`SYSTEMS` (name -> :class:`System`): its
generator returns named records (``train``, ``validation``, ``test``, ...) that ``sloshrom
train`` and ``sloshrom predict`` read like any other, with the system's own input and output
names and units. ``sloshrom system NAME --out DIR`` writes them. A domain room: it imports the
base and :mod:`sloshrom.io` only.

The registry names each generator as a string (``module:function``) and imports it on first
use, as :mod:`sloshrom.studies` does its studies: ``import sloshrom.systems`` (and so
``sloshrom --help``) loads no numba.

Modules: :mod:`~sloshrom.systems.boucwen` (the Bouc–Wen hysteretic benchmark of Noël &
Schoukens, 2016) and :mod:`~sloshrom.systems.tanks` (the cascaded tanks of Schoukens, Mattsson,
Wigren and Noël, 2016, simulated: a short record with a saturation).
"""

from __future__ import annotations

import importlib
from dataclasses import dataclass

from sloshrom.io import Record

__all__ = ["SYSTEMS", "Option", "System"]


@dataclass(frozen=True)
class Option:
    """One keyword of a system's generator, as the command line offers it.

    Parameters
    ----------
    name : str
        The generator's keyword (``periods``); the option is ``--periods``.
    default : int or float
        Its default, the benchmark's value.
    help : str
        One sentence with the unit.
    lo, hi : float
        The accepted range (inclusive).
    """

    name: str
    default: int | float
    help: str
    lo: float
    hi: float


@dataclass(frozen=True)
class System:
    """A benchmark system: what it is, its generator and the generator's options.

    Parameters
    ----------
    name : str
        The command line's name (``bouc-wen``).
    summary : str
        One line: the system, its input and its output.
    generator : str
        ``"module:function"`` of the generator, ``function(seed=..., **options) -> dict[str,
        Record]``: the records by file stem, the first ones ``train``, ``validation`` and
        ``test``.
    options : tuple of Option
        The generator's keywords besides ``seed``.
    records : tuple of str
        The stems of the records the generator returns, in its order (the files
        ``STEM.nc`` of ``sloshrom system``).
    names : (str, str)
        The records' input and output variable names (for ``sloshrom train --input/--output``).
    """

    name: str
    summary: str
    generator: str
    options: tuple[Option, ...]
    records: tuple[str, ...]
    names: tuple[str, str]

    def generate(self, seed: int = 0, **options: float) -> dict[str, Record]:
        """The system's records (its generator, imported on first use), by file stem."""
        module, _, function = self.generator.partition(":")
        records: dict[str, Record] = getattr(importlib.import_module(module), function)(
            seed=seed, **options)
        return records


_BOUC_WEN = System(
    name="bouc-wen",
    summary="the Bouc–Wen hysteretic benchmark (Noël & Schoukens 2016): a hysteretic "
            "oscillator, the force on it (N) in, its displacement (m) out, at 750 Hz",
    generator="sloshrom.systems.boucwen:benchmark_records",
    options=(
        Option("periods", 5, "multisine periods of the training record, from rest", 1, 100),
        Option("samples", 8192, "samples per multisine period (the benchmark's 8192; at most "
               "2^20 samples a record)", 256, 2**18),
        Option("noise", 8e-6, "RMS of the output noise of the training and validation "
               "records, m (the benchmark's 8e-3 mm; 0 = noiseless)", 0.0, 1.0),
        Option("validation_periods", 2, "multisine periods of the validation record, from "
               "rest", 1, 100),
    ),
    records=("train", "validation", "test", "test_steady", "sweep"),
    names=("force", "displacement"),
)

_CASCADED_TANKS = System(
    name="cascaded-tanks",
    summary="a short record: the cascaded tanks (Schoukens et al. 2016) simulated, pump "
            "voltage u (V) in, the lower tank's level y (V) out, Ts = 4 s, overflow at 10 V; "
            "1,024 estimation samples, a test record that does not start at rest",
    generator="sloshrom.systems.tanks:tank_records",
    options=(
        Option("n", 1024, "samples of the estimation and of the test record (the benchmark's "
               "1024)", 256, 2**16),
        Option("noise", 0.03, "standard deviation of the measurement noise, V", 0.0, 1.0),
        Option("warmup", 256, "samples run before the test record starts (it starts away "
               "from rest)", 0, 2**16),
    ),
    records=("train", "validation", "test", "estimation"),
    names=("u", "y"),
)

#: Every system by its command-line name. A new system: one module and one entry here.
SYSTEMS: dict[str, System] = {s.name: s for s in (_BOUC_WEN, _CASCADED_TANKS)}
