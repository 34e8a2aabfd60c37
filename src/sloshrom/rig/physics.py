"""Physics of the virtual rig: the tank modes and the numba step kernel.

The model (see ``docs/rig.md`` for the equations and what it does and does not
reproduce) is written in the tank frame with ``g_eff(t) = g + w''(t)`` (w up positive):

* **Impacting liquid column.** A fraction ``beta`` of the liquid is split into ``n_layers``
  layers of mass ``m_i = beta m_l / N``; each moves in the gap ``[0, G]`` (G = ullage) with
  ``z_i'' = -g_eff + f_c / m_i`` and compressive-only spring-dashpot contacts with floor and
  ceiling (contact frequency ``contact_frequency``, restitution ``restitution`` through
  ``e = exp(-pi zeta / sqrt(1 - zeta^2))``). A layer that lands re-attaches (rigid with the tank)
  once ``g_eff > 0`` and its rebound has started.
* **Rayleigh-Taylor release gate.** A bubble-front fraction ``s`` in [0, 1] grows while
  ``g_eff < 0`` (after a linear growth phase of ``rt_onset`` e-folds at the fastest
  Rayleigh-Taylor growth rate) as ``s' = C_b sqrt(|g_eff| lambda_m) / d`` with
  ``lambda_m = 2 pi sqrt(3 sigma / (rho |g_eff|))`` and relaxes as ``s' = -s / tau_s`` otherwise;
  layers are released from the top as ``s`` passes them (only while ``g_eff < 0``).
* **Coherence loss** above about 4 g (empirical): the column's force is multiplied by
  ``chi = 1 / (1 + (Gamma_lp / Gamma_0)^p)``, ``Gamma_lp`` a low-passed ``(pi/2)|w''|/g``.
* **Faraday modes.** Rectangular-tank surface modes as damped Mathieu oscillators
  ``a'' + 2 zeta_eff omega a' + (omega^2 + kappa w'') a = 0`` (``kappa = k tanh(k d)``), with
  amplitude saturation (``zeta_eff`` grows as ``(A / a_sat)^4``), a deterministic noise floor
  (amplitude never below ``mode_noise``, seeded phases) and extra damping ``zeta_frag`` times the
  detached fraction of the column (fragmented surface; rather than "frozen while detached", made
  gradual so that the wave energy it removes is accounted as a loss).
* **Output** ``dF = -chi sum m_i z_i'' - sum rho S_n (a_n a_n')'`` (N): minus the liquid mass
  times the acceleration of its centre of mass relative to the tank.

Integration: fixed step ``dt`` (default 1e-4 s); exact free flight, implicit-midpoint contacts
with sub-steps split at contact events, implicit-midpoint modes. The scheme is energy consistent:
work done by the tank equals the contact, re-attachment and modal losses plus stored energy
(checked by :func:`sloshrom.rig.energy_audit`). Every parameter is an engineering *estimate*,
calibrated so that the dissipation map has the shape the paper reports
(``benchmarks/calibrate_rig.py``).

The kernel works on flat float64 arrays (parameters and state, layouts below) so that numba
compiles one function for every parameter set; :class:`sloshrom.rig.VirtualRig` builds them.
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np

from sloshrom._jit import njit
from sloshrom.config import ConfigError, G, Tank
from sloshrom.rig.params import RigParams

__all__ = ["faraday_modes", "rig_kernel_step", "rig_step"]


# --------------------------------------------------------------------------------------------
# Faraday modes of a rectangular tank
# --------------------------------------------------------------------------------------------


def faraday_modes(
    tank: Tank, n_modes: int, f_min: float, f_max: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Pick ``n_modes`` rectangular-tank surface modes with natural frequency in [f_min, f_max].

    Modes ``cos(m pi x / l1) cos(n pi y / l2)``: ``k^2 = (m pi/l1)^2 + (n pi/l2)^2``,
    ``omega^2 = k tanh(k d) (g + sigma k^2 / rho)``. The modes are chosen spread evenly in log
    frequency over the band.

    Returns
    -------
    omega : ndarray
        Natural frequencies, rad/s.
    kappa : ndarray
        ``k tanh(k d)``, 1/m (coupling to the tank acceleration).
    area_factor : ndarray
        ``S_n / S`` (1/2 for one-directional modes, 1/4 for two-directional ones).
    """
    if n_modes == 0:
        z = np.zeros(0)
        return z, z.copy(), z.copy()
    d = tank.depth
    cand = []
    for m in range(0, 40):
        for n in range(0, 40):
            if m == 0 and n == 0:
                continue
            k = math.pi * math.hypot(m / tank.length, n / tank.width)
            kap = k * math.tanh(k * d)
            om = math.sqrt(kap * (G + tank.surface_tension * k * k / tank.density))
            f = om / (2 * math.pi)
            if f_min <= f <= f_max:
                cand.append((f, om, kap, 0.5 if (m == 0 or n == 0) else 0.25))
    if len(cand) < n_modes:
        raise ConfigError(
            f"the virtual rig cannot model fill {tank.fill:g} (liquid depth {d:.3g} m): only "
            f"{len(cand)} of the {n_modes} tank surface modes it needs lie in [{f_min:g}, "
            f"{f_max:g}] Hz (the Faraday band its calibration covers)"
        )
    cand.sort()
    freqs = np.array([c[0] for c in cand])
    targets = np.exp(np.linspace(np.log(f_min), np.log(f_max), n_modes))
    chosen: list[int] = []
    for t in targets:
        order = np.argsort(np.abs(np.log(freqs / t)))
        for j in order:
            if int(j) not in chosen:
                chosen.append(int(j))
                break
    chosen.sort()
    sel = [cand[j] for j in chosen]
    return (
        np.array([c[1] for c in sel]),
        np.array([c[2] for c in sel]),
        np.array([c[3] for c in sel]),
    )


# --------------------------------------------------------------------------------------------
# Flat parameter / state layout for the numba kernel
# --------------------------------------------------------------------------------------------
# params: [N, M, gap, depth, m_layer, g, K, C, C_b, tau_s, sigma/rho, Gamma_0, p, tau_G,
#          zeta_frag, a_sat, a_floor, dt, rt_onset, then per mode (omega, kappa, zeta, rhoS_n, M_n)]
_P_N, _P_M, _P_GAP, _P_D, _P_ML, _P_G, _P_K, _P_C, _P_CB, _P_TAUS = range(10)
_P_SIGRHO, _P_G0, _P_POW, _P_TAUG, _P_ZFRAG, _P_ASAT, _P_AFLOOR, _P_DT, _P_RTON = range(10, 19)
_P_HEAD = 19
# state: [s, Gamma_lp, chi_prev, loss_contact, loss_attach, loss_modes, exchange, a_prev, L_rt,
#         z(N), u(N), released(N), a(M), a'(M)]
_S_GATE, _S_GLP, _S_CHI, _S_LC, _S_LA, _S_LM, _S_X, _S_APREV, _S_RT = range(9)
_S_HEAD = 9


def _param_array(tank: Tank, p: RigParams, dt: float) -> np.ndarray:
    om, kap, fac = faraday_modes(tank, p.n_modes, p.mode_f_min, p.mode_f_max)
    m_layer = p.beta * tank.liquid_mass / p.n_layers
    wc = 2 * math.pi * p.contact_frequency
    head = np.zeros(_P_HEAD)
    head[_P_N] = p.n_layers
    head[_P_M] = p.n_modes
    head[_P_GAP] = tank.ullage
    head[_P_D] = tank.depth
    head[_P_ML] = m_layer
    head[_P_G] = G
    head[_P_K] = wc * wc  # per unit mass
    head[_P_C] = 2 * p.contact_damping_ratio * wc  # per unit mass
    head[_P_CB] = p.bubble_rate
    head[_P_TAUS] = p.gate_relaxation
    head[_P_SIGRHO] = tank.surface_tension / tank.density
    head[_P_G0] = p.coherence_gamma
    head[_P_POW] = p.coherence_power
    head[_P_TAUG] = p.coherence_time
    head[_P_ZFRAG] = p.fragment_damping
    head[_P_ASAT] = p.mode_saturation
    head[_P_AFLOOR] = p.mode_noise
    head[_P_DT] = dt
    head[_P_RTON] = p.rt_onset
    rho_s = tank.density * tank.area * fac
    modal_mass = rho_s / np.where(kap > 0, kap, 1.0)  # M_n kappa_n = rho S_n (energy pairing)
    modes = np.stack([om, kap, np.full_like(om, p.mode_damping), rho_s, modal_mass], axis=1)
    return np.concatenate([head, modes.ravel()])


def _state_size(n_layers: int, n_modes: int) -> int:
    return _S_HEAD + 3 * n_layers + 2 * n_modes


# --------------------------------------------------------------------------------------------
# Numba kernel
# --------------------------------------------------------------------------------------------


@njit(inline="always")
def _wall_contact(z, u, alpha, tau, K, C):
    """Layer in contact with a wall at z = 0 (penetration z < 0), unit mass, over at most tau.

    Returns (z, u, used_time, loss). Implicit midpoint for the linear spring-dashpot; if the
    force would be tensile the contact lets go (free flight) and the released spring energy is
    a loss; stops when the layer leaves the wall (z back to 0).
    """
    den = 2.0 + 0.5 * K * tau * tau + C * tau
    um = (2.0 * u + tau * (alpha - K * z)) / den
    zm = z + 0.5 * tau * um
    f = -K * zm - C * um
    if f >= 0.0:
        z1 = z + tau * um
        if z1 <= 0.0:
            return z1, 2.0 * um - u, tau, tau * C * um * um
        # leaves the wall inside the step: find the exit time by secant on z1(t) = 0
        t_lo, z_lo = 0.0, z
        t_hi, z_hi = tau, z1
        t = tau
        for _ in range(30):
            t = t_lo - z_lo * (t_hi - t_lo) / (z_hi - z_lo)
            d2 = 2.0 + 0.5 * K * t * t + C * t
            umt = (2.0 * u + t * (alpha - K * z)) / d2
            zt = z + t * umt
            if abs(zt) < 1e-13:
                break
            if zt < 0.0:
                t_lo, z_lo = t, zt
            else:
                t_hi, z_hi = t, zt
        d2 = 2.0 + 0.5 * K * t * t + C * t
        umt = (2.0 * u + t * (alpha - K * z)) / d2
        return 0.0, 2.0 * umt - u, t, t * C * umt * umt
    # tensile: free flight inside the wall region until z = 0
    t = tau
    z1 = z + u * tau + 0.5 * alpha * tau * tau
    if z1 > 0.0:
        # first root of z + u t + alpha t^2 / 2 = 0 with z < 0
        if abs(alpha) < 1e-12:
            t = -z / u
        else:
            disc = u * u - 2.0 * alpha * z
            if disc < 0.0:
                disc = 0.0
            sq = math.sqrt(disc)
            r1 = (-u + sq) / alpha
            r2 = (-u - sq) / alpha
            t = tau
            if 0.0 <= r1 <= tau:
                t = r1
            if 0.0 <= r2 <= tau and r2 < t:
                t = r2
        z1 = 0.0
    u1 = u + alpha * t
    loss = 0.5 * K * (z * z - z1 * z1)
    return z1, u1, t, loss


@njit(inline="always")
def _flight_time(z, u, alpha, tau, gap):
    """Time of first arrival at z = 0 (moving down) or z = gap (moving up) within tau, or -1."""
    t_hit = -1.0
    # roots of z + u t + alpha t^2 / 2 = target
    for target in (0.0, gap):
        c0 = z - target
        if abs(alpha) < 1e-12:
            if u != 0.0:
                r = -c0 / u
                if 1e-15 < r <= tau and (t_hit < 0.0 or r < t_hit):
                    t_hit = r
            continue
        disc = u * u - 2.0 * alpha * c0
        if disc < 0.0:
            continue
        sq = math.sqrt(disc)
        for r in ((-u + sq) / alpha, (-u - sq) / alpha):
            if 1e-15 < r <= tau:
                vel = u + alpha * r
                ok = (target == 0.0 and vel < 0.0) or (target == gap and vel > 0.0)
                if ok and (t_hit < 0.0 or r < t_hit):
                    t_hit = r
    return t_hit


@njit(inline="always")
def _advance_layer(z, u, alpha, dt, gap, K, C):
    """Advance a released layer by dt; returns (z, u, contact_loss) per unit mass."""
    rem = dt
    loss = 0.0
    for _ in range(12):
        if rem <= 1e-15:
            break
        if z < 0.0 or (z == 0.0 and u < 0.0):
            z, u, used, lo = _wall_contact(z, u, alpha, rem, K, C)
            loss += lo
            rem -= used
        elif z > gap or (z == gap and u > 0.0):
            zc, uc, used, lo = _wall_contact(gap - z, -u, -alpha, rem, K, C)
            z = gap - zc
            u = -uc
            loss += lo
            rem -= used
        else:
            t = _flight_time(z, u, alpha, rem, gap)
            if t < 0.0:
                z = z + u * rem + 0.5 * alpha * rem * rem
                u = u + alpha * rem
                # guard against round-off crossing without an event
                rem = 0.0
            else:
                u_new = u + alpha * t
                z = gap if u_new > 0.0 else 0.0
                u = u_new
                rem -= t
    if rem > 1e-15:  # pragma: no cover - safety: finish as free flight
        z = z + u * rem + 0.5 * alpha * rem * rem
        u = u + alpha * rem
    return z, u, loss


@njit
def rig_step(state, params, velocity, acceleration, dt):
    """Advance the rig ``state`` in place by one step ``dt`` (s); return the dynamic force (N).

    ``velocity`` (m/s) and ``acceleration`` (m/s^2) are the tank's at the start of the step. The
    acceleration held over the step is its mid-step value, extrapolated from this and the
    previous sample (second order: the velocity at the end of the step is then
    ``v + a_mid dt`` to O(dt^3)). The returned force is the step average of
    ``dF = -m_l x (acceleration of the liquid centre of mass relative to the tank)``.
    """
    n = int(params[_P_N])
    m = int(params[_P_M])
    gap = params[_P_GAP]
    depth = params[_P_D]
    m_layer = params[_P_ML]
    g = params[_P_G]
    K = params[_P_K]
    C = params[_P_C]
    # mid-step acceleration (linear extrapolation from the previous sample)
    acceleration = 1.5 * acceleration - 0.5 * state[_S_APREV]
    state[_S_APREV] = 0.5 * (acceleration + state[_S_APREV])  # = the raw sample a_k
    g_eff = g + acceleration

    # coherence: low-passed acceleration level and mass factor chi
    glp = state[_S_GLP]
    target = 0.5 * math.pi * abs(acceleration) / g
    glp += (target - glp) * (1.0 - math.exp(-dt / params[_P_TAUG]))
    state[_S_GLP] = glp
    chi = 1.0 / (1.0 + (glp / params[_P_G0]) ** params[_P_POW])

    # Rayleigh-Taylor gate: linear growth phase (log-amplitude L at the fastest growing
    # capillary-gravity wavelength), then the bubble front s once L passes rt_onset
    s = state[_S_GATE]
    lrt = state[_S_RT]
    if g_eff < 0.0:
        ag = -g_eff
        k_m = math.sqrt(ag / (3.0 * params[_P_SIGRHO]))
        lrt += dt * math.sqrt(2.0 / 3.0 * ag * k_m)
        if lrt >= params[_P_RTON]:
            lam = 2.0 * math.pi / k_m
            s += dt * params[_P_CB] * math.sqrt(ag * lam) / depth
            if s > 1.0:
                s = 1.0
    else:
        s *= math.exp(-dt / params[_P_TAUS])
        # positive gravity restabilises the interface at the same rate (|g_eff| symmetric)
        if lrt > 0.0 and g_eff > 0.0:
            k_m = math.sqrt(g_eff / (3.0 * params[_P_SIGRHO]))
            lrt -= dt * math.sqrt(2.0 / 3.0 * g_eff * k_m)
            if lrt < 0.0:
                lrt = 0.0
    state[_S_GATE] = s
    state[_S_RT] = lrt

    iz = _S_HEAD
    iu = iz + n
    ir = iu + n
    alpha = -g_eff
    du_sum = 0.0
    e_col = 0.0  # stored column energy E' (per unit mass) at the step start, for chi exchange
    loss_c = 0.0
    loss_a = 0.0
    n_detached = 0
    for i in range(n):
        z = state[iz + i]
        u = state[iu + i]
        pen = 0.0
        if z < 0.0:
            pen = z
        elif z > gap:
            pen = z - gap
        e_col += 0.5 * u * u + u * velocity + g * z + 0.5 * K * pen * pen
        rel = state[ir + i]
        if rel == 0.0:
            # layer i counted from the bottom; released from the top as s passes it
            if g_eff < 0.0 and s >= (n - i - 0.5) / n:
                rel = 1.0
                state[ir + i] = 1.0
            else:
                continue
        z1, u1, lo = _advance_layer(z, u, alpha, dt, gap, K, C)
        loss_c += lo
        if g_eff > 0.0 and z1 <= 0.0 and u1 >= 0.0:
            # landed and rebounding under positive gravity: re-attach (rest of energy lost)
            loss_a += 0.5 * u1 * u1 + 0.5 * K * z1 * z1 + g * z1
            z1 = 0.0
            u1 = 0.0
            state[ir + i] = 0.0
        else:
            n_detached += 1
        du_sum += u1 - u
        state[iz + i] = z1
        state[iu + i] = u1
    chi_prev = state[_S_CHI]
    state[_S_CHI] = chi
    state[_S_X] += (chi_prev - chi) * m_layer * e_col
    state[_S_LC] += chi * m_layer * loss_c
    state[_S_LA] += chi * m_layer * loss_a
    force = -chi * m_layer * du_sum / dt

    # Faraday modes (implicit midpoint, coefficients frozen over the step)
    ia = ir + n
    iad = ia + m
    a_floor = params[_P_AFLOOR]
    a_sat = params[_P_ASAT]
    # fragmented surface: extra damping in proportion to the detached part of the column
    zfrag = params[_P_ZFRAG] * n_detached / n
    loss_m = 0.0
    for j in range(m):
        base = _P_HEAD + 5 * j
        om = params[base]
        kap = params[base + 1]
        zeta = params[base + 2]
        rho_s = params[base + 3]
        mm = params[base + 4]
        a = state[ia + j]
        ad = state[iad + j]
        amp2 = a * a + (ad / om) ** 2
        if a_floor > 0.0 and amp2 < a_floor * a_floor:
            # noise floor: the surface is never perfectly still (deterministic, seeded phase)
            sc = a_floor / math.sqrt(amp2) if amp2 > 0.0 else 0.0
            if sc == 0.0:
                a = a_floor
            else:
                a *= sc
                ad *= sc
        r = amp2 / (a_sat * a_sat)
        ceff = 2.0 * om * (zeta * (1.0 + r * r) + zfrag)
        keff = om * om + kap * acceleration
        # ad_m (1 + dt ceff / 2 + dt^2 keff / 4) = ad - dt keff a / 2
        adm = (ad - 0.5 * dt * keff * a) / (1.0 + 0.5 * dt * ceff + 0.25 * dt * dt * keff)
        a1 = a + dt * adm
        ad1 = 2.0 * adm - ad
        loss_m += dt * ceff * mm * adm * adm
        force -= rho_s * (a1 * ad1 - a * ad) / dt
        state[ia + j] = a1
        state[iad + j] = ad1
    state[_S_LM] += loss_m
    return force


@njit(parallel=True)
def _simulate_batch(states0, params, velocity, acceleration, dt):
    n_runs, n = velocity.shape
    out = np.empty((n_runs, n))
    for r in nb.prange(n_runs):
        st = states0[r].copy()
        for k in range(n):
            out[r, k] = rig_step(st, params, velocity[r, k], acceleration[r, k], dt)
    return out


@njit
def _simulate_audit(state, params, velocity, acceleration, dt):
    """Single run returning the force and the loss accumulators after each step."""
    n = velocity.shape[0]
    out = np.empty(n)
    acc = np.empty((n, 4))
    for k in range(n):
        out[k] = rig_step(state, params, velocity[k], acceleration[k], dt)
        acc[k, 0] = state[_S_LC]
        acc[k, 1] = state[_S_LA]
        acc[k, 2] = state[_S_LM]
        acc[k, 3] = state[_S_X]
    return out, acc


@njit
def rig_kernel_step(state, params, velocity, acceleration):
    """:func:`rig_step` with the step ``dt`` read from the parameter array (kernel contract)."""
    return rig_step(state, params, velocity, acceleration, params[_P_DT])
