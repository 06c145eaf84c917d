"""Fleet server data exchange under load: N simulated robots each POST
/api/Robot/{name}/data-exchange once a second (random phase) to a real `robotd-fleet serve`
process, on SQLite and on PostgreSQL. Prints requests/s and latency percentiles, and as a baseline
the same load on GET /health in the same run (the HTTP stack and this machine's noise,
without the database).

    .venv/bin/python bench/bench_fleet.py [--robots 100,500] [--seconds 10] [--backend both]
        [--storm]

Every call carries a bearer token, as on a real site: each robot its own, the set-up calls
the admin's (seeded through the site file; stored hashed). ``--storm`` also times a reconnect
storm (bench/fleet_storm.py): every robot offline, then all report at once; it prints how long
until the last one is answered (restored), and checks that all are online.

The site has 40 customer rooms with a beacon each (every reply lists all 41 beacons). Half of
the robots serve a request (they get customer-room targets), half idle. Every other robot also
sends what issue 27 added to the exchange (State, EmergencyStopActive, Fault, BatteryPct):
the data-exchange latency is printed for all, and for the robots with and without the new
fields, side by side from the same run. Each robot
keeps one HTTP/1.1 connection, as a real robot's client does. Server CPU per request is read
from /proc over the measured seconds only; the load generator (protocol callbacks on loop
timers, uvloop) prints its own, since it shares the machine's cores with the server.

``--simulator`` instead times the in-process fleet traffic of a ``robotd sim laundry`` run
(bench/bench_fleet_sim.py).
"""

from __future__ import annotations

import argparse
import asyncio
import contextlib
import json
import os
import random
import subprocess
import sys
import tempfile
import time
from collections.abc import AsyncIterator
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "tests" / "support"))

from pgtest import PgCluster, PgUnavailable  # noqa: E402

ROOMS = 40
WARMUP_S = 3.0


ADMIN_TOKEN = "bench-admin-token-0123456789abcdef"


def robot_token(i: int) -> str:
    return f"bench-robot-{i}-token-0123456789abcdef"


def site_toml(robots: int, settings: str = "") -> str:
    """A site with ROOMS customer rooms (one beacon each), one base, N robots, N customers,
    a token for each robot and one admin token."""
    lines = [f'[settings]\nPreemptBusyRobot = false\n{settings}',
             '[[rooms]]\nname = "Laundry"\n',
             f'[[tokens]]\nrole = "admin"\nsubject = "bench"\ntoken = "{ADMIN_TOKEN}"\n',
             '[[beacons]]\nmac = "C3:00:00:00:FF:FF"\nname = "base"\nroom = "Laundry"\n'
             'base = true\n']
    for r in range(ROOMS):
        lines.append(f'[[rooms]]\nname = "Room {r}"\n')
        lines.append(f'[[beacons]]\nmac = "{room_mac(r)}"\nname = "room-{r}"\n'
                     f'room = "Room {r}"\n')
    for i in range(robots):
        lines.append(f'[[customers]]\nid = {i + 1}\nname = "c{i}"\n'
                     f'beacon = "{room_mac(i % ROOMS)}"\n')
        lines.append(f'[[robots]]\nname = "robot-{i}"\n')
        lines.append(f'[[tokens]]\nrole = "robot"\nsubject = "robot-{i}"\n'
                     f'token = "{robot_token(i)}"\n')
    return "\n".join(lines)


def room_mac(room: int) -> str:
    return f"C3:00:00:00:00:{room:02X}"


class Conn:
    """A minimal keep-alive HTTP/1.1 client (for the set-up calls)."""

    def __init__(self, port: int) -> None:
        self.port = port
        self.reader: asyncio.StreamReader | None = None
        self.writer: asyncio.StreamWriter | None = None

    async def connect(self) -> None:
        self.reader, self.writer = await asyncio.open_connection("127.0.0.1", self.port)

    async def call(self, method: str, path: str, body: bytes = b"",
                   token: str | None = ADMIN_TOKEN) -> tuple[int, bytes]:
        if self.writer is None:
            await self.connect()
        assert self.reader is not None
        self.writer.write(http_request(method, path, body, token))
        status_line = await self.reader.readline()
        length = 0
        while True:
            line = await self.reader.readline()
            if line in (b"\r\n", b""):
                break
            name, _, value = line.decode().partition(":")
            if name.lower() == "content-length":
                length = int(value)
        payload = await self.reader.readexactly(length)
        return int(status_line.split()[1]), payload

    def close(self) -> None:
        if self.writer is not None:
            self.writer.close()


def http_request(method: str, path: str, body: bytes = b"", token: str | None = None) -> bytes:
    auth = f"Authorization: Bearer {token}\r\n" if token else ""
    return (f"{method} {path} HTTP/1.1\r\nHost: fleet\r\nContent-Type: application/json\r\n"
            f"{auth}Content-Length: {len(body)}\r\n\r\n").encode() + body


def exchange_body(name: str, i: int, *, state: bool = False) -> bytes:
    """A robot's report; ``state``: with the fields issue 27 added (a robot on its way)."""
    body = {
        "RobotName": name, "Timestamp": "2026-01-05T08:00:00Z",
        "DetectedBeacons": [{"MacAddress": room_mac(i % ROOMS), "Rssi": -80, "Distance": 4.0}],
        "IsInTarget": False, "WeightKg": 0.0, "UltrasonicDistance": 120.0,
    }
    if state:
        body.update({"State": "mission.to_room", "EmergencyStopActive": False, "Fault": None,
                     "BatteryPct": 87.5})
    return json.dumps(body).encode()


def with_state(i: int) -> bool:
    """Every other robot sends the new fields."""
    return i % 2 == 0


class Robot(asyncio.Protocol):
    """One robot's keep-alive connection, sending its pre-encoded request once a second from a
    loop timer. No task, stream or header parsing beyond Content-Length per call, so the load
    generator costs little of the CPU it shares with the server."""

    def __init__(self, request: bytes, first_s: float, stop_at: float, measure_from: float,
                 latencies: list[float], errors: list[int], done: asyncio.Future[None]) -> None:
        self.request = request
        self.next_t = first_s
        self.stop_at = stop_at
        self.measure_from = measure_from
        self.latencies = latencies
        self.errors = errors
        self.done = done
        self.loop = asyncio.get_running_loop()
        self.transport: asyncio.WriteTransport | None = None
        self.buffer = b""
        self.sent_at = 0.0
        self.measured = False

    def connection_made(self, transport: asyncio.BaseTransport) -> None:
        self.transport = transport  # type: ignore[assignment]
        self.loop.call_at(self.next_t, self.send)

    def send(self) -> None:
        if self.transport is None or self.transport.is_closing():
            return
        self.measured = self.loop.time() >= self.measure_from
        self.sent_at = time.perf_counter()
        self.transport.write(self.request)

    def data_received(self, data: bytes) -> None:
        self.buffer += data
        head_end = self.buffer.find(b"\r\n\r\n")
        if head_end < 0:
            return
        head = self.buffer[:head_end].lower()
        at = head.find(b"content-length:")
        length = int(head[at + 15:head.find(b"\r\n", at)]) if at >= 0 else 0
        if len(self.buffer) < head_end + 4 + length:
            return
        elapsed = time.perf_counter() - self.sent_at
        status = int(self.buffer[9:12])
        self.buffer = self.buffer[head_end + 4 + length:]
        if self.measured:
            self.latencies.append(elapsed)
            if status != 200:
                self.errors.append(status)
        self.next_t += 1.0
        if self.next_t < self.stop_at:
            self.loop.call_at(self.next_t, self.send)
        elif self.transport is not None:
            self.transport.close()

    def connection_lost(self, exc: Exception | None) -> None:
        if self.next_t < self.stop_at:
            self.errors.append(0)  # the server closed the connection
        if not self.done.done():
            self.done.set_result(None)


async def load(port: int, robots: int, seconds: float, pid: int, *,
               health: bool) -> tuple[list[float], float, float, list[float]]:
    """Latencies of N robots calling once a second (after a 3 s warm-up), the server's and
    this load generator's CPU seconds over the measured part, and the latencies of the robots
    that send the new fields (``with_state``; the others are the first list)."""
    loop = asyncio.get_running_loop()
    latencies: list[float] = []
    stated: list[float] = []
    errors: list[int] = []
    start = loop.time() + 0.5
    warmup = WARMUP_S
    measure_from, stop_at = start + warmup, start + warmup + seconds
    cpu: list[float] = []
    own: list[float] = []

    def sample() -> None:
        cpu.append(cpu_s(pid))
        own.append(time.process_time())

    loop.call_at(measure_from, sample)
    done = []
    for i in range(robots):
        name = f"robot-{i}"
        request = (http_request("GET", "/health") if health else
                   http_request("POST", f"/api/Robot/{name}/data-exchange",
                                exchange_body(name, i, state=with_state(i)), robot_token(i)))
        finished: asyncio.Future[None] = loop.create_future()
        done.append(finished)
        into = stated if with_state(i) and not health else latencies
        robot = Robot(request, start + random.random(), stop_at, measure_from, into, errors,
                      finished)
        await loop.create_connection(lambda r=robot: r, "127.0.0.1", port)
    await asyncio.gather(*done)
    sample()
    if errors:
        msg = f"{len(errors)} errors, e.g. HTTP {errors[0]} (0: connection lost)"
        raise RuntimeError(msg)
    return latencies, cpu[1] - cpu[0], own[1] - own[0], stated


async def wait_ready(port: int, proc: subprocess.Popen[bytes]) -> None:
    for _ in range(300):
        if proc.poll() is not None:
            msg = f"server exited with {proc.returncode}"
            raise RuntimeError(msg)
        try:
            conn = Conn(port)
            status, _ = await conn.call("GET", "/health")
            conn.close()
            if status == 200:
                return
        except OSError:
            pass
        await asyncio.sleep(0.1)
    msg = "server did not start"
    raise RuntimeError(msg)


def cpu_s(pid: int) -> float:
    """User + system CPU seconds of a process."""
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def pct(values: list[float], q: float) -> float:
    ordered = sorted(values)
    return ordered[min(len(ordered) - 1, int(q * len(ordered)))] * 1000


async def run_one(db_url: str, robots: int, seconds: float, port: int,
                  extra: tuple[str, ...] = ()) -> dict[str, float]:
    # The exchanges run before the /health baseline: a robot that has not reported for
    # OfflineAfterS when the offline monitor looks (every 30 s) goes offline, and its next
    # report takes the write path.
    async with served_fleet(db_url, robots, port, extra) as (admin, pid):
        admin.close()
        plain, cpu, own, stated = await load(port, robots, seconds, pid, health=False)
        base, health_cpu_s, _, _ = await load(port, robots, seconds, pid, health=True)
        latencies = plain + stated
        return {"rps": len(latencies) / seconds, "p50": pct(latencies, 0.5),
                "plain_p50": pct(plain, 0.5), "plain_p99": pct(plain, 0.99),
                "state_p50": pct(stated, 0.5), "state_p99": pct(stated, 0.99),
                "cpu_ms": cpu / len(latencies) * 1000,
                "client_cpu_ms": own / len(latencies) * 1000,
                "health_cpu_ms": health_cpu_s / len(base) * 1000,
                "p99": pct(latencies, 0.99), "max": max(latencies) * 1000,
                "health_p50": pct(base, 0.5), "health_p99": pct(base, 0.99)}


async def report_all(conn: Conn, robots: int) -> None:
    """Every robot makes one data exchange."""
    for i in range(robots):
        status, body = await conn.call("POST", f"/api/Robot/robot-{i}/data-exchange",
                                       exchange_body(f"robot-{i}", i, state=with_state(i)),
                                       robot_token(i))
        if status != 200:
            msg = f"robot-{i}'s data exchange: HTTP {status} {body!r}"
            raise RuntimeError(msg)


@contextlib.asynccontextmanager
async def served_fleet(db_url: str, robots: int, port: int, extra: tuple[str, ...] = (),
                       settings: str = "", after: dict[str, object] | None = None,
                       ) -> AsyncIterator[tuple[Conn, int]]:
    """A ``robotd-fleet serve`` of its own for a run: the site's ``robots``, a request from
    half the customers and one report from every robot made. Yields an admin connection and
    the server's pid; the server is stopped after. (The robots report before the requests
    are made: a robot that has never reported is not online, and a site with no robot online
    refuses requests.) ``after``: settings put once all that is done."""
    workdir = Path(tempfile.mkdtemp(prefix="bench-fleet-"))
    site = workdir / "site.toml"
    site.write_text(site_toml(robots, settings))
    proc = subprocess.Popen(  # noqa: ASYNC220 - started once, before the measurement
        [str(ROOT / ".venv/bin/robotd-fleet"), "serve", "--db", db_url, "--site", str(site),
         "--port", str(port), "--log-level", "warning", *extra],
        stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        await wait_ready(port, proc)
        admin = Conn(port)
        await report_all(admin, robots)
        for c in range(1, robots // 2 + 1):
            status, _ = await admin.call("POST", "/api/requests",
                                         json.dumps({"CustomerId": c}).encode())
            if status != 201:
                msg = f"POST /api/requests for customer {c}: HTTP {status}"
                raise RuntimeError(msg)
        # Again, right before the measurement: the requests took a while, and a robot silent
        # for OfflineAfterS would take the write path (or go offline) in the measured part.
        await report_all(admin, robots)
        if after:
            status, body = await admin.call("PUT", "/api/settings", json.dumps(after).encode())
            if status != 200:
                msg = f"PUT /api/settings: HTTP {status} {body!r}"
                raise RuntimeError(msg)
        yield admin, proc.pid
    finally:
        proc.terminate()
        try:
            proc.wait(timeout=30)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait()


def report(backend: str, robots: int, r: dict[str, float]) -> None:
    print(f"{backend:10s} robots={robots:4d}  {r['rps']:7.1f} req/s  p50={r['p50']:6.1f} ms  "
          f"p99={r['p99']:6.1f} ms  max={r['max']:6.1f} ms  server CPU {r['cpu_ms']:.2f} ms/req\n"
          f"{'':10s} with State/EmergencyStopActive/Fault/BatteryPct: p50={r['state_p50']:.1f} ms "
          f"p99={r['state_p99']:.1f} ms; without them: p50={r['plain_p50']:.1f} ms "
          f"p99={r['plain_p99']:.1f} ms (same run, half the robots each)\n"
          f"{'':10s} same load on GET /health: p50={r['health_p50']:.1f} ms "
          f"p99={r['health_p99']:.1f} ms  server CPU {r['health_cpu_ms']:.2f} ms/req  "
          f"-> exchange p99 / health p99 = {r['p99'] / r['health_p99']:.1f}x\n"
          f"{'':10s} load generator CPU {r['client_cpu_ms']:.2f} ms/req; load average now "
          f"{os.getloadavg()[0]:.1f}", flush=True)


def parse_args() -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--robots", default="100,500")
    parser.add_argument("--seconds", type=float, default=10.0)
    parser.add_argument("--backend", choices=("sqlite", "sqlite-inline", "postgres", "both"),
                        default="both",
                        help="both: SQLite, SQLite inline (--sqlite-inline) and PostgreSQL")
    parser.add_argument("--storm", action="store_true",
                        help="also time a reconnect storm of every robot (target: 500 <= 1 s)")
    parser.add_argument("--simulator", type=int, nargs="?", const=1000, metavar="CALLS",
                        help="time the laundry simulation's fleet calls in process instead")
    return parser.parse_args()


async def main(args: argparse.Namespace) -> int:
    # bench/fleet_storm.py uses this module's robots and connections: imported here, not at the
    # top, so the two modules do not import each other while loading.
    from fleet_storm import report_storm, run_storm

    counts = [int(n) for n in args.robots.split(",")]
    print(f"bench_fleet: {os.cpu_count()} CPUs, load average "
          f"{os.getloadavg()[0]:.1f}; target: 500 robots p99 <= 50 ms on SQLite")
    port = 18700 + os.getpid() % 1000
    for robots in counts:
        if args.backend in ("sqlite", "both"):
            db = Path(tempfile.mkdtemp(prefix="bench-fleet-db-")) / "fleet.db"
            report("sqlite", robots, await run_one(f"sqlite:///{db}", robots, args.seconds,
                                                   port))
            if args.storm:
                db = Path(tempfile.mkdtemp(prefix="bench-fleet-db-")) / "fleet.db"
                report_storm("sqlite", robots, await run_storm(f"sqlite:///{db}", robots, port))
        if args.backend in ("sqlite-inline", "both"):
            db = Path(tempfile.mkdtemp(prefix="bench-fleet-db-")) / "fleet.db"
            report("sqlite-inl", robots, await run_one(
                f"sqlite:///{db}", robots, args.seconds, port, ("--sqlite-inline",)))
    if args.backend in ("postgres", "both"):
        try:
            cluster = PgCluster.start()
        except PgUnavailable as exc:
            print(f"postgres   skipped: {exc}")
            return 0
        try:
            for n, robots in enumerate(counts):
                url = await cluster.create_database(f"bench_{n}")
                report("postgres", robots, await run_one(url, robots, args.seconds, port))
                if args.storm:
                    url = await cluster.create_database(f"bench_storm_{n}")
                    report_storm("postgres", robots, await run_storm(url, robots, port))
        finally:
            cluster.stop()
    return 0


if __name__ == "__main__":
    options = parse_args()
    if options.simulator:
        from bench_fleet_sim import simulator_calls

        simulator_calls(options.simulator)  # on the simulator's own loop
        sys.exit(0)
    try:
        import uvloop
        loop_factory = uvloop.new_event_loop
    except ImportError:
        loop_factory = None
    with asyncio.Runner(loop_factory=loop_factory) as runner:
        sys.exit(runner.run(main(options)))
