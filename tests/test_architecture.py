"""The package's architecture, checked on the source: rooms, the direction of imports, no cycles.

Every module under ``src/sloshrom`` is parsed (nothing is imported) and put in a *room*:

========== =======================================================================
base       ``sloshrom`` (root), ``config``, ``errors``, ``fidelity``, ``fileio``, ``limits``,
           ``models``, ``signals``, ``_x64``, ``_jit``, ``_memory``, ``_workers``
domain     ``io``, ``rig``, ``rom``, ``energy``, ``beam``, ``systems`` (each one room)
plotting   ``plotting``: figures only
pipeline   ``pipeline``: the reproduce chain, the settings and the studies' registry
studies    ``studies``: one package per study beyond the paper
cli        ``cli``: the command line
========== =======================================================================

Imports point one way, ``cli -> studies -> pipeline -> plotting / domain rooms -> base``;
:data:`ALLOWED` is the table of the rooms each room may import. The studies' registry is below
the pipeline (:data:`REGISTRY`, in the pipeline room: it names the studies as strings), so that
no module of the pipeline imports a study; a study imports the pipeline's infrastructure
(:data:`FOR_STUDIES`).
Below the rooms, only the capability checks (:data:`CAPABILITIES`) ask a model what kind of
model it is, no module outside a ROM class's package names the class (:data:`OWNERS`), the ROM
room's floors hold (:data:`ROM_ANY_CLASS`), and no module raises a plain ``ValueError``. See
``docs/architecture.md``.
"""

from __future__ import annotations

import ast
import functools
import re
from dataclasses import dataclass
from pathlib import Path

import pytest

from sloshrom.rom.registry import CLASSES, packages

SRC = Path(__file__).resolve().parents[1] / "src"
PACKAGE = "sloshrom"

BASE = {"_jit", "_memory", "_threads", "_workers", "_x64", "config", "errors", "fidelity",
        "fileio", "limits", "models", "signals"}
DOMAIN = ("io", "rig", "rom", "energy", "beam", "systems")

#: The rooms each room may import (its own room is always allowed). Domain rooms see the base
#: and ``io`` (the records they read), never each other: a sloshing model reaches the beam and
#: the energy maps through the step contract of ``sloshrom.models``, not through ``rig``/``rom``.
#: Plotting draws what the domain rooms compute (it may call their analysis functions).
ALLOWED: dict[str, set[str]] = {
    "base": {"base"},
    "io": {"base"},
    "rig": {"base", "io"},
    "rom": {"base", "io"},
    "energy": {"base", "io"},
    "beam": {"base", "io"},
    "systems": {"base", "io"},
    "plotting": {"base", *DOMAIN},
    "pipeline": {"base", *DOMAIN, "plotting"},
    "studies": {"base", *DOMAIN, "plotting", "pipeline"},
    "cli": {"base", *DOMAIN, "plotting", "pipeline"},
}

#: The registry of the studies (``STUDIES``: each study's package, as a string), below the
#: pipeline: the settings assemble the configuration from the studies' tables through it, the
#: chain and the report run and show the studies ``sloshrom.pipeline.study.registered`` gives.
REGISTRY = "sloshrom.pipeline.registry"
#: The room of the studies' packages.
STUDIES_ROOM = "sloshrom.studies"
#: The pipeline modules a study may import: the infrastructure (the tables' schema, settings,
#: cache, run context, HTML, the experiment's report tables, the study protocol) and the
#: paper's stage modules whose helpers a study reuses (records, ROM errors, beam tests, maps);
#: never the chain or the report, which run and show the studies.
FOR_STUDIES = {f"sloshrom.pipeline.{m}" for m in
               ("schema", "settings", "cache", "context", "html", "experiment", "study", "data",
                "rom", "beam", "maps")}

#: Calls that change process-wide state of a library the user's process shares with us.
FORBIDDEN_CALLS = {
    "jax.config.update": "flips a JAX flag for the whole process (use jax.enable_x64(True) "
                         "around our own calls)",
    "matplotlib.use": "selects a backend for the user's process",
    "matplotlib.pyplot.switch_backend": "selects a backend for the user's process",
}


@dataclass(frozen=True)
class Import:
    """One import statement of a module, resolved to the module it loads."""

    target: str  # dotted name of the imported module (deepest existing module)
    line: int
    in_function: bool
    type_checking: bool


@functools.cache
def _tree(source: str) -> ast.Module:
    """The syntax tree of a source, parsed once a process: the package's ~170 modules take
    seconds to parse, and most tests below walk all of them (read only)."""
    return ast.parse(source)


def _module_name(path: Path) -> str:
    parts = list(path.relative_to(SRC).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


MODULES: dict[str, Path] = {
    _module_name(p): p for p in sorted((SRC / PACKAGE).rglob("*.py"))
}


def room(module: str) -> str:
    """The room of a module of the package (``base`` for the root and base modules)."""
    parts = module.split(".")
    if len(parts) == 1 or parts[1] in BASE:
        return "base"
    if parts[1] in (*DOMAIN, "plotting", "pipeline", "studies", "cli"):
        return parts[1]
    raise AssertionError(f"{module}: in no room; add it to the table of tests/test_architecture")


def _resolve(module: str, name: str) -> str:
    """The deepest module of the package that ``name`` (dotted) denotes."""
    parts = name.split(".")
    while parts and ".".join(parts) not in MODULES:
        parts.pop()
    return ".".join(parts) if parts else name


def _absolute(module: str, node: ast.ImportFrom) -> str:
    if not node.level:
        return node.module or ""
    is_package = MODULES[module].name == "__init__.py"
    base = module.split(".")
    base = base if is_package else base[:-1]
    base = base[: len(base) - (node.level - 1)]
    return ".".join([*base, node.module] if node.module else base)


class _Visitor(ast.NodeVisitor):
    def __init__(self, module: str) -> None:
        self.module = module
        self.imports: list[Import] = []
        self.aliases: dict[str, str] = {}  # local name -> dotted name it is bound to
        self.calls: list[tuple[str, int]] = []
        self._function = 0
        self._type_checking = 0

    def _add(self, target: str, line: int) -> None:
        imp = Import(target, line, self._function > 0, self._type_checking > 0)
        if imp not in self.imports:  # `from m import a, b` is one import of m
            self.imports.append(imp)

    def visit_Import(self, node: ast.Import) -> None:
        for a in node.names:
            if a.asname:
                self.aliases[a.asname] = a.name
            else:
                self.aliases[a.name.split(".")[0]] = a.name.split(".")[0]
            if a.name.split(".")[0] == PACKAGE:
                self._add(_resolve(self.module, a.name), node.lineno)

    def visit_ImportFrom(self, node: ast.ImportFrom) -> None:
        source = _absolute(self.module, node)
        for a in node.names:
            self.aliases[a.asname or a.name] = f"{source}.{a.name}"
            if source.split(".")[0] == PACKAGE:
                self._add(_resolve(self.module, f"{source}.{a.name}"), node.lineno)

    def _scope(self, node: ast.AST) -> None:
        self._function += 1
        self.generic_visit(node)
        self._function -= 1

    visit_FunctionDef = visit_AsyncFunctionDef = visit_Lambda = _scope

    def visit_If(self, node: ast.If) -> None:
        test = ast.unparse(node.test)
        if test in ("TYPE_CHECKING", "typing.TYPE_CHECKING"):
            self._type_checking += 1
            for child in node.body:
                self.visit(child)
            self._type_checking -= 1
            for child in node.orelse:
                self.visit(child)
        else:
            self.generic_visit(node)

    def visit_Call(self, node: ast.Call) -> None:
        chain, func = [], node.func
        while isinstance(func, ast.Attribute):
            chain.append(func.attr)
            func = func.value
        if isinstance(func, ast.Name):
            head = self.aliases.get(func.id, func.id)
            self.calls.append((".".join([head, *reversed(chain)]), node.lineno))
        self.generic_visit(node)


def _parse(module: str) -> _Visitor:
    v = _Visitor(module)
    v.visit(_tree(MODULES[module].read_text(encoding="utf-8")))
    return v


@functools.cache
def parsed() -> dict[str, _Visitor]:
    """Every module's imports and calls, parsed once a process when a test first asks: not at
    collection, where every test worker would parse the package."""
    return {m: _parse(m) for m in MODULES}


def _where(module: str, imp: Import) -> str:
    return f"{MODULES[module].relative_to(SRC)}:{imp.line} imports {imp.target}"


# ---------------------------------------------------------------------------------------------
def test_every_module_is_in_a_room():
    assert len(MODULES) > 20
    for module in MODULES:
        assert room(module) in ALLOWED


def test_nothing_outside_cli_imports_cli():
    bad = [_where(m, i) for m, v in parsed().items() for i in v.imports
           if room(m) != "cli" and room(i.target) == "cli"]
    assert not bad, "only the command line imports sloshrom.cli:\n" + "\n".join(bad)


def test_imports_point_one_way():
    bad = [f"{_where(m, i)} ({room(m)} -> {room(i.target)})"
           for m, v in parsed().items() for i in v.imports
           if room(i.target) != room(m) and room(i.target) not in ALLOWED[room(m)]]
    assert not bad, "imports against the direction of the rooms:\n" + "\n".join(bad)


#: The beam's rooms, in order: each imports only itself and the rooms before it. ``errors`` (the
#: room's error types) is below every other; the simulation (structures, the coupled runs)
#: knows no analysis; the damping analyses read responses, not files; the laboratory's files
#: are read, written and analysed with both; ``results`` writes every room's result files (a
#: measured test's names its channel map); the comparison sets them side by side.
BEAM_ROOMS = ("errors", "simulation", "damping", "lab", "results", "compare")


def beam_room(module: str) -> str | None:
    """The room of a module inside ``sloshrom.beam`` (``None`` for the package itself and any
    module outside the beam)."""
    parts = module.split(".")
    if len(parts) < 3 or parts[1] != "beam":
        return None
    if parts[2] not in BEAM_ROOMS:
        raise AssertionError(f"{module}: in no room of the beam; add it to BEAM_ROOMS of "
                             "tests/test_architecture")
    return parts[2]


def test_the_beam_rooms_import_one_way():
    """Simulation, damping analysis, laboratory files, comparison: each beam room imports the
    rooms before it in :data:`BEAM_ROOMS` only (``if TYPE_CHECKING`` imports included)."""
    order = {r: i for i, r in enumerate(BEAM_ROOMS)}
    rooms = {beam_room(m) for m in MODULES} - {None}
    assert rooms == set(BEAM_ROOMS), rooms
    bad = [f"{_where(m, i)} ({beam_room(m)} -> {beam_room(i.target)})"
           for m, v in parsed().items() if beam_room(m) is not None for i in v.imports
           if beam_room(i.target) is not None
           and order[beam_room(i.target)] > order[beam_room(m)]]
    assert not bad, "imports against the order of the beam's rooms:\n" + "\n".join(bad)


#: The floors of the rooms, top down: a room imports rooms of its floor or below only
#: (:data:`ALLOWED` says which), so that an import of a room above runs back up the floors.
FLOORS: tuple[tuple[str, ...], ...] = (("cli",), ("studies",), ("pipeline",), ("plotting",),
                                       DOMAIN, ("base",))


def _floor(r: str) -> int:
    return next(i for i, rooms in enumerate(FLOORS) if r in rooms)


def _runs_up(module: str, target: str) -> bool:
    """Whether ``module`` importing ``target`` runs back up the floors (to a room above)."""
    return _floor(room(target)) < _floor(room(module))


def test_no_import_runs_back_up_the_floors():
    """0 imports from a floor to one above it: the studies' registry is the pipeline's, and
    names the studies as strings (the one such import there was, from the chain and the
    report, is gone)."""
    assert {r for rooms in FLOORS for r in rooms} == set(ALLOWED)
    up = [f"{_where(m, i)} ({room(m)} -> {room(i.target)})" for m, v in parsed().items()
          for i in v.imports if _runs_up(m, i.target)]
    assert len(up) == 0, "imports running back up the floors:\n" + "\n".join(up)
    # the finder finds what it should
    assert _runs_up("sloshrom.pipeline.chain", f"{STUDIES_ROOM}.fills.study")
    assert not _runs_up(f"{STUDIES_ROOM}.fills.study", "sloshrom.pipeline.study")


def _crosses_seam(module: str, target: str) -> bool:
    """Whether ``module`` importing ``target`` breaks the pipeline/studies seam: the pipeline
    imports no study (the registry names them as strings); a study imports only
    :data:`FOR_STUDIES` of the pipeline."""
    if room(module) == "pipeline" and room(target) == "studies":
        return True
    return room(module) == "studies" and room(target) == "pipeline" \
        and target not in FOR_STUDIES


def test_the_seam_rule_refuses_what_it_should():
    chain, report = "sloshrom.pipeline.chain", "sloshrom.pipeline.report"
    assert not _crosses_seam(chain, REGISTRY) and not _crosses_seam(report, REGISTRY)
    for study in _study_packages():  # a study by name, even from the chain or the settings
        assert _crosses_seam(chain, f"{study}.stage") and _crosses_seam(report, study)
        assert _crosses_seam("sloshrom.pipeline.settings", f"{study}.table")
    assert _crosses_seam(f"{STUDIES_ROOM}.fills.stage", chain)
    assert not _crosses_seam(f"{STUDIES_ROOM}.fills.stage", "sloshrom.pipeline.study")
    assert not _crosses_seam(f"{STUDIES_ROOM}.fills.table", "sloshrom.pipeline.schema")


def test_pipeline_and_studies_meet_at_one_seam():
    """The pipeline imports no ``sloshrom.studies`` module; a study imports only the pipeline's
    infrastructure and the paper's stage helpers (so no study depends on the chain)."""
    bad = [_where(m, i) for m, v in parsed().items() for i in v.imports
           if _crosses_seam(m, i.target)]
    assert not bad, "imports across the pipeline/studies seam:\n" + "\n".join(bad)
    # the settings (the studies' tables) and the protocol (their declarations) reach the
    # studies through the registry
    for m in ("sloshrom.pipeline.settings", "sloshrom.pipeline.study"):
        assert REGISTRY in {i.target for i in parsed()[m].imports}, m


def _study_packages() -> list[str]:
    """The packages directly under ``sloshrom.studies``: one per study."""
    return sorted(m for m in MODULES if m.startswith(f"{STUDIES_ROOM}.")
                  and m.count(".") == 2 and MODULES[m].name == "__init__.py")


def _registry_entries() -> list[str]:
    """The packages of ``STUDIES`` in the registry, read from its source."""
    tree = _tree(MODULES[REGISTRY].read_text(encoding="utf-8"))
    for node in tree.body:
        target = node.target if isinstance(node, ast.AnnAssign) else (
            node.targets[0] if isinstance(node, ast.Assign) else None)
        if isinstance(target, ast.Name) and target.id == "STUDIES":
            return list(ast.literal_eval(node.value))
    raise AssertionError(f"{REGISTRY} has no STUDIES")


def _assigned(module: str) -> set[str]:
    tree = _tree(MODULES[module].read_text(encoding="utf-8"))
    return {t.id for n in tree.body if isinstance(n, ast.Assign) for t in n.targets
            if isinstance(t, ast.Name)}


def test_every_study_is_registered_once_with_its_declaration():
    """Each study package is one line of the registry, with its declaration (``study``, which
    assigns ``STUDY``) and its part of the configuration (``table``, which assigns ``TABLE``,
    its defaults in ``defaults.toml`` beside it): a study that is not registered would never
    run, one without its table could not be configured."""
    entries = _registry_entries()
    packages = _study_packages()
    assert len(packages) >= 3
    assert sorted(entries) == packages
    assert len(set(entries)) == len(entries)
    for entry in entries:
        assert "STUDY" in _assigned(f"{entry}.study"), f"{entry}.study does not assign STUDY"
        assert "TABLE" in _assigned(f"{entry}.table"), f"{entry}.table does not assign TABLE"
        assert (MODULES[entry].parent / "defaults.toml").is_file(), entry
        # the package itself imports nothing: the settings read its table when they start
        assert not parsed()[entry].imports, entry


def _cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """Strongly connected components with more than one module, or a module importing itself
    (Tarjan's algorithm, iterative)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    out: list[list[str]] = []
    counter = 0
    for root in sorted(graph):
        if root in index:
            continue
        work = [(root, iter(sorted(graph[root])))]
        index[root] = low[root] = counter
        counter += 1
        stack.append(root)
        on_stack.add(root)
        while work:
            node, children = work[-1]
            child = next(children, None)
            if child is not None:
                if child not in index:
                    index[child] = low[child] = counter
                    counter += 1
                    stack.append(child)
                    on_stack.add(child)
                    work.append((child, iter(sorted(graph.get(child, ())))))
                elif child in on_stack:
                    low[node] = min(low[node], index[child])
                continue
            work.pop()
            if work:
                low[work[-1][0]] = min(low[work[-1][0]], low[node])
            if low[node] == index[node]:
                comp = []
                while True:
                    top = stack.pop()
                    on_stack.discard(top)
                    comp.append(top)
                    if top == node:
                        break
                if len(comp) > 1 or node in graph.get(node, ()):
                    out.append(sorted(comp))
    return out


def test_cycle_finder():
    assert _cycles({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}) == [["a", "b", "c"]]
    assert _cycles({"a": {"b"}, "b": set()}) == []
    assert _cycles({"a": {"a"}}) == [["a"]]


def test_no_import_cycles():
    """Run-time imports (module level and inside functions; not ``if TYPE_CHECKING``)."""
    graph = {m: {i.target for i in v.imports if not i.type_checking and i.target != m}
             for m, v in parsed().items()}
    cycles = _cycles(graph)
    lines = []
    for comp in cycles:
        members = set(comp)
        lines.append(" <-> ".join(comp) + ": " + "; ".join(
            _where(m, i) for m in comp for i in parsed()[m].imports
            if i.target in members and not i.type_checking))
    assert not cycles, "import cycles:\n" + "\n".join(lines)


@pytest.mark.parametrize("call", sorted(FORBIDDEN_CALLS))
def test_no_process_wide_switches(call):
    bad = [f"{MODULES[m].relative_to(SRC)}:{line}" for m, v in parsed().items()
           for name, line in v.calls if name == call]
    assert not bad, f"{call} {FORBIDDEN_CALLS[call]}: " + ", ".join(bad)


#: Rooms whose import loads JAX, numba, xarray or matplotlib (seconds): the command line imports
#: them inside the command that needs them, so that ``sloshrom --help`` and argument errors stay
#: instant. Nothing else imports a module of the package inside a function.
HEAVY_FOR_CLI = {"rom", "rig", "beam", "energy", "plotting", "pipeline", "studies"}


def test_no_function_local_imports_of_the_package():
    """Imports inside functions are for optional or heavy third-party packages only."""
    bad = [_where(m, i) for m, v in parsed().items() for i in v.imports if i.in_function
           and not (room(m) == "cli" and room(i.target) in HEAVY_FOR_CLI
                    and i.target != "sloshrom.pipeline.settings")]
    assert not bad, "function-local imports of sloshrom modules:\n" + "\n".join(bad)


# -- the model contract: one place asks a model what it is -------------------------------------
#: The concrete sloshing-model classes (and their estimators' base) and the module of each.
MODEL_CLASSES = {
    "FrozenLiquid": "sloshrom.models", "VirtualRig": "sloshrom.rig.virtual",
    "Network": "sloshrom.rom.tdnn.network", "FittedNetwork": "sloshrom.rom.network",
    "NFIRNetwork": "sloshrom.rom.tdnn.network", "NOENetwork": "sloshrom.rom.tdnn.network",
    "StateSpaceNetwork": "sloshrom.rom.nss.network", "NSS": "sloshrom.rom.nss.estimator",
    "LinearStateSpace": "sloshrom.rom.lss.estimator", "LSS": "sloshrom.rom.lss.estimator",
    "Estimator": "sloshrom.rom.base",
    "NFIR": "sloshrom.rom.tdnn.estimators",
    "NOE": "sloshrom.rom.tdnn.estimators",
    "TimeDelayEstimator": "sloshrom.rom.tdnn.estimators",
    "Ensemble": "sloshrom.rom.ensemble", "FillFamily": "sloshrom.rom.family",
    "FillBlend": "sloshrom.rom.family", "BouncingBall": "sloshrom.rom.ball.model",
    "Ball": "sloshrom.rom.ball.model",
    "CompiledKernel": "sloshrom.models",  # a protocol: isinstance asks for kernel()
}
#: Members by which a model says what kind of model it is.
KIND_MEMBERS = {"input", "input_variable", "jax_traceable", "envelope_", "tank", "fill_range",
                "members_", "model_", "kernel",
                # what a model is made of: its architecture, its registry entry
                "spec", "model_class"}
#: The capability checks: the only functions that dispatch on the kind of model (by
#: ``isinstance`` on a model class or by asking for one of :data:`KIND_MEMBERS`). Each is
#: documented where it is defined; docs/architecture.md lists them.
CAPABILITIES = {
    "sloshrom.models": {"input_of", "is_jax_model", "has_kernel", "has_no_force", "tank_of",
                        "_envelope_mapping"},
    "sloshrom.rom.network": {"network_of"},
    "sloshrom.rom.ensemble": {"is_ensemble"},
    "sloshrom.rom.family": {"training_fills", "at_fill"},
}


def _dispatch_sites() -> list[tuple[str, str, int, str]]:
    """``(module, enclosing function, line, what)`` of every isinstance on a model class and
    every getattr/hasattr of a kind member on something other than ``self``/``cls``."""
    out = []
    for mod, path in MODULES.items():
        tree = _tree(path.read_text(encoding="utf-8"))

        def visit(node: ast.AST, func: str, mod: str = mod) -> None:
            for child in ast.iter_child_nodes(node):
                name = child.name if isinstance(child, ast.FunctionDef | ast.AsyncFunctionDef) \
                    else func
                if isinstance(child, ast.Call) and isinstance(child.func, ast.Name):
                    args = child.args
                    if child.func.id == "isinstance" and len(args) == 2:
                        kinds = args[1].elts if isinstance(args[1], ast.Tuple) else [args[1]]
                        hit = [k.id for k in kinds if isinstance(k, ast.Name)
                               and k.id in MODEL_CLASSES]
                        if hit:
                            out.append((mod, func, child.lineno, f"isinstance {hit}"))
                    if child.func.id in ("getattr", "hasattr") and len(args) >= 2 \
                            and isinstance(args[1], ast.Constant) \
                            and args[1].value in KIND_MEMBERS \
                            and not (isinstance(args[0], ast.Name)
                                     and args[0].id in ("self", "cls")):
                        out.append((mod, func, child.lineno,
                                    f"{child.func.id} {args[1].value!r}"))
                visit(child, name)

        visit(tree, "<module>")
    return out


def test_only_the_capability_checks_dispatch_on_the_kind_of_model():
    bad = [f"{MODULES[m].relative_to(SRC)}:{line} in {f}: {what}"
           for m, f, line, what in _dispatch_sites() if f not in CAPABILITIES.get(m, set())]
    assert not bad, ("dispatch on the kind of model outside the capability checks (use "
                     "sloshrom.models' functions or add a documented one):\n" + "\n".join(bad))


def test_the_capability_checks_are_few_and_documented():
    n = sum(len(v) for v in CAPABILITIES.values())
    assert n <= 10, f"{n} capability checks: the contract is splitting again"
    for mod, names in CAPABILITIES.items():
        tree = _tree(MODULES[mod].read_text(encoding="utf-8"))
        defs = {f.name: f for f in tree.body if isinstance(f, ast.FunctionDef)}
        for name in names:
            assert name in defs, f"{mod}.{name} is not a module-level function"
            assert ast.get_docstring(defs[name]), f"{mod}.{name} has no docstring"
    # the finder finds what it should: each check dispatches at least once
    sites = {(m, f) for m, f, _, _ in _dispatch_sites()}
    assert {(m, f) for m, names in CAPABILITIES.items() for f in names} <= sites


# -- the registry of ROM classes: each class one package, named nowhere else -------------------
def _package_of(mc) -> str:
    """The package of a class (``sloshrom.rom.nss``): its estimator's module's package."""
    return mc.estimator.split(":")[0].rsplit(".", 1)[0]


#: Each class's names (``nss``, ``NSS``) and the package that owns them.
OWNERS: dict[str, str] = {n: _package_of(mc) for mc in CLASSES.values()
                          for n in (mc.name, mc.class_name)}
#: Spec (architecture) types of the classes and their packages: nothing outside asks for one.
SPEC_TYPES = {"NetworkSpec": "sloshrom.rom.tdnn", "StateSpaceSpec": "sloshrom.rom.nss",
              "LinearSpec": "sloshrom.rom.lss"}
#: Names of a class spelled outside its package, and why: ``(module, name)``. Everything else
#: reads the registry (a class's entry, its estimator, its fitted model's methods).
NAMES_CLASSES = {
    # the public API ``sloshrom.NFIR``, ``sloshrom.NOE``: the root re-exports them lazily by
    # name, since the base imports nothing of the rooms above it (not even the registry)
    ("sloshrom", "NFIR"): "the package root's lazy re-export of sloshrom.NFIR",
    ("sloshrom", "NOE"): "the package root's lazy re-export of sloshrom.NOE",
    # the FMU's C kernel of a state-space member (rom/fmu_c, first written for the NSS): the
    # linear model lowers itself to it, a member without hidden units
    ("sloshrom.rom.lss.estimator", "NSS"): "the FMU kernel SL_NSS of rom/fmu_c",
}


def _entries(tree: ast.AST) -> set[int]:
    # the registry's list of the classes (``ENTRIES``): the one place naming every entry
    out = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.AnnAssign | ast.Assign) and any(
                isinstance(t, ast.Name) and t.id == "ENTRIES"
                for t in (node.targets if isinstance(node, ast.Assign) else [node.target])):
            out |= {id(c) for c in ast.walk(node.value)} if node.value is not None else set()
    return out


def _inside(module: str, package: str) -> bool:
    return module == package or module.startswith(package + ".")


def _words(text: str) -> set[str]:
    """The names a string spells: itself, or the words of a key (a string without spaces
    split at ``.``, ``_`` and the like: ``"sweep_nfir_delays"``, ``"rom.nss.n_states"``); a
    sentence is prose and not split."""
    if any(c.isspace() for c in text):
        return {text}
    return {text, *re.split(r"[._:/\[\]'\"=-]+", text)}


def class_name_uses(source: str, module: str) -> list[tuple[int, str]]:
    """``(line, what)`` of every place of ``source`` (the module ``module``) that names a class
    it does not own: a comparison with a class's name (``arch == "nss"``, ``in ("nfir",
    "noe")``), a dict keyed by names (``{"nfir": NFIR, ...}``), any other string literal that
    is a name or a key made of one (``"nfir"``, ``"sweep_nfir_delays"``; docstrings and
    ``__all__`` aside), an ``isinstance`` on a spec type."""
    tree = _tree(source)
    skip = _docstrings(tree) | _all_lists(tree) | _entries(tree)

    def foreign(c: ast.AST) -> str | None:
        if not isinstance(c, ast.Constant) or not isinstance(c.value, str) or id(c) in skip:
            return None
        return next((w for w in sorted(_words(c.value))
                     if w in OWNERS and not _inside(module, OWNERS[w])), None)

    out, seen = [], set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Compare | ast.Dict):
            parts = [node.left, *node.comparators] if isinstance(node, ast.Compare) \
                else [k for k in node.keys if k is not None]
            consts = [c for p in parts
                      for c in (p.elts if isinstance(p, ast.Tuple | ast.Set | ast.List) else [p])]
            hits = [(c, foreign(c)) for c in consts if foreign(c)]
            seen |= {id(c) for c, _ in hits}
            what = "compares with" if isinstance(node, ast.Compare) else "a dict keyed by"
            out += [(node.lineno, f"{what} {name!r}") for name in dict.fromkeys(n for _, n in hits)]
        if isinstance(node, ast.Call) and isinstance(node.func, ast.Name) \
                and node.func.id == "isinstance" and len(node.args) == 2:
            kinds = node.args[1].elts if isinstance(node.args[1], ast.Tuple) else [node.args[1]]
            out += [(node.lineno, f"isinstance on {k.id}") for k in kinds
                    if isinstance(k, ast.Name) and k.id in SPEC_TYPES
                    and not _inside(module, SPEC_TYPES[k.id])]
    for node in ast.walk(tree):
        name = foreign(node) if id(node) not in seen else None
        if name is not None:
            out.append((node.lineno, f"spells {name!r} in {node.value!r}"))
    return sorted(out)


def _class_name_uses() -> list[str]:
    return [f"{MODULES[m].relative_to(SRC)}:{line}: {what}" for m, path in MODULES.items()
            for line, what in class_name_uses(path.read_text(encoding="utf-8"), m)
            if (m, what.split("'")[1]) not in NAMES_CLASSES]


def test_the_class_name_finder():
    """It finds comparisons, dict dispatches, literals and keys of a class outside its
    package; not prose, docstrings, ``__all__`` or the class's own package."""
    src = ('"""nfir in a docstring is prose."""\n'
           '__all__ = ["NFIR"]\n'
           'a = arch == "nss"\n'
           'b = {"nfir": 1, "noe": 2}[arch]\n'
           'c = rom["nfir"]["max_epochs"]\n'
           'd = "sweep_noe_delays"\n'
           'e = isinstance(s, StateSpaceSpec)\n'
           'f = "an NFIR on the velocity"\n'
           'g = f"rom.{arch}.delays"\n'
           'h = "lssx"\n')
    found = class_name_uses(src, "sloshrom.pipeline.x")
    assert [line for line, _ in found] == [3, 4, 4, 5, 6, 7], found
    assert [w.split()[0] for _, w in found] == ["compares", "a", "a", "spells", "spells",
                                                "isinstance"]
    assert class_name_uses(src.replace("StateSpaceSpec", "NetworkSpec"),
                           "sloshrom.rom.tdnn.x") == [(3, "compares with 'nss'")]


def test_only_the_registry_names_a_class():
    """Only the registry's list and a class's own package name it: 0 comparisons, dict
    dispatches, literals and keys of a class's name outside its own package (and the listed
    exceptions); and none asks for another package's spec type."""
    bad = _class_name_uses()
    assert not bad, ("a ROM class named outside its package (read its entry in the registry, "
                     "or ask its fitted model):\n" + "\n".join(bad))
    for (module, name), why in NAMES_CLASSES.items():  # each exception is still needed
        uses = class_name_uses(MODULES[module].read_text(encoding="utf-8"), module)
        assert any(what.split("'")[1] == name for _, what in uses), \
            f"{module} spells {name} no more: remove its exception ({why})"


def test_every_class_is_one_registry_entry():
    """Each class's estimator says its entry, each entry lives in its package's light module
    ``entry``, and the registry lists each once."""
    from sloshrom.rom.registry import ENTRIES

    for mc in CLASSES.values():
        est = mc.estimator_class()
        assert est.model_class is mc
        module = MODULES[est.__module__]
        assert "registry" not in module.name
        assert f"{_package_of(mc)}.entry:" in " ".join(ENTRIES)
    assert len(set(ENTRIES)) == len(ENTRIES)


#: The floors of the ROM room, bottom up. The classes' packages (``rom/<class>/``) stand on the
#: shared modules (the registry, the estimators' shell, the trainers' engine, the model files);
#: the modules that work on any class (loading, ensembles, the sweep, the exporters) stand on
#: both and reach a class through the registry alone. A module imports its own floor and those
#: below it, never one above; and no class's package imports another's.
ROM_ANY_CLASS = {"sloshrom.rom", "sloshrom.rom.loading", "sloshrom.rom.ensemble",
                 "sloshrom.rom.sweep", "sloshrom.rom.fmu", "sloshrom.rom.fmu_runtime",
                 "sloshrom.rom.onnx"}
CLASS_PACKAGES = sorted(packages())


def _rom_floor(module: str) -> tuple[int, str]:
    """``(floor, package)`` of a module of the ROM room: 0 shared, 1 a class's package, 2 a
    module of any class."""
    pkg = next((p for p in CLASS_PACKAGES if _inside(module, p)), "")
    if pkg:
        return 1, pkg
    return (2 if module in ROM_ANY_CLASS else 0), ""


def test_no_import_runs_back_up_the_rom_floors():
    assert len(CLASS_PACKAGES) >= 4 and "sloshrom.rom.nss" in CLASS_PACKAGES
    bad = []
    for m, v in parsed().items():
        if room(m) != "rom":
            continue
        floor, pkg = _rom_floor(m)
        for i in v.imports:
            if room(i.target) != "rom" or i.type_checking:
                continue
            f, p = _rom_floor(i.target)
            if f > floor or (f == floor == 1 and p != pkg) or (floor == 2 and f == 1):
                bad.append(f"{_where(m, i)} (floor {floor} -> {f})")
    assert not bad, "imports running back up the ROM room's floors:\n" + "\n".join(bad)


# ---------------------------------------------------------------------------------------------
# Errors: one base. Every user error of the package is a SloshromError (also a ValueError) of
# its room; a plain ValueError raised by the package would escape the command line's one-line
# errors as a traceback, as a bug does.

def test_no_plain_value_error_is_raised():
    """``raise ValueError(...)`` (or ``raise ValueError``) nowhere: each room raises its type."""
    bad = []
    for path in MODULES.values():
        for node in ast.walk(_tree(path.read_text(encoding="utf-8"))):
            if not isinstance(node, ast.Raise) or node.exc is None:
                continue
            exc = node.exc.func if isinstance(node.exc, ast.Call) else node.exc
            if isinstance(exc, ast.Name) and exc.id == "ValueError":
                bad.append(f"{path.relative_to(SRC)}:{node.lineno}")
    assert not bad, "plain ValueError raised (use the room's error type):\n" + "\n".join(bad)


def test_every_error_class_is_a_sloshrom_error():
    """Every exception class the package defines derives from SloshromError (or is a warning).

    The one check here that imports the package (every module, JAX and numba included): a
    class's bases are only known once its module ran."""
    import importlib
    import inspect

    from sloshrom.errors import SloshromError

    bad, seen = [], 0
    for module, path in MODULES.items():
        mod = importlib.import_module(module)
        for name, obj in vars(mod).items():
            if not (inspect.isclass(obj) and issubclass(obj, BaseException)
                    and obj.__module__ == module):
                continue
            seen += 1
            if not issubclass(obj, SloshromError | Warning):
                bases = ", ".join(b.__name__ for b in obj.__mro__[1:-1])
                bad.append(f"{path.relative_to(SRC)}: {name} ({bases})")
    assert seen >= 10, seen  # the walk found the package's error classes
    assert not bad, "error classes that are not a SloshromError:\n" + "\n".join(bad)


# -- damping estimators: one registry, no names spelled elsewhere --------------------------------
#: Modules that may spell a registered estimator's name as a string, and why. Every other
#: module reaches an estimator through ``sloshrom.beam.damping.registry`` (``TABLE2``,
#: ``REFERENCE``, ``get_estimator``, the ``estimator`` coordinate of a result dataset). An
#: estimator's own class may spell it once, as the value of its ``name`` attribute (that is the
#: definition).
ESTIMATOR_NAME_ALLOWED = {
    # the two-mode study's own result column "half_power" (its half-power cross-check of each
    # mode, a file contract of its tables), not the registry's Table 2 estimator
    "sloshrom.beam.damping.multimode": "file contract of the two-mode study's tables",
}


def _docstrings(tree: ast.AST) -> set[int]:
    out = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Module | ast.ClassDef | ast.FunctionDef | ast.AsyncFunctionDef):
            body = node.body
            if body and isinstance(body[0], ast.Expr) and isinstance(body[0].value, ast.Constant):
                out.add(id(body[0].value))
    return out


def _name_definitions(tree: ast.AST) -> set[int]:
    # ``name: str = "lscf_h1"`` (or ``name = ...``) in a class body: an estimator's definition
    out = set()
    for cls in ast.walk(tree):
        if isinstance(cls, ast.ClassDef):
            for st in cls.body:
                target = st.target if isinstance(st, ast.AnnAssign) else (
                    st.targets[0] if isinstance(st, ast.Assign) and len(st.targets) == 1
                    else None)
                if isinstance(target, ast.Name) and target.id == "name" \
                        and isinstance(st.value, ast.Constant):
                    out.add(id(st.value))
    return out


def _all_lists(tree: ast.AST) -> set[int]:
    # the names a module exports (``__all__``) are function names, not estimator names
    out = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Assign) and any(isinstance(t, ast.Name) and t.id == "__all__"
                                                for t in node.targets):
            out |= {id(c) for c in ast.walk(node.value)}
    return out


def _literals_in(source: str, names: set[str]) -> list[tuple[int, str]]:
    tree = _tree(source)
    skip = _docstrings(tree) | _name_definitions(tree) | _all_lists(tree)
    return [(node.lineno, node.value) for node in ast.walk(tree)
            if isinstance(node, ast.Constant) and isinstance(node.value, str)
            and id(node) not in skip
            and any(node.value == n or node.value.startswith(n + "_") for n in names)]


def estimator_name_literals(names: set[str]) -> list[str]:
    """Every string literal (f-string parts included; docstrings, ``__all__`` and estimators'
    ``name`` definitions excluded) that is a registered estimator's name or starts with one and
    ``_`` (a composed key such as ``"lscf_h1_std"``), outside :data:`ESTIMATOR_NAME_ALLOWED`."""
    return [f"{mod}:{line}: {text!r}" for mod, path in MODULES.items()
            if mod not in ESTIMATOR_NAME_ALLOWED
            for line, text in _literals_in(path.read_text(encoding="utf-8"), names)]


def test_the_estimator_name_finder():
    src = (
        '"""lscf_h1 in a docstring is prose."""\n'
        '__all__ = ["lscf_h1_table"]\n'
        'class E:\n    name: str = "lscf_h1"\n'
        'a = r["lscf_h1"]\nb = r["lscf_h1_std"]\nc = f"lscf_h1_{k}"\nd = "lscf_h10"\n')
    assert [line for line, _ in _literals_in(src, {"lscf_h1"})] == [5, 6, 7]


def test_estimator_names_are_spelled_only_in_the_registry():
    from sloshrom.beam.damping.registry import ESTIMATORS

    names = set(ESTIMATORS)
    assert {"lscf_h1", "lscf_output", "half_power", "ssi_cov"} <= names
    bad = estimator_name_literals(names)
    assert not bad, ("estimator names spelled outside the registry (use "
                     "sloshrom.beam.damping.registry):\n" + "\n".join(bad))


# -- Table 2's flat columns: made and read in one place ----------------------------------------
#: The one module that composes (or parses) a file column from an estimator's name:
#: ``lscf_h1_std``, ``frequency_ssi_cov``. Everywhere else a damping table is a Dataset over
#: the dimension ``estimator``; its flat columns exist at the files' edge only.
COLUMNS_MODULE = "sloshrom.beam.damping.columns"
#: The suffixes of an estimator's columns (``sloshrom.beam.damping.columns.ESTIMATE_FIELDS``).
COLUMN_SUFFIXES = {f"_{s}" for s in ("std", "low", "high", "reason", "note", "spread",
                                      "members", "uncorrected", "iqr", "n")}


def _composed_columns(source: str) -> list[tuple[int, str]]:
    """``(line, text)`` of every column name composed from a name: an f-string ending in a
    field's suffix (``f"{est}_low"``) or starting with ``frequency_`` then a name, and a
    concatenation ``name + "_std"``."""
    out = []
    for node in ast.walk(_tree(source)):
        if isinstance(node, ast.JoinedStr) and len(node.values) >= 2:
            first, *_, last = node.values
            second = node.values[1]
            if (isinstance(last, ast.Constant) and last.value in COLUMN_SUFFIXES
                    and isinstance(node.values[-2], ast.FormattedValue)) or (
                    isinstance(first, ast.Constant) and first.value == "frequency_"
                    and isinstance(second, ast.FormattedValue)):
                out.append((node.lineno, ast.unparse(node)))
        if isinstance(node, ast.BinOp) and isinstance(node.op, ast.Add) \
                and isinstance(node.right, ast.Constant) and node.right.value in COLUMN_SUFFIXES:
            out.append((node.lineno, ast.unparse(node)))
    return out


def test_the_column_finder():
    src = ('a = f"{est}_low"\nb = n + "_std"\nc = f"frequency_{n}"\n'
           'd = f"{arch}_d{delays}_n{neurons}"\ne = f"{x}_lowpass"\nf = "measured_low"\n')
    assert [line for line, _ in _composed_columns(src)] == [1, 2, 3]


def test_table2_columns_are_composed_in_one_module():
    """Datasets over ``estimator`` flow through the analyses, the command line and the report;
    only :data:`COLUMNS_MODULE` turns them into the files' flat columns and back, so that a
    copy of the column contract cannot disagree with it."""
    assert COLUMNS_MODULE in MODULES
    bad = [f"{MODULES[m].relative_to(SRC)}:{line}: {text}" for m, path in MODULES.items()
           if m != COLUMNS_MODULE
           for line, text in _composed_columns(path.read_text(encoding="utf-8"))]
    assert not bad, ("estimator columns composed outside " + COLUMNS_MODULE + ":\n"
                     + "\n".join(bad))
