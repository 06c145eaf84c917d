"""Small helpers the services share: status changes and robot/request lookups."""

from __future__ import annotations

from datetime import datetime, timedelta
from typing import Literal

import structlog
from sqlalchemy import func, select
from sqlalchemy.ext.asyncio import AsyncSession

from fleet.errors import NotFound
from fleet.models import Request, Robot
from fleet.settings import FleetSettings
from fleet.status import Status

log = structlog.get_logger(__name__)


def set_status(request: Request, status: Status, now: datetime) -> None:
    old = request.status
    request.status = status
    request.status_changed_at = now
    if status in (Status.ARRIVED_AT_ROOM, Status.ARRIVED_FOR_DELIVERY):
        request.arrived_at = now
    if status in (Status.COMPLETED, Status.DECLINED, Status.CANCELLED):
        request.finished_at = now
    log.info("fleet.request.status", request_id=request.id, old=old, new=str(status))


def is_online(robot: Robot, now: datetime, cfg: FleetSettings) -> bool:
    """Online means reported: the robot has made a data exchange and its last one is younger
    than ``OfflineAfterS`` (a robot registered but never heard from is not online)."""
    return (not robot.is_offline and robot.last_ping_at is not None
            and now - robot.last_ping_at <= timedelta(seconds=cfg.offline_after_s))


def can_serve(robot: Robot, now: datetime, cfg: FleetSettings) -> bool:
    """Active, online, not stopped (by the server's order or its own e-stop latch): the
    seed's "active online robot"."""
    return (robot.is_active and not robot.maintenance_mode and not robot.emergency_stop
            and not robot.estop_active and is_online(robot, now, cfg))


def is_available(robot: Robot, now: datetime, cfg: FleetSettings) -> bool:
    """Can serve, serves nothing, stands at base, and carries nothing (not waiting to be
    unloaded)."""
    return (can_serve(robot, now, cfg) and robot.current_request_id is None
            and robot.base_place is not None and not robot.unload_pending)


def waiting_for(unload_pending: bool, line: str | None) -> Literal["unload", "line"] | None:
    """Why a free robot is not sent out (the exchange's ``WaitingFor``)."""
    if unload_pending:
        return "unload"
    return "line" if line is not None else None


async def robot_by_name(session: AsyncSession, name: str) -> Robot | None:
    result = await session.execute(select(Robot).where(Robot.name == name))
    return result.scalar_one_or_none()


async def registered_robot(session: AsyncSession, name: str) -> Robot:
    """The robot of this name; NotFound when the site does not have it."""
    robot = await robot_by_name(session, name)
    if robot is None:
        msg = f"robot {name!r} is not registered"
        raise NotFound(msg)
    return robot


async def robot_serving(session: AsyncSession, request: Request) -> Robot | None:
    """The robot whose current request this is (serving it or bringing it back to base)."""
    result = await session.execute(select(Robot).where(Robot.current_request_id == request.id))
    return result.scalar_one_or_none()


async def current_request(session: AsyncSession, robot: Robot) -> Request | None:
    if robot.current_request_id is None:
        return None
    return await session.get(Request, robot.current_request_id)


async def join_base_queue(session: AsyncSession, robot: Robot) -> None:
    """The robot stands at base now, behind every robot already there. (A counter, not a
    time: robots back in the same instant, or servers whose clocks differ, keep an order.)"""
    last = (await session.execute(select(func.max(Robot.base_place)))).scalar()
    robot.base_place = (last or 0) + 1


def release(robot: Robot) -> None:
    """The robot is free for the next request (the caller then processes the queue)."""
    log.info("fleet.robot.released", robot=robot.name, request_id=robot.current_request_id)
    robot.current_request_id = None
    robot.is_in_target = False
