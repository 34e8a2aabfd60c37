"""The neural state-space ROM's estimator, :class:`NSS`: the scikit-learn shell around a
:class:`~sloshrom.rom.nss.network.StateSpaceNetwork`.

The constructor stores the hyperparameters (those of the size left at None are sized by the
training record: :func:`sloshrom.rom.nss.entry.nss_size`), :meth:`NSS.fit` checks them, trains
by multiple shooting (:func:`sloshrom.rom.nss.training.fit_statespace`) and keeps the network
as ``model_``; the rest (prediction, the step contract, the pytree, saving) is the shared
:class:`sloshrom.rom.base.Estimator`'s.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np

from sloshrom._x64 import float64
from sloshrom.rom.base import Estimator, checked_history, checked_records, record_envelope
from sloshrom.rom.errors import ROMError
from sloshrom.rom.network import MinMaxScaler
from sloshrom.rom.nss.entry import NSS_CLASS, NSS_PARAM_NAMES
from sloshrom.rom.nss.network import StateSpaceNetwork, StateSpaceSpec
from sloshrom.rom.nss.training import fit_statespace
from sloshrom.rom.shooting import ShootingOptions
from sloshrom.signals import power_band

__all__ = ["NSS"]

#: The hyperparameters by default: the registry entry's, the one place they are written
_NSS = NSS_CLASS.defaults()


@jax.tree_util.register_pytree_node_class
class NSS(Estimator):
    """Neural state-space ROM: ``x_{k+1} = f(x_k, u_k)``, ``y_k = h(x_k, u_k)``, identified by
    multiple shooting (:mod:`sloshrom.rom.nss.network`).

    Unlike the NFIR, whose force is a function of the last ``delays`` inputs only, the model
    carries a state (where the liquid is, how fast it moves), so it can remember an impact or a
    flight phase for as long as it lasts. It starts from rest in the coupled beam and the maps;
    its encoder, which estimates the state from measured history, starts the training's
    sub-sequences, :meth:`predict` given ``history`` and the validation run of a fit given
    ``validation_history`` (a record that does not start at rest), and is available as
    :meth:`sloshrom.rom.nss.network.StateSpaceNetwork.encode`.

    It identifies any single-input single-output system, not only a tank: the input and output
    may be any signals in any units (``names``, ``units``); the passive recipe's loss terms
    alone are written for a velocity in m/s and a force in N.

    The size (``n_states``, ``neurons``, ``window``) and the ``horizon`` left at None are
    **sized by the training record** (:meth:`sloshrom.rom.registry.ModelClass.size`, the rule
    :func:`sloshrom.rom.nss.entry.nss_size`): from 100,000 samples on they are the defaults
    below, exactly (the sloshing records'); on a short record the network is smaller (on
    1,000 samples and fewer: 4 states, 16 neurons, window 10; docs/rom.md, "Short records") and the
    horizon is shortened only where the record is too short for it. A value given is kept; a
    size given with more than :data:`~sloshrom.rom.registry.OVERSIZE` times the rule's
    parameters is warned of (:class:`~sloshrom.rom.errors.ModelSizeWarning`). After
    :meth:`fit`, ``sized_`` holds the values the rule chose, ``sizing_`` a line saying them
    (None when none was left to it), and :meth:`effective_params` (what a model file records)
    every value.

    Parameters
    ----------
    n_states : int or None
        Dimension of the state (None: sized; 8 on a long record).
    neurons : int or None
        Hidden tanh units of each of the state map, the output map and the encoder (None:
        sized; 64 on a long record).
    window : int or None
        Past samples of input and output the encoder reads (None: sized; 50 on a long record).
    horizon : int or None
        Samples simulated from each encoded start in training (and the length of the passivity
        probes, which must hold a ramp and two periods of the band's lowest frequency) (None:
        200, shortened on a record too short for it).
    batch : int
        Sub-sequences per Adam step.
    max_epochs : int
        Epochs of ``steps_per_epoch`` Adam steps at most (early stopping on the validation
        free run, patience 6 epochs).
    steps_per_epoch : int
        Adam steps between validations; the learning rate's cosine decay spans
        ``max_epochs * steps_per_epoch`` steps.
    learning_rate : float
        Initial Adam step (cosine decay to 5 % of it over ``max_epochs``).
    seed : int
        Seeds the initialisation and the draws of sub-sequences (>= 0).
    units, names
        As :class:`NFIR`: any signals (the loss terms need a velocity in m/s and a force
        in N).
    amplitude_weighting, passivity, cycle_energy : float
        The passive recipe's loss terms, as :class:`NFIR` (the energy term is the error of the
        energy each sub-sequence exchanges with the liquid). 0 = off.
    feedthrough : {"yes", "no"}
        ``"no"``: strictly proper, the force ``y_k = H(x_k)`` from the state alone (no direct
        feed-through of the velocity: no algebraic loop when coupled, and a co-simulation
        master that reads outputs before it sets inputs gets the same force).
    velocity_offset : float
        Galilean augmentation, m/s (0 = off): each training sub-sequence's velocity is shifted
        by a uniform draw in ``[-velocity_offset, velocity_offset]`` and its force kept
        (:class:`~sloshrom.rom.shooting.ShootingOptions`).
    weight_decay : float
        AdamW's decoupled weight decay per unit learning rate (0 = plain Adam):
        :attr:`~sloshrom.rom.shooting.ShootingOptions.weight_decay`.

    Parameters are checked by :meth:`fit` (and by :func:`load_model`), not by the constructor.
    """

    model_class = NSS_CLASS

    def __init__(  # the defaults: its registry entry's (a size: None, the rule's)
        self,
        n_states: int | None = None,
        neurons: int | None = None,
        window: int | None = None,
        horizon: int | None = None,
        batch: int = _NSS["batch"],
        max_epochs: int = _NSS["max_epochs"],
        steps_per_epoch: int = _NSS["steps_per_epoch"],
        learning_rate: float = _NSS["learning_rate"],
        seed: int = _NSS["seed"],
        units: Sequence[str] = ("m/s", "N"),
        names: Sequence[str] = ("velocity", "dynamic_force"),
        amplitude_weighting: float = _NSS["amplitude_weighting"],
        passivity: float = _NSS["passivity"],
        cycle_energy: float = _NSS["cycle_energy"],
        feedthrough: str = _NSS["feedthrough"],
        velocity_offset: float = _NSS["velocity_offset"],
        weight_decay: float = _NSS["weight_decay"],
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
        self.feedthrough = feedthrough
        self.velocity_offset = velocity_offset
        self.weight_decay = weight_decay

    def _sizes(self, n_samples: int | None = None) -> dict[str, int]:
        """The values of the hyperparameters the rule may size (the registry's
        ``sized_by_record``): the user's, checked, and the others chosen by the rule for a
        training record of ``n_samples`` samples (None: their defaults, a long record's)."""
        h = self.model_class.check(self._sizes_given(), n_samples=n_samples, training=False)
        return {k: int(h[k]) for k in self.model_class.sized_by_record}

    def _sizes_given(self) -> dict[str, object]:
        return {k: getattr(self, k) for k in self.model_class.sized_by_record}

    def _chosen_sizes(self) -> dict[str, int]:
        sizes = {**self._sizes(), **getattr(self, "sized_", {})}
        if hasattr(self, "model_"):
            # the network's own size: also for an estimator rebuilt from pytree leaves, which
            # has no sized_
            sp = self.model_.spec
            sizes.update(n_states=sp.n_states, neurons=sp.neurons, window=sp.window)
        # the hyperparameters still left to the record (a value set since is the user's)
        return {k: v for k, v in sizes.items() if getattr(self, k) is None}

    def _check_hyperparameters(self, n_samples: int | None = None) -> StateSpaceSpec:
        # n_samples: the architecture of a training record of that length (its size rule's)
        return self._spec(self.model_class.check(self._arguments(), n_samples=n_samples,
                                                 input=self.input, training=False))

    @staticmethod
    def _spec(h: dict[str, Any]) -> StateSpaceSpec:
        return StateSpaceSpec(h["n_states"], h["neurons"], h["window"],
                              proper=h["feedthrough"] == "no")

    @property
    def theta_(self) -> jnp.ndarray:
        """The parameters packed into one vector (:data:`NSS_PARAM_NAMES` order)."""
        self._check_fitted()
        return jnp.concatenate([jnp.ravel(jnp.asarray(self.params_[k]))
                                for k in NSS_PARAM_NAMES])

    def _model(self, params: Any, scaler: MinMaxScaler, spec: Any,
               fs: float) -> StateSpaceNetwork:
        return StateSpaceNetwork(dict(params), scaler, spec, self.input, fs)

    @float64
    def fit(
        self,
        u: Any,
        y: Any,
        fs: float,
        validation: tuple[Any, Any] | None = None,
        callback: Callable[..., Any] | None = None,
        *,
        fill: float | None = None,
        validation_history: int = 0,
    ) -> NSS:
        """Identify the state-space ROM from an input/output record.

        Parameters
        ----------
        u : array_like, shape (n,)
            Input (the tank vertical velocity, m/s, or any signal), sampled at ``fs``.
        y : array_like, shape (n,)
            Output (the dynamic sloshing force, N, or any signal).
        fs : float
            Sample rate, Hz.
        validation : (u_val, y_val), optional
            Validation record at the same rate: its run from rest (or from its first
            ``validation_history`` samples) decides the early stopping and the parameters
            returned.
        callback : callable, optional
            ``callback(epoch, info)`` after every epoch (``train_mse``, ``val_mse`` in N^2,
            ``val_objective``, ``seconds``); returning True stops training.
        fill : float, optional
            Fill level d/h (-) of the training record, as :meth:`NFIR.fit`.
        validation_history : int
            The validation record's first samples taken as measured history (at least ``window``,
            the encoder's: the run starts from the state it gives): the validation run starts from
            them instead of from rest and is scored after them, for a validation record that does
            not start at rest. 0 (default): from rest, every sample scored.

        Returns
        -------
        self

        Raises
        ------
        ROMError
            A hyperparameter out of its domain, a bad record (shape, NaN, constant, too short)
            or sample rate.
        """
        # the class's rules (the fewest samples among them) and the sizes left to the record
        n_samples = int(np.size(u))
        h = self.check_training(n_samples)
        spec = self._spec(h)
        mc = self.model_class
        sz = {k: int(h[k]) for k in mc.sized_by_record}
        u, y, validation, fill = checked_records(u, y, fs, validation, fill, 0, spec.window)
        hv = checked_history(validation_history, validation, spec.window, mc.class_name)
        if (self.passivity > 0 or self.cycle_energy > 0) and not (u.min() < 0.0 < u.max()):
            raise ROMError(f"the input {self.names[0]!r} does not oscillate about rest: "
                           "passivity and cycle_energy judge the energy of a motion about rest")
        chosen = {k: sz[k] for k in mc.sized_by_record if getattr(self, k) is None}
        scaler = MinMaxScaler.fit(u, y)
        band = power_band(u, fs)
        probe_band = power_band(u, fs, 0.001, 0.999)
        options = ShootingOptions(
            horizon=sz["horizon"], batch=int(self.batch), max_epochs=int(self.max_epochs),
            steps_per_epoch=int(self.steps_per_epoch), learning_rate=float(self.learning_rate),
            amplitude_weighting=float(self.amplitude_weighting),
            passivity=float(self.passivity), cycle_energy=float(self.cycle_energy),
            frequency_band=(probe_band[0], probe_band[1]),
            velocity_offset=float(self.velocity_offset),
            weight_decay=float(self.weight_decay))
        params, history = fit_statespace(spec, u, y, float(fs), scaler, validation, options,
                                         seed=int(self.seed), callback=callback,
                                         validation_history=hv)
        self.sized_ = chosen
        self.sizing_ = mc.size_note(sz, n_samples, chosen) if chosen else None
        self.model_ = StateSpaceNetwork(params, scaler, spec, self.input, float(fs))
        self.envelope_ = record_envelope(u, fs, scaler, band, self.input, fill)
        self.history_ = history
        return self
