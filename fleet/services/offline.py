"""Robots that stop pinging and come back (seed section 13)."""

from __future__ import annotations

from collections.abc import Collection
from datetime import datetime, timedelta

import structlog
from sqlalchemy import select
from sqlalchemy.ext.asyncio import AsyncSession

from fleet.models import Request, Robot
from fleet.services.alerts import OFFLINE_LAUNDRY, close_alerts, open_alerts, raise_alert
from fleet.services.assignment import process_queue
from fleet.services.cancellation import cancel
from fleet.services.common import current_request
from fleet.services.notify import notify
from fleet.settings import FleetSettings
from fleet.status import Disposition, Status

log = structlog.get_logger(__name__)

_CANCEL = frozenset({Status.ACCEPTED, Status.ARRIVED_AT_ROOM})
_CRITICAL = frozenset({Status.LAUNDRY_LOADED, Status.GOING_TO_ROOM, Status.ARRIVED_FOR_DELIVERY})


async def check_offline(session: AsyncSession, now: datetime, cfg: FleetSettings) -> list[str]:
    """Mark robots whose last ping is too old offline and act on their request."""
    robots = (await session.execute(
        select(Robot).where(Robot.is_offline.is_(False)).order_by(Robot.id)
    )).scalars().all()
    went = []
    limit = timedelta(seconds=cfg.offline_after_s)
    for robot in robots:
        if robot.last_ping_at is not None and now - robot.last_ping_at <= limit:
            continue
        robot.is_offline = True
        went.append(robot.name)
        await _handle_request(session, now, robot)
    return went


async def _handle_request(session: AsyncSession, now: datetime, robot: Robot) -> None:
    request = await current_request(session, robot)
    status = Status(request.status) if request is not None else None
    log.warning("fleet.robot.offline", robot=robot.name,
                request_id=request.id if request else None, status=status)
    if request is None or status is None:
        pending = (await session.execute(select(Request.id).where(
            Request.status == Status.PENDING, Request.assigned_robot_id == robot.id))).all()
        if pending:
            log.info("fleet.robot.offline.pending_kept", robot=robot.name,
                     requests=[p[0] for p in pending])
        return
    if status in _CANCEL:
        await cancel(session, now, request, reason="RobotOffline",
                     message=(f"Service disruption: robot {robot.name} went offline, so request "
                              f"{request.id} was cancelled. You may ask for a refund or "
                              f"create a new request for another robot."))
    elif status in _CRITICAL or (status == Status.CANCELLED and not request.robot_returned
                                 and request.cancelled_from in _CRITICAL):
        request.admin_alert = f"Robot {robot.name} offline holding laundry"
        if not await open_alerts(session, kinds=[OFFLINE_LAUNDRY], request_id=request.id):
            raise_alert(session, now, kind=OFFLINE_LAUNDRY, level="critical",
                        request=request, robot_name=robot.name,
                        message=(f"Robot {robot.name} went offline holding the laundry of "
                                 f"request {request.id} ({status}): manual recovery needed."))
    elif status == Status.GOING_TO_BASE:
        notify(session, now, recipient="admin", kind="robot.offline", level="warning",
               request=request, robot_name=robot.name,
               message=f"Robot {robot.name} went offline on its way back to base.")


async def restore(session: AsyncSession, now: datetime, robot: Robot) -> None:
    """The robot pinged again: back online, resume its work, serve the queue."""
    await restore_many(session, now, [robot])


async def restore_many(session: AsyncSession, now: datetime, robots: list[Robot],
                       first_reports: Collection[str] = ()) -> None:
    """Robots that pinged again, back online together: each resumes its work (its request's
    offline alert is cleared, the admin told), then the queue is served once for all.

    Args:
        first_reports: names of robots heard from for the first time (registered, never
            reported): they come online rather than back.
    """
    ids = [r.current_request_id for r in robots if r.current_request_id is not None]
    requests = {r.id: r for r in (await session.execute(
        select(Request).where(Request.id.in_(ids)))).scalars()} if ids else {}
    for robot in robots:
        robot.is_offline = False
        request = (requests.get(robot.current_request_id)
                   if robot.current_request_id is not None else None)
        if request is not None and request.admin_alert is not None:
            # (An open offline alert always has AdminAlert set: most robots coming back in a
            # storm have none, and cost no alert query.)
            request.admin_alert = None
            if request.disposition != Disposition.ON_ROBOT:
                # Back with the laundry and on its way again. (Cancelled while it was away,
                # the laundry's fate is the staff's to record: that alert stays open.)
                await close_alerts(session, now, kinds=[OFFLINE_LAUNDRY],
                                   request_id=request.id, resolution="RobotReconnected",
                                   by=robot.name)
        if robot.name in first_reports:
            notify(session, now, recipient="admin", kind="robot.online", robot_name=robot.name,
                   message=f"Robot {robot.name} reported for the first time.")
            log.info("fleet.robot.first_report", robot=robot.name)
            continue
        notify(session, now, recipient="admin", kind="robot.reconnected", robot_name=robot.name,
               request=request, message=f"Robot {robot.name} is back online.")
        log.info("fleet.robot.reconnected", robot=robot.name)
    await process_queue(session, now)
