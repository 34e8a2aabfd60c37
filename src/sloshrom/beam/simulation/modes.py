"""Normal modes of a structure at its nodes, as finite-element codes and test-FE tools export them.

:class:`ModeSet` is the in-memory form of a modal model read from a file (UFF dataset 55,
Nastran punch, the NetCDF/CSV modal formats of :mod:`sloshrom.beam.simulation.modal_files`): natural
frequencies, generalised (modal) masses, optional damping ratios and participation, and the three
translations of every mode at every node. :meth:`ModeSet.to_modal_model` picks the tank and
sensor nodes and the structure's "up" direction and returns the
:class:`~sloshrom.beam.simulation.structure.ModalModel` the coupled simulation uses.

Units: frequencies in Hz, masses and participation in kg, coordinates in m; mode shapes are
dimensionless (any normalisation: the modal masses belong to the shapes as given), so that a
modal coordinate ``q`` is in m. This module does no file I/O.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from sloshrom.beam.simulation.structure import (
    MAX_MODES,
    MAX_VALUE,
    CantileverBeam,
    ModalDataError,
    ModalModel,
)
from sloshrom.config import Tank

__all__ = ["DIRECTIONS", "MAX_DEFAULT_OUTPUTS", "MAX_MODES", "ModeSet", "mode_table_arrays"]

#: the structure's "up" axes :meth:`ModeSet.to_modal_model` accepts -> (component, sign)
DIRECTIONS: dict[str, tuple[int, float]] = {
    "+X": (0, 1.0), "-X": (0, -1.0), "+Y": (1, 1.0), "-Y": (1, -1.0),
    "+Z": (2, 1.0), "-Z": (2, -1.0),
}
#: a model with more nodes than this needs explicit ``outputs`` (virtual accelerometers)
MAX_DEFAULT_OUTPUTS = 64
#: columns of a mode table (see :func:`mode_table_arrays`): name -> ModeSet field it sets
TABLE_COLUMNS = ("damping", "modal_mass", "participation", "participation_x",
                 "participation_y", "participation_z")
#: the optional column of a table that numbers its rows (default: row k is mode k + 1)
MODE_COLUMN = "mode"


def _vector(name: str, value: Any, n: int, where: str, allow_nan: bool = False) -> np.ndarray:
    a = np.atleast_1d(np.asarray(value, dtype=float))
    if a.shape != (n,):
        raise ModalDataError(f"{where}: {name} must have one value per mode ({n}), got {a.shape}")
    bad = ~np.isfinite(a) if not allow_nan else np.isinf(a)
    if np.any(bad):
        k = int(np.flatnonzero(bad)[0])
        raise ModalDataError(
            f"{where}: {name} of mode {k + 1} is {float(a[k])!r}; it must be finite"
        )
    _bounded(name, a, where)
    return a


def _bounded(name: str, a: np.ndarray, where: str) -> None:
    """Refuse a value of magnitude :data:`~sloshrom.beam.simulation.structure.MAX_VALUE` or more:
    squares and products of modal values (stiffness, frozen mass matrix) must not overflow."""
    with np.errstate(invalid="ignore"):
        big = np.abs(a) >= MAX_VALUE
    if np.any(big):
        v = float(np.asarray(a)[big].flat[0])
        raise ModalDataError(f"{where}: {name} holds {v:g}; modal values must be below "
                             f"{MAX_VALUE:g} in magnitude (a unit or format error?)")


def _mode_numbers(value: Any, n: int, where: str) -> np.ndarray:
    """The file's numbers of the ``n`` modes: positive, distinct integers (default 1..n)."""
    if value is None:
        return np.arange(1, n + 1, dtype=np.int64)
    a = np.atleast_1d(np.asarray(value))
    if a.shape != (n,):
        raise ModalDataError(f"{where}: mode_numbers must have one number per mode ({n}), got "
                             f"{a.shape}")
    f = np.asarray(a, dtype=float)
    if not np.all(np.isfinite(f)) or np.any(f != np.round(f)) or np.any(f < 1):
        raise ModalDataError(f"{where}: mode numbers must be integers >= 1, got "
                             f"{a.tolist()[:10]}")
    out = f.astype(np.int64)
    if np.unique(out).size != n:
        raise ModalDataError(f"{where}: mode numbers repeat: {out.tolist()[:20]}")
    return out


def _show_nodes(nodes: np.ndarray) -> str:
    """``nodes 1..120`` for a contiguous range, else the first few and the count."""
    s = np.sort(nodes)
    if s.size and s[-1] - s[0] + 1 == s.size:
        return f"nodes {s[0]}..{s[-1]}" if s.size > 1 else f"node {s[0]}"
    head = ", ".join(str(int(v)) for v in s[:6])
    return f"nodes {head}{', ...' if s.size > 6 else ''} ({s.size} nodes)"


def _show_numbers(a: np.ndarray) -> str:
    """``1..12`` for a contiguous range, else the first few numbers."""
    v = np.sort(np.asarray(a, dtype=np.int64))
    if v.size > 1 and v[-1] - v[0] + 1 == v.size:
        return f"{v[0]}..{v[-1]}"
    return ", ".join(str(int(x)) for x in v[:8]) + (", ..." if v.size > 8 else "")


def mode_table_arrays(table: Mapping[str, Any], n_modes: int, where: str = "mode table",
                      modes: Sequence[int] | np.ndarray | None = None) -> dict[str, np.ndarray]:
    """Check a per-mode table and return its columns for the modes of a set, by mode number.

    A table is matched to the modes by **mode number**, never by position: entry ``k`` of a
    column is mode number ``k + 1`` of the file (the ``mode`` column of a CSV table, the
    ``MODE =`` of a punch file, ``mode_n`` of UFF 55), whatever order the file lists its modes
    in.

    Parameters
    ----------
    table : mapping
        Column name -> sequence, entry ``k`` for mode number ``k + 1``, or for the mode number
        in entry ``k`` of an optional ``mode`` column (integers >= 1, each once; what
        :func:`~sloshrom.beam.simulation.modal_files.read_mode_table` returns). Columns: ``damping``
        (ratio, -), ``modal_mass`` (kg), ``participation`` (kg, along +Z; the same as
        ``participation_z``), ``participation_x`` / ``_y`` / ``_z`` (kg). Rows of modes the set
        does not hold are ignored (a table of 20 modes serves a set reduced to 3); a mode of
        the set without a row is an error.
    n_modes : int
        Modes of the set the table is applied to.
    where : str
        Names the table in messages.
    modes : sequence of int, optional
        The set's mode numbers, one per mode (:attr:`ModeSet.mode_numbers`); default
        ``1..n_modes``.

    Returns
    -------
    dict
        The given columns as float arrays of length ``n_modes``, entry ``i`` for the set's
        mode ``i`` (``participation`` renamed to ``participation_z``).

    Raises
    ------
    ModalDataError
        Unknown column, a mode of the set without a row, a non-finite value, damping outside
        [0, 1), a non-positive modal mass, ``participation`` together with
        ``participation_z``.
    """
    numbers = _mode_numbers(modes, n_modes, where)
    top = int(numbers.max()) if numbers.size else 0
    rows = None  # row of each of the set's modes in a table with a mode column
    if MODE_COLUMN in table:
        listed = _mode_numbers(table[MODE_COLUMN], np.size(table[MODE_COLUMN]),
                               f"{where} (its mode column)")
        lookup = {int(m): i for i, m in enumerate(listed)}
        absent = [int(m) for m in numbers if int(m) not in lookup]
        if absent:
            raise ModalDataError(
                f"{where}: no row for mode(s) {', '.join(map(str, absent[:10]))} of the mode "
                f"set (a table is matched to the modes by mode number; it lists modes "
                f"{_show_numbers(listed)})"
            )
        rows = np.array([lookup[int(m)] for m in numbers], dtype=int)
        table = {k: v for k, v in table.items() if k != MODE_COLUMN}
    unknown = sorted(set(table) - set(TABLE_COLUMNS))
    if unknown:
        raise ModalDataError(
            f"{where}: unknown column(s) {', '.join(unknown)} (known: {', '.join(TABLE_COLUMNS)})"
        )
    if "participation" in table and "participation_z" in table:
        raise ModalDataError(f"{where}: give participation or participation_z, not both")
    out: dict[str, np.ndarray] = {}
    for name, value in table.items():
        a = np.atleast_1d(np.asarray(value, dtype=float))
        if a.ndim != 1:
            raise ModalDataError(f"{where}: {name} must be one value per mode, got {a.shape}")
        if rows is not None:
            if a.size != np.size(listed):
                raise ModalDataError(f"{where}: {name} has {a.size} entries for "
                                     f"{np.size(listed)} listed modes")
            out["participation_z" if name == "participation" else name] = _table_values(
                name, a[rows], n_modes, where)
            continue
        if a.size < top:
            numbered = "" if top == n_modes else f", numbered up to {top}"
            raise ModalDataError(
                f"{where}: {name} lists {a.size} mode(s); the mode set holds {n_modes}"
                f"{numbered} (a table is matched to the modes by mode number, its row k to "
                f"mode k: list every mode, or select_modes({a.size}) first)"
            )
        out["participation_z" if name == "participation" else name] = _table_values(
            name, a[numbers - 1], n_modes, where)
    return out


def _table_values(name: str, a: np.ndarray, n_modes: int, where: str) -> np.ndarray:
    a = _vector(name, a, n_modes, where)
    if name == "damping" and (np.any(a < 0) or np.any(a >= 1)):
        raise ModalDataError(f"{where}: damping ratios must be in [0, 1), got {a}")
    if name == "modal_mass" and np.any(a <= 0):
        raise ModalDataError(f"{where}: modal masses must be positive (kg), got {a}")
    return a


@dataclass(frozen=True)
class ModeSet:
    """Normal modes of a structure at its nodes, as an FE code or test-FE tool exports them.

    Parameters
    ----------
    frequencies : array (n_modes,)
        Natural frequencies, Hz, finite and > 0.
    modal_masses : array (n_modes,)
        Generalised masses ``phi_n^T M phi_n`` of the shapes as given, kg, > 0.
    nodes : int array (n_nodes,)
        Node (grid) IDs, unique.
    shapes : array (n_nodes, 3, n_modes)
        Translations x, y, z of every mode at every node (dimensionless shape values).
    damping : array (n_modes,) or None
        Viscous damping ratios in [0, 1); None: not in the file.
    participation : array (3, n_modes) or None
        Participation ``Gamma_n = phi_n^T M r`` for unit rigid-body translations along x, y, z,
        kg; None: unknown. A NaN entry marks one unknown component.
    coordinates : array (n_nodes, 3) or None
        Node positions, m; None: not in the file.
    source : str
        Where the modes come from, e.g. ``"uff55:wing.unv"``.
    attrs : dict
        Notes of the reader (e.g. the scalar points a punch file held).
    mode_numbers : int array (n_modes,) or None
        The file's number of each mode (``MODE =`` of a punch file, ``mode_n`` of UFF 55),
        positive and distinct; mode tables are matched to the modes by these numbers. None:
        ``1..n_modes``.

    Raises
    ------
    ModalDataError
        No modes, non-positive or non-finite frequencies or masses, wrong shapes, duplicate
        nodes or mode numbers, damping outside [0, 1), non-finite shapes or coordinates, a
        value of magnitude :data:`~sloshrom.beam.simulation.structure.MAX_VALUE` or more.
    """

    frequencies: np.ndarray
    modal_masses: np.ndarray
    nodes: np.ndarray
    shapes: np.ndarray
    damping: np.ndarray | None = None
    participation: np.ndarray | None = None
    coordinates: np.ndarray | None = None
    source: str = ""
    attrs: dict[str, Any] = field(default_factory=dict)
    mode_numbers: np.ndarray | None = None

    def __post_init__(self) -> None:
        where = self.source or "mode set"
        f = np.atleast_1d(np.asarray(self.frequencies, dtype=float))
        n = f.size
        if n == 0 or f.ndim != 1:
            raise ModalDataError(f"{where}: no modes (frequencies {f.shape})")
        f = _vector("frequencies", f, n, where)
        if np.any(f <= 0):
            k = int(np.flatnonzero(f <= 0)[0])
            raise ModalDataError(
                f"{where}: frequency of mode {k + 1} is {float(f[k])!r} Hz; it must be positive "
                "(drop rigid-body modes)"
            )
        m = _vector("modal_masses", self.modal_masses, n, where)
        if np.any(m <= 0):
            k = int(np.flatnonzero(m <= 0)[0])
            raise ModalDataError(
                f"{where}: modal mass of mode {k + 1} is {float(m[k])!r} kg; it must be positive"
            )
        nodes = np.atleast_1d(np.asarray(self.nodes))
        if nodes.ndim != 1 or nodes.size == 0:
            raise ModalDataError(f"{where}: nodes must be a non-empty list of IDs, got "
                                 f"{nodes.shape}")
        if not np.issubdtype(nodes.dtype, np.integer):
            as_float = np.asarray(nodes, dtype=float)
            if not np.all(np.isfinite(as_float)) or np.any(as_float != np.round(as_float)):
                raise ModalDataError(f"{where}: node IDs must be integers")
            nodes = as_float.astype(np.int64)
        nodes = nodes.astype(np.int64)
        uniq, counts = np.unique(nodes, return_counts=True)
        if np.any(counts > 1):
            raise ModalDataError(f"{where}: duplicate node ID(s) {uniq[counts > 1][:10].tolist()}")
        shapes = np.asarray(self.shapes, dtype=float)
        if shapes.shape != (nodes.size, 3, n):
            raise ModalDataError(
                f"{where}: shapes must have shape (n_nodes, 3, n_modes) = ({nodes.size}, 3, {n}),"
                f" got {shapes.shape}"
            )
        if not np.all(np.isfinite(shapes)):
            i, _, k = np.argwhere(~np.isfinite(shapes))[0]
            raise ModalDataError(f"{where}: mode {k + 1} is not finite at node {nodes[i]}")
        if np.any(np.abs(shapes) >= MAX_VALUE):
            i, _, k = np.argwhere(np.abs(shapes) >= MAX_VALUE)[0]
            raise ModalDataError(
                f"{where}: mode {k + 1} is {float(np.max(np.abs(shapes[i, :, k]))):g} at node "
                f"{nodes[i]}; shape values must be below {MAX_VALUE:g} in magnitude (a unit or "
                "format error?)")
        numbers = _mode_numbers(self.mode_numbers, n, where)
        damping = None
        if self.damping is not None:
            damping = _vector("damping", self.damping, n, where)
            if np.any(damping < 0) or np.any(damping >= 1):
                raise ModalDataError(f"{where}: damping ratios must be in [0, 1), got {damping}")
        part = None
        if self.participation is not None:
            part = np.asarray(self.participation, dtype=float)
            if part.shape != (3, n):
                raise ModalDataError(
                    f"{where}: participation must have shape (3, n_modes) = (3, {n}) for x, y, "
                    f"z, got {part.shape}"
                )
            if np.any(np.isinf(part)):
                raise ModalDataError(f"{where}: participation must be finite (NaN: unknown)")
            _bounded("participation", part, where)
        coords = None
        if self.coordinates is not None:
            coords = np.asarray(self.coordinates, dtype=float)
            if coords.shape != (nodes.size, 3):
                raise ModalDataError(
                    f"{where}: coordinates must have shape (n_nodes, 3) = ({nodes.size}, 3), "
                    f"got {coords.shape}"
                )
            if not np.all(np.isfinite(coords)):
                raise ModalDataError(f"{where}: coordinates must be finite")
            _bounded("coordinates", coords, where)
        for name, value in (("frequencies", f), ("modal_masses", m), ("nodes", nodes),
                            ("shapes", shapes), ("damping", damping),
                            ("participation", part), ("coordinates", coords),
                            ("mode_numbers", numbers)):
            if value is not None:
                value = np.array(value)  # own copy: never freeze the caller's array
                value.setflags(write=False)  # frozen means frozen, arrays included
            object.__setattr__(self, name, value)
        object.__setattr__(self, "source", str(self.source))
        object.__setattr__(self, "attrs", dict(self.attrs))

    # -- derived ----------------------------------------------------------------------------
    @property
    def n_modes(self) -> int:
        """The number of modes."""
        return int(self.frequencies.size)

    @property
    def n_nodes(self) -> int:
        """The number of nodes."""
        return int(self.nodes.size)

    @property
    def file_name(self) -> str:
        """The file part of :attr:`source` (``"wing.pch"`` of ``"punch:wing.pch"``)."""
        return self.source.split(":", 1)[-1] if self.source else "the mode set"

    def node_index(self, node_ids: Sequence[int] | int, what: str = "grid") -> np.ndarray:
        """Row indices of ``node_ids`` in :attr:`nodes`; a missing ID is an error naming it."""
        ids = np.atleast_1d(np.asarray(node_ids))
        if ids.ndim != 1 or ids.size == 0:
            raise ModalDataError(f"{what} IDs: give one ID or a non-empty list, got {node_ids!r}")
        lookup = {int(v): i for i, v in enumerate(self.nodes)}
        out = []
        for v in ids.tolist():
            if isinstance(v, float) and v != int(v) or isinstance(v, bool):
                raise ModalDataError(f"{what} ID {v!r} is not an integer")
            if int(v) not in lookup:
                raise ModalDataError(
                    f"{what} {int(v)} is not in {self.file_name} ({_show_nodes(self.nodes)})"
                )
            out.append(lookup[int(v)])
        return np.asarray(out, dtype=int)

    # -- derived sets -----------------------------------------------------------------------
    def select_modes(self, n: int) -> ModeSet:
        """The first ``n`` modes (in the order of :attr:`mode_numbers`; readers sort by it)."""
        if isinstance(n, bool) or int(n) != n or n < 1:
            raise ModalDataError(f"select_modes: n must be a positive integer, got {n!r}")
        n = int(n)
        if n > self.n_modes:
            raise ModalDataError(
                f"{self.file_name}: the file holds {self.n_modes} modes, {n} requested"
            )
        return replace(
            self,
            frequencies=self.frequencies[:n], modal_masses=self.modal_masses[:n],
            shapes=self.shapes[:, :, :n],
            damping=None if self.damping is None else self.damping[:n],
            participation=None if self.participation is None else self.participation[:, :n],
            mode_numbers=self.mode_numbers[:n],
        )

    def with_table(self, table: Mapping[str, Any]) -> ModeSet:
        """This set with damping, modal masses and/or participation from a per-mode table.

        Parameters
        ----------
        table : mapping
            See :func:`mode_table_arrays` (e.g. the result of
            :func:`sloshrom.beam.simulation.modal_files.read_mode_table`): ``damping`` (-),
            ``modal_mass`` (kg), ``participation`` (kg, +Z) or ``participation_x/_y/_z`` (kg).

        Returns
        -------
        ModeSet
            Given columns replace the set's values, matched by mode number
            (:attr:`mode_numbers`: row k of a column is mode k); a participation component not
            given keeps the set's value (NaN, unknown, if the set has none).
        """
        cols = mode_table_arrays(table, self.n_modes, "mode table", self.mode_numbers)
        kw: dict[str, Any] = {}
        if "damping" in cols:
            kw["damping"] = cols["damping"]
        if "modal_mass" in cols:
            kw["modal_masses"] = cols["modal_mass"]
        comps = [c for c in ("participation_x", "participation_y", "participation_z")
                 if c in cols]
        if comps:
            part = (np.full((3, self.n_modes), np.nan) if self.participation is None
                    else np.array(self.participation))
            for c in comps:
                part["xyz".index(c[-1])] = cols[c]
            kw["participation"] = part
        return replace(self, **kw)

    # -- constructors -----------------------------------------------------------------------
    @classmethod
    def from_cantilever(
        cls,
        beam: CantileverBeam | None = None,
        tank: Tank | None = None,
        n_modes: int = 3,
        stations: Sequence[float] | None = None,
        damping: Sequence[float] | None = None,
    ) -> ModeSet:
        """The built-in cantilever (:meth:`ModalModel.from_beam`) as a mode set.

        Nodes ``1..S`` sit at the stations (x = station position in m, y = z = 0); the shapes
        are the beam's vertical displacement in z (x and y zero); participation z is Gamma
        (x and y zero: the beam does not move along them); damping and modal masses are those of
        ``from_beam``. The tank is at the tip, the last station (node S): with the default
        stations, ``to_modal_model(tanks=S, outputs=range(1, S + 1))`` reproduces
        ``ModalModel.from_beam()``.
        """
        mm = ModalModel.from_beam(beam, tank, n_modes, damping, stations)
        s = mm.stations.size
        shapes = np.zeros((s, 3, mm.n_modes))
        shapes[:, 2, :] = mm.psi_stations
        part = np.zeros((3, mm.n_modes))
        part[2] = mm.participation
        coords = np.zeros((s, 3))
        coords[:, 0] = mm.stations
        return cls(
            frequencies=mm.frequencies, modal_masses=mm.modal_masses,
            nodes=np.arange(1, s + 1), shapes=shapes, damping=mm.damping,
            participation=part, coordinates=coords, source="cantilever:euler-bernoulli",
            attrs={"beam": mm.attrs.get("beam", {}), "structure_mass": mm.structure_mass},
        )

    # -- conversion -------------------------------------------------------------------------
    def to_modal_model(
        self,
        tanks: int | Sequence[int],
        outputs: Sequence[int] | None = None,
        direction: str = "+Z",
        structure_mass: float | Sequence[float] = 0.45,
        damping: Sequence[float] | None = None,
    ) -> ModalModel:
        """The modal model the coupled simulation uses, at the tank and sensor nodes.

        Parameters
        ----------
        tanks : int or sequence of int
            Node ID of the tank (one tank: ``psi_tank`` of shape ``(n_modes,)``) or IDs of
            several tanks (``(n_tanks, n_modes)``).
        outputs : sequence of int, optional
            Node IDs of the virtual accelerometers. Default: every node, if the model has at
            most :data:`MAX_DEFAULT_OUTPUTS` nodes.
        direction : str
            The structure's "up", the axis the tank is shaken along: ``+X, -X, +Y, -Y, +Z, -Z``
            (case-insensitive). A ``-`` axis flips the sign of shapes and participation.
        structure_mass : float or sequence of float
            Tank structure mass above the interface, kg (one per tank for several tanks).
        damping : sequence of float, optional
            Modal damping ratios (-); default: the set's damping.

        Returns
        -------
        ModalModel
            ``stations`` are the outputs' coordinates (m) along the axis of largest extent of
            the output nodes when coordinates are known, else ``0, 1, 2, ...``;
            ``participation`` is None when the set's participation along ``direction`` is
            unknown (base excitation then refuses); ``attrs`` holds ``modes_source`` and
            ``direction``; ``station_ids`` / ``tank_ids`` the node IDs.

        Raises
        ------
        ModalDataError
            Unknown direction, a node not in the set, too many nodes for default outputs, no
            damping anywhere, more than :data:`MAX_MODES` modes (checked first: before any
            work on them).
        """
        if self.n_modes > MAX_MODES:
            raise ModalDataError(
                f"{self.file_name} holds {self.n_modes} modes; a modal model takes at most "
                f"{MAX_MODES} (the coupled simulation solves an n x n eigenproblem): keep the "
                f"lowest with select_modes(n) (sloshrom beam --modes N)")
        key = str(direction).strip().upper()
        if key not in DIRECTIONS:
            raise ModalDataError(
                f"direction {direction!r}: use one of {', '.join(DIRECTIONS)} (the structure's "
                "up axis)"
            )
        comp, sign = DIRECTIONS[key]
        one_tank = np.ndim(tanks) == 0
        tank_idx = self.node_index(tanks, "grid")
        if outputs is None:
            if self.n_nodes > MAX_DEFAULT_OUTPUTS:
                raise ModalDataError(
                    f"{self.file_name} has {self.n_nodes} nodes: give outputs=[...] (the node "
                    f"IDs of the virtual accelerometers; every node is the default up to "
                    f"{MAX_DEFAULT_OUTPUTS})"
                )
            out_idx = np.arange(self.n_nodes)
        else:
            out_idx = self.node_index(outputs, "grid")
        if damping is not None:
            zeta = _vector("damping", damping, self.n_modes, "to_modal_model")
        elif self.damping is not None:
            zeta = self.damping
        else:
            raise ModalDataError(
                f"no modal damping in {self.file_name}: give a mode table with a damping column"
            )
        psi = sign * self.shapes[:, comp, :]
        psi_tank = psi[tank_idx[0]] if one_tank else psi[tank_idx]
        participation = None
        if self.participation is not None and np.all(np.isfinite(self.participation[comp])):
            participation = sign * self.participation[comp]
        if self.coordinates is not None:
            xyz = self.coordinates[out_idx]
            axis = int(np.argmax(np.ptp(xyz, axis=0)))
            stations = xyz[:, axis].copy()
        else:
            stations = np.arange(out_idx.size, dtype=float)
        if not one_tank and np.ndim(structure_mass) == 0:
            structure_mass = [float(structure_mass)] * tank_idx.size  # type: ignore[arg-type]
        kwargs: dict[str, Any] = {
            "frequencies": np.array(self.frequencies), "damping": np.array(zeta),
            "modal_masses": np.array(self.modal_masses), "psi_tank": np.array(psi_tank),
            "participation": participation, "stations": stations,
            "psi_stations": np.array(psi[out_idx]), "structure_mass": structure_mass,
            "length": None, "source": f"modes:{self.source}" if self.source else "modes",
            "attrs": {"modes_source": self.source, "direction": key},
        }
        kwargs["station_ids"] = tuple(int(self.nodes[i]) for i in out_idx)
        kwargs["tank_ids"] = tuple(int(self.nodes[i]) for i in tank_idx)
        return ModalModel(**kwargs)
