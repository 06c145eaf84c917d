"""Which modules run compiled (mypyc, native_modules.txt), and whether one is stale.

Python imports a compiled module in place of its ``.py`` beside it, so a source edited after
the build would not run until ``scripts/bootstrap`` (or ``pip install -e .``) builds it again.
The daemon logs it at start (``native.stale``), the simulator prints it (even with --quiet),
and the test suite refuses to run on stale builds (tests/support/native_guard.py).
"""

from __future__ import annotations

import importlib.machinery
from dataclasses import dataclass
from pathlib import Path

import structlog

log = structlog.get_logger(__name__)

PACKAGES = ("behaviours", "drivers", "fleet", "hal", "robotd")
LISTED = "native_modules.txt"
# mypyc puts the compiled code of all listed modules in one library (setup.py's group); each
# module's own extension beside its .py is a small shim that loads it, rebuilt only when the
# shim's own few lines change.
GROUP_LIBRARY = "hal/_native__mypyc"
_ROOT = Path(__file__).resolve().parent.parent


@dataclass(frozen=True, slots=True)
class CompiledModule:
    source: Path
    built: Path
    built_s: float  # when its code was last compiled (the shim's or the library's mtime)

    @property
    def stale(self) -> bool:
        """The source changed after the build: the compiled module runs the old code."""
        return self.source.stat().st_mtime > self.built_s


def compiled_modules(root: Path = _ROOT) -> list[CompiledModule]:
    """Every module under ``root``'s packages that has a compiled build beside its source."""
    suffixes = importlib.machinery.EXTENSION_SUFFIXES
    libraries = [root / (GROUP_LIBRARY + suffix) for suffix in suffixes]
    library_s = max((p.stat().st_mtime for p in libraries if p.exists()), default=0.0)
    found = []
    for package in PACKAGES:
        for suffix in suffixes:
            for built in (root / package).rglob(f"*{suffix}"):
                source = built.with_name(built.name[:-len(suffix)] + ".py")
                if source.exists():
                    built_s = max(built.stat().st_mtime, library_s)
                    found.append(CompiledModule(source, built, built_s))
    return sorted(found, key=lambda m: m.source)


def listed_sources(root: Path = _ROOT) -> set[Path] | None:
    """The sources native_modules.txt lists (relative), or None without the file (a wheel)."""
    path = root / LISTED
    if not path.exists():
        return None
    lines = (line.split("#")[0].strip() for line in path.read_text("utf-8").splitlines())
    return {Path(line) for line in lines if line}


def stale_modules(root: Path = _ROOT) -> list[Path]:
    """Compiled modules that do not run their source (relative to ``root``): the source is
    newer than the build, or the module is no longer listed (its old build still shadows it)."""
    listed = listed_sources(root)
    return [m.source.relative_to(root) for m in compiled_modules(root)
            if m.stale or (listed is not None and m.source.relative_to(root) not in listed)]


def warn_if_stale(root: Path = _ROOT) -> list[Path]:
    """Log ``native.stale`` naming the modules that do not run their source; returns them."""
    stale = stale_modules(root)
    if stale:
        log.warning("native.stale", modules=[str(p) for p in stale],
                    note="these run their last build, not the source: run scripts/bootstrap")
    return stale
