"""Modal model of the sloshing beam's structure (paper Sect. 4, Eqs. 3-9).

A clamped Euler-Bernoulli cantilever with a rigid body (the tank) at its tip, of mass ``M`` and
rotary inertia ``J`` about the tank centre, which sits on the beam axis at ``x = L``.

Conventions
-----------
* ``w(x, t) = sum_n psi_n(x) q_n(t)``, w up positive, x from the clamp (m).
* Modes are normalised to **unit maximum displacement**: ``max_x |psi_n(x)| = 1`` with the tip
  displacement positive (the paper's Table 1 normalisation).
* Modal mass ``m_n = int mu psi_n^2 dx + M psi_n(L)^2 + J psi_n'(L)^2`` (kg), modal stiffness
  ``k_n = int EI psi_n''^2 dx = omega_n^2 m_n`` (N/m), participation
  ``Gamma_n = int mu psi_n dx + M psi_n(L)`` (kg, the mass-weighted mode integral that multiplies
  the base acceleration, Eq. 9 plus the tank structure).

All beam and inertia defaults are the paper's geometry (74 x 10 x 1 cm, aluminium) plus
**estimates** where the paper gives nothing (material constants, tank rotary inertia, sensor
stations); every one is a parameter.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from sloshrom.beam.errors import BeamError
from sloshrom.config import ConfigError, Tank, load_toml_table

#: default damping ratios of modes 1, 2, 3 (estimates; the paper's Table 1 values are not given)
DEFAULT_DAMPING = (0.010, 0.005, 0.005)
#: default number of accelerometer stations, evenly spaced to the tip (estimates; the tip
#: station is the tank): 1/5, 2/5, ..., 5/5 of the length
N_STATIONS = 5
#: Most modes of a modal model: the coupled simulation solves the n x n frozen-liquid
#: eigenproblem and steps 2n states at every sample (the cap ``sloshrom beam --modes`` has
#: always had); a modal file with more modes needs ``ModeSet.select_modes`` first.
MAX_MODES = 200
#: Largest magnitude of a modal value (frequency, mass, shape, position, participation): the
#: bound sloshrom puts on every value it reads (``sloshrom.io.MAX_ABS_VALUE``), so that products
#: and squares of them cannot overflow.
MAX_VALUE = 1e100
#: Largest ratio of the frozen liquid's mass at the tanks to the modal masses,
#: ``1 + sum_j m_j sum_n psi_jn^2 / m_n`` (the condition number of the frozen mass matrix in
#: mass-normalised modes): beyond it float64 keeps fewer than 4 digits of the modal masses and
#: the frozen-liquid eigenproblem is meaningless (at 1e16 it fails outright).
MAX_MASS_RATIO = 1e12


#: the signals of a coupled run that belong to a tank (a trailing tank axis with several)
TANK_KEYS = ("tank_acceleration", "dynamic_force", "interface_force", "tank_velocity")


def default_stations(length: float) -> tuple[float, ...]:
    """Accelerometer stations (m) at 1/5, 2/5, ..., 5/5 of a beam of ``length`` m."""
    return tuple(length * k / N_STATIONS for k in range(1, N_STATIONS + 1))


class ModalDataError(ConfigError, BeamError):
    """User-given modal data are inconsistent or unphysical.

    A :class:`~sloshrom.config.ConfigError` like the rest of the structure's configuration, and a
    :class:`~sloshrom.beam.errors.BeamError` like every user error of the beam.
    """


def tank_rotary_inertia(tank: Tank, include_liquid: bool = False) -> float:
    """Rotary inertia of the tank assembly about its centre, kg m^2 (estimate).

    The tank structure is taken as a uniform block of the tank's inner length (along the beam)
    and height: ``J = m (l1^2 + h^2) / 12``. With ``include_liquid`` the frozen liquid (a block
    l1 x d centred ``(h - d)/2`` below the tank centre) is added.
    """
    j = tank.structure_mass * (tank.length**2 + tank.height**2) / 12.0
    if include_liquid:
        ml, d = tank.liquid_mass, tank.depth
        j += ml * (tank.length**2 + d**2) / 12.0 + ml * (0.5 * (tank.height - d)) ** 2
    return j


@dataclass(frozen=True)
class CantileverBeam:
    """Clamped Euler-Bernoulli beam with a rigid tip body.

    Parameters
    ----------
    length, width, thickness : float
        m (paper: 0.74, 0.10, 0.01).
    youngs_modulus : float
        Pa (aluminium, 70 GPa; estimate of the alloy).
    density : float
        kg/m^3 (aluminium, 2700; estimate).
    tip_mass : float
        Mass of the rigid body at the tip, kg (default 0: bare beam).
    tip_inertia : float
        Its rotary inertia about the tip, kg m^2.
    """

    length: float = 0.74
    width: float = 0.10
    thickness: float = 0.01
    youngs_modulus: float = 70e9
    density: float = 2700.0
    tip_mass: float = 0.0
    tip_inertia: float = 0.0

    def __post_init__(self) -> None:
        for name in ("length", "width", "thickness", "youngs_modulus", "density"):
            v = float(getattr(self, name))
            if not (math.isfinite(v) and v > 0):
                raise ConfigError(f"beam {name} must be a finite positive number, got {v!r}")
        for name in ("tip_mass", "tip_inertia"):
            v = float(getattr(self, name))
            if not (math.isfinite(v) and v >= 0):
                raise ConfigError(f"beam {name} must be finite and >= 0, got {v!r}")

    @classmethod
    def with_tank(cls, tank: Tank | None = None, frozen: bool = False, **kw: Any) -> CantileverBeam:
        """Beam carrying the tank structure (dry) or tank structure + frozen liquid."""
        tank = tank if tank is not None else Tank()
        m = tank.structure_mass + (tank.liquid_mass if frozen else 0.0)
        return cls(tip_mass=m, tip_inertia=tank_rotary_inertia(tank, include_liquid=frozen), **kw)

    # -- properties -------------------------------------------------------------------------
    @property
    def mu(self) -> float:
        """Mass per unit length, kg/m."""
        return self.density * self.width * self.thickness

    @property
    def EI(self) -> float:  # noqa: N802 (the engineering symbol)
        """Bending stiffness, N m^2."""
        return self.youngs_modulus * self.width * self.thickness**3 / 12.0

    @property
    def mass(self) -> float:
        """Beam mass, kg."""
        return self.mu * self.length

    # -- frequency equation -----------------------------------------------------------------
    def _bc_matrix(self, bl: float) -> np.ndarray:
        """Tip boundary conditions on (A, B) for psi = A(ch - c) + B(sh - s), at beta L = bl.

        ``EI psi''(L) = J w^2 psi'(L)`` and ``EI psi'''(L) = -M w^2 psi(L)``, divided by
        beta^2 and beta^3 (w^2 = beta^4 EI / mu); rows scaled by 1/cosh for conditioning.
        """
        L, mu = self.length, self.mu
        b = bl / L
        ch, sh, c, s = math.cosh(bl), math.sinh(bl), math.cos(bl), math.sin(bl)
        j = self.tip_inertia * b**3 / mu
        m = self.tip_mass * b / mu
        mat = np.array(
            [
                [ch + c - j * (sh + s), sh + s - j * (ch - c)],
                [sh - s + m * (ch - c), ch + c + m * (sh - s)],
            ]
        )
        return mat / ch

    def _det(self, bl: float) -> float:
        return float(np.linalg.det(self._bc_matrix(bl)))

    def beta_l(self, n_modes: int = 3) -> np.ndarray:
        """The first ``n_modes`` roots beta_n L of the frequency equation (dimensionless)."""
        if n_modes < 1:
            raise BeamError(f"n_modes must be >= 1, got {n_modes}")
        return _beta_l(self, int(n_modes)).copy()

    def omegas(self, n_modes: int = 3) -> np.ndarray:
        """Natural circular frequencies, rad/s."""
        b = self.beta_l(n_modes) / self.length
        return b**2 * math.sqrt(self.EI / self.mu)

    def frequencies(self, n_modes: int = 3) -> np.ndarray:
        """Natural frequencies, Hz."""
        return self.omegas(n_modes) / (2 * math.pi)

    # -- mode shapes ------------------------------------------------------------------------
    def _coefficients(self, bl: float) -> tuple[float, float]:
        mat = self._bc_matrix(bl)
        # null vector of the 2x2 matrix: use the row with the larger norm
        row = mat[0] if np.linalg.norm(mat[0]) >= np.linalg.norm(mat[1]) else mat[1]
        return float(row[1]), float(-row[0])

    def _raw_shape(self, x: np.ndarray, bl: float, deriv: int) -> np.ndarray:
        a, bb = self._coefficients(bl)
        b = bl / self.length
        y = b * np.asarray(x, dtype=float)
        ch, sh, c, s = np.cosh(y), np.sinh(y), np.cos(y), np.sin(y)
        e = math.exp(-bl)  # keep magnitudes O(1): divide by cosh(bl) ~ exp(bl)/2
        forms = [
            (a * (ch - c) + bb * (sh - s)),
            (a * (sh + s) + bb * (ch - c)),
            (a * (ch + c) + bb * (sh + s)),
            (a * (sh - s) + bb * (ch + c)),
        ]
        return forms[deriv] * b**deriv * e

    def mode_shapes(self, x: Any, n_modes: int = 3, deriv: int = 0) -> np.ndarray:
        """Mode shapes (deriv 0), rotations (1), curvatures (2) at ``x``, shape (len(x), n_modes).

        Normalised to unit maximum displacement over the beam, tip displacement positive.
        """
        x = np.atleast_1d(np.asarray(x, dtype=float))
        if np.any(x < -1e-12) or np.any(x > self.length * (1 + 1e-12)):
            raise BeamError(f"positions must lie on the beam [0, {self.length}] m, got {x}")
        grid = np.linspace(0.0, self.length, 2001)
        out = np.empty((x.size, n_modes))
        for n, bl in enumerate(self.beta_l(n_modes)):
            g = self._raw_shape(grid, bl, 0)
            scale = np.max(np.abs(g)) * np.sign(g[-1] if abs(g[-1]) > 1e-9 else 1.0)
            out[:, n] = self._raw_shape(x, bl, deriv) / scale
        return out

    def modal_properties(self, n_modes: int = 3, n_grid: int = 4001) -> dict[str, np.ndarray]:
        """Frequencies (Hz), modal masses (kg), stiffnesses (N/m, from the curvature integral),
        participation Gamma (kg), tip displacement and rotation of each mode."""
        from scipy import integrate  # heavy: see beta_l

        x = np.linspace(0.0, self.length, n_grid)
        psi = self.mode_shapes(x, n_modes)
        curv = self.mode_shapes(x, n_modes, deriv=2)
        tip = psi[-1]
        rot = self.mode_shapes([self.length], n_modes, deriv=1)[0]
        mass = (
            self.mu * integrate.simpson(psi**2, x=x, axis=0)
            + self.tip_mass * tip**2
            + self.tip_inertia * rot**2
        )
        stiff = self.EI * integrate.simpson(curv**2, x=x, axis=0)
        gamma = self.mu * integrate.simpson(psi, x=x, axis=0) + self.tip_mass * tip
        return {
            "frequency": self.frequencies(n_modes),
            "modal_mass": mass,
            "modal_stiffness": stiff,
            "participation": gamma,
            "psi_tip": tip,
            "phi_tip": rot,
        }

    def static_tip_shape(self, x: Any, tip_displacement: float) -> np.ndarray:
        """Static deflection under a tip force scaled to ``tip_displacement`` at x = L, m."""
        x = np.asarray(x, dtype=float)
        L = self.length
        return tip_displacement * x**2 * (3 * L - x) / (2 * L**3)


# a beam is a value (frozen): its roots are solved once, not by each of the frequencies, mode
# shapes and modal integrals that ask for them (a scan of 1,500 determinants, 8 ms)
@functools.lru_cache(maxsize=64)
def _beta_l(beam: CantileverBeam, n_modes: int) -> np.ndarray:
    from scipy import optimize  # heavy (0.5 s): loaded when a beam is solved, not at import

    roots: list[float] = []
    grid = np.arange(0.05, (n_modes + 2) * math.pi, 0.01)
    vals = np.array([beam._det(x) for x in grid])
    for i in np.nonzero(np.sign(vals[:-1]) * np.sign(vals[1:]) < 0)[0]:
        roots.append(optimize.brentq(beam._det, grid[i], grid[i + 1], xtol=1e-14))
        if len(roots) == n_modes:
            break
    if len(roots) < n_modes:
        raise RuntimeError(f"found only {len(roots)} roots of the frequency equation")
    return np.array(roots)


@dataclass
class ModalModel:
    """Modal data of the dry structure (beam + tank structure) as the coupled model uses them.

    Parameters
    ----------
    frequencies : array (n_modes,)
        Natural frequencies, Hz.
    damping : array (n_modes,)
        Modal damping ratios (-). The coupled simulation applies them to the modes of the
        frozen-liquid system (see :func:`sloshrom.beam.simulation.coupled.damping_matrix`).
    modal_masses : array (n_modes,)
        kg, for the mode normalisation used (here unit maximum displacement).
    psi_tank : array (n_modes,) or (n_tanks, n_modes)
        Mode displacement at the tank centre (-); one row per tank for several tanks. The
        shape decides the shape of the per-tank results: a 1-D ``psi_tank`` (one tank) gives
        per-tank outputs without a tank axis, a 2-D one gives them a trailing tank axis.
    participation : array (n_modes,) or None
        Gamma_n = int mu psi_n dx + m_struct psi_n(x_T), kg: the mass-weighted mode integral
        in the direction of the base motion. ``None`` (unknown, stored as NaN): the structure
        can only be released (free responses); base excitation refuses to run.
    stations : array (n_stations,)
        Accelerometer positions along the beam, m (for a structure read from a modal file:
        the output points' coordinate along its longest axis, m, or their index).
    psi_stations : array (n_stations, n_modes)
        Mode displacement at the stations (-).
    structure_mass : float or array (n_tanks,)
        Tank structure mass above the interface, kg (enters the interface force); one per
        tank for a 2-D ``psi_tank`` (a scalar is used for every tank).
    length : float or None
        Beam length, m (stations must lie in [0, length]); None: not checked.
    station_ids, tank_ids : tuple of int, optional
        Labels of the output points and tanks (grid or node IDs of a modal file).

    Raises
    ------
    ModalDataError
        More than :data:`MAX_MODES` modes, a value that is not finite or of magnitude
        :data:`MAX_VALUE` or more (then no modal stiffness or mass product can overflow), and
        the shape, sign and label rules above.
    """

    frequencies: np.ndarray
    damping: np.ndarray
    modal_masses: np.ndarray
    psi_tank: np.ndarray
    participation: np.ndarray
    stations: np.ndarray
    psi_stations: np.ndarray
    structure_mass: float
    length: float | None = None
    source: str = "user"
    attrs: dict[str, Any] = field(default_factory=dict)
    station_ids: tuple[int, ...] | None = None
    tank_ids: tuple[int, ...] | None = None

    def __post_init__(self) -> None:
        f = np.atleast_1d(np.asarray(self.frequencies, dtype=float))
        n = f.size
        if n == 0:
            raise ModalDataError("need at least one mode")

        if n > MAX_MODES:
            raise ModalDataError(
                f"{n} modes: a modal model holds at most {MAX_MODES} (the coupled simulation "
                "solves an n x n eigenproblem and steps 2n states per sample); keep the lowest "
                "modes")

        def vec(name: str, v: Any) -> np.ndarray:
            a = np.atleast_1d(np.asarray(v, dtype=float))
            if a.shape != (n,):
                raise ModalDataError(f"{name} must have one value per mode ({n}), got {a.shape}")
            if not np.all(np.isfinite(a)):
                raise ModalDataError(f"{name} must be finite, got {a}")
            _bounded(name, a)
            return a

        self.frequencies = vec("frequencies", f)
        if np.any(self.frequencies <= 0):
            raise ModalDataError(f"frequencies must be positive (Hz), got {self.frequencies}")
        self.damping = vec("damping", self.damping)
        if np.any(self.damping < 0) or np.any(self.damping >= 1):
            raise ModalDataError(f"damping ratios must be in [0, 1), got {self.damping}")
        self.modal_masses = vec("modal_masses", self.modal_masses)
        if np.any(self.modal_masses <= 0):
            raise ModalDataError(f"modal masses must be positive (kg), got {self.modal_masses}")
        pt = np.asarray(self.psi_tank, dtype=float)
        if pt.ndim == 2:
            if pt.shape[1] != n or pt.shape[0] < 1:
                raise ModalDataError(f"psi_tank must have shape (n_tanks, n_modes = {n}), "
                                     f"got {pt.shape}")
            if not np.all(np.isfinite(pt)):
                raise ModalDataError(f"psi_tank must be finite, got {pt}")
            _bounded("psi_tank", pt)
            self.psi_tank = pt
        else:
            self.psi_tank = vec("psi_tank", pt)
        if self.participation is None:
            self.participation = np.full(n, np.nan)
        else:
            self.participation = vec("participation", self.participation)
        self.stations = np.atleast_1d(np.asarray(self.stations, dtype=float))
        ps = np.asarray(self.psi_stations, dtype=float)
        if ps.ndim == 1 and n == 1:
            ps = ps[:, None]
        if ps.shape != (self.stations.size, n):
            raise ModalDataError(
                f"psi_stations must have shape (n_stations, n_modes) = "
                f"({self.stations.size}, {n}), got {ps.shape}"
            )
        if not np.all(np.isfinite(ps)) or not np.all(np.isfinite(self.stations)):
            raise ModalDataError("stations and psi_stations must be finite")
        _bounded("stations", self.stations)
        _bounded("psi_stations", ps)
        self.psi_stations = ps
        if self.length is not None:
            self.length = float(self.length)
            off = (self.stations < 0) | (self.stations > self.length)
            if np.any(off):
                raise ModalDataError(
                    f"station(s) {self.stations[off]} m lie off the beam [0, {self.length}] m"
                )
        sm = np.asarray(self.structure_mass, dtype=float)
        if sm.ndim == 0:
            self.structure_mass = float(sm)
        elif self.psi_tank.ndim == 2 and sm.shape == (self.n_tanks,):
            self.structure_mass = sm
        else:
            raise ModalDataError(f"structure_mass must be one value (kg) or one per tank "
                                 f"({self.n_tanks}), got shape {sm.shape}")
        if not (np.all(np.isfinite(sm)) and np.all(sm >= 0)):
            raise ModalDataError(f"structure_mass must be >= 0 kg, got {self.structure_mass}")
        for name, ids, count in (("station_ids", self.station_ids, self.stations.size),
                                 ("tank_ids", self.tank_ids, self.n_tanks)):
            if ids is not None:
                ids = tuple(int(i) for i in ids)
                if len(ids) != count or len(set(ids)) != count:
                    raise ModalDataError(f"{name} must be {count} distinct labels, got {ids}")
                setattr(self, name, ids)

    # -- derived ----------------------------------------------------------------------------
    @property
    def n_modes(self) -> int:
        """The number of modes."""
        return self.frequencies.size

    @property
    def n_tanks(self) -> int:
        """Number of tanks (rows of a 2-D ``psi_tank``; 1 for a 1-D one)."""
        return 1 if self.psi_tank.ndim == 1 else self.psi_tank.shape[0]

    @property
    def psi_tanks(self) -> np.ndarray:
        """Mode displacement at the tanks, always (n_tanks, n_modes) (-)."""
        return np.atleast_2d(self.psi_tank)

    @property
    def structure_masses(self) -> np.ndarray:
        """Tank structure mass of each tank, (n_tanks,) kg."""
        return np.broadcast_to(np.asarray(self.structure_mass, dtype=float),
                               (self.n_tanks,)).copy()

    @property
    def has_participation(self) -> bool:
        """Whether the participation factors are known (base excitation needs them)."""
        return bool(np.all(np.isfinite(self.participation)))

    @property
    def omegas(self) -> np.ndarray:
        """rad/s."""
        return 2 * np.pi * self.frequencies

    @property
    def stiffness(self) -> np.ndarray:
        """Modal stiffnesses k_n = omega_n^2 m_n, N/m."""
        return self.omegas**2 * self.modal_masses

    def static_tip_state(self, tip_displacement: float, tank: int = 0) -> np.ndarray:
        """Modal coordinates of the static tip-load deflection with tank displacement given, m.

        A force F at the tank gives ``q_n = F psi_n(x_T) / k_n`` (modal expansion of the
        flexibility, equal to the mass-weighted projection of the exact static shape on the
        modes); F is scaled so that ``psi_T . q = tip_displacement``. With several tanks the
        force acts at tank number ``tank`` (0-based) and ``tip_displacement`` is its
        displacement.
        """
        if not 0 <= tank < self.n_tanks:
            raise ModalDataError(f"tank index {tank} outside the {self.n_tanks} tank(s)")
        psi = self.psi_tanks[tank]
        q = psi / self.stiffness
        scale = float(psi @ q)
        if scale == 0.0:
            raise ModalDataError(f"no mode moves tank {tank}: it cannot be deflected")
        return q * (tip_displacement / scale)

    # -- constructors -----------------------------------------------------------------------
    @classmethod
    def from_beam(
        cls,
        beam: CantileverBeam | None = None,
        tank: Tank | None = None,
        n_modes: int = 3,
        damping: Sequence[float] | None = None,
        stations: Sequence[float] | None = None,
    ) -> ModalModel:
        """Dry-structure modal model: the beam with the tank *structure* at its tip.

        ``beam`` defaults to :meth:`CantileverBeam.with_tank` (tank structure mass and rotary
        inertia); its tip body must be the tank structure only (the liquid enters the coupled
        model separately). ``damping`` defaults to 1.0 / 0.5 / 0.5 % (then 0.5 % for higher
        modes). ``stations`` (m) default to :func:`default_stations` of the beam's length.
        """
        tank = tank if tank is not None else Tank()
        beam = beam if beam is not None else CantileverBeam.with_tank(tank)
        if stations is None:
            stations = default_stations(beam.length)
        props = beam.modal_properties(n_modes)
        if damping is None:
            damping = [DEFAULT_DAMPING[min(i, 2)] for i in range(n_modes)]
        st = np.asarray(stations, dtype=float)
        off = (st < 0) | (st > beam.length)
        if np.any(off):
            raise ModalDataError(f"station(s) {st[off]} m lie off the beam [0, {beam.length}] m")
        return cls(
            frequencies=props["frequency"],
            damping=np.asarray(damping, dtype=float),
            modal_masses=props["modal_mass"],
            psi_tank=props["psi_tip"],
            participation=props["participation"],
            stations=st,
            psi_stations=beam.mode_shapes(st, n_modes),
            structure_mass=beam.tip_mass,
            length=beam.length,
            source="euler-bernoulli",
            attrs={"beam": {k: getattr(beam, k) for k in beam.__dataclass_fields__}},
        )

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> ModalModel:
        """From a mapping with keys ``frequencies`` (Hz), ``damping``, ``modal_masses`` (kg),
        ``psi_tank`` (a list, or a list of lists: one per tank), ``stations`` (m),
        ``psi_stations`` (rows = stations), ``structure_mass`` (kg, one or one per tank) and
        optional ``participation`` (kg; without it only free responses run), ``length`` (m),
        ``station_ids``, ``tank_ids``."""
        required = {
            "frequencies", "damping", "modal_masses", "psi_tank", "participation",
            "stations", "psi_stations", "structure_mass",
        }
        missing = required - {"participation"} - set(data)
        if missing:
            raise ModalDataError(f"modal data: missing key(s) {', '.join(sorted(missing))}")
        unknown = set(data) - required - {"length", "station_ids", "tank_ids"}
        if unknown:
            raise ModalDataError(f"modal data: unknown key(s) {', '.join(sorted(unknown))}")
        return cls(**{"participation": None, **data}, source="user")

    @classmethod
    def from_toml(cls, path: str | Path, section: str = "modal") -> ModalModel:
        """Read user modal data from TOML table ``[modal]`` (SI units, see :meth:`from_dict`)."""
        return cls.from_dict(load_toml_table(path, section, ModalDataError))

    def to_dict(self) -> dict[str, Any]:
        """The modal model as plain Python types (JSON-serialisable), by field name."""
        d: dict[str, Any] = {
            "frequencies": self.frequencies.tolist(),
            "damping": self.damping.tolist(),
            "modal_masses": self.modal_masses.tolist(),
            "psi_tank": self.psi_tank.tolist(),
            "stations": self.stations.tolist(),
            "psi_stations": self.psi_stations.tolist(),
            "structure_mass": np.asarray(self.structure_mass).tolist(),
        }
        if self.has_participation:
            d["participation"] = self.participation.tolist()
        if self.length is not None:
            d["length"] = self.length
        for name in ("station_ids", "tank_ids"):
            if getattr(self, name) is not None:
                d[name] = list(getattr(self, name))
        return d


def _bounded(name: str, a: np.ndarray) -> None:
    """Refuse a modal value of magnitude :data:`MAX_VALUE` or more (squares must not overflow)."""
    big = np.abs(a) >= MAX_VALUE
    if np.any(big):
        v = float(np.asarray(a)[big].flat[0])
        raise ModalDataError(f"{name} holds {v:g}: modal values must be below {MAX_VALUE:g} in "
                             "magnitude (a unit or format error?)")


def liquid_masses(modal: ModalModel, liquid_mass: Any) -> np.ndarray:
    """The liquid mass of every tank, (n_tanks,) kg: one value for all or one per tank."""
    m = np.asarray(liquid_mass, dtype=float)
    if m.ndim == 0:
        m = np.full(modal.n_tanks, float(m))
    if m.shape != (modal.n_tanks,):
        raise ModalDataError(f"need one liquid mass per tank ({modal.n_tanks}), got {m.shape}")
    if not (np.all(np.isfinite(m)) and np.all(m >= 0)):
        raise ModalDataError(f"liquid masses must be finite and >= 0 kg, got {m}")
    return m


def frozen_mass_matrix(modal: ModalModel, liquid_mass: Any) -> np.ndarray:
    """Mass matrix of the structure with the liquid frozen in the tanks, kg.

    ``M_f = M + sum_j m_j psi_j psi_j^T`` on the dry modes: ``M = diag(modal masses)``, the
    liquid mass ``m_j`` (kg; one value for every tank, or one per tank) rigidly attached at
    tank j, where the modes have the values ``psi_j``.
    """
    ml = liquid_masses(modal, liquid_mass)
    # condition number of M_f in mass-normalised modes: refuse shapes and modal masses that
    # are not in consistent units before the eigenproblem silently loses the modal masses
    with np.errstate(over="ignore", divide="ignore"):
        ratio = 1.0 + float(np.sum(ml[:, None] * modal.psi_tanks**2 / modal.modal_masses))
    if not ratio <= MAX_MASS_RATIO:
        j, k = np.unravel_index(np.argmax(ml[:, None] * modal.psi_tanks**2
                                          / modal.modal_masses), modal.psi_tanks.shape)
        raise ModalDataError(
            f"the liquid at the tank(s) weighs {ratio:.3g} times the modal masses (largest: "
            f"mode {k + 1} at tank {j + 1}, shape {modal.psi_tanks[j, k]:.3g}, modal mass "
            f"{modal.modal_masses[k]:.3g} kg); more than {MAX_MASS_RATIO:g}, beyond which "
            "float64 loses the modal masses: are the shapes and modal masses in consistent "
            "units (m_n = phi_n^T M phi_n of the shapes as given)?")
    mass = np.diag(modal.modal_masses)
    for m, psi in zip(ml, modal.psi_tanks, strict=True):
        mass = mass + m * np.outer(psi, psi)
    return mass


def coupled_frozen_modes(modal: ModalModel, liquid_mass: Any) -> tuple[np.ndarray, np.ndarray]:
    """Frequencies (Hz) and mode vectors (columns, in q) of ``(M + m_l psi psi^T, K)``.

    The vectors are mass-normalised: ``V^T M_f V = I`` (:func:`frozen_mass_matrix`).
    """
    from scipy.linalg import eigh

    w2, vec = eigh(np.diag(modal.stiffness), frozen_mass_matrix(modal, liquid_mass))
    return np.sqrt(w2) / (2 * np.pi), vec


def frozen_modal_table(
    tank: Tank | None = None,
    beam: CantileverBeam | None = None,
    n_modes: int = 3,
    damping: Sequence[float] | None = None,
) -> list[dict[str, float]]:
    """Frozen-liquid modes (analogue of paper Table 1), one row per mode.

    Columns: ``mode``; ``f_frozen_Hz`` from the frequency equation with the tip body = tank
    structure + frozen liquid (mass, and rotary inertia of the structure only, as in the coupled
    model); ``f_coupled_Hz`` from the truncated coupled model ``M + m_l psi psi^T`` on the dry
    modes; ``f_dry_Hz``; ``damping`` (the ratios the coupled model gives the frozen modes);
    ``modal_mass_kg`` of the frozen modes (unit maximum displacement); ``psi_tank``.
    """
    tank = tank if tank is not None else Tank()
    dry = beam if beam is not None else CantileverBeam.with_tank(tank)
    frozen = CantileverBeam(
        length=dry.length, width=dry.width, thickness=dry.thickness,
        youngs_modulus=dry.youngs_modulus, density=dry.density,
        tip_mass=dry.tip_mass + tank.liquid_mass, tip_inertia=dry.tip_inertia,
    )
    modal = ModalModel.from_beam(dry, tank, n_modes, damping)
    fc, _ = coupled_frozen_modes(modal, tank.liquid_mass)
    pf = frozen.modal_properties(n_modes)
    return [
        {
            "mode": n + 1,
            "f_dry_Hz": float(modal.frequencies[n]),
            "f_frozen_Hz": float(pf["frequency"][n]),
            "f_coupled_Hz": float(fc[n]),
            "damping": float(modal.damping[n]),
            "modal_mass_kg": float(pf["modal_mass"][n]),
            "psi_tank": float(pf["psi_tip"][n]),
        }
        for n in range(n_modes)
    ]

