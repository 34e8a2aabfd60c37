"""A wing-like structure with two active modes in the sloshing band.

The paper's tip-tank cantilever is one-mode dominated: its second mode (75 Hz) lies far above
the 5-25 Hz band in which the liquid sloshes violently, where the tank hardly moves and the
liquid is effectively frozen. This module provides a wing-like structure whose tank moves in two
modes, both inside that band; the damping of each of its modes is
``sloshrom.beam.damping.multimode``'s.

* :class:`WingDesign`, :func:`two_mode_wing`, :func:`wing_modal_model`: a cantilevered wing
  (bending + torsion, two assumed modes, Rayleigh-Ritz) with the tank on a pod at the tip, aft of
  the elastic axis, so that both normal modes move it vertically. Returned as a
  :class:`~sloshrom.beam.simulation.modes.ModeSet` (nodes, shapes, modal masses,
  participation), the form of a modal model read from a file, and converted by
  :meth:`~sloshrom.beam.simulation.modes.ModeSet.to_modal_model`.
* :func:`structure_summary`: frequencies, the tank's share of each mode, liquid-to-modal-mass
  ratios (dry and frozen liquid); :func:`frozen_station_shapes`: the frozen-liquid modes at
  the stations, for modal filtering.

Pure numerics: arrays and dataclasses in, arrays and dicts out; no files.

Wing kinematics
---------------
Span coordinate y from the clamp (m), chordwise coordinate x from the elastic axis (EA), positive
towards the tank (aft), z up. The vertical displacement is
``z(x, y, t) = phi_b(y) q_h(t) + x theta(y) q_t(t)`` with ``phi_b`` the first mode of a uniform
clamped-free beam (unit tip displacement) and ``theta(y) = sin(pi y / 2 L)`` the first mode of a
uniform clamped-free torsion shaft (unit tip twist): ``q_h`` is the tip deflection (m), ``q_t``
the tip twist (rad). With section mass ``mu`` per span, section centre of mass at ``x_cg`` and
radius of gyration ``r_g`` about it, tank structure mass ``M`` (rotary inertia ``J`` about
both axes) at ``(x_T, y_T)``::

    m_hh = mu int phi_b^2 + M phi_b(y_T)^2 + J phi_b'(y_T)^2
    m_tt = mu (r_g^2 + x_cg^2) int theta^2 + M x_T^2 theta(y_T)^2 + J theta(y_T)^2
    m_ht = mu x_cg int phi_b theta + M x_T phi_b(y_T) theta(y_T)
    k_hh = EI int phi_b''^2,   k_tt = GJ int theta'^2,   k_ht = 0
    Gamma_h = mu int phi_b + M phi_b(y_T),   Gamma_t = mu x_cg int theta + M x_T theta(y_T)

(Gamma: participation in a vertical base translation, kg or kg m). ``EI`` and ``GJ`` are not
inputs: they are solved so that the two *dry* normal modes have the target frequencies, the
lower one bending-dominated.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass
from typing import Any

import numpy as np
from scipy import integrate
from scipy.linalg import eigh

from sloshrom.beam.simulation.modes import ModeSet
from sloshrom.beam.simulation.structure import (
    CantileverBeam,
    ModalDataError,
    ModalModel,
    coupled_frozen_modes,
    tank_rotary_inertia,
)
from sloshrom.config import Tank

__all__ = [
    "WingDesign",
    "frozen_station_shapes",
    "structure_summary",
    "two_mode_wing",
    "wing_modal_model",
    "wing_ritz",
]

#: points of the span grid on which the assumed modes are integrated (Simpson)
_N_GRID = 2001


@dataclass(frozen=True)
class WingDesign:
    """A cantilevered wing with the tank on a pod at its tip (defaults: estimates, see below).

    Parameters
    ----------
    span : float
        Clamp to tip, m.
    chord : float
        Section chord, m (places the leading- and trailing-edge accelerometers).
    ea_chord_fraction : float
        Elastic axis position from the leading edge, fraction of the chord (-).
    mass_per_span : float
        Section mass per unit span ``mu``, kg/m.
    cg_offset : float
        Section centre of mass from the elastic axis ``x_cg``, m, positive towards the tank
        (negative: ahead of the EA, the usual leading-edge mass balance of a flutter model).
    gyration_radius : float
        Section radius of gyration about its centre of mass ``r_g``, m.
    tank_offset : float
        Tank centre from the elastic axis ``x_T``, m, positive aft (on a pod behind the trailing
        edge when larger than the aft chord).
    tank_span : float or None
        Spanwise tank position ``y_T``, m; None: at the tip.
    f_bending, f_torsion : float
        Target natural frequencies of the dry structure (wing + tank structure, liquid
        removed), Hz: the bending- and torsion-dominated normal modes.
    damping : (float, float)
        Modal damping ratios of the two modes with frozen liquid (the convention of
        :mod:`sloshrom.beam.simulation.coupled`), -.
    stations : sequence of float
        Spanwise positions of the accelerometer pairs (one at the leading edge, one at the
        trailing edge), m.

    Notes
    -----
    Why these defaults (estimates; every one is a parameter):

    * frequencies 9 and 17 Hz: both inside the 5-25 Hz band of the shaker and of the Phi_d
      maps, where the liquid sloshes violently once the tank exceeds about 1 g; 17/9 = 1.9
      separates them by 15 half-power bandwidths of a 1 % mode, so modal filtering and a band
      of +/-30 % around each mode isolate them.
    * 0.8 m span, 4 kg/m (a 3.2 kg wing: a ballasted aluminium box), centre of mass 5 cm ahead
      of the EA (leading-edge ballast), r_g = 6 cm, EA at 40 % of a 25 cm chord: the
      paper-tank's structure (0.45 kg) and liquid (0.124 kg) are then 15 % and 4 % of the wing
      mass, as on the paper's 2 kg beam (22 % and 6 %).
    * tank 20 cm aft of the EA at the tip: the torsion mode moves it as much as the bending
      mode (unit-maximum shapes: tank displacement 1.0 in both), and the tank offset couples
      bending and torsion only mildly (mass coupling about 0.2), so that the two dry frequencies
      are reachable with a bending-first ordering. The liquid-to-modal-mass ratio
      ``m_l psi_T^2 / m_n`` is then 0.117 and 0.116, against 0.133 for the paper's first
      mode: the sloshing damping is of the same order, measurable on both modes. The modes'
      shares of the tank's quasi-static motion ``psi_T Gamma_n / m_n`` are 1.45 and -0.47
      (the paper beam's modes 1 and 2: 1.30 and -0.40, its mode 2 at 75 Hz though); under
      the random tests of the two-mode study (``[multimode]``, 13 +/- 4 Hz) the torsion mode
      gives the tank 0.7 times the RMS acceleration of the bending mode.
    * damping 1.0 % (bending) and 0.5 % (torsion): the paper beam's estimates for its modes 1
      and 2.
    """

    span: float = 0.8
    chord: float = 0.25
    ea_chord_fraction: float = 0.4
    mass_per_span: float = 4.0
    cg_offset: float = -0.05
    gyration_radius: float = 0.06
    tank_offset: float = 0.20
    tank_span: float | None = None
    f_bending: float = 9.0
    f_torsion: float = 17.0
    damping: tuple[float, float] = (0.010, 0.005)
    stations: tuple[float, ...] = (0.2, 0.4, 0.6, 0.8)

    def __post_init__(self) -> None:
        for name in ("span", "chord", "mass_per_span", "gyration_radius", "f_bending",
                     "f_torsion"):
            v = float(getattr(self, name))
            if not (math.isfinite(v) and v > 0):
                raise ModalDataError(f"wing {name} must be a finite positive number, got {v!r}")
        for name in ("cg_offset", "tank_offset"):
            if not math.isfinite(float(getattr(self, name))):
                raise ModalDataError(f"wing {name} must be finite (m)")
        if not 0 <= self.ea_chord_fraction <= 1:
            raise ModalDataError(f"ea_chord_fraction must be in [0, 1], got "
                                 f"{self.ea_chord_fraction!r}")
        if not self.f_torsion > self.f_bending:
            raise ModalDataError("f_torsion must exceed f_bending (a bending-first wing)")
        if self.tank_offset == 0:
            raise ModalDataError("tank_offset = 0 puts the tank on the elastic axis: the "
                                 "torsion mode would not move it")
        y_t = self.tank_y
        if not 0 < y_t <= self.span:
            raise ModalDataError(f"tank_span must lie in (0, span], got {y_t!r}")
        z = tuple(float(v) for v in self.damping)
        if len(z) != 2 or not all(0 <= v < 1 for v in z):
            raise ModalDataError(f"damping must be two ratios in [0, 1), got {self.damping!r}")
        object.__setattr__(self, "damping", z)
        st = tuple(float(v) for v in self.stations)
        if len(st) < 1 or any(not 0 < v <= self.span for v in st) or len(set(st)) != len(st):
            raise ModalDataError(f"stations must be distinct positions in (0, span], got "
                                 f"{self.stations!r}")
        object.__setattr__(self, "stations", st)

    @property
    def tank_y(self) -> float:
        """Spanwise tank position, m."""
        return float(self.span if self.tank_span is None else self.tank_span)

    @property
    def leading_edge(self) -> float:
        """x of the leading edge, m (negative: ahead of the EA)."""
        return -self.ea_chord_fraction * self.chord

    @property
    def trailing_edge(self) -> float:
        """x of the trailing edge, m."""
        return (1.0 - self.ea_chord_fraction) * self.chord

    def as_dict(self) -> dict[str, Any]:
        """JSON-able parameters."""
        d = asdict(self)
        d["damping"] = list(self.damping)
        d["stations"] = list(self.stations)
        return d


def _assumed_modes(design: WingDesign) -> dict[str, Any]:
    """The two assumed modes on a span grid and the integrals of the Ritz matrices."""
    span = design.span
    y = np.linspace(0.0, span, _N_GRID)
    bare = CantileverBeam(length=span)  # the shape of a uniform bare cantilever: any section
    phi = bare.mode_shapes(y, 1)[:, 0]
    curv = bare.mode_shapes(y, 1, deriv=2)[:, 0]
    k = math.pi / (2.0 * span)
    theta = np.sin(k * y)
    simpson = integrate.simpson

    def phi_at(yy: float, deriv: int = 0) -> float:
        return float(bare.mode_shapes([yy], 1, deriv=deriv)[0, 0])

    return {
        "phi": lambda yy: bare.mode_shapes(yy, 1)[:, 0],
        "theta": lambda yy: np.sin(k * np.asarray(yy, dtype=float)),
        "int_phi2": float(simpson(phi**2, x=y)),
        "int_phi": float(simpson(phi, x=y)),
        "int_curv2": float(simpson(curv**2, x=y)),
        "int_theta2": float(simpson(theta**2, x=y)),
        "int_theta": float(simpson(theta, x=y)),
        "int_dtheta2": float(simpson((k * np.cos(k * y)) ** 2, x=y)),
        "int_phi_theta": float(simpson(phi * theta, x=y)),
        "phi_t": phi_at(design.tank_y),
        "slope_t": phi_at(design.tank_y, 1),
        "theta_t": float(np.sin(k * design.tank_y)),
    }


def wing_ritz(design: WingDesign | None = None, tank: Tank | None = None) -> dict[str, Any]:
    """Rayleigh-Ritz matrices of the dry wing in (q_h (m), q_t (rad)) and its normal modes.

    Parameters
    ----------
    design : WingDesign, optional
        Default :class:`WingDesign()`.
    tank : Tank, optional
        Its ``structure_mass`` (kg) and
        :func:`~sloshrom.beam.simulation.structure.tank_rotary_inertia` belong to the dry structure;
        default: the paper tank.

    Returns
    -------
    dict
        ``mass`` (2x2: kg, kg m, kg m^2), ``stiffness`` (2x2 diagonal: N/m, N m/rad),
        ``participation`` (2: kg, kg m), ``EI`` (N m^2), ``GJ`` (N m^2/rad), ``coupling``
        (``m_ht / sqrt(m_hh m_tt)``, -), ``frequencies`` (Hz, the dry normal modes),
        ``vectors`` (2x2 columns, mass-normalised), ``tank_vector`` (2: the tank's vertical
        displacement per unit q_h and q_t, m/m and m/rad), ``modes`` (the assumed-mode
        functions and integrals).

    Raises
    ------
    ModalDataError
        The mass coupling is too strong for the target frequency ratio (no bending-first
        stiffnesses give both frequencies).
    """
    design = design if design is not None else WingDesign()
    tank = tank if tank is not None else Tank()
    am = _assumed_modes(design)
    mu, xcg, x_t = design.mass_per_span, design.cg_offset, design.tank_offset
    m_t, j_t = tank.structure_mass, tank_rotary_inertia(tank)
    i_alpha = mu * (design.gyration_radius**2 + xcg**2)
    m_hh = mu * am["int_phi2"] + m_t * am["phi_t"] ** 2 + j_t * am["slope_t"] ** 2
    m_tt = i_alpha * am["int_theta2"] + (m_t * x_t**2 + j_t) * am["theta_t"] ** 2
    m_ht = mu * xcg * am["int_phi_theta"] + m_t * x_t * am["phi_t"] * am["theta_t"]
    mass = np.array([[m_hh, m_ht], [m_ht, m_tt]])
    gamma = np.array([mu * am["int_phi"] + m_t * am["phi_t"],
                      mu * xcg * am["int_theta"] + m_t * x_t * am["theta_t"]])
    # stiffnesses from the targets: det(K - lam M) = 0 at lam_1, lam_2 with K diagonal gives
    # k_h k_t = lam_1 lam_2 det M and k_h m_tt + k_t m_hh = (lam_1 + lam_2) det M
    lam1, lam2 = (2 * math.pi * design.f_bending) ** 2, (2 * math.pi * design.f_torsion) ** 2
    det = float(np.linalg.det(mass))
    p, s = lam1 * lam2 * det, (lam1 + lam2) * det
    disc = s * s - 4.0 * m_tt * m_hh * p
    if disc < 0:
        raise ModalDataError(
            f"the tank offset couples bending and torsion too strongly (mass coupling "
            f"{m_ht / math.sqrt(m_hh * m_tt):.2f}) for modes at {design.f_bending:g} and "
            f"{design.f_torsion:g} Hz: reduce tank_offset, or separate the frequencies")
    k_h = (s - math.sqrt(disc)) / (2.0 * m_tt)  # the smaller root: bending below torsion
    k_t = p / k_h
    stiffness = np.diag([k_h, k_t])
    w2, vec = eigh(stiffness, mass)
    return {
        "mass": mass, "stiffness": stiffness, "participation": gamma,
        "EI": k_h / am["int_curv2"], "GJ": k_t / am["int_dtheta2"],
        "coupling": m_ht / math.sqrt(m_hh * m_tt),
        "frequencies": np.sqrt(w2) / (2 * math.pi), "vectors": vec,
        "tank_vector": np.array([am["phi_t"], x_t * am["theta_t"]]),
        "modes": am,
    }


def two_mode_wing(design: WingDesign | None = None, tank: Tank | None = None) -> ModeSet:
    """The wing's two dry normal modes at its accelerometer and tank nodes, as a mode set.

    Nodes: ``1..S`` leading-edge accelerometers at ``design.stations``, ``S+1..2S`` trailing-edge
    ones at the same span positions, ``2S+1`` the tank centre. Coordinates (x chordwise from the
    EA, y span, z 0), m. Shapes: vertical (z) only, normalised to **unit maximum displacement
    over the nodes, tank displacement positive** (the paper's Table 1 convention); modal masses
    (kg) and participation (kg, along z; x and y zero) belong to that normalisation.

    Parameters
    ----------
    design : WingDesign, optional
    tank : Tank, optional
        The tank whose structure the wing carries (default: the paper tank).

    Returns
    -------
    ModeSet
        ``attrs``: ``wing`` (the design), ``EI``, ``GJ``, ``coupling``, ``tank_node``,
        ``station_nodes`` and ``structure_mass`` (kg).
    """
    design = design if design is not None else WingDesign()
    tank = tank if tank is not None else Tank()
    rz = wing_ritz(design, tank)
    am = rz["modes"]
    st = np.asarray(design.stations)
    n_st = st.size
    xs = np.concatenate([np.full(n_st, design.leading_edge), np.full(n_st, design.trailing_edge),
                         [design.tank_offset]])
    ys = np.concatenate([st, st, [design.tank_y]])
    # z = phi_b(y) q_h + x theta(y) q_t at every node, per normal mode
    basis = np.stack([am["phi"](ys), xs * am["theta"](ys)], axis=1)  # (n_nodes, 2)
    z = basis @ rz["vectors"]
    scale = np.max(np.abs(z), axis=0) * np.sign(z[-1])
    z = z / scale
    vec = rz["vectors"] / scale
    shapes = np.zeros((ys.size, 3, 2))
    shapes[:, 2, :] = z
    part = np.zeros((3, 2))
    part[2] = vec.T @ rz["participation"]
    nodes = np.arange(1, ys.size + 1)
    return ModeSet(
        frequencies=rz["frequencies"],
        modal_masses=np.einsum("in,ij,jn->n", vec, rz["mass"], vec),
        nodes=nodes, shapes=shapes, damping=np.asarray(design.damping),
        participation=part, coordinates=np.stack([xs, ys, np.zeros_like(xs)], axis=1),
        source="wing:two-mode",
        attrs={"wing": design.as_dict(), "EI": rz["EI"], "GJ": rz["GJ"],
               "coupling": rz["coupling"], "tank_node": int(nodes[-1]),
               "station_nodes": nodes[:-1].tolist(), "structure_mass": tank.structure_mass},
    )


def wing_modal_model(design: WingDesign | None = None, tank: Tank | None = None) -> ModalModel:
    """The wing as the coupled simulation's modal model (:func:`two_mode_wing`, then
    :meth:`ModeSet.to_modal_model` with the tank node, the 2S accelerometers as outputs, up = +Z
    and the tank's structure mass).

    ``stations`` of the result are the accelerometers' span positions, m (leading-edge ones
    first, then trailing-edge ones: each position appears twice); ``station_ids`` their nodes.
    """
    tank = tank if tank is not None else Tank()
    ms = two_mode_wing(design, tank)
    return ms.to_modal_model(tanks=ms.attrs["tank_node"], outputs=ms.attrs["station_nodes"],
                             direction="+Z", structure_mass=tank.structure_mass)


# -- analysis ----------------------------------------------------------------------------------
def frozen_station_shapes(modal: ModalModel, liquid_mass: float
                          ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Frequencies and shapes of the frozen-liquid modes, for modal filtering.

    The liquid mass at the tank couples the dry modes (``M + m_l psi psi^T``): under random
    excitation the responses separate into the *frozen-liquid* modes, not the dry ones, so the
    stations are filtered with the frozen shapes (as a test engineer would, after a modal test
    with the liquid frozen or replaced by a rigid mass).

    Parameters
    ----------
    modal : ModalModel
        The dry structure (one tank).
    liquid_mass : float
        kg.

    Returns
    -------
    frequencies : ndarray (n_modes,)
        Hz (:func:`~sloshrom.beam.simulation.structure.coupled_frozen_modes`).
    stations : ndarray (n_stations, n_modes)
        Frozen mode shapes at the stations, unit maximum over stations and tank, tank positive.
    tank : ndarray (n_modes,)
        Their tank displacement.
    """
    f, vec = coupled_frozen_modes(modal, liquid_mass)
    st = modal.psi_stations @ vec
    tk = modal.psi_tanks[0] @ vec
    scale = np.maximum(np.max(np.abs(st), axis=0), np.abs(tk))
    scale = scale * np.where(tk < 0, -1.0, 1.0)
    return f, st / scale, tk / scale


def structure_summary(modal: ModalModel, liquid_mass: float) -> dict[str, Any]:
    """The structure's modes, how much each moves the tank, and the liquid's weight in each.

    Parameters
    ----------
    modal : ModalModel
        Dry structure with participation (one tank).
    liquid_mass : float
        kg.

    Returns
    -------
    dict
        JSON-able lists, one entry per mode: ``f_dry_hz``, ``f_frozen_hz`` (Hz); ``damping``
        (-); ``modal_mass_kg`` (dry, unit maximum displacement); ``psi_tank`` (dry tank
        displacement, -); ``participation_kg``; ``effective_tank_mass_kg``
        (``m_n / psi_T^2``, the mass the tank drives in mode n); ``liquid_ratio``
        (``m_l psi_T^2 / m_n``, the paper beam's first mode: 0.133);
        ``tank_participation`` (``psi_T Gamma_n / m_n``, -: the mode's share of the tank's
        quasi-static base-following motion; the shares of a complete set of modes add up to 1,
        the paper beam's: 1.30, -0.40, 0.15).
    """
    psi = modal.psi_tanks[0]
    f_frozen, _, _ = frozen_station_shapes(modal, liquid_mass)
    m = modal.modal_masses
    with np.errstate(divide="ignore"):
        eff = np.where(psi != 0, m / psi**2, np.inf)
    return {
        "f_dry_hz": modal.frequencies.tolist(),
        "f_frozen_hz": f_frozen.tolist(),
        "damping": modal.damping.tolist(),
        "modal_mass_kg": m.tolist(),
        "psi_tank": psi.tolist(),
        "participation_kg": modal.participation.tolist(),
        "effective_tank_mass_kg": eff.tolist(),
        "liquid_ratio": (liquid_mass * psi**2 / m).tolist(),
        "tank_participation": (psi * modal.participation / m).tolist(),
    }

