"""Auto-assignment and the FIFO queue (seed sections 3 and 9)."""

from __future__ import annotations

from datetime import UTC, datetime

import structlog
from sqlalchemy import and_, select
from sqlalchemy.ext.asyncio import AsyncSession

from fleet.errors import NoRobotAvailable
from fleet.models import Request, Robot
from fleet.services.common import can_serve, is_available, set_status
from fleet.services.notify import notify
from fleet.settings import FleetSettings, load_settings
from fleet.status import Status

log = structlog.get_logger(__name__)

_NEVER = datetime.min.replace(tzinfo=UTC)


async def serving_robots(
    session: AsyncSession, now: datetime, cfg: FleetSettings
) -> list[Robot]:
    """All active online robots, in a stable order ("first available" = lowest id)."""
    robots = (await session.execute(select(Robot).order_by(Robot.id))).scalars().all()
    return [r for r in robots if can_serve(r, now, cfg)]


def dispatch(
    request: Request, robot: Robot, now: datetime, status: Status = Status.ACCEPTED
) -> None:
    """The robot starts line following to the customer's room (Accepted, or delivering)."""
    set_status(request, status, now)
    request.accepted_at = now
    request.assigned_robot_id = robot.id
    robot.current_request_id = request.id
    robot.last_assigned_at = now
    robot.is_in_target = False
    log.info("fleet.robot.dispatched", robot=robot.name, request_id=request.id)


async def assign_new(
    session: AsyncSession, now: datetime, cfg: FleetSettings, request: Request
) -> None:
    """Pick a robot for a new request, then let the queue dispatch it if it may go now.

    Raises NoRobotAvailable when no active online robot exists at all.
    """
    robots = await serving_robots(session, now, cfg)
    if not robots:
        msg = "no robot available: no active online robot"
        raise NoRobotAvailable(msg)
    free = [r for r in robots if r.current_request_id is None]
    if free:
        request.assigned_robot_id = free[0].id
    elif cfg.preempt_busy_robot:
        await _name_least_recent(session, robots, request)
    request.is_approved = cfg.auto_accept
    await process_queue(session, now, cfg)


async def _name_least_recent(
    session: AsyncSession, robots: list[Robot], request: Request
) -> None:
    """``PreemptBusyRobot``: name the least recently assigned busy robot for the new request.

    Seed section 3 also resets that robot's request to Pending and hands the robot to the new
    one. But the queue is FIFO (sections 1 and 9) and the reset request is older than the new
    one, so the freed robot went straight back to it: a spurious ``request.requeued`` notice,
    a fresh navigation timer, and the new request waiting anyway (and on one painted line a
    robot cannot be overtaken). Nothing is reset here: the new request waits in the queue
    with that robot named, and is served by whichever robot is free first. Only robots still
    on their way to a customer (Accepted) are named: one holding laundry has far to go.
    """
    candidates: list[tuple[datetime, int, Robot]] = []
    for robot in robots:
        current = (await session.get(Request, robot.current_request_id)
                   if robot.current_request_id is not None else None)
        if current is not None and current.status == Status.ACCEPTED:
            candidates.append((robot.last_assigned_at or _NEVER, robot.id, robot))
    if not candidates:
        return
    _, _, robot = min(candidates, key=lambda c: (c[0], c[1]))
    request.assigned_robot_id = robot.id
    log.info("fleet.robot.named", robot=robot.name, request_id=request.id,
             serving=robot.current_request_id)


_QUEUED = and_(Request.status == Status.PENDING, Request.is_approved.is_(True))


async def process_queue(
    session: AsyncSession, now: datetime, cfg: FleetSettings | None = None
) -> list[Request]:
    """Dispatch approved Pending requests, oldest first, while robots are available."""
    # Usually nothing waits: then no need to load every robot (a robot's reconnect, a cancel
    # and a timeout all run this).
    if (await session.execute(select(Request.id).where(_QUEUED).limit(1))).first() is None:
        return []
    if cfg is None:
        cfg = await load_settings(session)
    robots = [r for r in await serving_robots(session, now, cfg) if is_available(r, now, cfg)]
    if not robots:
        return []
    pending = (await session.execute(
        select(Request)
        .where(_QUEUED)
        .order_by(Request.created_at, Request.id)
        .limit(len(robots))
    )).scalars().all()
    dispatched = []
    for request in pending:
        robot = next((r for r in robots if r.id == request.assigned_robot_id), robots[0])
        robots.remove(robot)
        dispatch(request, robot, now)
        notify(session, now, recipient="customer", kind="request.accepted", request=request,
               robot_name=robot.name, message=f"Robot {robot.name} is on its way.")
        dispatched.append(request)
    return dispatched


async def pick_delivery_robot(
    session: AsyncSession, now: datetime, cfg: FleetSettings, request: Request
) -> Robot:
    """An available robot for delivering clean laundry (the original one if it is free)."""
    robots = [r for r in await serving_robots(session, now, cfg) if is_available(r, now, cfg)]
    if not robots:
        msg = f"no robot available to deliver request {request.id}; try again later"
        raise NoRobotAvailable(msg)
    return next((r for r in robots if r.id == request.assigned_robot_id), robots[0])
