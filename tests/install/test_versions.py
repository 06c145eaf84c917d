"""A version's id: the same source gives the same id, a changed one another; what is not a
robotd source is refused by name."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest

from robotd.install.system import InstallError
from robotd.install.versions import read_source


def _checkout(tmp_path: Path) -> Path:
    root = tmp_path / "checkout"
    (root / "robotd").mkdir(parents=True)
    (root / "pyproject.toml").write_text('[project]\nname = "robotd"\nversion = "0.3.0"\n')
    (root / "robotd" / "__init__.py").write_text('"""robotd."""\n')
    return root


class TestReadSource:
    def test_a_checkout_keeps_its_id_until_a_source_file_changes(self, tmp_path: Path) -> None:
        """Caches and compiled kernels do not change the id; an edited module does."""
        root = _checkout(tmp_path)
        first = read_source(root)
        assert first.id.startswith("0.3.0-") and not first.is_wheel
        (root / "robotd" / "__pycache__").mkdir()
        (root / "robotd" / "__pycache__" / "x.cpython-311.pyc").write_bytes(b"\0")
        (root / "robotd" / "_kernel.cpython-311-x86_64-linux-gnu.so").write_bytes(b"\0")
        assert read_source(root).id == first.id
        (root / "robotd" / "__init__.py").write_text('"""robotd, edited."""\n')
        assert read_source(root).id != first.id

    def test_a_wheel_id_is_its_version_and_a_digest_of_the_file(
            self, wheels: tuple[Path, Path], tmp_path: Path) -> None:
        source = read_source(wheels[1])
        assert source.is_wheel and source.id.startswith("0.1.1.dev1-")
        copy = tmp_path / wheels[1].name
        shutil.copy(wheels[1], copy)
        assert read_source(copy).id == source.id

    @pytest.mark.parametrize(("name", "text", "why"), [
        ("notes.txt", "hello", "neither a wheel nor a checkout (no pyproject.toml there)"),
        ("robotd-1.0-py3-none-any.whl", "not a zip", "not a wheel: "),
        ("other-1.0-py3-none-any.whl", "", "not a robotd wheel"),
    ])
    def test_what_is_not_robotd_is_refused_by_name(
            self, tmp_path: Path, name: str, text: str, why: str) -> None:
        path = tmp_path / name
        if name.endswith(".txt"):
            path.mkdir()
        else:
            path.write_text(text)
        with pytest.raises(InstallError, match=why.replace("(", r"\(").replace(")", r"\)")):
            read_source(path)

    def test_another_projects_checkout_is_refused(self, tmp_path: Path) -> None:
        (tmp_path / "pyproject.toml").write_text('[project]\nname = "other"\nversion = "1"\n')
        with pytest.raises(InstallError, match="not robotd's"):
            read_source(tmp_path)
