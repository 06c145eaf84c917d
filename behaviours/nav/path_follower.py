"""Going to a goal on the map: plan, drive the path's legs, replan around new obstacles, and
tell the caller when the robot stops getting closer.

The legs are driven by ``WaypointDrive`` with the follower's pose source (the localised pose
once there is one; wheel odometry until then). A watcher wakes every ``replan_period_s``:
obstacles seen in the scan that the map does not have (``see_obstacles``, points in the map
frame) and that come within the clearance of the rest of the path make it stop and plan again
with them; no progress along the path (``progress_m``) for ``no_progress_s`` raises
``NoProgress`` (turning on the spot towards a leg counts as progress). ``NoPath`` from the
planner reaches the caller as it is.
"""

from __future__ import annotations

import asyncio
import math
from collections.abc import Iterable
from dataclasses import dataclass

import structlog

from behaviours.motion.waypoint_drive import WaypointDrive
from behaviours.nav.config import PlannerConfig
from behaviours.nav.planner import Plan, Planner
from behaviours.nav.smoothing import Point, path_length_m
from hal.tasks import cancel_and_wait

log = structlog.get_logger(__name__)

_TURN_PROGRESS_RAD = math.radians(15)
"""Turning this much on the spot counts as progress: the robot is not stuck, it faces a leg."""


class NoProgress(Exception):
    """The robot got no closer to the goal for ``no_progress_s``."""

    def __init__(self, message: str, remaining_m: float) -> None:
        super().__init__(message)
        self.remaining_m = remaining_m


@dataclass(frozen=True, slots=True)
class Arrival:
    """How a goal was reached: where the pose source says the robot is, and at what cost."""

    x_m: float
    y_m: float
    remaining_m: float
    replans: int
    path_length_m: float
    duration_s: float


class PathFollower:
    """Drives to goals on one map, with the obstacles seen lately added to it."""

    def __init__(self, planner: Planner, drive: WaypointDrive,
                 config: PlannerConfig | None = None) -> None:
        self.planner = planner
        self.drive = drive
        self.config = config or planner.config
        self.plan: Plan | None = None
        self.replans = 0
        self._next = 1  # the index in plan.points of the waypoint being driven to
        self._seen: list[tuple[float, Point]] = []

    def see_obstacles(self, points: Iterable[Point]) -> None:
        """Obstacles in the map frame seen now (kept ``obstacle_keep_s``)."""
        now = asyncio.get_running_loop().time()
        self._seen.extend((now, (float(x), float(y))) for x, y in points)

    def _kept(self, now: float) -> list[Point]:
        keep_s = self.config.obstacle_keep_s
        self._seen = [(t, p) for t, p in self._seen if now - t <= keep_s]
        return [p for _t, p in self._seen]

    def remaining_path(self) -> list[Point]:
        """From where the robot is, through the waypoints still ahead, to the goal."""
        if self.plan is None:
            return []
        pose = self.drive.pose()
        return [(pose.x_m, pose.y_m), *self.plan.points[self._next:]]

    async def go_to(self, x_m: float, y_m: float) -> Arrival:
        """Plan and drive to a map-frame point; NoPath or NoProgress when it cannot."""
        loop = asyncio.get_running_loop()
        started = loop.time()
        goal = (x_m, y_m)
        replans_before = self.replans
        driven_m = 0.0
        while True:
            pose = self.drive.pose()
            start = (pose.x_m, pose.y_m)
            plan = await self._plan(start, goal, loop.time())
            self.plan, self._next = plan, 1
            log.info("nav.planned", goal_x_m=x_m, goal_y_m=y_m, waypoints=len(plan.points),
                     length_m=round(plan.length_m, 3), expanded=plan.expanded)
            if await self._follow(plan):
                break
            driven_m += path_length_m([start, (self.drive.pose().x_m, self.drive.pose().y_m)])
            self.replans += 1
        pose = self.drive.pose()
        remaining = math.hypot(x_m - pose.x_m, y_m - pose.y_m)
        arrival = Arrival(pose.x_m, pose.y_m, remaining, self.replans - replans_before,
                          driven_m + plan.length_m, loop.time() - started)
        log.info("nav.arrived", x_m=round(x_m, 3), y_m=round(y_m, 3),
                 remaining_m=round(remaining, 4), replans=arrival.replans)
        return arrival

    async def _plan(self, start: Point, goal: Point, now: float) -> Plan:
        """Plan in up to three loop steps (the grid with the obstacles seen, the search, the
        smoothing), each a few ms of CPU here and 8x that on a Pi 4: the loop runs between."""
        planner = self._planner_for(start, now)
        if planner is not self.planner:
            await asyncio.sleep(0)
        plan = planner.plan(start, goal, smooth=False)
        await asyncio.sleep(0)
        return planner.smoothed(plan)

    def _planner_for(self, start: Point, now: float) -> Planner:
        # Obstacles within the clearance of where the robot stands would put the start in
        # collision: the obstacle guard deals with what is that close, the plan leaves it out.
        near = self.config.clearance_m + self.planner.grid.resolution_m * 2
        kept = [p for p in self._kept(now) if math.dist(p, start) > near]
        return self.planner.with_obstacles(kept) if kept else self.planner

    async def _follow(self, plan: Plan) -> bool:
        """Drive the plan; True when done, False when it must be planned again."""
        loop = asyncio.get_running_loop()
        legs = asyncio.create_task(self._drive_legs(plan))
        best = path_length_m(self.remaining_path())
        best_t = loop.time()
        heading = self.drive.pose().theta_rad
        try:
            while True:
                done, _ = await asyncio.wait({legs}, timeout=self.config.replan_period_s)
                if done:
                    legs.result()
                    return True
                now = loop.time()
                if not self.planner.clear_of(self.remaining_path(), self._kept(now)):
                    log.info("nav.replan", reason="obstacle_on_path")
                    return False
                left = path_length_m(self.remaining_path())
                turned = abs(math.remainder(self.drive.pose().theta_rad - heading, math.tau))
                if left <= best - self.config.progress_m:
                    best, best_t = left, now
                elif turned >= _TURN_PROGRESS_RAD:
                    # Turning on the spot towards the next leg (slowly, in a speed zone).
                    best_t, heading = now, self.drive.pose().theta_rad
                elif now - best_t >= self.config.no_progress_s:
                    msg = (f"no progress for {now - best_t:.1f} s, {left:.2f} m of path "
                           "left")
                    log.warning("nav.no_progress", remaining_m=round(left, 3))
                    raise NoProgress(msg, left)
        finally:
            if not legs.done():
                await cancel_and_wait(legs)
                await self.drive.stop()

    async def _drive_legs(self, plan: Plan) -> None:
        for i in range(1, len(plan.points)):
            self._next = i
            x, y = plan.points[i]
            await self.drive.go_to(x, y)
        self._next = len(plan.points)
