"""A* on a large map (a warehouse's 1.7 M cells): blocks first, then a corridor round the
block path; the path is a valid one and nearly as short as the one-level search's."""

from __future__ import annotations

from importlib import resources
from pathlib import Path

import numpy as np
import pytest

from behaviours.nav import astar
from behaviours.nav.config import MapConfig, PlannerConfig
from behaviours.nav.map_file import grid_of
from behaviours.nav.planner import HIERARCHY_CELLS, NoPath, Planner, min_distance_to_path
from hal.occupancy_map import read_map_yaml


@pytest.fixture(scope="module")
def planner() -> Planner:
    path = Path(str(resources.files("sim") / "maps" / "warehouse.yaml"))
    return Planner(grid_of(read_map_yaml(path), MapConfig()), PlannerConfig())


@pytest.mark.parametrize(("start", "goal"), [((0.0, 0.0), (11.0, 18.0)),
                                             ((-12.0, -20.0), (10.5, 16.0)),
                                             ((2.0, -20.0), (-12.0, 20.0))])
def test_two_steps_give_a_clear_near_optimal_path(planner: Planner, start: tuple[float, float],
                                                  goal: tuple[float, float]) -> None:
    """Across the warehouse: the path keeps the clearance and costs at most 3 % more than
    the one-level search's optimum, for a fraction of its expanded cells."""
    assert planner.cost.size >= HIERARCHY_CELLS
    plan = planner.plan(start, goal)
    rows, cols = np.nonzero(planner.grid.occupied)
    centres = np.column_stack((planner.grid.origin_x_m + (cols + 0.5) * 0.03,
                               planner.grid.origin_y_m + (rows + 0.5) * 0.03))
    near = np.hypot(centres[:, 0] - (start[0] + goal[0]) / 2,
                    centres[:, 1] - (start[1] + goal[1]) / 2) < 40
    assert min_distance_to_path(plan.points, centres[near]) >= 0.30 - 1e-9
    g = planner.grid
    s, t = g.cell_of(*start), g.cell_of(*goal)
    full = astar.search(planner.cost, s[0] * g.cols + s[1], t[0] * g.cols + t[1], 0.03)
    assert plan.cost <= full.cost * 1.03
    assert plan.expanded < full.expanded


def test_a_goal_inside_a_rack_is_still_no_path(planner: Planner) -> None:
    """The two steps change nothing of what is refused."""
    with pytest.raises(NoPath):
        planner.plan((0.0, 0.0), (0.0, 9.0))
