"""Validated configuration objects: the tank and its liquid.

Every number here is a *default* and an engineering estimate unless the paper gives it (the paper
gives the tank's inner dimensions and the 50 % fill level; liquid properties are those of water;
the structure mass above the load cells is an estimate). All quantities are SI.
"""

from __future__ import annotations

import math
import tomllib
from dataclasses import asdict, dataclass, fields, replace
from pathlib import Path
from typing import Any

from sloshrom.errors import SloshromError
from sloshrom.fileio import not_a_regular_file

G = 9.80665  # standard gravity, m/s^2

#: Absolute tolerance on a fill level d/h (-) when two must agree (a model's training fill and
#: the tank it runs in, two records of one identification): 0.5 % of the tank height, about
#: what a level gauge resolves.
FILL_TOLERANCE = 0.005


class ConfigError(SloshromError):
    """A configuration value is missing, of the wrong type or outside its physical range."""


class ConfigWarning(UserWarning):
    """A configuration read as asked, with a note (e.g. a key under its former name)."""


def _positive(name: str, value: float) -> float:
    try:
        v = float(value)
    except (TypeError, ValueError) as exc:
        raise ConfigError(f"{name} must be a number, got {value!r}") from exc
    if not math.isfinite(v) or v <= 0.0:
        raise ConfigError(f"{name} must be a finite positive number, got {value!r}")
    return v


@dataclass(frozen=True)
class Tank:
    """Box tank partially filled with liquid (defaults: the paper's tank, water, 50 % fill).

    Parameters
    ----------
    length : float
        Inner base side l1, m (paper: 117.2 mm).
    width : float
        Inner base side l2, m (paper: 78.0 mm).
    height : float
        Inner height h, m (paper: 27.2 mm).
    fill : float
        Fill level alpha = liquid depth / height, in (0, 1) (paper: 0.5).
    density : float
        Liquid density rho, kg/m^3 (water: 1000).
    surface_tension : float
        Liquid surface tension sigma, N/m (water: 0.072).
    structure_mass : float
        Mass of the tank structure above the load cells (box, lid, accelerometers), kg.
        Estimate (0.45 kg); not given in the paper.
    """

    length: float = 0.1172
    width: float = 0.0780
    height: float = 0.0272
    fill: float = 0.5
    density: float = 1000.0
    surface_tension: float = 0.072
    structure_mass: float = 0.45

    def __post_init__(self) -> None:
        for f in fields(self):
            if f.name == "fill":
                continue
            object.__setattr__(self, f.name, _positive(f.name, getattr(self, f.name)))
        try:
            fill = float(self.fill)
        except (TypeError, ValueError) as exc:
            raise ConfigError(f"fill must be a number in (0, 1), got {self.fill!r}") from exc
        if not (0.0 < fill < 1.0):
            raise ConfigError(f"fill level must be in (0, 1) (exclusive), got {self.fill!r}")
        object.__setattr__(self, "fill", fill)
        if self.height > 1.0 or self.length > 10.0 or self.width > 10.0:
            raise ConfigError(
                "tank dimensions look like millimetres, not metres: "
                f"length={self.length}, width={self.width}, height={self.height}"
            )

    @property
    def depth(self) -> float:
        """Liquid depth d = alpha h, m."""
        return self.fill * self.height

    @property
    def ullage(self) -> float:
        """Gap G = h - d between free surface at rest and ceiling, m."""
        return self.height - self.depth

    @property
    def area(self) -> float:
        """Base area S = l1 l2, m^2."""
        return self.length * self.width

    @property
    def liquid_mass(self) -> float:
        """Liquid mass m_l = rho S d, kg."""
        return self.density * self.area * self.depth

    @property
    def reference_frequency(self) -> float:
        """sqrt(g/h), rad/s: omega_bar = Omega / sqrt(g/h)."""
        return math.sqrt(G / self.height)

    def to_dict(self) -> dict[str, float]:
        """The tank's parameters by name (SI units)."""
        return asdict(self)

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> Tank:
        """The tank of ``data`` (parameters by name); unknown names raise :class:`ConfigError`."""
        unknown = set(data) - {f.name for f in fields(cls)}
        if unknown:
            raise ConfigError(f"unknown tank parameter(s): {', '.join(sorted(unknown))}")
        return cls(**data)

    @classmethod
    def from_toml(cls, path: str | Path, section: str = "tank") -> Tank:
        """Read a tank from a TOML file (table ``[tank]`` by default, SI units)."""
        return cls.from_dict(load_toml_table(path, section))

    def replace(self, **changes: Any) -> Tank:
        """A copy with the given parameters changed."""
        return replace(self, **changes)


def load_toml(path: str | Path) -> dict[str, Any]:
    """Read a TOML file with a clear error for a missing or malformed file."""
    p = Path(path)
    why = not_a_regular_file(p)
    if why is not None:
        raise ConfigError(f"{p}: {why}")
    if not p.is_file():
        raise ConfigError(f"config file not found: {p}")
    try:
        with p.open("rb") as fh:
            return tomllib.load(fh)
    except tomllib.TOMLDecodeError as exc:
        raise ConfigError(f"{p}: not valid TOML ({exc})") from exc
    except UnicodeDecodeError as exc:  # a binary file (an image, a record) given as TOML
        raise ConfigError(f"{p}: not valid TOML (not UTF-8 text: byte "
                          f"{exc.object[exc.start]:#04x} at offset {exc.start})") from None


def load_toml_table(
    path: str | Path, section: str = "", error: type[ConfigError] = ConfigError
) -> dict[str, Any]:
    """Table ``[section]`` of a TOML file (the whole file if ``section`` is empty)."""
    data = load_toml(path)
    if section:
        if section not in data:
            raise error(f"{path}: no [{section}] table")
        data = data[section]
    return data
