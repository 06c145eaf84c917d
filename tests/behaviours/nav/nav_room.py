"""A small furnished room for localisation tests: wall segments, its map, and noisy scans.

Not symmetric on purpose (an alcove, a cabinet off-centre), so global localisation has one
answer. Scans are ray casts on the segments (the simulator's geometry) with sigma 10 mm noise
quantised to 1 mm, as the simulated LD19 makes them.
"""

from __future__ import annotations

import itertools
import math

import cv2
import numpy as np
import numpy.typing as npt

from behaviours.nav.localisation.likelihood_field import DistanceGrid
from hal.readings import LidarScan
from sim.world.geometry import raycast, segments_array

Segment = tuple[float, float, float, float]

WALLS: list[Segment] = [
    (0.0, 0.0, 6.0, 0.0), (6.0, 0.0, 6.0, 4.0), (6.0, 4.0, 2.5, 4.0),
    (2.5, 4.0, 2.5, 5.0), (2.5, 5.0, 0.0, 5.0), (0.0, 5.0, 0.0, 0.0),  # alcove top left
    (4.0, 1.4, 5.0, 1.4), (5.0, 1.4, 5.0, 2.0), (5.0, 2.0, 4.0, 2.0), (4.0, 2.0, 4.0, 1.4),
    (1.0, 1.0, 1.4, 1.0), (1.4, 1.0, 1.4, 1.4), (1.4, 1.4, 1.0, 1.4), (1.0, 1.4, 1.0, 1.0),
]
INSIDE = (3.0, 2.5)
RESOLUTION_M = 0.05
ORIGIN = (-0.525, -0.525)  # walls on whole metres fall on cell centres


def occupancy(walls: list[Segment] = WALLS, resolution_m: float = RESOLUTION_M,
              origin: tuple[float, float] = ORIGIN, size_m: tuple[float, float] = (7.0, 6.5)
              ) -> tuple[npt.NDArray[np.bool_], npt.NDArray[np.bool_]]:
    """(occupied, free) grids of the walls: cells a wall passes through; cells inside."""
    cols, rows = round(size_m[0] / resolution_m), round(size_m[1] / resolution_m)
    occupied = np.zeros((rows, cols), dtype=bool)
    for x1, y1, x2, y2 in walls:
        steps = int(math.hypot(x2 - x1, y2 - y1) / (resolution_m / 4)) + 2
        xs, ys = np.linspace(x1, x2, steps), np.linspace(y1, y2, steps)
        c = np.floor((xs - origin[0]) / resolution_m).astype(int)
        r = np.floor((ys - origin[1]) / resolution_m).astype(int)
        occupied[r, c] = True
    fill = np.where(occupied, 255, 0).astype(np.uint8)
    mask = np.zeros((rows + 2, cols + 2), dtype=np.uint8)
    seed = (int((INSIDE[0] - origin[0]) / resolution_m),
            int((INSIDE[1] - origin[1]) / resolution_m))
    cv2.floodFill(fill, mask, seed, 128)
    return occupied, fill == 128


def grid(robot_radius_m: float = 0.15) -> DistanceGrid:
    """The room's distance grid; free: inside and at least ``robot_radius_m`` from a wall."""
    occupied, inside = occupancy()
    g = DistanceGrid.from_occupancy(occupied, RESOLUTION_M, *ORIGIN)
    return DistanceGrid(g.distance_m, RESOLUTION_M, *ORIGIN,
                        free=inside & (g.distance_m >= robot_radius_m))


def scan_at(pose: tuple[float, float, float], rng: np.random.Generator, *,
            beams: int = 450, sigma_m: float = 0.01, max_range_m: float = 12.0,
            extra: list[Segment] = (), t_s: float = 0.0) -> LidarScan:  # type: ignore[assignment]
    """A 360 degree scan from ``pose`` (robot frame, CCW angles ascending from -pi)."""
    angles = -math.pi + np.arange(beams) * (2 * math.pi / beams)
    segs = segments_array([*WALLS, *extra])
    ranges = raycast(segs, pose[0], pose[1], angles + pose[2], max_range_m)
    ranges = np.round(ranges + rng.normal(0.0, sigma_m, beams), 3)
    ranges[ranges >= max_range_m] = np.nan
    return LidarScan(angles, ranges, np.zeros(beams, dtype=np.uint8), t_s)


def drive(path: list[tuple[float, float, float]], step_m: float = 0.05,
          step_rad: float = 0.1) -> list[tuple[float, float, float]]:
    """True poses every ``step_m``/``step_rad`` along straight legs between path poses."""
    out: list[tuple[float, float, float]] = [path[0]]
    for (x0, y0, t0), (x1, y1, t1) in itertools.pairwise(path):
        turn = math.remainder(t1 - t0, 2 * math.pi)
        n = max(1, int(max(math.hypot(x1 - x0, y1 - y0) / step_m, abs(turn) / step_rad)))
        for i in range(1, n + 1):
            f = i / n
            out.append((x0 + f * (x1 - x0), y0 + f * (y1 - y0), t0 + f * turn))
    return out


def odometry_of(truth: list[tuple[float, float, float]], rng: np.random.Generator,
                scale_err: float = 0.02, turn_err: float = 0.02
                ) -> list[tuple[float, float, float]]:
    """Odometry poses for a true path: each step's length and turn off by a few percent."""
    ox, oy, ot = 0.0, 0.0, 0.0
    out = [(ox, oy, ot)]
    for (x0, y0, t0), (x1, y1, t1) in itertools.pairwise(truth):
        c, s = math.cos(-t0), math.sin(-t0)
        fx, fy = c * (x1 - x0) - s * (y1 - y0), s * (x1 - x0) + c * (y1 - y0)
        dt = math.remainder(t1 - t0, 2 * math.pi)
        k = 1 + scale_err * (0.5 + rng.random())
        fx, fy, dt = fx * k, fy * k, dt * (1 + turn_err * rng.standard_normal())
        c, s = math.cos(ot), math.sin(ot)
        ox, oy = ox + c * fx - s * fy, oy + s * fx + c * fy
        ot += dt
        out.append((ox, oy, ot))
    return out
