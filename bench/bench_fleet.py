"""Fleet server data exchange under load: N simulated robots each POST
/api/Robot/{name}/data-exchange once a second (random phase) to a real `robotd-fleet serve`
process, on SQLite and on PostgreSQL. Prints requests/s and latency percentiles, and as a baseline
the same load on GET /health in the same run (the HTTP stack and this machine's noise,
without the database).

    .venv/bin/python bench/bench_fleet.py [--robots 100,500] [--seconds 10] [--backend both]

The site has 40 customer rooms with a beacon each (every reply lists all 41 beacons). Half of
the robots serve a request (they get customer-room targets), half idle. Each robot
keeps one HTTP/1.1 connection, as a real robot's client does.
"""

from __future__ import annotations

import argparse
import asyncio
import json
import os
import random
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from fleet.pgtest import PgCluster, PgUnavailable  # noqa: E402

ROOMS = 40


def site_toml(robots: int) -> str:
    """A site with ROOMS customer rooms (one beacon each), one base, N robots, N customers."""
    lines = ['[settings]\nPreemptBusyRobot = false\n', '[[rooms]]\nname = "Laundry"\n',
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
    return "\n".join(lines)


def room_mac(room: int) -> str:
    return f"C3:00:00:00:00:{room:02X}"


class Conn:
    """A minimal keep-alive HTTP/1.1 client (a robot's connection)."""

    def __init__(self, port: int) -> None:
        self.port = port
        self.reader: asyncio.StreamReader | None = None
        self.writer: asyncio.StreamWriter | None = None

    async def call(self, method: str, path: str, body: bytes = b"") -> tuple[int, bytes]:
        if self.writer is None:
            self.reader, self.writer = await asyncio.open_connection("127.0.0.1", self.port)
        assert self.reader is not None
        head = (f"{method} {path} HTTP/1.1\r\nHost: fleet\r\nContent-Type: application/json\r\n"
                f"Content-Length: {len(body)}\r\n\r\n").encode()
        self.writer.write(head + body)
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


def exchange_body(name: str, i: int) -> bytes:
    return json.dumps({
        "RobotName": name, "Timestamp": "2026-01-05T08:00:00Z",
        "DetectedBeacons": [{"MacAddress": room_mac(i % ROOMS), "Rssi": -80, "Distance": 4.0}],
        "IsInTarget": False, "WeightKg": 0.0, "UltrasonicDistance": 120.0,
    }).encode()


async def robot_loop(port: int, i: int, stop_at: float, measure_from: float,
                     latencies: list[float], errors: list[int], *, health: bool = False) -> None:
    conn = Conn(port)
    name = f"robot-{i}"
    body = exchange_body(name, i)
    method, path = ("GET", "/health") if health else ("POST", f"/api/Robot/{name}/data-exchange")
    loop = asyncio.get_running_loop()
    next_t = loop.time() + random.random()
    try:
        while next_t < stop_at:
            await asyncio.sleep(max(0.0, next_t - loop.time()))
            t0 = time.perf_counter()
            status, _ = await conn.call(method, path, b"" if health else body)
            elapsed = time.perf_counter() - t0
            if loop.time() >= measure_from:
                latencies.append(elapsed)
                if status != 200:
                    errors.append(status)
            next_t += 1.0
    finally:
        conn.close()


async def load(port: int, robots: int, seconds: float, *, health: bool) -> list[float]:
    """Latencies of N robots calling once a second (after a 3 s warm-up)."""
    latencies: list[float] = []
    errors: list[int] = []
    start = asyncio.get_running_loop().time()
    warmup = 3.0
    await asyncio.gather(*(
        robot_loop(port, i, start + warmup + seconds, start + warmup, latencies, errors,
                   health=health)
        for i in range(robots)))
    if errors:
        msg = f"{len(errors)} errors, e.g. HTTP {errors[0]}"
        raise RuntimeError(msg)
    return latencies


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
    """User + system CPU seconds of a process (warm-up included, so a slight overestimate)."""
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def pct(values: list[float], q: float) -> float:
    ordered = sorted(values)
    return ordered[min(len(ordered) - 1, int(q * len(ordered)))] * 1000


async def run_one(db_url: str, robots: int, seconds: float, port: int,
                  extra: tuple[str, ...] = ()) -> dict[str, float]:
    workdir = Path(tempfile.mkdtemp(prefix="bench-fleet-"))
    site = workdir / "site.toml"
    site.write_text(site_toml(robots))
    proc = subprocess.Popen(  # noqa: ASYNC220 - started once, before the measurement
        [str(ROOT / ".venv/bin/robotd-fleet"), "serve", "--db", db_url, "--site", str(site),
         "--port", str(port), "--log-level", "warning", *extra],
        stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        await wait_ready(port, proc)
        admin = Conn(port)
        for c in range(1, robots // 2 + 1):
            await admin.call("POST", "/api/requests", json.dumps({"CustomerId": c}).encode())
        admin.close()
        cpu0 = cpu_s(proc.pid)
        base = await load(port, robots, seconds, health=True)
        cpu1 = cpu_s(proc.pid)
        latencies = await load(port, robots, seconds, health=False)
        cpu2 = cpu_s(proc.pid)
        return {"rps": len(latencies) / seconds, "p50": pct(latencies, 0.5),
                "cpu_ms": (cpu2 - cpu1) / len(latencies) * 1000,
                "health_cpu_ms": (cpu1 - cpu0) / len(base) * 1000,
                "p99": pct(latencies, 0.99), "max": max(latencies) * 1000,
                "health_p50": pct(base, 0.5), "health_p99": pct(base, 0.99)}
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
          f"{'':10s} same load on GET /health: p50={r['health_p50']:.1f} ms "
          f"p99={r['health_p99']:.1f} ms  server CPU {r['health_cpu_ms']:.2f} ms/req  "
          f"-> exchange p99 / health p99 = {r['p99'] / r['health_p99']:.1f}x", flush=True)


async def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--robots", default="100,500")
    parser.add_argument("--seconds", type=float, default=10.0)
    parser.add_argument("--backend", choices=("sqlite", "postgres", "both"), default="both")
    args = parser.parse_args()
    counts = [int(n) for n in args.robots.split(",")]
    print(f"bench_fleet: {os.cpu_count()} CPUs, load average "
          f"{os.getloadavg()[0]:.1f}; target: 500 robots p99 <= 50 ms on SQLite")
    port = 18700 + os.getpid() % 1000
    if args.backend in ("sqlite", "both"):
        for robots in counts:
            db = Path(tempfile.mkdtemp(prefix="bench-fleet-db-")) / "fleet.db"
            report("sqlite", robots, await run_one(f"sqlite:///{db}", robots, args.seconds,
                                                   port))
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
        finally:
            cluster.stop()
    return 0


if __name__ == "__main__":
    sys.exit(asyncio.run(main()))
