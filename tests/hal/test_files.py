"""Files a config or a scenario points to: regular files of a bounded size, and no error ever
quotes them (issue 28: /dev/zero grew a scenario to 24 GB, /etc/shadow was echoed)."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from hal.files import FileRefused, read_bounded, read_bounded_text, restrict_new, write_new

SECRET = "root:$6$SECRETHASHxyz:19000:0:99999:7:::"
"""A line like /etc/shadow's: it must never appear in an error."""


@pytest.fixture
def secret_file(tmp_path: Path) -> Path:
    path = tmp_path / "shadow"
    path.write_text(f"{SECRET}\ndaemon:*:19000:0:99999:7:::\n")
    return path


class TestReadBounded:
    def test_a_regular_file_within_the_bound_is_read(self, tmp_path: Path) -> None:
        path = tmp_path / "a.json"
        path.write_bytes(b"{}")
        assert read_bounded(path, 2) == b"{}"

    def test_a_file_over_the_bound_is_refused_without_reading_it_all(self, tmp_path: Path
                                                                       ) -> None:
        path = tmp_path / "big"
        path.write_bytes(b"x" * 1000)
        with pytest.raises(FileRefused, match=r"big: cannot read: larger than 999 bytes"):
            read_bounded(path, 999, "map")

    def test_a_character_device_is_refused_at_once(self) -> None:
        """/dev/zero would be read forever: it is not a regular file."""
        with pytest.raises(FileRefused, match="a character device, not a regular file"):
            read_bounded("/dev/zero", 1 << 30)

    def test_a_fifo_with_no_writer_does_not_hang(self, tmp_path: Path) -> None:
        fifo = tmp_path / "fifo"
        os.mkfifo(fifo)
        with pytest.raises(FileRefused, match="a FIFO"):
            read_bounded(fifo, 100)

    def test_a_directory_and_a_missing_file_say_so(self, tmp_path: Path) -> None:
        with pytest.raises(FileRefused, match="a directory"):
            read_bounded(tmp_path, 100)
        with pytest.raises(FileRefused, match="No such file"):
            read_bounded(tmp_path / "none", 100)

    def test_text_that_is_not_utf8_is_refused_by_offset_not_content(self, tmp_path: Path
                                                                     ) -> None:
        path = tmp_path / "bin"
        path.write_bytes(b"ok\n\xff\xfeSECRET")
        with pytest.raises(FileRefused) as refused:
            read_bounded_text(path, 100, "map")
        assert "line 2" in str(refused.value) and "SECRET" not in str(refused.value)


def _check_config(tmp_path: Path, text: str) -> subprocess.CompletedProcess[str]:
    config = tmp_path / "robotd.toml"
    config.write_text(text)
    return subprocess.run([sys.executable, "-m", "robotd.cli", "check-config", str(config)],
                          capture_output=True, text=True, timeout=60, check=False)


EXAMPLES = Path(__file__).resolve().parents[2] / "behaviours" / "profiles" / "cabinet" / "examples"
REFERENCES = {
    "cabinet.map_file": '[robot]\nname = "c-1"\nprofile = "cabinet"\n[cabinet]\nmap_file = "{}"\n',
    "cabinet.task_file": '[robot]\nname = "c-1"\nprofile = "cabinet"\n[cabinet]\n'
                         f'map_file = "{EXAMPLES / "site.json"}"\ntask_file = "{{}}"\n',
    "map.file": '[robot]\nname = "p-1"\nprofile = "patrol"\n[map]\nfile = "{}"\n',
    "delivery.database_url": '[robot]\nname = "d-1"\nprofile = "delivery"\n[delivery]\n'
                             'database_url = "sqlite:///{}"\n',
}


class TestEveryReferencedFile:
    @pytest.mark.parametrize("key", sorted(REFERENCES))
    def test_dev_zero_is_exit_2_naming_the_key(self, key: str, tmp_path: Path) -> None:
        run = _check_config(tmp_path, REFERENCES[key].format("/dev/zero"))
        assert run.returncode == 2, run.stdout + run.stderr
        assert f": {key}: " in run.stdout and "/dev/zero" in run.stdout
        assert "Traceback" not in run.stdout + run.stderr

    @pytest.mark.parametrize("key", sorted(REFERENCES))
    def test_a_secret_file_is_refused_and_never_quoted(self, key: str, tmp_path: Path,
                                                       secret_file: Path) -> None:
        run = _check_config(tmp_path, REFERENCES[key].format(secret_file))
        assert run.returncode == 2, run.stdout + run.stderr
        assert "Traceback" not in run.stdout + run.stderr
        assert "SECRETHASH" not in run.stdout + run.stderr and "daemon:" not in run.stdout

    @pytest.mark.parametrize("target", ["/dev/zero", "secret"])
    def test_a_scenario_world_map_is_refused_alike(self, target: str, tmp_path: Path,
                                                   secret_file: Path) -> None:
        path = str(secret_file) if target == "secret" else target
        scenario = tmp_path / "s.toml"
        scenario.write_text(f'[scenario]\nprofile = "square"\n[world]\nmap = "{path}"\n'
                            '[robot]\nx_m = 1\ny_m = 1\n[success]\ntime_limit_s = 5\n')
        run = subprocess.run([sys.executable, "-m", "robotd.cli", "sim", str(scenario),
                              "--quiet"], capture_output=True, text=True, timeout=120,
                             check=False)
        assert run.returncode == 2, run.stdout + run.stderr
        assert "world.map" in run.stdout and "Traceback" not in run.stdout + run.stderr
        assert "SECRETHASH" not in run.stdout + run.stderr


class TestWritingSafely:
    def test_write_new_refuses_a_link_placed_where_the_file_goes(self, tmp_path: Path) -> None:
        """--report DIR in a shared place: a link there would have us write where its owner
        chose; refused, and its target untouched."""
        target = tmp_path / "victim"
        target.write_text("keep")
        link = tmp_path / "events.jsonl"
        link.symlink_to(target)
        with pytest.raises(OSError, match="is a symbolic link: not written through it"):
            write_new(link, b"x")
        assert target.read_text() == "keep"

    def test_write_new_gives_the_mode_whatever_the_umask(self, tmp_path: Path) -> None:
        old = os.umask(0o077)
        try:
            write_new(tmp_path / "a", b"x", 0o644)
        finally:
            os.umask(old)
        assert (tmp_path / "a").stat().st_mode & 0o777 == 0o644

    def test_state_files_are_private_whatever_the_umask(self, tmp_path: Path) -> None:
        """The state store (and anything made with restrict_new) is 0600 under umask 022."""
        from robotd.store import StateStore

        old = os.umask(0o022)
        try:
            store = StateStore(tmp_path / "state.db")
            store.close()
        finally:
            os.umask(old)
        assert (tmp_path / "state.db").stat().st_mode & 0o777 == 0o600
        existing = tmp_path / "loose"
        existing.write_text("")
        existing.chmod(0o666)
        restrict_new(existing, 0o640)
        assert existing.stat().st_mode & 0o777 == 0o640

    def test_a_report_directory_with_a_planted_link_is_refused(self, tmp_path: Path) -> None:
        report = tmp_path / "out"
        report.mkdir()
        (report / "trajectory.png").symlink_to(tmp_path / "elsewhere.png")
        run = subprocess.run([sys.executable, "-m", "robotd.cli", "sim", "square", "--quiet",
                              "--report", str(report)], capture_output=True, text=True,
                             timeout=120, check=False)
        assert run.returncode == 2, run.stdout + run.stderr
        assert "trajectory.png is a symbolic link" in run.stdout
        assert not (tmp_path / "elsewhere.png").exists()
