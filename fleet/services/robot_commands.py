"""The staff's orders to any robot (issue 29): e-stop, resume, maintenance. Held on the robot's
row (``emergency_stop``, ``maintenance_mode``, as ``PATCH /api/robots/{name}`` sets them) and
delivered in the answer to its next report, the data exchange's or the site status's.

The robot takes a resume only for the e-stop the server gave: one a person latched on the
robot is theirs to lift there (behaviours/site_report/orders.py).
"""

from __future__ import annotations

from datetime import datetime

import structlog
from sqlalchemy.ext.asyncio import AsyncSession

from fleet.clock import system_clock
from fleet.models import Robot
from fleet.services.admin import update_robot
from fleet.services.common import registered_robot
from fleet.services.notify import notify

log = structlog.get_logger(__name__)


async def _order(session: AsyncSession, name: str, by: str, now: datetime | None, *,
                 order: str, emergency_stop: bool | None = None,
                 maintenance_mode: bool | None = None) -> Robot:
    at = now if now is not None else system_clock()
    robot = await update_robot(session, at, await registered_robot(session, name), is_active=None,
                               emergency_stop=emergency_stop,
                               maintenance_mode=maintenance_mode)
    notify(session, at, recipient="admin", kind="robot.order", level="info",
           robot_name=robot.name, message=f"{by} ordered {order} of robot {robot.name}.")
    log.info("fleet.robot.order", robot=robot.name, order=order, by=by)
    return robot


async def estop(session: AsyncSession, name: str, by: str, *,
                now: datetime | None = None) -> Robot:
    """Order the robot into emergency stop (it stops at its next report)."""
    return await _order(session, name, by, now, order="estop", emergency_stop=True)


async def resume(session: AsyncSession, name: str, by: str, *,
                 now: datetime | None = None) -> Robot:
    """Lift the server's emergency stop (the robot resumes at its next report)."""
    return await _order(session, name, by, now, order="resume", emergency_stop=False)


async def maintenance(session: AsyncSession, name: str, by: str, *, on: bool,
                      now: datetime | None = None) -> Robot:
    """Put the robot into maintenance (``on``) or take it out."""
    return await _order(session, name, by, now,
                        order="maintenance" if on else "maintenance_end",
                        maintenance_mode=on)
