"""Which modules run compiled (mypyc, native_modules.txt), and whether one is stale.

Python imports a compiled module in place of its ``.py`` beside it, so a source edited after
the build would not run until ``scripts/bootstrap`` (or ``pip install -e .``) builds it again.
The daemon and the simulator say so at start (``native.stale``), and the test suite refuses to
run on stale builds (tests/conftest.py).
"""

from __future__ import annotations

import importlib.machinery
from dataclasses import dataclass
from pathlib import Path

import structlog

log = structlog.get_logger(__name__)

PACKAGES = ("behaviours", "drivers", "fleet", "hal", "robotd")
_ROOT = Path(__file__).resolve().parent.parent


@dataclass(frozen=True, slots=True)
class CompiledModule:
    source: Path
    built: Path

    @property
    def stale(self) -> bool:
        """The source changed after the build: the compiled module runs the old code."""
        return self.source.stat().st_mtime > self.built.stat().st_mtime


def compiled_modules(root: Path = _ROOT) -> list[CompiledModule]:
    """Every module under ``root``'s packages that has a compiled build beside its source."""
    found = []
    for package in PACKAGES:
        for suffix in importlib.machinery.EXTENSION_SUFFIXES:
            for built in (root / package).rglob(f"*{suffix}"):
                source = built.with_name(built.name[:-len(suffix)] + ".py")
                if source.exists():
                    found.append(CompiledModule(source, built))
    return sorted(found, key=lambda m: m.source)


def stale_modules(root: Path = _ROOT) -> list[Path]:
    """Sources newer than their compiled build (relative to ``root``)."""
    return [m.source.relative_to(root) for m in compiled_modules(root) if m.stale]


def warn_if_stale(root: Path = _ROOT) -> list[Path]:
    """Log ``native.stale`` naming the stale modules, if any; returns them."""
    stale = stale_modules(root)
    if stale:
        log.warning("native.stale", modules=[str(p) for p in stale],
                    note="these run their last build, not the source: run scripts/bootstrap")
    return stale
