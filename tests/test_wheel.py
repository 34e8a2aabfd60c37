"""The release as a user installs it (slow tier): ``python -m build`` makes an sdist and a wheel
that holds the FMU's C sources and the grey box's training kernel (its source, and compiled for
this platform: the wheel is then tagged with it); the wheel installs into a new environment (the
lock's pinned dependencies, then the wheel alone) and passes the smoke test there, away from the
checkout.
"""

from __future__ import annotations

import os
import subprocess
import sys
import tarfile
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


def _wheel(dist: Path) -> Path:
    """The one wheel built (``py3-none-any`` without the kernel, the platform's tag with it)."""
    wheels = sorted(dist.glob(f"sloshrom-{VERSION}-*.whl"))
    assert len(wheels) == 1, wheels
    return wheels[0]


def test_the_wheel_holds_the_package_and_the_fmu_sources(dist):
    sdist = dist / f"sloshrom-{VERSION}.tar.gz"
    assert sdist.is_file()
    with tarfile.open(sdist) as tar:
        assert any(n.endswith("src/sloshrom/rom/grey/window.cc") for n in tar.getnames())
        assert any(n.endswith("/setup.py") for n in tar.getnames())
    wheel = _wheel(dist)
    names = set(zipfile.ZipFile(wheel).namelist())
    # built with jaxlib's headers and a C++ compiler (this machine): the kernel is in it
    assert "sloshrom/rom/grey/window.cc" in names
    assert any(n.startswith("sloshrom/rom/grey/_window.") and n.endswith(".so") for n in names)
    assert "py3-none-any" not in wheel.name, wheel.name
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
    _run([python, "-m", "pip", "install", "--quiet", "--no-deps", _wheel(dist)])
    _run([python, "-m", "pip", "check"])
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "VIRTUAL_ENV")}
    sloshrom = env_dir / "bin" / "sloshrom"
    # run outside the checkout, so that the installed package is the one imported
    where = _run([python, "-c", "import sloshrom; print(sloshrom.__file__)"], cwd=tmp_path,
                 env=env).stdout.strip()
    assert Path(where).is_relative_to(env_dir), where
    # the installed kernel loads there (the grey box trains with it)
    assert _run([python, "-c", "from sloshrom.rom.grey.kernel import kernel_available; "
                 "print(kernel_available())"], cwd=tmp_path, env=env).stdout.strip() == "True"
    assert _run([sloshrom, "--version"], cwd=tmp_path, env=env).stdout.strip() == VERSION
    out = tmp_path / "quick"
    _run([sloshrom, "reproduce", "--quick", "--out", out], cwd=tmp_path, env=env)
    assert (out / "report.html").is_file() and (out / "summary.json").is_file()
