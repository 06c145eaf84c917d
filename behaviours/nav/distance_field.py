"""Distance from every cell to the nearest obstacle: the planner's clearance and inflation,
and the localiser's likelihood field, read the same field.

``cv2.distanceTransform`` with ``DIST_L2`` and ``DIST_MASK_PRECISE`` is the exact Euclidean
distance (Felzenszwalb-Huttenlocher) between cell centres, in cells; here in metres. An
obstacle cell is at 0; a grid without obstacles is everywhere ``inf``.
"""

from __future__ import annotations

import math

import cv2
import numpy as np
import numpy.typing as npt

from behaviours.nav.grid import Grid

FloatGrid = npt.NDArray[np.float32]


class DistanceField:
    """Metres from each cell's centre to the nearest obstacle cell's centre."""

    def __init__(self, grid: Grid) -> None:
        self.grid = grid
        self.distance_m: FloatGrid = distance_transform_m(grid)

    def at(self, x_m: float, y_m: float) -> float:
        """Distance at a map-frame point (its cell's value); 0 outside the grid."""
        row, col = self.grid.cell_of(x_m, y_m)
        if not self.grid.inside(row, col):
            return 0.0
        return float(self.distance_m[row, col])

    def at_points(self, x_m: npt.ArrayLike, y_m: npt.ArrayLike) -> npt.NDArray[np.float32]:
        """``at`` for arrays of points (the likelihood field's beams); 0 outside the grid."""
        rows, cols = self.grid.cells_of(x_m, y_m)
        inside = (rows >= 0) & (rows < self.grid.rows) & (cols >= 0) & (cols < self.grid.cols)
        out = np.zeros(rows.shape, dtype=np.float32)
        out[inside] = self.distance_m[rows[inside], cols[inside]]
        return out


def distance_transform_m(grid: Grid) -> FloatGrid:
    """The field as an array shaped like the grid (float32 metres)."""
    if not grid.occupied.any():
        return np.full(grid.occupied.shape, math.inf, dtype=np.float32)
    free = np.ascontiguousarray(~grid.occupied, dtype=np.uint8)
    cells = cv2.distanceTransform(free, cv2.DIST_L2, cv2.DIST_MASK_PRECISE)
    out: FloatGrid = (cells * np.float32(grid.resolution_m)).astype(np.float32)
    return out
