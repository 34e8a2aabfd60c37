"""One definition of the Welch segment of the random tests' damping estimates
(``sloshrom.beam.damping.limits.WELCH_SEGMENT``): every default, check and message reads it, so
that no copy of the number can disagree with it."""

from __future__ import annotations

import ast
import inspect
import tomllib
from importlib import resources

from helpers import REPO
from sloshrom.beam.damping.estimators import RandomTest
from sloshrom.beam.damping.limits import WELCH_SEGMENT
from sloshrom.beam.damping.multimode import modal_damping_table, mode_damping_random
from sloshrom.beam.damping.uncertainty import estimate_random, mode1_damping_random

SRC = REPO / "src" / "sloshrom"
#: Where the number stands for something else (not a Welch segment of the damping estimates).
OTHER_MEANINGS = {
    "rom/tdnn/training.py": "FAST_MAX_ROWS, rows of a fast training batch",
    "beam/damping/analysis.py": "_GAIN_LINES, frequency lines of a filter's gain",
}


def _literals(value: int) -> dict[str, int]:
    """Per module of the package (path relative to ``src/sloshrom``), how often the integer
    ``value`` is written as a literal."""
    out: dict[str, int] = {}
    for p in sorted(SRC.rglob("*.py")):
        n = sum(1 for node in ast.walk(ast.parse(p.read_text(encoding="utf-8")))
                if isinstance(node, ast.Constant) and type(node.value) is int
                and node.value == value)
        if n:
            out[p.relative_to(SRC).as_posix()] = n
    return out


def test_the_welch_segment_is_written_once():
    found = _literals(WELCH_SEGMENT)
    assert found.pop("beam/damping/limits.py") == 1  # the definition
    assert found == dict.fromkeys(OTHER_MEANINGS, 1), found


def test_every_default_is_the_welch_segment():
    assert RandomTest.__dataclass_fields__["nperseg"].default == WELCH_SEGMENT
    for f in (estimate_random, mode1_damping_random, mode_damping_random, modal_damping_table):
        assert inspect.signature(f).parameters["nperseg"].default == WELCH_SEGMENT, f


def test_the_multimode_default_is_the_welch_segment():
    """The ``[multimode] nperseg`` key (the two-mode study's random tests) defaults to it."""
    from sloshrom.pipeline.settings import defaults

    text = (resources.files("sloshrom.studies.multimode") / "defaults.toml").read_text(
        encoding="utf-8")
    assert tomllib.loads(text)["multimode"]["nperseg"] == WELCH_SEGMENT  # the study's own
    assert defaults()["multimode"]["nperseg"] == WELCH_SEGMENT  # as the settings give it


def test_a_free_decay_needs_what_the_instantaneous_damping_trims_and_smooths():
    """The free decay a damping analysis needs (settings, ``sloshrom beam free``, ``sloshrom
    analyse free``) is derived from the analysis's own trimming and smoothing."""
    from sloshrom.beam.damping import limits
    from sloshrom.beam.damping.analysis import instantaneous_damping
    from sloshrom.beam.lab import every_mode

    p = inspect.signature(instantaneous_damping).parameters
    assert p["trim_periods"].default == limits.TRIM_PERIODS
    assert p["smooth_periods"].default == limits.SMOOTH_PERIODS
    assert limits.FREE_DAMPING_PERIODS == 2 * limits.TRIM_PERIODS + limits.SMOOTH_PERIODS + 4
    assert every_mode.FREE_DAMPING_PERIODS is limits.FREE_DAMPING_PERIODS  # no copy
