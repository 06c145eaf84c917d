"""Creating requests and applying customer/admin actions (seed sections 1 and 2)."""

from __future__ import annotations

from datetime import datetime

import structlog
from sqlalchemy import select
from sqlalchemy.ext.asyncio import AsyncSession

from fleet.errors import Conflict, NotFound
from fleet.models import Customer, Request
from fleet.services.assignment import assign_new, dispatch, pick_delivery_robot, process_queue
from fleet.services.cancellation import cancel
from fleet.services.common import set_status
from fleet.services.lines import blocking, line_map, occupied
from fleet.services.notify import notify
from fleet.services.weight import can_confirm_loaded, can_confirm_unloaded
from fleet.settings import FleetSettings
from fleet.status import ACTIVE, ALLOWED, Action, Status

log = structlog.get_logger(__name__)


async def create_request(
    session: AsyncSession, now: datetime, cfg: FleetSettings, customer_id: int
) -> Request:
    """A customer asks for a pickup. Raises NotFound, Conflict (duplicate), NoRobotAvailable."""
    customer = await session.get(Customer, customer_id)
    if customer is None:
        msg = f"customer {customer_id} does not exist"
        raise NotFound(msg)
    active = (await session.execute(
        select(Request).where(Request.customer_id == customer_id,
                              Request.status.in_([str(s) for s in ACTIVE]))
    )).scalars().first()
    if active is not None:
        msg = (f"customer {customer_id} already has an active request "
               f"{active.id} ({active.status})")
        raise Conflict(msg)
    request = Request(customer_id=customer_id, status=Status.PENDING, created_at=now,
                      status_changed_at=now, is_approved=False, overweight=False,
                      is_paid=False, refund_due=False, disposition="None",
                      robot_returned=False)
    session.add(request)
    await session.flush()
    await assign_new(session, now, cfg, request)
    if request.status == Status.PENDING:
        waiting = ("waiting in the queue" if request.is_approved
                   else "waiting for an admin to approve it")
        notify(session, now, recipient="customer", kind="request.pending", request=request,
               message=f"Request {request.id} is {waiting}.")
        if not request.is_approved:
            notify(session, now, recipient="admin", kind="request.approval_needed",
                   request=request, message=f"Request {request.id} needs approval.")
    log.info("fleet.request.created", request_id=request.id, customer_id=customer_id,
             status=request.status)
    return request


async def apply_action(
    session: AsyncSession, now: datetime, cfg: FleetSettings, request_id: int, action: Action
) -> Request:
    """Apply ``action``; raises NotFound, or Conflict when the status does not allow it."""
    request = await session.get(Request, request_id)
    if request is None:
        msg = f"request {request_id} does not exist"
        raise NotFound(msg)
    status = Status(request.status)
    if status not in ALLOWED[action]:
        msg = f"cannot {action} request {request_id}: it is {status}"
        raise Conflict(msg)
    match action:
        case Action.ACCEPT:
            request.is_approved = True
            await process_queue(session, now, cfg)
        case Action.DECLINE:
            set_status(request, Status.DECLINED, now)
            request.assigned_robot_id = None
            notify(session, now, recipient="customer", kind="request.declined",
                   request=request, message=f"Request {request.id} was declined.")
        case Action.CANCEL:
            await cancel(session, now, request, reason="Cancelled",
                         message=f"Request {request.id} was cancelled.")
            await process_queue(session, now, cfg)
        case Action.CONFIRM_LOADED:
            if not can_confirm_loaded(request, cfg):
                msg = (f"cannot confirm-loaded request {request_id}: the robot reports "
                       f"{_kg(request.weight_kg)}, which is not between "
                       f"{cfg.min_weight_kg} and {cfg.max_weight_kg} kg")
                raise Conflict(msg)
            set_status(request, Status.LAUNDRY_LOADED, now)
        case Action.CONFIRM_UNLOADED:
            if not can_confirm_unloaded(request, cfg):
                msg = (f"cannot confirm-unloaded request {request_id}: the robot reports "
                       f"{_kg(request.weight_kg)}, not below {cfg.min_weight_kg} kg")
                raise Conflict(msg)
            set_status(request, Status.GOING_TO_BASE, now)
        case Action.WASHING_STARTED:
            if request.washing_started_at is not None:
                msg = f"washing of request {request_id} has already started"
                raise Conflict(msg)
            request.washing_started_at = now
        case Action.WASHING_DONE:
            robot = await pick_delivery_robot(session, now, cfg, request)
            await _check_line_free(session, request, robot.name)
            if request.washing_started_at is None:
                request.washing_started_at = now
            dispatch(request, robot, now, Status.GOING_TO_ROOM)
            request.weight_kg = None
            notify(session, now, recipient="customer", kind="laundry.delivering",
                   request=request, robot_name=robot.name,
                   message=f"Your clean laundry is on its way with robot {robot.name}.")
        case Action.PAY:
            if request.is_paid:
                msg = f"request {request_id} is already paid"
                raise Conflict(msg)
            request.is_paid = True
            notify(session, now, recipient="admin", kind="request.paid", request=request,
                   message=f"Request {request.id} was paid.")
    return request


async def _check_line_free(session: AsyncSession, request: Request, robot_name: str) -> None:
    """Conflict when the customer's room is on a painted line another robot is on."""
    lines = await line_map(session)
    if lines is None:
        return
    on_line = await occupied(session, lines)
    line = blocking(lines, on_line, request.customer_id, robot_name)
    if line is not None:
        msg = (f"cannot deliver request {request.id} now: line {line!r} is in use by robot "
               f"{on_line[line]}; try again when it is back at base")
        raise Conflict(msg)


def _kg(weight_kg: float | None) -> str:
    return "no weight" if weight_kg is None else f"{weight_kg:.2f} kg"
