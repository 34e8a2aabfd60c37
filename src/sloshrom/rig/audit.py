"""Energy audit of the virtual rig: the work done by the tank against the losses it counts.

The integrator is energy consistent (exact free flight, implicit-midpoint contacts and modes):
the work done by the tank equals the contact, re-attachment and modal losses plus the exchange
with the coherent column and the stored modal energy, to round-off. :func:`energy_audit`
checks it on one run.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from sloshrom.rig.errors import RigError
from sloshrom.rig.physics import _P_HEAD, _S_HEAD, _simulate_audit
from sloshrom.rig.virtual import VirtualRig

__all__ = ["energy_audit"]


def energy_audit(rig: VirtualRig, velocity: Any, acceleration: Any) -> dict[str, float]:
    """Work done by the tank on the liquid against the model's internal losses (one run).

    The motion must start and end at rest with the column re-attached for the balance to close.

    Returns
    -------
    dict
        ``work`` = -sum dF_k (v_k + v_{k+1})/2 dt (J, from the output force and the input
        motion; the last interval uses v + a dt),
        ``contact_loss``, ``attach_loss``, ``modal_loss`` (J, accumulated inside the model),
        ``exchange`` (J, energy carried by mass leaving/joining the coherent column),
        ``stored`` (J, modal energy left at the end), ``residual`` = work - losses - exchange -
        stored, ``relative_residual`` = residual / work, and ``dynamic_force`` (N, array).
    """
    v = np.ascontiguousarray(np.asarray(velocity, dtype=np.float64))
    a = np.ascontiguousarray(np.asarray(acceleration, dtype=np.float64))
    if v.ndim != 1 or v.shape != a.shape:
        raise RigError("velocity and acceleration must be 1-D arrays of equal length")
    st = rig.init_state()
    st0 = st.copy()
    f, acc = _simulate_audit(st, rig._params, v, a, rig.dt)
    v_next = np.append(v[1:], v[-1] + a[-1] * rig.dt)
    work = float(-np.sum(f * 0.5 * (v + v_next)) * rig.dt)
    p = rig.params
    ia = _S_HEAD + 3 * p.n_layers
    om = rig._params[_P_HEAD::5][: p.n_modes]
    mm = rig._params[_P_HEAD + 4 :: 5][: p.n_modes]

    def e_modes(s):
        aa = s[ia : ia + p.n_modes]
        ad = s[ia + p.n_modes :]
        return float(np.sum(0.5 * mm * (ad**2 + om**2 * aa**2)))

    stored = e_modes(st) - e_modes(st0)
    lc, la, lm, x = (float(val) for val in acc[-1])
    residual = work - lc - la - lm - x - stored
    return {
        "work": work,
        "contact_loss": lc,
        "attach_loss": la,
        "modal_loss": lm,
        "exchange": x,
        "stored": stored,
        "residual": residual,
        "relative_residual": residual / work if work != 0 else float("nan"),
        "dynamic_force": f,
        "released_at_end": float(np.sum(st[_S_HEAD + 2 * p.n_layers : ia])),
    }
