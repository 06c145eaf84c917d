"""Every robot of the site as the staff see it (issue 29): one ``RobotStatus`` each, from what
it last reported (the laundry data exchange or the site status), for the console's robot
views and the site map."""

from __future__ import annotations

from dataclasses import dataclass
from datetime import datetime, timedelta

from sqlalchemy import select
from sqlalchemy.ext.asyncio import AsyncSession

from fleet.clock import system_clock
from fleet.models import Robot
from fleet.settings import load_settings


@dataclass(frozen=True, slots=True)
class RobotStatus:
    """One robot: the fields of the console's ``RobotView``.

    ``estop``: held in e-stop (its own latch, or the server's order); ``online``: heard from
    within ``OfflineAfterS`` (a laundry robot: not marked offline); ``last_seen``: its last
    report of either kind; ``job``: its own words, or the request a laundry robot serves.
    """

    name: str
    profile: str | None
    state: str | None
    estop: bool
    fault_code: str | None
    fault_message: str | None
    battery_pct: float | None
    x_m: float | None
    y_m: float | None
    theta_rad: float | None
    map_name: str | None
    place: str | None
    job: str | None
    online: bool
    last_seen: datetime | None


def robot_status(robot: Robot, now: datetime, offline_after_s: float) -> RobotStatus:
    """One robot's status at ``now``."""
    seen = [t for t in (robot.last_ping_at, robot.status_at) if t is not None]
    last_seen = max(seen) if seen else None
    fresh = robot.status_at is not None \
        and now - robot.status_at <= timedelta(seconds=offline_after_s)
    job = robot.job
    if job is None and robot.current_request_id is not None:
        job = f"request {robot.current_request_id}"
    return RobotStatus(
        name=robot.name, profile=robot.profile, state=robot.state,
        estop=bool(robot.estop_active) or robot.emergency_stop,
        fault_code=robot.fault_code, fault_message=robot.fault_message,
        battery_pct=robot.battery_pct, x_m=robot.pose_x_m, y_m=robot.pose_y_m,
        theta_rad=robot.pose_theta_rad, map_name=robot.map_name, place=robot.place, job=job,
        online=fresh or (not robot.is_offline and robot.last_ping_at is not None),
        last_seen=last_seen)


async def robot_statuses(session: AsyncSession, now: datetime | None = None, *,
                         reporting_only: bool = False) -> list[RobotStatus]:
    """Every registered robot, in the order they were registered (``reporting_only``: those
    that have reported a site status). ``now``: the server's clock (default the system's,
    UTC)."""
    settings = await load_settings(session)
    query = select(Robot).order_by(Robot.id)
    if reporting_only:
        query = query.where(Robot.status_at.is_not(None))
    robots = (await session.execute(query)).scalars().all()
    at = now if now is not None else system_clock()
    return [robot_status(r, at, settings.offline_after_s) for r in robots]
