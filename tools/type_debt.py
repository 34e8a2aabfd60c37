"""Count the package's type debt and fail when it grew.

Three numbers, over the package's source (``src/sloshrom``):

- ``any``: annotations (of a parameter, a return, a variable) that use ``typing.Any``;
- ``type_ignore``: ``# type: ignore`` comments;
- ``relaxed``: the (module, error code) pairs of mypy's gradual baseline in pyproject.toml
  (``disable_error_code`` of a ``[[tool.mypy.overrides]]`` table; ``ignore_errors = true``
  counts one per module).

Each is compared with its ceiling in ``tools/type_debt.json``: the run fails (exit 1) when a
count is above its ceiling, and when a count fell below it, it says so and prints the ceilings
to write (lower them in the same commit, so the debt can only go down). Run by ``make test``.

Usage: ``python tools/type_debt.py [--root DIR] [--pyproject FILE] [--ceilings FILE]``
"""

from __future__ import annotations

import argparse
import ast
import io
import json
import sys
import tokenize
import tomllib
from pathlib import Path

_REPO = Path(__file__).resolve().parent.parent
KEYS = ("any", "type_ignore", "relaxed")


def _uses_any(node: ast.expr | None) -> bool:
    """Whether an annotation names ``Any`` (``Any``, ``typing.Any``, or inside a string)."""
    if node is None:
        return False
    for sub in ast.walk(node):
        if isinstance(sub, ast.Name) and sub.id == "Any":
            return True
        if isinstance(sub, ast.Attribute) and sub.attr == "Any":
            return True
        if isinstance(sub, ast.Constant) and isinstance(sub.value, str):
            try:
                inner = ast.parse(sub.value, mode="eval").body
            except SyntaxError:
                continue
            if _uses_any(inner):
                return True
    return False


def count_any(source: str) -> int:
    """The number of annotations in ``source`` that use ``Any``."""
    n = 0
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef):
            a = node.args
            args = [*a.posonlyargs, *a.args, *a.kwonlyargs, a.vararg, a.kwarg]
            n += sum(_uses_any(x.annotation) for x in args if x is not None)
            n += _uses_any(node.returns)
        elif isinstance(node, ast.AnnAssign):
            n += _uses_any(node.annotation)
    return n


def count_type_ignores(source: str) -> int:
    """The number of ``# type: ignore`` comments in ``source``."""
    if "type:" not in source:  # most files: no need to tokenize them
        return 0
    tokens = tokenize.generate_tokens(io.StringIO(source).readline)
    return sum(1 for t in tokens if t.type == tokenize.COMMENT
               and "type: ignore" in t.string.replace("type:ignore", "type: ignore"))


def count_relaxed(pyproject: Path) -> int:
    """The (module, error code) pairs that mypy's overrides in ``pyproject`` switch off."""
    mypy = tomllib.loads(pyproject.read_text()).get("tool", {}).get("mypy", {})
    n = 0
    for table in mypy.get("overrides", []):
        modules = table.get("module", [])
        n_modules = 1 if isinstance(modules, str) else len(modules)
        if table.get("ignore_errors"):
            n += n_modules
        n += n_modules * len(table.get("disable_error_code", []))
    return n


def counts(root: Path, pyproject: Path) -> dict[str, int]:
    """The three counts over the Python files under ``root``."""
    n_any = n_ignore = 0
    for path in sorted(root.rglob("*.py")):
        source = path.read_text(encoding="utf-8")
        n_any += count_any(source)
        n_ignore += count_type_ignores(source)
    return {"any": n_any, "type_ignore": n_ignore, "relaxed": count_relaxed(pyproject)}


def main(argv: list[str] | None = None) -> int:
    """Print the counts and compare them with the ceilings; the exit code (0 or 1)."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--root", type=Path, default=_REPO / "src" / "sloshrom")
    ap.add_argument("--pyproject", type=Path, default=_REPO / "pyproject.toml")
    ap.add_argument("--ceilings", type=Path, default=_REPO / "tools" / "type_debt.json")
    args = ap.parse_args(argv)
    now = counts(args.root, args.pyproject)
    ceilings = json.loads(args.ceilings.read_text())
    print("type debt: " + ", ".join(
        f"{k} = {now[k]} (ceiling {ceilings[k]})" for k in KEYS))
    rose = [k for k in KEYS if now[k] > ceilings[k]]
    fell = [k for k in KEYS if now[k] < ceilings[k]]
    if rose:
        print("type debt rose: " + ", ".join(f"{k} {ceilings[k]} -> {now[k]}" for k in rose)
              + ". Annotate with a precise type instead of Any, fix the error instead of "
              "ignoring it, or keep the module's baseline as it was.", file=sys.stderr)
        return 1
    if fell:
        lowered = {k: min(now[k], ceilings[k]) for k in KEYS}
        print(f"type debt fell ({', '.join(fell)}): lower the ceilings in {args.ceilings.name} "
              f"in this commit, to {json.dumps(lowered)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
