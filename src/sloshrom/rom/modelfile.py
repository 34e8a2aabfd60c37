"""Reading and validating ROM model files (``.npz``) without trusting their content.

A model file is a zip archive of ``.npy`` members: ``metadata`` (one JSON text) and the float
parameter arrays ``W``, ``b``, ``c``, ``c0`` (see :meth:`sloshrom.rom.NFIR.save`). Two variants
(docs/formats.md, "Model files"):

single model (class ``"NFIR"``, ``"NOE"``, ``"NSS"``, ... of the registry)
    One model: its class's parameter arrays (:meth:`~sloshrom.rom.registry.ModelClass.shapes`;
    an NFIR's ``W`` (H, D), ``b`` (H,), ``c`` (H,), ``c0`` ()), written with the format
    version of its class's entry (``ModelClass.format_version``: 1 for the time-delay
    networks).
ensemble (class ``"Ensemble"``, :class:`sloshrom.rom.ensemble.Ensemble`)
    Format version 2, or its class's version. K networks of one class and the same hyperparameters
    but their seeds: the same four arrays with a leading member axis, ``W`` (K, H, D), ``b`` (K, H),
    ``c`` (K, H), ``c0`` (K,); the metadata holds the member class, the shared hyperparameters and
    per member its seed, scaler, envelope and training history.


This module reads it defensively, in an order that never lets the content choose how much work
is done:

1. the file and each zip member are size-bounded before anything is read; a member's ``.npy``
   header (dtype, shape) is checked against the bytes it has *before* the array is allocated,
   object (pickled) arrays are refused, only stored/deflated members are read (deflate output is
   bounded by the member's declared size);
2. the metadata text is bounded (:data:`MAX_METADATA_CHARS`) and scanned iteratively for its
   bracket nesting depth (:data:`MAX_DEPTH`) before :func:`json.loads`, so deep nesting is refused
   with a message instead of a ``RecursionError``;
3. the format and format version are checked, then the checksum (SHA-256 of the metadata and the
   arrays): it detects accidental corruption and truncation, **not** forgery — anyone can
   recompute it;
4. every metadata field is validated against a schema with bounds (pydantic, unknown fields
   refused), then cross-field rules (frequency band within ``[0, fs/2]``, regressor and weight
   counts bounded so that simulating the model needs bounded memory), then the arrays against the
   metadata (shapes, finite values of bounded magnitude).

Every failure is a :class:`ModelFileError` (a :class:`~sloshrom.rom.errors.ROMError`, hence a
``ValueError``) naming the file and, for metadata, the field. Loading never runs code (no
pickle anywhere).
"""

from __future__ import annotations

import functools
import hashlib
import hmac
import json
import math
import re
import reprlib
import zipfile
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Annotated, Any, Literal

import numpy as np
from pydantic import (
    AfterValidator,
    BaseModel,
    ConfigDict,
    Field,
    PlainValidator,
    StringConstraints,
    ValidationError,
    create_model,
    field_validator,
    model_validator,
)

from sloshrom.fileio import atomic_write, not_a_regular_file
from sloshrom.limits import (  # the limits the command line and the settings share
    HIDDEN_KINDS,
    MAX_DELAY,
    MAX_EPOCHS,
    MAX_MEMBERS,
    MAX_NEURONS,
    MAX_REGRESSOR,
    MAX_WEIGHTS,
)
from sloshrom.rom.errors import ROMError
from sloshrom.rom.registry import CLASSES, Hyper, ModelClass, model_class_of_file

__all__ = [
    "ENSEMBLE_FORMAT_VERSION", "FORMAT_VERSION", "HIDDEN_KINDS", "MAX_DELAY", "MAX_DEPTH",
    "MAX_FILE_BYTES", "MAX_MEMBERS", "MAX_METADATA_CHARS", "MAX_NEURONS", "MAX_REGRESSOR",
    "MAX_WEIGHTS", "ModelFile", "ModelFileError", "file_version",
    "NEWEST_FORMAT_VERSION", "PARAM_NAMES",  # noqa: F822 - read from the registry when asked
    "checksum", "model_file_path", "read_model_file", "validate_for_save", "write_model_file",
]

FORMAT = "sloshrom-rom"
#: Version of the single-model files of the first classes (the time-delay networks): their
#: layout has not changed since version 1, so every sloshrom reads the single models written
#: with it.
FORMAT_VERSION = 1
#: Version of ensemble files of those classes (version 1 plus the ensemble variant).
ENSEMBLE_FORMAT_VERSION = 2


def _newest_version() -> int:
    """The newest version this sloshrom reads (it reads every version from 1): each class's
    files carry the version of its registry entry (``ModelClass.format_version``)."""
    return max(ENSEMBLE_FORMAT_VERSION, *(mc.format_version for mc in CLASSES.values()))


def _first_class() -> ModelClass:
    """The registry's first class (the paper's NFIR): the layout of version 1, which a file
    of no known class is checked against."""
    return next(iter(CLASSES.values()))


def _array_names() -> tuple[str, ...]:
    """Every array name a model file of any registered class may hold."""
    return tuple(dict.fromkeys(n for mc in CLASSES.values() for n in mc.param_names()))


def __getattr__(name: str) -> int | tuple[str, ...]:
    # read from the registry when asked, so that a class registered later counts
    if name == "NEWEST_FORMAT_VERSION":
        return _newest_version()
    if name == "PARAM_NAMES":  # the arrays of version 1's layout
        return _first_class().param_names()
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def _file_class(meta: Mapping[str, Any]) -> ModelClass | None:
    """The registry class of a file's (or an ensemble's members') ``class``."""
    name = meta.get("member_class") if meta.get("class") == "Ensemble" else meta.get("class")
    return model_class_of_file(name) if isinstance(name, str) else None


def _param_names(meta: Mapping[str, Any]) -> tuple[str, ...]:
    mc = _file_class(meta)
    return (_first_class() if mc is None else mc).param_names()


def file_version(mc: ModelClass, ensemble: bool) -> int:
    """The format version of a file of ``mc`` (an ensemble of a version-1 class: 2)."""
    return ENSEMBLE_FORMAT_VERSION if ensemble and mc.format_version == FORMAT_VERSION \
        else mc.format_version

# -- limits (all checked before the corresponding memory is allocated) --------------------------
#: Largest model file, bytes (metadata <= 16 MiB as UCS-4 text + W <= 32 MiB + headers).
MAX_FILE_BYTES = 64 * 2**20
#: Longest metadata JSON text, characters (a history of ~40 000 epochs fits).
MAX_METADATA_CHARS = 4 * 2**20
#: Deepest bracket nesting of the metadata JSON (a valid file has 3, an ensemble file 4).
MAX_DEPTH = 16
#: Largest sample rate, Hz.
MAX_FS = 1e6
#: Largest magnitude of a scaler or envelope bound (physical units).
MAX_ABS = 1e15
#: Smallest scaler range: ``2 / (max - min)`` must not overflow.
MIN_SPAN = 1e-100
#: Largest magnitude of a network parameter: squares and sums of them cannot overflow.
MAX_PARAM = 1e50
#: Longest name, unit, version or stop-reason string, characters.
MAX_TEXT = 64
#: Longest explanation of a training's stop (``history.stop_message``), characters.
MAX_MESSAGE = 2000


_MAX_MEMBERS = 64
_MAX_NPY_HEADER = 10_000


def _max_data(name: str) -> int:
    """The most bytes of data a zip member may hold beyond its header (the metadata, an
    array)."""
    return 4 * MAX_METADATA_CHARS if name == "metadata" else 8 * MAX_WEIGHTS


class ModelFileError(ROMError):
    """A model file is missing, not a sloshrom model, of another format version, or corrupt."""


# ---------------------------------------------------------------------------------------------
# Checksum
# ---------------------------------------------------------------------------------------------


def checksum(meta: Mapping[str, Any], arrays: Mapping[str, np.ndarray]) -> str:
    """SHA-256 of the metadata (without its ``checksum``) and the parameter arrays.

    Protects against accidental corruption and truncation, not against forgery: the algorithm
    is public and anyone can recompute it after an edit (:func:`read_model_file` validates the
    content for that reason).

    Parameters
    ----------
    meta : mapping
        The metadata (JSON-serialisable).
    arrays : mapping of str to ndarray
        The class's parameter arrays (an NFIR's ``W``, ``b``, ``c``, ``c0``; any float
        dtype; hashed as little-endian float64, with their shapes: an ensemble's stacked
        arrays hash as they are stored).

    Returns
    -------
    str
        ``"sha256:<64 hex digits>"``.
    """
    h = hashlib.sha256()
    body = {k: v for k, v in meta.items() if k != "checksum"}
    h.update(json.dumps(body, sort_keys=True).encode())
    for k in _param_names(meta):
        a = np.ascontiguousarray(arrays[k], dtype="<f8")
        h.update(k.encode() + repr(a.shape).encode() + a.tobytes())
    return "sha256:" + h.hexdigest()


def _checksum_matches(meta: dict[str, Any], arrays: dict[str, np.ndarray]) -> bool:
    stored = meta.get("checksum")
    if not isinstance(stored, str):
        return False
    if any(k not in arrays or arrays[k].dtype.kind != "f" for k in _param_names(meta)):
        return False  # not hashable as float64: cannot be what save wrote
    return hmac.compare_digest(stored, checksum(meta, arrays))


# ---------------------------------------------------------------------------------------------
# Schema
# ---------------------------------------------------------------------------------------------


def _printable(s: str) -> str:
    if not s.isprintable():
        raise ModelFileError("must be printable text (no control characters)")
    return s


def _number_or_null(v: Any) -> float | None:
    # history entries: NaN marks "not applicable" (e.g. mu under Adam), inf an unstable
    # validation run, exactly as the trainer records them; they are informational only
    if v is None:
        return None
    if type(v) not in (int, float):  # bool is an int subclass: refused by the exact type check
        raise ModelFileError("must be a number or null")
    return float(v)


def _delays_value(v: Any) -> int | list[int]:
    """``n`` (delays 1..n) or a list of distinct delays, each in 1..MAX_DELAY."""
    if type(v) is int:
        if v < 1:
            raise ModelFileError("must be >= 1")
        if v > MAX_DELAY:
            raise ModelFileError(f"must be <= {MAX_DELAY}")
        return v
    if type(v) is not list:
        raise ModelFileError("must be an integer or a list of integers")
    if not 1 <= len(v) <= MAX_REGRESSOR:
        raise ModelFileError(f"must list 1 to {MAX_REGRESSOR} delays")
    for i, d in enumerate(v):
        if type(d) is not int or not 1 <= d <= MAX_DELAY:
            raise ModelFileError(f"entry [{i}] must be an integer in 1..{MAX_DELAY}")
    if len(set(v)) != len(v):
        raise ModelFileError("must be distinct")
    return v


# short printable text: non-empty (names, version) or possibly empty (units, stop reason)
Text = Annotated[str, StringConstraints(min_length=1, max_length=MAX_TEXT),
                 AfterValidator(_printable)]
Unit = Annotated[str, StringConstraints(max_length=MAX_TEXT), AfterValidator(_printable)]
Message = Annotated[str, StringConstraints(max_length=MAX_MESSAGE), AfterValidator(_printable)]
Bound = Annotated[float, Field(allow_inf_nan=False, ge=-MAX_ABS, le=MAX_ABS)]
HistoryList = Annotated[list[Annotated[float | None, PlainValidator(_number_or_null)]],
                        Field(max_length=MAX_EPOCHS + 1)]


class _Strict(BaseModel):
    # strict: JSON types only (no "3" -> 3, no true -> 1); unknown fields are refused
    model_config = ConfigDict(extra="forbid", strict=True, frozen=True)


def _above(lower: str):
    """Field validator: the value must exceed the already validated field ``lower``."""

    def check(v: float, info: Any) -> float:
        lo = info.data.get(lower)
        if lo is not None and not v - lo >= MIN_SPAN:
            raise ModelFileError(f"must be greater than {lower} ({lo!r}) by at least {MIN_SPAN:g}")
        return v

    return check


class _Scaler(_Strict):
    in_min: Bound
    in_max: Bound
    out_min: Bound
    out_max: Bound

    _in = field_validator("in_max")(_above("in_min"))
    _out = field_validator("out_max")(_above("out_min"))


class _Envelope(_Strict):
    input_min: Bound
    input_max: Bound
    output_min: Bound
    output_max: Bound
    frequency_band: Annotated[
        list[Annotated[float, Field(allow_inf_nan=False, ge=0.0, le=MAX_FS)]],
        Field(min_length=2, max_length=2),
    ]
    # peak tank acceleration of the training record: max |du/dt| of a velocity input, max |u| of
    # an acceleration input (files written before it have none)
    acceleration_max: Annotated[float, Field(allow_inf_nan=False, ge=0.0)] | None = None
    # fill levels d/h of the training records (files written before them have none)
    fill_min: Annotated[float, Field(allow_inf_nan=False, gt=0.0, lt=1.0)] | None = None
    fill_max: Annotated[float, Field(allow_inf_nan=False, gt=0.0, lt=1.0)] | None = None

    _in = field_validator("input_max")(_above("input_min"))
    _out = field_validator("output_max")(_above("output_min"))

    @model_validator(mode="after")
    def _fills(self) -> _Envelope:
        lo, hi = self.fill_min, self.fill_max
        if (lo is None) != (hi is None):
            raise ModelFileError("fill_min and fill_max must be given together")
        if lo is not None and hi < lo:
            raise ModelFileError(f"fill_max ({hi!r}) must be >= fill_min ({lo!r})")
        return self

    @field_validator("frequency_band")
    @classmethod
    def _ordered(cls, v: list[float]) -> list[float]:
        if not v[0] <= v[1]:
            raise ModelFileError("must be ordered (low <= high)")
        return v


class _Pair(_Strict):
    input: Unit
    output: Unit


class _Names(_Strict):
    input: Text
    output: Text


class _History(_Strict):
    train_mse: HistoryList | None = None
    val_mse: HistoryList | None = None
    val_objective: HistoryList | None = None
    mu: HistoryList | None = None
    grad: HistoryList | None = None
    seconds: HistoryList | None = None
    step_seconds: HistoryList | None = None
    validation_seconds: HistoryList | None = None
    stop_reason: Unit | None = None
    stop_message: Message | None = None
    best_epoch: Annotated[int, Field(ge=0, le=MAX_EPOCHS)] | None = None
    trainer: Literal["fast", "lm", "adam", "shooting"] | None = None
    n_rows: Annotated[int, Field(ge=0, le=10**12)] | None = None
    train_seconds: Annotated[float, Field(allow_inf_nan=False, ge=0.0)] | None = None
    # a class's own figures of an identification before its training (a grey box's search
    # of its physical parameters: the values found, the score, the generations, the seconds)
    search: Annotated[dict[Unit, Annotated[float, Field(allow_inf_nan=False)]],
                      Field(max_length=64)] | None = None


TwoUnits = Annotated[list[Unit], Field(min_length=2, max_length=2)]
TwoNames = Annotated[list[Text], Field(min_length=2, max_length=2)]


def _file_field(h: Hyper) -> tuple[Any, Any]:
    """The pydantic field of a hyperparameter in a file: the registry's domain, strict JSON."""
    if h.kind == "delays":
        ann: Any = Annotated[int | list[int], PlainValidator(_delays_value)]
    elif h.kind == "choice":
        ann = Literal[h.choices]
    else:
        bounds = {"gt" if h.lo_open else "ge": h.lo, "lt" if h.hi_open else "le": h.hi}
        if h.kind == "int":
            ann = Annotated[int, Field(**bounds)]
        else:
            ann = Annotated[float, Field(allow_inf_nan=False, **bounds)]
    return ann, (... if h.required_in_file else h.file_default)


class _Meta(_Strict):
    format: Literal["sloshrom-rom"]
    sloshrom_version: Text
    fs: Annotated[float, Field(allow_inf_nan=False, gt=0.0, le=MAX_FS)]
    units: _Pair
    names: _Names
    scaler: _Scaler
    envelope: _Envelope
    history: _History = _History()
    checksum: Annotated[str, StringConstraints(pattern=r"^sha256:[0-9a-f]{64}$")]


class _Member(_Strict):
    """One member of an ensemble: what differs between members trained on the same data."""

    seed: Annotated[int, Field(ge=0, le=2**63 - 1)]
    scaler: _Scaler
    envelope: _Envelope
    history: _History = _History()


class _EnsembleMeta(_Strict):
    format: Literal["sloshrom-rom"]
    class_: Literal["Ensemble"] = Field(alias="class")
    sloshrom_version: Text
    n_members: Annotated[int, Field(ge=1, le=MAX_MEMBERS)]
    fs: Annotated[float, Field(allow_inf_nan=False, gt=0.0, le=MAX_FS)]
    units: _Pair
    names: _Names
    members: Annotated[list[_Member], Field(min_length=1, max_length=MAX_MEMBERS)]
    checksum: Annotated[str, StringConstraints(pattern=r"^sha256:[0-9a-f]{64}$")]


@functools.cache
def _schema_of(class_name: str, ensemble: bool) -> type[_Strict]:
    """The metadata schema of a file of the registry class ``class_name`` (its ensemble's)."""
    mc = model_class_of_file(class_name)
    assert mc is not None
    fields: dict[str, Any] = {h.name: _file_field(h) for h in mc.hyper}
    fields.update(units=(TwoUnits, ...), names=(TwoNames, ...))
    hyper = create_model(f"_{mc.class_name}Hyper", __base__=_Strict, **fields)
    version = Literal[(file_version(mc, ensemble), *mc.read_versions)]
    if ensemble:
        return create_model(f"_{mc.class_name}EnsembleMeta", __base__=_EnsembleMeta,
                            format_version=(version, ...),
                            member_class=(Literal[mc.class_name], ...),
                            hyperparameters=(hyper, ...))
    return create_model(f"_{mc.class_name}Meta", __base__=_Meta,
                        format_version=(version, ...),
                        class_=(Literal[mc.class_name], Field(alias="class")),
                        hyperparameters=(hyper, ...))


_MESSAGES = {
    "missing": "is missing",
    "extra_forbidden": "is not a field of this format",
    "finite_number": "must be a finite number",
    "int_type": "must be an integer",
    "float_type": "must be a number",
    "string_type": "must be a string",
    "list_type": "must be a list",
    "model_type": "must be an object",
    "model_attributes_type": "must be an object",
    "dict_type": "must be an object",
}
_repr = reprlib.Repr()
_repr.maxstring, _repr.maxother, _repr.maxlist, _repr.maxdict, _repr.maxlevel = 60, 60, 4, 4, 2


def _field_path(loc: tuple[Any, ...]) -> str:
    out = ""
    for part in loc:
        out += f"[{part}]" if isinstance(part, int) else (f".{part}" if out else str(part))
    return out


def _describe(err: Any) -> str:
    """One pydantic error as ``metadata field 'a.b': must be <= 10, got 11``."""
    t, ctx = err["type"], err.get("ctx") or {}
    bounds = {"less_than_equal": ("<=", "le"), "less_than": ("<", "lt"),
              "greater_than_equal": (">=", "ge"), "greater_than": (">", "gt")}
    if t in bounds:
        op, key = bounds[t]
        msg = f"must be {op} {ctx[key]}"
    elif t == "literal_error":
        msg = f"must be {ctx['expected']}"
    elif t in ("too_short", "too_long"):
        msg = f"has {ctx.get('actual_length')} entries, allowed {ctx.get('min_length', 0)}.." \
              f"{ctx.get('max_length', '')}"
    elif t in ("string_too_short", "string_too_long"):
        msg = "must be a non-empty string" if t == "string_too_short" else \
            f"must be at most {ctx['max_length']} characters"
    elif t == "string_pattern_mismatch":
        msg = f"must match {ctx['pattern']}"
    elif t == "value_error":
        msg = str(ctx.get("error", err["msg"]))
    else:
        msg = _MESSAGES.get(t, err["msg"])
    got = "" if t == "missing" else f", got {_repr.repr(err['input'])}"
    return f"metadata field '{_field_path(err['loc'])}': {msg}{got}"


# ---------------------------------------------------------------------------------------------
# Validation
# ---------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class ModelFile:
    """A validated model file: its metadata (as stored) and float64 parameter arrays."""

    meta: dict[str, Any]
    arrays: dict[str, np.ndarray]

    @property
    def hyperparameters(self) -> dict[str, Any]:
        """The hyperparameters stored in the file's metadata."""
        return self.meta["hyperparameters"]

    @property
    def is_ensemble(self) -> bool:
        """True for an ensemble file (class ``"Ensemble"``)."""
        return self.meta["class"] == "Ensemble"

    def members(self) -> list[ModelFile]:
        """The networks of the file, each as a single-model file (metadata and arrays).

        A single-model file is its own only member; an ensemble's member ``k`` has the member
        class, the shared hyperparameters with the member's seed, the member's scaler, envelope
        and history, and the slice ``k`` of the stacked arrays.
        """
        if not self.is_ensemble:
            return [self]
        m = self.meta
        out = []
        for k, e in enumerate(m["members"]):
            meta = {
                "format": FORMAT, "class": m["member_class"],
                "format_version": file_version(model_class_of_file(m["member_class"]), False),
                "sloshrom_version": m["sloshrom_version"],
                "hyperparameters": {**m["hyperparameters"], "seed": e["seed"]},
                "fs": m["fs"], "units": m["units"], "names": m["names"],
                "scaler": e["scaler"], "envelope": e["envelope"], "history": e.get("history", {}),
            }
            out.append(ModelFile(meta, {n: np.array(a[k]) for n, a in self.arrays.items()}))
        return out


def _fail_field(where: str, field: str, msg: str, value: Any) -> ModelFileError:
    return ModelFileError(f"{where}: metadata field '{field}': {msg}, got {_repr.repr(value)}")


def _schema(meta: dict[str, Any]) -> type[_Strict]:
    ensemble = meta.get("class") == "Ensemble"
    mc = _file_class(meta)
    if mc is None and ensemble and meta.get("member_class") is not None:
        # an unknown member class: the message lists the ones this sloshrom reads
        return create_model("_AnyEnsembleMeta", __base__=_EnsembleMeta,
                            member_class=(Literal[tuple(CLASSES[k].class_name
                                                        for k in CLASSES)], ...))
    return _schema_of((mc or _first_class()).class_name, ensemble)


def _check_trained(part: dict[str, Any], fs: float, where: str, prefix: str) -> None:
    """Cross-field rules of one network's training record (envelope band, history)."""
    nyquist = fs / 2
    band = part["envelope"]["frequency_band"]
    if band[1] > nyquist * (1 + 1e-9):  # rfftfreq's last bin is fs/2 up to rounding
        raise _fail_field(where, f"{prefix}envelope.frequency_band",
                          f"must lie within [0, fs/2 = {nyquist:g}] Hz", band)
    hist = part.get("history", {})
    best, val = hist.get("best_epoch"), hist.get("val_mse")
    if isinstance(best, int) and isinstance(val, list) and best >= len(val):
        raise _fail_field(where, f"{prefix}history.best_epoch",
                          f"must index history.val_mse ({len(val)} entries)", best)


def _validate_meta(meta: dict[str, Any], where: str) -> None:
    """Schema and cross-field rules; raises :class:`ModelFileError` naming the first bad field."""
    try:
        _schema(meta).model_validate(meta)
    except ValidationError as exc:
        errors = exc.errors(include_url=False)
        n = len(errors) - 1
        more = f" (and {n} more problem{'s' if n > 1 else ''})" if n else ""
        raise ModelFileError(f"{where}: {_describe(errors[0])}{more}") from None
    hyper = meta["hyperparameters"]
    ensemble = meta["class"] == "Ensemble"
    mc = _file_class(meta)
    assert mc is not None  # the schema admits the registry's classes only
    k = meta["n_members"] if ensemble else 1
    first = mc.hyper[0].name  # the size that names the class (delays, n_states)
    d = mc.width(hyper)
    if d > MAX_REGRESSOR:
        raise _fail_field(where, f"hyperparameters.{first}",
                          f"the model would read {d} entries at each step (delays + output "
                          f"delays, or its state and input), more than {MAX_REGRESSOR}",
                          hyper[first])
    n_weights = mc.file_weights(hyper)
    if k * n_weights > MAX_WEIGHTS:
        of = f"{k} members x " if ensemble else ""
        size = next((h.name for h in mc.hyper if h.name == "neurons"), first)
        sizes = f"{hyper['neurons']} neurons, " if "neurons" in hyper else ""
        raise _fail_field(where, f"hyperparameters.{size}",
                          f"{of}{n_weights} weights ({sizes}{d} inputs) is more than "
                          f"{MAX_WEIGHTS} weights", hyper[size])
    for key in ("units", "names"):
        pair = [meta[key]["input"], meta[key]["output"]]
        if pair != hyper[key]:
            raise _fail_field(where, f"hyperparameters.{key}",
                              f"must equal the '{key}' field {pair}", hyper[key])
    if not ensemble:
        _check_trained(meta, meta["fs"], where, "")
        return
    members = meta["members"]
    if len(members) != k:
        raise _fail_field(where, "members", f"must list n_members = {k} members, has "
                          f"{len(members)}", members)
    seen: set[int] = set()
    for i, m in enumerate(members):
        if m["seed"] in seen:
            raise _fail_field(where, f"members[{i}].seed",
                              "must differ from the other members' seeds", m["seed"])
        seen.add(m["seed"])
        _check_trained(m, meta["fs"], where, f"members[{i}].")


def _check_arrays(meta: dict[str, Any], arrays: dict[str, np.ndarray], where: str
                  ) -> dict[str, np.ndarray]:
    """Parameter arrays against validated metadata; returns them as float64."""
    hyper = meta["hyperparameters"]
    mc = _file_class(meta)
    assert mc is not None
    lead: tuple[int, ...] = ()
    of, fields = "", ""
    if meta["class"] == "Ensemble":
        lead = (meta["n_members"],)
        of, fields = f"{lead[0]} members, ", "'n_members', "
    shapes = {k: (*lead, *v) for k, v in mc.shapes(hyper).items()}
    sizes = ", ".join(f"{n} {hyper[n]}" for n in mc.sizes)
    fields += ", ".join(f"'hyperparameters.{n}'" for n in mc.sizes)
    out = {}
    for k, shp in shapes.items():
        a = arrays.get(k)
        if a is None or a.shape != shp or a.dtype.kind != "f":
            got = None if a is None else (a.shape, str(a.dtype))
            raise ModelFileError(
                f"{where}: parameter {k} tampered: expected float {shp} for {of}{sizes} "
                f"(metadata fields {fields}), got {got}"
            )
        a = a.astype(np.float64)
        if not np.all(np.isfinite(a)):
            raise ModelFileError(f"{where}: parameter {k} contains NaN or inf")
        if a.size and float(np.max(np.abs(a))) > MAX_PARAM:
            raise ModelFileError(f"{where}: parameter {k} has values beyond +-{MAX_PARAM:g}")
        out[k] = a
    return out


def model_file_path(path: str | Path) -> Path:
    """``path`` with the ``.npz`` suffix a model file always has (appended if missing)."""
    p = Path(path)
    if p.suffix != ".npz":
        p = p.with_suffix(p.suffix + ".npz") if p.suffix else p.with_suffix(".npz")
    return p


def write_model_file(path: Path, meta: dict[str, Any], arrays: dict[str, np.ndarray],
                     what: str = "model") -> Path:
    """Checksum ``meta`` and ``arrays``, check that they will load, write them atomically.

    Raises
    ------
    ROMError
        A value outside the bounds of the format (the message names the field); nothing is
        written.
    """
    meta["checksum"] = checksum(meta, arrays)
    try:
        text = validate_for_save(meta, arrays, str(path))
    except ModelFileError as exc:
        raise ROMError(f"cannot save the {what}: {exc}") from None

    def write(tmp: str) -> None:
        with open(tmp, "wb") as fh:  # a file object: np.savez adds no ".npz" to the name
            np.savez(fh, metadata=np.array(text), **arrays)

    return atomic_write(path, write, suffix=".npz")


def validate_for_save(meta: dict[str, Any], arrays: dict[str, np.ndarray], where: str) -> str:
    """The metadata JSON text :meth:`save` writes, after checking that it will load.

    Parameters
    ----------
    meta : dict
        Metadata with its checksum.
    arrays : dict of str to ndarray
        The parameter arrays.
    where : str
        How to name the file in messages.

    Returns
    -------
    str
        The JSON text.

    Raises
    ------
    ModelFileError
        The model would be refused by :func:`read_model_file` (out-of-bounds hyperparameter,
        too long a history, ...); nothing should be written.
    """
    text = json.dumps(meta)
    if len(text) > MAX_METADATA_CHARS:
        raise ModelFileError(
            f"{where}: metadata of {len(text)} characters is more than {MAX_METADATA_CHARS} "
            "(shorten the training history, model.history_)"
        )
    back = json.loads(text)  # validate exactly what a reader will see
    _validate_meta(back, where)
    _check_arrays(back, arrays, where)
    return text


# ---------------------------------------------------------------------------------------------
# Reading
# ---------------------------------------------------------------------------------------------

_JSON_SPECIAL = re.compile(r'[\[\]{}"\\]')


def json_depth_exceeds(text: str, limit: int) -> bool:
    """True if the JSON ``text`` nests brackets deeper than ``limit`` (iterative, linear).

    Brackets inside strings do not count; an unterminated string makes the count conservative
    (malformed text is refused by the parser afterwards anyway).
    """
    depth, in_string, skip = 0, False, -1
    for m in _JSON_SPECIAL.finditer(text):
        i, c = m.start(), m.group()
        if i == skip:  # the character after a backslash inside a string
            continue
        if in_string:
            if c == "\\":
                skip = i + 1
            elif c == '"':
                in_string = False
        elif c == '"':
            in_string = True
        elif c in "[{":
            depth += 1
            if depth > limit:
                return True
        elif c in "]}":
            depth -= 1
    return False


def _read_npy(zf: zipfile.ZipFile, info: zipfile.ZipInfo, name: str, where: str) -> np.ndarray:
    """One ``.npy`` member, header checked against the member's size before allocating."""
    if info.compress_type not in (zipfile.ZIP_STORED, zipfile.ZIP_DEFLATED):
        raise ModelFileError(f"{where}: not a sloshrom model file (member {name!r} uses an "
                             "unsupported compression)")
    if info.file_size > _max_data(name) + _MAX_NPY_HEADER + 16:
        raise ModelFileError(f"{where}: not a sloshrom model file (member {name!r} has "
                             f"{info.file_size} bytes, more than a model file holds)")
    with zf.open(info) as fh:
        version = np.lib.format.read_magic(fh)
        if version == (1, 0):
            shape, fortran, dtype = np.lib.format.read_array_header_1_0(
                fh, max_header_size=_MAX_NPY_HEADER)
        elif version == (2, 0):
            shape, fortran, dtype = np.lib.format.read_array_header_2_0(
                fh, max_header_size=_MAX_NPY_HEADER)
        else:
            raise ModelFileError(f"{where}: not a sloshrom model file (member {name!r}: .npy "
                                 f"version {version})")
        if dtype.hasobject:
            raise ModelFileError(
                f"{where}: not a sloshrom model file (it holds Python objects, which sloshrom "
                "never loads because loading them could run code)"
            )
        if name == "metadata" and dtype.kind == "U" and dtype.itemsize // 4 > MAX_METADATA_CHARS:
            raise ModelFileError(f"{where}: metadata of {dtype.itemsize // 4} characters is "
                                 f"more than {MAX_METADATA_CHARS}")
        nbytes = math.prod(shape) * dtype.itemsize
        fits = min(shape, default=0) >= 0 and nbytes <= _max_data(name)
        if not fits or fh.tell() + nbytes != info.file_size:
            raise ModelFileError(f"{where}: not a sloshrom model file (member {name!r}: array "
                                 f"{shape} {dtype} does not match its {info.file_size} bytes)")
        data = fh.read(nbytes)
        if len(data) != nbytes or fh.read(1):  # reading to the end also checks the CRC
            raise ModelFileError(f"{where}: member {name!r} is truncated")
    return np.frombuffer(data, dtype=dtype).reshape(shape, order="F" if fortran else "C")


def _read_members(p: Path, where: str) -> tuple[dict[str, np.ndarray], list[str]]:
    """The known members of the archive and the names of unknown ones."""
    arrays: dict[str, np.ndarray] = {}
    with zipfile.ZipFile(p) as zf:
        infos = zf.infolist()
        if len(infos) > _MAX_MEMBERS:
            raise ModelFileError(f"{where}: not a sloshrom model file ({len(infos)} members)")
        names = [i.filename for i in infos]
        if len(set(names)) != len(names):
            raise ModelFileError(f"{where}: not a sloshrom model file (duplicate members)")
        if "metadata.npy" not in names:
            raise ModelFileError(f"{where}: not a sloshrom model file (no metadata)")
        members = ("metadata", *_array_names())
        unknown = [n for n in names if n.removesuffix(".npy") not in members
                   or not n.endswith(".npy")]
        for info in infos:
            name = info.filename.removesuffix(".npy")
            if info.filename.endswith(".npy") and name in members:
                arrays[name] = _read_npy(zf, info, name, where)
    return arrays, unknown


def _metadata(raw: np.ndarray, where: str) -> dict[str, Any]:
    if raw.shape != () or raw.dtype.kind != "U":
        raise ModelFileError(f"{where}: not a sloshrom model file (metadata is not a text)")
    try:
        text = str(raw.item())
    except Exception as exc:  # invalid code points
        raise ModelFileError(f"{where}: corrupt metadata ({exc})") from None
    if len(text) > MAX_METADATA_CHARS:
        raise ModelFileError(f"{where}: metadata of {len(text)} characters is more than "
                             f"{MAX_METADATA_CHARS}")
    if json_depth_exceeds(text, MAX_DEPTH):
        raise ModelFileError(f"{where}: corrupt metadata (nested more than {MAX_DEPTH} levels "
                             "deep)")
    try:
        meta = json.loads(text)
    except (ValueError, RecursionError) as exc:  # JSONDecodeError, too long integers
        raise ModelFileError(f"{where}: corrupt metadata ({exc})") from None
    if not isinstance(meta, dict) or meta.get("format") != FORMAT:
        raise ModelFileError(f"{where}: not a sloshrom model file")
    return meta


def read_model_file(path: str | Path) -> ModelFile:
    """Read and validate a model file (see the module docstring for the order of the checks).

    Parameters
    ----------
    path : str or Path
        A ``.npz`` file written by :meth:`sloshrom.rom.NFIR.save` / ``NOE.save``.

    Returns
    -------
    ModelFile
        Validated metadata and float64 parameter arrays.

    Raises
    ------
    ModelFileError
        For any file that is missing, not a model file, of another format version, corrupt, or
        whose content is out of bounds or inconsistent; never anything else for a bad file.
    """
    p = Path(path)
    where = str(p)
    why = not_a_regular_file(p)
    if why is not None:
        raise ModelFileError(f"{where}: {why}")
    if not p.is_file():
        raise ModelFileError(f"{where}: no such model file")
    try:
        size = p.stat().st_size
        if size > MAX_FILE_BYTES:
            raise ModelFileError(f"{where}: not a sloshrom model file ({size} bytes, more than "
                                 f"the {MAX_FILE_BYTES} a model file can have)")
        arrays, unknown = _read_members(p, where)
    except (ModelFileError, MemoryError):
        raise
    except Exception as exc:  # zipfile, zlib, .npy header and OS errors of a damaged file
        raise ModelFileError(f"{where}: not a sloshrom model file ({exc})") from None
    meta = _metadata(arrays.pop("metadata"), where)
    ver = meta.get("format_version")
    if type(ver) is not int:
        raise ModelFileError(f"{where}: missing format version")
    newest = _newest_version()
    if ver > newest:
        raise ModelFileError(
            f"{where}: format version {ver} is newer than this sloshrom reads "
            f"({newest}); upgrade sloshrom"
        )
    if ver < FORMAT_VERSION:
        raise ModelFileError(f"{where}: unsupported format version {ver} (reads "
                             f"{FORMAT_VERSION} to {newest})")
    cls = meta.get("class")
    if cls != "Ensemble" and not (isinstance(cls, str) and model_class_of_file(cls)):
        raise ModelFileError(f"{where}: unknown model class {_repr.repr(cls)}")
    mc = _file_class(meta)
    expected = ENSEMBLE_FORMAT_VERSION if mc is None else file_version(mc, cls == "Ensemble")
    if ver != expected and not (mc is not None and ver in mc.read_versions):
        what = "an ensemble" if cls == "Ensemble" else f"a single {cls} model"
        raise ModelFileError(f"{where}: {what} file has format version {expected}, this one "
                             f"says {ver}")
    if unknown:
        raise ModelFileError(f"{where}: not a sloshrom model file (unexpected member "
                             f"{_repr.repr(unknown[0])})")
    if not _checksum_matches(meta, arrays):
        # name a parameter array that disagrees with intact metadata, else the mismatch itself
        try:
            _validate_meta(meta, where)
        except ModelFileError:
            pass
        else:
            _check_arrays(meta, arrays, where)
        raise ModelFileError(
            f"{where}: checksum mismatch: the file was modified or damaged after it was saved"
        )
    _validate_meta(meta, where)
    return ModelFile(meta, _check_arrays(meta, arrays, where))
