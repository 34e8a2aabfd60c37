"""The grey-box ROM's estimator, :class:`GreyBox`: the scikit-learn shell around a
:class:`~sloshrom.rom.grey.network.GreyBoxNetwork`.

The constructor stores the hyperparameters; :meth:`GreyBox.fit` checks them (the class's
rules, :meth:`sloshrom.rom.registry.ModelClass.check`), identifies the column
(:func:`sloshrom.rom.grey.training.fit_physics`), trains the network on it
(:func:`sloshrom.rom.grey.training.fit_greybox`) and keeps the model as ``model_``; the rest
(prediction, the step contract, the pytree, saving) is the shared
:class:`sloshrom.rom.base.Estimator`'s.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Mapping, Sequence

import jax
import numpy as np
from numpy.typing import ArrayLike

from sloshrom._x64 import float64
from sloshrom.config import Tank
from sloshrom.rom.base import Estimator, checked_records, record_envelope
from sloshrom.rom.errors import ROMError
from sloshrom.rom.grey.entry import GREY_CLASS
from sloshrom.rom.grey.network import GreyBoxNetwork, GreySpec
from sloshrom.rom.grey.training import fit_greybox, fit_physics
from sloshrom.rom.network import MinMaxScaler
from sloshrom.rom.shooting import ShootingOptions
from sloshrom.signals import power_band

__all__ = ["GreyBox"]

#: The hyperparameters by default: the registry entry's, the one place they are written
_G = GREY_CLASS.defaults()


@jax.tree_util.register_pytree_node_class
class GreyBox(Estimator):
    """Grey-box ROM: an impacting liquid column behind a release gate, and a neural
    state-space network that corrects it (:mod:`sloshrom.rom.grey.network`).

    The column is physics: the liquid that takes part in the impacts as ``n_balls`` balls
    released one after the other by a Rayleigh-Taylor gate while the tank pulls the liquid
    down faster than gravity, flying through the ullage and landing on soft contacts
    (:mod:`sloshrom.rom.grey.physics`); its seven parameters (mass, contact, gap, gate,
    coherence) are identified from the record by differential evolution, scaled by the tank's
    ``liquid_mass`` and ``ullage``. It times its impacts by the motion, which a network of
    the velocity alone cannot learn (it learns the force's conditional mean). The
    network is an NSS that reads the column's force and state; it starts at zero output, so the
    model starts as the physics, and corrects what the column does not hold.

    Strictly proper (the force at sample k reads the state only), from rest in the coupled
    beam and the maps; its network's encoder starts the training's sub-sequences and
    :meth:`predict` given ``history``.

    Parameters
    ----------
    n_states, neurons, window, horizon, batch, max_epochs, steps_per_epoch, learning_rate
        The network and its training, as :class:`sloshrom.rom.NSS`'s; ``max_epochs = 0``
        keeps the column alone.
    seed : int
        Seeds the column's search and the network's initialisation and draws (>= 0).
    units, names
        The record's signals: a velocity in m/s in, a force in N out (the column is a physical
        model of a tank's liquid: other signals are refused).
    amplitude_weighting, passivity, cycle_energy : float
        The passive recipe's loss terms of the network's training, as :class:`NSS`'s.
    velocity_offset : float
        Galilean augmentation of the network's training, m/s (the column reads the
        acceleration and needs none).
    weight_decay : float
        AdamW's decoupled weight decay per unit learning rate (0 = plain Adam).
    precision : {"float64", "float32"}
        The network's Adam steps: float64 (the default) makes a fit the same on every CPU to
        its members' spread; float32 (the NSS's) is faster and moves with the CPU's last bits.
    n_balls : int
        Balls of the column.
    n_substeps : int
        Sub-steps of each sample interval (a contact lasts a few ms).
    n_past : int
        Sample intervals the column's output filter reads at and before the output sample.
    liquid_mass, ullage : float
        The tank's liquid mass (kg) and ullage (m): the scales of the column's search; 0 (the
        default): the paper's tank at the ``fill`` given to :meth:`fit` (0.5 if none).
    spectral : float
        Weight of the timing-free spectral term of the column's search (0: point-wise only).
    physics_generations, physics_population, physics_windows : int
        The column's differential evolution: generations, population per variable, and the
        2 s windows of the record it scores.

    Attributes
    ----------
    model_ : GreyBoxNetwork
        The fitted model.
    physics_ : dict
        The column's identified parameters (SI units) and the search's figures.
    envelope_, history_
        As every ROM's.
    """

    model_class = GREY_CLASS

    def __init__(  # the defaults: its registry entry's
        self,
        n_states: int = _G["n_states"],
        neurons: int = _G["neurons"],
        window: int = _G["window"],
        horizon: int = _G["horizon"],
        batch: int = _G["batch"],
        max_epochs: int = _G["max_epochs"],
        steps_per_epoch: int = _G["steps_per_epoch"],
        learning_rate: float = _G["learning_rate"],
        seed: int = _G["seed"],
        units: Sequence[str] = ("m/s", "N"),
        names: Sequence[str] = ("velocity", "dynamic_force"),
        amplitude_weighting: float = _G["amplitude_weighting"],
        passivity: float = _G["passivity"],
        cycle_energy: float = _G["cycle_energy"],
        velocity_offset: float = _G["velocity_offset"],
        weight_decay: float = _G["weight_decay"],
        precision: str = _G["precision"],
        n_balls: int = _G["n_balls"],
        n_substeps: int = _G["n_substeps"],
        n_past: int = _G["n_past"],
        liquid_mass: float = _G["liquid_mass"],
        ullage: float = _G["ullage"],
        spectral: float = _G["spectral"],
        physics_generations: int = _G["physics_generations"],
        physics_population: int = _G["physics_population"],
        physics_windows: int = _G["physics_windows"],
    ) -> None:
        self.n_states = n_states
        self.neurons = neurons
        self.window = window
        self.horizon = horizon
        self.batch = batch
        self.max_epochs = max_epochs
        self.steps_per_epoch = steps_per_epoch
        self.learning_rate = learning_rate
        self.seed = seed
        self.units = units
        self.names = names
        self.amplitude_weighting = amplitude_weighting
        self.passivity = passivity
        self.cycle_energy = cycle_energy
        self.velocity_offset = velocity_offset
        self.weight_decay = weight_decay
        self.precision = precision
        self.n_balls = n_balls
        self.n_substeps = n_substeps
        self.n_past = n_past
        self.liquid_mass = liquid_mass
        self.ullage = ullage
        self.spectral = spectral
        self.physics_generations = physics_generations
        self.physics_population = physics_population
        self.physics_windows = physics_windows

    def _check_hyperparameters(self) -> GreySpec:
        return self._spec(self.check_training())

    @staticmethod
    def _spec(h: Mapping[str, int | float | str]) -> GreySpec:
        return GreySpec(int(h["n_states"]), int(h["neurons"]), int(h["window"]),
                        int(h["n_balls"]), int(h["n_substeps"]), int(h["n_past"]))

    def _model(self, params: Mapping[str, np.ndarray], scaler: MinMaxScaler, spec: GreySpec,
               fs: float) -> GreyBoxNetwork:
        return GreyBoxNetwork(dict(params), scaler, spec, self.input, fs)

    @property
    def physics_(self) -> dict[str, float]:
        """The column's identified physical parameters by name, SI units."""
        self._check_fitted()
        return self.model_.physics()

    def _tank_scales(self, fill: float | None) -> tuple[float, float]:
        """The liquid mass (kg) and ullage (m) the column's search is scaled by."""
        m, g = float(self.liquid_mass), float(self.ullage)
        if m > 0 and g > 0:
            return m, g
        tank = Tank(fill=0.5 if fill is None else float(fill))
        return (m if m > 0 else tank.liquid_mass), (g if g > 0 else tank.ullage)

    @float64
    def fit(
        self,
        u: ArrayLike,
        y: ArrayLike,
        fs: float,
        validation: tuple[ArrayLike, ArrayLike] | None = None,
        callback: Callable[[int, dict[str, float]], bool | None] | None = None,
        *,
        fill: float | None = None,
        validation_history: int = 0,
    ) -> GreyBox:
        """Identify the grey-box ROM from a shaker record: the column, then the network.

        Parameters
        ----------
        u : array_like, shape (n,)
            Tank vertical velocity, m/s, sampled at ``fs``, starting at rest.
        y : array_like, shape (n,)
            Dynamic sloshing force, N.
        fs : float
            Sample rate, Hz.
        validation : (u_val, y_val), optional
            Validation record at the same rate: the network's early stopping (its run from
            rest decides the parameters returned).
        callback : callable, optional
            ``callback(epoch, info)`` after every epoch of the network; True stops it.
        fill : float, optional
            Fill level d/h (-) of the record: the model records it, and with ``liquid_mass``
            or ``ullage`` at 0 it sizes the paper's tank they are taken from.
        validation_history : int
            Must be 0: the column starts from rest, and so does the validation run.

        Returns
        -------
        self

        Raises
        ------
        ROMError
            A hyperparameter out of its domain, signals other than a velocity in m/s and a
            force in N, a bad record (shape, NaN, constant, too short) or sample rate.
        """
        n_samples = int(np.size(u))
        h = self.check_training(n_samples)
        spec = self._spec(h)
        if tuple(str(x) for x in self.units) != ("m/s", "N"):
            raise ROMError("a grey box is a physical model of a tank's liquid: it maps the "
                           "tank velocity in m/s to the dynamic force in N, got units "
                           f"{tuple(self.units)!r} (NSS identifies any signals)")
        if validation_history:
            raise ROMError("a grey box starts from rest: validation_history must be 0")
        u, y, validation, fill = checked_records(u, y, fs, validation, fill, 0, spec.window)
        if (self.passivity > 0 or self.cycle_energy > 0) and not (u.min() < 0.0 < u.max()):
            raise ROMError(f"the input {self.names[0]!r} does not oscillate about rest: "
                           "passivity and cycle_energy judge the energy of a motion about rest")
        mass, ullage = self._tank_scales(fill)
        t0 = time.perf_counter()
        physics, taps, phys_history = fit_physics(
            u, y, float(fs), spec, mass, ullage, spectral=float(self.spectral),
            generations=int(self.physics_generations),
            population=int(self.physics_population), windows=int(self.physics_windows),
            seed=int(self.seed))
        scaler = MinMaxScaler.fit(u, y)
        band = power_band(u, fs)
        probe_band = power_band(u, fs, 0.001, 0.999)
        options = ShootingOptions(
            horizon=int(h["horizon"]), batch=int(self.batch), max_epochs=int(self.max_epochs),
            steps_per_epoch=int(self.steps_per_epoch), learning_rate=float(self.learning_rate),
            amplitude_weighting=float(self.amplitude_weighting),
            passivity=float(self.passivity), cycle_energy=float(self.cycle_energy),
            frequency_band=(probe_band[0], probe_band[1]),
            velocity_offset=float(self.velocity_offset),
            weight_decay=float(self.weight_decay))
        params, history = fit_greybox(spec, u, y, float(fs), scaler, physics, taps, validation,
                                      options, seed=int(self.seed), callback=callback,
                                      precision=str(h["precision"]))
        history["search"] = {**phys_history, "liquid_mass": mass, "ullage": ullage}
        history["train_seconds"] = time.perf_counter() - t0
        self.model_ = GreyBoxNetwork(dict(params), scaler, spec, self.input, float(fs))
        self.envelope_ = record_envelope(u, fs, scaler, band, self.input, fill)
        self.history_ = history
        return self
