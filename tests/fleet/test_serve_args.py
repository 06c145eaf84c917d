"""``robotd-fleet serve``: arguments that cannot work are refused in one line, before start."""

from __future__ import annotations

from pathlib import Path

import pytest

from fleet.cli import main, sqlite_dir_problem


class TestServeArguments:
    @pytest.mark.parametrize("port", ["99999", "0", "-1", "http"])
    def test_a_port_out_of_range_is_a_usage_error(self, port: str,
                                                   capsys: pytest.CaptureFixture[str]) -> None:
        """uvicorn would take 99999 as 34463 (modulo 65536) and -1 as a resolver error."""
        with pytest.raises(SystemExit) as exit_info:
            main(["serve", "--port", port])
        assert exit_info.value.code == 2
        assert "expected a TCP port 1-65535" in capsys.readouterr().err

    def test_a_sqlite_file_in_a_missing_directory_is_named_with_the_fix(
            self, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
        """The default database lives in /var/lib/robotd-fleet, which only the systemd unit
        makes: started by hand, the server says so instead of a start-up traceback."""
        db = tmp_path / "nowhere" / "fleet.db"
        assert main(["serve", "--db", f"sqlite:///{db}"]) == 2
        err = capsys.readouterr().err.strip()
        assert err.startswith(f"robotd-fleet: database {db}: the directory {db.parent} "
                              "does not exist")
        assert len(err.splitlines()) == 1

    def test_urls_that_can_work_pass(self, tmp_path: Path) -> None:
        assert sqlite_dir_problem(f"sqlite:///{tmp_path / 'fleet.db'}") is None
        assert sqlite_dir_problem("sqlite+aiosqlite:///fleet.db") is None  # the working dir
        assert sqlite_dir_problem("sqlite://") is None  # in memory
        assert sqlite_dir_problem("postgresql+asyncpg://u@localhost/fleet") is None


class TestServeHelp:
    def test_the_help_shows_the_host_and_port_defaults(
            self, capsys: pytest.CaptureFixture[str]) -> None:
        with pytest.raises(SystemExit):
            main(["serve", "--help"])
        out = " ".join(capsys.readouterr().out.split())
        assert "(default: 127.0.0.1" in out
        assert "(default: 8080)" in out
