"""A recorded drive through Nav2's depot: LiDAR scans, wheel odometry and true poses.

A small driver steers the simulated body (``DiffDriveBody``: PWM in, wheels that slip, encoder
ticks out) round a route of waypoints by its true pose, as a technician would with a remote;
every ``1 / scan_hz`` s the simulated LD19's beams (``LidarRays``, the world's walls are the
map's occupied cells) are cast, with the LD19's noise (10 mm, read to 1 mm) and its 12 m
reach, and the odometry integrated from the encoder ticks is recorded with them. Odometry
starts at the true start pose, so the map's frame is the world's. No event loop: the body is
stepped by hand, which is all a recording needs, as fast as numpy casts the beams.
"""

from __future__ import annotations

import argparse
import math
import random
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import structlog

from behaviours.motion.moves import wrap
from behaviours.nav.icp import Pose as PoseTuple
from behaviours.nav.mapping.scan import Scan
from robotd.mapping.clf import write_clf
from sim.world.body import BodyParams, DiffDriveBody
from sim.world.floor_plan import World
from sim.world.geometry import Pose
from sim.world.lidar_rays import LidarRays

log = structlog.get_logger(__name__)

MAPS_DIR = Path(__file__).resolve().parent.parent / "maps"
DEPOT_LOOP: tuple[tuple[float, float], ...] = (
    (2.0, 6.8), (28.8, 6.8), (29.2, 9.2), (29.2, 13.8), (1.5, 13.8), (1.5, 6.8), (9.0, 6.8))
"""Round the depot's open hall: along the pallets, up the east wall, back along the north
wall and down the west wall to where it started, then on over its first metres again (the
loop closes there)."""
LD19_RANGE_M = 12.0
LD19_NOISE_M = 0.010


@dataclass(slots=True)
class Recording:
    scans: list[Scan] = field(default_factory=list)
    true_poses: dict[float, PoseTuple] = field(default_factory=dict)
    distance_m: float = 0.0
    duration_s: float = 0.0


def record_run(route: tuple[tuple[float, float], ...] = DEPOT_LOOP, *,
               map_yaml: Path = MAPS_DIR / "depot.yaml", world: World | None = None,
               seed: int = 1,
               speed_mps: float = 0.4, turn_rad_s: float = 0.6, scan_hz: float = 5.0,
               beams: int = 360, slip_std: float = 0.01, dt_s: float = 0.01,
               max_duration_s: float = 600.0) -> Recording:
    """Drive ``route`` on the map's world (or ``world``) and record it (start at the first
    waypoint facing the second)."""
    world = world if world is not None else World.from_table({"map": str(map_yaml)})
    x, y = route[0]
    heading = math.atan2(route[1][1] - y, route[1][0] - x)
    params = BodyParams(slip_std=slip_std)
    body = DiffDriveBody(world, Pose(x, y, heading), params, rng=random.Random(seed))
    lidar = LidarRays(world, body)
    noise = np.random.default_rng(seed)
    angles = -math.pi + 2 * math.pi * np.arange(beams) / beams
    per_tick_m = 2 * math.pi * params.wheel_radius_m / params.ticks_per_rev
    odom = (x, y, heading)
    ticks = body.encoder_ticks()
    out = Recording()
    target = 1
    t_s, next_scan_s = 0.0, 0.0
    while target < len(route) and t_s < max_duration_s:
        pose = body.pose
        if t_s >= next_scan_s - 1e-9:
            ranges = lidar(angles) + noise.normal(0.0, LD19_NOISE_M, beams)
            ranges = np.round(ranges, 3)
            ranges[~np.isfinite(ranges) | (ranges >= LD19_RANGE_M)] = LD19_RANGE_M
            stamp = round(t_s, 6)
            out.scans.append(Scan(stamp, ranges, float(angles[0]), 2 * math.pi / beams,
                                  LD19_RANGE_M, odom))
            out.true_poses[stamp] = (pose.x_m, pose.y_m, pose.heading_rad)
            next_scan_s += 1.0 / scan_hz
        gx, gy = route[target]
        dist = math.hypot(gx - pose.x_m, gy - pose.y_m)
        if dist < 0.05:
            target += 1
            continue
        error = wrap(math.atan2(gy - pose.y_m, gx - pose.x_m) - pose.heading_rad)
        if abs(error) > 0.2:
            v, w = 0.0, math.copysign(turn_rad_s, error)
        else:
            v, w = min(speed_mps, 0.8 * dist + 0.05), 2.0 * error
        left, right = v - w * params.wheel_base_m / 2, v + w * params.wheel_base_m / 2
        body.apply_pwm(_duty(left, params), _duty(right, params), left >= 0, right >= 0)
        body.step(dt_s)
        t_s += dt_s
        now = body.encoder_ticks()
        odom = _odometry(odom, (now[0] - ticks[0]) * per_tick_m,
                         (now[1] - ticks[1]) * per_tick_m, params.wheel_base_m)
        ticks = now
    out.distance_m = body.distance_m
    out.duration_s = t_s
    log.info("mapping.recorded", scans=len(out.scans), distance_m=round(body.distance_m, 2),
             duration_s=round(t_s, 1), collisions=len(body.collisions))
    return out


def _duty(mps: float, params: BodyParams) -> int:
    if abs(mps) < 1e-4:
        return 0
    span = 255 - params.deadband_pwm
    return min(255, params.deadband_pwm + 1 + round(abs(mps) / params.max_wheel_speed_mps * span))


def _odometry(odom: PoseTuple, left_m: float, right_m: float, wheel_base_m: float
              ) -> PoseTuple:
    d = (left_m + right_m) / 2
    dtheta = (right_m - left_m) / wheel_base_m
    mid = odom[2] + dtheta / 2
    return (odom[0] + d * math.cos(mid), odom[1] + d * math.sin(mid), wrap(odom[2] + dtheta))


def write_recording(recording: Recording, path: Path) -> Path:
    """The recording as a CARMEN log: ROBOTLASER1 scans, each followed by its TRUEPOS."""
    path.parent.mkdir(parents=True, exist_ok=True)
    with path.open("w", encoding="ascii") as stream:
        write_clf(stream, recording.scans, recording.true_poses)
    return path


def main(argv: list[str] | None = None) -> int:
    """``python -m sim.mapping.depot_run OUT.clf [--seed N] [--slip-std S]``."""
    parser = argparse.ArgumentParser(prog="python -m sim.mapping.depot_run",
                                     description="record a depot run as a CARMEN log")
    parser.add_argument("out", type=Path)
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--slip-std", type=float, default=0.01)
    args = parser.parse_args(argv)
    recording = record_run(seed=args.seed, slip_std=args.slip_std)
    write_recording(recording, args.out)
    print(f"{args.out}: {len(recording.scans)} scans, {recording.distance_m:.1f} m in "
          f"{recording.duration_s:.1f} s")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
