"""Who holds a control connection: refusals, idle and stalled clients, the e-stop lane (issue 28).

A ControlServer on the test's real event loop, with short timeouts, and the daemon's real
handlers left out: ``status``, ``estop`` and ``subscribe`` stand-ins that record their calls.
"""

from __future__ import annotations

import asyncio
import contextlib
import json
import shutil
import socket
import tempfile
from collections.abc import AsyncIterator
from pathlib import Path
from typing import Any

from daemon_harness import RpcClient

from robotd.control.admission import ClientPolicy
from robotd.control.server import Client, ControlServer

STATUS = b'{"jsonrpc":"2.0","id":1,"method":"status"}'
ESTOP = b'{"jsonrpc":"2.0","id":9,"method":"estop"}'
REPORT = b'{"jsonrpc":"2.0","id":2,"method":"report"}\n'
SLOW = ClientPolicy(idle_timeout_s=3600, stall_timeout_s=3600, evict_idle_s=3600)
"""Nobody times out and nobody gives way: only the limits act."""


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
async def serving(*, max_clients: int, policy: ClientPolicy
                  ) -> AsyncIterator[tuple[ControlServer, Robot]]:
    workdir = Path(tempfile.mkdtemp(prefix="rd-"))  # short: sun_path
    robot = Robot()
    server = ControlServer(str(workdir / "c.sock"), {"status": robot.status,
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
    async def test_past_the_limit_a_client_is_told_too_many_clients_and_closed_cleanly(
            self) -> None:
        """With no e-stop lane: one error line (id null, "too many clients", the reason for
        robotctl) then EOF; the request it sent meets no closed socket."""
        policy = ClientPolicy(estop_reserve=0, idle_timeout_s=3600, evict_idle_s=3600)
        async with serving(max_clients=2, policy=policy) as (server, _):
            held = await busy_clients(server, 2)
            late = await RpcClient.connect(server.path)
            await late.send_line(STATUS)  # no BrokenPipeError: the server reads and drops it
            said = await until_closed(late)
            counts = dict(server.counts)
            for client in [*held, late]:
                await client.close()
        assert len(said) == 1, said
        error = said[0]["error"]
        assert said[0]["id"] is None
        assert "too many clients" in error["message"]
        assert error["data"] == {"reason": "too_many_clients", "max_clients": 2}
        assert counts["refused"] == 1

    async def test_in_the_estop_lane_a_request_other_than_estop_is_refused_with_its_id(
            self) -> None:
        async with serving(max_clients=1, policy=SLOW) as (server, robot):
            held = await busy_clients(server, 1)
            late = await RpcClient.connect(server.path)
            await late.send_line(STATUS)
            said = await until_closed(late)
            for client in [*held, late]:
                await client.close()
        assert [m["id"] for m in said] == [1]
        assert "too many clients" in said[0]["error"]["message"]
        assert "only estop" in said[0]["error"]["message"]
        assert robot.estops == 0


class TestEstopLane:
    async def test_estop_gets_through_when_every_place_is_held_by_a_busy_client(self) -> None:
        """Nobody can give way (all busy); the e-stop is served past the limit all the same,
        and its connection is closed after the reply."""
        async with serving(max_clients=3, policy=SLOW) as (server, robot):
            held = await busy_clients(server, 3)
            tech = await RpcClient.connect(server.path)
            await tech.send_line(ESTOP)
            said = await until_closed(tech)
            counts = dict(server.counts)
            for client in [*held, tech]:
                await client.close()
        assert said == [{"jsonrpc": "2.0", "id": 9, "result": {"state": "estop"}}]
        assert robot.estops == 1
        assert counts["estop_lane"] == 1

    async def test_silent_connections_filling_the_lane_give_way_to_the_estop(self) -> None:
        """A lane full of connections that send nothing: the oldest silent one is refused to
        seat the newcomer, which sends estop and is served."""
        policy = ClientPolicy(estop_reserve=2, idle_timeout_s=3600, evict_idle_s=3600,
                              lane_timeout_s=30)
        async with serving(max_clients=1, policy=policy) as (server, robot):
            held = await busy_clients(server, 1)
            squatters = [await RpcClient.connect(server.path) for _ in range(2)]
            await asyncio.sleep(0.1)  # older than the lane's grace
            tech = await RpcClient.connect(server.path)
            await tech.send_line(ESTOP)
            said = await until_closed(tech)
            first_squatter = await until_closed(squatters[0])
            for client in [*held, *squatters, tech]:
                await client.close()
        assert said[0]["result"] == {"state": "estop"}
        assert robot.estops == 1
        assert "too many clients" in first_squatter[0]["error"]["message"]


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
