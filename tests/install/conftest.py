"""Fixtures for the install tests: robotd wheels built once per run, and temporary roots.

A version is installed for real (a virtual environment, pip installing a robotd wheel) but
in seconds: the wheels are built once from a copy of this checkout, and each install takes
the dependencies from the test's own virtual environment (install-robot --deps-from) instead
of downloading them.
"""

from __future__ import annotations

import shutil
import subprocess
import sys
import tempfile
from collections.abc import Iterator
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
PACKAGES = ("robotd", "hal", "drivers", "behaviours", "sim", "fleet")


def _build_wheel(workdir: Path, version: str) -> Path:
    """A robotd wheel of this checkout's code, its version set to ``version``."""
    src = workdir / f"src-{version}"
    ignore = shutil.ignore_patterns("__pycache__", "*.so", "*.pyc")
    for package in PACKAGES:
        shutil.copytree(ROOT / package, src / package, ignore=ignore)
    for name in ("setup.py", "README.md"):
        shutil.copy(ROOT / name, src / name)
    pyproject = (ROOT / "pyproject.toml").read_text()
    (src / "pyproject.toml").write_text(
        pyproject.replace('version = "', f'version = "{version}"  # was "', 1))
    out = workdir / f"dist-{version}"
    subprocess.run([sys.executable, "-m", "pip", "wheel", "--quiet", "--no-deps", "-w",
                    str(out), str(src)], check=True, capture_output=True)
    [wheel] = out.glob("robotd-*.whl")
    return wheel


@pytest.fixture(scope="session")
def wheels(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    """Two robotd wheels of different versions (0.1.0 and 0.1.1.dev1)."""
    workdir = tmp_path_factory.mktemp("wheels")
    return _build_wheel(workdir, "0.1.0"), _build_wheel(workdir, "0.1.1.dev1")


@pytest.fixture
def root() -> Iterator[Path]:
    """An empty directory to install into (short: a control socket may live under it)."""
    path = Path(tempfile.mkdtemp(prefix="ri-"))
    yield path
    shutil.rmtree(path, ignore_errors=True)
