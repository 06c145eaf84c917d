"""Control socket and daemon figures: status round trip, loop lag, idle CPU, start to READY=1.

Runs a real ``robotd run`` (idle profile, no hardware) with a real NOTIFY_SOCKET, then:
- start to READY=1: from spawning the process to the READY=1 datagram;
- idle: loop lag p99 (from ``status``) and CPU % of one core over an idle window;
- ``status`` round trip p50/p99 with 20 clients connected, one at a time and all at once.
Targets (issue 2): round trip p99 <= 5 ms, idle CPU <= 1 %, start to READY=1 <= 2 s.

With ``--hostile`` (issue 28), against the same daemon:
- another client's ``status`` round trips while one client sends 5 MB of blank lines (p99
  target < 20 ms; before: 410 ms);
- ``estop`` latency with 200 idle and 200 slow clients connected (a raw client, 5 times, and
  the real ``robotctl estop`` process);
- 20 ``robotctl status`` (4 at a time) and a ``robotctl estop`` during a connect storm, paced
  (~1000 connects/s in waves of 100) and as fast as 4 threads can (before: 13 of 20 failed).

    .venv/bin/python bench/bench_control.py [--idle-s 10] [--requests 200] [--hostile]
"""

from __future__ import annotations

import argparse
import asyncio
import contextlib
import json
import os
import signal
import socket
import statistics
import struct
import subprocess
import sys
import tempfile
import threading
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

CLIENTS = 20
STATUS = json.dumps({"jsonrpc": "2.0", "id": 1, "method": "status"}).encode() + b"\n"
ROBOTCTL = str(Path(sys.executable).parent / "robotctl")


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


# --- issue 28: hostile clients -----------------------------------------------------------


def rpc(sock: str, method: str) -> dict[str, object]:
    with socket.socket(socket.AF_UNIX, socket.SOCK_STREAM) as conn:
        conn.settimeout(10)
        conn.connect(sock)
        conn.sendall(json.dumps({"jsonrpc": "2.0", "id": 1, "method": method}).encode() + b"\n")
        reply: dict[str, object] = json.loads(conn.makefile("rb").readline())
    return reply


def waiting_socket(wait_s: float) -> socket.socket:
    """A client socket whose connect waits up to ``wait_s`` for room in a full queue."""
    conn = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    conn.setsockopt(socket.SOL_SOCKET, socket.SO_SNDTIMEO,
                    struct.pack("@ll", int(wait_s), int(wait_s % 1 * 1e6)))
    return conn


def blank_flood_round_trips(sock: str, flood_bytes: int = 5 << 20, count: int = 50
                            ) -> list[float]:
    """``status`` round trips (ms) of one client while another sends ``flood_bytes`` of
    blank lines; only those made while the flood is under way count."""
    flooder = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    flooder.connect(sock)
    sent = [0]
    done = threading.Event()

    def flood() -> None:
        view = memoryview(b"\n" * flood_bytes)
        try:
            while sent[0] < len(view):
                sent[0] += flooder.send(view[sent[0]:sent[0] + 65536])
        except OSError:
            pass
        done.set()

    conn = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    conn.connect(sock)
    reader = conn.makefile("rb")
    for _ in range(10):  # warm up
        conn.sendall(STATUS)
        reader.readline()
    thread = threading.Thread(target=flood, daemon=True)
    thread.start()
    rtts_ms: list[float] = []
    while len(rtts_ms) < count and not done.is_set():
        under_way = sent[0] > 0
        start = time.perf_counter()
        conn.sendall(STATUS)
        reader.readline()
        if under_way and not done.is_set():
            rtts_ms.append((time.perf_counter() - start) * 1000)
        time.sleep(0.005)
    flooder.shutdown(socket.SHUT_RDWR)
    thread.join(10)
    flooder.close()
    reader.close()
    conn.close()
    return rtts_ms


def hostile_clients(sock: str, idle: int = 200, slow: int = 200) -> list[socket.socket]:
    """Idle clients (connected, silent) and slow ones (200 requests sent, no reply read)."""
    clients = []
    for i in range(idle + slow):
        conn = waiting_socket(10)
        conn.connect(sock)
        if i % 2:
            conn.setblocking(False)
            with contextlib.suppress(OSError):
                conn.send(STATUS * 200)
        clients.append(conn)
    return clients


def estop_ms(sock: str) -> float:
    """One estop as robotctl sends it (the control socket, else the e-stop socket), in ms,
    without robotctl's process start."""
    from robotd.ctl.connection import call_estop

    start = time.perf_counter()
    result = call_estop(sock, 10.0, {"reason": "bench"})
    elapsed_ms = (time.perf_counter() - start) * 1000
    assert isinstance(result, dict) and result["state"] == "estop", result
    return elapsed_ms


def run_robotctl(sock: str, *argv: str) -> tuple[int, float]:
    start = time.perf_counter()
    done = subprocess.run([ROBOTCTL, "--socket", sock, *argv], capture_output=True,
                          timeout=60, check=False)
    return done.returncode, time.perf_counter() - start


def estop_under_hostile(sock: str, trials: int = 5) -> tuple[list[float], int, float]:
    """Raw estop latencies (ms) with 400 hostile clients connected, and robotctl's own."""
    latencies = []
    for _ in range(trials):
        clients = hostile_clients(sock)
        try:
            latencies.append(estop_ms(sock))
        finally:
            for conn in clients:
                conn.close()
        rpc(sock, "resume")
        time.sleep(1.5)  # their places freed (idle ones give way after 1 s)
    clients = hostile_clients(sock)
    try:
        code, robotctl_s = run_robotctl(sock, "estop")
    finally:
        for conn in clients:
            conn.close()
    rpc(sock, "resume")
    return latencies, code, robotctl_s


def storm(sock: str, rate_per_s: float | None, threads: int = 4, burst: int = 25
          ) -> dict[str, float]:
    """20 robotctl status (4 at a time) and a robotctl estop during a connect storm."""
    stop = threading.Event()
    counts = [0, 0]
    cycle_s = 0.0 if rate_per_s is None else burst * threads / rate_per_s

    def wave() -> None:
        while not stop.is_set():
            started = time.monotonic()
            conns = []
            for _ in range(burst):
                conn = waiting_socket(1)
                conns.append(conn)
                try:
                    conn.connect(sock)
                    conn.setblocking(False)
                    conn.send(STATUS)
                    counts[0] += 1
                except OSError:
                    counts[1] += 1
            for conn in conns:
                conn.close()
            stop.wait(max(0.0, started + cycle_s - time.monotonic()))

    workers = [threading.Thread(target=wave, daemon=True) for _ in range(threads)]
    started = time.perf_counter()
    for worker in workers:
        worker.start()
    time.sleep(0.5)
    with ThreadPoolExecutor(4) as pool:
        statuses = list(pool.map(lambda _: run_robotctl(sock, "status"), range(20)))
    estop_code, estop_s = run_robotctl(sock, "estop")
    stop.set()
    for worker in workers:
        worker.join(10)
    seconds = time.perf_counter() - started
    time.sleep(1.0)
    rpc(sock, "resume")
    return {"storm_per_s": counts[0] / seconds, "ok": sum(1 for c, _ in statuses if c == 0),
            "slowest_s": max(s for _, s in statuses), "estop_code": estop_code,
            "estop_s": estop_s}


def report_hostile(sock: str) -> None:
    flood = blank_flood_round_trips(sock)
    print(f"status round trip during a 5 MB blank-line flood: p50 {percentile(flood, 50):.3f} "
          f"ms, p99 {percentile(flood, 99):.3f} ms, max {max(flood):.3f} ms ({len(flood)} "
          "round trips; target p99 < 20 ms)")
    latencies, code, robotctl_s = estop_under_hostile(sock)
    print(f"estop with 200 idle + 200 slow clients: {statistics.median(latencies):.1f} ms median, "
          f"{max(latencies):.1f} ms max ({len(latencies)} tries); robotctl estop exit {code} in "
          f"{robotctl_s * 1000:.0f} ms (process start included)")
    for name, rate in (("paced ~1000/s", 1000.0), ("as fast as 4 threads can", None)):
        figures = storm(sock, rate)
        print(f"connect storm, {name} ({figures['storm_per_s']:.0f} connects/s): robotctl "
              f"status {figures['ok']:.0f}/20 ok (slowest {figures['slowest_s']:.2f} s), "
              f"robotctl estop exit {figures['estop_code']:.0f} in {figures['estop_s']:.2f} s")


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--idle-s", type=float, default=10.0)
    parser.add_argument("--requests", type=int, default=200, help="per client")
    parser.add_argument("--hostile", action="store_true",
                        help="also the issue 28 figures: flood, hostile clients, connect storm")
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
            if args.hostile:
                report_hostile(sock)
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
