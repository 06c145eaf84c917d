"""Plane geometry for the simulated world: ray casts, distances to segments and polylines."""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass
from typing import Any

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


def _crossings(segments: FloatArray, x_m: float, y_m: float, dx: Any, dy: Any
               ) -> tuple[Any, Any, Any]:
    """Where the line (x, y) + t (dx, dy) meets each segment: (t, u along the segment, valid).

    ``dx``/``dy`` may be arrays of shape (rays, 1): the result is then (rays, segments).
    """
    x1, y1, x2, y2 = segments.T
    ex, ey = x2 - x1, y2 - y1
    denom = dx * ey - dy * ex
    # A denominator near zero (parallel) overflows or divides by zero: ``valid`` drops those.
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        wx, wy = x1 - x_m, y1 - y_m
        t = (wx * ey - wy * ex) / denom
        u = (wx * dy - wy * dx) / denom
    valid = (np.abs(denom) > 1e-12) & (u >= 0) & (u <= 1)
    return t, u, valid


def raycast(
    segments: FloatArray, x_m: float, y_m: float, angles_rad: FloatArray, max_range_m: float
) -> FloatArray:
    """Distance along each ray to the nearest segment (``max_range_m`` where none is hit)."""
    angles = np.atleast_1d(np.asarray(angles_rad, dtype=np.float64))
    out = np.full(angles.shape, max_range_m, dtype=np.float64)
    if segments.shape[0] == 0:
        return out
    t, _u, valid = _crossings(segments, x_m, y_m, np.cos(angles)[:, None],
                              np.sin(angles)[:, None])
    nearest = np.where(valid & (t >= 0), t, np.inf).min(axis=1)
    result: FloatArray = np.minimum(out, nearest)
    return result


def segments_crossed(segments: FloatArray, x_m: float, y_m: float, to_x_m: float,
                     to_y_m: float, *, end_margin: float = 1e-6) -> int:
    """How many segments the straight path from one point to another passes through.

    A segment touching either end (within ``end_margin`` of the path) does not count: a
    beacon on a wall is not behind that wall.
    """
    if segments.shape[0] == 0:
        return 0
    t, _u, valid = _crossings(segments, x_m, y_m, to_x_m - x_m, to_y_m - y_m)
    return int(np.count_nonzero(valid & (t > end_margin) & (t < 1 - end_margin)))


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


def segment_distances(segments: FloatArray, x_m: float, y_m: float) -> FloatArray:
    """Distance from a point to each segment."""
    x1, y1, x2, y2 = segments.T
    ex, ey = x2 - x1, y2 - y1
    length2 = ex * ex + ey * ey
    with np.errstate(divide="ignore", invalid="ignore"):
        t = np.clip(((x_m - x1) * ex + (y_m - y1) * ey) / length2, 0.0, 1.0)
    t = np.where(length2 > 0, t, 0.0)
    out: FloatArray = np.hypot(x1 + t * ex - x_m, y1 + t * ey - y_m)
    return out


class SegmentSet:
    """Segments (rows x1, y1, x2, y2) asked for their distances to many points: what
    ``segment_distances`` derives from the segments alone is computed once."""

    def __init__(self, ends: FloatArray) -> None:
        self.ends = ends
        x1, y1, x2, y2 = (np.ascontiguousarray(col) for col in ends.T)
        self.x1, self.y1 = x1, y1
        self.ex, self.ey = x2 - x1, y2 - y1
        self.length2 = self.ex * self.ex + self.ey * self.ey

    def distances(self, x_m: float, y_m: float) -> FloatArray:
        """As ``segment_distances(ends, x_m, y_m)``, to the bit (the same float operations)."""
        ex, ey, length2 = self.ex, self.ey, self.length2
        with np.errstate(divide="ignore", invalid="ignore"):
            t = np.clip(((x_m - self.x1) * ex + (y_m - self.y1) * ey) / length2, 0.0, 1.0)
        t = np.where(length2 > 0, t, 0.0)
        out: FloatArray = np.hypot(self.x1 + t * ex - x_m, self.y1 + t * ey - y_m)
        return out


class NearestSegments:
    """``float(segments.distances(x, y).min())`` (``SegmentSet``), the same float, from the few
    segments that can hold the minimum near the point.

    The plane is cut into square cells of ``cell_m``; a cell's candidates are found the first
    time a point falls in it. Why the minimum over the candidates is the minimum over all, to
    the bit: let ``f_s(p)`` be the exact distance from ``p`` to segment ``s``, ``c`` the cell's
    centre, ``r`` its half-diagonal plus ``2 _MARGIN_M``, and ``m = min_s f_s(c)``. ``f_s`` is
    1-Lipschitz, so for every ``p`` of the cell (within ``_MARGIN_M`` of it: the cell index
    is rounded) ``|f_s(p) - f_s(c)| <= r`` and ``min_s f_s(p) <= m + r``. A segment is left
    out when its computed centre distance exceeds the computed minimum by more than
    ``2 r + _MARGIN_M``. Each computed distance is within ``eps`` of the exact one, ``eps``
    well under 1e-9 m for coordinates under 1e4 m (a few roundings of quantities of that
    size), and ``_MARGIN_M = 1e-6 m > 4 eps``: a left-out ``s`` has ``f_s(c) > m + 2r +
    _MARGIN_M - 2 eps``, so ``f_s(p) > m + r + _MARGIN_M - 2 eps >= min f(p) + _MARGIN_M -
    2 eps``, and its computed distance exceeds the computed minimum by more than
    ``_MARGIN_M - 4 eps > 0``: it is never the minimum. The candidates' distances are the
    ``SegmentSet.distances`` float operations one by one (elementwise IEEE operations give
    the same bits); ``np.hypot`` (libm's, which ``math.hypot`` is not) is taken only for
    those whose squared distance is within ``1e-9`` (relative) of the smallest: a squared
    distance is within 3 roundings of the exact one and libm's hypot within 1 ulp of it, so
    any other one's hypot is larger than the smallest's. Points out of range (not finite, or
    farther than 1e4 m) go to ``SegmentSet.distances``.

    A cell's candidates are chosen the same way among those of its block (``_BLOCK`` x
    ``_BLOCK`` cells, chosen over all segments): a segment that cannot hold the minimum
    anywhere in the block cannot in the cell, and at the cell's centre the exact minimum is a
    block candidate's; those distances are taken with ``math.hypot`` (any distance within
    ``eps`` of the exact one serves the choice).
    """

    _MARGIN_M = 1e-6
    _RANGE_M = 1e4
    _MAX_CELLS = 1 << 16  # bound the cache (a robot visits a few hundred cells)
    _BLOCK = 8

    def __init__(self, segments: SegmentSet, cell_m: float = 0.05) -> None:
        self.segments = segments
        self.cell_m = cell_m
        self._reach_m = math.sqrt(2.0) * cell_m + 5 * self._MARGIN_M  # 2 r + margin
        self._rows = list(zip(segments.x1.tolist(), segments.y1.tolist(),
                              segments.ex.tolist(), segments.ey.tolist(),
                              segments.length2.tolist(), strict=True))
        self._cells: dict[tuple[int, int], list[tuple[float, float, float, float, float]]] = {}
        self._blocks: dict[tuple[int, int], list[tuple[float, float, float, float, float]]] = {}

    def min_distance(self, x_m: float, y_m: float) -> float:
        """The distance from a point to the nearest segment (inf when there are none)."""
        if not self._rows:
            return math.inf
        if not (abs(x_m) < self._RANGE_M and abs(y_m) < self._RANGE_M):  # NaN goes there too
            return float(self.segments.distances(x_m, y_m).min())
        key = (math.floor(x_m / self.cell_m), math.floor(y_m / self.cell_m))
        rows = self._cells.get(key)
        if rows is None:
            rows = self._candidates(*key)
        near: list[tuple[float, float, float]] = []
        best_d2 = math.inf
        for x1, y1, ex, ey, length2 in rows:
            t = 0.0
            if length2 > 0:  # np.clip of the same quotient (a -0.0 may stay: hypot drops it)
                t = ((x_m - x1) * ex + (y_m - y1) * ey) / length2
                if t < 0.0:
                    t = 0.0
                elif t > 1.0:
                    t = 1.0
            dx = x1 + t * ex - x_m
            dy = y1 + t * ey - y_m
            d2 = dx * dx + dy * dy
            near.append((d2, dx, dy))
            if d2 < best_d2:  # noqa: PLR1730 (a comparison costs less than min() here)
                best_d2 = d2
        window = best_d2 * (1 + 1e-9) if best_d2 > 1e-200 else math.inf  # no underflow
        return min(float(np.hypot(dx, dy)) for d2, dx, dy in near if d2 <= window)

    def _candidates(self, ix: int, iy: int) -> list[tuple[float, float, float, float, float]]:
        """The segments that can hold the minimum for a point of cell (ix, iy)."""
        key = (ix // self._BLOCK, iy // self._BLOCK)
        block = self._blocks.get(key)
        if block is None:
            block = self._blocks[key] = self._block(*key)
        x_m, y_m = (ix + 0.5) * self.cell_m, (iy + 0.5) * self.cell_m
        centre = [_distance(row, x_m, y_m) for row in block]
        nearest_m = min(centre)
        rows = [row for row, d in zip(block, centre, strict=True)
                if d <= nearest_m + self._reach_m]
        if len(self._cells) >= self._MAX_CELLS:
            self._cells.clear()
            self._blocks.clear()
        self._cells[(ix, iy)] = rows
        return rows

    def _block(self, bx: int, by: int) -> list[tuple[float, float, float, float, float]]:
        """The segments that can hold the minimum for a point of block (bx, by)."""
        size_m = self._BLOCK * self.cell_m
        centre = self.segments.distances((bx + 0.5) * size_m, (by + 0.5) * size_m)
        reach_m = math.sqrt(2.0) * size_m + 5 * self._MARGIN_M
        return [self._rows[i] for i in np.flatnonzero(centre <= centre.min() + reach_m).tolist()]


def _distance(row: tuple[float, float, float, float, float], x_m: float, y_m: float) -> float:
    """From a point to a segment (x1, y1, ex, ey, length2), within ``eps`` of the exact."""
    x1, y1, ex, ey, length2 = row
    t = min(max(((x_m - x1) * ex + (y_m - y1) * ey) / length2, 0.0), 1.0) if length2 > 0 else 0.0
    return math.hypot(x1 + t * ex - x_m, y1 + t * ey - y_m)


def distance_to_segments(segments: FloatArray, x_m: float, y_m: float) -> float:
    """Shortest distance from a point to any segment (inf when there are none)."""
    if segments.shape[0] == 0:
        return math.inf
    return float(np.min(segment_distances(segments, x_m, y_m)))


def polyline_segments(points: list[tuple[float, float]], closed: bool) -> FloatArray:
    pts = list(points) + ([points[0]] if closed and len(points) > 2 else [])
    return segments_array([(a[0], a[1], b[0], b[1]) for a, b in itertools.pairwise(pts)])
