"""The API reference's pages, written from the package itself before Sphinx reads the sources.

One page per public module of ``sloshrom`` (every module whose dotted path has no part starting
with ``_``). A module's public names are its ``__all__`` or, without one, the classes and
functions it defines. Each page opens with the module's docstring and a summary table of all its
public names; the table links each name to the one place where it is documented in full, its
*home*, so that a name re-exported by several modules is described once (no duplicate object
descriptions):

- a class or function: the shortest public package (other than the top-level ``sloshrom``) that
  lists it in ``__all__`` and contains the module that defines it (``sloshrom.rom.NSS``, not
  ``sloshrom.rom.nss.estimator.NSS``); else the module that defines it;
- any other value (constants, type aliases, the typer app): the module whose source assigns it
  (its ``#:`` comment is its documentation), found by following the ``from ... import``
  statements.

The classes and functions homed at a package get a page of their own (``api/sloshrom.rom.NSS``);
the others are documented on their module's page.
"""

from __future__ import annotations

import ast
import functools
import importlib
import inspect
import pkgutil
from dataclasses import dataclass, field
from pathlib import Path

PACKAGE = "sloshrom"


@dataclass
class Module:
    """A public module: its dotted name, whether it is a package, its public names."""

    name: str
    is_package: bool
    names: list[str]
    source: Path | None
    homed: list[str] = field(default_factory=list)


def public_modules() -> list[str]:
    """Every public module of the package, the package first, in dotted order."""
    root = importlib.import_module(PACKAGE)
    names = [PACKAGE] + [m.name for m in pkgutil.walk_packages(root.__path__, PACKAGE + ".")]
    return sorted(n for n in names if not any(p.startswith("_") for p in n.split(".")))


def public_names(module: object, name: str) -> list[str]:
    """The module's ``__all__``, else the classes and functions it defines (not private)."""
    listed = getattr(module, "__all__", None)
    if listed is not None:
        return list(dict.fromkeys(listed))
    return [n for n, obj in vars(module).items()
            if not n.startswith("_") and (inspect.isclass(obj) or inspect.isfunction(obj))
            and getattr(obj, "__module__", None) == name]


def _top_level(tree: ast.Module) -> list[ast.stmt]:
    """The module's top-level statements, the bodies of its ``try`` and ``if`` blocks too."""
    out: list[ast.stmt] = []
    stack = list(tree.body)
    while stack:
        node = stack.pop(0)
        out.append(node)
        if isinstance(node, ast.Try):
            stack[:0] = [*node.body, *node.orelse, *node.finalbody,
                         *(s for h in node.handlers for s in h.body)]
        elif isinstance(node, ast.If):
            stack[:0] = [*node.body, *node.orelse]
    return out


def _assigned_and_imported(path: Path, module: str, is_package: bool
                           ) -> tuple[set[str], dict[str, str]]:
    """The names a module's source assigns and, for each imported name, the module it comes from."""
    tree = ast.parse(path.read_text(encoding="utf-8"))
    assigned: set[str] = set()
    imported: dict[str, str] = {}
    package = module if is_package else module.rpartition(".")[0]
    for node in _top_level(tree):
        if isinstance(node, ast.Assign):
            for target in node.targets:
                for t in ast.walk(target):
                    if isinstance(t, ast.Name):
                        assigned.add(t.id)
        elif isinstance(node, (ast.AnnAssign, ast.AugAssign)) and isinstance(node.target, ast.Name):
            assigned.add(node.target.id)
        elif type(node).__name__ == "TypeAlias":  # ``type X = ...`` (Python 3.12+)
            assigned.add(node.name.id)  # type: ignore[attr-defined]
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                parts = package.split(".")
                parts = parts[: len(parts) - (node.level - 1)]
                base = ".".join([*parts, base]) if base else ".".join(parts)
            for alias in node.names:
                imported[alias.asname or alias.name] = base
    return assigned, imported


class Homes:
    """Where each public object of the package is documented in full."""

    def __init__(self) -> None:
        self.modules: dict[str, Module] = {}
        self._source: dict[str, tuple[set[str], dict[str, str]]] = {}
        for name in public_modules():
            mod = importlib.import_module(name)
            path = Path(mod.__file__) if getattr(mod, "__file__", None) else None
            self.modules[name] = Module(name, hasattr(mod, "__path__"),
                                        public_names(mod, name), path)
        self.home: dict[tuple[str, str], str] = {}  # (module, name) -> full name of its home
        for m in self.modules.values():
            for n in m.names:
                self.home[m.name, n] = self._home_of(m.name, n)
        for (_, n), full in self.home.items():
            module = full.rpartition(".")[0]
            if module in self.modules and full.rpartition(".")[2] == n:
                homed = self.modules[module].homed
                if n not in homed:
                    homed.append(n)

    def _source_of(self, module: str) -> tuple[set[str], dict[str, str]]:
        if module not in self._source:
            mod = importlib.import_module(module)
            path = getattr(mod, "__file__", None)
            self._source[module] = (_assigned_and_imported(Path(path), module,
                                                           hasattr(mod, "__path__"))
                                    if path else (set(), {}))
        return self._source[module]

    def _defining_module(self, module: str, name: str) -> str:
        """The module whose source assigns ``name``, following imports and lazy re-exports."""
        seen: set[str] = set()
        while module not in seen:
            seen.add(module)
            assigned, imported = self._source_of(module)
            if name in assigned:
                return module
            if name in imported:
                module = imported[name]
                continue
            break
        # a lazy re-export (PEP 562 ``__getattr__``): the module among the package's that
        # assigns the name and holds the same object
        obj = getattr(importlib.import_module(module), name)
        for other in self.modules:
            if other.startswith(module + ".") and name in self._source_of(other)[0]:
                if getattr(importlib.import_module(other), name, None) is obj:
                    return other
        return module

    def _home_of(self, module: str, name: str) -> str:
        obj = getattr(importlib.import_module(module), name)
        if inspect.isclass(obj) or inspect.isfunction(obj):
            defined = obj.__module__
            for pkg in sorted(self.modules, key=lambda p: (p.count("."), p)):
                m = self.modules[pkg]
                if (pkg != PACKAGE and m.is_package and name in m.names
                        and defined.startswith(pkg + ".")
                        and getattr(importlib.import_module(pkg), name) is obj):
                    return f"{pkg}.{name}"
            if (defined in self.modules
                    and getattr(importlib.import_module(defined), name, None) is obj):
                return f"{defined}.{name}"
            return f"{module}.{name}"
        defined = self._defining_module(module, name)
        return f"{defined if defined in self.modules else module}.{name}"

    def public(self) -> list[str]:
        """Every public name as ``module.name``, one for each module that lists it."""
        return [f"{m}.{n}" for m, n in self.home]


def _title(text: str, char: str = "=") -> str:
    return f"{text}\n{char * len(text)}\n"


def _documenter(obj: object) -> str:
    if inspect.isclass(obj):
        return "autoclass"
    if inspect.isfunction(obj):
        return "autofunction"
    return "autodata"


# A class on a page of its own shows what it inherits from the package's bases (an estimator's
# ``predict`` and ``save``), not what Python's or pydantic's bases give every such class.
NOT_INHERITED = ("object, BaseException, Exception, ValueError, TypeError, RuntimeError, "
                 "KeyError, OSError, Warning, UserWarning, RuntimeWarning, BaseModel, dict, "
                 "tuple, list, str, int, float, Protocol, Generic, NamedTuple, Enum")


def _object_block(directive: str, full: str, inherited: bool = False) -> str:
    if directive == "autoclass":
        extra = f"   :inherited-members: {NOT_INHERITED}\n" if inherited else ""
        return f".. autoclass:: {full}\n   :members:\n{extra}   :show-inheritance:\n"
    return f".. {directive}:: {full}\n"


def write_pages(out: Path) -> list[str]:
    """Write the API reference into ``out`` (``index.rst`` and one page a module or object)."""
    global _HOMES
    homes = _HOMES = Homes()
    out.mkdir(parents=True, exist_ok=True)
    wanted: dict[str, str] = {}
    for m in homes.modules.values():
        mod = importlib.import_module(m.name)
        lines = [f".. _api-{m.name}:\n", _title(f"``{m.name}``"),
                 f".. automodule:: {m.name}\n   :no-members:\n"]
        if m.names:
            # the table names each entry by its home's full path: no current module here
            lines.append(".. currentmodule:: None\n")
            lines.append(".. rubric:: Public names\n")
            lines.append(".. autosummary::\n   :nosignatures:\n")
            lines += [f"   ~{homes.home[m.name, n]}" for n in m.names]
            lines.append("")
        subpages = [n for n in m.homed if m.is_package
                    and _documenter(getattr(mod, n)) != "autodata"]
        inline = [n for n in m.homed if n not in subpages]
        if subpages:
            lines.append(".. toctree::\n   :hidden:\n")
            lines += [f"   {m.name}.{n}" for n in subpages]
            lines.append("")
            for n in subpages:
                full = f"{m.name}.{n}"
                text = [_title(f"``{full}``"), f".. currentmodule:: {m.name}\n",
                        _object_block(_documenter(getattr(mod, n)), n, inherited=True)]
                wanted[f"{full}.rst"] = "\n".join(text)
        if inline:
            lines.append(".. rubric:: Contents\n")
            lines.append(f".. currentmodule:: {m.name}\n")
            for n in inline:
                lines.append(_object_block(_documenter(getattr(mod, n)), n))
        children = [c for c in homes.modules
                    if c.rpartition(".")[0] == m.name]
        if children:
            lines.append(".. rubric:: Modules\n")
            lines.append(".. toctree::\n   :maxdepth: 1\n")
            lines += [f"   {c}" for c in children]
            lines.append("")
        wanted[f"{m.name}.rst"] = "\n".join(lines)
    wanted["index.rst"] = "\n".join([
        _title("API reference"),
        "Generated from the docstrings of the package (numpy convention). Each module's page "
        "lists its public names (its ``__all__``); a name that several modules re-export is "
        "described once, where the summary tables link.\n",
        ".. toctree::\n   :maxdepth: 2\n", f"   {PACKAGE}", ""])
    wanted["cli.md"] = cli_page()
    for rel, text in wanted.items():  # rewrite only what changed: Sphinx rereads only those
        path = out / rel
        if not path.exists() or path.read_text(encoding="utf-8") != text:
            path.write_text(text, encoding="utf-8")
    for stale in [*out.glob("*.rst"), *out.glob("*.md")]:
        if stale.name not in wanted:
            stale.unlink()
    return homes.public()


def cli_page() -> str:
    """The command-line reference: typer's own Markdown of every command of ``sloshrom``."""
    import typer
    import typer.main
    from typer.cli import get_docs_for_click

    from sloshrom.cli import app

    command = typer.main.get_command(app)
    body = get_docs_for_click(obj=command, ctx=typer.Context(command), indent=1,
                              name="sloshrom")
    return "\n".join([
        "# Command-line reference\n",
        "Generated from the command line itself (what ``sloshrom COMMAND --help`` prints): "
        "every command, its arguments and options with their defaults.\n", body.strip(), ""])


_HOMES: Homes | None = None


@functools.cache
def _module_names(module: str) -> tuple[set[str], dict[str, str]]:
    """What a module's source assigns and imports (see :func:`_assigned_and_imported`)."""
    try:
        mod = importlib.import_module(module)
    except ImportError:
        return set(), {}
    path = getattr(mod, "__file__", None)
    if not path or not path.endswith(".py"):
        return set(), {}
    return _assigned_and_imported(Path(path), module, hasattr(mod, "__path__"))


def qualify_annotations(app, doctree) -> None:
    """A bare name in a type annotation names what the annotated module means by it.

    Sphinx looks up every name of an annotation by a fuzzy search over the whole package
    (``refspecific``), so that ``Row`` in ``list[Row]`` is ambiguous when two modules define a
    ``Row``. The name is qualified here as Python reads it: the module it is imported from
    (``if TYPE_CHECKING:`` imports too), or the annotated module when it assigns the name.
    """
    from sphinx import addnodes

    for node in doctree.findall(addnodes.pending_xref):
        target = node.get("reftarget", "")
        module = node.get("py:module")
        if (node.get("refdomain") != "py" or node.get("refspecific") is not False
                or "." in target or not module or not module.startswith(PACKAGE)):
            continue
        assigned, imported = _module_names(module)
        if target in imported and imported[target].startswith(PACKAGE):
            where = imported[target]
        elif target in assigned:
            where = module
        else:
            continue
        home = _HOMES.home.get((where, target)) if _HOMES is not None else None
        node["reftarget"] = home or f"{where}.{target}"


def setup(app):  # noqa: D103 - the Sphinx extension's entry point
    def generate(app):
        write_pages(Path(app.srcdir) / "api")

    app.connect("builder-inited", generate)
    app.connect("doctree-read", qualify_annotations)
    return {"parallel_read_safe": True, "parallel_write_safe": True}
