"""Alerts for the laundry staff (issue 27): raised by the monitors and the data exchange,
acknowledged and resolved by staff; resolving a laundry alert says where the laundry is and
moves the request and its robot to a state that matches.

Kinds: ``robot.offline.laundry`` (a robot offline holding laundry, seed section 13),
``request.stuck`` (a loaded robot that does not reach base, or does not get back after a
delivery), both *laundry alerts*; and ``robot.fault`` (a fault the robot reports).
"""

from __future__ import annotations

from collections.abc import Collection
from datetime import datetime
from enum import StrEnum

import structlog
from sqlalchemy import select
from sqlalchemy.ext.asyncio import AsyncSession

from fleet.errors import Conflict, Invalid, NotFound
from fleet.models import Alert, Request
from fleet.services.assignment import process_queue
from fleet.services.cancellation import cancel
from fleet.services.common import release, robot_serving, set_status
from fleet.services.notify import notify
from fleet.status import CLEAN_ABOARD, DIRTY_ABOARD, Disposition, Status

log = structlog.get_logger(__name__)

OFFLINE_LAUNDRY = "robot.offline.laundry"
STUCK = "request.stuck"
FAULT = "robot.fault"
LAUNDRY_KINDS = frozenset({OFFLINE_LAUNDRY, STUCK})


class LaundryAt(StrEnum):
    """Where the staff found the laundry of a laundry alert."""

    ROBOT = "robot"
    BASE = "base"
    CUSTOMER = "customer"


def raise_alert(
    session: AsyncSession, now: datetime, *, kind: str, level: str, message: str,
    robot_name: str | None = None, request: Request | None = None, code: str | None = None,
) -> Alert:
    """Store an open alert and tell the admin (a notification of the same kind); ``code``
    says what a ``robot.fault`` is (``docking_gave_up``, a RelayBot error category)."""
    alert = Alert(created_at=now, kind=kind, level=level, message=message,
                  robot_name=robot_name, request_id=request.id if request is not None else None,
                  code=code)
    session.add(alert)
    notify(session, now, recipient="admin", kind=kind, level=level, message=message,
           request=request, robot_name=robot_name)
    log.warning("fleet.alert.raised", kind=kind, level=level, robot=robot_name,
                request_id=alert.request_id, code=code)
    return alert


async def open_alerts(
    session: AsyncSession, *, kinds: Collection[str], request_id: int | None = None,
    robot_name: str | None = None,
) -> list[Alert]:
    query = select(Alert).where(Alert.resolved_at.is_(None), Alert.kind.in_(list(kinds)))
    if request_id is not None:
        query = query.where(Alert.request_id == request_id)
    if robot_name is not None:
        query = query.where(Alert.robot_name == robot_name)
    return list((await session.execute(query.order_by(Alert.id))).scalars())


async def close_alerts(
    session: AsyncSession, now: datetime, *, kinds: Collection[str], resolution: str,
    by: str = "server", request_id: int | None = None, robot_name: str | None = None,
) -> list[Alert]:
    """Resolve the open alerts of these kinds (of this request or robot): what they warned of
    is over (the robot is back, the fault cleared, the request moved on)."""
    closed = await open_alerts(session, kinds=kinds, request_id=request_id,
                               robot_name=robot_name)
    for alert in closed:
        _mark_resolved(alert, now, by, resolution)
    return closed


def _mark_resolved(alert: Alert, now: datetime, by: str, resolution: str) -> None:
    alert.resolved_at = now
    alert.resolved_by = by
    alert.resolution = resolution
    log.info("fleet.alert.resolved", alert_id=alert.id, kind=alert.kind, by=by,
             resolution=resolution)


async def _alert(session: AsyncSession, alert_id: int) -> Alert:
    alert = await session.get(Alert, alert_id)
    if alert is None:
        msg = f"alert {alert_id} does not exist"
        raise NotFound(msg)
    return alert


async def acknowledge(session: AsyncSession, now: datetime, alert_id: int, by: str) -> Alert:
    """A person has seen it. Raises NotFound, or Conflict when it is resolved already."""
    alert = await _alert(session, alert_id)
    if alert.resolved_at is not None:
        msg = f"alert {alert_id} is resolved already ({alert.resolution})"
        raise Conflict(msg)
    if alert.acknowledged_at is None:
        alert.acknowledged_at = now
        alert.acknowledged_by = by
        log.info("fleet.alert.acknowledged", alert_id=alert_id, by=by)
    return alert


async def resolve(
    session: AsyncSession, now: datetime, alert_id: int, by: str,
    laundry_at: LaundryAt | None,
) -> Alert:
    """Staff resolve an alert; for a laundry alert ``laundry_at`` says where the laundry is,
    and the request and its robot are moved to match. Raises NotFound, Conflict (resolved
    already), Invalid (``laundry_at`` missing for a laundry alert, or given for another)."""
    alert = await _alert(session, alert_id)
    if alert.resolved_at is not None:
        msg = f"alert {alert_id} is resolved already ({alert.resolution})"
        raise Conflict(msg)
    if alert.kind not in LAUNDRY_KINDS:
        if laundry_at is not None:
            msg = f"LaundryAt: alert {alert_id} ({alert.kind}) is not about laundry"
            raise Invalid(msg)
        _mark_resolved(alert, now, by, "Resolved")
        return alert
    if laundry_at is None:
        msg = (f"LaundryAt is required: alert {alert_id} ({alert.kind}) is about laundry; "
               f"say where it is: robot, base or customer")
        raise Invalid(msg)
    request = (await session.get(Request, alert.request_id)
               if alert.request_id is not None else None)
    resolution = f"Laundry{laundry_at.capitalize()}" if laundry_at != LaundryAt.CUSTOMER \
        else "LaundryReturnedToCustomer"
    if request is not None and laundry_at != LaundryAt.ROBOT:
        await _laundry_moved(session, now, request, laundry_at)
    for other in await open_alerts(session, kinds=LAUNDRY_KINDS, request_id=alert.request_id):
        _mark_resolved(other, now, by, resolution)
    _mark_resolved(alert, now, by, resolution)
    await process_queue(session, now)
    return alert


async def _laundry_moved(
    session: AsyncSession, now: datetime, request: Request, where: LaundryAt
) -> None:
    """The staff took the laundry off the robot (to the base or back to the customer): the
    request goes on without the robot, which is released."""
    robot = await robot_serving(session, request)
    status = Status(request.status)
    cancelled = status == Status.CANCELLED
    prior = Status(request.cancelled_from) if cancelled and request.cancelled_from else status
    if where == LaundryAt.CUSTOMER:
        await _returned_to_customer(session, now, request, status)
    elif status in DIRTY_ABOARD:
        set_status(request, Status.WASHING, now)
        notify(session, now, recipient="admin", kind="laundry.at_base", request=request,
               message=f"Laundry of request {request.id} is at base (put there by staff).")
    elif status in CLEAN_ABOARD:
        # Held at base for delivery again: back to Washing with its washing done; the next
        # washing-done sends it out with a free robot.
        set_status(request, Status.WASHING, now)
        request.weight_kg = None
        request.washing_done_at = None
        if request.washing_started_at is None:
            request.washing_started_at = now
        notify(session, now, recipient="admin", kind="laundry.held_at_base", request=request,
               message=(f"Clean laundry of request {request.id} is held at base: mark "
                        f"washing-done to deliver it again."))
    elif status == Status.GOING_TO_BASE:
        set_status(request, Status.COMPLETED, now)  # the customer has the laundry already
    elif cancelled:
        request.disposition = (Disposition.DIRTY_AT_BASE if prior in DIRTY_ABOARD
                               else Disposition.HELD_AT_BASE)
    request.admin_alert = None
    if cancelled or request.status in (Status.CANCELLED, Status.COMPLETED):
        request.robot_returned = True
    if robot is not None:
        release(robot)
        robot.base_place = None  # wherever it is, it is not at base: it is sent there
    log.info("fleet.alert.laundry_moved", request_id=request.id, where=str(where),
             status=request.status, robot=robot.name if robot is not None else None)


async def _returned_to_customer(
    session: AsyncSession, now: datetime, request: Request, status: Status
) -> None:
    if status == Status.GOING_TO_BASE:
        set_status(request, Status.COMPLETED, now)
        return
    if status != Status.CANCELLED:
        await cancel(session, now, request, reason="LaundryReturned",
                     message=f"Request {request.id} was cancelled: your laundry was returned.")
    request.disposition = Disposition.RETURNED_TO_CUSTOMER
