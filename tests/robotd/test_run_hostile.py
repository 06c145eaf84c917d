"""``robotd run`` as a real process with a corrupt overrides file or its socket taken."""

from __future__ import annotations

import subprocess
import sys
import tempfile
from collections.abc import Iterator
from pathlib import Path

import pytest
from test_run_process import Robotd, result, write_config


@pytest.fixture
def workdir() -> Iterator[Path]:
    with tempfile.TemporaryDirectory(prefix="rd-") as name:  # short: sun_path
        yield Path(name)


class TestRobotdRunHostile:
    def test_a_corrupt_overrides_file_is_reported_and_the_robot_starts(self, workdir: Path
                                                                       ) -> None:
        """READY=1 on the main file's values; stderr names the overrides file's line; the
        file is left as it was."""
        config = write_config(workdir)
        overrides = workdir / "state" / "overrides.toml"
        overrides.parent.mkdir()
        text = "[line_follow]\nkp = " + "9" * 5000 + "\n"
        overrides.write_text(text)
        robot = Robotd(workdir, config)
        robot.wait_ready()
        kp = result(robot.call("tune.get", {"key": "line_follow.kp"}))["value"]
        code, stderr = robot.stop()
        assert kp == 0.7 and code == 0
        assert (f"{overrides}:2: line_follow.kp: integer of 5000 digits is out of range "
                "(TOML integers are 64-bit) (overrides file ignored; the robot runs on "
                f"{config})") in stderr
        assert "Traceback" not in stderr
        assert overrides.read_text() == text

    def test_a_second_robotd_on_the_same_socket_exits_2_naming_it(self, workdir: Path
                                                                   ) -> None:
        """The first keeps running; the second refuses to start (exit 2), not deaf."""
        config = write_config(workdir)
        robot = Robotd(workdir, config)
        robot.wait_ready()
        try:
            second = subprocess.run(
                [sys.executable, "-m", "robotd.cli", "run", "--config", str(config)],
                capture_output=True, text=True, timeout=60, check=False)
            status = result(robot.call("status"))
        finally:
            code, _ = robot.stop()
        assert second.returncode == 2, second.stderr
        assert (f"{config}: control.socket: another robotd is already listening on "
                f"{workdir / 'control.sock'}") in second.stderr
        assert status["state"] == "idle" and code == 0
