"""Property 24 (the coordinate system) on the delivery robot's own shop map: home is the
origin (0, 0) and the map's lower-left corner is not (the floor starts at (-2, -2)), so a
planner that confused the grid's corner with the map's origin would put its paths 2 m off."""

from __future__ import annotations

import math

from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

from behaviours.nav.config import PlannerConfig
from behaviours.nav.grid import Grid
from behaviours.nav.planner import NoPath, Planner

WALLS = [(-2.0, -2.0, 7.0, -2.0), (7.0, -2.0, 7.0, 5.0), (7.0, 5.0, -2.0, 5.0),
         (-2.0, 5.0, -2.0, -2.0),
         # the shelves, the pallet and the counter of the delivery scenario
         (3.4, 0.6, 3.8, 0.6), (3.8, 0.6, 3.8, 5.0), (3.4, 0.6, 3.4, 5.0),
         (6.2, 1.2, 7.0, 1.2), (6.2, 1.2, 6.2, 2.2), (6.2, 2.2, 7.0, 2.2),
         (-2.0, 3.9, -0.6, 3.9), (-0.6, 3.9, -0.6, 5.0)]
HOME = (0.0, 0.0)
GRID = Grid.from_segments(WALLS, 0.05)
PLANNER = Planner(GRID, PlannerConfig())


def _to_segment(x: float, y: float, seg: tuple[float, float, float, float]) -> float:
    x1, y1, x2, y2 = seg
    dx, dy = x2 - x1, y2 - y1
    t = max(0.0, min(1.0, ((x - x1) * dx + (y - y1) * dy) / (dx * dx + dy * dy)))
    return math.hypot(x - (x1 + t * dx), y - (y1 + t * dy))


def _clearance(x: float, y: float) -> float:
    return min(_to_segment(x, y, s) for s in WALLS)


def test_the_map_s_corner_is_not_home() -> None:
    assert GRID.bounds_m()[:2] != HOME  # the property below would not tell otherwise
    assert GRID.bounds_m()[0] < -1.9 and GRID.bounds_m()[1] < -1.9


# Feature: relaybot-autonomous-delivery, Property 24: For any position reported by the
# navigation system, the coordinates should be relative to the global origin (0,0) at home
# position.
@settings(max_examples=100, deadline=None, suppress_health_check=[HealthCheck.filter_too_much])
@given(st.floats(-1.6, 6.6), st.floats(-1.6, 4.6))
def test_property_24_paths_from_home_are_in_home_s_frame(x_m: float, y_m: float) -> None:
    """A path planned from home starts at exactly (0, 0), ends at exactly the goal, and every
    point of it keeps the planner's clearance from the walls measured in home's frame (the
    walls' own coordinates, not the grid's cells)."""
    assume(_clearance(x_m, y_m) > 0.45)
    try:
        plan = PLANNER.plan(HOME, (x_m, y_m))
    except NoPath:
        assume(False)
        return
    assert plan.points[0] == HOME
    assert plan.points[-1] == (x_m, y_m)
    for (ax, ay), (bx, by) in zip(plan.points, plan.points[1:], strict=False):
        steps = max(1, int(math.hypot(bx - ax, by - ay) / 0.02))
        for i in range(steps + 1):
            f = i / steps
            clear = _clearance(ax + (bx - ax) * f, ay + (by - ay) * f)
            assert clear >= PlannerConfig().clearance_m - 0.05, (x_m, y_m, clear)
