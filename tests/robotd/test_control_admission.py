"""Who holds a control connection: refusals, idle and stalled clients, the waiting room, the
e-stop past the limit and the e-stop socket (issue 28).

A ControlServer on the test's real event loop, with short timeouts, and the daemon's real
handlers left out: ``status``, ``estop`` and ``subscribe`` stand-ins that record their calls.
"""

from __future__ import annotations

import asyncio
import contextlib
import json
import os
import shutil
import socket
import stat
import tempfile
import threading
from collections.abc import AsyncIterator
from pathlib import Path
from typing import Any

import pytest
from daemon_harness import RpcClient

from robotd.control.admission import ClientPolicy
from robotd.control.server import Client, ControlServer

STATUS = b'{"jsonrpc":"2.0","id":1,"method":"status"}'
ESTOP = b'{"jsonrpc":"2.0","id":9,"method":"estop"}'
REPORT = b'{"jsonrpc":"2.0","id":2,"method":"report"}\n'
SLOW = ClientPolicy(idle_timeout_s=3600, stall_timeout_s=3600, evict_idle_s=3600)
"""Nobody times out and nobody gives way: only the limits act."""
NO_ROOM = ClientPolicy(wait_max=0, idle_timeout_s=3600, evict_idle_s=3600)
"""No waiting room: past the limit a connection is refused (or served an estop)."""


class Robot:
    """The handlers' side: what the clients asked for."""

    def __init__(self) -> None:
        self.estops = 0

    async def status(self, _params: dict[str, Any], _client: Client) -> dict[str, Any]:
        return {"state": "estop" if self.estops else "idle"}

    async def estop(self, _params: dict[str, Any], _client: Client) -> dict[str, Any]:
        self.estops += 1
        return {"state": "estop"}

    async def report(self, _params: dict[str, Any], _client: Client) -> dict[str, Any]:
        """A reply of 4 KB: a few hundred fill a socket's buffers."""
        return {"log": "x" * 4096}

    async def subscribe(self, params: dict[str, Any], client: Client) -> dict[str, Any]:
        client.topics.update(params["topics"])
        return {"topics": sorted(client.topics)}


@contextlib.asynccontextmanager
async def serving(*, max_clients: int, policy: ClientPolicy, path_bytes: int | None = None
                  ) -> AsyncIterator[tuple[ControlServer, Robot]]:
    """A ControlServer on a socket in a fresh directory (its path ``path_bytes`` long when
    given) and the stand-in handlers behind it."""
    workdir = Path(tempfile.mkdtemp(prefix="rd-"))  # short: sun_path
    sock = workdir / "c.sock"
    if path_bytes is not None:
        sock = workdir / ("d" * (path_bytes - len(str(sock)) - 1)) / "c.sock"
        sock.parent.mkdir()
    robot = Robot()
    server = ControlServer(str(sock), {"status": robot.status,
                                                     "estop": robot.estop,
                                                     "report": robot.report,
                                                     "subscribe": robot.subscribe},
                           max_clients=max_clients, policy=policy)
    ready = asyncio.Event()
    task = asyncio.create_task(server.run(ready.set))
    await asyncio.wait_for(ready.wait(), 10)
    try:
        yield server, robot
    finally:
        task.cancel()
        with contextlib.suppress(asyncio.CancelledError):
            await task
        shutil.rmtree(workdir, ignore_errors=True)


async def busy_clients(server: ControlServer, count: int) -> list[RpcClient]:
    """``count`` connections that each had a request answered (so they hold a place)."""
    clients = [await RpcClient.connect(server.path) for _ in range(count)]
    for client in clients:
        assert "result" in await client.call("status")
    return clients


async def until_closed(client: RpcClient) -> list[dict[str, Any]]:
    """Every line the server sends until it closes the connection (EOF, not a reset)."""
    lines = []
    while line := await asyncio.wait_for(client.reader.readline(), 10):
        lines.append(json.loads(line))
    return lines


class TestRefusal:
    async def test_past_the_limit_a_request_is_refused_with_its_id_and_closed_cleanly(
            self) -> None:
        """No room past the limit: its request gets one error line ("too many clients", its
        id, the reason robotctl retries on), then EOF; it meets no closed socket."""
        async with serving(max_clients=2, policy=NO_ROOM) as (server, robot):
            held = await busy_clients(server, 2)
            late = await RpcClient.connect(server.path)
            await late.send_line(STATUS)  # no BrokenPipeError: the server reads it
            said = await until_closed(late)
            counts = dict(server.counts)
            for client in [*held, late]:
                await client.close()
        assert len(said) == 1, said
        assert said[0]["id"] == 1
        error = said[0]["error"]
        assert "too many clients" in error["message"]
        assert error["data"] == {"reason": "too_many_clients", "max_clients": 2}
        assert counts["refused"] == 1
        assert robot.estops == 0

    async def test_one_that_says_nothing_is_refused_after_the_linger(self) -> None:
        policy = ClientPolicy(wait_max=0, refusal_linger_s=0.2, idle_timeout_s=3600,
                              evict_idle_s=3600)
        async with serving(max_clients=1, policy=policy) as (server, _):
            held = await busy_clients(server, 1)
            silent = await RpcClient.connect(server.path)
            said = await until_closed(silent)
            for client in [*held, silent]:
                await client.close()
        assert said[0]["id"] is None
        assert said[0]["error"]["data"]["reason"] == "too_many_clients"

    async def test_past_lingering_max_a_newcomer_is_told_at_once(self) -> None:
        policy = ClientPolicy(wait_max=0, lingering_max=0, idle_timeout_s=3600,
                              evict_idle_s=3600)
        async with serving(max_clients=1, policy=policy) as (server, _):
            held = await busy_clients(server, 1)
            late = await RpcClient.connect(server.path)
            said = await until_closed(late)
            for client in [*held, late]:
                await client.close()
        assert said[0]["id"] is None
        assert "too many clients" in said[0]["error"]["message"]


class TestWaitingRoom:
    async def test_a_newcomer_gets_the_next_place_that_frees_up(self) -> None:
        """Every place held: its request waits, and is answered once a holder leaves."""
        async with serving(max_clients=1, policy=SLOW) as (server, _):
            (holder,) = await busy_clients(server, 1)
            late = await RpcClient.connect(server.path)
            answer = asyncio.create_task(late.call("status"))
            await asyncio.sleep(0.2)
            answered_early = answer.done()
            await holder.close()
            reply = await answer
            again = await late.call("status")  # a client like any other now
            counts = dict(server.counts)
            await late.close()
        assert not answered_early
        assert reply["result"] == again["result"] == {"state": "idle"}
        assert (counts["waited"], counts["refused"]) == (1, 0)

    async def test_twenty_newcomers_share_two_places_first_come_first_served(self) -> None:
        """Each asks once and leaves; the places go round, in the order they came, and none
        is lost on the way (every waiter answered, no place left promised)."""
        policy = ClientPolicy(wait_s=10, idle_timeout_s=3600, evict_idle_s=3600)
        async with serving(max_clients=2, policy=policy) as (server, _):
            holders = await busy_clients(server, 2)
            answered: list[int] = []

            async def ask_once(n: int) -> None:
                client = await RpcClient.connect(server.path)
                await client.call("status")
                answered.append(n)
                await client.close()

            askers = []
            for n in range(20):
                askers.append(asyncio.create_task(ask_once(n)))
                await asyncio.sleep(0.01)  # they come in this order
            for holder in holders:
                await holder.close()
            await asyncio.wait_for(asyncio.gather(*askers), 10)
            await asyncio.sleep(0.05)
            figures = server.figures()
        assert sorted(answered) == list(range(20))
        assert answered[:2] in ([0, 1], [1, 0])
        assert {k: figures[k] for k in ("waiting", "queued", "promised", "lingering")} == {
            "waiting": 0, "queued": 0, "promised": 0, "lingering": 0}
        assert (figures["waited"], figures["refused"]) == (20, 0)

    async def test_one_that_waits_longer_than_wait_s_is_refused_with_its_id(self) -> None:
        policy = ClientPolicy(wait_s=0.2, idle_timeout_s=3600, evict_idle_s=3600)
        async with serving(max_clients=1, policy=policy) as (server, _):
            held = await busy_clients(server, 1)
            late = await RpcClient.connect(server.path)
            await late.send_line(STATUS)
            said = await until_closed(late)
            for client in [*held, late]:
                await client.close()
        assert [m["id"] for m in said] == [1]
        assert said[0]["error"]["data"]["reason"] == "too_many_clients"

    async def test_an_estop_in_the_waiting_room_is_served_at_once(self) -> None:
        async with serving(max_clients=1, policy=SLOW) as (server, robot):
            held = await busy_clients(server, 1)
            tech = await RpcClient.connect(server.path)
            await tech.send_line(ESTOP)
            said = await until_closed(tech)
            for client in [*held, tech]:
                await client.close()
        assert said == [{"jsonrpc": "2.0", "id": 9, "result": {"state": "estop"}}]
        assert robot.estops == 1


class TestEstopPastTheLimit:
    async def test_estop_is_served_when_every_place_is_held_by_a_busy_client(self) -> None:
        """Nobody can give way (all busy), no waiting room: the e-stop is served all the
        same, and its connection is closed after the reply."""
        async with serving(max_clients=3, policy=NO_ROOM) as (server, robot):
            held = await busy_clients(server, 3)
            tech = await RpcClient.connect(server.path)
            await tech.send_line(ESTOP)
            said = await until_closed(tech)
            counts = dict(server.counts)
            for client in [*held, tech]:
                await client.close()
        assert said == [{"jsonrpc": "2.0", "id": 9, "result": {"state": "estop"}}]
        assert robot.estops == 1
        assert (counts["estop_past_limit"], counts["refused"]) == (1, 0)


class TestEstopSocket:
    async def test_it_serves_estop_when_the_control_socket_cannot_even_listen(self) -> None:
        """Places, waiting room and refusals all taken by silent connections: the control
        socket tells a newcomer "too many clients" at once; PATH.estop serves the estop."""
        policy = ClientPolicy(wait_max=1, lingering_max=1, refusal_linger_s=30, wait_s=30,
                              idle_timeout_s=3600, evict_idle_s=3600)
        async with serving(max_clients=1, policy=policy) as (server, robot):
            squatters = [await RpcClient.connect(server.path) for _ in range(3)]
            await asyncio.sleep(0.05)
            main = await RpcClient.connect(server.path)
            refused = await until_closed(main)
            assert server.estop_socket is not None
            tech = await RpcClient.connect(server.estop_socket.path)
            await tech.send_line(ESTOP)
            said = await until_closed(tech)
            mode = os.stat(server.estop_socket.path).st_mode & 0o777
            for client in [*squatters, main, tech]:
                await client.close()
        assert "too many clients" in refused[0]["error"]["message"]
        assert said == [{"jsonrpc": "2.0", "id": 9, "result": {"state": "estop"}}]
        assert robot.estops == 1
        assert mode == 0o660

    async def test_it_serves_nothing_but_estop(self) -> None:
        async with serving(max_clients=8, policy=SLOW) as (server, robot):
            assert server.estop_socket is not None
            client = await RpcClient.connect(server.estop_socket.path)
            await client.send_line(STATUS)
            said = await until_closed(client)
            await client.close()
        assert said[0]["id"] == 1
        assert said[0]["error"]["code"] == -32601
        assert "serves only estop" in said[0]["error"]["message"]
        assert robot.estops == 0

    async def test_a_control_path_too_long_for_it_leaves_the_control_socket_working(
            self) -> None:
        """PATH.estop past 107 bytes: no e-stop socket (logged), the control socket serves."""
        async with serving(max_clients=8, policy=SLOW, path_bytes=104) as (server, robot):
            assert len(server.path) == 104
            assert server.estop_socket is not None
            client = await RpcClient.connect(server.path)
            reply = await client.call("estop")
            await client.close()
            with pytest.raises(FileNotFoundError):
                os.stat(server.estop_socket.path)
        assert reply["result"] == {"state": "estop"}
        assert robot.estops == 1

    async def test_it_is_removed_when_the_daemon_stops(self) -> None:
        async with serving(max_clients=8, policy=SLOW) as (server, _):
            assert server.estop_socket is not None
            path = server.estop_socket.path
            assert stat.S_ISSOCK(os.stat(path).st_mode)
        with pytest.raises(FileNotFoundError):
            os.stat(path)


class TestIdleAndStalled:
    async def test_an_idle_client_is_closed_after_the_idle_timeout_saying_why(self) -> None:
        policy = ClientPolicy(idle_timeout_s=0.3, evict_idle_s=3600)
        async with serving(max_clients=8, policy=policy) as (server, _):
            loop = asyncio.get_running_loop()
            idle = await RpcClient.connect(server.path)
            started_s = loop.time()
            said = await until_closed(idle)
            closed_after_s = loop.time() - started_s
            counts = dict(server.counts)
            await idle.close()
        assert 0.3 <= closed_after_s < 1.5
        assert said[0]["id"] is None
        assert said[0]["error"]["data"] == {"reason": "idle"}
        assert "no request for" in said[0]["error"]["message"]
        assert counts["idle"] == 1

    async def test_a_client_sending_requests_is_not_idle(self) -> None:
        policy = ClientPolicy(idle_timeout_s=0.3, evict_idle_s=3600)
        async with serving(max_clients=8, policy=policy) as (server, _):
            client = await RpcClient.connect(server.path)
            for _ in range(8):
                await asyncio.sleep(0.1)
                assert "result" in await client.call("status")
            await client.close()

    async def test_a_subscriber_that_reads_is_not_idle(self) -> None:
        """Subscribed, it sends nothing for four idle timeouts and is still told of events."""
        policy = ClientPolicy(idle_timeout_s=0.2, evict_idle_s=3600)
        async with serving(max_clients=8, policy=policy) as (server, _):
            watcher = await RpcClient.connect(server.path)
            await watcher.call("subscribe", {"topics": ["state"]})
            await asyncio.sleep(0.8)
            server.publish("state", {"dst": "estop"})
            told = await watcher.read()
            await watcher.close()
        assert told["params"] == {"dst": "estop"}

    async def test_a_client_that_stopped_reading_is_closed_after_the_stall_timeout(
            self) -> None:
        """It floods requests and reads none of the replies: once they have waited for it
        longer than the stall timeout it is cut off; another client is answered throughout."""
        policy = ClientPolicy(idle_timeout_s=3600, stall_timeout_s=0.3, evict_idle_s=3600)
        async with serving(max_clients=8, policy=policy) as (server, _):
            loop = asyncio.get_running_loop()
            slow = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)  # the loop never reads it
            slow.setblocking(False)
            await loop.sock_connect(slow, server.path)
            await loop.sock_sendall(slow, REPORT * 250)  # 1 MB of replies it never reads
            other = await RpcClient.connect(server.path)
            for _ in range(40):
                assert "result" in await other.call("status")
                if server.counts["stalled"]:
                    break
                await asyncio.sleep(0.05)
            counts = dict(server.counts)
            clients = len(server.clients)
            slow.close()
            await other.close()
        assert counts["stalled"] == 1
        assert clients == 1

    async def test_when_full_the_longest_idle_client_gives_way_to_a_newcomer(self) -> None:
        policy = ClientPolicy(idle_timeout_s=3600, evict_idle_s=0.1)
        async with serving(max_clients=2, policy=policy) as (server, _):
            oldest, newer = await busy_clients(server, 2)
            await asyncio.sleep(0.05)
            assert "result" in await newer.call("status")  # newer is the more recently busy
            await asyncio.sleep(0.1)
            late = await RpcClient.connect(server.path)
            answer = await late.call("status")
            told = await until_closed(oldest)
            still = await newer.call("status")
            for client in (oldest, newer, late):
                await client.close()
        assert answer["result"] == {"state": "idle"}
        assert told[0]["error"]["data"] == {"reason": "idle"}
        assert "socket is full" in told[0]["error"]["message"]
        assert "result" in still


HELD = ("clients", "waiting", "queued", "promised", "lingering")


class TestStorm:
    async def test_after_a_connect_storm_nothing_is_left_held(self) -> None:
        """Four threads connect, ask and hang up as fast as they can for a second: an estop
        sent in the middle of it is served; afterwards no place, seat, promise or lingering
        refusal is left, and a newcomer is answered at once."""
        policy = ClientPolicy(idle_timeout_s=3600, evict_idle_s=3600)
        async with serving(max_clients=8, policy=policy) as (server, robot):
            stop = threading.Event()

            def storm() -> None:
                while not stop.is_set():
                    with socket.socket(socket.AF_UNIX, socket.SOCK_STREAM) as conn:
                        conn.settimeout(1)
                        with contextlib.suppress(OSError):
                            conn.connect(server.path)
                            conn.sendall(STATUS + b"\n")

            threads = [threading.Thread(target=storm, daemon=True) for _ in range(4)]
            for thread in threads:
                thread.start()
            await asyncio.sleep(0.5)
            assert server.estop_socket is not None
            tech = await RpcClient.connect(server.estop_socket.path)
            await tech.send_line(ESTOP)
            said = await until_closed(tech)
            await tech.close()
            stop.set()
            await asyncio.to_thread(lambda: [t.join(5) for t in threads])
            for _ in range(50):  # lingering refusals and waits run out within 1.5 s
                figures = server.figures()
                if not any(figures[k] for k in HELD):
                    break
                await asyncio.sleep(0.1)
            late = await RpcClient.connect(server.path)
            answer = await late.call("status")
            await late.close()
        assert said[0]["result"] == {"state": "estop"}
        assert robot.estops == 1
        assert {k: figures[k] for k in HELD} == dict.fromkeys(HELD, 0), figures
        assert answer["result"] == {"state": "estop"}
