"""``robotd check-config`` and ``robotd probe``: exit codes and one line per problem."""

from __future__ import annotations

import subprocess
import sys
import types
from pathlib import Path

import pytest

from robotd import cli

BROKEN = """\
[robot]
name = 5
colour = "red"

[serial]
port = "/dev/ttyACM0"
baud = = 9600
"""


def robotd(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "robotd.cli", *args], capture_output=True,
                          text=True, timeout=60, check=False)


class TestCheckConfig:
    def test_a_wrong_type_an_unknown_key_and_a_syntax_error_each_get_one_line(
            self, tmp_path: Path) -> None:
        """Exit 2, ``PATH:LINE: section.key: message`` per problem, no traceback."""
        path = tmp_path / "robotd.toml"
        path.write_text(BROKEN)
        done = robotd("check-config", str(path))
        assert done.returncode == 2
        assert done.stdout.splitlines() == [
            f"{path}:2: robot.name: expected a string, got an integer (5)",
            f"{path}:3: robot.colour: unknown key (known: name, profile, state_dir)",
            f"{path}:7: serial.baud: TOML syntax error: Invalid value",
        ]
        assert "Traceback" not in done.stderr

    def test_a_valid_file_passes(self, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
        path = tmp_path / "robotd.toml"
        path.write_text('[robot]\nname = "r1"\nprofile = "idle"\n')
        assert cli.main(["check-config", str(path)]) == 0
        assert capsys.readouterr().out == f"{path}: ok\n"

    def test_the_shipped_example_config_is_valid(self) -> None:
        example = Path(__file__).parents[2] / "systemd" / "robotd.toml"
        assert cli.main(["check-config", str(example)]) == 0

    def test_a_missing_file_is_one_line_too(self, tmp_path: Path,
                                            capsys: pytest.CaptureFixture[str]) -> None:
        assert cli.main(["check-config", str(tmp_path / "nope.toml")]) == 2
        (line,) = capsys.readouterr().out.splitlines()
        assert line.startswith(f"{tmp_path / 'nope.toml'}: file: cannot read")


class TestProbe:
    def test_an_unknown_device_is_a_usage_error(self) -> None:
        done = robotd("probe", "toaster")
        assert done.returncode == 2
        assert "invalid choice: 'toaster'" in done.stderr

    def test_a_probe_module_that_is_not_installed_is_a_clear_error(
            self, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]) -> None:
        monkeypatch.setitem(cli.PROBES, "ghost", ("robotd.probes.ghost", "nothing"))
        assert cli.main(["probe", "ghost"]) == 2
        assert "no probe for 'ghost' in this installation" in capsys.readouterr().err

    def test_a_probe_gets_its_own_options_and_json(
            self, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]) -> None:
        """The registry's module adds its options; the CLI adds --json and runs it."""
        monkeypatch.setitem(cli.PROBES, "echo", ("probe_echo", "prints its options"))
        monkeypatch.syspath_prepend(str(Path(__file__).parent))
        assert cli.main(["probe", "echo", "--port", "/dev/x", "--json"]) == 0
        assert capsys.readouterr().out == '{"port": "/dev/x", "json": true}\n'


class TestSim:
    def test_sim_parses_the_contract_arguments(self, monkeypatch: pytest.MonkeyPatch) -> None:
        """The runner gets SCENARIO, seed, speed, socket, report, quiet and mcu."""
        seen = {}
        runner = types.ModuleType("sim.runner")
        runner.run_sim = lambda args: seen.update(vars(args)) or 0  # type: ignore[attr-defined]
        monkeypatch.setitem(sys.modules, "sim.runner", runner)
        assert cli.main(["sim", "square", "--seed", "3", "--speed", "5", "--socket", "/tmp/s",
                         "--report", "out", "--quiet", "--mcu", "simavr"]) == 0
        assert seen["scenario"] == "square"
        assert (seen["seed"], seen["speed"], seen["realtime"]) == (3, 5.0, False)
        assert (seen["socket"], seen["report"], seen["quiet"], seen["mcu"]) == (
            "/tmp/s", "out", True, "simavr")

    def test_an_outside_fleet_needs_a_paced_clock(self, capsys: pytest.CaptureFixture[str]
                                                  ) -> None:
        """--fleet-url on the virtual clock would flood the server: exit 2, saying why."""
        assert cli.main(["sim", "laundry-console", "--fleet-url", "http://127.0.0.1:1"]) == 2
        assert "--fleet-url needs --realtime or --speed" in capsys.readouterr().out

    def test_realtime_and_speed_exclude_each_other(self) -> None:
        with pytest.raises(SystemExit) as exc:
            cli.main(["sim", "--realtime", "--speed", "2"])
        assert exc.value.code == 2


class TestExampleConfig:
    def test_the_shipped_example_documents_every_key_of_the_schema(self) -> None:
        """systemd/robotd.toml is what ``robotd example-config`` prints from the schema."""
        from robotd.config.example import render_example

        example = Path(__file__).parents[2] / "systemd" / "robotd.toml"
        assert example.read_text() == render_example(), (
            "the schema changed: run `robotd example-config > systemd/robotd.toml`")
