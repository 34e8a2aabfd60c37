"""Ensembles of ROMs: K networks that differ only by the seed of their initialisation.

A trained network is one draw of a random initialisation: another seed gives another network,
with another validation error and another prediction. An :class:`Ensemble` trains K members of
one template estimator (:class:`~sloshrom.rom.NFIR`, :class:`~sloshrom.rom.NOE` or
:class:`~sloshrom.rom.NSS`) with seeds ``template.seed + k`` (or given seeds), in parallel
through the Dask machinery of the sweep (:func:`sloshrom.rom.parallel.run_tasks`). Its
prediction is the mean of the members' outputs; the spread of the members
(:meth:`Ensemble.member_predictions`, :meth:`Ensemble.member_errors`, :func:`spread`) shows how
much of a result is the network and how much the draw. :meth:`Ensemble.best_member` picks the
one member that does best on a validation record: training K seeds to keep the best single
network (``sloshrom train --seeds K``).

The ensemble is itself a sloshing model (:func:`sloshrom.models.is_jax_model`): its state is the
tuple of the members' states, its :meth:`~Ensemble.step` the mean of the members' steps, pure
JAX; it is a JAX pytree whose children are the members, so the coupled beam simulation runs it
in one ``lax.scan`` like a single network. Note that the coupled response of the ensemble (the
beam driven by the mean force) is not the mean of the members' coupled responses: the beam tests
(``sloshrom.pipeline.beam.coupled_model``) couple each member alone and average their
responses and damping estimates.

An ensemble is saved as one model file (:meth:`Ensemble.save`; docs/formats.md, "Model files",
ensemble variant) and loaded by :func:`sloshrom.rom.load_model`.
"""

from __future__ import annotations

import math
import os
import warnings
from collections.abc import Callable, Iterable, Sequence
from pathlib import Path
from typing import Any, ClassVar, Literal

import jax
import jax.numpy as jnp
import numpy as np
from numpy.typing import ArrayLike

from sloshrom import __version__
from sloshrom._threads import map_threads
from sloshrom.config import FILL_TOLERANCE
from sloshrom.models import check_envelope, envelope_quiet, envelope_union, model_input
from sloshrom.rom.base import Estimator, History, checked_past
from sloshrom.rom.epochs import EpochFile, EpochReport, epoch_reports
from sloshrom.rom.errors import (
    NotFittedError,
    ROMError,
    TrainingWarning,
    UnstableModelError,
    members_quiet,
)
from sloshrom.rom.family import check_training_fill, training_fills
from sloshrom.rom.modelfile import (
    MAX_MEMBERS,
    file_version,
    model_file_path,
    write_model_file,
)
from sloshrom.rom.network import MinMaxScaler, network_of
from sloshrom.rom.parallel import quiet_worker, run_tasks
from sloshrom.rom.registry import CLASSES

__all__ = ["Ensemble", "is_ensemble", "spread", "spread_text"]


def spread(values: Iterable[float]) -> dict[str, Any]:
    """Mean and standard deviation of a quantity over ensemble members, NaN ignored.

    Parameters
    ----------
    values : iterable of float
        One value per member (any unit; NaN marks a member without a value, e.g. unstable).

    Returns
    -------
    dict
        ``mean`` and ``std`` (the unit of the values; ``std`` with ``ddof=1`` when more than one
        value, 0.0 for one value, NaN for none), ``n`` (values that are not NaN) and ``values``
        (every value as a float, NaN included, in the given order).
    """
    vals = [float(v) for v in values]
    ok = np.array([v for v in vals if not math.isnan(v)], dtype=np.float64)
    n = int(ok.size)
    mean = float(np.mean(ok)) if n else math.nan
    std = float(np.std(ok, ddof=1)) if n > 1 else (0.0 if n == 1 else math.nan)
    return {"mean": mean, "std": std, "n": n, "values": vals}


def spread_text(values: Iterable[float], unit: str, fmt: str = "{:.3g}") -> str:
    """A quantity's spread over the members in words, for reports and consoles.

    Parameters
    ----------
    values : iterable of float
        One value per member (NaN: a member without a value, e.g. unstable), in ``unit``.
    unit : str
        Unit of the values, e.g. ``"N²"``.
    fmt : str
        Format of each number.

    Returns
    -------
    str
        ``"mean ± std unit (min a, max b, max/min r)"`` (:func:`spread`), followed by how many
        members have no value; ``"n/a"`` when none has one.
    """
    s = spread(values)
    ok = [v for v in s["values"] if not math.isnan(v)]
    if not ok:
        return "n/a"
    lo, hi = min(ok), max(ok)
    ratio = fmt.format(hi / lo) if lo > 0 else "n/a"
    missing = len(s["values"]) - len(ok)
    f = fmt.format
    return (f"{f(s['mean'])} ± {f(s['std'])} {unit} (min {f(lo)}, max {f(hi)}, max/min {ratio})"
            + (f", {missing} member{'s' if missing > 1 else ''} without a value" if missing
               else ""))


def is_ensemble(model: Any) -> bool:
    """True for an :class:`Ensemble`: a model with members whose spread can be reported."""
    return isinstance(model, Ensemble)


def _frozen(v: Any) -> Any:
    return tuple(_frozen(x) for x in v) if isinstance(v, list | tuple) else v


def _thawed(v: Any) -> Any:
    return [_thawed(x) for x in v] if isinstance(v, tuple) else v


def _signal(name: str, x: Any) -> np.ndarray:
    """A finite input of shape (n,) or (batch, n), float64."""
    a = np.asarray(x, dtype=np.float64)
    if a.ndim not in (1, 2):
        raise ROMError(f"{name} must have shape (n,) or (batch, n), got {a.shape}")
    if not np.all(np.isfinite(a)):
        raise ROMError(f"{name} contains NaN or inf (first at index {np.argmin(np.isfinite(a))})")
    return a


def _without_seed(params: dict[str, Any]) -> dict[str, Any]:
    return {k: v for k, v in params.items() if k != "seed"}


def _fit_member(
    item: tuple[int, int],
    u: np.ndarray,
    y: np.ndarray,
    val_u: np.ndarray,
    val_y: np.ndarray,
    cls: type,
    params: dict[str, Any],
    fs: float,
    fill: float | None = None,
    epochs_dir: str | None = None,
    validation_history: int = 0,
    parent: int | None = None,
) -> Any:
    """Train member ``k`` with ``seed`` (``item = (k, seed)``): a task of :func:`run_tasks`.

    ``epochs_dir``: where the member writes its latest epoch (:class:`~sloshrom.rom.epochs.
    EpochFile`), read by the parent process (:func:`~sloshrom.rom.epochs.epoch_reports`).
    ``parent``: the process id of :meth:`Ensemble.fit`'s caller; in any other process (a Dask
    worker's) the :class:`TrainingWarning` of a member is not shown."""
    quiet_worker(parent, TrainingWarning)  # Ensemble.fit says it once, from the histories
    k, seed = item
    model = cls(**params)
    model.set_params(seed=seed)
    validation = (val_u, val_y) if val_u.size else None
    callback = EpochFile(epochs_dir, k) if epochs_dir is not None else None
    return model.fit(u, y, fs=fs, validation=validation, callback=callback, fill=fill,
                     validation_history=validation_history)


def _fill_said(rng: tuple[float, float] | None) -> str:
    if rng is None:
        return "records no fill"
    lo, hi = rng
    return f"was identified at fill {lo:.1%}" + ("" if hi - lo < 1e-12 else f" to {hi:.1%}")


def _one_fill(members: Sequence[object]) -> None:
    """ROMError naming the first member identified at another fill than member 0 (beyond
    :data:`~sloshrom.config.FILL_TOLERANCE`), or with a fill beside one without.

    An ensemble is the mean of models of one tank at one fill (``fit`` gives every member the
    same ``fill``), not a blend: its envelope's fill range is the union of the members', so a
    member at 30 % beside one at 50 % would pass a fill check at either.
    """
    ref = training_fills(members[0])
    for k, m in enumerate(members[1:], 1):
        rng = training_fills(m)
        if (rng is None) != (ref is None) or (
                rng is not None and ref is not None
                and max(abs(rng[0] - ref[0]), abs(rng[1] - ref[1])) > FILL_TOLERANCE):
            raise ROMError(
                f"ensemble member {k} {_fill_said(rng)}, member 0 {_fill_said(ref)}: the members "
                "of an ensemble are identified at one fill (their mean at two fills is a model "
                "of neither; a fill family blends fills)")


@jax.tree_util.register_pytree_node_class
class Ensemble:
    """K ROMs of one template that differ by their seed; predicts the mean of the members.

    Parameters
    ----------
    template : NFIR, NOE or NSS
        The estimator every member is cloned from (``type(template)(**template.get_params())``
        with ``seed`` set), so every hyperparameter of the template, present or future, is the
        members'. Not fitted itself.
    n_members : int
        Number of members K (1 to :data:`~sloshrom.rom.modelfile.MAX_MEMBERS`).
    seeds : sequence of int, optional
        The members' seeds, K distinct integers >= 0; default ``template.seed + k``,
        k = 0..K-1.

    Attributes
    ----------
    members_ : list of NFIR, NOE or NSS
        The fitted members, in the order of the seeds.
    seeds_ : list of int
        The members' seeds.
    fs_ : float
        Sample rate, Hz (the members').
    scaler_ : MinMaxScaler
        Union of the members' scaler bounds (identical bounds when trained on the same data).
    envelope_ : dict
        Union of the members' training envelopes (input and output ranges in their units,
        frequency band in Hz).
    history_ : list of dict
        Each member's training history.

    Notes
    -----
    Parameters are checked by :meth:`fit`, not by the constructor (scikit-learn convention).
    """

    #: the force at sample k is the force at t_k (energy integrals: trapezoid rule)
    force_rule: ClassVar[Literal["trapezoid"]] = "trapezoid"
    #: step is a pure JAX function and a fitted ensemble is a pytree (sloshrom.models.is_jax_model)
    jax_traceable: ClassVar[Literal[True]] = True

    def __init__(self, template: Any, n_members: int = 5, seeds: Sequence[int] | None = None
                 ) -> None:
        self.template = template
        self.n_members = n_members
        self.seeds = seeds

    # -- hyperparameters ----------------------------------------------------------------------
    def get_params(self, deep: bool = True) -> dict[str, Any]:
        """``template``, ``n_members``, ``seeds``; with ``deep`` also ``template__<name>``."""
        out: dict[str, Any] = {"template": self.template, "n_members": self.n_members,
                               "seeds": None if self.seeds is None else list(self.seeds)}
        if deep and hasattr(self.template, "get_params"):
            out.update({f"template__{k}": v for k, v in self.template.get_params().items()})
        return out

    def set_params(self, **params: Any) -> Ensemble:
        """Set ``template``, ``n_members``, ``seeds`` or ``template__<name>``; returns self.

        Raises
        ------
        ROMError
            An unknown name.
        """
        for k, v in params.items():
            if k.startswith("template__"):
                self.template.set_params(**{k.removeprefix("template__"): v})
            elif k in ("template", "n_members", "seeds"):
                setattr(self, k, v)
            else:
                raise ROMError(f"Ensemble has no parameter {k!r} (valid: template, n_members, "
                               "seeds, template__<name>)")
        return self

    def _member_seeds(self) -> list[int]:
        """Validated template, K and seeds; the seeds of the members."""
        t = self.template
        if not all(hasattr(t, a) for a in ("get_params", "set_params", "fit", "step",
                                           "check_training")) or \
                "seed" not in t.get_params():
            seeded = ", ".join(mc.class_name for mc in CLASSES.values() if mc.ensemble)
            raise ROMError(f"template must be an unfitted estimator whose members differ by "
                           f"their seed ({seeded}), got {type(t).__name__}")
        k = self.n_members
        if isinstance(k, bool) or not isinstance(k, int | np.integer) or not \
                1 <= k <= MAX_MEMBERS:
            raise ROMError(f"n_members must be an integer in 1..{MAX_MEMBERS}, got {k!r}")
        if self.seeds is None:
            base = t.get_params()["seed"]
            if isinstance(base, bool) or not isinstance(base, int) or base < 0:
                raise ROMError(f"template seed must be an integer >= 0, got {base!r}")
            return [base + i for i in range(int(k))]
        seeds = list(self.seeds)
        if any(isinstance(s, bool) or not isinstance(s, int | np.integer) or s < 0
               for s in seeds):
            raise ROMError(f"seeds must be integers >= 0, got {seeds!r}")
        if len(seeds) != k:
            raise ROMError(f"seeds lists {len(seeds)} seeds for n_members = {k}")
        if len(set(seeds)) != len(seeds):
            raise ROMError(f"seeds must be distinct (equal seeds train equal members), got "
                           f"{seeds!r}")
        return [int(s) for s in seeds]

    def _clone(self, seed: int) -> Any:
        t = self.template
        return type(t)(**t.get_params()).set_params(seed=seed)

    # -- training -----------------------------------------------------------------------------
    def fit(
        self,
        u: Any,
        y: Any,
        fs: float,
        validation: tuple[Any, Any] | None = None,
        *,
        scheduler: str | None = None,
        n_workers: int = 2,
        progress: Callable[[int, Any], Any] | None = None,
        fill: float | None = None,
        epoch_progress: EpochReport | None = None,
        validation_history: int = 0,
        started: Callable[[], object] | None = None,
    ) -> Ensemble:
        """Train the K members on the same record, in parallel.

        Parameters
        ----------
        u, y : array_like, shape (n,)
            Input (e.g. tank vertical velocity, m/s) and output (e.g. dynamic force, N),
            sampled at ``fs``, starting at rest.
        fs : float
            Sample rate, Hz.
        validation : (u_val, y_val), optional
            Validation record (early stopping of every member).
        scheduler : str, optional
            ``None``: a new Dask ``LocalCluster(n_workers)``; ``"threads"``, ``"sequential"``;
            or the address of a running Dask scheduler (:func:`sloshrom.rom.parallel.run_tasks`).
        n_workers : int
            Processes (LocalCluster) or threads.
        progress : callable, optional
            ``progress(k, member)`` as member k finishes.
        fill : float, optional
            Fill level d/h (-) of the training record, recorded in every member's envelope
            (:meth:`sloshrom.rom.NFIR.fit`).
        epoch_progress : callable, optional
            ``epoch_progress(k, epoch, info)`` with member k's latest epoch and its training
            callback's ``info`` (``train_mse``, ``val_mse``, ``seconds``, ...), about once a
            second per member, from a thread of this process (:func:`sloshrom.rom.epochs.
            epoch_reports`: the members, in worker processes or not, write it to files). A
            worker on another machine reports nothing before its member finishes.
        validation_history : int
            The validation record's first samples taken as measured history by every member
            (:meth:`sloshrom.rom.NSS.fit`); 0: from rest.
        started : callable, optional
            ``started()`` once the members are handed to the workers (a new LocalCluster's
            placed on their cores): :func:`sloshrom.rom.parallel.run_tasks`.

        Returns
        -------
        self

        Raises
        ------
        ROMError
            A bad template, K or seeds; more weights than a model file holds (K x the
            network's, checked before training); any error of the members' ``fit`` (bad
            record, ...).
        UnstableModelError
            An NOE member unstable at its initial parameters.

        Warns
        -----
        TrainingWarning
            Once, naming the members whose Levenberg-Marquardt stopped at ``mu_max`` (each
            member's ``history_["stop_message"]`` says why).
        """
        seeds = self._member_seeds()
        # every rule of the class before any member trains: K members in one file (its weight
        # limit before K trainings, not at save time), the cost of an epoch, the record's length
        self.template.check_training(int(np.size(u)), members=len(seeds))
        if not (np.isfinite(fs) and fs > 0):
            raise ROMError(f"fs must be a finite positive sample rate in Hz, got {fs!r}")
        u = np.asarray(u, dtype=np.float64)
        y = np.asarray(y, dtype=np.float64)
        if validation is None:
            vu = vy = np.empty(0)
        else:
            vu = np.asarray(validation[0], dtype=np.float64)
            vy = np.asarray(validation[1], dtype=np.float64)
            if vu.size == 0:
                raise ROMError("validation record is empty")
        fill = check_training_fill(fill)
        # said once below for all the members: in this process through a context variable
        # (the "threads" scheduler's threads run in a copy of this context), not a warnings
        # filter, which is the whole process's and would silence a model that a thread of the
        # caller trains beside them; members in other processes are quiet there (_fit_member)
        token = members_quiet.set(True)
        try:
            with epoch_reports(epoch_progress) as epochs_dir:
                members = run_tasks(
                    _fit_member, list(enumerate(seeds)), shared=(u, y, vu, vy),
                    args=(type(self.template), self.template.get_params(), float(fs), fill,
                          epochs_dir, int(validation_history), os.getpid()),
                    scheduler=scheduler, n_workers=n_workers,
                    done=None if progress is None else progress, started=started,
                )
        finally:
            members_quiet.reset(token)
        self._set_members(members)
        stuck = [k for k, h in enumerate(self.history_) if h.get("stop_reason") == "mu_max"]
        if stuck:
            warnings.warn(TrainingWarning(
                f"{len(stuck)} of {len(seeds)} members (seed{'s' if len(stuck) > 1 else ''} "
                f"{', '.join(str(self.seeds_[k]) for k in stuck)}) stopped with "
                "Levenberg-Marquardt's damping at mu_max: no step lowered their training error "
                "(history_[k]['stop_message'] says why for member k). First: "
                f"{self.history_[stuck[0]].get('stop_message', '')}"), stacklevel=2)
        return self

    @classmethod
    def from_members(cls, members: Sequence[Any], template: Any = None) -> Ensemble:
        """An ensemble of already fitted members (same class and hyperparameters but the seed).

        Parameters
        ----------
        members : sequence of NFIR, NOE or NSS
            Fitted, distinct seeds, same sample rate.
        template : NFIR, NOE or NSS, optional
            Default: an unfitted clone of the first member.

        Raises
        ------
        ROMError
            No member, too many, a member not fitted, of another class, other hyperparameters,
            another sample rate, or a repeated seed.
        """
        members = list(members)
        if not 1 <= len(members) <= MAX_MEMBERS:
            raise ROMError(f"an ensemble has 1 to {MAX_MEMBERS} members, got {len(members)}")
        if template is None:
            m0 = members[0]
            template = type(m0)(**m0.get_params())
        obj = cls(template, n_members=len(members),
                  seeds=[int(m.get_params()["seed"]) for m in members])
        obj._member_seeds()
        obj._set_members(members)
        return obj

    def _set_members(self, members: list[Any]) -> None:
        t = self.template
        ref = _without_seed(t.get_params())
        for k, m in enumerate(members):
            if type(m) is not type(t):
                raise ROMError(f"member {k} is a {type(m).__name__}, the template a "
                               f"{type(t).__name__}")
            try:
                fitted = network_of(m) is not None
            except NotFittedError:
                fitted = False
            if not fitted:
                raise ROMError(f"member {k} is not fitted")
            if _without_seed(m.get_params()) != ref:
                diff = sorted(n for n, v in _without_seed(m.get_params()).items()
                              if ref.get(n) != v)
                raise ROMError(f"member {k} differs from the template in {', '.join(diff)}")
        fs = {float(m.fs_) for m in members}
        if len(fs) != 1:
            raise ROMError(f"members sampled at different rates: {sorted(fs)} Hz")
        _one_fill(members)
        self.members_ = list(members)
        self.seeds_ = [int(m.get_params()["seed"]) for m in members]
        self.fs_ = fs.pop()
        sc = [m.scaler_ for m in members]
        self.scaler_ = MinMaxScaler(min(float(s.in_min) for s in sc),
                                    max(float(s.in_max) for s in sc),
                                    min(float(s.out_min) for s in sc),
                                    max(float(s.out_max) for s in sc))
        env = envelope_union(members)
        if env is not None:
            self.envelope_ = env
        self.history_ = [m.history_ for m in members]

    # -- description --------------------------------------------------------------------------
    def _check_fitted(self) -> None:
        if not hasattr(self, "members_"):
            raise NotFittedError("this Ensemble is not fitted: call fit() first")

    @property
    def member_class(self) -> str:
        """Class name of the members (``"NFIR"`` or ``"NOE"``)."""
        return type(self.template).__name__

    @property
    def units(self) -> tuple[str, str]:
        """Units of the input and the output (the template's)."""
        return tuple(self.template.units)

    @property
    def names(self) -> tuple[str, str]:
        """Variable names of the input and the output (the template's)."""
        return tuple(self.template.names)

    @property
    def input(self) -> str:
        """The signal the members read (:func:`sloshrom.models.input_of`)."""
        return self.template.input

    @property
    def max_delay(self) -> int:
        """Longest input delay of the members, samples."""
        return int(self.template.max_delay)

    @property
    def n_params(self) -> int:
        """Parameters of all members together."""
        return int(self.template.n_params) * len(self._seeds_or_fitted())

    def _seeds_or_fitted(self) -> list[int]:
        return self.seeds_ if hasattr(self, "seeds_") else self._member_seeds()

    @property
    def dt(self) -> float:
        """Model time step = ``1/fs_``, s."""
        self._check_fitted()
        return 1.0 / self.fs_

    # -- pytree (members are the children, the template's hyperparameters static) -------------
    def tree_flatten(self) -> tuple[tuple[Any, ...], tuple[Any, ...]]:
        """JAX pytree: the members as the children, the template and seeds static."""
        children = tuple(self.members_) if hasattr(self, "members_") else ()
        seeds = getattr(self, "seeds_", self.seeds)
        aux = (type(self.template), _frozen(list(self.template.get_params().items())),
               self.n_members, None if seeds is None else tuple(int(s) for s in seeds),
               getattr(self, "fs_", None))
        return children, aux

    @classmethod
    def tree_unflatten(cls, aux: tuple[Any, ...], children: tuple[Any, ...]) -> Ensemble:
        """JAX pytree: the ensemble of this template, seeds and members."""
        tcls, hyper, n, seeds, fs = aux
        obj = cls(tcls(**{k: _thawed(v) for k, v in hyper}), n_members=n,
                  seeds=None if seeds is None else list(seeds))
        if children:
            # rebuilt inside jit or a gradient: the network and scalers only (no envelope)
            obj.members_ = list(children)
            obj.seeds_ = list(seeds)
            obj.fs_ = fs
        return obj

    # -- prediction ---------------------------------------------------------------------------
    @property
    def history_samples(self) -> int:
        """Samples of measured history a start from it reads: the most any member reads."""
        self._check_fitted()
        return max(int(m.history_samples) for m in self.members_)

    def _outputs(self, u: Any, stacklevel: int, history: History | None = None
                 ) -> np.ndarray:
        self._check_fitted()
        u = _signal("u", u)
        if history is not None:
            up, yp = checked_past(history)
            check_envelope(self, np.concatenate([up, np.ravel(u)]), unit=str(self.units[0]),
                           stacklevel=stacklevel)
        else:
            check_envelope(self, u, unit=str(self.units[0]), stacklevel=stacklevel)
        with envelope_quiet():  # warned once above, for the union of the envelopes
            # each member's run alone, a core each
            return np.stack(map_threads(lambda m: np.asarray(m.predict(u, history=history)),
                                        self.members_))

    def member_predictions(self, u: Any, history: History | None = None) -> np.ndarray:
        """Every member's output from rest, or from measured history (for spread bands).

        Parameters
        ----------
        u : array_like, shape (n,) or (batch, n)
            Input sampled at ``fs_`` (physical units, e.g. m/s).
        history : (u_past, y_past), optional
            Measured input and output before ``u`` (:meth:`sloshrom.rom.NSS.predict`).

        Returns
        -------
        ndarray, shape (K, n) or (K, batch, n)
            Output of member k in row k (physical units, e.g. N), float64.

        Raises
        ------
        NotFittedError
            The ensemble is not fitted.
        ROMError
            ``u`` of another shape, or with NaN or inf.
        UnstableModelError
            An NOE member whose simulation left its stability bound.

        Warns
        -----
        EnvelopeWarning
            ``u`` leaves the union of the members' training input ranges (once per call).
        """
        return self._outputs(u, stacklevel=3, history=history)

    def predict(self, u: Any, history: History | None = None) -> np.ndarray:
        """Mean of the members' outputs from rest (or from measured ``history``); does not
        change the ensemble.

        Parameters, errors and warnings as :meth:`member_predictions`.

        Returns
        -------
        ndarray, same shape as ``u``
            Output (physical units, e.g. N), float64.
        """
        return np.mean(self._outputs(u, stacklevel=3, history=history), axis=0)

    def member_errors(self, u: ArrayLike, y: ArrayLike, history: History | None = None
                      ) -> np.ndarray:
        """Each member's mean squared error on a record: its free run over the whole record,
        from rest or from measured ``history``, as early stopping scored it on the validation
        record.

        Parameters
        ----------
        u : array_like, shape (n,)
            Input sampled at ``fs_`` (physical units, e.g. m/s), starting at rest unless
            ``history`` is given.
        y : array_like, shape (n,)
            Measured output (physical units, e.g. N).
        history : (u_past, y_past), optional
            Measured input and output just before ``u``: every member starts from them
            (:meth:`predict`); the error is over ``u`` only.

        Returns
        -------
        ndarray, shape (K,)
            MSE of member k (output units squared, e.g. N^2), float64; NaN for a member whose
            simulation left its stability bound (an NOE).

        Raises
        ------
        NotFittedError
            The ensemble is not fitted.
        ROMError
            ``u`` or ``y`` not 1-D, of different lengths, or with NaN or inf; a bad
            ``history``.

        Warns
        -----
        EnvelopeWarning
            ``u`` (with the history's input) leaves the union of the members' training input
            ranges (once per call).
        """
        return self._errors(u, y, history, stacklevel=3)

    def _errors(self, u: ArrayLike, y: ArrayLike, history: History | None, stacklevel: int
                ) -> np.ndarray:
        self._check_fitted()
        u, y = _signal("u", u), _signal("y", y)
        if u.ndim != 1 or y.shape != u.shape:
            raise ROMError(f"u and y must be records of the same length, shape (n,), got "
                           f"{u.shape} and {y.shape}")
        seen = u if history is None else np.concatenate([checked_past(history)[0], u])
        check_envelope(self, seen, unit=str(self.units[0]), stacklevel=stacklevel)

        def error(m: Estimator) -> float:
            try:
                yh = np.asarray(m.predict(u, history=history))
                return float(np.mean((yh - y) ** 2))
            except UnstableModelError:  # no error to rank: never the best
                return math.nan

        with envelope_quiet():  # warned once above, for the union of the envelopes
            return np.asarray(map_threads(error, self.members_), dtype=np.float64)

    def best_member(self, u: ArrayLike, y: ArrayLike, history: History | None = None
                    ) -> Estimator:
        """The member with the lowest :meth:`member_errors` on a (validation) record.

        A normal single model (NFIR, NOE or NSS, fitted): ``save`` writes a single-model file
        and its ``seed`` is the one that trained it. Choose it on a validation record, not on
        the training record: on the training record the lowest error rewards over-fitting.

        Parameters
        ----------
        u, y : array_like, shape (n,)
            Input and measured output, as :meth:`member_errors`.
        history : (u_past, y_past), optional
            Measured history before ``u``, as :meth:`member_errors`.

        Returns
        -------
        NFIR, NOE or NSS
            The best member (the first of equal errors).

        Raises
        ------
        NotFittedError
            The ensemble is not fitted.
        ROMError
            Bad records (as :meth:`member_errors`), or every member unstable on them.
        """
        errors = self._errors(u, y, history, stacklevel=3)
        if np.all(np.isnan(errors)):
            raise ROMError(f"all {errors.size} members are unstable on this record: none is best")
        return self.members_[int(np.nanargmin(errors))]

    def simulate(self, velocity: Any, acceleration: Any = None) -> np.ndarray:
        """Sloshing-model contract: dynamic force (N) from the signal the members read
        (:attr:`input`)."""
        return self.predict(model_input(self, velocity, acceleration))

    def init_state(self) -> tuple[Any, ...]:
        """The members' states at rest, a tuple (a pytree of arrays)."""
        self._check_fitted()
        return tuple(m.init_state() for m in self.members_)

    def step(self, state: Any, velocity: Any, acceleration: Any = None) -> tuple[Any, Any]:
        """One pure, jax-traceable step: ``(state, mean of the members' dynamic forces)``.

        ``state`` is the tuple of the members' states (:meth:`init_state`); each member reads
        its weights from its pytree leaves (see :meth:`sloshrom.rom.NFIR.step`).
        """
        new, forces = [], []
        for m, s in zip(self.members_, state, strict=True):
            s, f = m.step(s, velocity, acceleration)
            new.append(s)
            forces.append(f)
        return tuple(new), jnp.mean(jnp.stack(forces), axis=0)

    # -- persistence --------------------------------------------------------------------------
    def save(self, path: str | Path) -> Path:
        """Write the fitted ensemble to ONE ``.npz`` model file atomically (no pickle).

        Ensemble variant of the model-file format (docs/formats.md, "Model files"): the
        members' ``W``, ``b``, ``c``, ``c0`` stacked on a leading member axis and a JSON
        ``metadata`` with the member class, the shared hyperparameters, ``n_members`` and per
        member its seed, scaler, envelope and history. Checked against the schema
        :func:`sloshrom.rom.load_model` applies before anything is written.

        Returns
        -------
        Path
            The file written (``.npz`` appended to another suffix).

        Raises
        ------
        NotFittedError
            The ensemble is not fitted.
        ROMError
            A value outside the bounds of the model-file format (the message names the field);
            nothing is written.
        """
        self._check_fitted()
        p = model_file_path(path)
        t = self.template
        hyper = t.get_params()
        # the members' hyperparameters (an NSS's size chosen by its fit), the template's seed
        members = {**self.members_[0].effective_params(), "seed": hyper["seed"]}
        mc = t.model_class
        meta = {
            "format": "sloshrom-rom",
            "format_version": file_version(mc, ensemble=True),
            "class": "Ensemble",
            "sloshrom_version": __version__,
            "member_class": self.member_class,
            "hyperparameters": members,
            "n_members": len(self.members_),
            "fs": self.fs_,
            "units": {"input": hyper["units"][0], "output": hyper["units"][1]},
            "names": {"input": hyper["names"][0], "output": hyper["names"][1]},
            "members": [{"seed": s, "scaler": m.scaler_.to_dict(), "envelope": m.envelope_,
                         "history": m.history_}
                        for s, m in zip(self.seeds_, self.members_, strict=True)],
        }
        arrays = {k: np.stack([np.asarray(m.params_[k], dtype=np.float64)
                               for m in self.members_]) for k in mc.param_names()}
        return write_model_file(p, meta, arrays, "ensemble")
