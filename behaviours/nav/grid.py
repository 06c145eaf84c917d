"""The occupancy grid the planner and the likelihood field read: obstacles as a boolean array.

Cells are square, ``resolution_m`` on a side; cell (row, col) covers x in [origin_x + col * res,
origin_x + (col + 1) * res), and likewise y with row (row 0 is the lowest y, as in a ROS
``OccupancyGrid``). All coordinates are in the map frame, whose origin is the robot's home
(seed property 24): a map's ``origin`` only says where its lower-left corner lies in it.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from hal.occupancy_map import OccupancyMap

BoolGrid = npt.NDArray[np.bool_]


@dataclass(frozen=True, slots=True)
class Grid:
    """Obstacle cells of a map (``occupied[row, col]``), with their place in the map frame."""

    occupied: BoolGrid
    resolution_m: float
    origin_x_m: float = 0.0
    origin_y_m: float = 0.0

    def __post_init__(self) -> None:
        if self.occupied.ndim != 2 or self.occupied.size == 0:
            msg = f"occupied must be a non-empty 2-D array, got shape {self.occupied.shape}"
            raise ValueError(msg)
        if not self.resolution_m > 0:
            msg = f"resolution_m must be > 0, got {self.resolution_m}"
            raise ValueError(msg)

    @property
    def rows(self) -> int:
        return int(self.occupied.shape[0])

    @property
    def cols(self) -> int:
        return int(self.occupied.shape[1])

    @classmethod
    def from_map(cls, occupancy: OccupancyMap, *, occupied_min: int = 65,
                 unknown_is_occupied: bool = True) -> Grid:
        """Obstacles of a ``map_server`` map; unknown cells count as obstacles by default
        (the robot must not plan through what it has never seen)."""
        return cls(occupancy.occupied(occupied_min, unknown_is_occupied),
                   occupancy.resolution_m, occupancy.origin_x_m, occupancy.origin_y_m)

    @classmethod
    def from_segments(cls, segments: Iterable[Sequence[float]], resolution_m: float, *,
                      margin_m: float = 0.5) -> Grid:
        """Walls ``(x1, y1, x2, y2)`` rasterised: every cell a wall passes through is occupied.

        The grid covers the walls' bounding box plus ``margin_m`` on every side.
        """
        segs = np.asarray(list(segments), dtype=np.float64).reshape(-1, 4)
        if segs.shape[0] == 0:
            msg = "no walls to rasterise"
            raise ValueError(msg)
        xs, ys = segs[:, [0, 2]], segs[:, [1, 3]]
        x0 = math.floor((float(xs.min()) - margin_m) / resolution_m) * resolution_m
        y0 = math.floor((float(ys.min()) - margin_m) / resolution_m) * resolution_m
        cols = math.ceil((float(xs.max()) + margin_m - x0) / resolution_m) + 1
        rows = math.ceil((float(ys.max()) + margin_m - y0) / resolution_m) + 1
        grid = cls(np.zeros((rows, cols), dtype=np.bool_), resolution_m, x0, y0)
        for x1, y1, x2, y2 in segs:
            grid.occupied[grid._segment_cells(x1, y1, x2, y2)] = True
        return grid

    def _segment_cells(self, x1: float, y1: float, x2: float, y2: float
                       ) -> tuple[npt.NDArray[np.intp], npt.NDArray[np.intp]]:
        # Samples every quarter cell along the wall: every cell it crosses gets at least one.
        steps = max(1, math.ceil(math.hypot(x2 - x1, y2 - y1) / (self.resolution_m / 4)))
        t = np.linspace(0.0, 1.0, steps + 1)
        rows, cols = self.cells_of(x1 + t * (x2 - x1), y1 + t * (y2 - y1))
        keep = (rows >= 0) & (rows < self.rows) & (cols >= 0) & (cols < self.cols)
        return rows[keep], cols[keep]

    def cell_of(self, x_m: float, y_m: float) -> tuple[int, int]:
        """(row, col) of the cell holding a point (may lie outside the grid)."""
        return (math.floor((y_m - self.origin_y_m) / self.resolution_m),
                math.floor((x_m - self.origin_x_m) / self.resolution_m))

    def cells_of(self, x_m: npt.ArrayLike, y_m: npt.ArrayLike
                 ) -> tuple[npt.NDArray[np.intp], npt.NDArray[np.intp]]:
        rows = np.floor((np.asarray(y_m) - self.origin_y_m) / self.resolution_m).astype(np.intp)
        cols = np.floor((np.asarray(x_m) - self.origin_x_m) / self.resolution_m).astype(np.intp)
        return rows, cols

    def centre_of(self, row: int, col: int) -> tuple[float, float]:
        """The map-frame point at a cell's centre."""
        return (self.origin_x_m + (col + 0.5) * self.resolution_m,
                self.origin_y_m + (row + 0.5) * self.resolution_m)

    def inside(self, row: int, col: int) -> bool:
        return 0 <= row < self.rows and 0 <= col < self.cols

    def with_points(self, points: Iterable[tuple[float, float]]) -> Grid:
        """A copy with the cells holding these map-frame points occupied (points outside
        the grid are dropped): obstacles seen in a scan that the map does not have."""
        pts = np.asarray(list(points), dtype=np.float64).reshape(-1, 2)
        occupied = self.occupied.copy()
        if pts.shape[0]:
            rows, cols = self.cells_of(pts[:, 0], pts[:, 1])
            keep = (rows >= 0) & (rows < self.rows) & (cols >= 0) & (cols < self.cols)
            occupied[rows[keep], cols[keep]] = True
        return Grid(occupied, self.resolution_m, self.origin_x_m, self.origin_y_m)

    def bounds_m(self) -> tuple[float, float, float, float]:
        """(x_min, y_min, x_max, y_max) of the area the grid covers."""
        return (self.origin_x_m, self.origin_y_m,
                self.origin_x_m + self.cols * self.resolution_m,
                self.origin_y_m + self.rows * self.resolution_m)
