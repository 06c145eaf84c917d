"""What a robot reports of its own condition (issue 27): its e-stop latch and the fault that
keeps it from its job, acted on when they change."""

from __future__ import annotations

from datetime import datetime

import structlog
from sqlalchemy.ext.asyncio import AsyncSession

from fleet.models import Robot
from fleet.services.alerts import FAULT, close_alerts, raise_alert
from fleet.services.assignment import process_queue
from fleet.services.common import current_request
from fleet.services.notify import notify

log = structlog.get_logger(__name__)

ALERT_CODES = {"dock_failed": "docking_gave_up", "dock_ir_lost": "docking_gave_up"}
"""Robot fault codes that one alert code stands for (the docking capability's two ways of
giving up); any other fault code (a RelayBot error category such as ``stuck``) is its own."""


def alert_code(fault_code: str) -> str:
    """The ``Code`` of the alert a robot's fault raises."""
    return ALERT_CODES.get(fault_code, fault_code)


async def apply_condition(
    session: AsyncSession, now: datetime, robot: Robot, estop_active: bool | None,
    fault_code: str | None, fault_message: str | None,
) -> None:
    """Store the robot's e-stop and fault; a new fault code is raised once, for as long as it
    lasts; a robot out of e-stop may serve the queue again."""
    if robot.fault_code != fault_code:
        await _fault_changed(session, now, robot, fault_code, fault_message)
    if robot.estop_active != estop_active:
        was = robot.estop_active
        robot.estop_active = estop_active
        if estop_active:
            notify(session, now, recipient="admin", kind="robot.estop", level="warning",
                   robot_name=robot.name, request=await current_request(session, robot),
                   message=f"Robot {robot.name} is in emergency stop.")
            log.warning("fleet.robot.estop", robot=robot.name)
        elif was:
            log.info("fleet.robot.estop_released", robot=robot.name)
            await process_queue(session, now)


async def _fault_changed(
    session: AsyncSession, now: datetime, robot: Robot, code: str | None, message: str | None
) -> None:
    old = robot.fault_code
    robot.fault_code = code
    robot.fault_message = message if code is not None else None
    if old is not None:
        # The fault it had is over (cleared, or another one took its place).
        await close_alerts(session, now, kinds=[FAULT], robot_name=robot.name,
                           resolution="FaultCleared", by=robot.name)
        log.info("fleet.robot.fault_cleared", robot=robot.name, code=old)
    if code is None:
        return
    request = await current_request(session, robot)
    raise_alert(session, now, kind=FAULT, level="warning", robot_name=robot.name,
                request=request, code=alert_code(code),
                message=f"Robot {robot.name} reports fault {code}: {message or 'no message'}")
    log.warning("fleet.robot.fault", robot=robot.name, code=code,
                request_id=request.id if request is not None else None)
