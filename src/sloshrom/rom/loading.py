"""Loading a model file of any registered class: :func:`load_model`.

A ``.npz`` file names its class (``"class"``, or an ensemble's ``"member_class"``): the
registry (:mod:`sloshrom.rom.registry`) gives its estimator, which builds the fitted model from
the validated arrays (:meth:`sloshrom.rom.base.Estimator.fitted`). A ``.toml`` file is a fill
family's manifest or the file of a registered :class:`~sloshrom.rom.registry.FileKind` (the
bouncing ball's). No class is named here: a class's package and its line in the registry are
all that loading it takes.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any, cast

from sloshrom.rom.base import Estimator
from sloshrom.rom.ensemble import Ensemble
from sloshrom.rom.errors import ROMError
from sloshrom.rom.family import at_fill, read_family
from sloshrom.rom.modelfile import ModelFile, ModelFileError, read_model_file
from sloshrom.rom.network import MinMaxScaler
from sloshrom.rom.registry import file_kinds, model_class

__all__ = ["load_model"]


def load_model(path: str | Path, fill: float | None = None) -> Any:
    """Load a model written by ``save``; never runs code (no pickle).

    Every metadata field is validated against a schema with bounds and the arrays against the
    metadata before the model is built (:mod:`sloshrom.rom.modelfile`; docs/formats.md, "Model
    files"), then the hyperparameters as the estimator's ``fit`` checks them, so a loaded model
    can be simulated, coupled and exported.

    Parameters
    ----------
    path : str or Path
        A ``.npz`` model file: a single model of a registered class (NFIR, NOE, NSS, LSS, ...)
        or an ensemble (:meth:`Ensemble.save`); or a ``.toml`` fill-family manifest naming one
        model file per fill level (:func:`sloshrom.rom.family.read_family`); or a file of a
        registered :class:`~sloshrom.rom.registry.FileKind` (a ``.toml`` bouncing-ball model,
        :meth:`sloshrom.rom.ball.model.BouncingBall.save`).
    fill : float, optional
        Fill level d/h (-) to run the model at. Given, the result is a sloshing model at that
        fill whatever the file holds (:func:`sloshrom.rom.family.at_fill`: a family's blend of
        its neighbouring members, any other model checked against the fills it was identified
        on). Without it a fill family comes back as a family, which is a sloshing model only
        at a fill.

    Returns
    -------
    Estimator, Ensemble, FillFamily, BouncingBall or (with ``fill``) FillBlend
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
    for kind in file_kinds():  # a model of its own files (the bouncing ball's .toml)
        if kind.recognises(Path(path)):
            return kind.load(path)
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
    cls = cast("type[Estimator]", model_class(meta["class"]).estimator_class())
    sc = meta["scaler"]
    scaler = MinMaxScaler(**{k: float(sc[k]) for k in ("in_min", "in_max", "out_min", "out_max")})
    try:
        return cls.fitted(mf.arrays, scaler, float(meta["fs"]), meta["envelope"],
                          meta.get("history", {}), **meta["hyperparameters"])
    except (TypeError, ROMError) as exc:  # unreachable after the schema; kept as a net
        raise ModelFileError(f"{path}: corrupt metadata ({exc})") from None
