"""Line of sight on the grid, and paths shortened by it without giving up the clearance.

A segment is clear when every cell it passes through (exactly: each stretch between two grid
lines it crosses; a corner it only touches does not count) is one the planner may stand on.
Such cells are at least the clearance plus half a cell's diagonal from every obstacle cell's
centre, so every point of a clear segment is at least the clearance from them.
"""

from __future__ import annotations

import itertools
import math

import numpy as np
import numpy.typing as npt

from behaviours.nav.grid import Grid

Point = tuple[float, float]


def segment_cells(grid: Grid, a: Point, b: Point
                  ) -> tuple[npt.NDArray[np.intp], npt.NDArray[np.intp]]:
    """(rows, cols) of every cell the segment a-b passes through, in order."""
    res = grid.resolution_m
    ax, ay = (a[0] - grid.origin_x_m) / res, (a[1] - grid.origin_y_m) / res
    bx, by = (b[0] - grid.origin_x_m) / res, (b[1] - grid.origin_y_m) / res
    dx, dy = bx - ax, by - ay
    ts = [np.array([0.0, 1.0])]
    if dx != 0.0:
        lines = np.arange(math.floor(min(ax, bx)) + 1, math.ceil(max(ax, bx)))
        ts.append((lines - ax) / dx)
    if dy != 0.0:
        lines = np.arange(math.floor(min(ay, by)) + 1, math.ceil(max(ay, by)))
        ts.append((lines - ay) / dy)
    t = np.unique(np.concatenate(ts))
    keep = np.diff(t) > 1e-9  # stretches of length 0: a corner touched, not entered
    mid = (t[:-1][keep] + t[1:][keep]) / 2
    if mid.size == 0:
        mid = np.array([0.0])
    cols = np.floor(ax + mid * dx).astype(np.intp)
    rows = np.floor(ay + mid * dy).astype(np.intp)
    return rows, cols


def line_of_sight(grid: Grid, free: npt.NDArray[np.bool_], a: Point, b: Point) -> bool:
    """True when every cell the segment passes through is inside the grid and ``free``."""
    rows, cols = segment_cells(grid, a, b)
    if rows.min() < 0 or cols.min() < 0 or rows.max() >= grid.rows or cols.max() >= grid.cols:
        return False
    return bool(free[rows, cols].all())


def shorten(grid: Grid, free: npt.NDArray[np.bool_], points: list[Point]) -> list[Point]:
    """The path with corners cut where the line of sight allows; same first and last point.

    From each kept point, the next is the farthest one found by doubling the step while the
    view is clear and then halving back (about 2 log n sight checks per kept point).
    """
    if len(points) <= 2:
        return list(points)
    out = [points[0]]
    i, last = 0, len(points) - 1
    while i < last:
        step, best = 1, i + 1
        while i + step <= last and line_of_sight(grid, free, points[i], points[i + step]):
            best = i + step
            step *= 2
        low, high = best, min(i + step, last + 1)  # clear at low; not known clear past it
        while high - low > 1:
            mid = (low + high) // 2
            if line_of_sight(grid, free, points[i], points[mid]):
                low = mid
            else:
                high = mid
        out.append(points[low])
        i = low
    return out


def path_length_m(points: list[Point]) -> float:
    return sum(math.dist(p, q) for p, q in itertools.pairwise(points))
