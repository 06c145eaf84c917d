"""Navigation targets per request status, sent back in every data exchange (seed section 5)."""

from __future__ import annotations

from dataclasses import dataclass

from sqlalchemy import select
from sqlalchemy.ext.asyncio import AsyncSession

from fleet.models import Beacon, Customer, Request, Robot, Room
from fleet.settings import FleetSettings
from fleet.status import HEADS_TO_BASE, HEADS_TO_CUSTOMER, Status


@dataclass(frozen=True)
class BeaconConfig:
    mac_address: str
    name: str
    room_name: str
    rssi_threshold_dbm: int
    is_navigation_target: bool


@dataclass(frozen=True)
class Navigation:
    beacons: list[BeaconConfig]
    is_line_following: bool
    follow_color: str | None


async def customer_room_id(session: AsyncSession, request: Request) -> int | None:
    """The room of the customer's assigned beacon; None when the customer has no beacon."""
    customer = await session.get(Customer, request.customer_id)
    if customer is None or customer.beacon_id is None:
        return None
    beacon = await session.get(Beacon, customer.beacon_id)
    return beacon.room_id if beacon is not None else None


async def customer_room_beacons(session: AsyncSession, request: Request) -> list[Beacon]:
    room_id = await customer_room_id(session, request)
    if room_id is None:
        return []
    result = await session.execute(
        select(Beacon).where(Beacon.room_id == room_id, Beacon.is_active.is_(True)))
    return list(result.scalars().all())


def heads_to_base(request: Request) -> bool:
    if request.status == Status.CANCELLED:
        return not request.robot_returned
    return request.status in HEADS_TO_BASE


async def navigation(
    session: AsyncSession, cfg: FleetSettings, robot: Robot, request: Request | None
) -> Navigation:
    """The beacon configuration, targets and line-following order for ``robot``."""
    rows = (await session.execute(
        select(Beacon, Room).join(Room, Beacon.room_id == Room.id)
        .where(Beacon.is_active.is_(True)).order_by(Beacon.id)
    )).all()
    target_room: int | None = None
    to_base = False
    if request is not None and request.status in HEADS_TO_CUSTOMER:
        target_room = await customer_room_id(session, request)
    elif request is not None and heads_to_base(request):
        to_base = True

    def is_target(beacon: Beacon) -> bool:
        return beacon.is_base if to_base else beacon.room_id == target_room

    beacons = [
        BeaconConfig(beacon.mac_address, beacon.name, room.name, beacon.rssi_threshold_dbm,
                     is_target(beacon))
        for beacon, room in rows
    ]
    targets = [(b, room) for (b, room), cfg_b in zip(rows, beacons, strict=True)
               if cfg_b.is_navigation_target]
    follow_color = None
    if targets and cfg.use_floor_color:
        follow_color = targets[0][1].floor_color
    moving = bool(targets) and not robot.emergency_stop and not robot.maintenance_mode
    return Navigation(beacons, moving, follow_color)
