"""A ``map_server`` map as walls of the simulated world: the edges of its occupied cells.

Every side an occupied cell shares with a cell that is not occupied (or with the outside of the
image) becomes a wall segment, runs along one grid line merged into one segment. The body's
collisions, its front sensor, the simulated LiDAR and the report all read ``World.walls``, so a
site's real map, as ``map_saver`` wrote it, is driven in the simulator exactly as the cells
are: a beam stops at the first occupied cell's side.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from hal.occupancy_map import OccupancyMap
from sim.world.geometry import FloatArray


def occupied_edges(occupied: npt.NDArray[np.bool_], resolution_m: float, origin_x_m: float,
                   origin_y_m: float) -> FloatArray:
    """Segments ``(x1, y1, x2, y2)`` along the outline of the occupied cells (row 0 lowest)."""
    occ = np.pad(occupied.astype(np.int8), 1)  # a ring of free cells around the image
    parts: list[FloatArray] = []
    # Horizontal edges: between rows r-1 and r (grid line y = r), for r in 0..rows.
    horizontal = occ[1:, 1:-1] != occ[:-1, 1:-1]
    for line, start, end in _runs(horizontal):
        y = origin_y_m + line * resolution_m
        parts.append(np.array([[origin_x_m + start * resolution_m, y,
                                origin_x_m + end * resolution_m, y]]))
    vertical = occ[1:-1, 1:] != occ[1:-1, :-1]  # between cols c-1 and c (x = c)
    for line, start, end in _runs(vertical.T):
        x = origin_x_m + line * resolution_m
        parts.append(np.array([[x, origin_y_m + start * resolution_m,
                                x, origin_y_m + end * resolution_m]]))
    if not parts:
        return np.zeros((0, 4), dtype=np.float64)
    return np.concatenate(parts).astype(np.float64)


def _runs(mask: npt.NDArray[np.bool_]) -> list[tuple[int, int, int]]:
    """(line, first, past-last) of each run of True along each line of ``mask``."""
    padded = np.pad(mask.astype(np.int8), ((0, 0), (1, 1)))
    change = np.diff(padded, axis=1)
    lines_start, starts = np.nonzero(change == 1)
    _lines_end, ends = np.nonzero(change == -1)
    return list(zip(lines_start.tolist(), starts.tolist(), ends.tolist(), strict=True))


def map_walls(occupancy: OccupancyMap, occupied_min: int = 65) -> FloatArray:
    """The walls of a map's occupied cells (unknown cells are not walls: nothing is there
    that a beam or a bumper could meet, as far as the map knows)."""
    return occupied_edges(occupancy.occupied(occupied_min), occupancy.resolution_m,
                          occupancy.origin_x_m, occupancy.origin_y_m)


def known_bounds(occupancy: OccupancyMap, margin_m: float = 0.5
                 ) -> tuple[float, float, float, float]:
    """(x_min, y_min, x_max, y_max) around the cells the map knows, free or occupied (the
    whole image if none): map_saver's images are mostly unknown grey around the site."""
    rows, cols = np.nonzero(occupancy.cells >= 0)
    res = occupancy.resolution_m
    if rows.size == 0:
        r0, r1, c0, c1 = 0, occupancy.height, 0, occupancy.width
    else:
        r0, r1, c0, c1 = int(rows.min()), int(rows.max()) + 1, int(cols.min()), int(cols.max()) + 1
    return (occupancy.origin_x_m + c0 * res - margin_m, occupancy.origin_y_m + r0 * res - margin_m,
            occupancy.origin_x_m + c1 * res + margin_m, occupancy.origin_y_m + r1 * res + margin_m)
