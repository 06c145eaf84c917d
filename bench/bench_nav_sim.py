"""``bench_nav.py --part sim``: the simulated LiDAR's cost per scan, the nav scenario's speed.

- ``rays``: one 360 deg scan (450 beams of the LD19 at 10 Hz) cast in a world, in the groups
  the ``SimLd19`` asks for (one per 20 ms of line: ~90 beams), from random free poses: the
  nav room (walls, boxes, a walker's legs) and the TurtleBot3 map world (its occupied cells'
  sides: ~1000 segments). ``packets``: the same scan as bytes (rays, noise, packing, CRC).
- ``scenario``: ``robotd sim nav`` run in this process (no report), virtual seconds per
  wall and per CPU second (the target: >= 20x CPU).
"""

from __future__ import annotations

import argparse
import gc
import math
import random
import statistics
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np

from sim.devices.ld19 import SimLd19
from sim.scenario import load_scenario
from sim.world.body import DiffDriveBody
from sim.world.floor_plan import World
from sim.world.geometry import Pose
from sim.world.lidar_rays import LidarRays
from sim.world.walkers import Walk

BEAMS_PER_SCAN = 450
GROUP = 90


def _free_poses(world: World, count: int, seed: int) -> list[Pose]:
    rng = random.Random(seed)
    out: list[Pose] = []
    while len(out) < count:
        x = rng.uniform(world.x_min_m, world.x_min_m + world.width_m)
        y = rng.uniform(world.y_min_m, world.y_min_m + world.height_m)
        if world.clearance_m(x, y) > 0.3:
            out.append(Pose(x, y, rng.uniform(-math.pi, math.pi)))
    return out


def rays_per_scan(world: World, scans: int, seed: int = 1) -> dict[str, Any]:
    """ms per 450-beam scan (cast in groups of 90), and per scan as LD19 bytes."""
    body = DiffDriveBody(world, Pose(0, 0, 0))
    rays = LidarRays(world, body, clock=lambda: 3.0)
    angles = np.radians(np.arange(BEAMS_PER_SCAN) * 360.0 / BEAMS_PER_SCAN)
    cast_ms, packet_ms = [], []
    ld19 = SimLd19(rays, seed=seed)
    for pose in _free_poses(world, scans, seed):
        body.pose = pose
        t0 = time.perf_counter()
        for i in range(0, BEAMS_PER_SCAN, GROUP):
            rays(angles[i:i + GROUP])
        cast_ms.append((time.perf_counter() - t0) * 1000)
        t0 = time.perf_counter()
        for _ in range(5):
            ld19.packets(BEAMS_PER_SCAN // 12 // 5 + 1)
        packet_ms.append((time.perf_counter() - t0) * 1000)
    return {"segments": int(world.walls.shape[0]), "scans": scans,
            "rays_p50_ms": round(statistics.median(cast_ms), 3),
            "rays_p95_ms": round(float(np.percentile(cast_ms, 95)), 3),
            "packets_p50_ms": round(statistics.median(packet_ms), 3),
            "cpu_share_at_10hz_pct": round(statistics.median(packet_ms) * 10 / 1000 * 100, 2)}


def scenario_speed(name: str, runs: int) -> dict[str, Any]:
    """Virtual s per wall s and per CPU s of ``robotd sim <name>`` (seeds 1..runs)."""
    from sim import runner as sim_runner
    from sim import vclock
    from sim.console import SimConsole

    scenario = load_scenario(name)
    wall_f, cpu_f, oks = [], [], []
    for i in range(runs):
        args = argparse.Namespace(scenario=name, seed=i + 1, realtime=False, speed=None,
                                  report=None, quiet=True, socket=None, config=None, mcu="fake")
        gc.collect()
        w0, c0 = time.perf_counter(), time.process_time()
        with tempfile.TemporaryDirectory(prefix="bench-nav-") as workdir:
            result = vclock.run(sim_runner._run(args, scenario, SimConsole(quiet=True),
                                                Path(workdir)))
        wall, cpu = time.perf_counter() - w0, time.process_time() - c0
        if isinstance(result, int):
            return {"error": f"exit {result}"}
        oks.append(result.ok)
        wall_f.append(result.sim_s / wall)
        cpu_f.append(result.sim_s / cpu)
    return {"runs": runs, "ok": all(oks), "speed_wall_x": round(statistics.median(wall_f), 1),
            "speed_cpu_x": round(statistics.median(cpu_f), 1)}


def sim_part(scans: int, runs: int) -> dict[str, Any]:
    room = load_scenario("nav").world
    for person in room.people:
        person.walk = Walk(((person.x_m, person.y_m), (4.1, 0.4)), 0.6, 0.0)
    tb3 = load_scenario("nav-map").world
    return {"rays_nav_room": rays_per_scan(room, scans),
            "rays_turtlebot3_map": rays_per_scan(tb3, scans),
            "scenario_nav": scenario_speed("nav", runs)}


def report(result: dict[str, Any]) -> None:
    for key in ("rays_nav_room", "rays_turtlebot3_map"):
        r = result[key]
        print(f"{key}: {r['segments']} segments, {r['scans']} scans: cast p50 "
              f"{r['rays_p50_ms']} ms p95 {r['rays_p95_ms']} ms per 450-beam scan; as LD19 "
              f"bytes p50 {r['packets_p50_ms']} ms ({r['cpu_share_at_10hz_pct']} % of a core "
              f"at 10 scans/s)")
    s = result["scenario_nav"]
    print(f"scenario nav: {s}")
