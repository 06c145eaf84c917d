"""``NavStack`` on the simulated rig, kidnapped: relocalised over the whole map and on to the
goal; an operator's pose (``set_pose``) re-seeds the filter and the drive replans from it."""

from __future__ import annotations

import asyncio
import math
import random
from typing import Any

from behaviours.motion.odometry import Odometry
from behaviours.motion.waypoint_drive import OdometryTracker
from behaviours.nav.localisation.filter import LOCALISED, UNCERTAIN
from behaviours.nav.navigator import NavStack
from sim import vclock
from sim.config import robot_settings
from sim.rig import open_sim_rig
from sim.scenario import load_scenario
from sim.world.body import DiffDriveBody
from sim.world.geometry import Pose


async def _kidnapped(goal: tuple[float, float], *, operator: bool = False,
                     relocalise: str = "global", operator_after_s: float | None = None
                     ) -> dict[str, Any]:
    """Drive towards ``goal`` from the nav-kidnap start, teleport the body 1 m aside after
    5 s; with ``operator`` the true pose is given by hand as it is put down."""
    scenario = load_scenario("nav-kidnap")
    spec = scenario.robots[0]
    settings = robot_settings(scenario, spec, None)
    settings.set("localisation.relocalise", relocalise)
    loop = asyncio.get_running_loop()
    body = DiffDriveBody(scenario.world, Pose(spec.x_m, spec.y_m, spec.heading_rad),
                         rng=random.Random(2), clock=loop.time)
    rig = await open_sim_rig(scenario.world, body, settings, seed=2, index=0,
                             needs=("motors", "encoders", "lidar"))
    d = rig.devices
    assert d.motors is not None and d.encoders is not None and d.lidar is not None
    for device in d.distinct():
        await device.start()
    drive = settings.section("drive")
    odometry = Odometry(drive["wheel_base_m"], drive["wheel_radius_m"], drive["ticks_per_rev"])
    events: list[tuple[float, str, dict[str, Any]]] = []
    nav = NavStack(settings, d.motors, d.lidar, odometry, front_range=d.front_range,
                   emit=lambda kind, **f: events.append((loop.time(), kind, f)))
    tasks = [asyncio.create_task(OdometryTracker(d.encoders, odometry).run()),
             asyncio.create_task(nav.service.run(lambda: None))]
    nav.watch_scans()

    async def kidnap() -> None:
        await asyncio.sleep(5.0)
        p = body.pose
        body.pose = Pose(p.x_m, p.y_m - 1.0, p.heading_rad)
        if operator_after_s is not None:
            await asyncio.sleep(operator_after_s)
        if operator or operator_after_s is not None:
            t = body.pose
            nav.set_pose(t.x_m, t.y_m, t.heading_rad, 0.05, math.radians(3))
            events.append((loop.time(), "status_after_set", {"status": nav.localiser.status}))

    tasks.append(asyncio.create_task(kidnap()))
    try:
        outcome = await nav.go_to(*goal)
        true = body.pose
        return {"reason": outcome.reason, "off_m": true.distance_to(*goal), "events": events,
                "relocalisations": nav.relocalisations, "status": nav.localiser.status}
    finally:
        for t in tasks:
            t.cancel()
        await asyncio.gather(*tasks, return_exceptions=True)
        for device in d.distinct():
            await device.close()
        await rig.close()


def test_a_kidnapped_robot_relocalises_and_reaches_its_goal() -> None:
    """Teleported 1 m mid-drive: diverged, a global search, localised while turning on the
    spot, then the goal is planned again and reached (true pose within 10 cm)."""
    result = vclock.run(_kidnapped((5.0, 1.8)))
    kinds = [kind for _t, kind, _f in result["events"]]
    assert result["reason"] == "reached"
    assert result["off_m"] <= 0.10
    assert kinds.index("localisation.diverged") < kinds.index("nav.relocalise") \
        < kinds.index("nav.relocalised")
    t_done, _kind, done = next(e for e in result["events"] if e[1] == "nav.relocalised")
    assert done["ok"] is True and t_done - 5.0 <= 30.0
    assert result["relocalisations"] == 1 and result["status"] == LOCALISED


def test_with_relocalisation_off_a_divergence_fails_the_goal() -> None:
    """localisation.relocalise = "off": the goal ends as diverged, as before issue 30."""
    result = vclock.run(_kidnapped((5.0, 1.8), relocalise="off"))
    assert result["reason"] == "diverged"
    assert "nav.relocalise" not in [kind for _t, kind, _f in result["events"]]


def test_an_operators_pose_replans_from_it() -> None:
    """The operator gives the true pose as the robot is put down: the filter re-seeded there
    (uncertain until the next scan), no divergence, the goal reached."""
    result = vclock.run(_kidnapped((5.0, 1.8), operator=True))
    kinds = [kind for _t, kind, _f in result["events"]]
    assert result["reason"] == "reached" and result["off_m"] <= 0.10
    after = next(f for _t, kind, f in result["events"] if kind == "status_after_set")
    assert after["status"] == UNCERTAIN
    assert "nav.relocalise" not in kinds


def test_an_operators_pose_during_a_search_ends_it() -> None:
    """The operator gives the pose 3 s after the kidnap, while the robot searches: the
    relocalisation ends as done (by the operator) and the goal is reached from that pose."""
    result = vclock.run(_kidnapped((5.0, 1.8), operator_after_s=3.0))
    found = next(f for _t, kind, f in result["events"] if kind == "nav.relocalised")
    assert found["by"] == "operator"
    assert result["reason"] == "reached" and result["off_m"] <= 0.10
