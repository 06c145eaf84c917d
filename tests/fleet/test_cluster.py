"""Several server processes (issue 29): three ``robotd-fleet serve`` on one PostgreSQL behind
Debian's HAProxy (``tests/support/fleet_cluster.py``). Robots report, customers ask for pickups
and the staff move them on, all through the load balancer, while the process that runs the
sweeps is SIGKILLed: no request answered 2xx is lost and each reaches its end, an event
stream that resumes with ``Last-Event-ID`` gets every notification once and in order, and
another process takes the sweeps over (a robot that falls silent with laundry still raises
its alert). And a notification created through one process reaches a stream on another at
once by LISTEN/NOTIFY, with the poll set far longer."""

from __future__ import annotations

import asyncio
import contextlib
import itertools
import json
from collections.abc import AsyncIterator
from pathlib import Path
from typing import Any

import asyncpg
import httpx
import pytest
from fleet_cluster import FleetCluster, HaproxyUnavailable, haproxy_binary
from pgtest import PgCluster

from fleet.pg_listen import LEADER_LOCK_KEY

pytestmark = pytest.mark.postgres

ADMIN = "cluster-admin-token-0123456789abcdef"
BASE_MAC = "C3:00:00:00:FF:FF"
ROBOTS = 5
CUSTOMERS = 12
REPORT_S = 0.3
SETTINGS = {"AutoAccept": True, "RequireWeightCheck": False, "OfflineAfterS": 5,
            "OfflineCheckPeriodS": 1, "TimeoutCheckPeriodS": 1}
_databases = itertools.count()
SERVER_ERRORS: list[str] = []
"""5xx answers other than HAProxy's 502/503 while a server dies: a server's own failure."""


def _note(answer: httpx.Response) -> httpx.Response:
    if answer.status_code >= 500 and answer.status_code not in (502, 503):
        SERVER_ERRORS.append(f"{answer.request.method} {answer.request.url.path}: "
                             f"{answer.status_code} {answer.text[:200]}")
    return answer


def robot_token(i: int) -> str:
    return f"cluster-robot-{i}-token-0123456789abcdef"


def room_mac(c: int) -> str:
    return f"C3:00:00:00:01:{c:02X}"


def site_toml() -> str:
    settings = "\n".join(f"{k} = {json.dumps(v)}" for k, v in SETTINGS.items())
    parts = [f"[settings]\n{settings}\n", '[[rooms]]\nname = "Laundry"\n',
             f'[[beacons]]\nmac = "{BASE_MAC}"\nname = "base"\nroom = "Laundry"\nbase = true\n',
             f'[[tokens]]\nrole = "admin"\nsubject = "staff"\ntoken = "{ADMIN}"\n']
    for c in range(1, CUSTOMERS + 1):
        parts.append(f'[[rooms]]\nname = "Room {c}"\n')
        parts.append(f'[[beacons]]\nmac = "{room_mac(c)}"\nname = "room-{c}"\n'
                     f'room = "Room {c}"\n')
        parts.append(f'[[customers]]\nid = {c}\nname = "c{c}"\nbeacon = "{room_mac(c)}"\n')
    for i in range(ROBOTS):
        parts.append(f'[[robots]]\nname = "robot-{i}"\n')
        parts.append(f'[[tokens]]\nrole = "robot"\nsubject = "robot-{i}"\n'
                     f'token = "{robot_token(i)}"\n')
    return "\n".join(parts)


@pytest.fixture
async def pg_url(pg_cluster: PgCluster | str) -> str:
    if isinstance(pg_cluster, str):
        pytest.skip(f"no PostgreSQL server: {pg_cluster}")
    try:
        haproxy_binary()
    except HaproxyUnavailable as exc:
        pytest.skip(str(exc))
    return await pg_cluster.create_database(f"cluster_{next(_databases)}")


def _plain(url: str) -> str:
    return url.replace("postgresql+asyncpg://", "postgresql://")


@contextlib.asynccontextmanager
async def cluster(pg_url: str, tmp_path: Path, servers: int,
                  *args: str) -> AsyncIterator[FleetCluster]:
    site = tmp_path / "site.toml"
    site.write_text(site_toml())
    async with FleetCluster(pg_url, site, servers=servers, args=("--log-level", "info", *args),
                            workdir=tmp_path) as running:
        yield running


class SimRobot:
    """A robot that follows its targets: the second report with the same targets says it is
    there (hearing them); with none it waits at base hearing the base beacon. ``hold``: in
    that request status it never arrives (stuck on its way)."""

    def __init__(self, http: httpx.AsyncClient, index: int, hold: str | None = None) -> None:
        self.http = http
        self.name = f"robot-{index}"
        self.token = robot_token(index)
        self.hold = hold
        self.targets: list[str] = []
        self.seen = 0
        self.status: str | None = None
        self.answers = 0

    async def run(self) -> None:
        while True:
            await self.report()
            await asyncio.sleep(REPORT_S)

    async def report(self) -> None:
        arrived = bool(self.targets) and self.seen >= 1 and self.status != self.hold
        heard = self.targets if arrived else [] if self.targets else [BASE_MAC]
        body = {"RobotName": self.name, "Timestamp": "2026-01-05T08:00:00Z",
                "DetectedBeacons": [{"MacAddress": m, "Rssi": -40, "Distance": 0.5}
                                    for m in heard],
                "IsInTarget": arrived, "WeightKg": 0.0, "UltrasonicDistance": 100.0}
        try:
            answer = _note(await self.http.post(
                f"/api/Robot/{self.name}/data-exchange", json=body,
                headers={"Authorization": f"Bearer {self.token}"}))
        except httpx.HTTPError:
            return  # the robot tries again next period, as the real one does
        if answer.status_code != 200:
            return
        self.answers += 1
        reply = answer.json()
        targets = sorted(b["MacAddress"] for b in reply["ActiveBeacons"]
                         if b["IsNavigationTarget"])
        self.seen = self.seen + 1 if targets == self.targets else 0
        self.targets = targets
        self.status = reply.get("RequestStatus")


class Stream:
    """An admin's event stream through the load balancer that reconnects at once with
    ``Last-Event-ID`` whenever it drops; ``move_to`` makes it reconnect until HAProxy puts it
    on that server."""

    def __init__(self, url: str) -> None:
        self.url = url
        self.ids: list[int] = []
        self.server: str | None = None
        self.connections = 0
        self.want: str | None = None
        self.on_server = asyncio.Event()
        self._current: asyncio.Task[None] | None = None

    async def run(self) -> None:
        async with httpx.AsyncClient(base_url=self.url, timeout=httpx.Timeout(5, read=30)) as c:
            while True:
                self._current = asyncio.create_task(self._listen(c))
                try:
                    await asyncio.wait([self._current])
                finally:
                    self._current.cancel()
                if not self._current.cancelled():
                    self._current.exception()  # a dropped stream: reconnect
                await asyncio.sleep(0.05)

    async def _listen(self, client: httpx.AsyncClient) -> None:
        last = self.ids[-1] if self.ids else 0
        headers = {"Authorization": f"Bearer {ADMIN}", "Last-Event-ID": str(last)}
        async with client.stream("GET", "/api/events", headers=headers) as response:
            if response.status_code != 200:
                return
            self.connections += 1
            self.server = response.headers.get("x-fleet-server")
            if self.want is not None and self.server != self.want:
                return
            self.on_server.set()
            event_id: int | None = None
            async for line in response.aiter_lines():
                if line.startswith("id: "):
                    event_id = int(line[4:])
                elif line == "" and event_id is not None:
                    self.ids.append(event_id)
                    event_id = None

    async def move_to(self, server: str) -> None:
        """Reconnect until the stream runs through ``server``."""
        if self.server == server:
            return
        self.want = server
        self.on_server.clear()
        if self._current is not None:
            self._current.cancel()
        await self.on_server.wait()
        self.want = None


async def staff(http: httpx.AsyncClient) -> None:
    """The laundry room: confirms loads and unloads for the customers, marks washing done."""
    actions = {"ArrivedAtRoom": "confirm-loaded", "Washing": "washing-done",
               "FinishedWashingArrivedAtRoom": "confirm-unloaded"}
    auth = {"Authorization": f"Bearer {ADMIN}"}
    while True:
        with contextlib.suppress(httpx.HTTPError, ValueError):
            answer = _note(await http.get("/api/requests?limit=100", headers=auth))
            if answer.status_code == 200:
                for request in answer.json():
                    action = actions.get(request["Status"])
                    if action and not (action == "washing-done" and request["DeliveryQueued"]):
                        _note(await http.post(f"/api/requests/{request['Id']}/{action}",
                                              headers=auth))
        await asyncio.sleep(0.2)


async def ask_pickup(http: httpx.AsyncClient, customer: int, created: dict[int, int]) -> None:
    """POST /api/requests until it answers 201 (kept) or 409 (an earlier try made it)."""
    auth = {"Authorization": f"Bearer {ADMIN}"}
    while True:
        with contextlib.suppress(httpx.HTTPError):
            answer = _note(await http.post("/api/requests", json={"CustomerId": customer},
                                           headers=auth))
            if answer.status_code == 201:
                created[customer] = answer.json()["Id"]
                return
            if answer.status_code == 409:
                return
        await asyncio.sleep(0.2)


async def leader_pid(conn: Any) -> int | None:
    """The process id of the server holding the sweeps' lock (its listener connection's
    application_name is ``robotd-fleet PID``)."""
    name = await conn.fetchval(
        "SELECT a.application_name FROM pg_locks l JOIN pg_stat_activity a ON a.pid = l.pid "
        "WHERE l.locktype = 'advisory' AND l.granted AND l.classid = $1 AND l.objid = $2",
        LEADER_LOCK_KEY >> 32, LEADER_LOCK_KEY & 0xFFFF_FFFF)
    return int(name.split()[1]) if name else None


async def until(check: Any, timeout_s: float, what: str) -> Any:
    loop = asyncio.get_running_loop()
    deadline = loop.time() + timeout_s
    while loop.time() < deadline:
        value = await check()
        if value:
            return value
        await asyncio.sleep(0.2)
    msg = f"not within {timeout_s:.0f} s: {what}"
    raise AssertionError(msg)


class TestKilledProcess:
    async def test_nothing_is_lost_when_the_sweeping_process_is_killed(
            self, pg_url: str, tmp_path: Path) -> None:
        """A server process SIGKILLed mid-run behind HAProxy: every request answered 201 is in
        the database and reaches its end, the event stream that reconnects with
        Last-Event-ID has every notification once and in order, and a robot that falls
        silent with laundry after the kill still raises its alert (another process took the
        sweeps over)."""
        async with cluster(pg_url, tmp_path, 3) as fleet, \
                httpx.AsyncClient(base_url=fleet.url, timeout=10) as http:
            db = await asyncpg.connect(_plain(pg_url))
            tasks: list[asyncio.Task[None]] = []
            SERVER_ERRORS.clear()
            try:
                stream = Stream(fleet.url)
                tasks.append(asyncio.create_task(stream.run()))
                tasks.append(asyncio.create_task(staff(http)))
                # robot-0 takes customer 1's laundry and then never gets to base.
                stuck = SimRobot(http, 0, hold="LaundryLoaded")
                stuck_task = asyncio.create_task(stuck.run())
                tasks.append(stuck_task)
                created: dict[int, int] = {}
                await until(lambda: _true(stuck.answers > 2), 30, "robot-0 reports")
                await ask_pickup(http, 1, created)
                await until(lambda: _true(stuck.status == "LaundryLoaded"), 60,
                            "robot-0 loaded")
                robots = [SimRobot(http, i) for i in range(1, ROBOTS)]
                tasks += [asyncio.create_task(r.run()) for r in robots]
                for customer in range(2, CUSTOMERS // 2 + 1):
                    await ask_pickup(http, customer, created)
                    await asyncio.sleep(0.3)

                pid = await until(lambda: leader_pid(db), 30, "a process leads the sweeps")
                victim = fleet.by_pid(pid)
                await asyncio.wait_for(stream.move_to(fleet.procs[victim].name), 30)
                before = stream.connections
                await fleet.kill(victim)
                stuck_task.cancel()  # robot-0 falls silent holding the laundry

                for customer in range(CUSTOMERS // 2 + 1, CUSTOMERS + 1):
                    await ask_pickup(http, customer, created)
                    await asyncio.sleep(0.3)
                new = await until(lambda: _other_leader(db, pid), 30, "another process leads")
                assert new != pid
                stuck_request = created[1]
                alert = await until(lambda: _open_alert(http, stuck_request), 60,
                                    "robot-0's offline alert")
                assert alert["Kind"] == "robot.offline.laundry"
                assert alert["RobotName"] == "robot-0"
                answer = await http.post(f"/api/alerts/{alert['Id']}/resolve",
                                         json={"LaundryAt": "customer"},
                                         headers={"Authorization": f"Bearer {ADMIN}"})
                assert answer.status_code == 200, answer.text

                ends = await until(lambda: _all_ended(db, len(created)), 180,
                                   "every request at its end")
                assert stream.connections > before  # it was cut by the kill and came back
                newest = await db.fetchval("SELECT max(id) FROM notifications")
                await until(lambda: _true(stream.ids and stream.ids[-1] >= newest), 30,
                            "the stream has every notification")
                stored = [r["id"] for r in await db.fetch(
                    "SELECT id FROM notifications ORDER BY id")]
            finally:
                for task in tasks:
                    task.cancel()
                await asyncio.gather(*tasks, return_exceptions=True)
                await db.close()
        assert set(created) == set(range(1, CUSTOMERS + 1))
        for customer, request_id in created.items():
            expected = "Cancelled" if customer == 1 else "Completed"
            assert ends[request_id] == expected, (customer, request_id, ends[request_id])
        assert stream.ids == stored
        assert SERVER_ERRORS == []


async def _true(value: object) -> bool:
    return bool(value)


async def _other_leader(db: Any, old: int) -> int | None:
    pid = await leader_pid(db)
    return pid if pid is not None and pid != old else None


async def _open_alert(http: httpx.AsyncClient, request_id: int) -> dict[str, Any] | None:
    with contextlib.suppress(httpx.HTTPError):
        answer = await http.get(f"/api/alerts?open=true&request_id={request_id}",
                                headers={"Authorization": f"Bearer {ADMIN}"})
        if answer.status_code == 200 and answer.json():
            found: dict[str, Any] = answer.json()[0]
            return found
    return None


async def _all_ended(db: Any, count: int) -> dict[int, str] | None:
    rows = await db.fetch("SELECT id, status FROM requests")
    ends = {r["id"]: r["status"] for r in rows}
    if len(ends) == count and all(s in ("Completed", "Cancelled") for s in ends.values()):
        return ends
    return None


class TestNotify:
    async def test_a_stream_on_one_process_hears_a_commit_on_another_at_once(
            self, pg_url: str, tmp_path: Path) -> None:
        """With the event poll at 60 s, a stream on process A gets the notifications of a
        request created through process B long before any poll: only LISTEN/NOTIFY can bring
        it. (It takes milliseconds; the bound is 10 s so that a loaded CI machine's queues do
        not fail it, and still far below the poll.)"""
        async with cluster(pg_url, tmp_path, 2, "--events-poll-s", "60") as fleet, \
                httpx.AsyncClient(timeout=10) as http:
            for server in fleet.procs:
                started = [json.loads(line) for line in
                           (tmp_path / f"{server.name}.log").read_text().splitlines()
                           if '"fleet.started"' in line]
                assert started and started[-1]["events_poll_s"] == 60.0
            a, b = fleet.procs[0].url, fleet.procs[1].url
            robot = SimRobot(httpx.AsyncClient(base_url=b, timeout=10), 1)
            for _ in range(3):  # online, sent to base, there
                await robot.report()
            got: asyncio.Queue[tuple[float, dict[str, Any]]] = asyncio.Queue()
            subscribed = asyncio.Event()
            loop = asyncio.get_running_loop()

            async def listen() -> None:
                async with http.stream("GET", f"{a}/api/events",
                                       headers={"Authorization": f"Bearer {ADMIN}"}) as stream:
                    async for line in stream.aiter_lines():
                        if line.startswith(": subscribed"):
                            subscribed.set()
                        elif line.startswith("data: "):
                            got.put_nowait((loop.time(), json.loads(line[6:])))

            listener = asyncio.create_task(listen())
            try:
                await asyncio.wait_for(subscribed.wait(), 10)
                answer = await http.post(f"{b}/api/requests", json={"CustomerId": 3},
                                         headers={"Authorization": f"Bearer {ADMIN}"})
                answered = loop.time()
                assert answer.status_code == 201, answer.text
                request_id = answer.json()["Id"]
                at, event = await asyncio.wait_for(got.get(), 20)
                while event["RequestId"] != request_id:
                    at, event = await asyncio.wait_for(got.get(), 20)
            finally:
                listener.cancel()
                await asyncio.gather(listener, return_exceptions=True)
                await robot.http.aclose()
        assert at - answered < 10.0

    async def test_a_process_that_lost_its_listening_connection_catches_up(
            self, pg_url: str, tmp_path: Path) -> None:
        """PostgreSQL drops process A's listening connection (``pg_terminate_backend``): A
        connects again by itself, and a stream on A still gets what process B creates next,
        long before the 30 s poll (heard on the new connection, or, if it was committed
        before A listened again, read from the stream's last id on reconnecting)."""
        async with cluster(pg_url, tmp_path, 2, "--events-poll-s", "30") as fleet, \
                httpx.AsyncClient(timeout=10) as http:
            a, b = fleet.procs
            robot = SimRobot(httpx.AsyncClient(base_url=b.url, timeout=10), 1)
            for _ in range(3):
                await robot.report()
            db = await asyncpg.connect(_plain(pg_url))
            got: asyncio.Queue[dict[str, Any]] = asyncio.Queue()
            subscribed = asyncio.Event()

            async def listen() -> None:
                async with http.stream("GET", f"{a.url}/api/events",
                                       headers={"Authorization": f"Bearer {ADMIN}"}) as stream:
                    async for line in stream.aiter_lines():
                        if line.startswith(": subscribed"):
                            subscribed.set()
                        elif line.startswith("data: "):
                            got.put_nowait(json.loads(line[6:]))

            listener = asyncio.create_task(listen())
            try:
                await asyncio.wait_for(subscribed.wait(), 10)
                cut = await db.fetchval(
                    "SELECT count(pg_terminate_backend(pid)) FROM pg_stat_activity "
                    "WHERE application_name = $1", f"robotd-fleet {a.pid}")
                assert cut == 1
                answer = await http.post(f"{b.url}/api/requests", json={"CustomerId": 4},
                                         headers={"Authorization": f"Bearer {ADMIN}"})
                assert answer.status_code == 201, answer.text
                event = await asyncio.wait_for(got.get(), 10)
                while event["RequestId"] != answer.json()["Id"]:
                    event = await asyncio.wait_for(got.get(), 10)
                log = (tmp_path / f"{a.name}.log").read_text()
                assert log.count('"fleet.listen.connected"') == 2
                assert '"fleet.listen.lost"' in log
            finally:
                listener.cancel()
                await asyncio.gather(listener, return_exceptions=True)
                await robot.http.aclose()
                await db.close()
