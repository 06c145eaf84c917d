"""robotd.native: which modules run compiled, and which builds are older than their source."""

from __future__ import annotations

import importlib.machinery
import os
from pathlib import Path

from robotd.native import GROUP_LIBRARY, compiled_modules, listed_sources, stale_modules

SUFFIX = importlib.machinery.EXTENSION_SUFFIXES[0]


def _tree(root: Path) -> tuple[Path, Path]:
    package = root / "drivers"
    package.mkdir()
    source = package / "hx711.py"
    source.write_text("x = 1\n")
    built = package / f"hx711{SUFFIX}"
    built.write_bytes(b"\0")
    (package / f"_line_scan{SUFFIX}").write_bytes(b"\0")  # a C extension: no .py beside it
    return source, built


class TestCompiledModules:
    def test_finds_builds_beside_their_sources_only(self, tmp_path: Path) -> None:
        """A compiled module is an extension with its .py beside it; C extensions are not."""
        source, built = _tree(tmp_path)
        found = compiled_modules(tmp_path)
        assert [(m.source, m.built) for m in found] == [(source, built)]

    def test_a_source_edited_after_the_build_is_stale(self, tmp_path: Path) -> None:
        """The build runs the old code when the source is newer: it is named, relative."""
        source, built = _tree(tmp_path)
        os.utime(built, (1000, 1000))
        os.utime(source, (2000, 2000))
        assert stale_modules(tmp_path) == [Path("drivers/hx711.py")]

    def test_a_build_newer_than_its_source_is_not_stale(self, tmp_path: Path) -> None:
        """Built after the last edit: nothing to say."""
        source, built = _tree(tmp_path)
        os.utime(source, (1000, 1000))
        os.utime(built, (2000, 2000))
        assert stale_modules(tmp_path) == []

    def test_a_library_built_after_the_edit_holds_the_new_code(self, tmp_path: Path) -> None:
        """mypyc rebuilds the shared library, not each module's unchanged shim: a source
        older than the library is not stale, whatever the shim's age."""
        source, built = _tree(tmp_path)
        (tmp_path / "hal").mkdir()
        library = tmp_path / (GROUP_LIBRARY + SUFFIX)
        library.write_bytes(b"\0")
        os.utime(built, (1000, 1000))
        os.utime(source, (2000, 2000))
        os.utime(library, (3000, 3000))
        assert stale_modules(tmp_path) == []
        os.utime(library, (1500, 1500))
        assert stale_modules(tmp_path) == [Path("drivers/hx711.py")]

    def test_a_module_no_longer_listed_is_named(self, tmp_path: Path) -> None:
        """Taken off native_modules.txt, its old build would still shadow the .py."""
        source, built = _tree(tmp_path)
        os.utime(source, (1000, 1000))
        os.utime(built, (2000, 2000))
        (tmp_path / "native_modules.txt").write_text("# none\ndrivers/ble_scanner.py\n")
        assert stale_modules(tmp_path) == [Path("drivers/hx711.py")]
        (tmp_path / "native_modules.txt").write_text("drivers/hx711.py  # listed\n")
        assert stale_modules(tmp_path) == []


class TestThisCheckout:
    def test_every_listed_module_runs_compiled(self) -> None:
        """native_modules.txt's modules are imported from their build here (bootstrap built
        them), not silently from their .py: the simulator's speed rests on it."""
        import importlib
        import shutil

        import pytest

        if os.environ.get("ROBOTD_NATIVE") == "0" or shutil.which("gcc") is None:
            pytest.skip("built without mypyc (ROBOTD_NATIVE=0 or no C compiler)")
        listed = listed_sources()
        assert listed
        names = [str(p.with_suffix("")).replace("/", ".") for p in sorted(listed)]
        for name in names:
            module = importlib.import_module(name)
            assert module.__file__ is not None
            assert module.__file__.endswith(tuple(importlib.machinery.EXTENSION_SUFFIXES)), name
