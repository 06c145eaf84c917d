"""Nothing locks a technician out of the e-stop (issue 28): a real daemon, the real robotctl.

``robotd sim square --realtime`` is a real daemon driving a simulated robot. Against it: 200
idle clients (connected, sending nothing) and 200 slow ones (requests sent, replies never
read) opened at once, then a connect storm; ``robotctl estop`` (a subprocess) must exit 0 with
the robot in ``estop``, and ``robotctl status`` must work too. Before: 64 idle connections were
enough to make ``robotctl estop`` fail with ``Broken pipe``, exit 3, the robot not stopped.
"""

from __future__ import annotations

import contextlib
import json
import signal
import socket
import struct
import subprocess
import sys
import tempfile
import threading
import time
from collections.abc import Iterator
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from typing import Any

import pytest

BIN = Path(sys.executable).parent
STATUS = b'{"jsonrpc":"2.0","id":1,"method":"status"}\n'
START_GUARD_S = 90.0  # a hang guard only: imports on a loaded machine can be slow
IDLE, SLOW = 200, 200


def blocking_socket(wait_s: float) -> socket.socket:
    """A client socket whose connect waits (up to ``wait_s``) for room in a full queue."""
    sock = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    sock.setsockopt(socket.SOL_SOCKET, socket.SO_SNDTIMEO,
                    struct.pack("@ll", int(wait_s), int(wait_s % 1 * 1_000_000)))
    return sock


class SimDaemon:
    """``robotd sim square --realtime --socket PATH`` as a process."""

    def __init__(self, workdir: Path) -> None:
        self.socket_path = str(workdir / "c.sock")
        self.log = (workdir / "robotd.err").open("w+")
        self.proc = subprocess.Popen(
            [str(BIN / "robotd"), "sim", "square", "--realtime", "--quiet",
             "--socket", self.socket_path],
            stdout=subprocess.DEVNULL, stderr=self.log)

    def call(self, method: str) -> dict[str, Any]:
        with blocking_socket(5) as conn:
            conn.settimeout(10)
            conn.connect(self.socket_path)
            conn.sendall(json.dumps({"jsonrpc": "2.0", "id": 1, "method": method}).encode()
                         + b"\n")
            reply: dict[str, Any] = json.loads(conn.makefile("rb").readline())
        return reply

    def wait_for_state(self, prefix: str) -> None:
        deadline = time.monotonic() + START_GUARD_S
        while time.monotonic() < deadline:
            assert self.proc.poll() is None, self.stderr()
            with contextlib.suppress(OSError, ValueError):
                if self.call("status")["result"]["state"].startswith(prefix):
                    return
            time.sleep(0.1)
        pytest.fail(f"the daemon never reached {prefix}: {self.stderr()[-2000:]}")

    def stderr(self) -> str:
        self.log.flush()
        self.log.seek(0)
        return self.log.read()

    def stop(self) -> str:
        self.proc.send_signal(signal.SIGTERM)
        try:
            self.proc.wait(timeout=15)
        finally:
            if self.proc.poll() is None:
                self.proc.kill()
                self.proc.wait()
        text = self.stderr()
        self.log.close()
        return text


@pytest.fixture
def daemon() -> Iterator[SimDaemon]:
    with tempfile.TemporaryDirectory(prefix="rd-") as name:  # short: sun_path
        robot = SimDaemon(Path(name))
        try:
            robot.wait_for_state("mission.")  # the robot is driving its square
            yield robot
        finally:
            stderr = robot.stop()
        assert "Traceback" not in stderr, stderr[-3000:]


def robotctl(daemon: SimDaemon, *argv: str) -> tuple[int, str, str, float]:
    """The real robotctl as a process: exit code, stdout, stderr, seconds it took."""
    started = time.monotonic()
    done = subprocess.run([str(BIN / "robotctl"), "--socket", daemon.socket_path, *argv],
                          capture_output=True, text=True, timeout=60, check=False)
    return done.returncode, done.stdout, done.stderr, time.monotonic() - started


def open_hostile_clients(path: str) -> list[socket.socket]:
    """200 idle and 200 slow clients, interleaved, all connected."""
    clients = []
    for i in range(IDLE + SLOW):
        sock = blocking_socket(10)
        sock.connect(path)
        if i % 2:  # slow: asks for 200 replies (~300 KB) and never reads one
            sock.setblocking(False)
            with contextlib.suppress(OSError):
                sock.send(STATUS * 200)
        clients.append(sock)
    return clients


class ConnectStorm:
    """Threads that each open ``burst`` connections at once (each sends a request), hang
    them all up and start again: at ``rate_per_s`` in all, or as fast as they can (None)."""

    def __init__(self, path: str, *, threads: int = 4, burst: int = 25,
                 rate_per_s: float | None = None) -> None:
        self.path = path
        self.burst = burst
        self.cycle_s = 0.0 if rate_per_s is None else burst * threads / rate_per_s
        self.stop = threading.Event()
        self.connects = 0
        self.failures = 0
        self._threads = [threading.Thread(target=self._run, daemon=True)
                         for _ in range(threads)]

    def _run(self) -> None:
        while not self.stop.is_set():
            started = time.monotonic()
            wave = []
            for _ in range(self.burst):
                sock = blocking_socket(1)
                wave.append(sock)
                try:
                    sock.connect(self.path)
                    sock.setblocking(False)
                    sock.send(STATUS)
                    self.connects += 1
                except OSError:
                    self.failures += 1
            for sock in wave:
                sock.close()
            self.stop.wait(max(0.0, started + self.cycle_s - time.monotonic()))

    def __enter__(self) -> ConnectStorm:
        self.started = time.monotonic()
        for thread in self._threads:
            thread.start()
        return self

    def __exit__(self, *_exc: object) -> None:
        self.stop.set()
        for thread in self._threads:
            thread.join(10)
        self.seconds = time.monotonic() - self.started

    def rate(self) -> str:
        return f"{self.connects / self.seconds:.0f} connects/s ({self.failures} failed)"


class TestEstopThroughHostileClients:
    def test_estop_and_status_get_through_400_idle_and_slow_clients(
            self, daemon: SimDaemon) -> None:
        """With 400 hostile connections made (64 hold places, the rest are refused or sit
        in the e-stop lane), robotctl estop exits 0 and the robot is in estop, latched;
        robotctl status answers too."""
        hostile = open_hostile_clients(daemon.socket_path)
        try:
            code, out, err, estop_s = robotctl(daemon, "--json", "estop")
            status_code, status_out, status_err, status_s = robotctl(daemon, "--json",
                                                                     "status")
        finally:
            for sock in hostile:
                sock.close()
        print(f"\nunder {len(hostile)} hostile clients: robotctl estop {estop_s * 1000:.0f} ms "
              f"(process included), robotctl status {status_s * 1000:.0f} ms")
        assert code == 0, err
        assert json.loads(out)["state"] == "estop"
        assert status_code == 0, status_err
        status = json.loads(status_out)
        assert status["state"] == "estop"
        assert status["estop"] is True
        assert status["estop_latch"]["source"] == "robotctl"

    def test_estop_and_status_get_through_a_connect_storm(self, daemon: SimDaemon) -> None:
        """While 4 threads open waves of 25 connections at once (each sends status, all hang
        up), ~500 connects a second, 20 robotctl status (4 at a time) and one robotctl estop
        all exit 0; the robot ends in estop. (Harder storms: bench_control.py --hostile.)"""
        with ConnectStorm(daemon.socket_path, rate_per_s=500) as storm, \
                ThreadPoolExecutor(4) as pool:
            time.sleep(0.5)  # the storm is raging
            statuses = list(pool.map(lambda _: robotctl(daemon, "--json", "status"),
                                     range(20)))
            estop = robotctl(daemon, "--json", "estop")
        ok = [r for r in statuses if r[0] == 0]
        print(f"\nconnect storm: {storm.rate()}; robotctl status {len(ok)}/{len(statuses)} "
              f"ok, slowest {max(r[3] for r in statuses):.2f} s (process included); "
              f"robotctl estop {estop[3]:.2f} s")
        assert len(ok) == len(statuses), [r[2] for r in statuses if r[0] != 0]
        assert estop[0] == 0, estop[2]
        assert json.loads(estop[1])["state"] == "estop"
        assert daemon.call("status")["result"]["state"] == "estop"
