"""Cancelling a request from any status, with the seed's branches (section 12)."""

from __future__ import annotations

from datetime import datetime

import structlog
from sqlalchemy.ext.asyncio import AsyncSession

from fleet.errors import Conflict
from fleet.models import Refund, Request
from fleet.services.common import robot_serving, set_status
from fleet.services.notify import notify
from fleet.status import ALLOWED, HOLDS_LAUNDRY, Action, Disposition, Status

log = structlog.get_logger(__name__)

# The robot drives back to base after these (it keeps the request until it is there).
_ROBOT_RETURNS = frozenset({
    Status.ACCEPTED, Status.ARRIVED_AT_ROOM, Status.LAUNDRY_LOADED, Status.GOING_TO_ROOM,
    Status.ARRIVED_FOR_DELIVERY,
})


async def cancel(
    session: AsyncSession, now: datetime, request: Request, *, reason: str, message: str
) -> None:
    """Cancel ``request``; the robot, if one serves it, heads to base (navigation follows).

    Raises Conflict when the status cannot be cancelled.
    """
    prior = Status(request.status)
    if prior not in ALLOWED[Action.CANCEL]:
        msg = f"request {request.id} cannot be cancelled in status {prior}"
        raise Conflict(msg)
    robot = await robot_serving(session, request)
    set_status(request, Status.CANCELLED, now)
    request.cancel_reason = reason
    request.cancelled_from = prior
    if prior == Status.PENDING:
        request.assigned_robot_id = None
    elif prior in HOLDS_LAUNDRY and robot is not None and robot.is_offline:
        # The laundry is on a robot nobody hears from: it stays there (and the robot keeps
        # the request) until the staff resolve the alert and say where it is.
        request.disposition = Disposition.ON_ROBOT
    elif prior == Status.LAUNDRY_LOADED:
        request.disposition = Disposition.DIRTY_AT_BASE
    elif prior == Status.WASHING:
        request.disposition = (Disposition.RETURN_DIRTY if request.washing_started_at is None
                               else Disposition.FINISH_WASHING)
        notify(session, now, recipient="admin", kind="request.cancelled.washing",
               request=request, level="warning",
               message=(f"Request {request.id} cancelled during washing: "
                        f"{request.disposition}."))
    if prior not in _ROBOT_RETURNS or robot is None:
        request.robot_returned = True
    if request.is_paid:
        request.refund_due = True
        session.add(Refund(request_id=request.id, customer_id=request.customer_id,
                           created_at=now, reason=f"{reason} (from {prior})"))
        message += " A refund will be processed."
    notify(session, now, recipient="customer", kind="request.cancelled", request=request,
           robot_name=robot.name if robot is not None else None, message=message)
    log.info("fleet.request.cancelled", request_id=request.id, prior=str(prior), reason=reason,
             robot=robot.name if robot is not None else None, refund=request.refund_due)
