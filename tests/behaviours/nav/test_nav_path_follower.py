"""The path follower on the simulated robot: goals reached, replans, no progress reported."""

from __future__ import annotations

import asyncio
import math
import random

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from behaviours.motion.odometry import Odometry
from behaviours.motion.waypoint_drive import OdometryTracker, WaypointDrive
from behaviours.nav.config import PlannerConfig
from behaviours.nav.grid import Grid
from behaviours.nav.path_follower import Arrival, NoProgress, PathFollower
from behaviours.nav.planner import NoPath, Planner
from robotd.config.loader import defaults
from robotd.config.settings import Settings
from sim import vclock
from sim.rig import open_sim_rig
from sim.world.body import BodyParams, DiffDriveBody
from sim.world.floor_plan import World
from sim.world.geometry import Pose

WALLS = [(0.0, 0.0, 6.0, 0.0), (6.0, 0.0, 6.0, 4.0), (6.0, 4.0, 0.0, 4.0),
         (0.0, 4.0, 0.0, 0.0), (3.0, 0.0, 3.0, 2.6)]


async def _drive_to(goals: list[tuple[float, float]], *, box_at_s: float | None = None,
                    config: PlannerConfig | None = None, frozen: bool = False
                    ) -> tuple[list[object], DiffDriveBody, PathFollower]:
    world = World.from_table({"width_m": 6, "height_m": 4, "boundary": False, "walls": [
        {"x1": a, "y1": b, "x2": c, "y2": d} for a, b, c, d in WALLS]})
    loop = asyncio.get_running_loop()
    body = DiffDriveBody(world, Pose(1.0, 1.0, 0.0), BodyParams(slip_std=0.0),
                         rng=random.Random(1), clock=loop.time)
    settings = Settings(defaults())
    rig = await open_sim_rig(world, body, settings, seed=1, index=0)
    await rig.link.start()
    odometry = Odometry(settings.get("drive.wheel_base_m"), settings.get("drive.wheel_radius_m"),
                        settings.get("drive.ticks_per_rev"))
    odometry.reset(1.0, 1.0, 0.0)
    tracker = asyncio.create_task(OdometryTracker(rig.link.encoders, odometry).run())
    drive = WaypointDrive(rig.link, odometry, settings,
                          pose_source=(lambda: odometry.pose().__class__(1.0, 1.0, 0.0))
                          if frozen else None)
    follower = PathFollower(Planner(Grid.from_segments(WALLS, 0.05), config), drive)
    results: list[object] = []
    if box_at_s is not None:
        async def drop_box() -> None:
            await asyncio.sleep(box_at_s)
            follower.see_obstacles([(4.0 + dx / 10, 2.2 + dy / 10)
                                    for dx in range(-3, 4) for dy in range(-3, 4)])
        asyncio.get_running_loop().call_soon(lambda: asyncio.ensure_future(drop_box()))
    try:
        for goal in goals:
            try:
                results.append(await follower.go_to(*goal))
            except (NoPath, NoProgress) as exc:
                results.append(exc)
    finally:
        tracker.cancel()
        await rig.link.stop()
        await rig.close()
    return results, body, follower


class TestPathFollower:
    def test_goals_around_a_wall_are_reached_without_touching_it(self) -> None:
        """Through the gap above the wall and back: each goal within 10 cm, no collision."""
        results, body, _ = vclock.run(_drive_to([(5.0, 1.0), (1.0, 3.2)]))
        for result in results:
            assert isinstance(result, Arrival), result
            assert result.remaining_m <= 0.10
        assert math.dist((body.pose.x_m, body.pose.y_m), (1.0, 3.2)) <= 0.10
        assert body.collisions == []

    def test_a_box_seen_on_the_path_is_driven_around(self) -> None:
        """A box the map does not have, seen mid-route on the path: a replan, goal reached."""
        results, body, follower = vclock.run(_drive_to([(5.0, 1.0)], box_at_s=20.0))
        assert not isinstance(results[0], Exception), results[0]
        assert follower.replans >= 1
        assert math.dist((body.pose.x_m, body.pose.y_m), (5.0, 1.0)) <= 0.10

    def test_no_progress_is_reported_within_the_bound(self) -> None:
        """A pose that never changes: NoProgress after no_progress_s, and the wheels stop."""
        config = PlannerConfig(no_progress_s=3.0, replan_period_s=0.5)
        results, body, _ = vclock.run(_drive_to([(2.0, 1.0)], config=config, frozen=True))
        assert isinstance(results[0], NoProgress)
        assert body.pwm[:2] == (0, 0)

    def test_an_unreachable_goal_is_no_path(self) -> None:
        """A goal inside the wall: NoPath with its reason, nothing driven."""
        results, body, _ = vclock.run(_drive_to([(3.0, 1.0)]))
        assert isinstance(results[0], NoPath) and results[0].reason == "goal_in_collision"
        assert body.distance_m == pytest.approx(0.0, abs=1e-6)


class TestNavigationProperty:
    # Feature: relaybot-autonomous-delivery, Property 9: For any navigation goal (warehouse,
    # customer position, home), the final position should be within 10cm of the target
    # coordinates.
    @given(st.tuples(st.floats(0.4, 5.6), st.floats(0.4, 3.6)))
    @settings(max_examples=100, deadline=None)
    def test_property_9_every_reachable_goal_is_reached_within_10_cm(
            self, goal: tuple[float, float]) -> None:
        """The simulated body (true pose) ends within 10 cm of any goal that has a path."""
        results, body, _ = vclock.run(_drive_to([goal]))
        if isinstance(results[0], NoPath):
            return  # in the wall's clearance: not a valid goal
        assert isinstance(results[0], Arrival), results[0]
        assert math.dist((body.pose.x_m, body.pose.y_m), goal) <= 0.10
        assert body.collisions == []
