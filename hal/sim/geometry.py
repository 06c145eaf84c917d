"""Plane geometry for the simulated world: ray casts, distances to segments and polylines."""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

FloatArray = npt.NDArray[np.float64]


@dataclass(frozen=True, slots=True)
class Pose:
    """Position (m) and heading (rad, counter-clockwise from +x) on the floor plan."""

    x_m: float
    y_m: float
    heading_rad: float

    def distance_to(self, x_m: float, y_m: float) -> float:
        return math.hypot(self.x_m - x_m, self.y_m - y_m)

    def to_world(self, forward_m: float, left_m: float) -> tuple[float, float]:
        """A point given in the robot's frame, in world coordinates."""
        c, s = math.cos(self.heading_rad), math.sin(self.heading_rad)
        return self.x_m + c * forward_m - s * left_m, self.y_m + s * forward_m + c * left_m


def wrap_angle(angle_rad: float) -> float:
    """Angle folded into [-pi, pi)."""
    return (angle_rad + math.pi) % (2 * math.pi) - math.pi


def segments_array(segments: list[tuple[float, float, float, float]]) -> FloatArray:
    if not segments:
        return np.zeros((0, 4), dtype=np.float64)
    return np.asarray(segments, dtype=np.float64).reshape(-1, 4)


def raycast(
    segments: FloatArray, x_m: float, y_m: float, angles_rad: FloatArray, max_range_m: float
) -> FloatArray:
    """Distance along each ray to the nearest segment (``max_range_m`` where none is hit)."""
    angles = np.atleast_1d(np.asarray(angles_rad, dtype=np.float64))
    out = np.full(angles.shape, max_range_m, dtype=np.float64)
    if segments.shape[0] == 0:
        return out
    dx = np.cos(angles)[:, None]
    dy = np.sin(angles)[:, None]
    x1, y1, x2, y2 = (segments[:, i][None, :] for i in range(4))
    ex, ey = x2 - x1, y2 - y1
    denom = dx * ey - dy * ex
    with np.errstate(divide="ignore", invalid="ignore"):
        wx, wy = x1 - x_m, y1 - y_m
        t = (wx * ey - wy * ex) / denom
        u = (wx * dy - wy * dx) / denom
    hit = (np.abs(denom) > 1e-12) & (t >= 0) & (u >= 0) & (u <= 1)
    t = np.where(hit, t, np.inf)
    nearest = t.min(axis=1)
    result: FloatArray = np.minimum(out, nearest)
    return result


def raycast_one(segments: list[tuple[float, float, float, float]], x_m: float, y_m: float,
                angle_rad: float, max_range_m: float) -> float:
    """``raycast`` for one ray over segments as a list of tuples (``segments.tolist()``).

    A sensor model casts one ray many times a second; NumPy's per-call cost is ten times the
    arithmetic at that size.
    """
    dx, dy = math.cos(angle_rad), math.sin(angle_rad)
    nearest = max_range_m
    for x1, y1, x2, y2 in segments:
        ex, ey = x2 - x1, y2 - y1
        denom = dx * ey - dy * ex
        if abs(denom) > 1e-12:
            wx, wy = x1 - x_m, y1 - y_m
            t = (wx * ey - wy * ex) / denom
            u = (wx * dy - wy * dx) / denom
            if 0 <= t < nearest and 0 <= u <= 1:
                nearest = t
    return nearest


def distance_to_segments(segments: FloatArray, x_m: float, y_m: float) -> float:
    """Shortest distance from a point to any segment (inf when there are none)."""
    if segments.shape[0] == 0:
        return math.inf
    x1, y1, x2, y2 = segments.T
    ex, ey = x2 - x1, y2 - y1
    length2 = ex * ex + ey * ey
    with np.errstate(divide="ignore", invalid="ignore"):
        t = np.clip(((x_m - x1) * ex + (y_m - y1) * ey) / length2, 0.0, 1.0)
    t = np.where(length2 > 0, t, 0.0)
    px, py = x1 + t * ex, y1 + t * ey
    return float(np.min(np.hypot(px - x_m, py - y_m)))


def polyline_segments(points: list[tuple[float, float]], closed: bool) -> FloatArray:
    pts = list(points) + ([points[0]] if closed and len(points) > 2 else [])
    return segments_array([(a[0], a[1], b[0], b[1]) for a, b in itertools.pairwise(pts)])
