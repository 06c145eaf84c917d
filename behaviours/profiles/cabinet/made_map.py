"""A cabinet site laid on a map the robot made (``robotctl map save``, ``robotd map
--from-log``): the site file names the map_server YAML beside it as ``"occupancy"`` and keeps
only what a LiDAR cannot see (rooms, doors, cabinets), instead of hand-written walls.

The map's occupied cells are the walls: their outlines are the lines the scan fit matches
(``behaviours.nav.outline``), and the nav grid is the map with unknown cells as obstacles (the
robot plans through nothing it has not seen). A door must stand in the map's walls: each end
within ``DOOR_JAMB_TOLERANCE_M`` of an occupied cell. Its stretch is opened in the nav grid
whether the door stood open or shut while the map was made.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np

from behaviours.nav.grid import Grid
from behaviours.nav.outline import Segment, outline_segments
from hal.occupancy_map import MapFileError, read_map_yaml

Point = tuple[float, float]
KEY = "occupancy"
DOOR_JAMB_TOLERANCE_M = 0.15
"""A door's end this near a wall cell: a made map's jamb is a cell or two off the drawing."""
DOOR_OPEN_CELLS = 1.5
"""Cells whose centre is this near the door's line are opened: a closed door a few cells
thick, as a LiDAR maps it."""


class MadeMap:
    """The occupancy a site file points to, in the robot's frame (``zero`` subtracted)."""

    def __init__(self, occupied: Grid, planning: Grid, source: str) -> None:
        self.occupied = occupied
        """Cells seen occupied: the walls."""
        self.planning = planning
        """Occupied or never seen: where the robot may not go."""
        self.source = source

    @classmethod
    def read(cls, path: Path, zero: Point) -> MadeMap:
        """The map at ``path``; MapFileError says what is wrong with it."""
        occupancy = read_map_yaml(path)
        shifted = (occupancy.origin_x_m - zero[0], occupancy.origin_y_m - zero[1])
        res = occupancy.resolution_m
        return cls(Grid(occupancy.occupied(), res, *shifted),
                   Grid(occupancy.occupied(unknown_is_occupied=True), res, *shifted),
                   occupancy.source)

    def walls(self) -> list[Segment]:
        return outline_segments(self.occupied)

    def jamb_gap_m(self, x_m: float, y_m: float) -> float:
        """How far the point is from the nearest occupied cell (inf with none near)."""
        grid = self.occupied
        reach = math.ceil(DOOR_JAMB_TOLERANCE_M * 4 / grid.resolution_m)
        row, col = grid.cell_of(x_m, y_m)
        r0, r1 = max(0, row - reach), min(grid.rows, row + reach + 1)
        c0, c1 = max(0, col - reach), min(grid.cols, col + reach + 1)
        rows, cols = np.nonzero(grid.occupied[r0:r1, c0:c1])
        if rows.size == 0:
            return math.inf
        cx = grid.origin_x_m + (cols + c0 + 0.5) * grid.resolution_m
        cy = grid.origin_y_m + (rows + r0 + 0.5) * grid.resolution_m
        return float(np.min(np.hypot(cx - x_m, cy - y_m)))

    def with_doors_open(self, doors: list[Segment]) -> Grid:
        """The planning grid with every door's stretch free."""
        grid = self.planning
        occupied = grid.occupied.copy()
        rows, cols = np.indices(occupied.shape)
        cx = grid.origin_x_m + (cols + 0.5) * grid.resolution_m
        cy = grid.origin_y_m + (rows + 0.5) * grid.resolution_m
        for x1, y1, x2, y2 in doors:
            dx, dy = x2 - x1, y2 - y1
            t = np.clip(((cx - x1) * dx + (cy - y1) * dy) / (dx * dx + dy * dy), 0.0, 1.0)
            near = np.hypot(cx - (x1 + t * dx), cy - (y1 + t * dy))
            occupied[near <= DOOR_OPEN_CELLS * grid.resolution_m] = False
        return Grid(occupied, grid.resolution_m, grid.origin_x_m, grid.origin_y_m)


def read_made_map(value: Any, base_dir: Path | None, zero: Point
                  ) -> tuple[MadeMap | None, str | None]:
    """The map a site file's ``occupancy`` names, or the problem with it."""
    if not isinstance(value, str) or not value:
        return None, f"expected a map_server YAML file name, got {value!r}"
    path = Path(value).expanduser()
    if not path.is_absolute() and base_dir is not None:
        path = base_dir / path
    try:
        return MadeMap.read(path, zero), None
    except MapFileError as exc:
        return None, str(exc)
