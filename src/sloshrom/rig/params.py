"""Parameters of the virtual rig: the physics (:class:`RigParams`) and the sensors
(:class:`SensorParams`), with their TOML file (``rig_params.toml``: the calibrated values).
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, fields, replace
from pathlib import Path
from typing import Any

import numpy as np

from sloshrom.config import ConfigError, load_toml_table
from sloshrom.fileio import atomic_write_text

__all__ = ["RigParams", "SensorParams"]

_DEFAULT_TOML = Path(__file__).with_name("rig_params.toml")


@dataclass(frozen=True)
class RigParams:
    """Physics parameters of the virtual rig (all engineering estimates, SI units).

    The defaults of the dataclass are round starting values; :meth:`default` returns the
    calibrated values shipped in ``sloshrom/rig/rig_params.toml``.

    Parameters
    ----------
    n_layers : int
        Number of column layers N.
    beta : float
        Fraction of the liquid mass taking part in the impacting column, -.
    contact_frequency : float
        Natural frequency of a layer on its contact spring, Hz (sets stiffness ``m (2 pi f)^2``).
    restitution : float
        Coefficient of restitution e of a layer impact, in [0, 1).
    bubble_rate : float
        C_b, bubble-front growth coefficient of the Rayleigh-Taylor gate, -.
    gate_relaxation : float
        tau_s, relaxation time of the gate while g_eff > 0, s.
    rt_onset : float
        Log-amplitude growth ``ln(eps/eps_0)`` the Rayleigh-Taylor instability needs (linear
        phase, growth rate ``sqrt(2/3 |g_eff| k_m)``, ``k_m = sqrt(rho |g_eff| / (3 sigma))``)
        before the bubble front starts; 0 disables the delay. This finite onset time makes
        dissipation fall at high frequency.
    coherence_gamma : float
        Gamma_0, acceleration (g) above which the column loses coherence.
    coherence_power : float
        p, exponent of the coherence loss.
    coherence_time : float
        Time constant of the low-pass acceleration level Gamma_lp, s.
    n_modes : int
        Number of Faraday modes (0 to switch them off).
    mode_f_min, mode_f_max : float
        Natural-frequency band from which the modes are chosen, Hz (Faraday subharmonic
        resonance: a mode at f_n responds to a drive at 2 f_n).
    mode_damping : float
        zeta_n, effective damping ratio of the modes, -.
    mode_saturation : float
        a_sat, amplitude scale of the saturation, m.
    mode_noise : float
        Seed amplitude and noise floor of the modes, m.
    fragment_damping : float
        Extra damping ratio of the modes while the column is detached, -.
    """

    n_layers: int = 10
    beta: float = 0.8
    contact_frequency: float = 200.0
    restitution: float = 0.1
    bubble_rate: float = 0.5
    gate_relaxation: float = 0.05
    rt_onset: float = 0.0
    coherence_gamma: float = 5.5
    coherence_power: float = 2.0
    coherence_time: float = 0.2
    n_modes: int = 4
    mode_f_min: float = 2.5
    mode_f_max: float = 12.5
    mode_damping: float = 0.2
    mode_saturation: float = 1.5e-3
    mode_noise: float = 1e-6
    fragment_damping: float = 1.0

    def __post_init__(self) -> None:
        for f in fields(self):
            v = getattr(self, f.name)
            if f.name in ("n_layers", "n_modes"):
                if isinstance(v, bool) or int(v) != v:
                    raise ConfigError(f"RigParams.{f.name} must be an integer, got {v!r}")
                object.__setattr__(self, f.name, int(v))
                continue
            try:
                v = float(v)
            except (TypeError, ValueError) as exc:
                raise ConfigError(f"RigParams.{f.name} must be a number, got {v!r}") from exc
            if not math.isfinite(v):
                raise ConfigError(f"RigParams.{f.name} must be finite, got {v!r}")
            object.__setattr__(self, f.name, v)
        if self.n_layers < 1:
            raise ConfigError(f"RigParams.n_layers must be >= 1, got {self.n_layers}")
        if self.n_modes < 0:
            raise ConfigError(f"RigParams.n_modes must be >= 0, got {self.n_modes}")
        if not (0.0 <= self.beta <= 1.0):
            raise ConfigError(f"RigParams.beta must be in [0, 1], got {self.beta}")
        if not (0.0 <= self.restitution < 1.0):
            raise ConfigError(f"RigParams.restitution must be in [0, 1), got {self.restitution}")
        for name in (
            "contact_frequency", "gate_relaxation", "coherence_gamma", "coherence_time",
            "mode_saturation", "mode_f_min", "mode_f_max",
        ):
            if getattr(self, name) <= 0:
                raise ConfigError(f"RigParams.{name} must be positive, got {getattr(self, name)}")
        for name in ("bubble_rate", "coherence_power", "mode_damping", "mode_noise",
                     "fragment_damping", "rt_onset"):
            if getattr(self, name) < 0:
                raise ConfigError(f"RigParams.{name} must be >= 0, got {getattr(self, name)}")
        if self.mode_f_max <= self.mode_f_min:
            raise ConfigError("RigParams.mode_f_max must exceed mode_f_min")

    @property
    def contact_damping_ratio(self) -> float:
        """zeta of the contact dashpot from the restitution, ``e = exp(-pi z / sqrt(1 - z^2))``."""
        e = self.restitution
        if e <= 0.0:
            return 1.0  # critically damped: no rebound
        le = math.log(e)
        return -le / math.sqrt(math.pi**2 + le * le)

    def to_dict(self) -> dict[str, float | int]:
        """The rig's parameters by name (SI units)."""
        return asdict(self)

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> RigParams:
        """The parameters of ``data`` (by name); unknown names raise :class:`ConfigError`."""
        unknown = set(data) - {f.name for f in fields(cls)}
        if unknown:
            raise ConfigError(f"unknown rig parameter(s): {', '.join(sorted(unknown))}")
        return cls(**data)

    @classmethod
    def from_toml(cls, path: str | Path, section: str = "rig") -> RigParams:
        """Read parameters from table ``[rig]`` of a TOML file (missing keys keep defaults)."""
        return cls.from_dict(load_toml_table(path, section))

    def to_toml(self, path: str | Path, comment: str = "") -> None:
        """Write the parameters as table ``[rig]`` (atomically: temporary file, then replace)."""
        import tomli_w

        p = Path(path)
        text = tomli_w.dumps({"rig": self.to_dict()})
        if comment:
            text = "".join(f"# {line}\n" for line in comment.splitlines()) + text
        atomic_write_text(p, text)

    @classmethod
    def default(cls) -> RigParams:
        """The calibrated parameters shipped with the package (``rig_params.toml``)."""
        if _DEFAULT_TOML.is_file():
            return cls.from_toml(_DEFAULT_TOML)
        return cls()  # pragma: no cover - source tree without the calibrated file

    def replace(self, **changes: Any) -> RigParams:
        """A copy with the given parameters changed."""
        return replace(self, **changes)


@dataclass(frozen=True)
class SensorParams:
    """Sensor model of the virtual rig (engineering estimates).

    Parameters
    ----------
    acquisition_fs : float
        Sample rate of the acquisition system, Hz.
    output_fs : float
        Rate of the returned record after digital decimation, Hz.
    anti_alias_fraction : float
        Cut-off of the anti-alias filters as a fraction of the Nyquist frequency of the rate
        that follows them, -.
    filter_order : int
        Order of the Butterworth anti-alias filters (applied forward-backward, zero phase).
    force_noise : float
        Standard deviation of the load-cell (sum) noise at the acquisition rate, N.
    acceleration_noise : float
        Standard deviation of the accelerometer noise at the acquisition rate, m/s^2.
    """

    acquisition_fs: float = 5000.0
    output_fs: float = 500.0
    anti_alias_fraction: float = 0.8
    filter_order: int = 8
    force_noise: float = 0.02
    acceleration_noise: float = 0.05

    def __post_init__(self) -> None:
        for name in ("acquisition_fs", "output_fs", "anti_alias_fraction"):
            v = getattr(self, name)
            if not (np.isfinite(v) and v > 0):
                raise ConfigError(f"SensorParams.{name} must be positive, got {v!r}")
        if self.anti_alias_fraction >= 1.0:
            raise ConfigError("SensorParams.anti_alias_fraction must be < 1")
        if self.output_fs > self.acquisition_fs:
            raise ConfigError("SensorParams.output_fs must not exceed acquisition_fs")
        for name in ("force_noise", "acceleration_noise"):
            v = getattr(self, name)
            if not (np.isfinite(v) and v >= 0):
                raise ConfigError(f"SensorParams.{name} must be >= 0, got {v!r}")
        if int(self.filter_order) != self.filter_order or self.filter_order < 1:
            raise ConfigError("SensorParams.filter_order must be a positive integer")
