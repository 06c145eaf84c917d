"""``robotd sim square``: the whole daemon on the simulator drives a square and comes home."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest

from robotd.cli import main


def _events(report: Path) -> list[dict[str, Any]]:
    return [json.loads(line) for line in (report / "events.jsonl").read_text().splitlines()]


@pytest.fixture(scope="module")
def square_seed1(tmp_path_factory: pytest.TempPathFactory) -> tuple[int, Path]:
    out = tmp_path_factory.mktemp("square1")
    code = main(["sim", "square", "--quiet", "--seed", "1", "--report", str(out)])
    return code, out


class TestSquareScenario:
    def test_passes_and_writes_the_report(self, square_seed1: tuple[int, Path]) -> None:
        """Exit 0, an events file ending in a successful result, and a PNG."""
        code, out = square_seed1
        assert code == 0
        result = _events(out)[-1]
        assert result["kind"] == "result" and result["ok"] is True
        png = (out / "trajectory.png").read_bytes()
        assert png.startswith(b"\x89PNG") and len(png) > 10_000

    def test_ends_within_5_cm_of_the_start(self, square_seed1: tuple[int, Path]) -> None:
        _, out = square_seed1
        fig = _events(out)[-1]["figures"]["sim-1"]
        off = ((fig["final_x_m"] - 1.5) ** 2 + (fig["final_y_m"] - 1.2) ** 2) ** 0.5
        assert off <= 0.05
        assert fig["distance_m"] == pytest.approx(4.0, abs=0.1)

    def test_unplug_stops_the_motors_within_500_ms_and_the_mission_resumes(
        self, square_seed1: tuple[int, Path]
    ) -> None:
        """The board's deadman stops the wheels; the link comes back; the square finishes."""
        _, out = square_seed1
        events = _events(out)
        unplug = next(e for e in events if e.get("action") == "mcu.unplug")
        deadman = next(e for e in events if e["kind"] == "deadman")
        assert 0 < deadman["t"] - unplug["t"] <= 0.5
        assert deadman["t"] - deadman["last_command_t"] == pytest.approx(0.5, abs=0.01)
        link_up = [e for e in events if e["kind"] == "link" and e["status"] == "up"]
        assert any(e["t"] > unplug["t"] + 1.0 for e in link_up)
        done = next(e for e in events if e["kind"] == "square.done")
        assert done["link_waits"] >= 1
        assert [e["dst"] for e in events if e["kind"] == "transition"] == [
            "idle", "mission.square", "idle"]

    def test_same_seed_gives_byte_identical_events(
        self, square_seed1: tuple[int, Path], tmp_path: Path
    ) -> None:
        _, first = square_seed1
        assert main(["sim", "square", "--quiet", "--seed", "1", "--report", str(tmp_path)]) == 0
        assert (tmp_path / "events.jsonl").read_bytes() == (first / "events.jsonl").read_bytes()

    def test_another_seed_gives_other_noise_and_still_succeeds(
        self, square_seed1: tuple[int, Path], tmp_path: Path
    ) -> None:
        _, first = square_seed1
        assert main(["sim", "square", "--quiet", "--seed", "2", "--report", str(tmp_path)]) == 0
        assert (tmp_path / "events.jsonl").read_bytes() != (first / "events.jsonl").read_bytes()


class TestSimCommandLine:
    def test_unknown_scenario_is_exit_2_with_the_built_ins(
        self, capsys: pytest.CaptureFixture[str]
    ) -> None:
        assert main(["sim", "no-such-scenario", "--quiet"]) == 2
        assert "square" in capsys.readouterr().out

    def test_a_failing_condition_is_exit_1_with_the_reason(
        self, tmp_path: Path, capsys: pytest.CaptureFixture[str]
    ) -> None:
        """A time limit too short for the square fails and says so."""
        from importlib import resources

        text = (resources.files("sim.robots.square") / "scenarios" / "square.toml").read_text()
        scenario = tmp_path / "short.toml"
        scenario.write_text(text.replace("time_limit_s = 120", "time_limit_s = 5"))
        assert main(["sim", str(scenario), "--quiet"]) == 1
        out = capsys.readouterr().out
        assert "FAILED" in out and "time limit of 5 s reached" in out

    def test_a_script_step_that_never_ran_fails_the_run(
        self, tmp_path: Path, capsys: pytest.CaptureFixture[str]
    ) -> None:
        """A step waiting for a state the robot never enters is not skipped silently: the
        run fails, naming the step and the state (issue 28)."""
        from importlib import resources

        text = (resources.files("sim.robots.square") / "scenarios" / "square.toml").read_text()
        scenario = tmp_path / "never.toml"
        scenario.write_text(text + '\n[[script]]\nat_s = 1.0\naction = "robot.kill"\n'
                            'when_state = "docking.search"\n')
        assert main(["sim", str(scenario), "--quiet"]) == 1
        out = capsys.readouterr().out
        assert "script step robot.kill (at_s 1) never ran: its when_state 'docking.search' " \
               "never came" in out

    def test_bad_config_in_a_scenario_names_the_key(
        self, tmp_path: Path, capsys: pytest.CaptureFixture[str]
    ) -> None:
        from importlib import resources

        text = (resources.files("sim.robots.square") / "scenarios" / "square.toml").read_text()
        scenario = tmp_path / "bad.toml"
        scenario.write_text(text.replace('[config.robot]\n', '[config.drive]\ncruise_mps = "fast"\n'
                                                            '[config.robot]\n'))
        assert main(["sim", str(scenario), "--quiet"]) == 2
        assert "drive.cruise_mps: expected a number" in capsys.readouterr().out

    def test_limits_in_a_scenario_are_checked_in_order_once_all_are_set(
        self, tmp_path: Path, capsys: pytest.CaptureFixture[str]
    ) -> None:
        """min_kg 12 before max_kg 20 is a valid pair (each alone would not be against the
        defaults); min_kg 12 with the default max_kg 10 is refused, naming both."""
        from importlib import resources

        text = (resources.files("sim.robots.square") / "scenarios" / "square.toml").read_text()
        good = tmp_path / "good.toml"
        good.write_text(text.replace('[config.robot]\n', '[config.weight]\nmin_kg = 12\n'
                                                         'max_kg = 20\n[config.robot]\n'))
        assert main(["sim", str(good), "--quiet"]) == 0
        bad = tmp_path / "bad.toml"
        bad.write_text(text.replace('[config.robot]\n', '[config.weight]\nmin_kg = 12\n'
                                                        '[config.robot]\n'))
        assert main(["sim", str(bad), "--quiet"]) == 2
        assert "weight.max_kg: must be above weight.min_kg (12), got 10" in \
            capsys.readouterr().out


class TestSimavrOption:
    def test_the_emulated_firmware_needs_the_wall_clock(
        self, capsys: pytest.CaptureFixture[str]
    ) -> None:
        """--mcu simavr in virtual time is refused with what to do, before anything starts."""
        assert main(["sim", "square", "--mcu", "simavr", "--quiet"]) == 2
        assert "add --realtime" in capsys.readouterr().out


class TestOptionsCheckedBeforeRunning:
    def test_a_speed_that_is_not_positive_is_a_usage_error(self) -> None:
        with pytest.raises(SystemExit) as info:
            main(["sim", "square", "--speed", "-3"])
        assert info.value.code == 2

    def test_a_report_directory_that_cannot_be_made_is_refused_at_once(
        self, capsys: pytest.CaptureFixture[str]
    ) -> None:
        assert main(["sim", "square", "--quiet", "--report", "/proc/nope"]) == 2
        assert "--report /proc/nope: cannot create the directory" in capsys.readouterr().out


class TestQuiet:
    def test_quiet_prints_the_result_and_no_log_lines(self) -> None:
        """``--quiet``: the summary on stdout, nothing on stderr (the daemons' warnings, such
        as link.down while the board is unplugged, are JSON log lines a user did not ask for)."""
        import subprocess
        import sys

        done = subprocess.run([sys.executable, "-m", "robotd.cli", "sim", "square", "--quiet",
                               "--seed", "1"], capture_output=True, text=True, timeout=120,
                              check=False)
        assert done.returncode == 0
        assert done.stderr == ""
        assert done.stdout.lstrip().startswith("scenario square: SUCCESS")


class TestSocketInUse:
    def test_a_socket_another_daemon_listens_on_is_exit_2(
            self, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
        """A second ``robotd sim --socket`` on a socket in use says so and exits 2 (it ran on
        without its socket)."""
        import socket

        path = str(tmp_path / "r.sock")
        with socket.socket(socket.AF_UNIX, socket.SOCK_STREAM) as other:
            other.bind(path)
            other.listen()
            assert main(["sim", "square", "--quiet", "--socket", path]) == 2
        assert f"--socket {path}: another robotd is already listening" in capsys.readouterr().out
