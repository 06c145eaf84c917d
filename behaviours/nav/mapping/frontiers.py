"""Frontiers of a map being made: where the robot should go next to see more.

A frontier cell is a free cell next to an unknown one (Yamauchi 1997). Frontier cells are
grouped (8-connected) and groups smaller than ``min_frontier_m`` of edge are dropped (a few
cells a grazing beam left unknown behind a pillar). The robot cannot stand on a frontier: the
planner treats unknown as blocked, so a frontier cell lies within the clearance of a blocked
one. The goal is therefore the nearest cell the robot can stand on, that it can reach (the
planner's standable cells connected to where it stands), within ``reach_m`` of a frontier
group, not within ``min_move_m`` of the robot (it is there already) and not near a goal that
was given up (``avoid``). Both the frontiers and the planner's grid are taken from the map
``filled`` in (the gaps between far beams are no frontier).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import cv2
import numpy as np
import numpy.typing as npt

from behaviours.nav.planner import Planner
from hal.occupancy_map import FREE, OCCUPIED, UNKNOWN, OccupancyMap

Point = tuple[float, float]


@dataclass(frozen=True, slots=True)
class FrontierConfig:
    min_frontier_m: float = 0.5
    reach_m: float = 0.6
    min_move_m: float = 0.5
    avoid_m: float = 1.0


@dataclass(frozen=True, slots=True)
class FrontierGoal:
    """The chosen goal, and how many frontier cells (in groups kept) the map had."""

    goal: Point | None
    frontier_cells: int
    groups: int
    candidates: int


def filled(occupancy: OccupancyMap, robot: Point, *, gap_cells: int = 5,
           footprint_m: float = 0.7) -> OccupancyMap:
    """The map with the unknown specks between a fan's beams made free: far from the robot
    its beams (1 degree apart: 9 cm at 5 m, 21 cm at 12 m) leave unknown cells between them
    that are neither a frontier nor an obstacle. An unknown cell that a closing of the known
    cells (``gap_cells`` square) covers, and that no occupied cell touches, is taken as free."""
    cells = occupancy.cells
    known = (cells != UNKNOWN).astype(np.uint8)
    kernel = np.ones((gap_cells, gap_cells), np.uint8)
    closed = cv2.morphologyEx(known, cv2.MORPH_CLOSE, kernel).astype(np.bool_)
    near_wall = cv2.dilate((cells == OCCUPIED).astype(np.uint8),
                           np.ones((3, 3), np.uint8)).astype(np.bool_)
    out = cells.copy()
    out[(cells == UNKNOWN) & closed & ~near_wall] = FREE
    res = occupancy.resolution_m
    rows, cols = cells.shape
    ys = occupancy.origin_y_m + (np.arange(rows) + 0.5) * res
    xs = occupancy.origin_x_m + (np.arange(cols) + 0.5) * res
    around = np.hypot(xs[None, :] - robot[0], ys[:, None] - robot[1]) <= footprint_m
    out[around & (cells == UNKNOWN)] = FREE
    return OccupancyMap(out, occupancy.resolution_m, occupancy.origin_x_m,
                        occupancy.origin_y_m, occupancy.source)


def frontier_cells(occupancy: OccupancyMap) -> npt.NDArray[np.bool_]:
    """Free cells with an unknown cell among their 8 neighbours that no occupied cell touches
    (an unknown speck at a wall's foot, where beams stop a cell short, leads nowhere)."""
    cells = occupancy.cells
    eight = np.ones((3, 3), np.uint8)
    near_wall = cv2.dilate((cells == OCCUPIED).astype(np.uint8), eight).astype(np.bool_)
    open_unknown = ((cells == UNKNOWN) & ~near_wall).astype(np.uint8)
    near_unknown = cv2.dilate(open_unknown, eight).astype(np.bool_)
    out: npt.NDArray[np.bool_] = (cells == FREE) & near_unknown
    return out


def choose_frontier(occupancy: OccupancyMap, planner: Planner, robot: Point,
                    avoid: Sequence[Point] = (), config: FrontierConfig | None = None
                    ) -> FrontierGoal:
    """The nearest reachable standing point next to a frontier, or None when none is left.

    ``planner`` must plan on ``occupancy`` (same grid) with unknown cells as obstacles."""
    c = config or FrontierConfig()
    grid = planner.grid
    res = grid.resolution_m
    frontier = frontier_cells(occupancy)
    count, labels, stats, _ = cv2.connectedComponentsWithStats(frontier.astype(np.uint8),
                                                               connectivity=8)
    big = np.zeros(count, dtype=np.bool_)
    big[1:] = stats[1:, cv2.CC_STAT_AREA] * res >= c.min_frontier_m
    kept = big[labels]
    kept_cells = int(kept.sum())
    if kept_cells == 0:
        return FrontierGoal(None, 0, 0, 0)
    reachable = _reachable(planner, robot)
    if reachable is None:
        return FrontierGoal(None, kept_cells, int(big.sum()), 0)
    radius = max(1, round(c.reach_m / res))
    disk = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * radius + 1, 2 * radius + 1))
    near = cv2.dilate(kept.astype(np.uint8), disk).astype(np.bool_)
    rows, cols = np.nonzero(near & reachable)
    if rows.size == 0:
        return FrontierGoal(None, kept_cells, int(big.sum()), 0)
    xs = grid.origin_x_m + (cols + 0.5) * res
    ys = grid.origin_y_m + (rows + 0.5) * res
    ok = np.hypot(xs - robot[0], ys - robot[1]) >= c.min_move_m
    for ax, ay in avoid:
        ok &= np.hypot(xs - ax, ys - ay) >= c.avoid_m
    if not ok.any():
        return FrontierGoal(None, kept_cells, int(big.sum()), 0)
    xs, ys = xs[ok], ys[ok]
    best = int(np.argmin(np.hypot(xs - robot[0], ys - robot[1])))
    return FrontierGoal((float(xs[best]), float(ys[best])), kept_cells, int(big.sum()),
                        int(xs.size))


def _reachable(planner: Planner, robot: Point) -> npt.NDArray[np.bool_] | None:
    """The standable cells connected to the robot's (or to the nearest standable cell within
    half a metre, when the robot stands closer to a wall than the clearance)."""
    free = planner.free.astype(np.uint8)
    _, labels = cv2.connectedComponents(free, connectivity=8)
    row, col = planner.grid.cell_of(*robot)
    res = planner.grid.resolution_m
    reach = max(1, math.ceil(0.5 / res))
    r0, r1 = max(0, row - reach), min(free.shape[0], row + reach + 1)
    c0, c1 = max(0, col - reach), min(free.shape[1], col + reach + 1)
    window = labels[r0:r1, c0:c1]
    if window.size == 0 or not window.any():
        return None
    rr, cc = np.nonzero(window)
    nearest = int(np.argmin((rr + r0 - row) ** 2 + (cc + c0 - col) ** 2))
    label = int(window[rr[nearest], cc[nearest]])
    out: npt.NDArray[np.bool_] = labels == label
    return out


def nearest_standable(planner: Planner, robot: Point, within_m: float) -> Point | None:
    """The centre of the nearest cell the planner lets the robot stand on, within
    ``within_m``; None when there is none."""
    grid = planner.grid
    res = grid.resolution_m
    row, col = grid.cell_of(*robot)
    reach = max(1, math.ceil(within_m / res))
    r0, r1 = max(0, row - reach), min(grid.rows, row + reach + 1)
    c0, c1 = max(0, col - reach), min(grid.cols, col + reach + 1)
    rr, cc = np.nonzero(planner.free[r0:r1, c0:c1])
    if rr.size == 0:
        return None
    d2 = (rr + r0 - row) ** 2 + (cc + c0 - col) ** 2
    best = int(np.argmin(d2))
    if d2[best] > reach * reach:
        return None
    return grid.centre_of(int(rr[best] + r0), int(cc[best] + c0))
