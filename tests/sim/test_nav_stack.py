"""``NavStack`` on the simulated rig: the real LD19 driver on the SimLd19, go_to, status."""

from __future__ import annotations

import asyncio
import random

from behaviours.motion.odometry import Odometry
from behaviours.motion.waypoint_drive import OdometryTracker
from behaviours.nav.navigator import NavStack
from sim import vclock
from sim.config import robot_settings
from sim.rig import open_sim_rig
from sim.scenario import load_scenario
from sim.world.body import DiffDriveBody
from sim.world.geometry import Pose


async def _go(goal: tuple[float, float]) -> tuple[dict[str, object], str, float]:
    scenario = load_scenario("nav-kidnap")
    spec = scenario.robots[0]
    settings = robot_settings(scenario, spec, None)
    loop = asyncio.get_running_loop()
    body = DiffDriveBody(scenario.world, Pose(spec.x_m, spec.y_m, spec.heading_rad),
                         rng=random.Random(1), clock=loop.time)
    rig = await open_sim_rig(scenario.world, body, settings, seed=1, index=0,
                             needs=("motors", "encoders", "lidar"))
    d = rig.devices
    assert d.motors is not None and d.encoders is not None and d.lidar is not None
    for device in d.distinct():
        await device.start()
    drive = settings.section("drive")
    odometry = Odometry(drive["wheel_base_m"], drive["wheel_radius_m"], drive["ticks_per_rev"])
    nav = NavStack(settings, d.motors, d.lidar, odometry, front_range=d.front_range)
    tasks = [asyncio.create_task(OdometryTracker(d.encoders, odometry).run()),
             asyncio.create_task(nav.service.run(lambda: None))]
    nav.watch_scans()
    try:
        outcome = await nav.go_to(*goal)
        await asyncio.sleep(1.0)
        status = nav.status()
        true = body.pose
        return status, outcome.reason, true.distance_to(*goal)
    finally:
        for t in tasks:
            t.cancel()
        await asyncio.gather(*tasks, return_exceptions=True)
        for device in d.distinct():
            await device.close()
        await rig.close()


def test_go_to_reaches_the_goal_and_reports_its_figures() -> None:
    """go_to on the localised pose reaches the goal (true pose within 10 cm); status has the
    pose, its spread, the scan rate and the plan (robotctl status/sensors)."""
    status, reason, off_m = vclock.run(_go((3.0, 1.8)))
    assert reason == "reached"
    assert off_m <= 0.10
    assert status["status"] == "localised"
    assert isinstance(status["pose"], dict) and "x_m" in status["pose"]
    assert isinstance(status["spread_m"], float) and status["spread_m"] < 0.2
    assert isinstance(status["scan_rate_hz"], float) and 9.0 <= status["scan_rate_hz"] <= 11.0
    plan = status["plan"]
    assert isinstance(plan, dict) and plan["waypoints"][-1] == [3.0, 1.8]
    assert isinstance(status["poses_published"], int) and status["poses_published"] > 100


def test_no_path_is_an_outcome_not_an_exception() -> None:
    """A goal inside the table: ``no_path``, said, motors stopped."""
    _status, reason, _off = vclock.run(_go((3.0, 3.0)))
    assert reason == "no_path"
