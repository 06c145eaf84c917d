"""Control socket and daemon figures: status round trip, loop lag, idle CPU, start to READY=1.

Runs a real ``robotd run`` (idle profile, no hardware) with a real NOTIFY_SOCKET, then:
- start to READY=1: from spawning the process to the READY=1 datagram;
- idle: loop lag p99 (from ``status``) and CPU % of one core over an idle window;
- ``status`` round trip p50/p99 with 20 clients connected, one at a time and all at once.
Targets (issue 2): round trip p99 <= 5 ms, idle CPU <= 1 %, start to READY=1 <= 2 s.

    .venv/bin/python bench/bench_control.py [--idle-s 10] [--requests 200]
"""

from __future__ import annotations

import argparse
import asyncio
import json
import os
import signal
import socket
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

CLIENTS = 20
STATUS = json.dumps({"jsonrpc": "2.0", "id": 1, "method": "status"}).encode() + b"\n"


def percentile(samples: list[float], pct: float) -> float:
    ordered = sorted(samples)
    index = max(0, min(len(ordered) - 1, round(pct / 100 * len(ordered) + 0.5) - 1))
    return ordered[index]


def cpu_s(pid: int) -> float:
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def rss_mb(pid: int) -> float:
    for line in Path(f"/proc/{pid}/status").read_text().splitlines():
        if line.startswith("VmRSS:"):
            return int(line.split()[1]) / 1024
    return 0.0


async def concurrent_round_trips(sock: str, requests: int) -> list[float]:
    """20 asyncio clients, each sending its next request as soon as it has the answer."""
    streams = [await asyncio.open_unix_connection(sock, limit=1 << 20) for _ in range(CLIENTS)]
    rtts_ms: list[float] = []

    async def one_client(reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
        for _ in range(requests):
            start = time.perf_counter()
            writer.write(STATUS)
            await reader.readline()
            rtts_ms.append((time.perf_counter() - start) * 1000)

    await asyncio.gather(*(one_client(r, w) for r, w in streams))
    for _, writer in streams:
        writer.close()
    return rtts_ms


def sequential_round_trips(sock: str, requests: int) -> list[float]:
    """Blocking clients (no client-side event loop in the figure), asked in turn."""
    conns = []
    for _ in range(CLIENTS):
        conn = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
        conn.connect(sock)
        conns.append((conn, conn.makefile("rb")))
    rtts_ms: list[float] = []
    for _ in range(requests):
        for conn, reader in conns:
            start = time.perf_counter()
            conn.sendall(STATUS)
            reader.readline()
            rtts_ms.append((time.perf_counter() - start) * 1000)
    for conn, reader in conns:
        reader.close()
        conn.close()
    return rtts_ms


def status(sock: str) -> dict[str, object]:
    with socket.socket(socket.AF_UNIX, socket.SOCK_STREAM) as conn:
        conn.connect(sock)
        conn.sendall(STATUS)
        reply: dict[str, object] = json.loads(conn.makefile("rb").readline())["result"]
    return reply


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--idle-s", type=float, default=10.0)
    parser.add_argument("--requests", type=int, default=200, help="per client")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory(prefix="rd-bench-") as tmp:
        work = Path(tmp)
        sock = str(work / "control.sock")
        config = work / "robotd.toml"
        config.write_text(f'[robot]\nname = "bench"\nprofile = "idle"\n'
                          f'state_dir = "{work / "state"}"\n'
                          f'[control]\nsocket = "{sock}"\n[logging]\nlevel = "warning"\n')
        notify = socket.socket(socket.AF_UNIX, socket.SOCK_DGRAM)
        notify.bind(str(work / "notify"))
        notify.settimeout(60)
        env = dict(os.environ, NOTIFY_SOCKET=str(work / "notify"))
        env.pop("JOURNAL_STREAM", None)
        started = time.perf_counter()
        proc = subprocess.Popen([sys.executable, "-m", "robotd.cli", "run", "--config",
                                 str(config)], env=env, stderr=subprocess.DEVNULL)
        try:
            while b"READY=1" not in notify.recv(4096):
                pass
            ready_s = time.perf_counter() - started

            cpu_before, wall_before = cpu_s(proc.pid), time.perf_counter()
            time.sleep(args.idle_s)
            idle_cpu_pct = (cpu_s(proc.pid) - cpu_before) / (time.perf_counter() - wall_before)
            lag = status(sock)["loop_lag_ms"]
            assert isinstance(lag, dict)

            one_at_a_time = sequential_round_trips(sock, args.requests // 4)
            all_at_once = asyncio.run(concurrent_round_trips(sock, args.requests))
            memory_mb = rss_mb(proc.pid)
        finally:
            proc.send_signal(signal.SIGTERM)
            stop_start = time.perf_counter()
            code = proc.wait(timeout=10)
            stop_s = time.perf_counter() - stop_start
            notify.close()

    print(f"machine: {os.cpu_count()} cores, load average {os.getloadavg()[0]:.2f}")
    print(f"start to READY=1:          {ready_s:.3f} s   (target <= 2 s)")
    print(f"idle CPU over {args.idle_s:g} s:       {idle_cpu_pct * 100:.2f} % of a core "
          "(target <= 1 %)")
    print(f"idle loop lag:             p50 {lag['p50_ms']:.3f} ms, p99 {lag['p99_ms']:.3f} ms, "
          f"max {lag['max_ms']:.3f} ms ({lag['samples']} samples)")
    for name, rtts in (("20 connected, one at a time", one_at_a_time),
                       ("20 clients all at once", all_at_once)):
        print(f"status round trip, {name}: p50 {percentile(rtts, 50):.3f} ms, "
              f"p99 {percentile(rtts, 99):.3f} ms, mean {statistics.fmean(rtts):.3f} ms "
              f"({len(rtts)} requests; target p99 <= 5 ms)")
    print(f"RSS after the run:         {memory_mb:.1f} MB")
    print(f"SIGTERM to exit:           {stop_s:.3f} s, exit code {code}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
