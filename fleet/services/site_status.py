"""Any robot's site status (issue 29, ``POST /api/Robot/{name}/status``): stored as its latest,
its e-stop and fault acted on as the data exchange's are (a fault raises a ``robot.fault``
alert, pushed to the staff), answered with the staff's orders.

As with the data exchange's pings, most reports change nothing but the figures (state path,
battery, pose, job): those are answered from one read and written in one batch a second
(``StatusWrites``, flushed with the pings), read from the snapshot of every robot that the
data exchange keeps, so a report costs no statement of its own. A report whose e-stop latch
or fault code changed (a robot's first, too: nothing stored yet) is a write transaction.
"""

from __future__ import annotations

from dataclasses import dataclass
from datetime import datetime
from typing import Any, cast

import structlog
from sqlalchemy import Connection, Table, bindparam, update

from fleet.db import Database
from fleet.models import Robot
from fleet.services.common import registered_robot
from fleet.services.condition import apply_condition
from fleet.services.exchange import RobotViews

log = structlog.get_logger(__name__)


@dataclass(frozen=True, slots=True)
class SiteStatus:
    """What the robot reports (None: not reported)."""

    robot_name: str
    profile: str | None = None
    state: str | None = None
    estop_active: bool | None = None
    fault_code: str | None = None
    fault_message: str | None = None
    battery_pct: float | None = None
    x_m: float | None = None
    y_m: float | None = None
    theta_rad: float | None = None
    map_name: str | None = None
    place: str | None = None
    job: str | None = None


@dataclass(frozen=True, slots=True)
class Orders:
    """The staff's orders for the robot, sent in the answer."""

    emergency_stop: bool
    maintenance_mode: bool


_robots = cast(Table, Robot.__table__)
_FIGURES = ("status_at", "profile", "state", "battery_pct", "pose_x_m", "pose_y_m",
            "pose_theta_rad", "map_name", "place", "job", "fault_message")
_UPDATE = update(_robots).where(_robots.c.id == bindparam("rid")).values(
    {name: bindparam(f"v_{name}") for name in _FIGURES})
_CHUNK = 200


class StatusWrites:
    """The figures of quiet reports, written in one batch (``flush``)."""

    def __init__(self) -> None:
        self._pending: dict[int, dict[str, Any]] = {}

    def note(self, robot_id: int, now: datetime, status: SiteStatus) -> None:
        self._pending[robot_id] = {"rid": robot_id, **{f"v_{k}": v for k, v in zip(
            _FIGURES, (now, status.profile, status.state, status.battery_pct, status.x_m,
                       status.y_m, status.theta_rad, status.map_name, status.place,
                       status.job, status.fault_message), strict=True)}}

    def discard(self, robot_id: int) -> None:
        """Its report is being written whole: an older batch entry must not follow it."""
        self._pending.pop(robot_id, None)

    async def flush(self, db: Database) -> int:
        """Write what was noted since the last flush; returns how many robots."""
        if not self._pending:
            return 0
        rows, self._pending = list(self._pending.values()), {}

        def write(conn: Connection) -> None:
            for start in range(0, len(rows), _CHUNK):
                conn.execute(_UPDATE, rows[start:start + _CHUNK])

        await db.run_write(write, serial=False)
        return len(rows)


async def answer_status(views: RobotViews, db: Database, now: datetime, status: SiteStatus,
                        pending: StatusWrites) -> Orders:
    """One report: a quiet one (e-stop latch and fault code as stored) is noted for the next
    batch and answered from the robots' snapshot the data exchange reads (no statement of
    its own); any other is ``record_status``. NotFound for a robot the site does not have."""
    light = await views.get(status.robot_name)
    if light.estop_active == status.estop_active and light.fault_code == status.fault_code:
        pending.note(light.robot_id, now, status)
        return Orders(light.emergency_stop, light.maintenance_mode)
    pending.discard(light.robot_id)
    return await record_status(db, now, status)


async def record_status(db: Database, now: datetime, status: SiteStatus) -> Orders:
    """Store the status as the robot's latest and act on its e-stop and fault. NotFound for
    a robot the site does not have."""
    async with db.write() as session:
        robot = await registered_robot(session, status.robot_name)
        first = robot.status_at is None
        robot.status_at = now
        robot.profile = status.profile
        robot.state = status.state
        robot.battery_pct = status.battery_pct
        robot.pose_x_m, robot.pose_y_m = status.x_m, status.y_m
        robot.pose_theta_rad, robot.map_name = status.theta_rad, status.map_name
        robot.place = status.place
        robot.job = status.job
        if robot.fault_code is not None and robot.fault_code == status.fault_code:
            robot.fault_message = status.fault_message
        await apply_condition(session, now, robot, status.estop_active, status.fault_code,
                              status.fault_message)
        if first:
            log.info("fleet.robot.status_first", robot=robot.name, profile=status.profile)
        return Orders(robot.emergency_stop, robot.maintenance_mode)

