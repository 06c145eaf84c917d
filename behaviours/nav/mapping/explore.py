"""The exploring driver: to the nearest reachable frontier, again and again, until none is left.

A behaviour, not a simulator part: it needs the growing map, the map-frame pose and the
planner in the same process as the mapping, and the same code explores a real site (driven
on the same motors as ``robotctl drive``, with the same e-stop above it). Each round it takes
the map so far (``LiveMapping.occupancy``), plans with the existing A* on it with unknown
cells as obstacles (``Planner`` over ``Grid.from_map``), picks the nearest frontier it can
reach (``frontiers.choose_frontier``) and drives there with the existing ``PathFollower``.
Its drive stops every ``step_m`` and waits for a still scan (``StopAndScanDrive``): the
mapping takes key scans only while the robot stands. A goal it cannot plan to or make no
progress towards is given up (and frontiers near it are left alone); so is one it reached.
"""

from __future__ import annotations

import asyncio
import math
from dataclasses import dataclass, field

import structlog

from behaviours.motion.odometry import Odometry, OdometryPose
from behaviours.motion.waypoint_drive import WaypointDrive
from behaviours.nav.config import PlannerConfig
from behaviours.nav.grid import Grid
from behaviours.nav.mapping.frontiers import (
    FrontierConfig,
    Point,
    choose_frontier,
    filled,
    nearest_standable,
)
from behaviours.nav.mapping.live import Emit, LiveMapping
from behaviours.nav.path_follower import NoProgress, PathFollower
from behaviours.nav.planner import NoPath, Planner
from hal.devices import Motors
from hal.settings import SettingsView

log = structlog.get_logger(__name__)


class StopAndScanDrive(WaypointDrive):
    """A ``WaypointDrive`` that stops every ``step_m`` until the mapping used a still scan."""

    def __init__(self, motors: Motors, odometry: Odometry, settings: SettingsView,
                 live: LiveMapping, step_m: float) -> None:
        super().__init__(motors, odometry, settings, pose_source=self._map_pose)
        self.live = live
        self.step_m = step_m

    def _map_pose(self) -> OdometryPose:
        x, y, theta = self.live.pose()
        return OdometryPose(x, y, theta)

    async def go_to(self, x_m: float, y_m: float) -> float:
        pose = self.pose()
        length = math.hypot(x_m - pose.x_m, y_m - pose.y_m)
        steps = max(1, math.ceil(length / self.step_m))
        start_x, start_y = pose.x_m, pose.y_m
        remaining = length
        for i in range(1, steps + 1):
            f = i / steps
            remaining = await super().go_to(start_x + (x_m - start_x) * f,
                                            start_y + (y_m - start_y) * f)
            await self.live.settle(asyncio.get_running_loop().time())
        return remaining


@dataclass(slots=True)
class ExploreResult:
    reason: str
    """``done`` (no frontier left) or ``time_limit``."""
    goals_reached: int = 0
    goals_given_up: int = 0
    rounds: int = 0
    given_up: list[Point] = field(default_factory=list)


class Explorer:
    """Drives to frontiers until none is left or ``time_limit_s`` has passed."""

    def __init__(self, live: LiveMapping, motors: Motors, odometry: Odometry,
                 settings: SettingsView, *, step_m: float, time_limit_s: float,
                 frontier: FrontierConfig | None = None, emit: Emit | None = None) -> None:
        self.live = live
        self.settings = settings
        self.drive = StopAndScanDrive(motors, odometry, settings, live, step_m)
        self.time_limit_s = time_limit_s
        self.frontier = frontier or FrontierConfig()
        self.emit: Emit = emit if emit is not None else live.emit

    async def run(self) -> ExploreResult:
        loop = asyncio.get_running_loop()
        started = loop.time()
        result = ExploreResult("done")
        await self.live.settle(started)  # the first key scan, taken standing
        started_at = self.live.pose()
        try:
            while loop.time() - started < self.time_limit_s:
                result.rounds += 1
                x, y, _ = self.live.pose()
                occupancy = filled(await self.live.occupancy(), (x, y))
                config = PlannerConfig.from_settings(self.settings)
                planner = Planner(Grid.from_map(occupancy), config)
                choice = choose_frontier(occupancy, planner, (x, y), result.given_up,
                                         self.frontier)
                if choice.goal is None:
                    self.emit("mapping.explored", rounds=result.rounds,
                              goals_reached=result.goals_reached,
                              goals_given_up=result.goals_given_up,
                              frontier_cells=choice.frontier_cells,
                              duration_s=round(loop.time() - started, 1))
                    await self._return(planner, started_at)
                    return result
                await self._step_clear(planner, (x, y))
                gx, gy = choice.goal
                self.emit("mapping.frontier", goal_x_m=round(gx, 3), goal_y_m=round(gy, 3),
                          frontier_cells=choice.frontier_cells, groups=choice.groups)
                follower = PathFollower(planner, self.drive, config)
                try:
                    await follower.go_to(gx, gy)
                    result.goals_reached += 1
                except (NoPath, NoProgress) as exc:
                    result.goals_given_up += 1
                    self.emit("mapping.frontier_given_up", goal_x_m=round(gx, 3),
                              goal_y_m=round(gy, 3), why=str(exc))
                result.given_up.append((gx, gy))  # reached or not: not a goal again
            result.reason = "time_limit"
            self.emit("mapping.explore_time_limit", rounds=result.rounds,
                      goals_reached=result.goals_reached)
            x, y, _ = self.live.pose()
            occupancy = filled(await self.live.occupancy(), (x, y))
            await self._return(Planner(Grid.from_map(occupancy),
                                       PlannerConfig.from_settings(self.settings)), started_at)
            return result
        finally:
            await self.drive.stop()

    async def _step_clear(self, planner: Planner, robot: Point) -> None:
        """When the robot stands closer to a wall than the planner's clearance (the map grew
        since it got there), a short straight move to the nearest cell it may stand on: the
        planner will not start from where it is."""
        row, col = planner.grid.cell_of(*robot)
        if not planner.grid.inside(row, col) or planner.free[row, col]:
            return
        spot = nearest_standable(planner, robot, self.frontier.reach_m)
        if spot is not None:
            self.emit("mapping.step_clear", to_x_m=round(spot[0], 3), to_y_m=round(spot[1], 3))
            await self.drive.go_to(*spot)

    async def _return(self, planner: Planner, start: tuple[float, float, float]) -> None:
        """Back to where the exploring began (where a robot that is handed the map expects
        to stand), on the map as it is now."""
        x, y, _ = self.live.pose()
        await self._step_clear(planner, (x, y))
        follower = PathFollower(planner, self.drive, planner.config)
        try:
            await follower.go_to(start[0], start[1])
            self.emit("mapping.returned", goal_x_m=round(start[0], 3), goal_y_m=round(start[1], 3))
        except (NoPath, NoProgress) as exc:
            self.emit("mapping.return_failed", why=str(exc))
