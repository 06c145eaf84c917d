"""Rooms, beacons, customers and robots: created from the site file and admin endpoints."""

from __future__ import annotations

from datetime import datetime

import structlog
from sqlalchemy import select
from sqlalchemy.ext.asyncio import AsyncSession

from fleet.db import SITE, announce
from fleet.errors import Conflict, NotFound
from fleet.models import Beacon, Customer, Robot, Room
from fleet.services.assignment import process_queue
from fleet.services.common import join_base_queue

log = structlog.get_logger(__name__)


def normalize_mac(mac: str) -> str:
    return mac.strip().upper()


async def room_by_name(session: AsyncSession, name: str) -> Room:
    room = (await session.execute(select(Room).where(Room.name == name))).scalar_one_or_none()
    if room is None:
        msg = f"room {name!r} does not exist"
        raise NotFound(msg)
    return room


async def beacon_by_mac(session: AsyncSession, mac: str) -> Beacon:
    beacon = (await session.execute(
        select(Beacon).where(Beacon.mac_address == normalize_mac(mac)))).scalar_one_or_none()
    if beacon is None:
        msg = f"beacon {mac!r} does not exist"
        raise NotFound(msg)
    return beacon


async def put_room(session: AsyncSession, name: str, floor_color: str | None) -> Room:
    """Create the room or update its floor colour."""
    room = (await session.execute(select(Room).where(Room.name == name))).scalar_one_or_none()
    if room is None:
        room = Room(name=name, floor_color=floor_color)
        session.add(room)
    else:
        room.floor_color = floor_color
    await session.flush()
    announce(session, SITE)
    return room


async def put_beacon(
    session: AsyncSession, *, mac: str, name: str, room: str, rssi_threshold_dbm: int,
    is_base: bool, is_active: bool = True,
) -> Beacon:
    """Create or update the beacon with this MAC address."""
    room_row = await room_by_name(session, room)
    mac = normalize_mac(mac)
    beacon = (await session.execute(
        select(Beacon).where(Beacon.mac_address == mac))).scalar_one_or_none()
    if beacon is None:
        beacon = Beacon(mac_address=mac)
        session.add(beacon)
    beacon.name = name
    beacon.room_id = room_row.id
    beacon.rssi_threshold_dbm = rssi_threshold_dbm
    beacon.is_base = is_base
    beacon.is_active = is_active
    await session.flush()
    announce(session, SITE)
    return beacon


async def put_customer(
    session: AsyncSession, *, name: str, room: str | None, beacon: str | None,
    customer_id: int | None = None, create: bool = False,
) -> Customer:
    """Create a customer (``create``) or create/update one by id if given, else by name."""
    room_id = (await room_by_name(session, room)).id if room is not None else None
    beacon_row = await beacon_by_mac(session, beacon) if beacon is not None else None
    if beacon_row is not None and room_id is None:
        room_id = beacon_row.room_id
    if create:
        customer = None
    elif customer_id is not None:
        customer = await session.get(Customer, customer_id)
    else:
        customer = (await session.execute(
            select(Customer).where(Customer.name == name))).scalars().first()
    if customer is None:
        customer = Customer(id=customer_id, name=name)
        session.add(customer)
    customer.name = name
    customer.room_id = room_id
    customer.beacon_id = beacon_row.id if beacon_row is not None else None
    await session.flush()
    announce(session, SITE)
    return customer


async def add_robot(session: AsyncSession, now: datetime, name: str, *, exist_ok: bool) -> Robot:
    """Register a robot. It is offline until its first data exchange: online means reported
    (a robot that was never heard from must not be sent to a customer). It is taken to stand
    at base, behind the robots registered before it."""
    robot = (await session.execute(select(Robot).where(Robot.name == name))).scalar_one_or_none()
    if robot is not None:
        if exist_ok:
            return robot
        msg = f"robot {name!r} already exists"
        raise Conflict(msg)
    robot = Robot(name=name, is_active=True, is_offline=True, emergency_stop=False,
                  maintenance_mode=False, is_in_target=False, last_ping_at=None)
    await join_base_queue(session, robot)
    session.add(robot)
    await session.flush()
    log.info("fleet.robot.added", robot=name)
    return robot


async def update_robot(
    session: AsyncSession, now: datetime, robot: Robot, *, is_active: bool | None,
    emergency_stop: bool | None, maintenance_mode: bool | None,
) -> Robot:
    if is_active is not None:
        robot.is_active = is_active
    if emergency_stop is not None:
        robot.emergency_stop = emergency_stop
    if maintenance_mode is not None:
        robot.maintenance_mode = maintenance_mode
    log.info("fleet.robot.updated", robot=robot.name, active=robot.is_active,
             estop=robot.emergency_stop, maintenance=robot.maintenance_mode)
    await process_queue(session, now)
    return robot
