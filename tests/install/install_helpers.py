"""Helpers for the install tests: run install-robot into a root, photograph a root."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
VENV = Path(sys.prefix)


def install_robot(root: Path, *args: str, check: bool = True,
                  source: Path | None = None) -> subprocess.CompletedProcess[str]:
    """scripts/install-robot --root ROOT ARGS, run as a technician would run it."""
    argv = [str(ROOT / "scripts" / "install-robot"), "--root", str(root), *args]
    if "--uninstall" not in args:
        argv += ["--deps-from", str(VENV)]
        if source is not None:
            argv += ["--source", str(source)]
    env = {**os.environ, "PYTHON": sys.executable}
    proc = subprocess.run(argv, capture_output=True, text=True, env=env, timeout=240,
                          check=False)
    if check:
        assert proc.returncode == 0, proc.stderr
    return proc


def snapshot(root: Path, times: bool = True) -> dict[str, tuple[object, ...]]:
    """Every path under ``root``: its kind, mode, size, link target or content, and its
    modification time unless ``times`` is False (what was made and removed again changes
    its directory's time)."""
    out: dict[str, tuple[object, ...]] = {}
    for path in sorted(root.rglob("*")):
        st = path.lstat()
        rel = str(path.relative_to(root))
        if path.is_symlink():
            out[rel] = ("link", str(path.readlink()))
        elif path.is_dir():
            out[rel] = ("dir", st.st_mode, st.st_mtime_ns if times else None)
        else:
            out[rel] = ("file", st.st_mode, st.st_size, st.st_mtime_ns if times else None,
                        path.read_bytes())
    return out
