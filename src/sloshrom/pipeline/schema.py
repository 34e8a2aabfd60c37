"""The building blocks of the configuration's tables, shared by the settings and the studies.

A table of ``sloshrom reproduce``'s configuration is a :class:`Table` (a strict, frozen pydantic
model that remembers the order of its keys); its keys' domains are written as ``Annotated``
types whose metadata both bound the value and say, in an error message, what it must be:

* :func:`number` - a finite number (or an integer) in an interval;
* :func:`items` - a non-empty list (or a ``[low, high]`` pair) of such numbers, optionally of
  distinct values;
* :class:`Says` - what any other key must be, in words.

E.g. ``seed: Annotated[int, number(0, MAX_SEED, integer=True, what="a seed")]``: the settings
refuse ``seed = -1`` with ``'table.seed' must be a seed in [0, ...], got -1``.

A study beyond the paper declares its part of the configuration as a :class:`StudyTable`: its
own table, its keys of ``[beyond]``, their defaults (TOML text with comments) and their checks;
``sloshrom.pipeline.settings`` assembles the configuration from the registered studies'
(``sloshrom.pipeline.registry``). This module imports no study and no stage.
"""

from __future__ import annotations

import copy
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Annotated, Any

import annotated_types as at
from pydantic import AfterValidator, BaseModel, ConfigDict, Field, PrivateAttr, model_validator
from pydantic.types import AllowInfNan
from pydantic_core import PydanticCustomError

from sloshrom.limits import MAX_DELAY, MAX_NEURONS, MAX_SEED

if TYPE_CHECKING:  # the settings assemble their configuration from the studies' tables
    from sloshrom.pipeline.settings import ReproduceConfig

__all__ = ["Delays", "Items", "Neurons", "Number", "Says", "Seed", "StudyTable", "Table",
           "distinct_values", "fmt", "items", "no_config_check", "no_rig_fills", "number", "shown"]


def fmt(v: float) -> str:
    """A bound as a message prints it: an integer as such, a float in ``:g``."""
    return str(v) if isinstance(v, int) else f"{v:g}"


def shown(value: object) -> str:
    """A configuration value as a message quotes it: TOML's ``true``/``false`` said to be
    booleans (Python's ``True`` is also an integer, the confusion to avoid), else its repr."""
    if isinstance(value, bool):
        return f"{str(value).lower()} (a boolean)"
    return repr(value)


@dataclass(frozen=True)
class Says:
    """How a key is described in an error message: ``what`` it is, ``why`` (optional) and, for
    a list, what its ``item`` is (``None``: the item's own metadata say it)."""

    what: str
    why: str = ""
    item: Says | None = None

    def value(self, key: str, v: object) -> str:
        """The message of a value ``v`` of ``key`` that is not :attr:`what` it must be."""
        return (f"'{key}' must be {self.what}, got {shown(v)}"
                + (f" ({self.why})" if self.why else ""))


@dataclass(frozen=True)
class Number(Says, at.GroupedMetadata):
    """A finite number in an interval (:func:`number`): the bounds pydantic checks, and the
    message's words."""

    constraints: tuple[object, ...] = ()

    def __iter__(self) -> Iterator[object]:  # the constraints pydantic applies
        yield from self.constraints


def number(lo: float | None = None, hi: float | None = None, *, lo_open: bool = False,
           hi_open: bool = False, integer: bool = False, what: str = "a number",
           why: str = "") -> Number:
    """A finite number (an integer if ``integer``) in ``[lo, hi]`` (open ends on request), in
    the units ``what`` names; ``why`` says where the bounds come from."""
    ends = ("-inf" if lo is None else fmt(lo), "inf" if hi is None else fmt(hi))
    interval = f"{'(' if lo_open else '['}{ends[0]}, {ends[1]}{')' if hi_open else ']'}"
    text = f"{what} in {interval}"
    constraints: list[object] = []
    if lo is not None:
        constraints.append(at.Gt(lo) if lo_open else at.Ge(lo))
    if hi is not None:
        constraints.append(at.Lt(hi) if hi_open else at.Le(hi))
    if not integer:
        constraints.append(AllowInfNan(False))
    constraints.append(Field(description=text))
    return Number(text, why, constraints=tuple(constraints))


def distinct_values(v: list[Any]) -> list[Any]:
    """A list whose values are distinct (``AfterValidator``: else the error ``distinct``)."""
    if len(set(v)) != len(v):
        raise PydanticCustomError("distinct", "must not repeat a value")
    return v


@dataclass(frozen=True)
class Items(Says, at.GroupedMetadata):
    """A non-empty list or a ``[low, high]`` pair (:func:`items`)."""

    constraints: tuple[object, ...] = ()

    def __iter__(self) -> Iterator[object]:
        yield from self.constraints


def items(what: str, *, pair: bool = False, distinct: bool = False,
          item: Says | None = None) -> Items:
    """A non-empty list of ``what`` (a ``[low, high]`` pair of them if ``pair``; no value twice
    if ``distinct``), each item as its own annotation says (or ``item``)."""
    text = f"a [low, high] pair of {what}" if pair else f"a non-empty list of {what}"
    constraints: list[object] = [at.MinLen(2 if pair else 1)]
    if pair:
        constraints.append(at.MaxLen(2))
    if distinct:
        constraints.append(AfterValidator(distinct_values))
    return Items(text, item=item, constraints=tuple(constraints))


#: A seed (an integer in [0, MAX_SEED]).
Seed = Annotated[int, number(0, MAX_SEED, integer=True, what="a non-negative integer seed")]
#: A network's delays and neurons (``sloshrom.limits``).
Delays = Annotated[int, number(1, MAX_DELAY, integer=True, what="an integer")]
Neurons = Annotated[int, number(1, MAX_NEURONS, integer=True, what="an integer")]


class Table(BaseModel):
    """A table of the configuration: TOML's types only, no unknown key, frozen; it remembers the
    order its keys were given in."""

    # strict: TOML types only (no "3" -> 3, no true -> 1, no 3.0 -> 3); unknown keys are refused
    model_config = ConfigDict(extra="forbid", strict=True, frozen=True)
    # the keys in the order given (defaults.toml's, then the optional keys as the user wrote
    # them): the dict form keeps it, so summary.json reads as the merged configuration did
    _order: tuple[str, ...] = PrivateAttr(default=())

    @model_validator(mode="wrap")
    @classmethod
    def _remember_order(cls, data: Any, handler: Any) -> Any:
        table = handler(data)
        if isinstance(data, dict):
            table._order = tuple(data)
        return table

    def _given(self) -> dict[str, Any]:
        """``ReproduceConfig.as_dict`` of this table: the keys given, in their order."""
        out = {}
        for key in sorted(self.model_fields_set, key=lambda k: (
                k not in self._order, self._order.index(k) if k in self._order else 0)):
            value = getattr(self, key)
            out[key] = value._given() if isinstance(value, Table) else copy.deepcopy(value)
        return out


def no_config_check(cfg: ReproduceConfig) -> None:
    """A study without checks across the configuration's tables."""


def no_rig_fills(cfg: ReproduceConfig) -> list[tuple[str, float]]:
    """A study that runs the virtual rig at no fill of its own."""
    return []


@dataclass(frozen=True)
class StudyTable:
    """A study's part of the configuration of ``sloshrom reproduce``.

    Attributes
    ----------
    defaults : str
        The TOML text (with comments) of its keys: a ``[beyond]`` table with its keys of
        ``[beyond]`` and, if it has one, its own table. ``sloshrom config show`` prints them in
        their place: the keys of ``[beyond]`` after ``enabled`` (the studies' switches last),
        the tables after ``[beyond]``, in the registry's order.
    table : str or None
        The name of its own table (``"baseline"``: ``[baseline]``), or ``None``.
    model : type of Table or None
        Its own table's model (its keys' domains and its checks).
    beyond : type of Table or None
        A model of its keys of ``[beyond]`` (their domains and checks, run on ``[beyond]``).
    switch : str or None
        The one of them that switches it on (``[beyond] baseline = true``), or ``None`` (it
        runs whenever ``[beyond] enabled``).
    check : callable
        ``check(cfg)``: its checks across the tables (raises ``ConfigError``), run when the
        configuration is validated, after the paper's own.
    rig_fills : callable
        ``rig_fills(cfg) -> [(key, fill), ...]``: the fill levels (d/h) at which it runs the
        virtual rig, each with its key, checked before any stage
        (``sloshrom.pipeline.context.check_rig_tanks``); empty when it would not run.
    """

    defaults: str
    table: str | None = None
    model: type[Table] | None = None
    beyond: type[Table] | None = None
    switch: str | None = None
    check: Callable[[ReproduceConfig], None] = no_config_check
    rig_fills: Callable[[ReproduceConfig], list[tuple[str, float]]] = no_rig_fills

    def beyond_keys(self) -> Sequence[str]:
        """Its keys of ``[beyond]``, in their order."""
        return tuple(self.beyond.model_fields) if self.beyond is not None else ()

