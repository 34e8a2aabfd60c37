"""One sloshing model for every fill level: ROMs identified at a few fills, blended in between.

A ROM identified on records at one fill level knows that fill only: the liquid mass, the depth
and the ullage gap the liquid impacts across all change with it (docs/rig.md, "Fill level").
:class:`FillFamily` holds ROMs identified at several fills (the pipeline trains them at 25, 50
and 75 %) and gives, at any fill between the first and the last, a :class:`FillBlend` that
predicts the convex combination of its two neighbours' dynamic forces,

    dF(alpha) = (1 - w) dF_lo + w dF_hi,   w = (alpha - alpha_lo) / (alpha_hi - alpha_lo).

Why the force (N) and not the force per liquid mass: the dissipated energy per cycle is linear
in the force, so the blend's Phi_d map is the same blend of the members' energies; on the
virtual rig, blending the 25/50 % and 50/75 % energies predicts the maps at 37.5 and 62.5 % to
8.4 and 12.5 % (full-map relative L2), against 12.2 and 12.0 % for blending Phi_d (energy per
liquid mass) and 29-47 % for the nearest trained fill (docs/rom.md, "Fill levels"). The weights
are >= 0, so a blend of passive members is passive.

Every model records the fill range it was identified on in ``envelope_`` (``fill_min``,
``fill_max``; :meth:`sloshrom.rom.NFIR.fit` ``fill=``); :func:`check_fill` refuses a fill
outside it (with :data:`FILL_TOLERANCE`) and :func:`at_fill` turns any model into the sloshing
model for a given fill.

Family files are TOML manifests that name the member model files (never code):

.. code-block:: toml

    [fill_family]
    format_version = 1

    [[fill_family.member]]
    fill = 0.25
    model = "fill_25/models/nfir.npz"   # relative to this file
"""

from __future__ import annotations

import math
import tomllib
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any

import jax
import numpy as np
from numpy.typing import ArrayLike

from sloshrom.config import FILL_TOLERANCE
from sloshrom.fileio import atomic_write_text, not_a_regular_file
from sloshrom.models import envelope_of, envelope_union, input_of, is_jax_model
from sloshrom.rom.errors import FillRangeError, ROMError

__all__ = [
    "FILL_TOLERANCE",
    "FillBlend",
    "FillFamily",
    "at_fill",
    "check_fill",
    "check_training_fill",
    "read_family",
    "training_fills",
    "write_family",
]

FAMILY_FORMAT_VERSION = 1


def check_training_fill(fill: Any) -> float | None:
    """``fill`` as a float in (0, 1), or ``None``; ROMError otherwise."""
    if fill is None:
        return None
    try:
        f = float(fill)
    except (TypeError, ValueError):
        raise ROMError(f"fill must be a number in (0, 1) (liquid depth / tank height), "
                       f"got {fill!r}") from None
    if not (math.isfinite(f) and 0.0 < f < 1.0):
        raise ROMError(f"fill must be in (0, 1) (liquid depth / tank height), got {fill!r}")
    return f


def training_fills(model: Any) -> tuple[float, float] | None:
    """``(fill_min, fill_max)`` (-) a model was identified on, or ``None`` if it does not say.

    A family, a blend and a physics model tied to one tank (the bouncing ball: its tank's fill)
    say it by ``fill_range``; a network in its envelope (``fill_min``/``fill_max``).
    """
    rng = getattr(model, "fill_range", None)  # capability: models that span fills say so
    if isinstance(rng, tuple) and len(rng) == 2:
        return float(rng[0]), float(rng[1])
    env = envelope_of(model)
    if env is not None and env.fill_min is not None and env.fill_max is not None:
        return env.fill_min, env.fill_max
    return None


def check_fill(model: Any, fill: float, what: str = "the model") -> None:
    """Refuse a fill level outside the range ``model`` was identified on.

    Parameters
    ----------
    model : sloshing model or FillFamily
        A model without a recorded fill range (older files, models fitted without ``fill``)
        passes.
    fill : float
        Fill level d/h, in (0, 1).
    what : str
        How the message names the model (e.g. its file).

    Raises
    ------
    FillRangeError
        ``fill`` lies outside ``[fill_min, fill_max]`` by more than :data:`FILL_TOLERANCE`.
    """
    f = check_training_fill(fill)
    rng = training_fills(model)
    if rng is None or f is None:
        return
    lo, hi = rng
    if f < lo - FILL_TOLERANCE or f > hi + FILL_TOLERANCE:
        trained = f"{lo:.1%}" if hi - lo < 1e-12 else f"{lo:.1%} to {hi:.1%}"
        raise FillRangeError(
            f"{what} was identified at fill {trained}; fill {f:.1%} is outside that range "
            f"(tolerance {FILL_TOLERANCE:.1%}): identify a model at this fill or use a fill "
            "family that spans it")


def at_fill(model: Any, fill: float | None, what: str = "the model") -> Any:
    """The sloshing model of ``model`` at ``fill``: a family's blend, any other model itself.

    ``fill=None`` keeps a single model as it is and is refused for a family (which needs one).
    Raises :class:`~sloshrom.rom.errors.FillRangeError` as :func:`check_fill`.
    """
    if isinstance(model, FillFamily):
        if fill is None:
            raise FillRangeError(f"{what} is a fill family ({model.describe()}): give the fill "
                                 "level to run it at")
        return model.at(fill, what)
    if fill is not None:
        check_fill(model, fill, what)
    return model


def _same_input(models: Sequence[Any]) -> None:
    kinds = {input_of(m) for m in models}
    if len(kinds) != 1:
        raise ROMError(f"members read different inputs {sorted(kinds)}")


@jax.tree_util.register_pytree_node_class
class FillBlend:
    """Convex blend of sloshing models identified at neighbouring fill levels.

    Sloshing-model contract (:class:`sloshrom.models.SloshingModel`); a JAX pytree whose children
    are the members, so it runs on the coupled simulation's JAX backend when they do.

    Parameters
    ----------
    members : sequence of sloshing models
        Same step ``dt`` and force rule.
    weights : sequence of float
        Non-negative, summing to 1.
    fill : float
        The fill level d/h it stands for (-).
    fill_range : (float, float)
        The fills of the members it blends (-).
    """

    def __init__(self, members: Sequence[Any], weights: Sequence[float], fill: float,
                 fill_range: tuple[float, float]) -> None:
        self.members = tuple(members)
        self.weights = tuple(float(w) for w in weights)
        if len(self.members) != len(self.weights) or not self.members:
            raise ROMError("a blend needs one weight per member")
        if min(self.weights) < 0 or abs(sum(self.weights) - 1.0) > 1e-12:
            raise ROMError(f"blend weights must be >= 0 and sum to 1, got {self.weights}")
        dts = {float(m.dt) for m in self.members}
        if max(dts) - min(dts) > 1e-12 * max(dts):
            raise ROMError(f"members run at different steps {sorted(dts)} s")
        rules = {m.force_rule for m in self.members}
        if len(rules) != 1:
            raise ROMError(f"members use different force rules {sorted(rules)}")
        _same_input(self.members)
        self.dt = float(self.members[0].dt)
        self.force_rule = rules.pop()
        # traceable (JAX backend of the coupled simulation) when every member is
        self.jax_traceable = all(is_jax_model(m) for m in self.members)
        self.fill = float(fill)
        self.fill_range = (float(fill_range[0]), float(fill_range[1]))
        env = envelope_union(self.members)
        if env is not None:
            env["fill_min"], env["fill_max"] = self.fill_range
            self.envelope_ = env

    def tree_flatten(self) -> tuple[tuple[Any, ...], tuple[Any, ...]]:
        """JAX pytree: the members as the children, weights and fills static."""
        return self.members, (self.weights, self.fill, self.fill_range)

    @classmethod
    def tree_unflatten(cls, aux: tuple[Any, ...], children: tuple[Any, ...]) -> FillBlend:
        """JAX pytree: the blend of these members, weights and fills."""
        obj = object.__new__(cls)
        obj.members = tuple(children)
        obj.weights, obj.fill, obj.fill_range = aux
        obj.dt = float(children[0].dt)
        obj.force_rule = children[0].force_rule
        obj.jax_traceable = True  # rebuilt inside a JAX transformation
        return obj

    @property
    def fs_(self) -> float:
        """Sample rate of the members, Hz."""
        return 1.0 / self.dt

    @property
    def units(self) -> tuple[str, str]:
        """Units of the input and the output (the first member's; members agree)."""
        return tuple(self.members[0].units)

    @property
    def names(self) -> tuple[str, str]:
        """Variable names of the input and the output (the first member's)."""
        return tuple(self.members[0].names)

    @property
    def input(self) -> str:
        """The signal the members read (:func:`sloshrom.models.input_of`)."""
        return input_of(self.members[0])

    def init_state(self) -> tuple[Any, ...]:
        """The members' states at rest."""
        return tuple(m.init_state() for m in self.members)

    def step(self, state: Any, velocity: Any, acceleration: Any = None) -> tuple[Any, Any]:
        """One pure step: ``(states, sum_k w_k dF_k)`` (N)."""
        new, force = [], 0.0
        for m, s, w in zip(self.members, state, self.weights, strict=True):
            s, f = m.step(s, velocity, acceleration)
            new.append(s)
            force = force + w * f
        return tuple(new), force

    def simulate(self, velocity: Any, acceleration: Any = None) -> np.ndarray:
        """Dynamic force (N) of the blend over whole records (``(..., n)``, sampled at 1/dt)."""
        out = None
        for m, w in zip(self.members, self.weights, strict=True):
            if w == 0.0:
                continue
            f = w * np.asarray(m.simulate(velocity, acceleration), dtype=np.float64)
            out = f if out is None else out + f
        return out

    @property
    def history_samples(self) -> int:
        """Samples of measured history a start from it reads: the most any member reads."""
        return max(int(m.history_samples) for m in self.members)

    def predict(self, u: Any, history: tuple[ArrayLike, ArrayLike] | None = None
                ) -> np.ndarray:
        """:meth:`simulate` of the input ``u`` alone (velocity-input members), or the blend of
        the members' runs from measured ``history`` (:meth:`sloshrom.rom.NSS.predict`)."""
        if history is None:
            return self.simulate(u, None)
        out = np.zeros(np.shape(u))
        for m, w in zip(self.members, self.weights, strict=True):
            if w != 0.0:
                out = out + w * np.asarray(m.predict(u, history=history), dtype=np.float64)
        return out

    def __repr__(self) -> str:
        return (f"FillBlend(fill={self.fill:.3f}, weights={self.weights}, "
                f"members={[type(m).__name__ for m in self.members]})")


class FillFamily:
    """Sloshing models identified at several fill levels (a model conditioned on the fill).

    Parameters
    ----------
    template : estimator, optional
        Cloned for every fill by :meth:`fit` (``type(t)(**t.get_params(deep=False))``): an
        ``NFIR``, ``NOE`` or ``Ensemble``. Not needed for :meth:`from_members`.

    Attributes
    ----------
    fills_ : ndarray
        The members' fill levels d/h (-), increasing.
    members_ : list
        The fitted models, one per fill.
    """

    def __init__(self, template: Any = None) -> None:
        self.template = template

    def get_params(self, deep: bool = True) -> dict[str, Any]:
        """The constructor arguments by name (scikit-learn style)."""
        return {"template": self.template}

    def set_params(self, **params: Any) -> FillFamily:
        """Set the constructor arguments by name (only ``template``); returns self."""
        for k, v in params.items():
            if k != "template":
                raise ROMError(f"FillFamily has no parameter {k!r}")
            self.template = v
        return self

    def fit(self, records: Mapping[float, tuple[Any, Any, float, Any]]) -> FillFamily:
        """Identify one model per fill level.

        Parameters
        ----------
        records : mapping
            Fill level d/h (-) -> ``(u, y, fs, validation)``: input (m/s), output (N), sample
            rate (Hz) and the validation pair or ``None``, as the template's ``fit`` takes
            them. At least two fills.

        Returns
        -------
        self
        """
        if self.template is None:
            raise ROMError("FillFamily.fit needs a template estimator")
        t = self.template
        members = {}
        for fill, (u, y, fs, val) in records.items():
            m = type(t)(**t.get_params(deep=False))
            members[fill] = m.fit(u, y, fs, val, fill=fill)
        self._set_members(members)
        return self

    @classmethod
    def from_members(cls, members: Mapping[float, Any]) -> FillFamily:
        """A family of fitted models, keyed by the fill level they were identified at.

        Raises
        ------
        ROMError
            Fewer than two members, a fill outside (0, 1) or repeated, members with different
            steps or force rules, or a member whose recorded fill range disagrees with its key.
        """
        obj = cls()
        obj._set_members(dict(members))
        return obj

    def _set_members(self, members: dict[float, Any]) -> None:
        if len(members) < 2:
            raise ROMError(f"a fill family needs models at two fills at least, got {len(members)}")
        fills = [check_training_fill(f) for f in members]
        order = np.argsort(fills)
        fills_sorted = np.asarray(fills)[order]
        if np.any(np.diff(fills_sorted) < 2 * FILL_TOLERANCE):
            raise ROMError(f"fill levels {sorted(fills)} repeat (closer than "
                           f"{2 * FILL_TOLERANCE:.1%})")
        models = list(members.values())
        for f, m in zip(fills, models, strict=True):
            check_fill(m, f, f"the member at fill {f:.1%}")
        _same_input(models)
        dts = {float(m.dt) for m in models}
        if max(dts) - min(dts) > 1e-12 * max(dts):
            raise ROMError(f"the members run at different steps {sorted(dts)} s (resample the "
                           "records to one rate)")
        if len({m.force_rule for m in models}) != 1:
            raise ROMError("the members use different force rules")
        self.fills_ = fills_sorted
        self.members_ = [models[i] for i in order]

    @property
    def fill_range(self) -> tuple[float, float]:
        """``(first, last)`` fill level (-)."""
        return float(self.fills_[0]), float(self.fills_[-1])

    @property
    def dt(self) -> float:
        """The members' step, s."""
        return float(self.members_[0].dt)

    # the members' description, so that metadata is read alike from a family and a model
    @property
    def units(self) -> tuple[str, str]:
        """Units of the input and the output (the members')."""
        return tuple(self.members_[0].units)

    @property
    def names(self) -> tuple[str, str]:
        """Variable names of the input and the output (the members')."""
        return tuple(self.members_[0].names)

    @property
    def input(self) -> str:
        """The signal the members read (:func:`sloshrom.models.input_of`)."""
        return input_of(self.members_[0])

    def describe(self) -> str:
        """A one-line description: the fills of the members."""
        return "fills " + ", ".join(f"{f:.1%}" for f in self.fills_)

    def weights(self, fill: float) -> np.ndarray:
        """The blend weight of every member at ``fill`` (-): two neighbours, linear in fill."""
        f = float(np.clip(fill, self.fills_[0], self.fills_[-1]))
        w = np.zeros(self.fills_.size)
        k = int(np.clip(np.searchsorted(self.fills_, f, side="right") - 1, 0,
                        self.fills_.size - 2))
        t = (f - self.fills_[k]) / (self.fills_[k + 1] - self.fills_[k])
        w[k], w[k + 1] = 1.0 - t, t
        return w

    def at(self, fill: float, what: str = "the fill family") -> FillBlend:
        """The sloshing model at ``fill`` (:class:`FillBlend` of the two neighbouring members).

        Raises
        ------
        FillRangeError
            ``fill`` outside the members' fills (:func:`check_fill`).
        """
        check_fill(self, fill, what)
        w = self.weights(fill)
        keep = np.flatnonzero(w > 0.0)
        return FillBlend([self.members_[i] for i in keep], w[keep], float(fill),
                         self.fill_range)


def write_family(path: str | Path, members: Mapping[float, str | Path]) -> Path:
    """Write a family manifest (TOML) naming the member model files, atomically.

    Parameters
    ----------
    path : str or Path
        The ``.toml`` file.
    members : mapping
        Fill level d/h (-) -> model file. Paths inside the manifest's directory are written
        relative to it (the directory can move as a whole).
    """
    p = Path(path)
    if p.suffix != ".toml":
        raise ROMError(f"a fill family file must end in .toml, got {p.name}")
    lines = ["# sloshrom fill family: ROMs identified at these fill levels (d/h)",
             "[fill_family]", f"format_version = {FAMILY_FORMAT_VERSION}", ""]
    for fill in sorted(members):
        f = check_training_fill(fill)
        mp = Path(members[fill]).resolve()
        try:
            rel = mp.relative_to(p.resolve().parent).as_posix()
        except ValueError:
            rel = mp.as_posix()
        lines += ["[[fill_family.member]]", f"fill = {f!r}", f"model = {rel!r}".replace(
            "'", '"'), ""]
    return atomic_write_text(p, "\n".join(lines))


def read_family(path: str | Path, load: Callable[[Path], Any]) -> FillFamily:
    """Read a family manifest; ``load(member_path)`` loads each member model file.

    Raises
    ------
    ROMError
        Not TOML, no ``[fill_family]`` table, another format version, a member without
        ``fill``/``model`` or with a bad fill, a member file that does not exist or is itself a
        family, or members that disagree (:meth:`FillFamily.from_members`). The message names the
        file and the member.
    """
    p = Path(path)
    why = not_a_regular_file(p)
    if why is not None:  # a named pipe would block the open below
        raise ROMError(f"{p}: {why}")
    try:
        with p.open("rb") as fh:
            data = tomllib.load(fh)
    except FileNotFoundError:
        raise ROMError(f"{p}: no such file") from None
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
        raise ROMError(f"{p}: not a valid TOML fill-family file ({exc})") from None
    fam = data.get("fill_family")
    if not isinstance(fam, dict):
        raise ROMError(f"{p}: no [fill_family] table (not a sloshrom fill family)")
    if fam.get("format_version") != FAMILY_FORMAT_VERSION:
        raise ROMError(f"{p}: fill_family.format_version must be {FAMILY_FORMAT_VERSION}, got "
                       f"{fam.get('format_version')!r}")
    entries = fam.get("member")
    if not isinstance(entries, list) or not entries:
        raise ROMError(f"{p}: no [[fill_family.member]] entries")
    members: dict[float, Any] = {}
    for k, e in enumerate(entries):
        where = f"{p}: member {k + 1}"
        if not isinstance(e, dict) or set(e) != {"fill", "model"}:
            raise ROMError(f"{where}: needs exactly the keys fill and model")
        if isinstance(e["fill"], bool) or not isinstance(e["fill"], (int, float)):
            raise ROMError(f"{where}: fill must be a number in (0, 1), got {e['fill']!r}")
        try:
            fill = check_training_fill(e["fill"])
        except ROMError as exc:
            raise ROMError(f"{where}: {exc}") from None
        if not isinstance(e["model"], str) or not e["model"]:
            raise ROMError(f"{where}: model must be a file name")
        mp = Path(e["model"])
        mp = mp if mp.is_absolute() else p.parent / mp
        if mp.suffix == ".toml":
            raise ROMError(f"{where}: {mp.name} is a family file; members must be model files")
        why = not_a_regular_file(mp)
        if why is not None:
            raise ROMError(f"{where}: model file {mp} {why}")
        if not mp.is_file():
            raise ROMError(f"{where}: model file {mp} not found")
        if fill in members:
            raise ROMError(f"{where}: fill {fill!r} appears twice")
        members[fill] = load(mp)
    try:
        return FillFamily.from_members(members)
    except ROMError as exc:
        raise ROMError(f"{p}: {exc}") from None
