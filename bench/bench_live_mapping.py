"""Live mapping's cost to the event loop: the loop's lag while key scans are matched in the
mapping's executor thread, beside the same work done on the loop itself (the baseline).

Replays a recorded depot drive (``sim/mapping/depot_run.py``) into ``LiveMapping.on_scan``
on a plain asyncio loop in real time (each scan delivered three times, 50 ms apart, so it counts as
taken standing: the live mapping uses still scans only), while a 10 ms ticker measures how
late it wakes (the loop lag: what a motor-board heartbeat or a drive step would suffer).
Prints the lag's p50 / p99 / max and the key-scan work's median and p95, for both.

    .venv/bin/python bench/bench_live_mapping.py [--seconds 60] [--json]
"""

from __future__ import annotations

import argparse
import asyncio
import json
import statistics
import time
from typing import Any

import numpy as np

from behaviours.nav.mapping.live import LiveMapping
from behaviours.nav.mapping.scan import Scan
from hal.readings import LidarScan
from sim.mapping.depot_run import record_run

TICK_S = 0.01


class InlineMapping(LiveMapping):
    """The baseline: the key scan's work on the loop, as if no thread were used."""

    async def _add_key(self, scan: Scan, t_s: float) -> None:
        try:
            self._key_work(scan)
        finally:
            self._job = None
        self._mark_settled(t_s)


def _lidar(scan: Scan, t_s: float) -> LidarScan:
    angles = scan.angles_rad()
    ranges = np.where(scan.returns(), scan.ranges_m, np.nan)
    return LidarScan(angles, ranges, np.zeros(angles.size, np.uint8), t_s,
                     max_range_m=scan.max_range_m)


async def _replay(live: LiveMapping, scans: list[Scan], odom: list[Any]) -> dict[str, Any]:
    loop = asyncio.get_running_loop()
    lags: list[float] = []
    done = asyncio.Event()

    async def ticker() -> None:
        while not done.is_set():
            due = loop.time() + TICK_S
            await asyncio.sleep(TICK_S)
            lags.append(max(0.0, loop.time() - due))

    tick = asyncio.create_task(ticker())
    started = time.perf_counter()
    for scan in scans:
        odom[0] = scan.odom
        for _ in range(3):
            live.on_scan(_lidar(scan, loop.time()))
            await asyncio.sleep(0.05)
    await live.settle(loop.time() - 1.0, timeout_s=30.0)  # the last key scan's work done
    done.set()
    await tick
    live.close()
    ordered = sorted(lags)
    work = sorted(live.key_work_s)
    return {"wall_s": round(time.perf_counter() - started, 1),
            "key_scans": len(live.mapper.key_scans),
            "lag_p50_ms": round(statistics.median(ordered) * 1000, 2),
            "lag_p99_ms": round(ordered[int(0.99 * (len(ordered) - 1))] * 1000, 2),
            "lag_max_ms": round(ordered[-1] * 1000, 2),
            "key_work_median_ms": round(statistics.median(work) * 1000, 1),
            "key_work_p95_ms": round(work[int(0.95 * (len(work) - 1))] * 1000, 1)}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=60.0, help="of the depot drive")
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args()
    recording = record_run(max_duration_s=args.seconds)
    scans = recording.scans
    figures: dict[str, Any] = {"scans": len(scans)}
    for name, cls in (("executor", LiveMapping), ("baseline_on_the_loop", InlineMapping)):
        odom: list[Any] = [scans[0].odom]
        live = cls(lambda o=odom: o[0], start=scans[0].odom)
        figures[name] = asyncio.run(_replay(live, scans, odom))
    if args.json:
        print(json.dumps(figures))
        return
    for key, value in figures.items():
        print(f"{key:22s} {value}")


if __name__ == "__main__":
    main()
