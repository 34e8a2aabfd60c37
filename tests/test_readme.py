"""The README's examples run: its Python example as written, its commands as far as ``--help``."""

from __future__ import annotations

import importlib.util
import re
import shlex
import sys
from pathlib import Path

import pytest
from typer.testing import CliRunner

from sloshrom.cli import app

README = Path(__file__).resolve().parents[1] / "README.md"


def _blocks(language: str) -> list[str]:
    """The fenced code blocks of the README in ``language``, in order."""
    text = README.read_text(encoding="utf-8")
    return re.findall(rf"^```{language}\n(.*?)^```$", text, flags=re.DOTALL | re.MULTILINE)


def test_readme_starts_with_make():
    lines = [ln.strip() for ln in README.read_text(encoding="utf-8").splitlines() if ln.strip()]
    assert lines[1].startswith("make reproduce") and lines[2].startswith("make test")


def _make_recipe(target: str) -> str:
    """The recipe (its tab-indented lines) of ``target`` in the Makefile."""
    make = (README.parent / "Makefile").read_text(encoding="utf-8")
    recipe = re.search(rf"^{re.escape(target)}:.*\n((?:\t.*\n)+)", make, flags=re.MULTILINE)
    assert recipe, f"no target {target} in the Makefile"
    return recipe.group(1)


def test_ci_runs_the_fast_and_the_long_tier():
    # `make test` leaves the long tests out: CI must run them, or 160 tests would run nowhere
    def pytest_marks(target: str) -> str:
        return re.search(r'pytest -m "([^"]+)"', _make_recipe(target)).group(1)

    assert pytest_marks("test") == "not slow and not long"
    assert pytest_marks("test-long") == "long and not slow"
    ci = [ln.strip() for ln in
          (README.parent / ".ci" / "run").read_text(encoding="utf-8").splitlines()]
    assert "make test" in ci and "make test-long" in ci


def test_the_environment_is_installed_with_its_bytecode():
    # uv leaves the .pyc to the first import; where PYTHONDONTWRITEBYTECODE is set none is
    # ever written, and every process compiled JAX, SciPy and the rest again (7.5 s, not 2.8 s)
    lock_install = re.search(r"uv pip install ([^\n]|\\\n)*-r \$\(LOCK\)",
                             _make_recipe("$(STAMP)"))
    assert lock_install, "the lock is not installed by uv"
    assert "--compile-bytecode" in lock_install.group(0)
    # and, in the environment `make` made, the bytecode is there
    if Path(sys.prefix).resolve() == (README.parent / ".venv").resolve():
        import jax
        assert Path(importlib.util.cache_from_source(jax.__file__)).is_file()


@pytest.mark.filterwarnings("ignore::UserWarning")
@pytest.mark.long
def test_python_example_runs(tmp_path, monkeypatch, capsys):
    """Every ``python`` block, in order, in one namespace, in an empty directory."""
    blocks = _blocks("python")
    assert blocks, "README.md has no ```python block"
    monkeypatch.chdir(tmp_path)
    namespace: dict = {"__name__": "__readme__"}
    for i, code in enumerate(blocks):
        exec(compile(code, f"README.md (python block {i + 1})", "exec"), namespace)
    out = capsys.readouterr().out
    assert "validation: normalised RMS error" in out
    assert (tmp_path / "nfir.npz").is_file()
    assert namespace["phi"].shape == (5, 5)


def _commands() -> list[list[str]]:
    """The ``sloshrom`` sub-command of every line of the README's ``bash`` blocks."""
    out = []
    for block in _blocks("bash"):
        for line in block.splitlines():
            words = shlex.split(line, comments=True)
            if words[:1] == ["sloshrom"]:
                out.append([w for w in words[1:3] if not w.startswith("-")])
    return out


@pytest.mark.parametrize("command", _commands(), ids=" ".join)
def test_commands_exist(command):
    res = CliRunner().invoke(app, [*command, "--help"])
    assert res.exit_code == 0, res.output
