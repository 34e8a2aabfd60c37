"""Time-delay neural-network reduced-order models: NFIR and NOE with a normalized RBF layer.

Paper section 3 and Appendix A. Both models map a scalar input history (tank vertical velocity,
m/s) to a scalar output (dynamic sloshing force, N), but work for any single-input single-output
record. The network equations and the pure functions that evaluate them are in
:mod:`sloshrom.rom.tdnn.network`; the trainers in :mod:`sloshrom.rom.tdnn.training`; their
registry entries in :mod:`sloshrom.rom.tdnn.entry`.

Model and estimator are apart. The fitted *model* is a
:class:`~sloshrom.rom.tdnn.network.Network`:
an immutable JAX pytree with the parameters, the scaler, the architecture, the input signal and
the time step, whose pure ``step``/``free_run`` implement the sloshing-model contract. The
*estimators* here are thin shells in the scikit-learn style: the constructor only stores its
arguments, :meth:`~TimeDelayEstimator.fit` validates them once, trains and keeps the network
as ``model_``, ``get_params``/``set_params`` cover every constructor argument, and ``predict``
does not change the model. Fitted attributes end in ``_`` (``model_``, ``envelope_``,
``history_``; ``params_``, ``scaler_``, ``fs_`` read the network).

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

from collections.abc import Callable, Sequence
from typing import Any, ClassVar

import jax
import jax.numpy as jnp
import numpy as np

from sloshrom._x64 import float64
from sloshrom.rom.base import Estimator, checked_history, checked_records, record_envelope
from sloshrom.rom.errors import ROMError
from sloshrom.rom.network import MinMaxScaler
from sloshrom.rom.tdnn import training
from sloshrom.rom.tdnn.entry import NFIR_CLASS, NOE_CLASS, check_delays
from sloshrom.rom.tdnn.network import (
    Network,
    NetworkSpec,
    NFIRNetwork,
    NOENetwork,
    pack,
    unpack,
)
from sloshrom.signals import power_band

__all__ = ["NFIR", "NOE", "TimeDelayEstimator"]

#: Each class's hyperparameters by default: its registry entry's, the one place they are written
_NFIR = NFIR_CLASS.defaults()
_NOE = NOE_CLASS.defaults()



class TimeDelayEstimator(Estimator):
    """Shared code of the time-delay network estimators NFIR and NOE (the loss terms, the
    hyperparameters of the time-delay networks)."""

    #: the fitted network's class (NFIRNetwork, NOENetwork)
    _network: ClassVar[type[Network]]
    # constructor parameters of both classes
    trainer: str
    max_epochs: int
    seed: int
    #: fed-back past outputs: none for the NFIR (an NOE constructor parameter)
    out_delays: int = 0
    #: stability bound of the scaled output (an NOE constructor parameter)
    unstable_bound: float = 10.0
    #: loss options of the Adam and shooting trainers (constructor parameters of NFIR, NOE)
    amplitude_weighting: float = 0.0
    passivity: float = 0.0
    cycle_energy: float = 0.0
    #: precision of the Adam steps (an NFIR constructor parameter; the NOE's are its own)
    precision: str = "float64"

    def _check_hyperparameters(self) -> NetworkSpec:
        """Validate the constructor arguments (the rules of the class's registry entry that
        do not depend on a training); the network architecture they give.

        Raises
        ------
        ROMError
            The first argument out of its domain, named.
        """
        return self._spec(self.model_class.check(self._arguments(), input=self.input,
                                                 training=False))

    def _spec(self, h: dict[str, Any]) -> NetworkSpec:
        """The architecture of checked hyperparameters ``h``, once the input's unit is the
        acceleration's (for a network on it)."""
        # spelled out rather than io.same_unit: importing io would pull xarray into the ROMs
        if self.input == "acceleration" and \
                str(self.units[0]).replace(" ", "").replace("^", "") != "m/s2":
            raise ROMError(f"the input 'acceleration' is in m/s^2, got units {self.units[0]!r}")
        return NetworkSpec(self.arch, check_delays(h["delays"]), h["neurons"], h["hidden"],
                           h.get("out_delays", 0))

    def _model(self, params: Any, scaler: MinMaxScaler, spec: Any, fs: float) -> Network:
        return self._network(dict(params), scaler, spec, self.input, fs,
                             float(self.unstable_bound))

    @property
    def theta_(self) -> jnp.ndarray:
        """The parameters packed into one vector (:func:`~sloshrom.rom.tdnn.network.pack`)."""
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
    ) -> TimeDelayEstimator:
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
        # the class's rules (the fewest samples among them) before anything else
        spec = self._spec(self.check_training(int(np.size(u))))
        u, y, validation, fill = checked_records(u, y, fs, validation, fill, 0, spec.max_delay)
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
            precision=str(self.precision), **self._trainer_options(),
        )
        self.model_ = self._model({k: np.asarray(v) for k, v in
                                   unpack(theta, spec.n_inputs, spec.neurons).items()},
                                  scaler, spec, float(fs))
        self.envelope_ = record_envelope(u, fs, scaler, band, self.input, fill)
        self.history_ = history
        return self

    def _trainer_options(self) -> dict[str, Any]:
        """Options of :func:`sloshrom.rom.tdnn.training.train` beyond the common ones (the NOE's
        multiple shooting); none by default."""
        return {}

@jax.tree_util.register_pytree_node_class
class NFIR(TimeDelayEstimator):
    """Nonlinear finite-impulse-response network: ``y_k = f(u_{k-1}, ..., u_{k-n})``.

    Parameters
    ----------
    delays : int or sequence of int
        ``n`` for delays 1..n (MATLAB ``timedelaynet``) or an explicit list of delays (samples).
    neurons : int
        Hidden normalized RBF neurons H.
    hidden : {"matlab", "distance"}
        RBF variant (see :mod:`sloshrom.rom.tdnn.network`).
    max_epochs : int
        Training epochs at most.
    seed : int
        Seeds the initialisation (>= 0).
    trainer : {"fast", "lm", "adam"}
        ``"lm"``: MATLAB ``trainlm`` on all samples; ``"fast"``: the same algorithm with J^T J
        accumulated on a fixed decimated subset of the samples; ``"adam"`` (default): minibatch
        Adam with the same validation early stopping, which reached a lower validation error
        than both LM variants in less time on the virtual-rig data (see
        :mod:`sloshrom.rom.tdnn.training` and docs/rom.md).
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
        local input amplitude (:func:`sloshrom.rom.losses.amplitude_weights`): small-amplitude
        cycles count in the loss as they count in Phi_d. 0 (default) = plain MSE, as the
        paper. Adam only.
    passivity : float
        Weight of the passivity penalty: the squared negative part of the network's
        dissipated energy on harmonic probes inside the training envelope
        (:func:`sloshrom.rom.tdnn.training.harmonic_probes`). 0 (default) = none, as the paper.
        Adam only.
    cycle_energy : float
        Weight of the cycle-energy term: the squared error of the energy each cycle of the
        training record exchanges with the liquid, over the cycle's squared amplitude
        (:func:`sloshrom.rom.tdnn.training.energy_cycles`): the part of the error that changes the
        damping. 0 (default) = none, as the paper. Adam only.
    precision : {"float64", "float32"}
        Precision of the Adam steps (their validation and the parameters stay float64).
        ``"float32"`` trains about 1.7x faster and moves the model from one CPU to another by
        about 1e-4 of its output's peak (``"float64"``, the default: about 1e-12). Adam only
        (the Levenberg-Marquardt trainers run float64).

    ``sloshrom reproduce`` and ``sloshrom train`` use ``amplitude_weighting = 0.05`` m/s,
    ``passivity = 1`` and ``cycle_energy = 0.1`` (docs/rom.md, "A passive ROM").

    Parameters are checked by :meth:`fit` (and by :func:`load_model`), not by the constructor.
    """

    model_class = NFIR_CLASS
    _network = NFIRNetwork

    def __init__(  # the defaults: its registry entry's
        self,
        delays: int | Sequence[int] = _NFIR["delays"],
        neurons: int = _NFIR["neurons"],
        hidden: str = _NFIR["hidden"],
        max_epochs: int = _NFIR["max_epochs"],
        seed: int = _NFIR["seed"],
        trainer: str = _NFIR["trainer"],
        units: Sequence[str] = ("m/s", "N"),
        names: Sequence[str] = ("velocity", "dynamic_force"),
        amplitude_weighting: float = _NFIR["amplitude_weighting"],
        passivity: float = _NFIR["passivity"],
        cycle_energy: float = _NFIR["cycle_energy"],
        precision: str = _NFIR["precision"],
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
        self.precision = precision


@jax.tree_util.register_pytree_node_class
class NOE(TimeDelayEstimator):
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
        the NOE). ``"adam"``: multiple shooting (:func:`sloshrom.rom.tdnn.training.adam_noe`):
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

    def __init__(  # the defaults: its registry entry's
        self,
        delays: int | Sequence[int] = _NOE["delays"],
        neurons: int = _NOE["neurons"],
        hidden: str = _NOE["hidden"],
        max_epochs: int = _NOE["max_epochs"],
        seed: int = _NOE["seed"],
        trainer: str = _NOE["trainer"],
        out_delays: int = _NOE["out_delays"],
        unstable_bound: float = _NOE["unstable_bound"],
        units: Sequence[str] = ("m/s", "N"),
        names: Sequence[str] = ("velocity", "dynamic_force"),
        amplitude_weighting: float = _NOE["amplitude_weighting"],
        passivity: float = _NOE["passivity"],
        cycle_energy: float = _NOE["cycle_energy"],
        horizon: int = _NOE["horizon"],
        batch: int = _NOE["batch"],
        steps_per_epoch: int = _NOE["steps_per_epoch"],
        learning_rate: float = _NOE["learning_rate"],
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

    def _trainer_options(self) -> dict[str, Any]:
        if self.trainer != "adam":
            return {}
        return {"horizon": int(self.horizon), "batch": int(self.batch),
                "steps_per_epoch": int(self.steps_per_epoch),
                "learning_rate": float(self.learning_rate)}
