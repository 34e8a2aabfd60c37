"""What every ROM estimator shares: the scikit-learn shell around a fitted model.

A class of :mod:`sloshrom.rom.registry` is implemented by a fitted *model* (an immutable JAX
pytree implementing the sloshing-model contract of :mod:`sloshrom.models`) and an *estimator*
that fits it. :class:`Estimator` is the estimator's shared part: the constructor's arguments
as hyperparameters (:meth:`~Estimator.get_params`, :meth:`~Estimator.set_params`), the fitted
attributes that read the model (``params_``, ``scaler_``, ``fs_``, ``dt``), prediction from
rest with the envelope check, the step contract, the pytree (the fitted model is the child,
the hyperparameters the static part), saving to a model file, and building a fitted estimator
from known parts (:meth:`~Estimator.fitted`, which the loader uses). A subclass says which
registry entry it is (``model_class``), validates its hyperparameters into its architecture
(``_check_hyperparameters``), builds its model from arrays (``_model``) and fits.

The helpers below check the records every ``fit`` takes and describe a training record's
envelope.
"""

from __future__ import annotations

import functools
import inspect
import warnings
from collections.abc import Mapping
from pathlib import Path
from typing import Any, ClassVar, Literal, cast

import numpy as np
from numpy.typing import ArrayLike

from sloshrom import __version__
from sloshrom._x64 import float64
from sloshrom.limits import MIN_SCORED
from sloshrom.models import SloshingModel, check_envelope, model_input
from sloshrom.rom.errors import HistoryError, ModelSizeWarning, NotFittedError, ROMError
from sloshrom.rom.family import check_training_fill
from sloshrom.rom.modelfile import model_file_path, write_model_file
from sloshrom.rom.network import MinMaxScaler
from sloshrom.rom.registry import ARGUMENTS, ModelClass, Naming

__all__ = ["Estimator", "History", "as_signal", "checked_history", "checked_past",
           "checked_records", "record_envelope"]


def as_signal(name: str, x: ArrayLike, allow_batch: bool = False) -> np.ndarray:
    """``x`` as a finite float64 signal, shape (n,) (or (batch, n)); :class:`ROMError` else."""
    a = np.asarray(x, dtype=np.float64)
    if a.ndim != 1 and not (allow_batch and a.ndim == 2):
        shape = "(n,) or (batch, n)" if allow_batch else "(n,)"
        raise ROMError(f"{name} must have shape {shape}, got {a.shape}")
    if not np.all(np.isfinite(a)):
        raise ROMError(f"{name} contains NaN or inf (first at index {np.argmin(np.isfinite(a))})")
    return a


def _plain(v: Any) -> Any:
    """NumPy scalars and arrays, tuples -> plain Python numbers and lists (JSON-serialisable)."""
    if isinstance(v, np.generic):
        return v.item()
    if isinstance(v, np.ndarray):
        return v.tolist()
    if isinstance(v, tuple | list):
        return [_plain(x) for x in v]
    return v


def _frozen(v: Any) -> Any:
    """Lists -> tuples (hashable pytree aux data)."""
    return tuple(_frozen(x) for x in v) if isinstance(v, list) else v


def _thawed(v: Any) -> Any:
    return [_thawed(x) for x in v] if isinstance(v, tuple) else v


def checked_records(u: ArrayLike, y: ArrayLike, fs: float,
                    validation: tuple[ArrayLike, ArrayLike] | None,
                    fill: float | None, need: int, history: int
                    ) -> tuple[np.ndarray, np.ndarray, tuple[np.ndarray, np.ndarray] | None,
                               float | None]:
    """The training and validation records and the fill, checked for any estimator's fit.

    ``need``: fewest training samples; ``history``: samples of input history the model reads
    (the validation record must be longer).

    Raises
    ------
    ROMError
        A sample rate that is not finite and positive, records of other shapes or lengths,
        NaN or inf, too few samples; a fill outside (0, 1).
    """
    if not (np.isfinite(fs) and fs > 0):
        raise ROMError(f"fs must be a finite positive sample rate in Hz, got {fs!r}")
    fill = check_training_fill(fill)
    u = as_signal("u", u)
    y = as_signal("y", y)
    if u.shape != y.shape:
        raise ROMError(f"u and y must have the same length, got {u.size} and {y.size}")
    if u.size < need:
        raise ROMError(f"{u.size} samples are too few for {history} samples of history "
                       f"(need at least {need})")
    if validation is not None:
        uv = as_signal("validation input", validation[0])
        yv = as_signal("validation output", validation[1])
        if uv.shape != yv.shape:
            raise ROMError("validation input and output must have the same length")
        if uv.size <= history:
            raise ROMError(f"validation record too short for {history} samples of history")
        validation = (uv, yv)
    return u, y, validation, fill


#: Measured history before a record: its input and output, oldest first.
History = tuple[ArrayLike, ArrayLike]


def checked_past(history: object) -> tuple[np.ndarray, np.ndarray]:
    """``(u_past, y_past)`` of a prediction from measured history, as finite 1-D float64
    signals of one length.

    Raises
    ------
    ROMError
        Not a pair, other shapes or lengths, NaN or inf.
    """
    if not isinstance(history, tuple | list) or len(history) != 2:
        raise ROMError("history must be a pair (u_past, y_past) of measured input and output")
    up = as_signal("history input", history[0])
    yp = as_signal("history output", history[1])
    if up.size != yp.size:
        raise ROMError(f"the history's input has {up.size} samples, its output {yp.size}")
    return up, yp


def checked_history(history: object, validation: tuple[np.ndarray, np.ndarray] | None,
                    need: int, label: str) -> int:
    """``validation_history`` of a fit, checked: 0, or the validation record's first samples
    taken as measured history (at least ``need``, the samples the class ``label`` reads, and
    leaving at least :data:`MIN_SCORED` samples, so that something is scored).

    Raises
    ------
    ROMError
        Not an integer >= 0, or given without a validation record.
    HistoryError
        Too short for the class, or too long for the record.
    """
    if isinstance(history, bool) or not isinstance(history, int | np.integer) or history < 0:
        raise ROMError(f"validation_history must be an integer >= 0 (samples), got {history!r}")
    h = int(history)
    if h == 0:
        return 0
    if validation is None:
        raise ROMError("validation_history needs a validation record")
    if h < need:
        raise HistoryError(h, f"a start from history reads {need} samples ({label})")
    n = validation[0].size
    if h > n - MIN_SCORED:
        raise HistoryError(h, f"leaves {n - h} sample(s) of the validation record of {n} to "
                              f"score; a score needs {MIN_SCORED} (at most {n - MIN_SCORED} "
                              "samples of history)")
    return h


def record_envelope(u: np.ndarray, fs: float, scaler: MinMaxScaler, band: Any, input: str,
                    fill: float | None) -> dict[str, Any]:
    """``envelope_`` of a model trained on the input record ``u``."""
    env = {
        "input_min": scaler.in_min,
        "input_max": scaler.in_max,
        "output_min": scaler.out_min,
        "output_max": scaler.out_max,
        "frequency_band": band,
        # the peak tank acceleration of the training record
        "acceleration_max": float(np.max(np.abs(u))) if input == "acceleration"
        else float(np.max(np.abs(np.gradient(u)))) * float(fs),
    }
    if fill is not None:
        env.update(fill_min=fill, fill_max=fill)
    return env


class Estimator:
    """The shared shell of every ROM estimator (scikit-learn estimator + sloshing-model
    contract); module docstring."""

    #: the class's registry entry
    model_class: ClassVar[ModelClass]
    #: the force at sample k is the force at t_k (energy integrals: trapezoid rule)
    force_rule: ClassVar[Literal["trapezoid"]] = "trapezoid"
    #: step is a pure JAX function and a fitted model is a pytree (sloshrom.models.is_jax_model)
    jax_traceable: ClassVar[Literal[True]] = True
    #: the training ranges (set by fit and load; None for a model rebuilt from pytree leaves)
    envelope_: dict[str, Any] | None = None
    #: the fitted model (set by fit and load; no class attribute: ``hasattr`` says fitted)
    model_: Any
    #: the training history (set by fit and load)
    history_: dict[str, Any]
    units: Any = ("m/s", "N")
    names: Any = ("velocity", "dynamic_force")

    @property
    def arch(self) -> str:
        """The class's name in the registry (``"nfir"``, ``"nss"``, ...)."""
        return self.model_class.name

    # -- hyperparameters ----------------------------------------------------------------------
    @classmethod
    @functools.cache
    def _param_names(cls) -> tuple[str, ...]:
        sig = inspect.signature(cls.__init__)
        return tuple(p.name for p in sig.parameters.values() if p.name != "self")

    def get_params(self, deep: bool = True) -> dict[str, Any]:
        """Every constructor argument by name, in plain Python types (JSON-serialisable).

        ``deep`` is accepted for scikit-learn compatibility (there are no nested estimators).
        """
        return {k: _plain(getattr(self, k)) for k in self._param_names()}

    def set_params(self, **params: Any) -> Estimator:
        """Set constructor arguments by name (checked by the next :meth:`fit`); returns self.

        Raises
        ------
        ROMError
            A name that is not a constructor argument.
        """
        valid = self._param_names()
        for k, v in params.items():
            if k not in valid:
                raise ROMError(f"{type(self).__name__} has no parameter {k!r} "
                               f"(valid: {', '.join(valid)})")
            setattr(self, k, v)
        return self

    def _arguments(self) -> dict[str, object]:
        """The hyperparameters as given to the constructor, by name (the class's entry's)."""
        return {h.name: getattr(self, h.name) for h in self.model_class.hyper}

    def check_training(self, n_samples: int | None = None, members: int = 1,
                       naming: Naming = ARGUMENTS) -> dict[str, Any]:
        """The hyperparameters checked by every rule of the class for a training
        (:meth:`sloshrom.rom.registry.ModelClass.check`, the one place of its rules): on a
        record of ``n_samples`` samples (None: not known yet), ``members`` models in one file
        (an ensemble's); ``naming``: how a message names the values (the command line's
        options). ``fit`` calls it first, an ensemble before any member trains, the command
        line before either; a second call for the same record reuses the first's result.

        Returns
        -------
        dict
            Every hyperparameter by name (a size left to the record: the size rule's).

        Raises
        ------
        ROMError
            The first rule broken, naming the arguments at fault.

        Warns
        -----
        ModelSizeWarning
            A size given with many more parameters than the record supports (the size rule's
            for it, :meth:`~sloshrom.rom.registry.ModelClass.oversize`).
        """
        mc = self.model_class
        args = self._arguments()
        key = (repr(sorted(args.items())), n_samples, members, self.input)
        done = getattr(self, "_checked", None)
        if done is not None and done[0] == key:
            return dict(done[1])
        h = mc.check(args, n_samples=n_samples, input=self.input, members=members,
                     naming=naming)
        given = [k for k in mc.sized_by_record if args[k] is not None]
        if n_samples is not None and given:
            # only a size the user gave can be too big: the rule's is the reference
            too_big = mc.oversize({k: int(h[k]) for k in mc.sized_by_record}, n_samples)
            if too_big is not None:
                warnings.warn(too_big, ModelSizeWarning, stacklevel=4)  # fit's caller
        self._checked = (key, h)
        return dict(h)

    def _check_hyperparameters(self) -> Any:
        """Validate the constructor arguments; the architecture (spec) they give."""
        raise NotImplementedError

    def effective_params(self) -> dict[str, object]:
        """The hyperparameters the model has (a model file records them): :meth:`get_params`,
        with the values :meth:`fit` chose for those a class leaves to the record (an NSS's
        size; before a fit, their defaults)."""
        return {**self.get_params(), **self._chosen_sizes()}

    def _chosen_sizes(self) -> dict[str, int]:
        """The values chosen for the hyperparameters left to the record (none by default)."""
        return {}

    def _model(self, params: Mapping[str, Any], scaler: MinMaxScaler, spec: Any,
               fs: float) -> Any:
        """The fitted model of ``params`` (arrays by name)."""
        raise NotImplementedError

    @property
    def input(self) -> str:
        """The tank signal the model reads (:func:`sloshrom.models.input_of`): the record's
        input variable ``names[0]`` says it, ``"acceleration"`` or else ``"velocity"``; fixed
        in the fitted model when it is fitted or loaded."""
        if hasattr(self, "model_"):
            return cast(str, self.model_.input)
        return "acceleration" if str(self.names[0]) == "acceleration" else "velocity"

    @property
    def spec(self) -> Any:
        """The architecture: the fitted model's, else the validated hyperparameters'."""
        if hasattr(self, "model_"):
            return self.model_.spec
        return self._check_hyperparameters()

    @property
    def n_inputs(self) -> int:
        """Length D of the regressor (a state-space model: its state and input)."""
        return cast(int, self.spec.n_inputs)

    @property
    def n_params(self) -> int:
        """The number of trained parameters."""
        return cast(int, self.spec.n_params)

    @property
    def max_delay(self) -> int:
        """The longest input delay, samples."""
        return cast(int, self.spec.max_delay)

    def _check_fitted(self) -> None:
        if not hasattr(self, "model_"):
            raise NotFittedError(f"this {type(self).__name__} is not fitted: call fit() first")

    @property
    def params_(self) -> dict[str, Any]:
        """The fitted parameter arrays by name (the model's)."""
        self._check_fitted()
        return cast("dict[str, Any]", self.model_.params)

    @property
    def scaler_(self) -> MinMaxScaler:
        """Bounds of the training input and output."""
        self._check_fitted()
        return cast(MinMaxScaler, self.model_.scaler)

    @property
    def fs_(self) -> float:
        """Sample rate of the training record, Hz."""
        self._check_fitted()
        return cast(float, self.model_.fs)

    @classmethod
    def fitted(cls, params: dict[str, Any], scaler: MinMaxScaler, fs: float,
               envelope: dict[str, Any] | None = None, history: dict[str, Any] | None = None,
               **hyperparameters: Any) -> Estimator:
        """A fitted estimator from known parts (no training): the loader's and the tests' way
        to build one.

        Parameters
        ----------
        params : dict
            The class's parameter arrays by name (:meth:`ModelClass.shapes` of the
            hyperparameters).
        scaler : MinMaxScaler
        fs : float
            Sample rate, Hz.
        envelope, history : dict, optional
            ``envelope_`` and ``history_`` (default: none, empty).
        **hyperparameters
            Constructor arguments.

        Raises
        ------
        ROMError
            A hyperparameter out of its domain, or arrays of other shapes than it gives.
        """
        obj = cls(**hyperparameters)
        spec = obj._check_hyperparameters()
        shapes = cls.model_class.shapes(obj.effective_params())
        arrays = {k: np.asarray(params[k], dtype=np.float64) for k in shapes}
        for k, shp in shapes.items():
            if arrays[k].shape != shp:
                raise ROMError(f"parameter {k} has shape {arrays[k].shape}, the "
                               f"hyperparameters give {shp}")
        obj.model_ = obj._model(arrays, scaler, spec, float(fs))
        obj.envelope_ = envelope
        obj.history_ = {} if history is None else history
        return obj

    # -- pytree (parameters are leaves, hyperparameters static) -------------------------------
    def tree_flatten(self) -> tuple[tuple[Any, ...], tuple[Any, ...]]:
        """JAX pytree: the fitted model as the child, the hyperparameters static."""
        children = (self.model_,) if hasattr(self, "model_") else ()
        hyper = tuple((k, _frozen(v)) for k, v in self.get_params().items())
        return children, hyper

    @classmethod
    def tree_unflatten(cls, aux: tuple[Any, ...], children: tuple[Any, ...]) -> Estimator:
        """JAX pytree: the estimator of these hyperparameters and fitted model."""
        obj = cls(**{k: _thawed(v) for k, v in aux})
        if children:
            obj.model_ = children[0]
        return obj

    # -- prediction ---------------------------------------------------------------------------
    @property
    def dt(self) -> float:
        """Model time step = ``1/fs_``, s."""
        self._check_fitted()
        return cast(float, self.model_.dt)

    @property
    def history_samples(self) -> int:
        """Samples of measured input and output that :meth:`predict` reads as ``history``
        (the delay lines, the encoder's window, a linear model's order)."""
        self._check_fitted()
        return cast(int, self.model_.history_samples)

    @float64
    def predict(self, u: ArrayLike, history: History | None = None) -> np.ndarray:
        """Simulation from rest, or from measured history; does not change the model.

        Parameters
        ----------
        u : array_like, shape (n,) or (batch, n)
            Input sampled at ``fs_`` (physical units, e.g. m/s).
        history : (u_past, y_past), optional
            The measured input and output of the samples just before ``u`` (oldest first, at
            least :attr:`history_samples` of them; ``u`` 1-D): the run starts where they
            leave the system (delay lines filled, state encoded or fitted) instead of at
            rest, for a record that does not start at rest.

        Returns
        -------
        ndarray, same shape as ``u``
            Output (physical units, e.g. N), float64.

        Raises
        ------
        NotFittedError
            The model is not fitted.
        ROMError
            ``u`` of another shape, or with NaN or inf; a history of other lengths or shorter
            than :attr:`history_samples`.
        UnstableModelError
            A recurrent model whose simulation left its stability bound.

        Warns
        -----
        EnvelopeWarning
            ``u`` leaves the input range of the training record.
        """
        self._check_fitted()
        if history is None:
            u = as_signal("u", u, allow_batch=True)
            # predict < float64 wrapper < the caller
            check_envelope(self, u, unit=str(self.units[0]), stacklevel=3)
            return cast(np.ndarray, self.model_.free_run(u))
        u = as_signal("u", u)
        up, yp = checked_past(history)
        check_envelope(self, np.concatenate([up, u]), unit=str(self.units[0]), stacklevel=3)
        return cast(np.ndarray, self.model_.run_from_history(up, yp, u))

    def simulate(self, velocity: ArrayLike, acceleration: ArrayLike | None = None
                 ) -> np.ndarray:
        """Sloshing-model contract: dynamic force (N) from the tank velocity (m/s) or, for a
        model on the acceleration (:attr:`input`), the acceleration (m/s^2)."""
        return self.predict(model_input(self, velocity, acceleration))

    def init_state(self) -> Any:
        """The model's state at rest, a pytree of arrays."""
        self._check_fitted()
        return self.model_.init_state()

    def step(self, state: Any, velocity: Any, acceleration: Any = None) -> tuple[Any, Any]:
        """One pure, jax-traceable step: ``(state, dynamic_force)`` at the current sample k
        (the fitted model's ``step``).

        Reads the parameters and the scaler from the model's pytree leaves, so a model passed
        as an argument into ``jit`` is traced, not compiled in.
        """
        return cast("tuple[Any, Any]", self.model_.step(state, velocity, acceleration))

    @property
    def stepper(self) -> SloshingModel:
        """The fitted network, whose ``init_state`` and ``step`` are this model's: what a
        compiled loop takes as its argument (:func:`sloshrom.models.stepper_of`). Its pytree's
        static part is the architecture alone, where this estimator's holds every
        hyperparameter: models that differ only in their training (an ensemble's members, by
        their seeds) share one compiled loop."""
        self._check_fitted()
        return cast(SloshingModel, self.model_)

    # -- persistence --------------------------------------------------------------------------
    @float64
    def save(self, path: str | Path) -> Path:
        """Write the fitted model to a ``.npz`` file atomically (no pickle).

        The file holds the class's parameter arrays and a JSON string ``metadata`` (format
        version, class, sloshrom version, hyperparameters, fs, units, variable names, scaler,
        envelope, history, checksum); docs/formats.md, "Model files". The metadata is checked
        against the schema :func:`~sloshrom.rom.load_model` applies before anything is
        written, so a model that could not be loaded back is never saved.

        Raises
        ------
        ROMError
            A hyperparameter, the sample rate, the scaler or the envelope is outside the bounds of
            the model-file format, or the training history is too long to store; the message names
            the field and nothing is written.
        """
        self._check_fitted()
        arrays = {k: np.asarray(self.params_[k], dtype=np.float64)
                  for k in self.model_class.param_names()}
        return write_model_file(model_file_path(path),
                                self._metadata(self.model_class.format_version), arrays,
                                "model")

    def _metadata(self, version: int) -> dict[str, Any]:
        """The metadata of a single-model file (without its checksum)."""
        return {
            "format": "sloshrom-rom",
            "format_version": version,
            "class": type(self).__name__,
            "sloshrom_version": __version__,
            "hyperparameters": self.effective_params(),
            "fs": self.fs_,
            "units": {"input": self.units[0], "output": self.units[1]},
            "names": {"input": self.names[0], "output": self.names[1]},
            "scaler": self.scaler_.to_dict(),
            "envelope": self.envelope_,
            "history": self.history_,
        }
