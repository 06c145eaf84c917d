"""The live map's grid: key scans cast in one at a time give the cells ``render`` gives, and
the frontiers and goals the exploring driver picks from it."""

from __future__ import annotations

import math

import numpy as np

from behaviours.nav.config import PlannerConfig
from behaviours.nav.grid import Grid
from behaviours.nav.mapping.frontiers import (
    choose_frontier,
    filled,
    frontier_cells,
    nearest_standable,
)
from behaviours.nav.mapping.growing_grid import GrowingGrid
from behaviours.nav.mapping.log_odds import RenderConfig, render
from behaviours.nav.mapping.scan import Scan
from behaviours.nav.planner import Planner
from hal.occupancy_map import FREE, OCCUPIED, UNKNOWN, OccupancyMap

W = 0.02


def _room_scan(x: float, y: float, door: bool = False, beams: int = 360) -> Scan:
    """A scan from (x, y), heading 0, inside the 6 x 4 m room [W, 6 + W] x [W, 4 + W] (W off
    the cells' edges, as real walls are); with ``door`` the east wall has a 1 m gap (y
    1.5..2.5) through which beams find nothing."""
    angles = -math.pi + 2 * math.pi * np.arange(beams) / beams
    ranges = np.full(beams, np.inf)
    c, s = np.cos(angles), np.sin(angles)
    with np.errstate(divide="ignore", invalid="ignore"):
        for t in (np.where(c > 0, (6 + W - x) / c, np.inf),
                  np.where(c < 0, (W - x) / c, np.inf),
                  np.where(s > 0, (4 + W - y) / s, np.inf),
                  np.where(s < 0, (W - y) / s, np.inf)):
            ranges = np.minimum(ranges, t)
    if door:
        hit_y = y + ranges * s
        east = np.isclose(x + ranges * c, 6.0 + W) & (hit_y > 1.5) & (hit_y < 2.5)
        ranges[east] = np.inf
    ranges[ranges > 12.0] = 12.0
    return Scan(0.0, ranges, float(angles[0]), 2 * math.pi / beams, 12.0, (x, y, 0.0))


class TestGrowingGrid:
    def test_scans_cast_one_by_one_give_the_rendered_cells(self) -> None:
        """Two scans added as they come give the cells ``render`` gives for both, where
        the two grids overlap (the growing one is aligned to whole blocks, so a point on a
        cell's edge may fall either side by rounding: all but a few cells agree)."""
        scans = [_room_scan(1.0, 1.0), _room_scan(4.5, 3.0)]
        poses = [s.odom for s in scans]
        grid = GrowingGrid(RenderConfig(), block_m=2.0)
        for scan, pose in zip(scans, poses, strict=True):
            grid.add(scan, pose)
        live = grid.occupancy()
        whole = render(scans, poses)
        dx = round((whole.origin_x_m - live.origin_x_m) / 0.05)
        dy = round((whole.origin_y_m - live.origin_y_m) / 0.05)
        assert dx >= 0 and dy >= 0
        part = live.cells[dy:dy + whole.height, dx:dx + whole.width]
        assert part.shape == whole.cells.shape
        assert (part != whole.cells).mean() < 0.002
        assert (part == OCCUPIED).sum() > 300

    def test_it_grows_when_a_scan_reaches_past_its_edge(self) -> None:
        grid = GrowingGrid(RenderConfig(), block_m=2.0)
        grid.add(_room_scan(1.0, 1.0), (1.0, 1.0, 0.0))
        cols = grid.cols
        grid.add(_room_scan(1.0, 1.0), (21.0, 1.0, 0.0))  # the same room 20 m east
        assert grid.cols > cols
        occ = grid.occupancy()
        row, col = occ.cell_of(21.0, 1.0) if hasattr(occ, "cell_of") else (
            int((1.0 - occ.origin_y_m) / 0.05), int((21.0 - occ.origin_x_m) / 0.05))
        assert occ.cells[row, col] != OCCUPIED


def _live_grid(*scans: Scan) -> OccupancyMap:
    grid = GrowingGrid(RenderConfig(free_logodds=-1.2, hit_logodds=2.0))
    for scan in scans:
        grid.add(scan, scan.odom)
    return grid.occupancy()


class TestFrontiers:
    def test_a_closed_room_has_no_frontier_left(self) -> None:
        """Seen from two places, a closed room is all known: nothing to explore."""
        occ = filled(_live_grid(_room_scan(2.0, 2.0), _room_scan(4.0, 2.0)), (2.0, 2.0))
        planner = Planner(Grid.from_map(occ), PlannerConfig())
        assert choose_frontier(occ, planner, (2.0, 2.0)).goal is None

    def test_an_open_door_is_the_goal(self) -> None:
        """The gap in the east wall leads into unknown space; its beams return nothing and
        clear nothing, so the unknown reaches back to the robots' spots as a wedge: the goal
        is east, in that wedge, towards the door."""
        occ = filled(_live_grid(_room_scan(2.0, 2.0, door=True), _room_scan(4.0, 2.0,
                                                                            door=True)),
                     (2.0, 2.0))
        assert frontier_cells(occ).any()
        planner = Planner(Grid.from_map(occ), PlannerConfig())
        goal = choose_frontier(occ, planner, (2.0, 2.0)).goal
        assert goal is not None
        assert goal[0] > 2.4 and abs(goal[1] - 2.0) < 0.6
        assert choose_frontier(occ, planner, (2.0, 2.0), avoid=[goal]).goal != goal

    def test_filled_closes_the_gaps_between_far_beams_but_not_walls(self) -> None:
        """Unknown specks between 1-degree beams far away become free; wall cells stay."""
        raw = _live_grid(_room_scan(0.5, 0.5))
        out = filled(raw, (0.5, 0.5))
        assert (out.cells == FREE).sum() > (raw.cells == FREE).sum()
        assert np.array_equal(out.cells == OCCUPIED, raw.cells == OCCUPIED)
        assert (out.cells == UNKNOWN).sum() < (raw.cells == UNKNOWN).sum()

    def test_a_robot_too_near_a_wall_finds_the_nearest_standing_cell(self) -> None:
        occ = filled(_live_grid(_room_scan(2.0, 2.0)), (2.0, 2.0))
        planner = Planner(Grid.from_map(occ), PlannerConfig())
        spot = nearest_standable(planner, (5.85, 2.0), 0.7)
        assert spot is not None
        assert 5.5 <= spot[0] <= 5.7
        row, col = planner.grid.cell_of(*spot)
        assert planner.free[row, col]
