"""Configuration of `sloshrom reproduce`: the shipped defaults, merged with a user's TOML file."""

from __future__ import annotations

import copy
import tomllib
from importlib import resources
from pathlib import Path
from typing import Any

from sloshrom.config import ConfigError, load_toml

# Reduced sizes for `--quick` (a smoke run of the whole chain in a few minutes).
QUICK: dict[str, dict[str, Any]] = {
    "data": {"train_duration": 120.0, "validation_duration": 60.0},
    "rom": {"delays": 40, "neurons": 15, "max_epochs": 60},
    "map": {"n_omega": 10, "n_a": 8},
    "beam": {"free_duration": 6.0, "random_duration": 70.0},
}


def default_text() -> str:
    """The shipped defaults, as TOML text with comments."""
    return resources.files("sloshrom").joinpath("defaults.toml").read_text(encoding="utf-8")


def defaults() -> dict[str, Any]:
    return tomllib.loads(default_text())


def merge(base: dict[str, Any], override: dict[str, Any], where: str = "") -> dict[str, Any]:
    """Deep-merge ``override`` into a copy of ``base``; unknown keys or wrong types are errors."""
    out = copy.deepcopy(base)
    for key, value in override.items():
        path = f"{where}{key}"
        if key not in base:
            raise ConfigError(f"unknown configuration key '{path}'")
        if isinstance(base[key], dict):
            if not isinstance(value, dict):
                raise ConfigError(f"'{path}' must be a table")
            out[key] = merge(base[key], value, where=f"{path}.")
            continue
        ref = base[key]
        if isinstance(ref, bool) != isinstance(value, bool):
            raise ConfigError(f"'{path}' must be true or false, got {value!r}")
        if isinstance(ref, int | float) and not isinstance(ref, bool):
            if not isinstance(value, int | float) or isinstance(value, bool):
                raise ConfigError(f"'{path}' must be a number, got {value!r}")
            value = type(ref)(value) if isinstance(ref, float) else value
        elif isinstance(ref, str) and not isinstance(value, str):
            raise ConfigError(f"'{path}' must be a string, got {value!r}")
        elif isinstance(ref, list) and not isinstance(value, list):
            raise ConfigError(f"'{path}' must be a list, got {value!r}")
        out[key] = value
    return out


def load(path: str | Path | None = None, quick: bool = False) -> dict[str, Any]:
    """Defaults, then ``QUICK`` if asked, then the user's file (which wins)."""
    cfg = defaults()
    if quick:
        cfg = merge(cfg, QUICK)
    if path is not None:
        cfg = merge(cfg, load_toml(path))
    return cfg
