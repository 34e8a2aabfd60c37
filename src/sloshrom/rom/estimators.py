"""Time-delay neural-network reduced-order models: NFIR and NOE with a normalized RBF layer.

Paper section 3 and Appendix A. Both models map a scalar input history (tank vertical velocity,
m/s) to a scalar output (dynamic sloshing force, N), but work for any single-input single-output
record. The network equations and the pure functions that evaluate them are in
:mod:`sloshrom.rom.network`; the trainers in :mod:`sloshrom.rom.training`.

Model and estimator are apart. The fitted *model* is a :class:`~sloshrom.rom.network.Network`:
an immutable JAX pytree with the parameters, the scaler, the architecture, the input signal and
the time step, whose pure ``step``/``free_run`` implement the sloshing-model contract. The
*estimators* here are thin shells in the scikit-learn style: the constructor only stores its
arguments, :meth:`~_Estimator.fit` validates them once, trains and keeps the network as ``model_``,
:meth:`~_Estimator.get_params`/:meth:`~_Estimator.set_params` cover every constructor argument, and
:meth:`~_Estimator.predict` does not change the model. Fitted attributes end in ``_`` (``model_``,
``envelope_``, ``history_``; ``params_``, ``scaler_``, ``fs_`` read the network).

A fitted estimator is also a JAX pytree (:func:`sloshrom.models.is_jax_model`) whose child is
its network: the parameters and scaler bounds are the leaves, the hyperparameters and sample
rate the static part. Passed as an argument into a jitted function, its :meth:`step` is traced with
the weights as data: one compilation serves every model of the same hyperparameters and shapes,
and ``jax.grad`` with respect to the model gives the gradient of each parameter (a model-shaped
pytree). The training record (``envelope_``, ``history_``) is not part of the pytree: a model
rebuilt from leaves (inside ``jit``, a gradient) has the network and scaler only.

The normalized RBF output is bounded by ``max |c_j| + |c_0|``, so an NOE cannot run off to
infinity; an "unstable" NOE shows up as an output far beyond the training range (limit cycles,
saturation), which :meth:`NOE.predict` detects against ``unstable_bound`` and raises.

Initial conditions: every delay line starts at rest (zero physical input and output).

Precision: fitting, prediction and saving run in float64 (``jax.enable_x64`` around the call,
:mod:`sloshrom._x64`) without changing the process's JAX configuration; :meth:`step` and
:meth:`init_state` are JAX functions that follow the caller's configuration.
"""

from __future__ import annotations

import warnings
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np

from sloshrom._x64 import float64
from sloshrom.rom import training
from sloshrom.rom.base import Estimator, checked_history, checked_records, record_envelope
from sloshrom.rom.bouncing import BouncingBall, is_ball_file
from sloshrom.rom.ensemble import Ensemble
from sloshrom.rom.errors import (
    EnvelopeWarning,
    FillRangeError,
    ModelSizeWarning,
    NotFittedError,
    ROMError,
    UnstableModelError,
)
from sloshrom.rom.family import FillFamily, at_fill, read_family
from sloshrom.rom.modelfile import (
    FORMAT_VERSION,
    ModelFile,
    ModelFileError,
    check_file_limits,
    read_model_file,
)
from sloshrom.rom.network import (
    MinMaxScaler,
    Network,
    NetworkSpec,
    NFIRNetwork,
    NOENetwork,
    check_delays,
    hidden_activations,
    n_params,
    noe_simulate,
    pack,
    rbf_apply,
    unpack,
)
from sloshrom.rom.registry import (
    LOSS_TERMS,
    NFIR_CLASS,
    NOE_CLASS,
    NSS_CLASS,
    check_hyperparameters,
    model_class,
)
from sloshrom.rom.shooting import ShootingOptions
from sloshrom.rom.statespace import (
    NSS_PARAM_NAMES,
    StateSpaceNetwork,
    StateSpaceSpec,
    fit_statespace,
)
from sloshrom.signals import power_band

__all__ = [
    "FORMAT_VERSION",
    "NFIR",
    "NOE",
    "NSS",
    "BouncingBall",
    "Ensemble",
    "EnvelopeWarning",
    "FillFamily",
    "FillRangeError",
    "MinMaxScaler",
    "ModelFileError",
    "ModelSizeWarning",
    "Network",
    "NotFittedError",
    "ROMError",
    "UnstableModelError",
    "hidden_activations",
    "load_model",
    "n_params",
    "noe_simulate",
    "pack",
    "rbf_apply",
    "unpack",
]



class _Estimator(Estimator):
    """Shared code of the network estimators NFIR, NOE and NSS (the loss terms, the
    hyperparameters of the time-delay networks)."""

    #: fed-back past outputs: none for the NFIR (an NOE constructor parameter)
    out_delays: int = 0
    #: stability bound of the scaled output (an NOE constructor parameter)
    unstable_bound: float = 10.0
    #: loss options of the Adam and shooting trainers (constructor parameters of NFIR, NOE, NSS)
    amplitude_weighting: float = 0.0
    passivity: float = 0.0
    cycle_energy: float = 0.0

    def _check_hyperparameters(self) -> NetworkSpec:
        """Validate the constructor arguments (the domains of the class's registry entry, then
        the rules between them); the network architecture they give.

        Raises
        ------
        ROMError
            The first argument out of its domain, named.
        """
        mc = self.model_class
        h = check_hyperparameters(mc, {x.name: getattr(self, x.name) for x in mc.hyper})
        why_not = mc.recipe_needs(h)
        for name in LOSS_TERMS:
            if h[name] > 0 and why_not:
                raise ROMError(f"{name} > 0 needs {why_not}, got trainer={h['trainer']!r}")
            if h[name] > 0 and self.input == "acceleration":
                # the weights, probes and cycle energies are written for the power F v of a
                # velocity input
                raise ROMError(f"{name} > 0 needs a velocity input; set it to 0 for a network "
                               "on the tank acceleration")
        if self.input not in mc.inputs:
            raise ROMError(f"an {mc.class_name} takes the tank {' or '.join(mc.inputs)}; a "
                           "network on the acceleration is an NFIR")
        # spelled out rather than io.same_unit: importing io would pull xarray into the ROMs
        if self.input == "acceleration" and \
                str(self.units[0]).replace(" ", "").replace("^", "") != "m/s2":
            raise ROMError(f"the input 'acceleration' is in m/s^2, got units {self.units[0]!r}")
        spec = NetworkSpec(self.arch, check_delays(h["delays"]), h["neurons"], h["hidden"],
                           h.get("out_delays", 0))
        # a network no model file can hold is refused before training, not when saved
        check_file_limits(spec.max_delay, spec.neurons, spec.n_inputs)
        return spec

    def _model(self, params: Any, scaler: MinMaxScaler, spec: Any, fs: float) -> Network:
        return self._network(dict(params), scaler, spec, self.input, fs,
                             float(self.unstable_bound))

    @property
    def theta_(self) -> jnp.ndarray:
        """The parameters packed into one vector (:func:`~sloshrom.rom.network.pack`)."""
        self._check_fitted()
        return pack(self.params_)

    # -- training -----------------------------------------------------------------------------
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
    ) -> _Estimator:
        """Identify the network from an input/output record.

        Parameters
        ----------
        u : array_like, shape (n,)
            Input (default: tank vertical velocity, m/s), sampled at ``fs``, starting at rest.
        y : array_like, shape (n,)
            Output (default: dynamic sloshing force, N).
        fs : float
            Sample rate, Hz.
        validation : (u_val, y_val), optional
            Validation record at the same rate; used for early stopping (6 failures) and for
            returning the best-validation network.
        callback : callable, optional
            ``callback(epoch, info)`` after every epoch; ``info`` is a dict with ``train_mse``,
            ``val_mse`` (N^2), ``mu``, ``grad``, ``seconds``; returning True stops training
            (the best-validation network so far is kept).
        fill : float, optional
            Fill level d/h (-) of the tank in the training record (``Record.attrs["fill"]`` of
            rig records). Stored in ``envelope_`` (``fill_min``/``fill_max``): the model then
            refuses other fills (:func:`sloshrom.rom.family.check_fill`).
        validation_history : int
            The validation record's first samples taken as measured history (at least the delay
            lines: ``max(delays)``, and ``out_delays`` for an NOE): the validation run starts from
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
        UnstableModelError
            An NOE unstable at its initial parameters.

        Warns
        -----
        TrainingWarning
            Levenberg-Marquardt stopped at mu_max: no step lowered the training error (why, and
            what to try: ``history_["stop_message"]``).
        """
        spec = self._check_hyperparameters()
        u, y, validation, fill = checked_records(u, y, fs, validation, fill,
                                                  self._fewest_samples(spec), spec.max_delay)
        hv = checked_history(validation_history, validation,
                             max(spec.max_delay, spec.out_delays), type(self).__name__)
        if (self.passivity > 0 or self.cycle_energy > 0) and not (u.min() < 0.0 < u.max()):
            # say what is wrong with the input, not which loss term tripped over it
            on = " and ".join(n for n in ("passivity", "cycle_energy") if getattr(self, n) > 0)
            raise ROMError(
                f"the input {self.names[0]!r} does not oscillate about rest (it stays between "
                f"{u.min():.4g} and {u.max():.4g} {self.units[0]}, never changing sign): "
                f"{on} judge the energy of a motion about rest; give the tank's oscillating "
                "signal (velocity, zero mean), or train with passivity=0 and cycle_energy=0"
            )
        scaler = MinMaxScaler.fit(u, y)
        band = power_band(u, fs)
        # passivity probes and energy cycles span the band holding all but 0.2 % of the
        # input's power: the edges of a VFA sweep are where its central-98 % band stops short
        probe_band = power_band(u, fs, 0.001, 0.999)
        theta, history = training.train(
            spec, u, y, scaler, validation, trainer=self.trainer,
            max_epochs=int(self.max_epochs), seed=int(self.seed),
            unstable_bound=float(self.unstable_bound), callback=callback, fs=float(fs),
            amplitude_weighting=float(self.amplitude_weighting),
            passivity=float(self.passivity), frequency_band=(probe_band[0], probe_band[1]),
            cycle_energy=float(self.cycle_energy), validation_history=hv,
            **self._trainer_options(),
        )
        self.model_ = self._model({k: np.asarray(v) for k, v in
                                   unpack(theta, spec.n_inputs, spec.neurons).items()},
                                  scaler, spec, float(fs))
        self.envelope_ = record_envelope(u, fs, scaler, band, self.input, fill)
        self.history_ = history
        return self

    def _fewest_samples(self, spec: NetworkSpec) -> int:
        """Fewest training samples: the delay line and two samples per hundred parameters."""
        return spec.max_delay + spec.out_delays + 2 * spec.n_params // 100 + 10

    def _trainer_options(self) -> dict[str, Any]:
        """Options of :func:`sloshrom.rom.training.train` beyond the common ones (the NOE's
        multiple shooting); none by default."""
        return {}

@jax.tree_util.register_pytree_node_class
class NFIR(_Estimator):
    """Nonlinear finite-impulse-response network: ``y_k = f(u_{k-1}, ..., u_{k-n})``.

    Parameters
    ----------
    delays : int or sequence of int
        ``n`` for delays 1..n (MATLAB ``timedelaynet``) or an explicit list of delays (samples).
    neurons : int
        Hidden normalized RBF neurons H.
    hidden : {"matlab", "distance"}
        RBF variant (see :mod:`sloshrom.rom.network`).
    max_epochs : int
        Training epochs at most.
    seed : int
        Seeds the initialisation (>= 0).
    trainer : {"fast", "lm", "adam"}
        ``"lm"``: MATLAB ``trainlm`` on all samples; ``"fast"``: the same algorithm with J^T J
        accumulated on a fixed decimated subset of the samples; ``"adam"`` (default): minibatch
        Adam with the same validation early stopping, which reached a lower validation error
        than both LM variants in less time on the virtual-rig data (see
        :mod:`sloshrom.rom.training` and docs/rom.md).
    units : (str, str)
        Units of the input and the output.
    names : (str, str)
        Variable names of the input and the output. ``"acceleration"`` as the input (units
        ``m/s^2``) makes a network on the tank acceleration: it runs in the coupled beam
        (:meth:`step`) and the energy maps like a velocity network, its envelope is an
        acceleration range, and the three loss terms below, written for the power of a velocity
        input, must be 0.
    amplitude_weighting : float
        ``eps`` (input units, e.g. m/s) of the loss weights ``1 / (a^2 + eps^2)``, ``a`` the
        local input amplitude (:func:`sloshrom.rom.training.amplitude_weights`): small-amplitude
        cycles count in the loss as they count in Phi_d. 0 (default) = plain MSE, as the
        paper. Adam only.
    passivity : float
        Weight of the passivity penalty: the squared negative part of the network's
        dissipated energy on harmonic probes inside the training envelope
        (:func:`sloshrom.rom.training.harmonic_probes`). 0 (default) = none, as the paper.
        Adam only.
    cycle_energy : float
        Weight of the cycle-energy term: the squared error of the energy each cycle of the
        training record exchanges with the liquid, over the cycle's squared amplitude
        (:func:`sloshrom.rom.training.energy_cycles`): the part of the error that changes the
        damping. 0 (default) = none, as the paper. Adam only.

    ``sloshrom reproduce`` and ``sloshrom train`` use ``amplitude_weighting = 0.05`` m/s,
    ``passivity = 1`` and ``cycle_energy = 0.1`` (docs/rom.md, "A passive ROM").

    Parameters are checked by :meth:`fit` (and by :func:`load_model`), not by the constructor.
    """

    model_class = NFIR_CLASS
    _network = NFIRNetwork

    def __init__(
        self,
        delays: int | Sequence[int] = 70,
        neurons: int = 35,
        hidden: str = "matlab",
        max_epochs: int = 1000,
        seed: int = 0,
        trainer: str = "adam",
        units: Sequence[str] = ("m/s", "N"),
        names: Sequence[str] = ("velocity", "dynamic_force"),
        amplitude_weighting: float = 0.0,
        passivity: float = 0.0,
        cycle_energy: float = 0.0,
    ) -> None:
        self.delays = delays
        self.neurons = neurons
        self.hidden = hidden
        self.max_epochs = max_epochs
        self.seed = seed
        self.trainer = trainer
        self.units = units
        self.names = names
        self.amplitude_weighting = amplitude_weighting
        self.passivity = passivity
        self.cycle_energy = cycle_energy


@jax.tree_util.register_pytree_node_class
class NOE(_Estimator):
    """Nonlinear output-error network: ``y^_k = f(u_{k-1..k-n}, y^_{k-1..k-m})`` (recurrent).

    Parameters
    ----------
    delays : int or sequence of int
        Input delays (default 2 -> 1, 2).
    neurons : int
        Hidden normalized RBF neurons.
    hidden, max_epochs, seed
        As :class:`NFIR`.
    trainer : {"lm", "fast", "adam"}
        ``"lm"`` (default): Levenberg-Marquardt on the simulation (output) error of the whole
        record with forward-mode derivatives through the recurrence (``"fast"`` is the same for
        the NOE). ``"adam"``: multiple shooting (:func:`sloshrom.rom.training.adam_noe`):
        minibatch Adam on the simulation error of ``batch`` sub-sequences of ``horizon``
        samples, each started from the delay lines filled with the measured past, with the
        loss terms below; early stopping on the free run of the validation record from rest.
    out_delays : int
        Number of fed-back past outputs m (default 2).
    unstable_bound : float
        A simulation whose scaled output exceeds this magnitude (10 = ten half-ranges of the
        training output) or is non-finite is unstable: :meth:`predict` raises
        :class:`UnstableModelError`.
    units, names
        As :class:`NFIR`; the input must be the tank velocity.
    amplitude_weighting, passivity, cycle_energy : float
        The passive recipe's loss terms, as :class:`NFIR` (the energy term is the error of the
        energy each simulated sub-sequence exchanges with the liquid, per input cycle). 0
        (default) = off. Adam only.
    horizon : int
        Adam: samples simulated from each start (and the length of the passivity probes,
        which must hold a ramp and two periods of the band's lowest frequency), >= 8.
    batch : int
        Adam: sub-sequences per step.
    steps_per_epoch : int
        Adam: steps between validations (early stopping after 6 epochs without a new best).
    learning_rate : float
        Adam: initial step (cosine decay to 5 % of it over ``max_epochs``), in (0, 1].

    Parameters are checked by :meth:`fit` (and by :func:`load_model`), not by the constructor.
    """

    model_class = NOE_CLASS
    _network = NOENetwork

    def __init__(
        self,
        delays: int | Sequence[int] = 2,
        neurons: int = 10,
        hidden: str = "matlab",
        max_epochs: int = 1000,
        seed: int = 0,
        trainer: str = "lm",
        out_delays: int = 2,
        unstable_bound: float = 10.0,
        units: Sequence[str] = ("m/s", "N"),
        names: Sequence[str] = ("velocity", "dynamic_force"),
        amplitude_weighting: float = 0.0,
        passivity: float = 0.0,
        cycle_energy: float = 0.0,
        horizon: int = 300,
        batch: int = 128,
        steps_per_epoch: int = 200,
        learning_rate: float = 3e-3,
    ) -> None:
        self.delays = delays
        self.neurons = neurons
        self.hidden = hidden
        self.max_epochs = max_epochs
        self.seed = seed
        self.trainer = trainer
        self.out_delays = out_delays
        self.unstable_bound = unstable_bound
        self.units = units
        self.names = names
        self.amplitude_weighting = amplitude_weighting
        self.passivity = passivity
        self.cycle_energy = cycle_energy
        self.horizon = horizon
        self.batch = batch
        self.steps_per_epoch = steps_per_epoch
        self.learning_rate = learning_rate

    def _fewest_samples(self, spec: NetworkSpec) -> int:
        # multiple shooting also needs one sub-sequence of `horizon` samples
        n = super()._fewest_samples(spec)
        return max(n, int(self.horizon) + 1) if self.trainer == "adam" else n

    def _trainer_options(self) -> dict[str, Any]:
        if self.trainer != "adam":
            return {}
        return {"horizon": int(self.horizon), "batch": int(self.batch),
                "steps_per_epoch": int(self.steps_per_epoch),
                "learning_rate": float(self.learning_rate)}


@jax.tree_util.register_pytree_node_class
class NSS(_Estimator):
    """Neural state-space ROM: ``x_{k+1} = f(x_k, u_k)``, ``y_k = h(x_k, u_k)``, identified by
    multiple shooting (:mod:`sloshrom.rom.statespace`).

    Unlike the NFIR, whose force is a function of the last ``delays`` inputs only, the model
    carries a state (where the liquid is, how fast it moves), so it can remember an impact or a
    flight phase for as long as it lasts. It starts from rest in the coupled beam and the maps;
    its encoder, which estimates the state from measured history, starts the training's
    sub-sequences, :meth:`predict` given ``history`` and the validation run of a fit given
    ``validation_history`` (a record that does not start at rest), and is available as
    :meth:`sloshrom.rom.statespace.StateSpaceNetwork.encode`.

    It identifies any single-input single-output system, not only a tank: the input and output
    may be any signals in any units (``names``, ``units``); the passive recipe's loss terms
    alone are written for a velocity in m/s and a force in N.

    The size (``n_states``, ``neurons``, ``window``) and the ``horizon`` left at None are
    **sized by the training record** (:meth:`sloshrom.rom.registry.ModelClass.size`, the rule
    :func:`sloshrom.rom.registry.nss_size`): from 100,000 samples on they are the defaults
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

    def __init__(
        self,
        n_states: int | None = None,
        neurons: int | None = None,
        window: int | None = None,
        horizon: int | None = None,
        batch: int = 128,
        max_epochs: int = 60,
        steps_per_epoch: int = 200,
        learning_rate: float = 3e-3,
        seed: int = 0,
        units: Sequence[str] = ("m/s", "N"),
        names: Sequence[str] = ("velocity", "dynamic_force"),
        amplitude_weighting: float = 0.0,
        passivity: float = 0.0,
        cycle_energy: float = 0.0,
        feedthrough: str = "yes",
        velocity_offset: float = 0.0,
        weight_decay: float = 0.0,
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
        mc = self.model_class
        given = {}
        for k in mc.sized_by_record:
            v = getattr(self, k)
            if v is not None:
                # the user's values checked first: the rule reads them
                given[k] = int(mc.hyper_named(k).check(v))
        if n_samples is None:
            return {k: int(mc.hyper_named(k).default) for k in mc.sized_by_record} | given
        return {**given, **mc.size(n_samples, given)}

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
        mc = self.model_class
        h = check_hyperparameters(mc, {**{x.name: getattr(self, x.name) for x in mc.hyper},
                                       **self._sizes(n_samples)})
        if self.input != "velocity":
            # the coupled beam hands a model the acceleration of the previous step: a state
            # driven by it would run one sample behind its training
            raise ROMError("an NSS takes the tank velocity (names[0] = 'velocity'); a network "
                           "on the acceleration is an NFIR")
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
        n_samples = int(np.size(u))
        spec = self._check_hyperparameters(n_samples)
        sz = self._sizes(n_samples)
        u, y, validation, fill = checked_records(
            u, y, fs, validation, fill, spec.window + sz["horizon"] + 1, spec.window)
        hv = checked_history(validation_history, validation, spec.window, "NSS")
        if (self.passivity > 0 or self.cycle_energy > 0) and not (u.min() < 0.0 < u.max()):
            raise ROMError(f"the input {self.names[0]!r} does not oscillate about rest: "
                           "passivity and cycle_energy judge the energy of a motion about rest")
        mc = self.model_class
        chosen = {k: sz[k] for k in mc.sized_by_record if getattr(self, k) is None}
        too_big = mc.oversize(sz, n_samples)
        if too_big is not None:
            # only a size the user gave can be too big: the rule's is the reference
            warnings.warn(too_big, ModelSizeWarning, stacklevel=3)
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


# ---------------------------------------------------------------------------------------------
# Loading
# ---------------------------------------------------------------------------------------------


def load_model(path: str | Path, fill: float | None = None) -> Any:
    """Load a model written by ``save``; never runs code (no pickle).

    Every metadata field is validated against a schema with bounds and the arrays against the
    metadata before the model is built (:mod:`sloshrom.rom.modelfile`; docs/formats.md, "Model
    files"), then the hyperparameters as :meth:`~_Estimator.fit` checks them, so a loaded model
    can be simulated, coupled and exported.

    Parameters
    ----------
    path : str or Path
        A ``.npz`` model file: a single network (NFIR, NOE, NSS) or an ensemble
        (:meth:`Ensemble.save`); or a
        ``.toml`` fill-family manifest naming one model file per fill level
        (:func:`sloshrom.rom.family.read_family`); or a ``.toml`` bouncing-ball model
        (:meth:`sloshrom.rom.bouncing.BouncingBall.save`).
    fill : float, optional
        Fill level d/h (-) to run the model at. Given, the result is a sloshing model at that
        fill whatever the file holds (:func:`sloshrom.rom.family.at_fill`: a family's blend of
        its neighbouring members, any other model checked against the fills it was identified
        on). Without it a fill family comes back as a family, which is a sloshing model only
        at a fill.

    Returns
    -------
    NFIR, NOE, NSS, Ensemble, FillFamily, BouncingBall or (with ``fill``) FillBlend
        Every one describes its records alike (``names``, ``units``, ``input``).

    Raises
    ------
    ModelFileError
        Missing file, not a sloshrom model, other/newer format version, corrupt or truncated file
        (checksum), a metadata field out of bounds or inconsistent (the message names it),
        parameter arrays that do not match the metadata.
    FillRangeError
        ``fill`` outside the fills the model was identified on.
    """
    if fill is not None:
        return at_fill(load_model(path), fill, str(path))
    if is_ball_file(path):
        return BouncingBall.load(path)
    if Path(path).suffix == ".toml":
        try:
            return read_family(path, load_model)
        except ModelFileError:
            raise
        except ROMError as exc:
            raise ModelFileError(str(exc)) from None
    mf = read_model_file(path)
    if not mf.is_ensemble:
        return _from_model_file(mf, path)
    cls = model_class(mf.meta["member_class"]).estimator_class()
    try:
        return Ensemble.from_members([_from_model_file(m, path) for m in mf.members()],
                                     template=cls(**mf.meta["hyperparameters"]))
    except ModelFileError:
        raise
    except ROMError as exc:  # members the schema cannot relate (fills that disagree)
        raise ModelFileError(f"{path}: {exc}") from None


def _from_model_file(mf: ModelFile, path: str | Path) -> Estimator:
    """The network of a validated single-model file (or of one member of an ensemble file)."""
    meta = mf.meta
    cls = model_class(meta["class"]).estimator_class()
    sc = meta["scaler"]
    scaler = MinMaxScaler(**{k: float(sc[k]) for k in ("in_min", "in_max", "out_min", "out_max")})
    try:
        return cls.fitted(mf.arrays, scaler, float(meta["fs"]), meta["envelope"],
                          meta.get("history", {}), **meta["hyperparameters"])
    except (TypeError, ROMError) as exc:  # unreachable after the schema; kept as a net
        raise ModelFileError(f"{path}: corrupt metadata ({exc})") from None
