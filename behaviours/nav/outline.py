"""The outlines of a grid's obstacles as line segments: what a scan is fitted against when the
map is an occupancy grid rather than a list of walls.

OpenCV's ``findContours`` traces every blob of occupied cells (a wall one cell thick gives
the path along both its faces, which is where a LiDAR sees it), ``approxPolyDP`` straightens
each trace within ``tolerance_cells``, and each side of the result becomes a segment between
cell centres in the map frame.
"""

from __future__ import annotations

import cv2
import numpy as np
import numpy.typing as npt

from behaviours.nav.grid import Grid

Segment = tuple[float, float, float, float]
DEFAULT_TOLERANCE_CELLS = 0.75
"""Within a cell: a wall drawn by a mapping run keeps its jags of noise out of the fit."""


def outline_segments(grid: Grid, tolerance_cells: float = DEFAULT_TOLERANCE_CELLS
                     ) -> list[Segment]:
    """Every occupied blob's outline, straightened, as ``(x1, y1, x2, y2)`` in metres."""
    mask = np.ascontiguousarray(grid.occupied, dtype=np.uint8)
    contours, _ = cv2.findContours(mask, cv2.RETR_LIST, cv2.CHAIN_APPROX_SIMPLE)
    out: list[Segment] = []
    for contour in contours:
        poly = np.asarray(cv2.approxPolyDP(contour, tolerance_cells, True),
                          dtype=np.float64).reshape(-1, 2)
        out.extend(_sides(poly, grid))
    return out


def _sides(poly: npt.NDArray[np.float64], grid: Grid) -> list[Segment]:
    if poly.shape[0] < 2:
        return []
    xs = grid.origin_x_m + (poly[:, 0] + 0.5) * grid.resolution_m
    ys = grid.origin_y_m + (poly[:, 1] + 0.5) * grid.resolution_m
    if poly.shape[0] == 2:
        return [(float(xs[0]), float(ys[0]), float(xs[1]), float(ys[1]))]
    nxt = np.roll(np.arange(poly.shape[0]), -1)
    return [(float(xs[i]), float(ys[i]), float(xs[j]), float(ys[j]))
            for i, j in enumerate(nxt) if (xs[i], ys[i]) != (xs[j], ys[j])]
