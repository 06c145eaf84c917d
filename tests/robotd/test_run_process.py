"""``robotd run`` as a real process: READY=1, SIGHUP, SIGTERM exit 0, missing devices."""

from __future__ import annotations

import json
import os
import signal
import socket
import subprocess
import sys
import tempfile
from collections.abc import Iterator
from pathlib import Path

import pytest

STOP_LIMIT_S = 5.0
START_GUARD_S = 30.0  # a hang guard only: imports on a loaded machine can be slow


@pytest.fixture
def workdir() -> Iterator[Path]:
    # Short: Unix socket paths are limited to 107 bytes.
    with tempfile.TemporaryDirectory(prefix="rd-") as name:
        yield Path(name)


def write_config(workdir: Path, extra: str = "") -> Path:
    path = workdir / "robotd.toml"
    path.write_text(f"""\
[robot]
name = "proc-1"
profile = "idle"
state_dir = "{workdir / 'state'}"

[control]
socket = "{workdir / 'control.sock'}"

[line_follow]
kp = 0.7
{extra}""")
    return path


class Robotd:
    """A ``robotd run`` process with a real NOTIFY_SOCKET to hear READY=1 from."""

    def __init__(self, workdir: Path, config: Path, **extra_env: str) -> None:
        notify_path = workdir / f"notify-{len(list(workdir.glob('notify-*')))}"
        self.notify = socket.socket(socket.AF_UNIX, socket.SOCK_DGRAM)
        self.notify.bind(str(notify_path))
        self.notify.settimeout(START_GUARD_S)
        env = dict(os.environ, NOTIFY_SOCKET=str(notify_path), **extra_env)
        env.pop("JOURNAL_STREAM", None)
        self.proc = subprocess.Popen(
            [sys.executable, "-m", "robotd.cli", "run", "--config", str(config)],
            env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        self.socket_path = str(workdir / "control.sock")

    def wait_ready(self) -> list[str]:
        seen: list[str] = []
        while "READY=1" not in seen:
            seen += self.notify.recv(4096).decode().splitlines()
        return seen

    def call(self, method: str, params: dict[str, object] | None = None) -> dict[str, object]:
        with socket.socket(socket.AF_UNIX, socket.SOCK_STREAM) as conn:
            conn.settimeout(10)
            conn.connect(self.socket_path)
            conn.sendall(json.dumps({"jsonrpc": "2.0", "id": 1, "method": method,
                                     "params": params or {}}).encode() + b"\n")
            reply: dict[str, object] = json.loads(conn.makefile("rb").readline())
        return reply

    def stop(self) -> tuple[int, str]:
        self.proc.send_signal(signal.SIGTERM)
        try:
            code = self.proc.wait(timeout=STOP_LIMIT_S)
        finally:
            if self.proc.poll() is None:
                self.proc.kill()
            self.notify.close()
        _, stderr = self.proc.communicate()
        return code, stderr


def line_of(path: Path, text: str) -> int:
    """The 1-based line on which ``text`` starts."""
    return next(n for n, line in enumerate(path.read_text().splitlines(), 1)
                if line.startswith(text))


def result(reply: dict[str, object]) -> dict[str, object]:
    value = reply["result"]
    assert isinstance(value, dict)
    return value


class TestRobotdRun:
    def test_ready_then_sigterm_exits_0_within_5_s(self, workdir: Path) -> None:
        robot = Robotd(workdir, write_config(workdir))
        notices = robot.wait_ready()
        status = result(robot.call("status"))
        code, stderr = robot.stop()
        assert "READY=1" in notices
        assert status["state"] == "idle"
        assert code == 0
        assert "daemon.stopped" in stderr
        assert "Traceback" not in stderr
        assert not Path(robot.socket_path).exists(), "the socket is removed at exit"

    def test_step_cpu_debug_puts_the_long_steps_in_status(self, workdir: Path) -> None:
        """ROBOTD_STEP_CPU_MS: ``status`` lists the loop's steps over it, by name."""
        robot = Robotd(workdir, write_config(workdir), ROBOTD_STEP_CPU_MS="0.001")
        robot.wait_ready()
        status = result(robot.call("status"))
        code, _stderr = robot.stop()
        slow = status["slow_steps"]
        assert isinstance(slow, dict)
        assert slow["threshold_ms"] == 0.001
        assert slow["steps"], "start-up takes more than 1 us of CPU in some step"
        assert code == 0

    def test_status_has_no_step_figures_unless_asked(self, workdir: Path) -> None:
        robot = Robotd(workdir, write_config(workdir), ROBOTD_STEP_CPU_MS="")
        robot.wait_ready()
        status = result(robot.call("status"))
        robot.stop()
        assert "slow_steps" not in status

    def test_a_bad_step_cpu_threshold_is_one_clear_line(self, workdir: Path) -> None:
        done = subprocess.run([sys.executable, "-m", "robotd.cli", "run", "--config",
                               str(write_config(workdir))], capture_output=True, text=True,
                              timeout=60, check=False,
                              env=dict(os.environ, ROBOTD_STEP_CPU_MS="fast"))
        assert done.returncode == 2
        assert done.stderr == "robotd: ROBOTD_STEP_CPU_MS: 'fast' is not a number of ms\n"

    def test_sighup_with_a_broken_file_keeps_the_old_config(self, workdir: Path) -> None:
        config = write_config(workdir)
        robot = Robotd(workdir, config)
        robot.wait_ready()
        config.write_text(config.read_text().replace("kp = 0.7", "kp = \"fast\"\nbogus = 1"))
        robot.proc.send_signal(signal.SIGHUP)
        for _ in range(100):
            events = robot.call("events", {"kind": "config"})["result"]
            if events:
                break
        kp = result(robot.call("tune.get", {"key": "line_follow.kp"}))["value"]
        code, stderr = robot.stop()
        assert kp == 0.7
        assert isinstance(events, list)
        assert events[0]["status"] == "rejected"
        assert events[0]["problems"] == [
            f"{config}:{line_of(config, 'kp =')}: line_follow.kp: expected a number, got a "
            "string ('fast')",
            f"{config}:{line_of(config, 'bogus =')}: line_follow.bogus: unknown key"
            + events[0]["problems"][1].split("unknown key", 1)[1]]
        assert "config.reload_rejected" in stderr
        assert code == 0

    def test_persisted_tuning_is_loaded_over_the_file_at_the_next_start(
            self, workdir: Path) -> None:
        config = write_config(workdir)
        robot = Robotd(workdir, config)
        robot.wait_ready()
        robot.call("tune.set", {"key": "line_follow.kp", "value": 1.25, "persist": True})
        assert robot.stop()[0] == 0
        again = Robotd(workdir, config)
        again.wait_ready()
        kp = result(again.call("tune.get", {"key": "line_follow.kp"}))["value"]
        assert again.stop()[0] == 0
        assert kp == 1.25

    def test_a_missing_device_is_one_clear_line_each_not_a_traceback(
            self, workdir: Path) -> None:
        config = write_config(workdir, extra=(
            '\n[hal]\ndevices = ["motors", "lidar"]\n\n[serial]\nport = "/dev/ttyNOPE7"\n'))
        done = subprocess.run([sys.executable, "-m", "robotd.cli", "run", "--config",
                               str(config)], capture_output=True, text=True, timeout=60,
                              check=False)
        assert done.returncode == 1
        lines = done.stderr.splitlines()
        assert lines[0] == ("robotd: missing device: motors (arduino): serial port "
                            "/dev/ttyNOPE7 does not exist (check serial.port, the USB cable, "
                            "and ls /dev/ttyACM* /dev/ttyUSB*)")
        assert lines[1].startswith("robotd: missing device: lidar (lidar): ")
        assert len(lines) == 2

    def test_a_bad_config_stops_the_start_with_exit_2_and_its_lines(self,
                                                                     workdir: Path) -> None:
        config = write_config(workdir, extra="\n[serial]\nbaud = \"fast\"\n")
        done = subprocess.run([sys.executable, "-m", "robotd.cli", "run", "--config",
                               str(config)], capture_output=True, text=True, timeout=60,
                              check=False)
        assert done.returncode == 2
        assert done.stderr == (f"{config}:{line_of(config, 'baud =')}: serial.baud: expected "
                               "an integer, got a string ('fast')\n")

    def test_a_state_dir_it_cannot_create_is_one_clear_line(self, workdir: Path) -> None:
        blocker = workdir / "file"
        blocker.write_text("")
        config = write_config(workdir)
        config.write_text(config.read_text().replace(str(workdir / "state"),
                                                     str(blocker / "state")))
        done = subprocess.run([sys.executable, "-m", "robotd.cli", "run", "--config",
                               str(config)], capture_output=True, text=True, timeout=60,
                              check=False)
        assert done.returncode == 1
        assert done.stderr.startswith(f"robotd: cannot open the state store in {blocker}/state")
        assert "Traceback" not in done.stderr
