"""The house rule of the layout that holds everywhere: every package says what it holds.

How long a module or how full a folder may be is guidance (STYLE.md, "Our own habits", and
docs/profiles.md), not a test: a size is a signal to look, and a cap made into a test became a
target that modules were trimmed and split to meet.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("robotd", "hal", "drivers", "behaviours", "fleet", "sim")


def _modules() -> list[Path]:
    return sorted(p for top in PACKAGES for p in (ROOT / top).rglob("*.py"))


class TestLayout:
    @pytest.mark.parametrize("init", [p for p in _modules() if p.name == "__init__.py"],
                             ids=lambda p: str(p.parent.relative_to(ROOT)))
    def test_every_package_says_what_lives_there_in_one_line(self, init: Path) -> None:
        doc = ast.get_docstring(ast.parse(init.read_text()))
        assert doc, f"{init.relative_to(ROOT)} has no docstring"
        first = doc.splitlines()[0]
        assert first.endswith(".") and len(first.split()) >= 4, first
