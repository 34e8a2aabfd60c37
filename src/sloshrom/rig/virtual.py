"""The virtual shaker rig: plays a shaker test on the physics of :mod:`sloshrom.rig.physics`
and records it through a sensor model (anti-alias filters, sampling, noise, decimation).

:class:`VirtualRig` is a sloshing model (:class:`sloshrom.models.SloshingModel`, force rule
``"step"``) with a numba kernel (:class:`sloshrom.models.CompiledKernel`).
"""

from __future__ import annotations

from typing import Any

import numpy as np
from scipy import signal as sps

from sloshrom.config import Tank
from sloshrom.models import ForceRule
from sloshrom.rig.errors import RigError
from sloshrom.rig.limits import RIG_RATE
from sloshrom.rig.params import RigParams, SensorParams
from sloshrom.rig.physics import (
    _P_HEAD,
    _S_CHI,
    _S_HEAD,
    _param_array,
    _simulate_batch,
    _state_size,
    rig_kernel_step,
    rig_step,
)

__all__ = ["RigParams", "SensorParams", "VirtualRig"]


class VirtualRig:
    """The virtual shaker rig (sloshing-model contract at its fine step ``dt``).

    Parameters
    ----------
    tank : Tank
        Tank and liquid (default: the paper tank, 50 % water).
    params : RigParams, optional
        Physics parameters (default: the calibrated ``rig_params.toml``).
    sensors : SensorParams, optional
        Sensor model used by :meth:`measure`.
    seed : int
        Seed of the Faraday-mode initial noise and of the sensor noise.
    dt : float
        Fine integration step, s (default 1e-4).

    Examples
    --------
    >>> from sloshrom.signals import harmonic
    >>> rig = VirtualRig()
    >>> h = harmonic(1 / rig.dt, 12.0, 0.25 * rig.tank.height)
    >>> df = rig.simulate(h.velocity, h.acceleration)
    """

    #: the output force sample k is the average over [t_k, t_k+1] (for energy integrals)
    force_rule: ForceRule = "step"

    def __init__(
        self,
        tank: Tank | None = None,
        params: RigParams | None = None,
        sensors: SensorParams | None = None,
        seed: int = 0,
        dt: float = 1.0 / RIG_RATE,
    ) -> None:
        if not (np.isfinite(dt) and 0 < dt <= 2e-3):
            raise RigError(f"dt must be a positive step in s, at most 2e-3, got {dt!r}")
        self.tank = tank if tank is not None else Tank()
        self.params = params if params is not None else RigParams.default()
        self.sensors = sensors if sensors is not None else SensorParams()
        self.seed = int(seed)
        self.dt = float(dt)
        self._params = _param_array(self.tank, self.params, self.dt)

    # -- contract -------------------------------------------------------------------------
    def init_state(self) -> np.ndarray:
        """State at rest: column attached, gate closed, modes at seeded µm noise."""
        p = self.params
        st = np.zeros(_state_size(p.n_layers, p.n_modes))
        st[_S_CHI] = 1.0
        rng = np.random.default_rng([self.seed, 17])
        ia = _S_HEAD + 3 * p.n_layers
        om = self._params[_P_HEAD::5][: p.n_modes]
        phase = rng.uniform(0, 2 * np.pi, p.n_modes)
        st[ia : ia + p.n_modes] = p.mode_noise * np.cos(phase)
        st[ia + p.n_modes :] = -p.mode_noise * om * np.sin(phase)
        return st

    def step(
        self, state: np.ndarray, velocity: float, acceleration: float
    ) -> tuple[np.ndarray, float]:
        """Pure step: returns ``(new_state, dynamic_force)`` (N); ``state`` is not modified."""
        st = np.array(state, dtype=np.float64, copy=True)
        n_state = _state_size(self.params.n_layers, self.params.n_modes)
        if st.shape != (n_state,):
            raise RigError(f"state must be a 1-D array of {n_state} values (init_state())")
        f = rig_step(st, self._params, float(velocity), float(acceleration), self.dt)
        return st, f

    def simulate(self, velocity: Any, acceleration: Any) -> np.ndarray:
        """Dynamic force (N) for tank velocity (m/s) and acceleration (m/s^2) sampled at 1/dt.

        Arrays of shape ``(..., n)`` (broadcast together); leading axes are independent runs,
        each starting from :meth:`init_state`.
        """
        v = np.asarray(velocity, dtype=np.float64)
        a = np.asarray(acceleration, dtype=np.float64)
        shape = np.broadcast_shapes(v.shape, a.shape)
        if len(shape) == 0:
            raise RigError("velocity and acceleration must have a time axis")
        if not (np.all(np.isfinite(v)) and np.all(np.isfinite(a))):
            raise RigError("velocity and acceleration must be finite")
        v = np.ascontiguousarray(np.broadcast_to(v, shape).reshape(-1, shape[-1]))
        a = np.ascontiguousarray(np.broadcast_to(a, shape).reshape(-1, shape[-1]))
        st0 = np.tile(self.init_state(), (v.shape[0], 1))
        out = _simulate_batch(st0, self._params, v, a, self.dt)
        return out.reshape(shape)

    def kernel(self) -> tuple[Any, np.ndarray, np.ndarray]:
        """``(step_fn, params_array, state_array)`` for use inside other numba loops.

        ``step_fn(state, params, velocity, acceleration) -> dynamic_force`` is ``@njit``, advances
        ``state`` (float64 1-D) in place by one step ``self.dt``.
        """
        return rig_kernel_step, self._params.copy(), self.init_state()

    # -- sensors --------------------------------------------------------------------------
    def measure(self, acceleration: Any) -> dict[str, Any]:
        """Play a test on the rig and return what the sensors record.

        Parameters
        ----------
        acceleration : array_like
            Tank vertical acceleration imposed by the shaker, m/s^2, sampled at 1/dt, 1-D,
            starting and ending at rest.

        Returns
        -------
        dict
            ``fs`` (Hz), ``time`` (s), ``acceleration`` (accelerometer, m/s^2), ``force``
            (load cells, N: ``-(m_l + m_struct) w'' + dF``), ``true_velocity`` (m/s) and
            ``true_dynamic_force`` (N), all at ``sensors.output_fs``. The true signals pass
            through the same (zero-phase) filters as the measured ones, without noise.
        """
        acc = np.asarray(acceleration, dtype=np.float64)
        if acc.ndim != 1 or acc.size < 16:
            raise RigError("acceleration must be a 1-D array of at least 16 samples")
        if not np.all(np.isfinite(acc)):
            raise RigError("acceleration must be finite")
        sp = self.sensors
        fs_fine = 1.0 / self.dt
        if sp.acquisition_fs > fs_fine * (1 + 1e-9):
            raise RigError(
                f"acquisition rate {sp.acquisition_fs} Hz exceeds the rig rate {fs_fine} Hz"
            )
        if (acc.size - 1) * self.dt * sp.output_fs < 40:
            raise RigError(
                f"record too short for the sensor filters: need at least {40 / sp.output_fs} s"
            )
        # velocity by exact trapezoidal integration (motion starts at rest)
        vel = np.concatenate([[0.0], np.cumsum(0.5 * (acc[1:] + acc[:-1]) * self.dt)])
        df = self.simulate(vel, acc)
        m_tot = self.tank.liquid_mass + self.tank.structure_mass
        force = -m_tot * acc + df
        t_fine = np.arange(acc.size) * self.dt
        # analogue anti-alias filter, then sampling at the acquisition rate
        sig = np.stack([acc, force, vel, df])
        sig = _lowpass(sig, fs_fine, sp.acquisition_fs, sp)
        t_acq = np.arange(0.0, t_fine[-1] + 1e-12, 1.0 / sp.acquisition_fs)
        sig = _resample(sig, t_fine, t_acq, fs_fine, sp.acquisition_fs)
        rng = np.random.default_rng([self.seed, 29])
        sig[0] += sp.acceleration_noise * rng.standard_normal(t_acq.size)
        sig[1] += sp.force_noise * rng.standard_normal(t_acq.size)
        # digital decimation to the output rate
        sig = _lowpass(sig, sp.acquisition_fs, sp.output_fs, sp)
        t_out = np.arange(0.0, t_acq[-1] + 1e-12, 1.0 / sp.output_fs)
        sig = _resample(sig, t_acq, t_out, sp.acquisition_fs, sp.output_fs)
        return {
            "fs": float(sp.output_fs),
            "time": t_out,
            "acceleration": sig[0],
            "force": sig[1],
            "true_velocity": sig[2],
            "true_dynamic_force": sig[3],
        }


def _lowpass(x: np.ndarray, fs_in: float, fs_next: float, sp: SensorParams) -> np.ndarray:
    """Zero-phase Butterworth anti-alias filter before sampling at ``fs_next``."""
    if fs_next >= fs_in * (1 - 1e-9):
        return x
    wn = sp.anti_alias_fraction * 0.5 * fs_next / (0.5 * fs_in)
    sos = sps.butter(int(sp.filter_order), wn, output="sos")
    # row by row: the same arithmetic as axis=-1 (bit for bit), with a quarter of the
    # temporaries; growing the process by a few hundred MB at once cost seconds where huge
    # pages are slow to come (sloshrom._memory)
    out = np.empty_like(x)
    for i in range(x.shape[0]):
        out[i] = sps.sosfiltfilt(sos, x[i])
    return out


def _resample(x, t_in, t_out, fs_in, fs_out) -> np.ndarray:
    ratio = fs_in / fs_out
    q = int(round(ratio))
    if abs(ratio - q) < 1e-9 and q >= 1:
        return np.ascontiguousarray(x[..., ::q][..., : t_out.size])
    return np.stack([np.interp(t_out, t_in, row) for row in x])
