"""The release as a user installs it (slow tier): ``python -m build`` makes an sdist and a wheel
that holds the FMU's C sources; the wheel installs into a new environment (the lock's pinned
dependencies, then the wheel alone) and passes the smoke test there, away from the checkout.
"""

from __future__ import annotations

import os
import subprocess
import sys
import tomllib
import venv
import zipfile
from pathlib import Path

import pytest

pytestmark = pytest.mark.slow

ROOT = Path(__file__).resolve().parents[1]
VERSION = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["version"]


def _run(cmd: list[str], **kwargs) -> subprocess.CompletedProcess:
    proc = subprocess.run([str(c) for c in cmd], capture_output=True, text=True, **kwargs)
    assert proc.returncode == 0, f"{cmd}\n{proc.stdout[-3000:]}\n{proc.stderr[-5000:]}"
    return proc


@pytest.fixture(scope="module")
def dist(tmp_path_factory) -> Path:
    """An sdist and a wheel built from the checkout (the venv's pinned setuptools: offline)."""
    pytest.importorskip("build", reason="build is not installed (the docs extra)")
    out = tmp_path_factory.mktemp("dist")
    _run([sys.executable, "-m", "build", "--no-isolation", "--outdir", out, ROOT], cwd=ROOT)
    return out


def test_the_wheel_holds_the_package_and_the_fmu_sources(dist):
    assert (dist / f"sloshrom-{VERSION}.tar.gz").is_file()
    wheel = dist / f"sloshrom-{VERSION}-py3-none-any.whl"
    names = set(zipfile.ZipFile(wheel).namelist())
    sources = {p.relative_to(ROOT / "src").as_posix()
               for p in (ROOT / "src/sloshrom/rom/fmu_c").iterdir() if p.suffix in (".c", ".h")}
    assert sources and sources <= names, sorted(sources - names)
    assert "sloshrom/pipeline/defaults.toml" in names
    assert f"sloshrom-{VERSION}.dist-info/entry_points.txt" in names
    assert not any(n.startswith(("tests/", "docs/", "examples/")) for n in names)


@pytest.mark.timeout(2400)
def test_the_wheel_installs_and_passes_the_smoke_test(dist, tmp_path):
    env_dir = tmp_path / "venv"
    venv.EnvBuilder(with_pip=True).create(env_dir)
    python = env_dir / "bin" / "python"
    # the lock's versions, hashes checked, no resolution; then the wheel alone
    _run([python, "-m", "pip", "install", "--quiet", "--require-hashes", "--no-deps",
          "-r", ROOT / "requirements.lock"])
    wheel = dist / f"sloshrom-{VERSION}-py3-none-any.whl"
    _run([python, "-m", "pip", "install", "--quiet", "--no-deps", wheel])
    _run([python, "-m", "pip", "check"])
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "VIRTUAL_ENV")}
    sloshrom = env_dir / "bin" / "sloshrom"
    # run outside the checkout, so that the installed package is the one imported
    where = _run([python, "-c", "import sloshrom; print(sloshrom.__file__)"], cwd=tmp_path,
                 env=env).stdout.strip()
    assert Path(where).is_relative_to(env_dir), where
    assert _run([sloshrom, "--version"], cwd=tmp_path, env=env).stdout.strip() == VERSION
    out = tmp_path / "quick"
    _run([sloshrom, "reproduce", "--quick", "--out", out], cwd=tmp_path, env=env)
    assert (out / "report.html").is_file() and (out / "summary.json").is_file()
