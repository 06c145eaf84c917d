"""The fleet server on several processes: N robots at 1 Hz through HAProxy to 3 `robotd-fleet
serve` processes on one PostgreSQL, beside the same load on ONE process behind the same
HAProxy, in the same run. Prints the data-exchange latency (p50/p99) and the push latency:
from a request status change made through the API (a new request, then its cancellation, a
few a second) to the admin's event stream (`GET /api/events` through HAProxy) receiving it.

    .venv/bin/python bench/bench_fleet_cluster.py [--robots 2000] [--seconds 60]
        [--servers 3] [--generators 2] [--changes-per-s 4]

The robots are bench_fleet.py's (one keep-alive connection each, a pre-encoded report sent
from a loop timer at a random phase of the second, every other one with issue 27's fields),
spread over ``--generators`` load-generator processes so that one Python loop does not
bound the rate. Latency is measured by each generator from its send to the whole answer.
Push latency is measured from the status-changing call's send (and, beside it, from its
answer) to the event's arrival. The servers' and HAProxy's CPU over the measured seconds is
read from /proc. The machine is shared: the load average is printed with each result.
"""

from __future__ import annotations

import argparse
import asyncio
import contextlib
import json
import os
import random
import resource
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "tests" / "support"))
sys.path.insert(0, str(ROOT / "bench"))

import httpx  # noqa: E402
from bench_fleet import (  # noqa: E402
    ADMIN_TOKEN,
    Conn,
    Robot,
    cpu_s,
    exchange_body,
    http_request,
    pct,
    robot_token,
    site_toml,
    with_state,
)
from fleet_cluster import FleetCluster  # noqa: E402
from pgtest import PgCluster, PgUnavailable  # noqa: E402

WARMUP_S = 5.0
REQUESTS_SERVED = 200
"""Requests made before the measurement (the robots named for them get room targets)."""


async def report_each(port: int, robots: int, connections: int = 20) -> None:
    """Every robot reports once, over ``connections`` connections at a time."""
    async def some(first: int) -> None:
        conn = Conn(port)
        for i in range(first, robots, connections):
            status, body = await conn.call(
                "POST", f"/api/Robot/robot-{i}/data-exchange",
                exchange_body(f"robot-{i}", i, state=with_state(i)), robot_token(i))
            if status != 200:
                msg = f"robot-{i}'s data exchange: HTTP {status} {body!r}"
                raise RuntimeError(msg)
        conn.close()

    await asyncio.gather(*(some(c) for c in range(connections)))


async def generate(port: int, first: int, count: int, start_wall: float, seconds: float,
                   ) -> dict[str, Any]:
    """One load generator: robots ``first``..``first+count-1``, measuring from
    ``start_wall + WARMUP_S`` (wall clock, shared by every generator) for ``seconds``."""
    loop = asyncio.get_running_loop()
    offset = loop.time() - time.time()
    start = start_wall + offset
    measure_from, stop_at = start + WARMUP_S, start + WARMUP_S + seconds
    latencies: list[float] = []
    errors: list[int] = []
    done = []
    for i in range(first, first + count):
        name = f"robot-{i}"
        request = http_request("POST", f"/api/Robot/{name}/data-exchange",
                               exchange_body(name, i, state=with_state(i)), robot_token(i))
        finished: asyncio.Future[None] = loop.create_future()
        done.append(finished)
        robot = Robot(request, start + random.random(), stop_at, measure_from, latencies,
                      errors, finished)
        await loop.create_connection(lambda r=robot: r, "127.0.0.1", port)
    cpu_at_start = time.process_time()
    await asyncio.gather(*done)
    return {"latencies": latencies, "errors": errors,
            "cpu_s": time.process_time() - cpu_at_start}


class PushProbe:
    """The admin's event stream through the load balancer, and the status changes whose
    arrival on it is timed."""

    def __init__(self, url: str, customers: range) -> None:
        self.url = url
        self.customers = iter(customers)
        # (request id, "created" or "cancelled") -> when its first such event came
        self.arrivals: dict[tuple[int, str], float] = {}
        self.from_send: list[float] = []
        self.from_answer: list[float] = []
        self.failed = 0
        self.subscribed = asyncio.Event()

    async def listen(self) -> None:
        headers = {"Authorization": f"Bearer {ADMIN_TOKEN}"}
        async with httpx.AsyncClient(timeout=httpx.Timeout(10, read=60)) as client, \
                client.stream("GET", f"{self.url}/api/events", headers=headers) as stream:
            kind = ""
            async for line in stream.aiter_lines():
                if line.startswith(": subscribed"):
                    self.subscribed.set()
                elif line.startswith("event: "):
                    kind = line[7:]
                elif line.startswith("data: "):
                    data = json.loads(line[6:])
                    if data["RequestId"] is not None:
                        what = "cancelled" if kind == "request.cancelled" else "created"
                        self.arrivals.setdefault((data["RequestId"], what), time.perf_counter())

    async def change(self, client: httpx.AsyncClient, per_s: float, until: float) -> None:
        """A new request, then its cancellation, ``per_s`` status changes a second."""
        headers = {"Authorization": f"Bearer {ADMIN_TOKEN}"}
        loop = asyncio.get_running_loop()
        next_t = loop.time()
        while loop.time() < until:
            customer = next(self.customers)
            sent = time.perf_counter()
            answer = await client.post("/api/requests", json={"CustomerId": customer},
                                       headers=headers)
            if answer.status_code != 201:
                self.failed += 1
                print(f"  POST /api/requests: HTTP {answer.status_code} {answer.text[:200]}")
                await asyncio.sleep(1 / per_s)
                continue
            request_id = answer.json()["Id"]
            await self._timed(request_id, "created", sent, time.perf_counter())
            next_t += 1 / per_s
            await asyncio.sleep(max(0.0, next_t - loop.time()))
            sent = time.perf_counter()
            answer = await client.post(f"/api/requests/{request_id}/cancel", headers=headers)
            if answer.status_code != 200:
                self.failed += 1
                print(f"  cancel: HTTP {answer.status_code} {answer.text[:200]}")
                continue
            await self._timed(request_id, "cancelled", sent, time.perf_counter())
            next_t += 1 / per_s
            await asyncio.sleep(max(0.0, next_t - loop.time()))

    async def _timed(self, request_id: int, kind: str, sent: float, answered: float) -> None:
        for _ in range(500):  # up to 5 s
            at = self.arrivals.get((request_id, kind))
            if at is not None:
                self.from_send.append(at - sent)
                self.from_answer.append(at - answered)
                return
            await asyncio.sleep(0.01)
        self.failed += 1
        print(f"  no event for request {request_id} {kind} within 5 s", flush=True)


async def run(pg: PgCluster, name: str, servers: int, args: argparse.Namespace
              ) -> dict[str, Any]:
    url = await pg.create_database(name)
    workdir = Path(tempfile.mkdtemp(prefix=f"bench-cluster-{name}-"))
    site = workdir / "site.toml"
    # Setting up 2000 robots takes longer than the default OfflineAfterS (30 s).
    site.write_text(site_toml(args.robots, "OfflineAfterS = 300\n"))
    async with FleetCluster(url, site, servers=servers, args=("--log-level", "warning"),
                            workdir=workdir) as fleet:
        admin = Conn(fleet.port)
        began = time.perf_counter()
        await report_each(fleet.port, args.robots)
        reported = time.perf_counter()
        for c in range(1, REQUESTS_SERVED + 1):
            status, body = await admin.call("POST", "/api/requests",
                                            json.dumps({"CustomerId": c}).encode())
            if status != 201:
                msg = f"POST /api/requests for customer {c}: HTTP {status} {body!r}"
                raise RuntimeError(msg)
        print(f"  set-up: {args.robots} first reports in {reported - began:.1f} s, "
              f"{REQUESTS_SERVED} requests in {time.perf_counter() - reported:.1f} s",
              flush=True)
        await report_each(fleet.port, args.robots)
        admin.close()
        probe = PushProbe(fleet.url, range(REQUESTS_SERVED + 1, args.robots + 1))
        listener = asyncio.create_task(probe.listen())
        await asyncio.wait_for(probe.subscribed.wait(), 10)
        start_wall = time.time() + 2.0 + args.robots / 2000  # time to open the connections
        outs = [workdir / f"gen{g}.json" for g in range(args.generators)]
        share = -(-args.robots // args.generators)
        gens = [await asyncio.create_subprocess_exec(
            sys.executable, __file__, "--generate", str(fleet.port), str(g * share),
            str(min(share, args.robots - g * share)), repr(start_wall), str(args.seconds),
            str(out)) for g, out in enumerate(outs)]
        loop = asyncio.get_running_loop()
        pids = [s.pid for s in fleet.procs]
        assert fleet.haproxy is not None
        await asyncio.sleep(max(0.0, start_wall + WARMUP_S - time.time()))
        cpu0 = [cpu_s(p) for p in pids]
        lb0 = cpu_s(fleet.haproxy.pid)
        load0 = os.getloadavg()[0]
        async with httpx.AsyncClient(base_url=fleet.url, timeout=10) as client:
            await probe.change(client, args.changes_per_s, loop.time() + args.seconds)
        cpu1 = [cpu_s(p) for p in pids]
        lb1 = cpu_s(fleet.haproxy.pid)
        for gen in gens:
            if await gen.wait() != 0:
                msg = f"a load generator failed ({gen.returncode})"
                raise RuntimeError(msg)
        load1 = os.getloadavg()[0]
        if listener.done():
            print(f"  the event stream ended: {listener.exception()!r}", flush=True)
        listener.cancel()
        with contextlib.suppress(asyncio.CancelledError, httpx.HTTPError):
            await listener
    latencies, errors, gen_cpu = _collect(outs)
    if not probe.from_send:
        probe.from_send = probe.from_answer = [float("nan")]
    requests = len(latencies)
    return {
        "servers": servers, "rps": requests / args.seconds, "errors": len(errors),
        "p50": pct(latencies, 0.5), "p99": pct(latencies, 0.99), "max": max(latencies) * 1000,
        "push_p50": pct(probe.from_send, 0.5), "push_p99": pct(probe.from_send, 0.99),
        "push_max": max(probe.from_send) * 1000, "push_n": len(probe.from_send),
        "push_answer_p50": pct(probe.from_answer, 0.5),
        "push_answer_p99": pct(probe.from_answer, 0.99), "push_failed": probe.failed,
        "server_cpu_ms": (sum(cpu1) - sum(cpu0)) / max(1, requests) * 1000,
        "server_cpu_share": [round((b - a) / args.seconds, 2)
                             for a, b in zip(cpu0, cpu1, strict=True)],
        "haproxy_cpu_ms": (lb1 - lb0) / max(1, requests) * 1000,
        "generator_cpu_ms": gen_cpu / max(1, requests) * 1000, "load": (load0, load1)}


def _collect(outs: list[Path]) -> tuple[list[float], list[int], float]:
    """The generators' latencies, errors and CPU seconds, added up."""
    latencies: list[float] = []
    errors: list[int] = []
    cpu = 0.0
    for out in outs:
        got = json.loads(out.read_text())
        latencies += got["latencies"]
        errors += got["errors"]
        cpu += got["cpu_s"]
    return latencies, errors, cpu


def report(args: argparse.Namespace, r: dict[str, Any]) -> None:
    print(f"{r['servers']} process(es) behind HAProxy, {args.robots} robots at 1 Hz: "
          f"{r['rps']:.0f} req/s ({r['errors']} errors)\n"
          f"  data exchange  p50={r['p50']:.1f} ms  p99={r['p99']:.1f} ms  max={r['max']:.0f} ms\n"
          f"  push (status change -> event stream), {r['push_n']} changes: from the call's send "
          f"p50={r['push_p50']:.1f} ms p99={r['push_p99']:.1f} ms max={r['push_max']:.0f} ms; "
          f"from its answer p50={r['push_answer_p50']:.1f} ms "
          f"p99={r['push_answer_p99']:.1f} ms ({r['push_failed']} failed)\n"
          f"  CPU per exchange: servers {r['server_cpu_ms']:.2f} ms (cores busy per process "
          f"{r['server_cpu_share']}), HAProxy {r['haproxy_cpu_ms']:.3f} ms, load generators "
          f"{r['generator_cpu_ms']:.2f} ms; load average {r['load'][0]:.1f} -> "
          f"{r['load'][1]:.1f}", flush=True)


def parse_args() -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--robots", type=int, default=2000)
    parser.add_argument("--seconds", type=float, default=60.0)
    parser.add_argument("--servers", type=int, default=3)
    parser.add_argument("--generators", type=int, default=2)
    parser.add_argument("--changes-per-s", type=float, default=4.0)
    parser.add_argument("--generate", nargs=6, metavar=("PORT", "FIRST", "COUNT", "START",
                                                        "SECONDS", "OUT"),
                        help=argparse.SUPPRESS)
    return parser.parse_args()


async def main(args: argparse.Namespace) -> int:
    _soft, hard = resource.getrlimit(resource.RLIMIT_NOFILE)
    resource.setrlimit(resource.RLIMIT_NOFILE, (hard, hard))
    print(f"bench_fleet_cluster: {os.cpu_count()} CPUs, load average "
          f"{os.getloadavg()[0]:.1f}; target: push p99 <= 1 s", flush=True)
    try:
        pg = PgCluster.start()
    except PgUnavailable as exc:
        print(f"skipped: {exc}")
        return 0
    try:
        for n, servers in enumerate((args.servers, 1)):
            report(args, await run(pg, f"cluster_{n}", servers, args))
    finally:
        pg.stop()
    return 0


if __name__ == "__main__":
    options = parse_args()
    try:
        import uvloop
        loop_factory = uvloop.new_event_loop
    except ImportError:
        loop_factory = None
    with asyncio.Runner(loop_factory=loop_factory) as runner:
        if options.generate:
            port, first, count, start, seconds, out = options.generate
            _soft, hard = resource.getrlimit(resource.RLIMIT_NOFILE)
            resource.setrlimit(resource.RLIMIT_NOFILE, (hard, hard))
            result = runner.run(generate(int(port), int(first), int(count), float(start),
                                         float(seconds)))
            Path(out).write_text(json.dumps(result))
            sys.exit(0)
        sys.exit(runner.run(main(options)))
