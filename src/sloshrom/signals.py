"""Excitation signals: harmonic tests, variable-frequency-amplitude (VFA) paths, random base input,
band-limited broadband tank acceleration (rig records that start and end at rest).

Functions take the sample rate ``fs`` (Hz) and return plain arrays, in the style of
``scipy.signal``. Displacement w is positive up; all quantities SI. A signal that cannot be made
as asked (a rate too low for its frequencies, a negative amplitude, ...) raises
:class:`SignalError`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from sloshrom.config import G, Tank
from sloshrom.errors import SloshromError


class SignalError(SloshromError):
    """A signal cannot be made as asked: a rate, frequency, amplitude, duration or shaker limit
    out of range (the message names the argument and its value)."""


@dataclass(frozen=True)
class Harmonic:
    """A ramped harmonic motion ``w = a r(t) cos(Omega t)`` sampled at ``fs``.

    Attributes
    ----------
    time, displacement, velocity, acceleration : ndarray
        s, m, m/s, m/s^2 (exact derivatives of the ramped displacement).
    steady : slice
        Samples of the whole steady cycles (ramps excluded), for per-cycle energy.
    frequency : float
        Hz.
    amplitude : float
        Displacement amplitude a, m.
    """

    time: np.ndarray
    displacement: np.ndarray
    velocity: np.ndarray
    acceleration: np.ndarray
    steady: slice
    frequency: float
    amplitude: float


def _ramp(t: np.ndarray, t_up: float, t_total: float) -> tuple[np.ndarray, ...]:
    """Raised-cosine ramp r(t) in [0, t_up] and out over the last t_up, with r', r''."""
    r = np.ones_like(t)
    dr = np.zeros_like(t)
    ddr = np.zeros_like(t)
    if t_up <= 0:
        return r, dr, ddr
    k = np.pi / t_up
    up = t < t_up
    down = t > t_total - t_up
    for mask, tau, sign in ((up, t, 1.0), (down, t_total - t, -1.0)):
        x = k * tau[mask]
        r[mask] = 0.5 * (1.0 - np.cos(x))
        dr[mask] = sign * 0.5 * k * np.sin(x)
        ddr[mask] = 0.5 * k * k * np.cos(x)
    return r, dr, ddr


def harmonic(
    fs: float,
    frequency: float,
    amplitude: float,
    n_cycles: int = 10,
    n_ramp: int = 3,
    n_settle: int = 2,
) -> Harmonic:
    """Ramped harmonic tank motion ``w(t) = a r(t) cos(2 pi f t)``.

    The motion ramps in over ``n_ramp`` cycles (raised cosine), holds ``n_settle`` cycles for the
    transient to die, then ``n_cycles`` steady cycles (the ones to evaluate), then ramps out.

    Parameters
    ----------
    fs : float
        Sample rate, Hz.
    frequency : float
        Excitation frequency f = Omega / 2 pi, Hz.
    amplitude : float
        Displacement amplitude a, m.
    n_cycles : int
        Steady cycles to evaluate.
    n_ramp, n_settle : int
        Cycles of ramp (each end) and of settling before the evaluated cycles.

    Returns
    -------
    Harmonic
    """
    if not (fs > 0 and frequency > 0 and np.isfinite(fs) and np.isfinite(frequency)):
        raise SignalError(f"fs and frequency must be positive, got fs={fs!r}, f={frequency!r}")
    if not (amplitude >= 0 and np.isfinite(amplitude)):
        raise SignalError(f"amplitude must be a finite non-negative length in m, got {amplitude!r}")
    if fs < 8 * frequency:
        raise SignalError(f"fs={fs} Hz is too low for f={frequency} Hz (need >= 8 samples/cycle)")
    if n_cycles < 1 or n_ramp < 0 or n_settle < 0:
        raise SignalError("n_cycles must be >= 1 and n_ramp, n_settle >= 0")
    period = 1.0 / frequency
    t_up = n_ramp * period
    t_total = (2 * n_ramp + n_settle + n_cycles) * period
    n = int(round(t_total * fs)) + 1
    t = np.arange(n) / fs
    om = 2.0 * np.pi * frequency
    r, dr, ddr = _ramp(t, t_up, t_total)
    c, s = np.cos(om * t), np.sin(om * t)
    w = amplitude * r * c
    v = amplitude * (dr * c - om * r * s)
    acc = amplitude * (ddr * c - 2.0 * om * dr * s - om * om * r * c)
    i0 = int(round((n_ramp + n_settle) * period * fs))
    i1 = int(round((n_ramp + n_settle + n_cycles) * period * fs))
    return Harmonic(t, w, v, acc, slice(i0, i1), float(frequency), float(amplitude))


def _ramp_c2(t: np.ndarray, t_up: float, t_total: float) -> tuple[np.ndarray, ...]:
    """Quintic smooth-step fade in over [0, t_up] and out over the last t_up, with r', r''.

    C2-continuous (unlike the raised cosine), so the acceleration of a ramped motion has no jumps.
    """
    r = np.ones_like(t)
    dr = np.zeros_like(t)
    ddr = np.zeros_like(t)
    if t_up <= 0:
        return r, dr, ddr
    for mask, tau, sign in ((t < t_up, t, 1.0), (t > t_total - t_up, t_total - t, -1.0)):
        x = tau[mask] / t_up
        r[mask] = x**3 * (10.0 - 15.0 * x + 6.0 * x * x)
        dr[mask] = sign * 30.0 * x * x * (1.0 - x) ** 2 / t_up
        ddr[mask] = 60.0 * x * (1.0 - x) * (1.0 - 2.0 * x) / t_up**2
    return r, dr, ddr


# --------------------------------------------------------------------------------------------
# VFA: variable frequency and amplitude (paper section 2.1, Figs. 5 and 7a)
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class ShakerEnvelope:
    """The domain of the shaker tests: VFA paths and Phi_d maps (estimates, SI except as noted).

    The one definition of the test domain: :func:`vfa`, :func:`vfa_gamma_limit`,
    :func:`sloshrom.energy.shaker_envelope`, :func:`sloshrom.energy.phi_d_map` and
    :func:`sloshrom.energy.default_grid` take their defaults from :data:`SHAKER_ENVELOPE`. The
    paper plays 5-25 Hz up to 6 g; ``a_bar_max`` keeps the displacement within the shaker's
    stroke for the paper tank (0.45 h = 12.2 mm < 12.5 mm, see :class:`ShakerLimits`).

    Attributes
    ----------
    f_min, f_max : float
        Frequency band, Hz.
    gamma_max : float
        Largest acceleration amplitude ``a Omega^2 / g``, g.
    a_bar_max : float
        Largest displacement amplitude over tank height ``a / h``, -.
    """

    f_min: float = 5.0
    f_max: float = 25.0
    gamma_max: float = 6.0
    a_bar_max: float = 0.45

    def __post_init__(self) -> None:
        for name in ("f_min", "f_max", "gamma_max", "a_bar_max"):
            v = getattr(self, name)
            if not (np.isfinite(v) and v > 0):
                raise SignalError(f"ShakerEnvelope.{name} must be finite and positive, got {v!r}")
        if not self.f_min < self.f_max:
            raise SignalError(f"ShakerEnvelope: need f_min < f_max, got {self.f_min}, {self.f_max}")


#: The shaker-test domain of the paper (5-25 Hz, Gamma <= 6 g, a_bar <= 0.45): the defaults.
SHAKER_ENVELOPE = ShakerEnvelope()

#: Smallest a_bar of the default map grid (below it the force is at the noise floor).
DEFAULT_A_BAR_MIN = 0.01


@dataclass(frozen=True)
class ShakerLimits:
    """Limits of the electrodynamic shaker that a VFA path must respect (SI).

    The paper does not give its shaker; the defaults are engineering estimates of a small
    laboratory shaker (±12.5 mm stroke, 1 m/s, 6 g) and are only upper bounds: the VFA domain
    (:data:`SHAKER_ENVELOPE`, ``a_bar <= 0.45`` of the paper tank, i.e. 12.2 mm) is usually the
    tighter one. The acceleration limit is the envelope's ``gamma_max`` (one definition of 6 g).

    Attributes
    ----------
    max_displacement : float
        Displacement amplitude limit, m.
    max_velocity : float
        Velocity amplitude limit, m/s.
    max_acceleration : float
        Acceleration amplitude limit, m/s^2.
    """

    max_displacement: float = 0.0125
    max_velocity: float = 1.0
    max_acceleration: float = SHAKER_ENVELOPE.gamma_max * G

    def __post_init__(self) -> None:
        for name in ("max_displacement", "max_velocity", "max_acceleration"):
            v = getattr(self, name)
            if not (np.isfinite(v) and v > 0):
                raise SignalError(f"ShakerLimits.{name} must be finite and positive, got {v!r}")


#: The (estimated) limits of the paper's shaker: 12.5 mm, 1 m/s, 6 g.
SHAKER_LIMITS = ShakerLimits()


@dataclass(frozen=True)
class VFADesign:
    """The amplitude limits of a VFA path (the keywords of :func:`vfa`), and why.

    Attributes
    ----------
    gamma_max : float
        Largest acceleration amplitude, g.
    a_bar_max : float
        Largest displacement amplitude / tank height, -.
    limits : ShakerLimits
        Displacement (m), velocity (m/s) and acceleration (m/s^2) limits of the path.
    rule : str
        ``"shaker"`` (the paper's shaker domain) or ``"structure"`` (:func:`vfa_design`).
    margin : float
        Factor over the structure's tank motion, - (1 for ``"shaker"``).
    """

    gamma_max: float
    a_bar_max: float
    limits: ShakerLimits
    rule: str = "shaker"
    margin: float = 1.0

    def kwargs(self) -> dict[str, object]:
        """``gamma_max``, ``a_bar_max`` and ``limits``, to pass to :func:`vfa`."""
        return {"gamma_max": self.gamma_max, "a_bar_max": self.a_bar_max, "limits": self.limits}

    def exceeds(self, shaker: ShakerLimits | None = None) -> list[str]:
        """Which limits of ``shaker`` (default: the paper's, :data:`SHAKER_LIMITS`) the design
        goes beyond: a subset of ``["acceleration", "velocity", "displacement"]``.

        A laboratory would need a bigger shaker for those; the virtual rig has no limits.
        """
        shaker = SHAKER_LIMITS if shaker is None else shaker
        tol = 1.0 + 1e-9
        out = []
        if self.limits.max_acceleration > shaker.max_acceleration * tol:
            out.append("acceleration")
        if self.limits.max_velocity > shaker.max_velocity * tol:
            out.append("velocity")
        if self.limits.max_displacement > shaker.max_displacement * tol:
            out.append("displacement")
        return out


#: The paper's VFA domain: 6 g, a_bar <= 0.45 and the (estimated) shaker limits.
SHAKER_DESIGN = VFADesign(SHAKER_ENVELOPE.gamma_max, SHAKER_ENVELOPE.a_bar_max, SHAKER_LIMITS)

#: Width (as a frequency ratio) of the band below the structure's dominant frequency in which
#: a structure-designed VFA may reach the full velocity, -.
DESIGN_SPREAD = 1.25


def vfa_design(
    peak_acceleration: float,
    peak_velocity: float,
    displacement: float,
    frequency: float,
    tank: Tank | None = None,
    margin: float = 1.15,
    f_min: float = SHAKER_ENVELOPE.f_min,
    f_max: float = SHAKER_ENVELOPE.f_max,
    spread: float = DESIGN_SPREAD,
) -> VFADesign:
    """VFA limits whose acceleration and velocity cover a structure's tank motion.

    The rule, never below the paper's shaker domain (:data:`SHAKER_DESIGN`: 6 g, 1 m/s,
    12.5 mm, a_bar 0.45):

    * velocity ``V = margin * peak_velocity``;
    * displacement ``D = max(margin * displacement, V / (2 pi f / spread))`` and
      acceleration ``A = max(margin * peak_acceleration, V 2 pi f)``, so that the velocity
      limit alone binds between ``f / spread`` and ``f`` (f the structure's dominant
      frequency): the path reaches the full velocity at and just below f, where it needs the
      least acceleration;
    * ``gamma_max = A / g``, ``a_bar_max = D / h``, ``ShakerLimits(D, V, A)``;
    * then every limit is scaled by the same factor (>= 1) so that the smooth minimum of
      :func:`vfa_gamma_limit` (up to ~5 % below the smallest limit) still gives an acceleration
      amplitude ``>= margin * peak_acceleration`` somewhere in the band and a velocity amplitude
      ``>= margin * peak_velocity`` at f (clipped into the band).

    Parameters
    ----------
    peak_acceleration : float
        The structure's largest tank acceleration, m/s^2.
    peak_velocity : float
        Its largest tank velocity, m/s.
    displacement : float
        Its tank displacement amplitude, m.
    frequency : float
        Its dominant frequency, Hz.
    tank : Tank, optional
        Sets h (default: the paper tank).
    margin : float
        Factor (>= 1) over the structure's motion, -.
    f_min, f_max : float
        Band of the VFA path, Hz.
    spread : float
        Frequency ratio (> 1) of the velocity plateau below ``frequency``, -.

    Returns
    -------
    VFADesign
    """
    tank = Tank() if tank is None else tank
    for name, v in (("peak_acceleration", peak_acceleration), ("peak_velocity", peak_velocity),
                    ("displacement", displacement), ("frequency", frequency)):
        if not (np.isfinite(v) and v >= 0):
            raise SignalError(f"{name} must be finite and >= 0, got {v!r}")
    if not (np.isfinite(margin) and margin >= 1.0):
        raise SignalError(f"margin must be >= 1, got {margin!r}")
    if not (np.isfinite(spread) and spread > 1.0):
        raise SignalError(f"spread must be > 1, got {spread!r}")
    if not 0 < f_min < f_max:
        raise SignalError(f"need 0 < f_min < f_max, got {f_min!r}, {f_max!r}")
    paper = SHAKER_DESIGN
    f_dom = float(np.clip(frequency, f_min, f_max)) if frequency > 0 else f_min
    om = 2.0 * np.pi * f_dom
    need_acc = margin * peak_acceleration
    need_vel = margin * peak_velocity
    vel = max(paper.limits.max_velocity, need_vel)
    disp = max(paper.limits.max_displacement, margin * displacement, need_vel * spread / om)
    acc = max(paper.limits.max_acceleration, need_acc, need_vel * om)
    a_bar = max(paper.a_bar_max, disp / tank.height)
    # the smooth minimum sits below the smallest limit: scale all (it is homogeneous) to reach
    f = np.geomspace(f_min, f_max, 2001)
    reach_acc = float(np.max(vfa_gamma_limit(f, tank, a_bar, acc / G,
                                             ShakerLimits(disp, vel, acc)))) * G
    reach_vel = float(vfa_gamma_limit(np.array([f_dom]), tank, a_bar, acc / G,
                                      ShakerLimits(disp, vel, acc))[0]) * G / om
    k = max(1.0, need_acc / reach_acc, need_vel / reach_vel)
    return VFADesign(gamma_max=k * acc / G, a_bar_max=k * a_bar,
                     limits=ShakerLimits(k * disp, k * vel, k * acc), rule="structure",
                     margin=float(margin))


@dataclass(frozen=True)
class VFA:
    """A VFA acceleration law and its path in the (omega_bar, a_bar) plane.

    Motion ``w(t) = -a(t) cos(theta(t))``, ``theta' = Omega(t)``, hence
    ``w'' = A(t) cos(theta) + O(a', Omega')`` with ``A = a Omega^2`` (the paper's law
    ``w'' = f(t) cos(int Omega dt)``); displacement, velocity and acceleration are exact
    derivatives of each other (no integration drift), and all three are zero at both ends.

    Attributes
    ----------
    time : ndarray
        s, uniform at ``fs``.
    displacement, velocity, acceleration : ndarray
        m, m/s, m/s^2 (w up positive).
    frequency : ndarray
        Instantaneous frequency Omega / 2 pi, Hz.
    amplitude : ndarray
        Instantaneous displacement amplitude a(t), m.
    fs : float
        Sample rate, Hz.
    split : str
        ``"train"`` or ``"validation"``.
    seed : int
        Seed of the path's phase.
    height : float
        Tank height h, m (for ``a_bar``, ``omega_bar``).

    Properties ``omega_bar`` (Omega / sqrt(g/h)), ``a_bar`` (a / h) and ``gamma`` (acceleration
    amplitude in g, ``a Omega^2 / g = a_bar omega_bar^2``) give the non-dimensional path.
    """

    time: np.ndarray
    displacement: np.ndarray
    velocity: np.ndarray
    acceleration: np.ndarray
    frequency: np.ndarray
    amplitude: np.ndarray
    fs: float
    split: str
    seed: int
    height: float

    @property
    def omega_bar(self) -> np.ndarray:
        """Omega / sqrt(g/h)."""
        return 2.0 * np.pi * self.frequency / np.sqrt(G / self.height)

    @property
    def a_bar(self) -> np.ndarray:
        """a / h."""
        return self.amplitude / self.height

    @property
    def gamma(self) -> np.ndarray:
        """Acceleration amplitude a Omega^2 / g, in g."""
        return self.amplitude * (2.0 * np.pi * self.frequency) ** 2 / G


# Lissajous-like path families: the normalised log-frequency x(s) = (1 - cos(2 pi p s + phi)) / 2
# sweeps the band p times, while the normalised amplitude y(s) = (1 - cos(2 pi q s)) / 2 goes from
# rest to the limit and back q times (q integer, so both ends are at rest). Different (p, q, phi)
# give two different paths over the same domain; q / (2 p) is kept away from integers, otherwise
# successive sweeps retrace the same arches and leave gaps (chosen by the 95th percentile of the
# distance from a 60 x 60 grid of the normalised domain to the path: 0.013 train, 0.032
# validation).
_VFA_FAMILIES = {
    "train": {"duration": 480.0, "p": 2.5, "q": 38, "phase": 0.0},
    "validation": {"duration": 240.0, "p": 2.5, "q": 19, "phase": np.pi},
}


def _softmin_log(values: list[np.ndarray], tau: float = 0.03) -> np.ndarray:
    """Smooth minimum of positive arrays (log-sum-exp on logs): smooth, <= min, within ~3 %."""
    logs = np.stack([np.log(v) for v in values])
    m = logs.min(axis=0)
    return np.exp(m - tau * np.log(np.sum(np.exp(-(logs - m) / tau), axis=0)))


def vfa_gamma_limit(
    frequency: np.ndarray,
    tank: Tank | None = None,
    a_bar_max: float = SHAKER_ENVELOPE.a_bar_max,
    gamma_max: float = SHAKER_ENVELOPE.gamma_max,
    limits: ShakerLimits | None = None,
) -> np.ndarray:
    """Largest acceleration amplitude (in g) a VFA path may reach at each frequency.

    Smooth minimum of ``gamma_max``, ``a_bar_max omega_bar^2`` and the shaker's displacement,
    velocity and acceleration limits.

    Parameters
    ----------
    frequency : array_like
        Hz.
    tank : Tank, optional
        Sets h (default: the paper tank).
    a_bar_max : float
        Largest a / h.
    gamma_max : float
        Largest acceleration amplitude, g.
    limits : ShakerLimits, optional
        Default :data:`SHAKER_LIMITS`.

    Returns
    -------
    ndarray
        Acceleration amplitude limit, g.
    """
    tank = Tank() if tank is None else tank
    limits = SHAKER_LIMITS if limits is None else limits
    om = 2.0 * np.pi * np.asarray(frequency, dtype=float)
    omb2 = om**2 / (G / tank.height)
    ones = np.ones_like(om)
    return _softmin_log(
        [
            gamma_max * ones,
            a_bar_max * omb2,
            limits.max_displacement * om**2 / G,
            limits.max_velocity * om / G,
            limits.max_acceleration / G * ones,
        ]
    )


def vfa(
    fs: float,
    split: str = "train",
    duration: float | None = None,
    tank: Tank | None = None,
    seed: int = 0,
    f_min: float = SHAKER_ENVELOPE.f_min,
    f_max: float = SHAKER_ENVELOPE.f_max,
    a_bar_max: float = SHAKER_ENVELOPE.a_bar_max,
    gamma_max: float = SHAKER_ENVELOPE.gamma_max,
    limits: ShakerLimits | None = None,
    ramp: float = 2.0,
) -> VFA:
    """Variable-frequency-and-amplitude (VFA) tank motion (paper section 2.1, Fig. 5).

    The path sweeps log-frequency between ``f_min`` and ``f_max`` slowly (``p`` sweeps) while the
    acceleration amplitude goes from rest to ``vfa_gamma_limit(f)`` and back ``q`` times, so that
    (omega_bar, a_bar) covers the domain bounded by ``gamma <= gamma_max``,
    ``a_bar <= a_bar_max`` and the shaker limits. ``"train"`` (480 s, p = 2.5, q = 38) and
    ``"validation"`` (240 s, p = 2.5, q = 19, starting at ``f_max``) are different paths over
    the same domain. Both start and end at rest (amplitude zero, plus a C2 smooth-step ramp of
    ``ramp`` s).

    Parameters
    ----------
    fs : float
        Sample rate, Hz (at least 8 samples per cycle of ``f_max``).
    split : {"train", "validation"}
    duration : float, optional
        s; default 480 (train) or 240 (validation). A different duration scales the same path.
    tank : Tank, optional
        Sets h for omega_bar and a_bar (default: the paper tank).
    seed : int
        Seeds a random phase shift (within ±pi/4) of the frequency sweep.
    f_min, f_max : float
        Frequency band, Hz.
    a_bar_max : float
        Largest displacement amplitude / tank height.
    gamma_max : float
        Largest acceleration amplitude, g.
    limits : ShakerLimits, optional
        Shaker displacement/velocity/acceleration limits.
    ramp : float
        Smooth-step (quintic, C2) fade in/out, s.

    Returns
    -------
    VFA
    """
    tank = Tank() if tank is None else tank
    limits = SHAKER_LIMITS if limits is None else limits
    if split not in _VFA_FAMILIES:
        raise SignalError(f"split must be 'train' or 'validation', got {split!r}")
    fam = _VFA_FAMILIES[split]
    duration = fam["duration"] if duration is None else float(duration)
    if not (np.isfinite(fs) and fs > 0):
        raise SignalError(f"fs must be a finite positive rate in Hz, got {fs!r}")
    if not (0 < f_min < f_max and np.isfinite(f_max)):
        raise SignalError(f"need 0 < f_min < f_max, got f_min={f_min!r}, f_max={f_max!r}")
    if fs < 8 * f_max:
        raise SignalError(f"fs={fs} Hz is too low for f_max={f_max} Hz (need >= 8 samples/cycle)")
    if not (np.isfinite(duration) and duration > 2 * ramp and duration >= 10.0):
        raise SignalError(f"duration must be >= 10 s and > 2*ramp, got {duration!r}")
    rng = np.random.default_rng(seed)
    phase = fam["phase"] + rng.uniform(-0.25, 0.25) * np.pi
    p, q = fam["p"], fam["q"]
    log_ratio = np.log(f_max / f_min)

    def envelope(t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Slow displacement amplitude a(t) (m) and angular frequency Omega(t) (rad/s)."""
        s = np.clip(t / duration, 0.0, 1.0)
        x = 0.5 - 0.5 * np.cos(2.0 * np.pi * p * s + phase)
        y = 0.5 - 0.5 * np.cos(2.0 * np.pi * q * s)
        f = f_min * np.exp(x * log_ratio)
        gam = y * vfa_gamma_limit(f, tank, a_bar_max, gamma_max, limits)
        om = 2.0 * np.pi * f
        return gam * G / om**2, om

    n = int(round(duration * fs)) + 1
    t = np.arange(n) / fs
    duration = float(t[-1])  # the path ends exactly on the last sample
    # The envelope varies over seconds: sample it at 100 Hz and interpolate with C2 cubic splines,
    # whose derivatives and antiderivative are exact; w, v and acc below are then exact
    # derivatives of one smooth function, at any fs, at the cost of a few arrays of size n.
    from scipy.interpolate import CubicSpline  # heavy (0.8 s): loaded when a path is made

    t_env = np.linspace(0.0, duration, int(np.ceil(duration * 100.0)) + 1)
    a_env, om_env = envelope(t_env)
    a_spl = CubicSpline(t_env, a_env, bc_type="clamped")
    om_spl = CubicSpline(t_env, om_env)
    # the ramp multiplies the spline exactly (product rule), so that w, v and acc are exactly
    # zero at both ends (the spline is exactly zero at its end knots)
    r, dr, ddr = _ramp_c2(t, ramp, duration)
    a_s, da_s, dda_s = a_spl(t), a_spl(t, 1), a_spl(t, 2)
    a = r * a_s
    da = dr * a_s + r * da_s
    dda = ddr * a_s + 2.0 * dr * da_s + r * dda_s
    del r, dr, ddr, a_s, da_s, dda_s
    om = om_spl(t)
    dom = om_spl(t, 1)
    theta = om_spl.antiderivative()(t)
    c = np.cos(theta)
    s_ = np.sin(theta)
    del theta
    w = -a * c
    v = a * om * s_ - da * c
    acc = (a * om**2 - dda) * c
    acc += (2.0 * da * om + a * dom) * s_
    return VFA(
        time=t,
        displacement=w,
        velocity=v,
        acceleration=acc,
        frequency=om / (2 * np.pi),
        amplitude=a,
        fs=float(fs),
        split=split,
        seed=int(seed),
        height=tank.height,
    )


# --------------------------------------------------------------------------------------------
# Random base acceleration with a Gaussian PSD (paper Eq. 8)
# --------------------------------------------------------------------------------------------


def gaussian_psd(f, f0: float, sigma: float, A: float) -> np.ndarray:
    """One-sided Gaussian-shaped PSD of paper Eq. (8).

    ``S(f) = A / (sigma sqrt(2 pi)) [exp(-(f - f0)^2 / 2 sigma^2) + exp(-(f + f0)^2 / 2 sigma^2)]``;
    its integral over f >= 0 is exactly ``A`` (the variance).

    Parameters
    ----------
    f : array_like
        Frequency, Hz (>= 0).
    f0 : float
        Centre, Hz.
    sigma : float
        Standard deviation, Hz.
    A : float
        Variance of the signal (e.g. (m/s^2)^2).

    Returns
    -------
    ndarray
        PSD in units of A per Hz.
    """
    if not (np.isfinite(sigma) and sigma > 0):
        raise SignalError(f"sigma must be a positive frequency in Hz, got {sigma!r}")
    f = np.asarray(f, dtype=float)
    k = A / (sigma * np.sqrt(2.0 * np.pi))
    return k * (
        np.exp(-((f - f0) ** 2) / (2 * sigma**2)) + np.exp(-((f + f0) ** 2) / (2 * sigma**2))
    )


def random_base_acceleration(
    fs: float,
    duration: float,
    rms,
    f0: float = 12.0,
    sigma: float = 4.0,
    seed: int = 0,
    fade: float = 0.0,
) -> np.ndarray:
    """Random acceleration with the Gaussian PSD of paper Eq. (8) and an exact RMS.

    Random-phase inverse FFT: the amplitude of each FFT bin follows ``sqrt(S(f))`` exactly and the
    phases are uniform random (seeded), so the periodogram of the (periodic) record is the target
    shape without statistical scatter. The record is then scaled to the exact RMS. Several levels
    share the SAME phases (the same signal, scaled), as the paper's 0.1/0.2/0.4 g tests.

    Parameters
    ----------
    fs : float
        Sample rate, Hz (must exceed 2 (f0 + 4 sigma)).
    duration : float
        s; n = round(duration fs) samples.
    rms : float or sequence of float
        Target RMS, m/s^2 (multiply g-levels by ``sloshrom.config.G``).
    f0, sigma : float
        Centre and standard deviation of the PSD, Hz (defaults are estimates).
    seed : int
        Seed of the random phases.
    fade : float
        Raised-cosine fade in/out at each end, s (0: none). The mean is still removed and the RMS
        is exact over the whole returned record, fades included.

    Returns
    -------
    ndarray
        Shape (n,) for a scalar ``rms``, (n_levels, n) for a sequence; zero mean.
    """
    if not (np.isfinite(fs) and fs > 0):
        raise SignalError(f"fs must be a finite positive rate in Hz, got {fs!r}")
    if not (np.isfinite(f0) and f0 >= 0 and np.isfinite(sigma) and sigma > 0):
        raise SignalError(f"need f0 >= 0 and sigma > 0 in Hz, got f0={f0!r}, sigma={sigma!r}")
    if fs <= 2 * (f0 + 4 * sigma):
        raise SignalError(f"fs={fs} Hz is too low for the PSD (need fs > 2 (f0 + 4 sigma))")
    n = int(round(duration * fs))
    if n < 16:
        raise SignalError(f"duration={duration!r} s gives fewer than 16 samples at fs={fs} Hz")
    if not (np.isfinite(fade) and 0 <= 2 * fade < duration):
        raise SignalError(f"fade must be in [0, duration/2), got {fade!r}")
    levels = np.asarray(rms, dtype=float)
    if levels.ndim > 1 or not np.all(np.isfinite(levels)) or np.any(levels < 0):
        raise SignalError(f"rms must be a non-negative number or 1-D sequence (m/s^2), got {rms!r}")
    rng = np.random.default_rng(seed)
    freqs = np.fft.rfftfreq(n, 1.0 / fs)
    mag = np.sqrt(gaussian_psd(freqs, f0, sigma, 1.0))
    mag[0] = 0.0  # zero mean
    if n % 2 == 0:
        mag[-1] = 0.0  # the Nyquist bin is real; leave it out
    phases = rng.uniform(0.0, 2.0 * np.pi, size=freqs.size)
    x = np.fft.irfft(mag * np.exp(1j * phases), n)
    if fade > 0:
        t = np.arange(n) / fs
        r, _, _ = _ramp(t, fade, t[-1])
        x = x * r
        x = x - (x.mean() / r.mean()) * r  # zero mean, ends still at zero
    x = x / np.sqrt(np.mean(x**2))
    return np.multiply.outer(levels, x) if levels.ndim else float(levels) * x


def _fade_window(n: int, fs: float, fade: float) -> np.ndarray:
    """Raised-cosine fade in and out over ``fade`` s at each end (ones in between)."""
    t = np.arange(n) / fs
    r = np.ones(n)
    if fade > 0:
        rise = t < fade
        fall = t > t[-1] - fade
        r[rise] = 0.5 * (1 - np.cos(np.pi * t[rise] / fade))
        r[fall] = 0.5 * (1 - np.cos(np.pi * (t[-1] - t[fall]) / fade))
    return r


def to_rest(x: np.ndarray, fs: float, fade: float, end_fade: float | None = None
            ) -> np.ndarray:
    """An acceleration that starts and ends at rest, as a shaker must play it.

    A raised-cosine fade of ``fade`` s in and ``end_fade`` s out (default ``fade``), then two
    smooth corrections (the fade window and the fade window times ``t - T/2``, least squares)
    that zero the mean and the first moment: the velocity and the displacement integrated from
    rest return to zero at the end.

    Parameters
    ----------
    x : ndarray (n,)
        Acceleration, m/s^2 (any unit: the operation is linear).
    fs : float
        Sample rate, Hz.
    fade, end_fade : float
        Fade-in and fade-out, s (> 0).

    Returns
    -------
    ndarray (n,)
        Zero at both ends, zero mean and zero first moment (to round-off).
    """
    x = np.asarray(x, dtype=float)
    end = fade if end_fade is None else end_fade
    if x.ndim != 1 or not (np.isfinite(fade) and fade > 0 and np.isfinite(end) and end > 0):
        raise SignalError(f"need a 1-D signal and fades > 0 s, got fade={fade!r}, "
                          f"end_fade={end_fade!r}")
    n = x.size
    if (fade + end) * fs >= n - 1:
        raise SignalError(f"the fades ({fade:g} + {end:g} s) do not fit in {n / fs:g} s")
    t = np.arange(n) / fs
    r = _fade_window(n, fs, fade)
    if end != fade:
        r = np.where(t <= t[-1] / 2, r, _fade_window(n, fs, end))
    x = x * r
    # zero mean (end velocity) and first moment (end displacement) with smooth corrections
    basis = np.stack([r, r * (t - t[-1] / 2)])
    moments = np.stack([np.ones(n), t])
    coef = np.linalg.solve(moments @ basis.T, moments @ x)
    return x - coef @ basis


def broadband_acceleration(
    fs: float,
    duration: float,
    rms: float,
    f_lo: float,
    f_hi: float,
    seed: int = 0,
    fade: float = 2.0,
    edge: float = 0.1,
) -> np.ndarray:
    """Band-limited Gaussian tank acceleration that starts and ends at rest.

    Random-phase inverse FFT of a flat amplitude spectrum on ``[f_lo, f_hi]`` (raised-cosine
    edges over ``edge`` of the band's width on each side): a stationary Gaussian signal whose
    periodogram is the band exactly. Then a raised-cosine fade of ``fade`` s at both ends and two
    smooth corrections (the fade window and the fade window times ``t - T/2``, least squares)
    that zero the mean and the first moment: velocity and displacement return to zero at the
    end (rest: a shaker could play it). Finally scaled to the exact ``rms`` over the record.

    Parameters
    ----------
    fs : float
        Sample rate, Hz (the rig's fine rate, 10 kHz).
    duration : float
        s (> 2 ``fade``).
    rms : float
        RMS acceleration, m/s^2.
    f_lo, f_hi : float
        Band, Hz (0 < f_lo < f_hi < fs / 2).
    seed : int
        Seed of the phases.
    fade : float
        Fade in/out, s.
    edge : float
        Width of each spectral taper, fraction of ``f_hi - f_lo`` (-).

    Returns
    -------
    ndarray (n,)
        m/s^2, ``n = round(duration fs) + 1``; zero at both ends, zero mean and zero first
        moment (the end velocity and displacement are zero to round-off).
    """
    if not (np.isfinite(fs) and fs > 0):
        raise SignalError(f"fs must be a finite positive rate in Hz, got {fs!r}")
    if not (0 < f_lo < f_hi < fs / 2):
        raise SignalError(f"need 0 < f_lo < f_hi < fs/2, got f_lo={f_lo!r}, f_hi={f_hi!r}")
    if not (np.isfinite(rms) and rms >= 0):
        raise SignalError(f"rms must be >= 0 (m/s^2), got {rms!r}")
    if not (np.isfinite(fade) and fade > 0 and np.isfinite(duration) and duration > 2 * fade):
        raise SignalError(f"need fade > 0 and duration > 2 fade, got {fade!r}, {duration!r}")
    if not 0 <= edge < 0.5:
        raise SignalError(f"edge must be in [0, 0.5), got {edge!r}")
    n = int(round(duration * fs)) + 1
    freqs = np.fft.rfftfreq(n, 1.0 / fs)
    width = edge * (f_hi - f_lo)
    mag = ((freqs >= f_lo) & (freqs <= f_hi)).astype(float)
    if width > 0:
        for lo, hi, rising in ((f_lo, f_lo + width, True), (f_hi - width, f_hi, False)):
            sel = (freqs >= lo) & (freqs <= hi)
            s = (freqs[sel] - lo) / width
            mag[sel] = 0.5 * (1 - np.cos(np.pi * (s if rising else 1 - s)))
    rng = np.random.default_rng(seed)
    x = to_rest(np.fft.irfft(mag * np.exp(1j * rng.uniform(0, 2 * np.pi, freqs.size)), n), fs,
                fade)
    return x * (rms / np.sqrt(np.mean(x**2))) if rms > 0 else np.zeros(n)


def power_band(x: np.ndarray, fs: float, lo: float = 0.01, hi: float = 0.99) -> list[float]:
    """Band ``[f_lo, f_hi]`` (Hz) between the ``lo`` and ``hi`` quantiles of the power of ``x``.

    ``x`` is a 1-D signal sampled at ``fs`` (Hz), its mean removed first; the default holds the
    central 98 % of the power (a ROM's training band). ``[0, 0]`` for a constant signal.
    """
    p = np.abs(np.fft.rfft(x - x.mean())) ** 2
    f = np.fft.rfftfreq(x.size, 1.0 / fs)
    c = np.cumsum(p)
    if c[-1] <= 0:
        return [0.0, 0.0]
    c /= c[-1]
    return [float(f[np.searchsorted(c, lo)]), float(f[min(np.searchsorted(c, hi), f.size - 1)])]
