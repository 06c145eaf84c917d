"""``python -m sim.feed`` serving a delivery robot to a real ``robotd run`` in another process."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import tempfile
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from robotd.ctl.connection import CannotConnect, Connection

ROOT = Path(__file__).resolve().parents[2]
GUARD_S = 120.0  # a hang guard only: two processes' imports on a loaded machine are slow
MOVING = ("mission.approaching", "mission.verifying", "mission.navigating_to_warehouse")


@pytest.fixture
def workdir() -> Iterator[Path]:
    # Short: Unix socket paths are limited to 107 bytes.
    with tempfile.TemporaryDirectory(prefix="fd-") as name:
        yield Path(name)


def stop(proc: subprocess.Popen[str]) -> str:
    """SIGINT, then what it printed on stdout."""
    if proc.poll() is None:
        proc.send_signal(signal.SIGINT)
    try:
        out, _ = proc.communicate(timeout=20)
    except subprocess.TimeoutExpired:
        proc.kill()
        out, _ = proc.communicate()
    return out or ""


def poll_until_moving(socket_path: str, daemon: subprocess.Popen[str]) -> dict[str, Any]:
    """Status every 0.2 s until the robot drives to its customer (or the guard runs out)."""
    deadline = time.monotonic() + GUARD_S
    status: dict[str, Any] = {}
    conn: Connection | None = None
    while time.monotonic() < deadline and daemon.poll() is None:
        try:
            conn = conn or Connection(socket_path, 5.0)
            status = conn.call("status")
        except (CannotConnect, FileNotFoundError):
            conn = None
        if status.get("state") in MOVING:
            break
        time.sleep(0.2)
    if conn is not None:
        conn.close()
    return status


class TestFeedDelivery:
    def test_robotd_run_on_the_feeder_detects_the_customer_and_reports_its_loop_lag(
            self, workdir: Path) -> None:
        """The feeder writes a config that check-config accepts; robotd run on it sees the
        customer walk in through the LD19 on a pty, drives to them on the motor board on
        another pty (the mission moves on), and its status has the loop lag."""
        env = dict(os.environ, PYTHONPATH=str(ROOT))
        feed = subprocess.Popen([sys.executable, "-m", "sim.feed", "delivery", "--dir",
                                 str(workdir / "feed")], stdout=subprocess.PIPE, text=True,
                                env=env, cwd=ROOT)
        daemon: subprocess.Popen[str] | None = None
        try:
            assert feed.stdout is not None
            line = feed.stdout.readline().strip()
            assert line.startswith("config "), line
            config = line.removeprefix("config ")
            check = subprocess.run([sys.executable, "-m", "robotd.cli", "check-config", config],
                                   capture_output=True, text=True, env=env, timeout=GUARD_S,
                                   check=False)
            assert check.returncode == 0, check.stdout + check.stderr
            daemon = subprocess.Popen([sys.executable, "-m", "robotd.cli", "run", "--config",
                                       config], stdout=subprocess.DEVNULL,
                                      stderr=subprocess.PIPE, text=True, env=env)
            status = poll_until_moving(str(workdir / "feed" / "control.sock"), daemon)
        finally:
            errors = ""
            if daemon is not None:
                daemon.send_signal(signal.SIGINT)
                _, errors = daemon.communicate(timeout=30)
            figures = stop(feed).strip().splitlines()
        assert status.get("state") in MOVING, errors[-2000:]
        assert status["profile"] == "delivery"
        assert status["loop_lag_ms"]["samples"] > 0
        assert status["loop_lag_ms"]["p50_ms"] >= 0
        served = json.loads(figures[-1])
        assert served["ld19_bytes"] > 0 and served["mcu_commands"] > 0
