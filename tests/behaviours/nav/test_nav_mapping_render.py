"""Log-odds rendering: walls where beams end, free where they pass, unknown elsewhere."""

from __future__ import annotations

import math

import numpy as np

from behaviours.nav.mapping.log_odds import render
from behaviours.nav.mapping.scan import Scan
from hal.occupancy_map import FREE, OCCUPIED, UNKNOWN


def _room_scan(x: float, y: float) -> Scan:
    """A 360-beam scan from (x, y) in a 4 x 4 m room with walls at 0 and 4, and one beam with
    no return."""
    angles = -math.pi + 2 * math.pi * np.arange(360) / 360
    c, s = np.cos(angles), np.sin(angles)
    with np.errstate(divide="ignore"):
        tx = np.where(c > 0, (4 - x) / c, np.where(c < 0, -x / c, np.inf))
        ty = np.where(s > 0, (4 - y) / s, np.where(s < 0, -y / s, np.inf))
    ranges = np.minimum(tx, ty)
    ranges[0] = 12.0  # at the maximum: no return
    return Scan(0.0, ranges, -math.pi, 2 * math.pi / 360, 12.0, (x, y, 0.0))


class TestRender:
    def test_walls_are_occupied_inside_is_free_outside_unknown(self) -> None:
        """Three scans of a room (a cell passed three times is free; twice is not enough at
        -0.4 a pass): its walls occupied, its middle free, beyond unknown."""
        places = [(2.0, 2.0), (1.0, 3.0), (3.0, 1.0)]
        grid = render([_room_scan(x, y) for x, y in places],
                      [(x, y, 0.0) for x, y in places])

        def at(x: float, y: float) -> int:
            r = math.floor((y - grid.origin_y_m) / grid.resolution_m)
            q = math.floor((x - grid.origin_x_m) / grid.resolution_m)
            return int(grid.cells[r, q])

        # A wall at x = 4 ends its beams in the cell either side of the line, by rounding.
        assert OCCUPIED in (at(2.0, 3.99), at(2.0, 4.01))
        assert OCCUPIED in (at(3.99, 1.0), at(4.01, 1.0))
        assert at(2.0, 2.5) == FREE
        assert at(4.6, 2.0) == UNKNOWN
