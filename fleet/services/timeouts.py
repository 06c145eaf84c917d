"""The timeout monitor's check (seed section 10): robots that do not arrive, customers who do
not load or unload."""

from __future__ import annotations

from datetime import datetime, timedelta

import structlog
from sqlalchemy import Connection, select
from sqlalchemy.ext.asyncio import AsyncSession

from fleet.models import Request
from fleet.services.assignment import process_queue
from fleet.services.cancellation import cancel
from fleet.services.common import robot_serving
from fleet.settings import FleetSettings, read_settings
from fleet.status import Status

log = structlog.get_logger(__name__)

_WATCHED = {
    Status.ACCEPTED: ("accepted_timeout_s", "NavigationTimeout", "the robot did not arrive"),
    Status.GOING_TO_ROOM: (
        "accepted_timeout_s", "NavigationTimeout", "the robot did not arrive for delivery"),
    Status.ARRIVED_AT_ROOM: ("arrived_timeout_s", "LoadTimeout", "the laundry was not loaded"),
    Status.ARRIVED_FOR_DELIVERY: (
        "delivery_arrived_timeout_s", "UnloadTimeout", "the laundry was not taken out"),
}


_WATCHED_SINCE = select(Request.status, Request.status_changed_at).where(
    Request.status.in_(list(_WATCHED)))


def _since(request: Request) -> datetime:
    return request.status_changed_at


def _timed_out(status: str, since: datetime, now: datetime, cfg: FleetSettings) -> bool:
    """Whether a request in watched ``status`` since ``since`` has waited past its limit."""
    limit_s = float(getattr(cfg, _WATCHED[Status(status)][0]))
    return now - since > timedelta(seconds=limit_s)


def any_timed_out(conn: Connection, now: datetime) -> bool:
    """Whether ``check_timeouts`` would cancel a request now: the same test on the same rows,
    read with Core (nearly every pass of the monitor finds nothing to do)."""
    cfg = read_settings(conn)
    return any(_timed_out(status, since, now, cfg)
               for status, since in conn.execute(_WATCHED_SINCE))


async def check_timeouts(session: AsyncSession, now: datetime, cfg: FleetSettings) -> list[int]:
    """Cancel timed-out requests and send their robots to base; returns the cancelled ids."""
    requests = (await session.execute(
        select(Request).where(Request.status.in_(list(_WATCHED))).order_by(Request.id)
    )).scalars().all()
    cancelled = []
    for request in requests:
        if not _timed_out(request.status, _since(request), now, cfg):
            continue
        _key, reason, what = _WATCHED[Status(request.status)]
        robot = await robot_serving(session, request)
        await cancel(session, now, request, reason=reason,
                     message=f"Request {request.id} was cancelled: {what} in time.")
        cancelled.append(request.id)
        if robot is None:
            continue
        last_ping = robot.last_ping_at
        alive = last_ping is not None and now - last_ping <= timedelta(seconds=cfg.offline_after_s)
        if alive and not robot.is_offline:
            log.info("fleet.timeout.return_to_base", robot=robot.name, request_id=request.id)
        else:
            robot.is_offline = True
            log.warning("fleet.robot.disconnected", robot=robot.name, request_id=request.id)
    if cancelled:
        await process_queue(session, now, cfg)
    return cancelled
