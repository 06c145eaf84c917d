"""``robotctl pose set X Y THETA``: the command's request, and the profile's ``set_pose``
method on a navigation stack in the simulated rig (params checked, the filter re-seeded)."""

from __future__ import annotations

import asyncio
import math
import random
from typing import Any

import pytest

from behaviours.motion.odometry import Odometry
from behaviours.motion.waypoint_drive import OdometryTracker
from behaviours.nav.control import pose_methods
from behaviours.nav.localisation.filter import LOCALISED
from behaviours.nav.navigator import NavStack
from behaviours.profile import ControlRefused
from robotd.ctl import _request as ctl_request
from robotd.ctl import build_parser
from sim import vclock
from sim.config import robot_settings
from sim.rig import open_sim_rig
from sim.scenario import load_scenario
from sim.world.body import DiffDriveBody
from sim.world.geometry import Pose


def test_pose_set_is_the_profiles_set_pose_with_the_pose_and_its_spread() -> None:
    """The arguments become params (degrees as given); the method's profile is asked for
    when it runs (robotctl does not know which robot it talks to)."""
    args = build_parser().parse_args(["pose", "set", "1.5", "-2", "90", "--sigma", "0.1"])
    assert ctl_request(args) == ("set_pose", {"x_m": 1.5, "y_m": -2.0, "heading_deg": 90.0,
                                              "sigma_m": 0.1})
    with pytest.raises(SystemExit):
        build_parser().parse_args(["pose", "set", "1.5"])


async def _teleported_then_set(params: dict[str, Any]) -> tuple[dict[str, Any], NavStack]:
    scenario = load_scenario("nav-kidnap")
    spec = scenario.robots[0]
    settings = robot_settings(scenario, spec, None)
    loop = asyncio.get_running_loop()
    body = DiffDriveBody(scenario.world, Pose(spec.x_m, spec.y_m, spec.heading_rad),
                         rng=random.Random(3), clock=loop.time)
    rig = await open_sim_rig(scenario.world, body, settings, seed=3, index=0,
                             needs=("motors", "encoders", "lidar"))
    d = rig.devices
    assert d.motors is not None and d.encoders is not None and d.lidar is not None
    for device in d.distinct():
        await device.start()
    drive = settings.section("drive")
    odometry = Odometry(drive["wheel_base_m"], drive["wheel_radius_m"], drive["ticks_per_rev"])
    nav = NavStack(settings, d.motors, d.lidar, odometry)
    tasks = [asyncio.create_task(OdometryTracker(d.encoders, odometry).run()),
             asyncio.create_task(nav.service.run(lambda: None))]
    try:
        await asyncio.sleep(1.0)
        body.pose = Pose(3.0, 1.0, math.radians(90))  # carried elsewhere, standing
        method = pose_methods("patrol", lambda: nav)["patrol.set_pose"]
        result = await method(params)
        await asyncio.sleep(1.0)
        return result, nav
    finally:
        for t in tasks:
            t.cancel()
        await asyncio.gather(*tasks, return_exceptions=True)
        for device in d.distinct():
            await device.close()
        await rig.close()


def test_the_operators_pose_is_where_the_filter_settles() -> None:
    """Carried 2 m away and told where: localised there within 5 cm a second later."""
    result, nav = vclock.run(_teleported_then_set(
        {"x_m": 3.1, "y_m": 1.05, "heading_deg": 85.0, "sigma_m": 0.2}))
    assert result["sigma_deg"] == 10.0
    pose = nav.pose()
    assert nav.localiser.status == LOCALISED
    assert math.hypot(pose.x_m - 3.0, pose.y_m - 1.0) < 0.05
    assert abs(math.degrees(pose.theta_rad) - 90.0) < 3.0


@pytest.mark.parametrize(("params", "message"), [
    ({"x_m": 3.0, "y_m": 1.0}, "heading_deg: required"),
    ({"x_m": "here", "y_m": 1.0, "heading_deg": 0}, "x_m: expected a number"),
    ({"x_m": 40.0, "y_m": 1.0, "heading_deg": 0}, "off the map"),
    ({"x_m": 3.0, "y_m": 2.6, "heading_deg": 0}, "inside an obstacle"),  # the table
    ({"x_m": 3.0, "y_m": 1.0, "heading_deg": 0, "sigma_m": -1}, "sigma_m must be"),
    ({"x_m": 3.0, "y_m": 1.0, "heading_deg": 0, "where": 1}, "unknown params"),
])
def test_a_bad_pose_is_refused_saying_why(params: dict[str, Any], message: str) -> None:
    """Missing or bad numbers, off the map, in the table: a ValueError (invalid params)."""
    with pytest.raises(ValueError, match=message):
        vclock.run(_teleported_then_set(params))


def test_before_the_stack_runs_it_is_refused() -> None:
    """No navigation stack yet: refused (an application error), not a crash."""
    method = pose_methods("patrol", lambda: None)["patrol.set_pose"]
    with pytest.raises(ControlRefused, match="not running"):
        asyncio.run(method({"x_m": 1.0, "y_m": 1.0, "heading_deg": 0.0}))
