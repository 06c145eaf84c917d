"""The timeout monitor's check (seed section 10): robots that do not arrive, customers who do
not load or unload."""

from __future__ import annotations

from datetime import datetime, timedelta

import structlog
from sqlalchemy import Connection, select
from sqlalchemy.ext.asyncio import AsyncSession

from fleet.models import Request
from fleet.services.alerts import STUCK, open_alerts, raise_alert
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


# The robot holds laundry in these (or has just delivered it): a request that takes too long
# is not cancelled (the laundry must be found first) but raises a stuck alert, once.
_STUCK = {
    Status.LAUNDRY_LOADED: ("laundry_loaded_timeout_s", "critical",
                            "has not brought the laundry to base"),
    Status.GOING_TO_BASE: ("going_to_base_timeout_s", "warning",
                           "has not got back to base after the delivery"),
}

_WATCHED_SINCE = select(Request.status, Request.status_changed_at, Request.admin_alert).where(
    Request.status.in_([*_WATCHED, *_STUCK]))


def _since(request: Request) -> datetime:
    return request.status_changed_at


def _timed_out(status: str, since: datetime, now: datetime, cfg: FleetSettings) -> bool:
    """Whether a request in watched ``status`` since ``since`` has waited past its limit."""
    key = _WATCHED[Status(status)][0] if status in _WATCHED else _STUCK[Status(status)][0]
    limit_s = float(getattr(cfg, key))
    return now - since > timedelta(seconds=limit_s)


def _due(status: str, since: datetime, admin_alert: str | None, now: datetime,
         cfg: FleetSettings) -> bool:
    """A watched request past its limit, or a stuck one past its limit not yet alerted."""
    return (status in _WATCHED or admin_alert is None) and _timed_out(status, since, now, cfg)


def any_timed_out(conn: Connection, now: datetime) -> bool:
    """Whether ``check_timeouts`` would act now: the same test on the same rows, read with
    Core (nearly every pass of the monitor finds nothing to do)."""
    cfg = read_settings(conn)
    return any(_due(status, since, alert, now, cfg)
               for status, since, alert in conn.execute(_WATCHED_SINCE))


async def check_timeouts(session: AsyncSession, now: datetime, cfg: FleetSettings) -> list[int]:
    """Cancel timed-out requests and send their robots to base, and raise an alert for stuck
    ones; returns the cancelled ids."""
    requests = (await session.execute(
        select(Request).where(Request.status.in_([*_WATCHED, *_STUCK])).order_by(Request.id)
    )).scalars().all()
    cancelled = []
    for request in requests:
        if not _due(request.status, _since(request), request.admin_alert, now, cfg):
            continue
        if request.status in _STUCK:
            await _stuck(session, now, request)
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


async def _stuck(session: AsyncSession, now: datetime, request: Request) -> None:
    """The robot holds the laundry (or has just delivered it) and is late: the staff must
    find it. One alert while it lasts; ``AdminAlert`` shows it on the request."""
    _key, level, what = _STUCK[Status(request.status)]
    robot = await robot_serving(session, request)
    name = robot.name if robot is not None else "?"
    request.admin_alert = f"Robot {name} stuck in {request.status}"
    if await open_alerts(session, kinds=[STUCK], request_id=request.id):
        return
    raise_alert(session, now, kind=STUCK, level=level, request=request,
                robot_name=robot.name if robot is not None else None,
                message=(f"Robot {name} {what} (request {request.id}, {request.status} since "
                         f"{request.status_changed_at:%H:%M:%S}): please find it."))
