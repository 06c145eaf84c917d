"""Hostile config files: each is one ``PATH:LINE: section.key: message`` line and exit 2."""

from __future__ import annotations

import os
import time
from pathlib import Path

import pytest

from robotd.cli import main
from robotd.config.loader import MAX_CONFIG_BYTES, load_config_and_overrides
from robotd.config.system_limits import UNIX_PATH_MAX


def check(path: Path | str, capsys: pytest.CaptureFixture[str]) -> tuple[int, list[str]]:
    code = main(["check-config", str(path)])
    return code, capsys.readouterr().out.splitlines()


def write(tmp_path: Path, text: str) -> Path:
    path = tmp_path / "robotd.toml"
    path.write_text(text)
    return path


class TestCheckConfig:
    def test_a_5000_digit_integer_is_a_line_naming_its_key(self, tmp_path: Path,
                                                           capsys: pytest.CaptureFixture[str]
                                                           ) -> None:
        """Past Python's digit limit: one line at the key's line, exit 2, no traceback."""
        path = write(tmp_path, "[line_follow]\nkp = " + "9" * 5000 + "\n")
        assert check(path, capsys) == (2, [
            f"{path}:2: line_follow.kp: integer of 5000 digits is out of range "
            "(TOML integers are 64-bit)"])

    def test_a_1000_deep_array_is_a_line_naming_its_key(self, tmp_path: Path,
                                                        capsys: pytest.CaptureFixture[str]
                                                        ) -> None:
        """Deeper than the TOML reader can recurse: one line, exit 2."""
        path = write(tmp_path, "[weight]\nmin_kg = 1\nmax_kg = " + "[" * 1000 + "]" * 1000)
        code, lines = check(path, capsys)
        assert code == 2
        assert lines == [f"{path}:3: weight.max_kg: arrays or inline tables nested too deeply "
                         "to read (past 100 levels on this line)"]

    def test_a_20_deep_array_is_refused_by_the_value_check(
            self, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
        """Readable but deeper than any option holds: refused at its key."""
        path = write(tmp_path, "[line_follow]\nkp = " + "[" * 20 + "]" * 20 + "\n")
        code, lines = check(path, capsys)
        assert code == 2 and lines == [f"{path}:2: line_follow.kp: nested deeper than 8 levels"]

    @pytest.mark.parametrize("number", ["9" * 400, "-" + "9" * 400, "9223372036854775808"])
    def test_an_integer_past_64_bits_is_out_of_range(
            self, number: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
        """For a float option (OverflowError before) and an int option alike."""
        for key in ("line_follow.kp", "supervisor.max_failures"):
            section, name = key.split(".")
            path = write(tmp_path, f"[{section}]\n{name} = {number}\n")
            code, lines = check(path, capsys)
            assert code == 2 and len(lines) == 1
            assert lines[0].startswith(f"{path}:2: {key}: integer out of range: about ")

    @pytest.mark.parametrize("special", ["/dev/zero", "directory", "fifo"])
    def test_what_is_not_a_regular_file_is_refused_at_once(
            self, special: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
        """/dev/zero, a directory, a FIFO with no writer: one clear line, no hang, exit 2."""
        path = Path(special)
        if special == "directory":
            path = tmp_path
        elif special == "fifo":
            path = tmp_path / "fifo"
            os.mkfifo(path)
        code, lines = check(path, capsys)
        assert code == 2 and len(lines) == 1
        assert lines[0].startswith(f"{path}: file: cannot read: ")
        assert lines[0].endswith("not a regular file")

    def test_a_file_over_1_mib_is_refused(self, tmp_path: Path,
                                          capsys: pytest.CaptureFixture[str]) -> None:
        path = write(tmp_path, "#" * MAX_CONFIG_BYTES + "\n")
        code, lines = check(path, capsys)
        assert code == 2 and lines == [f"{path}: file: cannot read: larger than 1048576 bytes "
                                       "(1 MiB); a config file is a few kilobytes"]

    def test_bytes_that_are_not_utf8_are_named_with_their_line(
            self, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
        path = tmp_path / "robotd.toml"
        path.write_bytes(b"[robot]\nname = \"r\xff\"\n")
        code, lines = check(path, capsys)
        assert code == 2 and lines == [
            f"{path}:2: file: not UTF-8 text: byte b'\\xff' at offset 17"]

    def test_a_socket_path_over_the_unix_limit_names_control_socket(
            self, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
        """108 bytes with the NUL fit sun_path; 108 without it do not."""
        fits = "/run/" + "a" * (UNIX_PATH_MAX - 1 - 5)
        path = write(tmp_path, f'[control]\nsocket = "{fits}"\n')
        assert check(path, capsys) == (0, [f"{path}: ok"])
        path = write(tmp_path, f'[control]\nsocket = "{fits}b"\n')
        code, lines = check(path, capsys)
        assert code == 2 and lines == [
            f"{path}:2: control.socket: path is 108 bytes; a Unix socket path is at most 107 "
            "bytes on Linux (108 with its NUL, sockaddr_un.sun_path)"]

    def test_a_long_line_of_spaces_after_a_bracket_is_read_in_linear_time(
            self, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
        """The table-header pattern took cubic time (4000 spaces: 37 s); 500 000 now: fast."""
        path = write(tmp_path, "[" + " " * 500_000 + "x\n")
        start_s = time.perf_counter()
        code, lines = check(path, capsys)
        assert time.perf_counter() - start_s < 2.0
        assert code == 2 and len(lines) == 1


class TestRun:
    def test_robotd_run_exits_2_with_the_lines_on_a_5000_digit_integer(
            self, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
        """Exit 2 (systemd: RestartPreventExitStatus=2), not 1 with a traceback."""
        path = write(tmp_path, "[line_follow]\nkp = " + "9" * 5000 + "\n")
        assert main(["run", "--config", str(path)]) == 2
        assert capsys.readouterr().err.startswith(f"{path}:2: line_follow.kp: integer of")

    @pytest.mark.parametrize("problem", ["too long", "not a socket"])
    def test_robotd_run_exits_2_when_it_could_not_listen_on_its_socket(
            self, problem: str, tmp_path: Path, capsys: pytest.CaptureFixture[str],
            monkeypatch: pytest.MonkeyPatch) -> None:
        """Refuses to start (exit 2, control.socket named) instead of running deaf."""
        socket = str(tmp_path / ("s" * 120 if problem == "too long" else "plain-file"))
        if problem == "not a socket":
            Path(socket).write_text("")
        monkeypatch.setenv("STATE_DIRECTORY", str(tmp_path / "state"))
        path = write(tmp_path, f'[robot]\nprofile = "idle"\n[control]\nsocket = "{socket}"\n')
        assert main(["run", "--config", str(path)]) == 2
        err = capsys.readouterr().err
        assert err.startswith(f"{path}:") and ": control.socket: " in err
        assert ("path is" if problem == "too long" else "is not a socket") in err


class TestOverridesFile:
    @pytest.mark.parametrize("text", ["[line_follow\nkp = 1\n", "[line_follow]\nkp = "
                                      + "9" * 5000 + "\n", "[line_follow]\nkp = -1\n"])
    def test_a_corrupt_overrides_file_is_reported_and_the_main_file_used(
            self, text: str, tmp_path: Path) -> None:
        """Its problems come back as lines; none of its keys are used; nothing raises."""
        main_file = write(tmp_path, "[line_follow]\nkp = 0.7\nki = 0.1\n")
        over = tmp_path / "overrides.toml"
        over.write_text(text + "[weight]\nmax_kg = 12.5\n")
        values, problems = load_config_and_overrides(main_file, over)
        assert values["line_follow"]["kp"] == 0.7 and values["weight"]["max_kg"] != 12.5
        assert problems and all(str(p).startswith(f"{over}:") for p in problems)

    def test_a_good_overrides_file_is_laid_over(self, tmp_path: Path) -> None:
        main_file = write(tmp_path, "[line_follow]\nkp = 0.7\n")
        over = tmp_path / "overrides.toml"
        over.write_text("[line_follow]\nkp = 0.9\n")
        values, problems = load_config_and_overrides(main_file, over)
        assert values["line_follow"]["kp"] == 0.9 and problems == []
