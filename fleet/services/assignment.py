"""Auto-assignment and the FIFO queue (seed sections 3 and 9)."""

from __future__ import annotations

from datetime import UTC, datetime

import structlog
from sqlalchemy import and_, func, or_, select, update
from sqlalchemy.ext.asyncio import AsyncSession

from fleet.errors import NoRobotAvailable
from fleet.models import Request, Robot
from fleet.services.common import can_serve, is_available, set_status
from fleet.services.lines import blocking, line_map, occupied
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
    robot.has_left_base = False
    if robot.waiting_for_line is not None:
        robot.waiting_for_line = None
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
_DELIVERY = and_(Request.status == Status.WASHING, Request.washing_done_at.is_not(None))
_WAITS = or_(_QUEUED, _DELIVERY)


async def process_queue(
    session: AsyncSession, now: datetime, cfg: FleetSettings | None = None
) -> list[Request]:
    """Dispatch approved Pending requests and washed laundry waiting for delivery, in the
    order they became ready, while robots are available; one for a room on a painted line
    another robot is on waits (``fleet.services.lines``) and the next one that can go goes."""
    # Usually nothing waits: then no need to load every robot (a robot's reconnect, a cancel
    # and a timeout all run this).
    if (await session.execute(select(Request.id).where(_WAITS).limit(1))).first() is None:
        await _clear_line_waits(session)
        return []
    if cfg is None:
        cfg = await load_settings(session)
    lines = await line_map(session)
    robots = await base_queue(session, now, cfg, on_a_line=lines is not None)
    if not robots:
        await _clear_line_waits(session)
        return []
    query = select(Request).where(_WAITS).order_by(
        func.coalesce(Request.washing_done_at, Request.created_at), Request.id)
    pending = (await session.execute(
        query if lines is not None else query.limit(len(robots)))).scalars().all()
    on_line = await occupied(session, lines) if lines is not None else {}
    waiting: dict[int, str] = {}  # free robot id -> the line its next request waits for
    dispatched = []
    for request in pending:
        if not robots:
            break
        line = blocking(lines, on_line, request.customer_id) if lines is not None else None
        if line is not None:
            _wait_for_line(request, robots, waiting, line, on_line[line])
            continue
        robot = robots[0] if lines is not None else next(
            (r for r in robots if r.id == request.assigned_robot_id), robots[0])
        robots.remove(robot)
        waiting.pop(robot.id, None)
        if request.status == Status.WASHING:
            start_delivery(session, request, robot, now)
        else:
            dispatch(request, robot, now)
            notify(session, now, recipient="customer", kind="request.accepted",
                   request=request, robot_name=robot.name,
                   message=f"Robot {robot.name} is on its way.")
        if lines is not None:
            on_line.update(dict.fromkeys(lines.lines_of(request.customer_id), robot.name))
        dispatched.append(request)
    for robot in robots:
        if robot.waiting_for_line != waiting.get(robot.id):
            robot.waiting_for_line = waiting.get(robot.id)
    return dispatched


def start_delivery(session: AsyncSession, request: Request, robot: Robot,
                   now: datetime) -> None:
    """The robot takes the washed laundry to the customer (seed: "Start Delivery")."""
    dispatch(request, robot, now, Status.GOING_TO_ROOM)
    request.weight_kg = None
    request.washing_done_at = None
    notify(session, now, recipient="customer", kind="laundry.delivering", request=request,
           robot_name=robot.name,
           message=f"Your clean laundry is on its way with robot {robot.name}.")


async def base_queue(session: AsyncSession, now: datetime, cfg: FleetSettings, *,
                     on_a_line: bool) -> list[Robot]:
    """The robots that may be sent out now, in the order they go.

    Only a robot standing at base goes (one away with nothing to do is sent back first, seed
    flowchart 10). Where the base is on a painted line (the site declares lines), the robots
    there queue on it and cannot pass each other: the one back at base longest, at the front,
    goes first, and one waiting to be unloaded holds those behind it. Elsewhere any free
    robot goes, the first available (lowest id) first.
    """
    at_base = [r for r in await serving_robots(session, now, cfg)
               if r.base_place is not None and r.current_request_id is None]
    if not on_a_line:
        return [r for r in at_base if is_available(r, now, cfg)]
    queue: list[Robot] = []
    for robot in sorted(at_base, key=lambda r: (r.base_place or 0, r.id)):
        if not is_available(robot, now, cfg):
            break
        queue.append(robot)
    return queue


def _wait_for_line(request: Request, robots: list[Robot], waiting: dict[int, str], line: str,
                   holder: str) -> None:
    """The request waits Pending; its robot (the one named for it if free, else the first
    free one not yet waiting) is told why."""
    robot = next((r for r in robots if r.id == request.assigned_robot_id), None) or next(
        (r for r in robots if r.id not in waiting), None)
    if robot is not None:
        waiting.setdefault(robot.id, line)
        request.assigned_robot_id = robot.id
    log.info("fleet.request.waits_for_line", request_id=request.id, line=line, holder=holder,
             robot=robot.name if robot is not None else None)


async def _clear_line_waits(session: AsyncSession) -> None:
    await session.execute(update(Robot).where(Robot.waiting_for_line.is_not(None))
                          .values(waiting_for_line=None))
