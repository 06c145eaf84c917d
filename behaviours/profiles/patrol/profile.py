"""The ``patrol`` profile: a route of goals on the map, driven on the localised pose.

States: ``mission.plan`` (the next goal chosen, its path planned) -> ``mission.drive`` (the
``NavStack`` drives it, replanning around obstacles the map lacks) -> ``mission.at_goal``
(``nav.goal_reached`` with the error, a pause) -> the next goal, or ``idle`` after the last
loop. A diverged localisation or a lost LiDAR is a ``fault``: ``recovery`` with the reason,
motors stopped. The pose is kept in the state store (``patrol.pose``) every few seconds, so
``localisation.initial_pose = "store"`` restarts where the robot was.
"""

from __future__ import annotations

import asyncio
import math
from typing import TYPE_CHECKING, Any, Final

import structlog

from behaviours.machine_tables import CoreTrigger, mission_children
from behaviours.motion.odometry import Odometry
from behaviours.motion.waypoint_drive import OdometryTracker
from behaviours.nav.control import pose_methods
from behaviours.nav.localisation.filter import LocalisedPose
from behaviours.nav.navigator import NavLocalisation, NavOutcome, NavStack, stored_pose
from behaviours.persistence import MissionRecord
from behaviours.profile import BaseProfile, ControlMethod, SiteFacts, StateTask
from behaviours.service import Service, TaskService
from hal.options import Option, Section

if TYPE_CHECKING:
    from behaviours.context import RobotContext

log = structlog.get_logger(__name__)

PATROL = Section("patrol", "The patrol robot: a route of goals on the map.", (
    Option("goals", "list[point]", [], "The route: [[x, y], ...] in the map frame (metres)."),
    Option("loops", "int", 1, "Times round the route (0: for ever).", min=0, max=100000),
    Option("pause_s", "float", 1.0, "Stop this long at each goal.", min=0, max=3600,
           tunable=True),
    Option("pose_event_s", "float", 0.5,
           "A nav.pose event (the estimate, its spread and status) this often.",
           min=0.05, max=60),
    Option("particles_event_s", "float", 30.0,
           "A nav.particles event (a sample of the particles, for the report) this often; "
           "0: only at the start and when localisation is lost.", min=0, max=3600),
    Option("autostart", "bool", True, "Start the route as soon as the robot is idle."),
))

PATROL_MISSION = MissionRecord("patrol.mission", 1, {"goal": 0, "loop": 0})
"""The next goal and the loop, so a restart goes on where the robot was."""
POSE_RECORD = MissionRecord("patrol.pose", 1, {"x_m": None, "y_m": None, "heading_rad": None})
"""The last localised pose (``localisation.initial_pose = "store"``)."""
_STORE_POSE_S = 5.0
_CLOUD_POINTS = 150


class PatrolState:
    """The mission's states."""

    PLAN: Final = "mission.plan"
    DRIVE: Final = "mission.drive"
    AT_GOAL: Final = "mission.at_goal"


class PatrolTrigger:
    """The mission's own triggers."""

    PLANNED: Final = "planned"
    ARRIVED: Final = "arrived"
    NEXT_GOAL: Final = "next_goal"


class PatrolProfile(BaseProfile):
    name = "patrol"
    devices = ("motors", "encoders", "lidar")

    def __init__(self) -> None:
        self.nav: NavStack | None = None
        self.goal_index = 0
        self.loop = 0
        self.last_outcome: NavOutcome | None = None

    def mission_states(self) -> list[str | dict[str, Any]]:
        return mission_children(PatrolState.PLAN, PatrolState.DRIVE, PatrolState.AT_GOAL)

    def mission_transitions(self) -> list[dict[str, Any]]:
        s, t = PatrolState, PatrolTrigger
        return [
            {"trigger": t.PLANNED, "source": s.PLAN, "dest": s.DRIVE},
            {"trigger": t.ARRIVED, "source": s.DRIVE, "dest": s.AT_GOAL},
            {"trigger": t.NEXT_GOAL, "source": s.AT_GOAL, "dest": s.PLAN},
        ]

    def mission_records(self) -> tuple[MissionRecord, ...]:
        return (PATROL_MISSION, POSE_RECORD)

    def control_methods(self, ctx: RobotContext) -> dict[str, ControlMethod]:
        """``patrol.set_pose`` (``robotctl pose set``): an operator's pose for the filter."""
        return pose_methods(self.name, lambda: self.nav)

    def services(self, ctx: RobotContext) -> list[Service]:
        d = ctx.devices
        if d.encoders is None or d.motors is None or d.lidar is None:
            msg = "the patrol profile needs motors, encoders and a lidar"
            raise RuntimeError(msg)
        odometry = Odometry.from_settings(ctx.settings)
        stored = stored_pose(ctx.persisted(POSE_RECORD).values())
        nav = self.nav = NavStack(ctx.settings, d.motors, d.lidar, odometry,
                                  front_range=d.front_range, stored_pose=stored,
                                  emit=ctx.emit, telemetry=ctx.telemetry)
        ctx.emit("nav.start", initial_pose=nav.started_from, particles=len(
            nav.localiser.particles), map_resolution_m=nav.planner.grid.resolution_m)
        progress = ctx.persisted(PATROL_MISSION)
        self.goal_index, self.loop = int(progress["goal"]), int(progress["loop"])

        async def autostart() -> None:
            """The route starts once the robot is idle after boot (if there is one)."""
            nav.watch_scans()
            goals = ctx.settings.get("patrol.goals")
            if ctx.settings.get("patrol.autostart") and goals:
                await ctx.trigger(CoreTrigger.START_MISSION)
            await asyncio.Event().wait()

        return [
            TaskService("odometry", OdometryTracker(d.encoders, odometry,
                                                    telemetry=ctx.telemetry).run,
                        critical=True),
            NavLocalisation(nav),
            TaskService("patrol.poses", lambda: self._pose_events(ctx),
                        depends_on=("localisation",)),
            TaskService("patrol.autostart", autostart, depends_on=("localisation",)),
        ]

    async def _pose_events(self, ctx: RobotContext) -> None:
        """``nav.pose`` at ``patrol.pose_event_s``; the pose stored every few seconds."""
        nav = self.nav
        assert nav is not None
        loop = asyncio.get_running_loop()
        stored_s = loop.time()
        period_s = ctx.settings.get("patrol.pose_event_s")
        cloud_s = ctx.settings.get("patrol.particles_event_s")
        self._particles(ctx, "start")
        clouds_s = loop.time()
        try:
            await self._pose_loop(ctx, period_s, cloud_s, clouds_s, stored_s)
        finally:
            # An orderly stop (a restart, an update) keeps where the robot stands, not where
            # it was up to _STORE_POSE_S ago: initial_pose = "store" starts from there.
            if nav.service.poses.latest() is not None:
                self._store_pose(ctx, nav.live_pose())

    async def _pose_loop(self, ctx: RobotContext, period_s: float, cloud_s: float,
                         clouds_s: float, stored_s: float) -> None:
        nav = self.nav
        assert nav is not None
        loop = asyncio.get_running_loop()
        status = ""
        while True:
            await asyncio.sleep(period_s)
            if nav.service.poses.latest() is None:
                continue  # not publishing yet
            pose = nav.live_pose()
            if pose.status != status and pose.status in ("diverged", "lidar_lost"):
                self._particles(ctx, pose.status)
            elif cloud_s > 0 and loop.time() - clouds_s >= cloud_s:
                clouds_s = loop.time()
                self._particles(ctx, "periodic")
            status = pose.status
            ctx.emit("nav.pose", est_x_m=round(pose.x_m, 4), est_y_m=round(pose.y_m, 4),
                     est_heading_deg=round(math.degrees(pose.theta_rad), 2),
                     status=pose.status, spread_m=round(min(pose.spread_m, 99.0), 4),
                     particles=pose.particles, poses_published=nav.poses_published)
            if loop.time() - stored_s >= _STORE_POSE_S and pose.status == "localised":
                stored_s = loop.time()
                self._store_pose(ctx, pose)

    @staticmethod
    def _store_pose(ctx: RobotContext, pose: LocalisedPose) -> None:
        if pose.status == "localised":
            ctx.persisted(POSE_RECORD).set(x_m=round(pose.x_m, 4), y_m=round(pose.y_m, 4),
                                           heading_rad=round(pose.theta_rad, 5))

    def _particles(self, ctx: RobotContext, why: str) -> None:
        """``nav.particles``: a sample of the filter's particles (for the report)."""
        nav = self.nav
        assert nav is not None
        poses = nav.localiser.particles.poses
        step = max(1, len(poses) // _CLOUD_POINTS)
        xy = [[round(float(p[0]), 3), round(float(p[1]), 3)] for p in poses[::step]]
        ctx.emit("nav.particles", why=why, count=len(poses), xy=xy)

    def state_tasks(self) -> dict[str, StateTask]:
        return {PatrolState.PLAN: self._plan, PatrolState.DRIVE: self._drive,
                PatrolState.AT_GOAL: self._at_goal}

    def _goal(self, ctx: RobotContext) -> tuple[float, float]:
        goals = ctx.settings.get("patrol.goals")
        x, y = goals[self.goal_index % len(goals)]
        return float(x), float(y)

    async def _plan(self, ctx: RobotContext) -> None:
        goals = ctx.settings.get("patrol.goals")
        if not goals:
            await ctx.trigger(CoreTrigger.MISSION_DONE)
            return
        x, y = self._goal(ctx)
        ctx.emit("nav.goal", index=self.goal_index, loop=self.loop, goal_x_m=x, goal_y_m=y)
        await ctx.trigger(PatrolTrigger.PLANNED)

    async def _drive(self, ctx: RobotContext) -> None:
        nav = self.nav
        assert nav is not None
        x, y = self._goal(ctx)
        outcome = self.last_outcome = await nav.go_to(x, y)
        if outcome.reached:
            ctx.emit("nav.goal_reached", index=self.goal_index, goal_x_m=x, goal_y_m=y,
                     est_error_m=round(outcome.remaining_m, 4), replans=outcome.replans,
                     duration_s=round(outcome.duration_s, 2))
            await ctx.trigger(PatrolTrigger.ARRIVED)
            return
        ctx.emit("nav.failed", index=self.goal_index, reason=outcome.reason,
                 detail=outcome.detail, goal_x_m=x, goal_y_m=y)
        await ctx.trigger(CoreTrigger.FAULT, reason=outcome.reason)

    async def _at_goal(self, ctx: RobotContext) -> None:
        nav = self.nav
        if nav is not None and nav.service.poses.latest() is not None:
            self._store_pose(ctx, nav.live_pose())  # standing: the pose a restart starts from
        await asyncio.sleep(ctx.settings.get("patrol.pause_s"))
        goals = ctx.settings.get("patrol.goals")
        self.goal_index += 1
        if self.goal_index >= len(goals):
            self.goal_index = 0
            self.loop += 1
        ctx.persisted(PATROL_MISSION).set(goal=self.goal_index, loop=self.loop)
        loops = ctx.settings.get("patrol.loops")
        if loops and self.loop >= loops:
            ctx.emit("patrol.done", loops=self.loop)
            await ctx.trigger(CoreTrigger.MISSION_DONE)
            return
        await ctx.trigger(PatrolTrigger.NEXT_GOAL)

    def site_facts(self, ctx: RobotContext) -> SiteFacts:
        """The map pose (no job: it patrols)."""
        return self.nav.site_facts() if self.nav is not None else SiteFacts()

    def status(self) -> dict[str, Any]:
        """The navigation figures for ``robotctl status``."""
        if self.nav is None:
            return {}
        out = self.nav.status()
        out["goal_index"] = self.goal_index
        out["loop"] = self.loop
        return out
