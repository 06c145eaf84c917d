"""Creating requests and applying customer/admin actions (seed sections 1 and 2)."""

from __future__ import annotations

from datetime import datetime

import structlog
from sqlalchemy import select
from sqlalchemy.ext.asyncio import AsyncSession

from fleet.errors import Conflict, NoRobotAvailable, NotFound
from fleet.models import Customer, Request
from fleet.services.assignment import assign_new, process_queue, serving_robots
from fleet.services.cancellation import cancel
from fleet.services.common import set_status
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
            await _mark_washed(session, now, cfg, request)
        case Action.PAY:
            if request.is_paid:
                msg = f"request {request_id} is already paid"
                raise Conflict(msg)
            request.is_paid = True
            notify(session, now, recipient="admin", kind="request.paid", request=request,
                   message=f"Request {request.id} was paid.")
    return request


async def _mark_washed(session: AsyncSession, now: datetime, cfg: FleetSettings,
                       request: Request) -> None:
    """Washing done: delivered now by the robot that may go, or queued until one may (the
    robots are out, the one at the front of the base queue still loaded, or the customer's
    line in use). NoRobotAvailable when no active online robot exists at all."""
    if request.washing_done_at is not None:
        msg = f"request {request.id} is already washed; its delivery waits for a robot"
        raise Conflict(msg)
    if not await serving_robots(session, now, cfg):
        msg = f"no robot available to deliver request {request.id}: no active online robot"
        raise NoRobotAvailable(msg)
    if request.washing_started_at is None:
        request.washing_started_at = now
    request.washing_done_at = now
    await process_queue(session, now, cfg)
    if request.status == Status.WASHING:
        log.info("fleet.delivery.queued", request_id=request.id)
        notify(session, now, recipient="admin", kind="delivery.queued", request=request,
               message=(f"Clean laundry of request {request.id} waits for a robot that may "
                        f"go; it is sent with the first one."))


def _kg(weight_kg: float | None) -> str:
    return "no weight" if weight_kg is None else f"{weight_kg:.2f} kg"
