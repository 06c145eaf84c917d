"""Global planning on the occupancy grid: A* with a hard clearance and a soft inflation cost.

A cell the robot may stand on is one whose centre is at least ``clearance_m`` plus half a
cell's diagonal from every obstacle cell's centre; then every point of a path through such
cells (and of the straight cuts smoothing makes through them) is at least ``clearance_m`` from
every obstacle cell's centre (seed property 10). Beyond that, cells cost more the nearer they
are, ``1 + inflation_weight`` at the edge down to 1 ``inflation_m`` farther: paths keep off
walls where there is room. A path starts exactly at the start and ends exactly at the goal.
No path is a ``NoPath`` that says why.

Keep-out zones (``KeepoutCells``, from a keep-out mask: ``behaviours.nav.zones``) are never
entered, nor the band of ``keepout_margin_m`` round them; a robot that the tracking error put
in the band plans its way out of it (band cells then cost ``KEEPOUT_BAND_COST`` times more)
instead of failing.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass

import cv2
import numpy as np
import numpy.typing as npt

from behaviours.nav.astar import Search, search
from behaviours.nav.config import PlannerConfig
from behaviours.nav.distance_field import DistanceField
from behaviours.nav.grid import Grid
from behaviours.nav.smoothing import Point, path_length_m, shorten

REASONS = ("start_outside", "goal_outside", "start_in_collision", "goal_in_collision",
           "start_in_keepout", "goal_in_keepout", "disconnected")
HIERARCHY_CELLS = 1_000_000
"""Grids of at least this many cells are searched in two steps (``Planner._search``)."""
COARSE_CELLS = 4
CORRIDOR_M = 1.0
KEEPOUT_BAND_COST = 10.0
"""A cell of the margin round a keep-out zone costs this many times its own cost."""


class NoPath(Exception):
    """No path between two points; ``reason`` is one of ``REASONS``, the message says more."""

    def __init__(self, reason: str, message: str) -> None:
        super().__init__(message)
        self.reason = reason


@dataclass(frozen=True, slots=True)
class KeepoutCells:
    """A keep-out mask on the planner's grid: the cells ``inside`` a zone, and those ``near``
    one (inside, or within the margin)."""

    inside: npt.NDArray[np.bool_]
    near: npt.NDArray[np.bool_]


@dataclass(frozen=True, slots=True)
class Plan:
    """Waypoints in the map frame from the start to the goal, and how they were found."""

    points: list[Point]
    cost: float
    length_m: float
    expanded: int
    cells: int


class Planner:
    """Plans on one grid (the map, plus any obstacles seen since: ``with_obstacles``)."""

    def __init__(self, grid: Grid, config: PlannerConfig | None = None, *,
                 kernel: str | None = None, keepout: KeepoutCells | None = None) -> None:
        self.grid = grid
        self.config = config or PlannerConfig()
        self.kernel = kernel
        self.keepout = keepout
        self.field = DistanceField(grid)
        self.free, self.cost = cell_costs(self.field.distance_m, grid.resolution_m, self.config)
        self._escape: npt.NDArray[np.float64] | None = None
        if keepout is not None:
            # Leaving the margin (a start in it) may cross it, at a price; nothing else may.
            escape = self.cost.copy()
            escape[keepout.near] *= KEEPOUT_BAND_COST
            escape[keepout.inside] = math.inf
            self._escape = escape
            self.cost[keepout.near] = math.inf
            self.free &= ~keepout.near

    def with_obstacles(self, points: Iterable[Point]) -> Planner:
        """A planner for the same map with these map-frame points as obstacles too."""
        return Planner(self.grid.with_points(points), self.config, kernel=self.kernel,
                       keepout=self.keepout)

    def in_keepout(self, point: Point) -> bool:
        """Whether a map point lies in a keep-out zone's cell (on this grid)."""
        row, col = self.grid.cell_of(*point)
        return (self.keepout is not None and self.grid.inside(row, col)
                and bool(self.keepout.inside[row, col]))

    def plan(self, start: Point, goal: Point, *, smooth: bool = True) -> Plan:
        """The cheapest path from ``start`` to ``goal``; NoPath says why there is none.

        ``smooth=False`` leaves the cell centres as they are (``smoothed`` does the rest), for
        a caller that spreads the work over loop steps.
        """
        start_cell = self._standing_cell(start, "start")
        goal_cell = self._standing_cell(goal, "goal")
        cols = self.grid.cols
        cost = self.cost
        if self._escape is not None and not self.free[start_cell]:
            cost = self._escape  # the start is in a keep-out zone's margin: out of it first
        found = self._search(cost, start_cell[0] * cols + start_cell[1],
                             goal_cell[0] * cols + goal_cell[1])
        if not found.cells:
            msg = (f"no path from ({start[0]:.2f}, {start[1]:.2f}) to ({goal[0]:.2f}, "
                   f"{goal[1]:.2f}): they are not connected with {self.config.clearance_m} m "
                   f"clearance ({found.expanded} cells searched)")
            raise NoPath("disconnected", msg)
        centres = [self.grid.centre_of(*divmod(c, cols)) for c in found.cells]
        # The start lies in the first cell and the goal in the last: the legs to and from
        # their centres stay inside cells the robot may stand on.
        points = _dedupe([start, *centres, goal])
        plan = Plan(points, found.cost, path_length_m(points), found.expanded, len(found.cells))
        return self.smoothed(plan) if smooth else plan

    def smoothed(self, plan: Plan) -> Plan:
        """``plan`` with its corners cut where the grid allows (``PlannerConfig.smoothing``)."""
        if not self.config.smoothing:
            return plan
        points = shorten(self.grid, self.free, plan.points)
        return Plan(points, plan.cost, path_length_m(points), plan.expanded, plan.cells)

    def _search(self, cost: npt.NDArray[np.float64], start: int, goal: int) -> Search:
        """A* on the grid; on a large map (``HIERARCHY_CELLS``) first on blocks of
        ``COARSE_CELLS`` cells (a block is as dear as its dearest cell, so a block path is a
        path), then on the cells within ``CORRIDOR_M`` of that path only: a warehouse's
        far-apart goals expanded most of its 1.7 M cells. Should the corridor hold no path
        (a passage narrower than a block), the whole grid is searched."""
        res = self.grid.resolution_m
        if cost.size < HIERARCHY_CELLS:
            return search(cost, start, goal, res, self.kernel)
        corridor, coarse_expanded = self._corridor(cost, start, goal)
        if corridor is not None:
            found = search(np.where(corridor, cost, math.inf), start, goal, res, self.kernel)
            if found.cells:
                return Search(found.cells, found.cost, found.expanded + coarse_expanded)
        found = search(cost, start, goal, res, self.kernel)
        return Search(found.cells, found.cost, found.expanded + coarse_expanded)

    def _corridor(self, cost: npt.NDArray[np.float64], start: int, goal: int
                  ) -> tuple[npt.NDArray[np.bool_] | None, int]:
        """The fine cells within ``CORRIDOR_M`` of the block path (None: no block path)."""
        k = COARSE_CELLS
        rows, cols = cost.shape
        crow, ccol = -(-rows // k), -(-cols // k)
        padded = np.full((crow * k, ccol * k), math.inf)
        padded[:rows, :cols] = cost
        coarse = np.ascontiguousarray(padded.reshape(crow, k, ccol, k).max(axis=(1, 3)))
        (sr, sc), (gr, gc) = divmod(start, cols), divmod(goal, cols)
        # The start's and goal's own blocks may hold a wall cell: enterable all the same.
        for r, c in ((sr // k, sc // k), (gr // k, gc // k)):
            block = padded[r * k:(r + 1) * k, c * k:(c + 1) * k]
            coarse[r, c] = float(np.min(block)) if np.isfinite(block).any() else math.inf
        found = search(coarse, (sr // k) * ccol + sc // k, (gr // k) * ccol + gc // k,
                       self.grid.resolution_m * k, self.kernel)
        if not found.cells:
            return None, found.expanded
        on_path = np.zeros((crow, ccol), dtype=np.uint8)
        path = np.asarray(found.cells)
        on_path[path // ccol, path % ccol] = 1
        reach = max(1, math.ceil(CORRIDOR_M / (self.grid.resolution_m * k)))
        near = cv2.dilate(on_path, np.ones((2 * reach + 1, 2 * reach + 1), dtype=np.uint8))
        fine = np.repeat(np.repeat(near.astype(np.bool_), k, axis=0), k, axis=1)
        return fine[:rows, :cols], found.expanded

    def _standing_cell(self, point: Point, what: str) -> tuple[int, int]:
        row, col = self.grid.cell_of(*point)
        where = f"{what} ({point[0]:.2f}, {point[1]:.2f})"
        if not (math.isfinite(point[0]) and math.isfinite(point[1])) or \
                not self.grid.inside(row, col):
            x0, y0, x1, y1 = self.grid.bounds_m()
            msg = f"{where} is outside the map ({x0:.2f}..{x1:.2f}, {y0:.2f}..{y1:.2f})"
            raise NoPath(f"{what}_outside", msg)
        if self.keepout is not None and not self.free[row, col]:
            if self.keepout.inside[row, col]:
                msg = f"{where} is in a keep-out zone"
                raise NoPath(f"{what}_in_keepout", msg)
            if what == "start" and self._escape is not None \
                    and math.isfinite(self._escape[row, col]):
                return row, col  # in the margin round a zone: the path leads out of it
        if not self.free[row, col]:
            distance = float(self.field.distance_m[row, col])
            msg = (f"{where} is in collision: {distance:.2f} m from an obstacle, "
                   f"{self.config.clearance_m} m needed")
            raise NoPath(f"{what}_in_collision", msg)
        return row, col

    def clear_of(self, points: list[Point], obstacles: Iterable[Point]) -> bool:
        """True when no obstacle point is within the clearance of the path ``points``."""
        obs = np.asarray(list(obstacles), dtype=np.float64).reshape(-1, 2)
        if obs.shape[0] == 0 or len(points) < 2:
            return True
        return bool(min_distance_to_path(points, obs) >= self.config.clearance_m)


def cell_costs(distance_m: npt.NDArray[np.float32], resolution_m: float, config: PlannerConfig
               ) -> tuple[npt.NDArray[np.bool_], npt.NDArray[np.float64]]:
    """(cells the robot may stand on, the cost of entering each: inf where it may not)."""
    edge_m = config.clearance_m + resolution_m * math.sqrt(0.5)
    distance = distance_m.astype(np.float64)
    free: npt.NDArray[np.bool_] = distance >= edge_m
    if config.inflation_m > 0 and config.inflation_weight > 0:
        nearness = np.clip(1.0 - (distance - edge_m) / config.inflation_m, 0.0, 1.0)
        cost = 1.0 + config.inflation_weight * nearness
    else:
        cost = np.ones_like(distance)
    cost[~free] = math.inf
    return free, np.ascontiguousarray(cost)


def min_distance_to_path(points: list[Point], obstacles: npt.NDArray[np.float64]) -> float:
    """Shortest distance from any obstacle point to any segment of the path."""
    p = np.asarray(points, dtype=np.float64)
    a, b = p[:-1], p[1:]
    ab = b - a
    length2 = (ab * ab).sum(axis=1)
    rel = obstacles[:, None, :] - a[None, :, :]
    with np.errstate(divide="ignore", invalid="ignore"):
        t = np.clip((rel * ab[None]).sum(axis=2) / length2[None], 0.0, 1.0)
    t = np.where(length2[None] > 0, t, 0.0)
    nearest = a[None] + t[..., None] * ab[None]
    return float(np.sqrt(((obstacles[:, None, :] - nearest) ** 2).sum(axis=2)).min())


def _dedupe(points: list[Point]) -> list[Point]:
    out = [points[0]]
    for p in points[1:]:
        if p != out[-1]:
            out.append(p)
    if len(out) == 1:
        out.append(points[-1])  # start == goal: a path of one point, given twice
    return out
