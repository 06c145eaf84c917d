"""Admin endpoints: robots, rooms, beacons, customers, settings, notifications."""

from __future__ import annotations

from typing import Annotated, Any

from fastapi import APIRouter, Depends, Path, Query
from fastapi import Request as HttpRequest
from pydantic import ValidationError
from sqlalchemy import select

from fleet.api.auth import Admin
from fleet.api.auth import admin as admin_only
from fleet.api.deps import AUTH_ERRORS, ERRORS, errors, robot_out, server_of
from fleet.api.schemas import (
    BeaconIn,
    BeaconOut,
    CustomerIn,
    CustomerOut,
    LineIn,
    LineOut,
    MaintenanceIn,
    NotificationOut,
    RobotIn,
    RobotOut,
    RobotPatch,
    RoomIn,
    RoomOut,
)
from fleet.errors import Conflict
from fleet.models import Beacon, Customer, Notification, Robot, Room
from fleet.services import admin, lines, robot_commands, unload
from fleet.services.assignment import process_queue
from fleet.services.common import registered_robot
from fleet.services.notify import notification_out
from fleet.settings import SettingsUpdate, load_settings, store_settings

router = APIRouter(prefix="/api", tags=["admin"], responses=AUTH_ERRORS,
                   dependencies=[Depends(admin_only)])

Name = Annotated[str, Path(min_length=1, max_length=100, pattern=r"^[^\x00-\x1f\x7f]+$")]


@router.get("/robots", response_model=list[RobotOut])
async def list_robots(http: HttpRequest) -> list[RobotOut]:
    await server_of(http).flush_pings()
    async with server_of(http).db.read() as session:
        robots = (await session.execute(select(Robot).order_by(Robot.id))).scalars().all()
        return [robot_out(r) for r in robots]


@router.post("/robots", status_code=201, response_model=RobotOut, responses=errors(409, 413))
async def add_robot(body: RobotIn, http: HttpRequest) -> RobotOut:
    server = server_of(http)
    async with server.db.write() as session:
        robot = await admin.add_robot(session, server.clock(), body.Name, exist_ok=False)
        return robot_out(robot)


@router.get("/robots/{name}", response_model=RobotOut, responses=errors(404))
async def get_robot(name: Name, http: HttpRequest) -> RobotOut:
    await server_of(http).flush_pings()
    async with server_of(http).db.read() as session:
        return robot_out(await _robot(session, name))


@router.patch("/robots/{name}", response_model=RobotOut, responses=ERRORS)
async def patch_robot(name: Name, body: RobotPatch, http: HttpRequest) -> RobotOut:
    """Enable/disable a robot, emergency stop, maintenance mode."""
    server = server_of(http)
    await server.flush_pings()  # a robot released now is dispatched on its latest report
    async with server.db.write() as session:
        robot = await admin.update_robot(
            session, server.clock(), await _robot(session, name), is_active=body.IsActive,
            emergency_stop=body.EmergencyStop, maintenance_mode=body.MaintenanceMode)
        return robot_out(robot)


@router.post("/robots/{name}/estop", response_model=RobotOut, responses=errors(404))
async def robot_estop(name: Name, http: HttpRequest, caller: Admin) -> RobotOut:
    """Order any robot into emergency stop (``EmergencyStop`` true): it stops at its next
    report (data exchange or site status), through its own e-stop."""
    server = server_of(http)
    async with server.db.write() as session:
        return robot_out(await robot_commands.estop(session, name, caller.subject,
                                                    now=server.clock()))


@router.post("/robots/{name}/resume", response_model=RobotOut, responses=errors(404))
async def robot_resume(name: Name, http: HttpRequest, caller: Admin) -> RobotOut:
    """Lift the server's emergency stop; the robot resumes at its next report (an e-stop a
    person latched on the robot stays until lifted there)."""
    server = server_of(http)
    await server.flush_pings()  # a robot released now is dispatched on its latest report
    async with server.db.write() as session:
        return robot_out(await robot_commands.resume(session, name, caller.subject,
                                                     now=server.clock()))


@router.post("/robots/{name}/maintenance", response_model=RobotOut, responses=ERRORS)
async def robot_maintenance(name: Name, body: MaintenanceIn, http: HttpRequest,
                            caller: Admin) -> RobotOut:
    """``{"On": true}`` puts the robot into maintenance (stopped, out of service) at its next
    report; ``{"On": false}`` takes it out."""
    server = server_of(http)
    await server.flush_pings()
    async with server.db.write() as session:
        return robot_out(await robot_commands.maintenance(session, name, caller.subject,
                                                          on=body.On, now=server.clock()))


@router.post("/robots/{name}/unloaded", response_model=RobotOut, responses=errors(404, 409))
async def robot_unloaded(name: Name, http: HttpRequest) -> RobotOut:
    """The staff took the load off a robot back at base (``WaitingFor`` "unload"): it serves
    the queue at once, without waiting for its load cell to settle. 409 when it is not
    waiting to be unloaded."""
    server = server_of(http)
    await server.flush_pings()  # dispatched on its latest report
    async with server.db.write() as session:
        robot = await _robot(session, name)
        await unload.confirm_unloaded(session, server.clock(), await load_settings(session),
                                      robot)
        return robot_out(robot)


async def _robot(session: Any, name: str) -> Robot:
    return await registered_robot(session, name)


@router.get("/rooms", response_model=list[RoomOut])
async def list_rooms(http: HttpRequest) -> list[RoomOut]:
    async with server_of(http).db.read() as session:
        rooms = (await session.execute(select(Room).order_by(Room.id))).scalars().all()
        return [RoomOut(Id=r.id, Name=r.name, FloorColor=r.floor_color) for r in rooms]


@router.put("/rooms", response_model=RoomOut, responses=ERRORS)
async def put_room(body: RoomIn, http: HttpRequest) -> RoomOut:
    """Create a room, or set the floor colour of an existing one."""
    async with server_of(http).db.write() as session:
        room = await admin.put_room(session, body.Name, body.FloorColor)
    server_of(http).cache.invalidate()
    return RoomOut(Id=room.id, Name=room.name, FloorColor=room.floor_color)


@router.get("/beacons", response_model=list[BeaconOut])
async def list_beacons(http: HttpRequest) -> list[BeaconOut]:
    async with server_of(http).db.read() as session:
        rows = (await session.execute(
            select(Beacon, Room).join(Room, Beacon.room_id == Room.id).order_by(Beacon.id)
        )).all()
        return [_beacon_out(b, r) for b, r in rows]


@router.put("/beacons", response_model=BeaconOut, responses=ERRORS)
async def put_beacon(body: BeaconIn, http: HttpRequest) -> BeaconOut:
    """Create or update the beacon with this MAC address."""
    async with server_of(http).db.write() as session:
        beacon = await admin.put_beacon(
            session, mac=body.MacAddress, name=body.Name, room=body.RoomName,
            rssi_threshold_dbm=body.RssiThreshold, is_base=body.IsBase, is_active=body.IsActive)
        room = await session.get(Room, beacon.room_id)
        assert room is not None
    server_of(http).cache.invalidate()
    return _beacon_out(beacon, room)


def _beacon_out(beacon: Beacon, room: Room) -> BeaconOut:
    return BeaconOut(Id=beacon.id, MacAddress=beacon.mac_address, Name=beacon.name,
                     RoomName=room.name, RssiThreshold=beacon.rssi_threshold_dbm,
                     IsBase=beacon.is_base, IsActive=beacon.is_active)


@router.get("/lines", response_model=list[LineOut])
async def list_lines(http: HttpRequest) -> list[LineOut]:
    """The painted lines that rooms share, each with its rooms."""
    async with server_of(http).db.read() as session:
        return [LineOut(Name=name, Rooms=rooms)
                for name, rooms in (await lines.all_lines(session)).items()]


@router.put("/lines", response_model=LineOut, responses=ERRORS)
async def put_line(body: LineIn, http: HttpRequest) -> LineOut:
    """Declare a painted line that these rooms share (at most one robot travels it at a
    time), or replace its rooms; no rooms removes it. 404 for a room that does not exist."""
    server = server_of(http)
    await server.flush_pings()
    async with server.db.write() as session:
        rooms = [(await admin.room_by_name(session, room)).id for room in body.Rooms]
        await lines.put_line(session, body.Name, rooms)
        await process_queue(session, server.clock())  # a line removed may free a request
        found = (await lines.all_lines(session)).get(body.Name, [])
    return LineOut(Name=body.Name, Rooms=found)


@router.get("/customers", response_model=list[CustomerOut])
async def list_customers(http: HttpRequest) -> list[CustomerOut]:
    async with server_of(http).db.read() as session:
        customers = (await session.execute(select(Customer).order_by(Customer.id))).scalars()
        return [await _customer_out(session, c) for c in customers.all()]


@router.post("/customers", status_code=201, response_model=CustomerOut, responses=ERRORS)
async def add_customer(body: CustomerIn, http: HttpRequest) -> CustomerOut:
    async with server_of(http).db.write() as session:
        customer = await admin.put_customer(session, name=body.Name, room=body.RoomName,
                                            beacon=body.BeaconMacAddress, customer_id=None,
                                            create=True)
        out = await _customer_out(session, customer)
    server_of(http).cache.invalidate()
    return out


async def _customer_out(session: Any, customer: Customer) -> CustomerOut:
    beacon = (await session.get(Beacon, customer.beacon_id)
              if customer.beacon_id is not None else None)
    return CustomerOut(Id=customer.id, Name=customer.name, RoomId=customer.room_id,
                       BeaconMacAddress=beacon.mac_address if beacon is not None else None)


@router.get("/settings")
async def get_settings(http: HttpRequest) -> dict[str, Any]:
    return (await server_of(http).settings()).public()


@router.put("/settings", responses=errors(409, 413))
async def put_settings(body: SettingsUpdate, http: HttpRequest) -> dict[str, Any]:
    """Change settings (AutoAccept, timeouts, weights...); only the keys given change. 409
    when the result would not hold together (MinWeightKg not below MaxWeightKg)."""
    async with server_of(http).db.write() as session:
        try:
            merged = await store_settings(session, body.given())
        except ValidationError as exc:
            raise Conflict("; ".join(str(e["msg"]) for e in exc.errors())) from exc
    server_of(http).cache.invalidate()
    server_of(http).webhooks.urls = merged.webhook_urls
    return merged.public()


@router.get("/notifications", response_model=list[NotificationOut])
async def list_notifications(
    http: HttpRequest,
    recipient: Annotated[str | None, Query(pattern="^(customer|admin)$")] = None,
    request_id: Annotated[int | None, Query(ge=1, le=2**31 - 1)] = None,
    customer_id: Annotated[int | None, Query(ge=1, le=2**31 - 1)] = None,
    limit: Annotated[int, Query(ge=1, le=1000)] = 100,
) -> list[NotificationOut]:
    """Stored notifications, newest first."""
    query = select(Notification).order_by(Notification.id.desc()).limit(limit)
    if recipient is not None:
        query = query.where(Notification.recipient == recipient)
    if request_id is not None:
        query = query.where(Notification.request_id == request_id)
    if customer_id is not None:
        query = query.where(Notification.customer_id == customer_id)
    async with server_of(http).db.read() as session:
        rows = (await session.execute(query)).scalars().all()
        return [notification_out(n) for n in rows]
