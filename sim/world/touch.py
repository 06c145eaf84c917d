"""What a robot vacuum feels at its rim: the front bumper's two switches and the wall sensor.

The bumper covers the front half of the round body, split in the middle: something within
``BUMP_MARGIN_M`` of the rim in front of the left half presses the left switch, in front of
the right half the right one, and straight ahead (within ``BOTH_DEG``) both, as on a Roomba.
Walls, the dock's body and people press it; the dock's pads do not (the nose rests on them).
The wall sensor looks out of the right side, square to the heading, over a short range (a
Roomba's wall-following sensor; here a small time-of-flight sensor reporting centimetres).
"""

from __future__ import annotations

import math

import numpy as np

from sim.world.floor_plan import World
from sim.world.geometry import FloatArray, Pose, raycast

BUMP_MARGIN_M = 0.008  # the bumper's travel before its switch closes, and a step's reach
BOTH_DEG = 12.0
WALL_MIN_CM = 1.0
WALL_MAX_CM = 40.0
WALL_SENSOR_AHEAD_M = 0.05  # the sensor sits on the right rim, a little ahead of the axle


def obstacles(world: World) -> FloatArray:
    """Every segment a bumper can press on: the walls and the dock's body."""
    if world.dock is None:
        return world.walls
    return np.concatenate((world.walls, world.dock.outline()))


def bumpers(world: World, pose: Pose, radius_m: float) -> tuple[bool, bool]:
    """(left, right): which bumper switches are closed at this pose."""
    left = right = False
    reach_m = radius_m + BUMP_MARGIN_M
    for bearing in _touch_bearings(world, pose, reach_m):
        if abs(bearing) > math.pi / 2:
            continue  # behind the axle: the bumper only covers the front half
        if abs(bearing) <= math.radians(BOTH_DEG):
            left = right = True
        elif bearing > 0:
            left = True
        else:
            right = True
    return left, right


def wall_cm(world: World, pose: Pose, radius_m: float) -> float:
    """The right-side wall sensor: distance from the rim to what lies square to the right."""
    x, y = pose.to_world(WALL_SENSOR_AHEAD_M, -radius_m)
    angle = pose.heading_rad - math.pi / 2
    max_m = WALL_MAX_CM / 100
    hit_m = float(raycast(obstacles(world), x, y, np.array([angle]), max_m)[0])
    for person in world.people:
        if person.present:
            hit_m = min(hit_m, _ray_circle(x, y, angle, person.x_m, person.y_m,
                                           person.radius_m))
    return float(min(WALL_MAX_CM, max(WALL_MIN_CM, hit_m * 100)))


def _touch_bearings(world: World, pose: Pose, reach_m: float) -> list[float]:
    """Bearings (relative to the heading) of everything within ``reach_m`` of the centre."""
    out: list[float] = []
    segs = obstacles(world)
    if segs.shape[0]:
        x1, y1, x2, y2 = segs.T
        ex, ey = x2 - x1, y2 - y1
        length2 = ex * ex + ey * ey
        with np.errstate(divide="ignore", invalid="ignore"):
            t = np.clip(((pose.x_m - x1) * ex + (pose.y_m - y1) * ey) / length2, 0.0, 1.0)
        t = np.where(length2 > 0, t, 0.0)
        px, py = x1 + t * ex, y1 + t * ey
        near = np.hypot(px - pose.x_m, py - pose.y_m) <= reach_m
        for nx, ny in zip(px[near], py[near], strict=True):
            out.append(_bearing(pose, float(nx), float(ny)))
    for person in world.people:
        if person.present and pose.distance_to(person.x_m, person.y_m) <= (
                reach_m + person.radius_m):
            out.append(_bearing(pose, person.x_m, person.y_m))
    return out


def _bearing(pose: Pose, x_m: float, y_m: float) -> float:
    angle = math.atan2(y_m - pose.y_m, x_m - pose.x_m) - pose.heading_rad
    return (angle + math.pi) % (2 * math.pi) - math.pi


def _ray_circle(x: float, y: float, angle: float, cx: float, cy: float, r: float) -> float:
    dx, dy = math.cos(angle), math.sin(angle)
    fx, fy = x - cx, y - cy
    b = fx * dx + fy * dy
    c = fx * fx + fy * fy - r * r
    disc = b * b - c
    if disc < 0:
        return math.inf
    t = -b - math.sqrt(disc)
    return t if t >= 0 else math.inf

