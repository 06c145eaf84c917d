"""The server side of the robot's 1 s data exchange (seed section 8): record the report,
handle arrival and weight, answer with beacons, targets and orders."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

from sqlalchemy.ext.asyncio import AsyncSession

from fleet.clock import Clock
from fleet.db import Database
from fleet.errors import NotFound
from fleet.models import Robot
from fleet.services import weight
from fleet.services.arrival import Sighting, handle_arrival
from fleet.services.common import current_request, robot_by_name
from fleet.services.navigation import Navigation, navigation
from fleet.services.offline import restore
from fleet.settings import load_settings


@dataclass(frozen=True)
class Report:
    """What the robot sends."""

    robot_name: str
    sightings: Sequence[Sighting]
    is_in_target: bool
    weight_kg: float | None
    ultrasonic_distance: float | None


@dataclass(frozen=True)
class Reply:
    navigation: Navigation
    emergency_stop: bool
    maintenance_mode: bool


async def _needs_serial(db: Database, report: Report) -> bool:
    """Whether this report may change a request (then it must run serialized)."""
    async with db.read() as session:
        robot = await _robot(session, report.robot_name)
        if robot.is_offline:
            return True
        request = await current_request(session, robot)
        if request is None:
            return False
        return report.is_in_target or weight.needs_weight(request)


async def _robot(session: AsyncSession, name: str) -> Robot:
    robot = await robot_by_name(session, name)
    if robot is None:
        msg = f"robot {name!r} is not registered"
        raise NotFound(msg)
    return robot


async def exchange(db: Database, clock: Clock, report: Report) -> Reply:
    """One data exchange. Raises NotFound for an unknown robot."""
    serial = await _needs_serial(db, report)
    async with db.write(serial=serial) as session:
        now = clock()
        cfg = await load_settings(session)
        robot = await _robot(session, report.robot_name)
        robot.last_ping_at = now
        if robot.weight_kg != report.weight_kg:
            robot.weight_kg = report.weight_kg
        if robot.ultrasonic_distance != report.ultrasonic_distance:
            robot.ultrasonic_distance = report.ultrasonic_distance
        if robot.is_in_target != report.is_in_target:
            robot.is_in_target = report.is_in_target
        if serial:
            if robot.is_offline:
                await restore(session, now, robot)
            if report.is_in_target:
                await handle_arrival(session, now, robot, report.sightings)
            request = await current_request(session, robot)
            if request is not None:
                weight.evaluate(session, now, cfg, request, report.weight_kg)
        request = await current_request(session, robot)
        nav = await navigation(session, cfg, robot, request)
        return Reply(nav, robot.emergency_stop, robot.maintenance_mode)
