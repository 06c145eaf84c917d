"""Versions side by side: ``/opt/robotd/versions/<id>``, each its own virtual environment, and
``current``/``previous`` symlinks that switch between them atomically.

A version's id is the package version and a digest of what was installed (the wheel file, or
a checkout's sources), ``0.1.0-3f9c2a1b7e``: a rebuilt checkout with the same version number
is a new id, and installing the same thing again is the same id (nothing to do).
"""

from __future__ import annotations

import hashlib
import os
import re
import shutil
import subprocess
import sys
import tomllib
import zipfile
from dataclasses import dataclass
from pathlib import Path

from robotd.install.layout import Layout
from robotd.install.system import InstallError

PACKAGES = ("robotd", "hal", "drivers", "behaviours", "sim", "fleet")
CHECKOUT_FILES = ("pyproject.toml", "setup.py")
COMPLETE = ".robotd-complete"
_SKIPPED = {"__pycache__", "build", ".mypy_cache", ".ruff_cache"}
_WHEEL = re.compile(r"^(?P<name>[A-Za-z0-9_.]+)-(?P<version>[^-]+)-.+\.whl$")


@dataclass(frozen=True)
class Source:
    """What a version is installed from: a checkout (a directory with pyproject.toml) or a
    wheel file."""

    path: Path
    version: str
    digest: str

    @property
    def id(self) -> str:
        return f"{self.version}-{self.digest}"

    @property
    def is_wheel(self) -> bool:
        return self.path.is_file()


def read_source(path: Path) -> Source:
    """The source at ``path`` with its version and digest; InstallError when it is neither a
    robotd checkout nor a robotd wheel."""
    if path.is_file():
        match = _WHEEL.match(path.name)
        if match is None or match["name"] != "robotd":
            msg = f"{path}: not a robotd wheel (expected robotd-VERSION-...whl)"
            raise InstallError(msg)
        try:
            zipfile.ZipFile(path).close()
        except (zipfile.BadZipFile, OSError) as exc:
            msg = f"{path}: not a wheel: {exc}"
            raise InstallError(msg) from None
        return Source(path, match["version"], _digest_file(path))
    pyproject = path / "pyproject.toml"
    if not pyproject.is_file():
        msg = f"{path}: neither a wheel nor a checkout (no pyproject.toml there)"
        raise InstallError(msg)
    try:
        project = tomllib.loads(pyproject.read_text()).get("project", {})
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
        msg = f"{pyproject}: cannot be read: {exc}"
        raise InstallError(msg) from None
    if project.get("name") != "robotd" or not isinstance(project.get("version"), str):
        msg = f"{pyproject}: not robotd's (project.name must be 'robotd', with a version)"
        raise InstallError(msg)
    return Source(path, project["version"], _digest_checkout(path))


def _digest_file(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()[:10]


def _digest_checkout(root: Path) -> str:
    """A digest of the files a wheel is built from (not caches, builds or compiled kernels)."""
    digest = hashlib.sha256()
    files = [root / name for name in CHECKOUT_FILES if (root / name).is_file()]
    for package in PACKAGES:
        for dirpath, dirnames, filenames in os.walk(root / package):
            dirnames[:] = sorted(d for d in dirnames if d not in _SKIPPED)
            files += [Path(dirpath) / f for f in sorted(filenames)
                      if not f.endswith((".pyc", ".so"))]
    for file in files:
        digest.update(str(file.relative_to(root)).encode() + b"\0")
        digest.update(file.read_bytes() + b"\0")
    return digest.hexdigest()[:10]


def is_complete(layout: Layout, version: str) -> bool:
    return (layout.version_dir(version) / COMPLETE).exists()


def install_version(layout: Layout, source: Source, *, deps_from: Path | None = None,
                    extras: tuple[str, ...] = ()) -> Path:
    """Make ``versions/<id>`` (a virtual environment with robotd from ``source``) unless a
    complete one is there; a half-made one (an install that was cut short) is made again.

    Args:
        deps_from: a virtual environment whose site-packages provide the dependencies
            (robotd itself is installed with --no-deps): an install in seconds, with no
            download, for tests and for a robot with no route to a package index.
        extras: robotd's extras to install (``pi``: lgpio for the HX711).
    """
    target = layout.version_dir(source.id)
    if is_complete(layout, source.id):
        return target
    if target.exists():
        shutil.rmtree(target)
    target.parent.mkdir(parents=True, exist_ok=True)
    requirement = str(source.path.resolve())
    if extras:
        requirement += f"[{','.join(extras)}]"
    try:
        if deps_from is None:
            _check([sys.executable, "-m", "venv", str(target)], "make the virtual environment")
            _check([str(target / "bin" / "python"), "-m", "pip", "install", "--quiet",
                    requirement], f"install {source.path} into {target}")
        else:
            deps_from = deps_from.absolute()
            site = _site_packages(deps_from)
            _check([str(deps_from / "bin" / "python"), "-m", "venv", "--without-pip",
                    str(target)], "make the virtual environment")
            _check([str(deps_from / "bin" / "python"), "-m", "pip", "--python",
                    str(target / "bin" / "python"), "install", "--quiet", "--no-deps",
                    requirement], f"install {source.path} into {target}")
            # After the install (pip would take the other environment's robotd for this one).
            # A plain path entry, not a site dir: the other environment's .pth files (an
            # editable robotd among them) are not read, so only its dependencies are seen.
            (_site_packages(target) / "_robotd_deps.pth").write_text(f"{site}\n")
    except InstallError:
        shutil.rmtree(target, ignore_errors=True)
        raise
    (target / COMPLETE).write_text(f"{source.path.resolve()}\n")
    return target


def _site_packages(venv: Path) -> Path:
    found = sorted((venv / "lib").glob("python3*/site-packages"))
    if not found:
        msg = f"{venv}: not a virtual environment (no lib/python3*/site-packages)"
        raise InstallError(msg)
    return found[0]


def version_env() -> dict[str, str]:
    """The environment to run an installed version's programs and pip in: without the
    PYTHONPATH that install-robot runs with (the checkout would shadow what is installed)."""
    return {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "PYTHONHOME")}


def _check(argv: list[str], what: str) -> None:
    proc = subprocess.run(argv, capture_output=True, text=True, check=False, env=version_env())
    if proc.returncode != 0:
        lines = (proc.stderr.strip() or proc.stdout.strip()).splitlines()
        msg = f"cannot {what}: {lines[-1] if lines else f'exit {proc.returncode}'}"
        raise InstallError(msg)


def switch_current(layout: Layout, version: str) -> None:
    """Point ``current`` at ``versions/<version>`` and ``previous`` at what it pointed to,
    each replaced atomically (a symlink made beside it, then renamed over it)."""
    old = layout.current_version()
    if old == version:
        return
    if old is not None:
        _replace_link(layout.previous, f"versions/{old}")
    _replace_link(layout.current, f"versions/{version}")


def _replace_link(link: Path, target: str) -> None:
    temporary = link.with_name(f".{link.name}.new")
    temporary.unlink(missing_ok=True)
    temporary.symlink_to(target)
    temporary.replace(link)


def remove_version(layout: Layout, version: str) -> None:
    shutil.rmtree(layout.version_dir(version), ignore_errors=True)


def robotd_of(layout: Layout, version: str) -> Path:
    return layout.version_dir(version) / "bin" / "robotd"
