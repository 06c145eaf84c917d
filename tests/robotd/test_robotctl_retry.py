"""robotctl tries again, briefly, when the daemon cannot take its connection at once (issue 28).

Before: 13 of 20 ``robotctl status`` failed during a connect storm (``EAGAIN``, refused).
"""

from __future__ import annotations

import asyncio
import json
import shutil
import socket
import tempfile
import threading
from collections.abc import Iterator
from pathlib import Path

import pytest
from daemon_harness import RpcClient, running_daemon
from test_control_admission import busy_clients, serving
from test_robotctl import robotctl

from robotd.control.admission import ClientPolicy
from robotd.ctl.retry import FIRST_PAUSE_S, MAX_PAUSE_S, Backoff


@pytest.fixture
def sock_path() -> Iterator[str]:
    workdir = tempfile.mkdtemp(prefix="rd-")  # short: sun_path
    yield str(Path(workdir) / "c.sock")
    shutil.rmtree(workdir, ignore_errors=True)


class LateDaemon(threading.Thread):
    """A listening socket that accepts nobody for ``late_s``, then answers every request
    with ``{"state": "idle"}``; ``listen_at_once=False`` leaves it unlistened until then
    (connect: ECONNREFUSED) instead of listening with a full queue (connect: EAGAIN)."""

    def __init__(self, path: str, late_s: float, *, listen_at_once: bool) -> None:
        super().__init__(daemon=True)
        self.sock = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
        self.sock.bind(path)
        self.late_s = late_s
        self.listen_at_once = listen_at_once
        self.filler: socket.socket | None = None
        if listen_at_once:
            self.sock.listen(0)
            self.filler = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
            self.filler.connect(path)  # the one connection a backlog of 0 holds: now full
        self.stop = threading.Event()

    def run(self) -> None:
        if self.stop.wait(self.late_s):
            return
        if not self.listen_at_once:
            self.sock.listen(8)
        self.sock.settimeout(0.05)
        while not self.stop.is_set():
            try:
                conn, _ = self.sock.accept()
            except TimeoutError:
                continue
            except OSError:
                return
            with conn:
                conn.settimeout(0.5)
                try:
                    request = json.loads(conn.makefile("rb").readline())
                except (OSError, ValueError):
                    continue  # the filler: it sends nothing
                conn.sendall(json.dumps({"jsonrpc": "2.0", "id": request["id"],
                                         "result": {"state": "idle"}}).encode() + b"\n")

    def close(self) -> None:
        self.stop.set()
        self.sock.close()
        if self.filler is not None:
            self.filler.close()
        self.join(5)


class TestBackoff:
    def test_pauses_double_up_to_the_cap_and_stop_at_the_budget(self) -> None:
        now = [0.0]
        pauses: list[float] = []

        def pause(seconds: float) -> None:
            pauses.append(seconds)
            now[0] += seconds

        backoff = Backoff(1.0, pause=pause, clock=lambda: now[0])
        while backoff.again():
            pass
        assert pauses[:5] == [FIRST_PAUSE_S, 0.02, 0.04, 0.08, 0.16]
        assert max(pauses) == MAX_PAUSE_S
        assert sum(pauses) == pytest.approx(1.0)
        assert backoff.attempts == len(pauses) + 1


class TestConnectRetried:
    @pytest.mark.parametrize("listen_at_once", [False, True], ids=["ECONNREFUSED", "EAGAIN"])
    async def test_a_daemon_that_takes_the_connection_within_a_second_is_reached(
            self, sock_path: str, listen_at_once: bool,
            capsys: pytest.CaptureFixture[str]) -> None:
        """Its socket is there but refuses (not listening yet) or its queue of new connections
        is full for 0.3 s: robotctl status gets through, exit 0."""
        late = LateDaemon(sock_path, 0.3, listen_at_once=listen_at_once)
        late.start()
        try:
            code, out, err = await robotctl(capsys, "--socket", sock_path, "--json", "status")
        finally:
            late.close()
        assert (code, json.loads(out), err) == (0, {"state": "idle"}, "")

    async def test_one_that_does_not_within_the_budget_is_exit_3_saying_why(
            self, sock_path: str, capsys: pytest.CaptureFixture[str]) -> None:
        late = LateDaemon(sock_path, 30, listen_at_once=False)
        late.start()
        try:
            code, _, err = await robotctl(capsys, "--socket", sock_path, "status")
        finally:
            late.close()
        assert code == 3
        assert "nothing listens on" in err


class TestTooManyClients:
    async def test_status_gets_through_once_a_place_frees_up(
            self, capsys: pytest.CaptureFixture[str]) -> None:
        """The only place is held by a subscriber (it never gives way); robotctl status
        waits, and is answered once the subscriber leaves."""
        async with running_daemon(config={"control": {"max_clients": 1}}) as daemon:
            sock = str(daemon.socket_path)
            holder = await RpcClient.connect(sock)
            await holder.call("subscribe", {"topics": ["state"]})
            status = asyncio.create_task(robotctl(capsys, "--socket", sock, "--json",
                                                  "status"))
            await asyncio.sleep(0.3)
            assert not status.done()
            await holder.close()
            code, out, _ = await status
        assert code == 0
        assert json.loads(out)["state"] == "idle"

    async def test_a_daemon_full_for_longer_is_exit_3_saying_too_many_clients(
            self, capsys: pytest.CaptureFixture[str]) -> None:
        async with running_daemon(config={"control": {"max_clients": 1}}) as daemon:
            sock = str(daemon.socket_path)
            holder = await RpcClient.connect(sock)
            await holder.call("subscribe", {"topics": ["state"]})
            code, _, err = await robotctl(capsys, "--socket", sock, "status")
            await holder.close()
        assert code == 3
        assert "robotd refused the connection: too many clients (1 connected)" in err

    async def test_estop_gets_through_a_full_daemon_at_once(
            self, capsys: pytest.CaptureFixture[str]) -> None:
        """No retry needed: the e-stop lane serves it past the limit."""
        async with running_daemon(config={"control": {"max_clients": 1}}) as daemon:
            sock = str(daemon.socket_path)
            holder = await RpcClient.connect(sock)
            await holder.call("subscribe", {"topics": ["state"]})
            code, out, _ = await robotctl(capsys, "--socket", sock, "--json", "estop")
            state = daemon.state
            await holder.close()
        assert code == 0
        assert json.loads(out)["state"] == "estop" == state


class TestEstopSocketFallback:
    async def test_estop_goes_through_the_estop_socket_when_the_control_socket_refuses(
            self, capsys: pytest.CaptureFixture[str]) -> None:
        """The control socket tells every newcomer "too many clients" at once (no waiting
        room, no lingering): robotctl estop is served through PATH.estop, exit 0."""
        policy = ClientPolicy(wait_max=0, lingering_max=0, idle_timeout_s=3600,
                              evict_idle_s=3600)
        async with serving(max_clients=1, policy=policy) as (server, robot):
            held = await busy_clients(server, 1)
            code, out, err = await robotctl(capsys, "--socket", server.path, "--json", "estop")
            served = server.estop_socket.served if server.estop_socket else 0
            for client in held:
                await client.close()
        # robotctl printed no refusal of its own (a logging handler an earlier test bound to a
        # stream pytest has since closed may print its own complaint to stderr: not robotctl's).
        assert code == 0
        assert not [line for line in err.splitlines() if line.startswith("robotctl")], err
        assert json.loads(out) == {"state": "estop"}
        assert (robot.estops, served) == (1, 1)

    async def test_without_an_estop_socket_the_control_sockets_refusal_is_shown(
            self, capsys: pytest.CaptureFixture[str]) -> None:
        policy = ClientPolicy(wait_max=0, lingering_max=0, idle_timeout_s=3600,
                              evict_idle_s=3600)
        async with serving(max_clients=1, policy=policy) as (server, robot):
            held = await busy_clients(server, 1)
            assert server.estop_socket is not None
            server.estop_socket.close()  # as an older daemon: no e-stop socket
            code, _, err = await robotctl(capsys, "--socket", server.path, "estop")
            for client in held:
                await client.close()
        assert code == 3
        assert "too many clients" in err
        assert robot.estops == 0
