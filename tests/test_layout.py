"""The house rules of the layout: small modules, small folders, every package says what it holds."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("robotd", "hal", "drivers", "behaviours", "fleet")
MAX_MODULE_LINES = 400
MAX_MODULES_SIDE_BY_SIDE = 12
"""robotd/, hal/, behaviours/ and drivers/ (and each folder below them)."""


def _modules() -> list[Path]:
    return sorted(p for top in PACKAGES for p in (ROOT / top).rglob("*.py"))


def _folders(top: str) -> list[Path]:
    return sorted({p.parent for p in (ROOT / top).rglob("*.py")})


class TestLayout:
    @pytest.mark.parametrize("path", _modules(), ids=lambda p: str(p.relative_to(ROOT)))
    def test_no_module_is_over_400_lines(self, path: Path) -> None:
        """One concern per module: past 400 lines a second one has crept in."""
        assert len(path.read_text().splitlines()) <= MAX_MODULE_LINES

    @pytest.mark.parametrize("folder", [f for top in ("robotd", "hal", "behaviours", "drivers")
                                        for f in _folders(top)],
                             ids=lambda p: str(p.relative_to(ROOT)))
    def test_no_folder_holds_more_than_a_dozen_modules(self, folder: Path) -> None:
        """Past a dozen modules side by side a folder wants subpackages."""
        assert len(list(folder.glob("*.py"))) <= MAX_MODULES_SIDE_BY_SIDE

    @pytest.mark.parametrize("init", [p for p in _modules() if p.name == "__init__.py"],
                             ids=lambda p: str(p.parent.relative_to(ROOT)))
    def test_every_package_says_what_lives_there_in_one_line(self, init: Path) -> None:
        doc = ast.get_docstring(ast.parse(init.read_text()))
        assert doc, f"{init.relative_to(ROOT)} has no docstring"
        first = doc.splitlines()[0]
        assert first.endswith(".") and len(first.split()) >= 4, first
