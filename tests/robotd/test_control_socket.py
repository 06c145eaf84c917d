"""The daemon under test, driven through its control socket (JSON-RPC 2.0, one per line)."""

from __future__ import annotations

import asyncio
import json
import os
import stat
from typing import Any, ClassVar

from daemon_harness import RpcClient, running_daemon

from behaviours.profile import BaseProfile, ProfileSpec
from hal.options import Option, Section
from robotd.profiles import PROFILES


class _CountedOption(Option):
    """An option that records each value it checks."""

    seen: ClassVar[list[Any]] = []

    def check(self, value: Any) -> tuple[Any, str | None]:
        _CountedOption.seen.append(value)
        return super().check(value)


class _Counted(BaseProfile):
    name = "counted"


_COUNTED = ProfileSpec(_Counted, "a robot whose one key counts its checks", sections=(
    Section("counted", "A key that counts its checks.", (
        _CountedOption("gain", "float", 0.5, "A gain.", min=0, max=2, tunable=True),)),))


def socket_of(daemon: object) -> str:
    path = getattr(daemon, "socket_path", None)
    assert isinstance(path, str)
    return path


class TestStatus:
    async def test_status_reports_robot_profile_state_estop_uptime_services(self) -> None:
        async with running_daemon(config={"robot": {"name": "r2"}}) as daemon:
            client = await RpcClient.connect(socket_of(daemon))
            reply = await client.call("status")
            await client.close()
        result = reply["result"]
        assert result["robot"] == "r2"
        assert result["profile"] == "idle"
        assert result["state"] == "idle"
        assert result["estop"] is False
        assert result["uptime_s"] >= 0
        assert {s["name"] for s in result["services"]} >= {"store", "machine", "control"}
        assert "p99_ms" in result["loop_lag_ms"]

    async def test_the_socket_is_mode_0660(self) -> None:
        async with running_daemon() as daemon:
            mode = stat.S_IMODE(os.stat(socket_of(daemon)).st_mode)
        assert mode == 0o660


class TestTune:
    async def test_a_valid_value_is_applied_at_once(self) -> None:
        async with running_daemon() as daemon:
            client = await RpcClient.connect(socket_of(daemon))
            reply = await client.call("tune.set", {"key": "line_follow.kp", "value": 0.6})
            got = await client.call("tune.get", {"key": "line_follow.kp"})
            await client.close()
            assert daemon.settings.get("line_follow.kp") == 0.6
        assert reply["result"] == {"key": "line_follow.kp", "value": 0.6, "persisted": False}
        assert got["result"]["value"] == 0.6

    async def test_invalid_values_are_refused_with_why_and_change_nothing(self) -> None:
        async with running_daemon() as daemon:
            client = await RpcClient.connect(socket_of(daemon))
            bounds = await client.call("tune.set", {"key": "line_follow.kp", "value": -1})
            kind = await client.call("tune.set", {"key": "line_follow.kp", "value": "fast"})
            unknown = await client.call("tune.set", {"key": "line_follow.kq", "value": 1})
            fixed = await client.call("tune.set", {"key": "serial.port", "value": "/dev/x"})
            await client.close()
            assert daemon.settings.get("line_follow.kp") == 0.5
        assert bounds["error"] == {"code": -32602,
                                   "message": "line_follow.kp: must be >= 0, got -1"}
        assert "expected a number" in kind["error"]["message"]
        assert unknown["error"]["message"] == "line_follow.kq: unknown key"
        assert "cannot be tuned live" in fixed["error"]["message"]

    async def test_a_value_is_checked_once_on_its_way(self) -> None:
        """tune.set reads the typed text, then Settings.check checks it once: the option's
        check runs once per call (it ran three times)."""
        with PROFILES.registered(_COUNTED):
            async with running_daemon() as daemon:
                client = await RpcClient.connect(socket_of(daemon))
                _CountedOption.seen.clear()
                typed = await client.call("tune.set", {"key": "counted.gain", "value": "0.3"})
                sent = await client.call("tune.set", {"key": "counted.gain", "value": 1,
                                                      "persist": True})
                await client.close()
        assert (typed["result"]["value"], sent["result"]["value"]) == (0.3, 1.0)
        assert _CountedOption.seen == [0.3, 1]

    async def test_persist_writes_the_overrides_file_in_the_state_dir(self) -> None:
        async with running_daemon() as daemon:
            client = await RpcClient.connect(socket_of(daemon))
            reply = await client.call("tune.set", {"key": "weight.max_kg", "value": "12.5",
                                                   "persist": True})
            await client.close()
            text = (daemon.state_dir / "overrides.toml").read_text()
        assert reply["result"]["persisted"] is True
        assert reply["result"]["persisted_to"] == str(daemon.state_dir / "overrides.toml")
        assert "note" not in reply["result"]
        assert "[weight]\nmax_kg = 12.5\n" in text

    async def test_persist_in_the_simulator_says_the_value_will_not_outlive_the_run(
            self) -> None:
        """The simulator's state directory is temporary: the reply says so (a technician
        would otherwise expect the value at the next run)."""
        async with running_daemon(config={"hal": {"backend": "sim"}}) as daemon:
            client = await RpcClient.connect(socket_of(daemon))
            reply = await client.call("tune.set", {"key": "weight.max_kg", "value": 12.5,
                                                   "persist": True})
            await client.close()
        assert "temporary" in reply["result"]["note"]


class TestSubscribe:
    async def test_a_subscriber_is_told_of_every_transition(self) -> None:
        async with running_daemon() as daemon:
            watcher = await RpcClient.connect(socket_of(daemon))
            sub = await watcher.call("subscribe", {"topics": ["state"]})
            actor = await RpcClient.connect(socket_of(daemon))
            await actor.call("estop", {"reason": "test"})
            note = await watcher.read()
            await watcher.close()
            await actor.close()
        assert sub["result"] == {"topics": ["state"]}
        assert note["jsonrpc"] == "2.0"
        assert note["method"] == "state"
        params = note["params"]
        assert (params["src"], params["dst"], params["trigger"]) == ("idle", "estop", "estop")
        assert isinstance(params["t"], float)

    async def test_unknown_topics_are_refused(self) -> None:
        async with running_daemon() as daemon:
            client = await RpcClient.connect(socket_of(daemon))
            reply = await client.call("subscribe", {"topics": ["weather"]})
            await client.close()
        assert reply["error"]["code"] == -32602


class TestBadInput:
    async def test_a_malformed_line_gets_an_error_and_the_connection_stays_usable(self) -> None:
        async with running_daemon() as daemon:
            client = await RpcClient.connect(socket_of(daemon))
            await client.send_line(b'{"jsonrpc": "2.0", "id": 1, "method": "sta')
            error = await client.read()
            reply = await client.call("status")
            await client.close()
        assert error["id"] is None
        assert error["error"]["code"] == -32700
        assert reply["result"]["state"] == "idle"

    async def test_each_kind_of_bad_request_gets_its_json_rpc_code(self) -> None:
        async with running_daemon() as daemon:
            client = await RpcClient.connect(socket_of(daemon))
            codes = []
            for line in [b'[1, 2]', b'{"id": 5, "method": "status"}',
                         b'{"jsonrpc": "2.0", "id": 6, "method": "fly"}',
                         b'{"jsonrpc": "2.0", "id": 7, "method": "events", "params": [1]}',
                         b'{"jsonrpc": "2.0", "id": 8, "method": "events",'
                         b' "params": {"limit": "x"}}',
                         b'\xff\xfe']:
                await client.send_line(line)
                reply = await client.read()
                codes.append((reply["id"], reply["error"]["code"]))
            await client.close()
        assert codes == [(None, -32600), (5, -32600), (6, -32601), (7, -32602), (8, -32602),
                         (None, -32700)]

    async def test_an_oversized_line_is_refused_and_the_next_request_answered(self) -> None:
        async with running_daemon() as daemon:
            client = await RpcClient.connect(socket_of(daemon))
            await client.send_line(b'{"x": "' + b"a" * 200_000 + b'"}')
            refused = await client.read()
            reply = await client.call("status")
            await client.close()
        assert refused["error"]["code"] == -32600
        assert "longer than" in refused["error"]["message"]
        assert reply["result"]["state"] == "idle"


class TestManyClients:
    async def test_fifty_clients_at_once_all_get_answers(self) -> None:
        async with running_daemon() as daemon:
            clients = await asyncio.gather(*(RpcClient.connect(socket_of(daemon))
                                             for _ in range(50)))
            replies = await asyncio.gather(*(c.call("status") for c in clients))
            clients_seen = replies[-1]["result"]["clients"]
            await asyncio.gather(*(c.close() for c in clients))
        assert all(r["result"]["state"] == "idle" for r in replies)
        assert clients_seen == 50

    async def test_a_client_that_never_reads_does_not_stop_the_others(self) -> None:
        """A stuck client that floods requests is read no further once its replies back up,
        and is cut off when they have not drained for ``stall_timeout_s``; the others keep
        their answers throughout."""
        config = {"control": {"client_queue": 8, "stall_timeout_s": 0.5}}
        async with running_daemon(config=config) as daemon:
            stuck = await RpcClient.connect(socket_of(daemon))
            await stuck.call("subscribe", {"topics": ["*"]})
            request = json.dumps({"jsonrpc": "2.0", "id": 1, "method": "status"}).encode()
            stuck.writer.write((request + b"\n") * 20_000)  # never read
            others = [await RpcClient.connect(socket_of(daemon)) for _ in range(5)]
            for _ in range(20):
                replies = await asyncio.gather(*(c.call("status") for c in others))
                assert all("result" in r for r in replies)
            # Cut off once ~256 kB of replies fill the socket and stay unread 0.5 s; on a
            # loaded CI machine the daemon may take seconds to answer that many, so the wait
            # is bounded only against a hang.
            for _ in range(600):
                if not any(c.id == 1 for c in daemon.control.clients.values()):
                    break
                await asyncio.sleep(0.05)
            remaining = sorted(daemon.control.clients)
            for c in others:
                await c.close()
            stuck.writer.transport.abort()
        assert 1 not in remaining  # the stuck client (the first to connect) was cut off

    async def test_a_subscriber_that_falls_behind_loses_notifications_with_a_notice(self) -> None:
        async with running_daemon(config={"control": {"client_queue": 4}}) as daemon:
            slow = await RpcClient.connect(socket_of(daemon))
            await slow.call("subscribe", {"topics": ["events"]})
            for i in range(5000):
                daemon.emit("test.burst", i=i)  # all at once: the writer cannot keep up
            seen = []
            while True:
                message = await slow.read()
                seen.append(message)
                if message["method"] == "dropped":
                    break
            reply = await slow.call("status")
            await slow.close()
        assert seen[-1]["params"]["count"] > 0
        assert reply["result"]["state"] == "idle"
