"""Monte Carlo localisation update and people detection cost: figures, not pass/fail.

    .venv/bin/python bench/bench_nav_mcl.py [--updates N] [--json]
    (and ``bench/bench_nav.py --part mcl``, which calls ``mcl_part``)

``mcl``: one filter update as the localisation service runs it on each scan once the robot
has moved (``Localiser.on_scan``: 60 beams picked from a 450-point scan, odometry motion
model, likelihood field over particles x beams, KLD-sized low-variance resampling with
augmented-MCL recovery, the estimate, the scan match at the fused pose), with the particle
count held at 500 and at 2000 (min = max). The map is a 10 x 10 m office at 0.05 m cells
(walls with doorways, furniture), the scans are ray casts from a robot driving a loop with
10 mm noise; the odometry is 2 % off. Per update, after 20 warm-up updates, p50 / p95 / max
over N updates of the wall-clock time and of the thread's CPU time (``time.thread_time``: on
a machine shared with other work the wall-clock tail is mostly the time the process waited
for a core). Also: the pose error at the end (a sanity check),
and ``people``: the people detector on the same scans with a walker in view.
"""

from __future__ import annotations

import argparse
import json
import math
import statistics
import time
from typing import Any

import numpy as np

from behaviours.nav.distance_field import DistanceField
from behaviours.nav.grid import Grid
from behaviours.nav.localisation.config import LocalisationConfig, PeopleConfig
from behaviours.nav.localisation.filter import Localiser
from behaviours.nav.localisation.likelihood_field import DistanceGrid
from behaviours.nav.localisation.people import PeopleTracker
from hal.readings import LidarScan
from sim.world.geometry import raycast, segments_array

RESOLUTION_M = 0.05
Segment = tuple[float, float, float, float]


def office() -> list[Segment]:
    """10 x 10 m: outer walls, a cross of inner walls with doorways, some furniture."""
    walls: list[Segment] = [(0, 0, 10, 0), (10, 0, 10, 10), (10, 10, 0, 10), (0, 10, 0, 0),
                            (5, 0, 5, 2), (5, 3, 5, 7), (5, 8, 5, 10),
                            (0, 5, 1.5, 5), (2.5, 5, 7.5, 5), (8.5, 5, 10, 5)]
    rng = np.random.default_rng(4)
    for _ in range(12):
        x, y = rng.uniform(0.5, 8.5), rng.uniform(0.5, 8.5)
        if abs(x - 2.0) < 1.2 or abs(y - 2.0) < 1.2:
            continue  # keep the loop the robot drives clear
        w, h = rng.uniform(0.4, 1.0), rng.uniform(0.3, 0.8)
        walls += [(x, y, x + w, y), (x + w, y, x + w, y + h), (x + w, y + h, x, y + h),
                  (x, y + h, x, y)]
    return walls


def loop_path(steps: int) -> list[tuple[float, float, float]]:
    """Laps of a 2 x 2 m square in the lower-left room (turning at the corners), 5 cm steps."""
    out: list[tuple[float, float, float]] = []
    for i in range(steps):
        s = (i * 0.05) % 8.0  # perimeter of a 2 x 2 m square
        side, f = int(s // 2.0), (s % 2.0)
        x0, y0 = [(2.0, 2.0), (4.0, 2.0), (4.0, 4.0), (2.0, 4.0)][side]
        heading = side * math.pi / 2
        out.append((x0 + f * math.cos(heading), y0 + f * math.sin(heading), heading))
    return out


def scan(segs: np.ndarray, pose: tuple[float, float, float], rng: np.random.Generator,
         t_s: float) -> LidarScan:
    angles = -math.pi + np.arange(450) * (2 * math.pi / 450)
    ranges = raycast(segs, pose[0], pose[1], angles + pose[2], 12.0)
    ranges = np.round(ranges + rng.normal(0, 0.01, 450), 3)
    ranges[ranges >= 12.0] = np.nan
    return LidarScan(angles, ranges, np.zeros(450, dtype=np.uint8), t_s)


def figures(times_ms: list[float]) -> dict[str, float]:
    ordered = sorted(times_ms)
    p95 = ordered[min(len(ordered) - 1, math.ceil(0.95 * len(ordered)) - 1)]
    return {"p50_ms": round(statistics.median(ordered), 3), "p95_ms": round(p95, 3),
            "max_ms": round(ordered[-1], 3), "n": len(ordered)}


def run_mcl(particles: int, updates: int, grid: DistanceGrid, walls: list[Segment]
            ) -> dict[str, Any]:
    rng = np.random.default_rng(particles)
    config = LocalisationConfig(min_particles=particles, max_particles=particles,
                                update_min_d_m=0.0, update_min_a_deg=0.0)
    loc = Localiser(grid, config)
    truth = loop_path(updates + 20)
    loc.start_at(truth[0][0] + 0.1, truth[0][1] - 0.1, truth[0][2] + 0.05)
    segs = segments_array(walls)
    scans = [scan(segs, p, rng, i * 0.1) for i, p in enumerate(truth)]
    odom: list[tuple[float, float, float]] = []
    for p in truth:  # 2 % long odometry in its own frame (starts at the origin)
        odom.append((1.02 * (p[0] - truth[0][0]), 1.02 * (p[1] - truth[0][1]), p[2]))
    times: list[float] = []
    cpu: list[float] = []
    for i, (o, s) in enumerate(zip(odom, scans, strict=True)):
        start, start_cpu = time.perf_counter(), time.thread_time()
        loc.on_scan(o, s, i * 0.1)
        elapsed = (time.perf_counter() - start) * 1000.0
        if i >= 20:
            times.append(elapsed)
            cpu.append((time.thread_time() - start_cpu) * 1000.0)
    end = loc.pose_array(odom[-1])
    t = truth[-1]
    return {**figures(times), "cpu": figures(cpu), "particles": len(loc.particles),
            "status": loc.status,
            "final_error_m": round(math.hypot(end[0] - t[0], end[1] - t[1]), 4),
            "final_error_deg": round(abs(math.degrees(math.remainder(end[2] - t[2],
                                                                       2 * math.pi))), 2)}


def run_people(scans_n: int, grid: DistanceGrid, walls: list[Segment]) -> dict[str, Any]:
    rng = np.random.default_rng(9)
    tracker = PeopleTracker(PeopleConfig(), grid)
    times: list[float] = []
    seen = 0
    pose = (2.0, 2.0, 0.0)
    for i in range(scans_n):
        x = 2.5 + 0.02 * (i % 100)
        legs: list[Segment] = []
        for cx, cy in ((x, 3.0), (x + 0.2, 3.05)):
            pts = [(cx + 0.06 * math.cos(a), cy + 0.06 * math.sin(a))
                   for a in np.linspace(0, 2 * math.pi, 12, endpoint=False)]
            legs += [(*pts[k], *pts[(k + 1) % 12]) for k in range(12)]
        s = scan(segments_array([*walls, *legs]), pose, rng, i * 0.1)
        start = time.perf_counter()
        people = tracker.update(s, np.array(pose), i * 0.1)
        times.append((time.perf_counter() - start) * 1000.0)
        seen += bool(people)
    return {**figures(times), "scans_with_a_person": seen}


def mcl_part(updates: int = 200) -> dict[str, Any]:
    walls = office()
    field = DistanceField(Grid.from_segments(walls, RESOLUTION_M))
    grid = DistanceGrid.from_field(field)
    return {"map_cells": list(grid.shape),
            "mcl_500": run_mcl(500, updates, grid, walls),
            "mcl_2000": run_mcl(2000, updates, grid, walls),
            "people": run_people(updates, grid, walls)}


def report(result: dict[str, Any], *, as_json: bool) -> None:
    """Print ``mcl_part``'s figures (``bench_nav.py --part mcl`` prints them the same)."""
    if as_json:
        print(json.dumps({"mcl": result}, indent=2))
        return
    print(f"map {result['map_cells'][0]} x {result['map_cells'][1]} cells of {RESOLUTION_M} m")
    for name in ("mcl_500", "mcl_2000", "people"):
        f = result[name]
        extra = (f"; end error {f['final_error_m']} m / {f['final_error_deg']} deg, {f['status']}"
                 if name != "people" else f"; {f['scans_with_a_person']} scans with a person")
        print(f"  {name:9s} p50 {f['p50_ms']:7.2f} ms  p95 {f['p95_ms']:7.2f} ms  "
              f"max {f['max_ms']:7.2f} ms  (n={f['n']}){extra}")
        if "cpu" in f:
            c = f["cpu"]
            print(f"  {'  cpu':9s} p50 {c['p50_ms']:7.2f} ms  p95 {c['p95_ms']:7.2f} ms  "
                  f"max {c['max_ms']:7.2f} ms")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--updates", type=int, default=200)
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args()
    report(mcl_part(args.updates), as_json=args.json)


if __name__ == "__main__":
    main()
