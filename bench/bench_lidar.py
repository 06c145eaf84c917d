"""LD19 parsing speed as a multiple of the line rate, and the simulated LD19's cost per scan.

    .venv/bin/python bench/bench_lidar.py [--seconds S] [--json]

Cases (one core, best of five runs, wall-clock time):
- parse: ``PacketParser.feed`` over S seconds of LD19 data, in 256-byte chunks (about 11 ms
  of line time, what a USB serial read brings) and 4096-byte chunks; clean, and with 5 % of
  bytes bit-flipped (95 % of packets then fail their CRC);
- driver: parser + scan assembler (scans in the robot's frame), the driver's whole CPU path;
- false accepts: damaged packets that still pass CRC-8 (1 in 256 of those with two or more
  bad bits) and the plausibility checks, at 0.1, 1 and 5 % of bytes corrupted (10x S seconds);
- sim: the simulated LD19 making one turn of packets (450 beams cast on four walls, noise,
  encoding, CRC), and a turn through the whole simulated line into the real driver on the
  virtual-time loop.
The line rate is 23040 bytes/s (230400 baud, 8N1); the LD19 fills 76 % of it.
"""

from __future__ import annotations

import argparse
import asyncio
import json
import random
import time
from collections.abc import Callable
from typing import Any

import structlog

from drivers.lidar import Ld19Lidar, LidarConfig
from drivers.lidar.packet import LINE_BYTES_PER_S
from drivers.lidar.parser import PacketParser
from drivers.lidar.scan_assembler import ScanAssembler
from sim import vclock
from sim.devices.byte_pipe import corrupt_bytes
from sim.devices.ld19 import SimLd19, walls
from sim.devices.sim_serial import SimSerialPorts

ROOM = [(1.0, -3.0, 1.0, 2.0), (-3.0, 2.0, 1.0, 2.0), (-3.0, -3.0, 1.0, -3.0),
        (-3.0, -3.0, -3.0, 2.0)]
PACKETS_PER_S = 4500 / 12
RUNS = 5


def stream(seconds: float, corrupt_pct: float) -> bytes:
    device = SimLd19(walls(ROOM), seed=1)
    data = device.packets(int(seconds * PACKETS_PER_S))
    return corrupt_bytes(data, corrupt_pct / 100.0, random.Random(2))


def best_s(run: Callable[[], object]) -> float:
    times = []
    for _ in range(RUNS):
        start = time.perf_counter()
        run()
        times.append(time.perf_counter() - start)
    return min(times)


def parse_case(data: bytes, chunk: int, *, assemble: bool) -> dict[str, Any]:
    chunks = [data[i:i + chunk] for i in range(0, len(data), chunk)]
    result: dict[str, Any] = {}

    def run() -> None:
        parser = PacketParser()
        assembler = ScanAssembler(LidarConfig())
        scans = 0
        for piece in chunks:
            packets = parser.feed(piece)
            if assemble:
                scans += len(assembler.add(packets, 0.0))
        result.update(packets=parser.counters.packets, crc_errors=parser.counters.crc_errors,
                      scans=scans)

    elapsed_s = best_s(run)
    rate = len(data) / elapsed_s
    return {"chunk_bytes": chunk, "mb_per_s": round(rate / 1e6, 2),
            "x_line_rate": round(rate / LINE_BYTES_PER_S, 1), **result}


def false_accepts(seconds: float, corrupt_pct: float) -> dict[str, Any]:
    """Damaged packets that passed CRC-8 and the plausibility checks (vs the clean stream)."""
    device = SimLd19(walls(ROOM), seed=1)
    clean = device.packets(int(seconds * PACKETS_PER_S))
    intact = {clean[i:i + 47] for i in range(0, len(clean), 47)}
    parser = PacketParser()
    records = parser.feed(corrupt_bytes(clean, corrupt_pct / 100.0, random.Random(3)))
    false = sum(1 for record in records if record.tobytes() not in intact)
    return {"corrupt_pct": corrupt_pct, "accepted": len(records), "false": false,
            "false_pct_of_accepted": round(100.0 * false / max(1, len(records)), 3),
            "implausible": parser.counters.implausible}


def sim_turn_ms() -> float:
    """CPU per turn of the simulated LD19 as it is paced: a write every 10 ms (3-4 packets)."""
    device = SimLd19(walls(ROOM), seed=1)
    turns = 20
    counts = [int((i + 1) * 3.75) - int(i * 3.75) for i in range(10 * turns)]

    def run() -> None:
        for count in counts:
            device.packets(count)

    return best_s(run) / turns * 1000.0


def sim_through_driver(seconds: float) -> dict[str, Any]:
    """Wall time per simulated scan: SimLd19 -> byte pipe -> Ld19Lidar on the virtual clock."""

    async def main() -> int:
        device = SimLd19(walls(ROOM), seed=1)
        ports = SimSerialPorts()
        ports.attach("/dev/ttyUSB0", device)
        lidar = Ld19Lidar(ports, LidarConfig())
        await lidar.start()
        await asyncio.sleep(seconds)
        scans: int = lidar.status()["scans"]
        await lidar.close()
        device.close()
        return scans

    start = time.perf_counter()
    scans = vclock.run(main())
    elapsed_s = time.perf_counter() - start
    return {"scans": scans, "ms_per_scan": round(elapsed_s / scans * 1000.0, 3),
            "speed_factor": round(seconds / elapsed_s, 1)}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=20.0, help="seconds of LD19 data")
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args()
    structlog.configure(wrapper_class=structlog.make_filtering_bound_logger(40))
    clean, noisy = stream(args.seconds, 0.0), stream(args.seconds, 5.0)
    report: dict[str, Any] = {
        "parse_clean": [parse_case(clean, c, assemble=False) for c in (256, 4096)],
        "parse_5pct": [parse_case(noisy, c, assemble=False) for c in (256, 4096)],
        "driver_clean": [parse_case(clean, c, assemble=True) for c in (256, 4096)],
        "driver_5pct": [parse_case(noisy, c, assemble=True) for c in (256, 4096)],
        "false_accepts": [false_accepts(10 * args.seconds, pct) for pct in (0.1, 1.0, 5.0)],
        "sim_turn_ms": round(sim_turn_ms(), 3),
        "sim_through_driver": sim_through_driver(args.seconds),
    }
    if args.json:
        print(json.dumps(report))
        return
    for case in ("parse_clean", "parse_5pct", "driver_clean", "driver_5pct"):
        for row in report[case]:
            print(f"{case:13} chunk {row['chunk_bytes']:5} B: {row['x_line_rate']:7.1f}x line "
                  f"rate ({row['mb_per_s']} MB/s), packets {row['packets']}, "
                  f"CRC errors {row['crc_errors']}, scans {row['scans']}")
    for row in report["false_accepts"]:
        print(f"{row['corrupt_pct']:4} % bytes corrupted: {row['false']} damaged packets of "
              f"{row['accepted']} accepted ({row['false_pct_of_accepted']} %) passed CRC-8 and "
              f"the checks; {row['implausible']} refused as implausible")
    print(f"simulated LD19: {report['sim_turn_ms']} ms of CPU per turn (450 beams, "
          "10 writes)")
    sim = report["sim_through_driver"]
    print(f"sim -> pipe -> driver, virtual time: {sim['ms_per_scan']} ms per scan, "
          f"{sim['speed_factor']}x real time ({sim['scans']} scans)")


if __name__ == "__main__":
    main()
