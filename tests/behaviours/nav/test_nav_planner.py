"""A* on the grid: optimal, clearance kept, smoothing safe, NoPath with its reason."""

from __future__ import annotations

import heapq
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from behaviours.nav import astar
from behaviours.nav.config import PlannerConfig
from behaviours.nav.grid import Grid
from behaviours.nav.planner import NoPath, Planner, min_distance_to_path
from behaviours.nav.smoothing import segment_cells

ROOM = [(0, 0, 8, 0), (8, 0, 8, 6), (8, 6, 0, 6), (0, 6, 0, 0), (4, 0, 4, 4)]


def _dijkstra(cost: np.ndarray, start: int, goal: int, res: float) -> float:
    rows, cols = cost.shape
    dist = {start: 0.0}
    heap = [(0.0, start)]
    done = set()
    while heap:
        d, cur = heapq.heappop(heap)
        if cur in done:
            continue
        done.add(cur)
        if cur == goal:
            return d
        r, c = divmod(cur, cols)
        for dr in (-1, 0, 1):
            for dc in (-1, 0, 1):
                nr, nc = r + dr, c + dc
                if (dr or dc) and 0 <= nr < rows and 0 <= nc < cols \
                        and math.isfinite(cost[nr, nc]):
                    nd = d + (math.sqrt(2) * res if dr and dc else res) * cost[nr, nc]
                    nxt = nr * cols + nc
                    if nd < dist.get(nxt, math.inf):
                        dist[nxt] = nd
                        heapq.heappush(heap, (nd, nxt))
    return math.inf


def _obstacle_centres(grid: Grid) -> np.ndarray:
    rows, cols = np.nonzero(grid.occupied)
    return np.stack([grid.origin_x_m + (cols + 0.5) * grid.resolution_m,
                     grid.origin_y_m + (rows + 0.5) * grid.resolution_m], axis=1)


costs = arrays(np.float64, st.tuples(st.integers(2, 12), st.integers(2, 12)),
               elements=st.one_of(st.just(math.inf), st.floats(1.0, 5.0)))


class TestSearch:
    @given(cost=costs, data=st.data())
    @settings(max_examples=100, deadline=None)
    def test_a_star_is_as_cheap_as_dijkstra(self, cost: np.ndarray, data: st.DataObject
                                            ) -> None:
        """A*'s path costs what Dijkstra's does on the same graph, with either kernel."""
        n = cost.size
        start = data.draw(st.integers(0, n - 1))
        goal = data.draw(st.integers(0, n - 1))
        cost.ravel()[[start, goal]] = 1.0
        best = _dijkstra(cost, start, goal, 0.05)
        for kernel in ("python", *(["c"] if astar._astar is not None else [])):
            found = astar.search(cost, start, goal, 0.05, kernel)
            if math.isinf(best):
                assert found.cells == []
            else:
                assert found.cost == pytest.approx(best, rel=1e-9)
                assert found.cells[0] == start and found.cells[-1] == goal

    @pytest.mark.skipif(astar._astar is None, reason="the C kernel was not built")
    @given(cost=costs, data=st.data())
    @settings(max_examples=100, deadline=None)
    def test_the_c_and_python_kernels_give_the_same_path(self, cost: np.ndarray,
                                                         data: st.DataObject) -> None:
        """Both kernels return the same cells and the same cost."""
        start = data.draw(st.integers(0, cost.size - 1))
        goal = data.draw(st.integers(0, cost.size - 1))
        cost.ravel()[[start, goal]] = 1.0
        c = astar.search(cost, start, goal, 0.05, "c")
        py = astar.search(cost, start, goal, 0.05, "python")
        assert c.cells == py.cells and c.cost == py.cost and c.expanded == py.expanded


class TestPlanner:
    def test_paths_start_and_end_exactly_at_start_and_goal(self) -> None:
        """The first point is the start and the last the goal, to the bit."""
        plan = Planner(Grid.from_segments(ROOM, 0.05)).plan((1.013, 1.0), (7.0, 1.21))
        assert plan.points[0] == (1.013, 1.0) and plan.points[-1] == (7.0, 1.21)
        assert len(plan.points) >= 3  # around the wall

    def test_no_path_says_why(self) -> None:
        """Outside the map, in collision, disconnected: each is its own reason."""
        sealed = Grid.from_segments([*ROOM, (4, 4, 4, 6)], 0.05)
        planner = Planner(sealed)
        cases = [((-5, 1), (1, 1), "start_outside"), ((1, 1), (1, 50), "goal_outside"),
                 ((4.0, 2.0), (1, 1), "start_in_collision"),
                 ((1, 1), (0.1, 1), "goal_in_collision"), ((1, 1), (7, 1), "disconnected")]
        for start, goal, reason in cases:
            with pytest.raises(NoPath) as info:
                planner.plan(start, goal)
            assert info.value.reason == reason, str(info.value)
        with pytest.raises(NoPath, match=r"start \(4\.00, 2\.00\) is in collision: 0\.00 m"):
            planner.plan((4.0, 2.0), (1, 1))

    def test_a_new_obstacle_on_the_path_makes_a_new_path_around_it(self) -> None:
        """An obstacle seen on the path is not clear of it; the replan keeps clear of it."""
        planner = Planner(Grid.from_segments(ROOM, 0.05))
        plan = planner.plan((1, 5), (7, 5))
        box = [(5.5 + dx, 4.8 + dy) for dx in (-0.1, 0, 0.1) for dy in (-0.1, 0, 0.1)]
        assert not planner.clear_of(plan.points, box)
        again = planner.with_obstacles(box).plan((1, 5), (7, 5))
        assert planner.clear_of(again.points, box)
        assert again.length_m > plan.length_m

    def test_without_smoothing_the_path_is_the_cells_centres(self) -> None:
        """smoothing = false keeps A*'s cells: start, centres, goal."""
        planner = Planner(Grid.from_segments(ROOM, 0.1), PlannerConfig(smoothing=False))
        plan = planner.plan((1, 1), (3, 1))
        assert len(plan.points) == plan.cells + 2

    def test_a_plan_smoothed_afterwards_is_the_plan_smoothed_at_once(self) -> None:
        """plan(smooth=False) then smoothed() (the path follower's two loop steps) gives the
        same plan as plan()."""
        planner = Planner(Grid.from_segments(ROOM, 0.05))
        raw = planner.plan((1.013, 1.0), (7.0, 1.21), smooth=False)
        assert len(raw.points) == raw.cells + 2
        assert planner.smoothed(raw) == planner.plan((1.013, 1.0), (7.0, 1.21))


@st.composite
def rooms_and_points(draw: st.DrawFn) -> tuple[Grid, tuple[float, float], tuple[float, float]]:
    boxes = draw(st.lists(st.tuples(st.floats(0.5, 7.0), st.floats(0.5, 5.0),
                                    st.floats(0.1, 1.5), st.floats(0.1, 1.5)), max_size=5))
    walls = list(ROOM)
    for x, y, w, h in boxes:
        walls += [(x, y, x + w, y), (x + w, y, x + w, y + h), (x + w, y + h, x, y + h),
                  (x, y + h, x, y)]
    grid = Grid.from_segments(walls, 0.05)
    point = st.tuples(st.floats(0.0, 8.0), st.floats(0.0, 6.0))
    return grid, draw(point), draw(point)


class TestProperties:
    # Feature: relaybot-autonomous-delivery, Property 8: For any pair of valid coordinates in
    # the environment, the navigation system should generate a valid path (non-empty list of
    # waypoints).
    @given(rooms_and_points())
    @settings(max_examples=100, deadline=None)
    def test_property_8_every_connected_pair_gets_a_path(self, case: tuple) -> None:
        """Valid (free, connected) start and goal: a path from exactly one to the other."""
        grid, start, goal = case
        planner = Planner(grid)
        try:
            plan = planner.plan(start, goal)
        except NoPath as exc:
            # Only for coordinates that are not valid: the search agrees they are not.
            assert exc.reason in ("start_in_collision", "goal_in_collision", "disconnected")
            if exc.reason == "disconnected":
                assert _dijkstra(planner.cost, *_cells(grid, start, goal), 0.05) == math.inf
            return
        assert plan.points[0] == start and plan.points[-1] == goal and plan.points

    # Feature: relaybot-autonomous-delivery, Property 10: For any navigation task with
    # obstacles in the path, the planned path should not pass through obstacle positions
    # (maintain minimum 30cm clearance).
    @given(rooms_and_points(), st.booleans())
    @settings(max_examples=100, deadline=None)
    def test_property_10_no_point_of_a_path_is_within_the_clearance(
            self, case: tuple, smoothing: bool) -> None:
        """Every point of every segment (smoothed or not) is >= 0.30 m from every obstacle."""
        grid, start, goal = case
        planner = Planner(grid, PlannerConfig(smoothing=smoothing))
        try:
            plan = planner.plan(start, goal)
        except NoPath:
            return
        if len(plan.points) >= 2:
            assert min_distance_to_path(plan.points, _obstacle_centres(grid)) >= 0.30 - 1e-9

    # Feature: relaybot-autonomous-delivery, Property 24: For any position reported by the
    # navigation system, the coordinates should be relative to the global origin (0,0) at
    # home position.
    @given(st.floats(-20, 20), st.floats(-20, 20))
    @settings(max_examples=100, deadline=None)
    def test_property_24_a_shifted_map_gives_the_same_path_shifted(self, ox: float,
                                                                   oy: float) -> None:
        """Paths are in the map frame: moving the map's origin moves its paths, no more."""
        base = Grid.from_segments(ROOM, 0.05)
        moved = Grid(base.occupied, 0.05, base.origin_x_m + ox, base.origin_y_m + oy)
        a = Planner(base).plan((1.0, 1.0), (7.0, 1.0)).points
        b = Planner(moved).plan((1.0 + ox, 1.0 + oy), (7.0 + ox, 1.0 + oy)).points
        assert len(a) == len(b)
        for p, q in zip(a, b, strict=True):
            assert q == pytest.approx((p[0] + ox, p[1] + oy), abs=1e-6)


def _cells(grid: Grid, start: tuple[float, float], goal: tuple[float, float]
           ) -> tuple[int, int]:
    (r0, c0), (r1, c1) = grid.cell_of(*start), grid.cell_of(*goal)
    return r0 * grid.cols + c0, r1 * grid.cols + c1


class TestSegmentCells:
    def test_a_diagonal_through_a_corner_does_not_enter_the_side_cells(self) -> None:
        """Corners touched are not cells entered; every cell crossed is listed."""
        grid = Grid(np.zeros((4, 4), dtype=np.bool_), 1.0)
        rows, cols = segment_cells(grid, (0.5, 0.5), (2.5, 2.5))
        assert list(zip(rows.tolist(), cols.tolist(), strict=True)) == [(0, 0), (1, 1), (2, 2)]
        rows, cols = segment_cells(grid, (0.5, 0.5), (3.5, 1.5))
        assert set(zip(rows.tolist(), cols.tolist(), strict=True)) == {
            (0, 0), (0, 1), (1, 2), (1, 3)}


class TestRealMap:
    # Feature: relaybot-autonomous-delivery, Property 8: For any pair of valid coordinates in
    # the environment, the navigation system should generate a valid path (non-empty list of
    # waypoints).
    @given(st.tuples(st.floats(0.5, 12.5), st.floats(0.5, 14.8)),
           st.tuples(st.floats(0.5, 12.5), st.floats(0.5, 14.8)))
    @settings(max_examples=100, deadline=None)
    def test_property_8_on_the_depot_map(self, start: tuple[float, float],
                                         goal: tuple[float, float]) -> None:
        """On Nav2's depot map: free points of the hall's open west half (its pillars, not
        the shelving blocks whose outlines enclose floor) always get a path."""
        planner = _depot_planner()
        try:
            plan = planner.plan(start, goal)
        except NoPath as exc:
            assert exc.reason in ("start_in_collision", "goal_in_collision"), str(exc)
            return
        assert plan.points[0] == start and plan.points[-1] == goal
        obstacles = _obstacle_centres(planner.grid)
        assert min_distance_to_path(plan.points, obstacles) >= 0.30 - 1e-9


_CACHE: dict[str, Planner] = {}


def _depot_planner() -> Planner:
    if "depot" not in _CACHE:
        from importlib import resources

        from hal.occupancy_map import read_map_yaml
        path = resources.files("sim") / "maps" / "depot.yaml"
        _CACHE["depot"] = Planner(Grid.from_map(read_map_yaml(str(path))))
    return _CACHE["depot"]
