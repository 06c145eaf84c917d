"""Every robot as the console shows it: one ``RobotView`` a robot, made in one place.

The board's robot table, the site map, the robot page and the pushed ``robots`` events all
read ``robot_views(session)``; what a robot reports of itself reaches every page through it
(more profiles and fields: this function is the one to extend). Today the robots that report
are the laundry seed's: their state path, e-stop latch, fault and battery as they send them;
their place is what the server knows of them (at base, at the customer's room, or on the way
between the two, from the request they serve); a line robot has no pose (``x_m`` and the
like stay None).

``place`` is a room's name (the robot is there) or ``"FROM -> TO"`` (on its way);
``place_rooms`` reads it back.
"""

from __future__ import annotations

from dataclasses import dataclass
from datetime import datetime, timedelta
from typing import Literal

from sqlalchemy import select
from sqlalchemy.ext.asyncio import AsyncSession

from fleet.models import Beacon, Customer, Request, Robot, Room
from fleet.settings import load_settings
from fleet.status import Status

Condition = Literal["offline", "estop", "fault", "moving", "idle"]
ON_THE_WAY = " -> "
UNKNOWN = "the line"
"""Where a robot sent back to base with no request comes from (the server does not know)."""
PROFILE = "laundry"
"""Every robot of the data exchange is a laundry robot (seed 000, section 8)."""

_TO_ROOM = {Status.ACCEPTED, Status.GOING_TO_ROOM}
_AT_ROOM = {Status.ARRIVED_AT_ROOM, Status.ARRIVED_FOR_DELIVERY}
_TO_BASE = {Status.LAUNDRY_LOADED, Status.GOING_TO_BASE, Status.CANCELLED,
            Status.COMPLETED}


@dataclass(frozen=True)
class RobotView:
    """One robot on the console (None: not known)."""

    name: str
    profile: str | None
    state: str | None
    estop: bool
    fault_code: str | None
    fault_message: str | None
    battery_pct: float | None
    x_m: float | None
    y_m: float | None
    theta_rad: float | None
    map_name: str | None
    place: str | None
    job: str | None
    online: bool
    last_seen: datetime | None

    @property
    def condition(self) -> Condition:
        """What its colour on the map says, the first that holds."""
        if not self.online:
            return "offline"
        if self.estop:
            return "estop"
        if self.fault_code is not None:
            return "fault"
        moving = self.place is not None and ON_THE_WAY in self.place
        return "moving" if moving else "idle"

    def public(self) -> dict[str, object]:
        """As JSON (the pushed ``robots`` event): PascalCase, like the API."""
        return {"Name": self.name, "Profile": self.profile, "State": self.state,
                "EmergencyStop": self.estop, "FaultCode": self.fault_code,
                "FaultMessage": self.fault_message, "BatteryPct": self.battery_pct,
                "X": self.x_m, "Y": self.y_m, "Theta": self.theta_rad, "Map": self.map_name,
                "Place": self.place, "Job": self.job, "Online": self.online,
                "LastSeen": self.last_seen.isoformat() if self.last_seen else None,
                "Condition": self.condition}


def place_rooms(place: str | None) -> tuple[str | None, str | None]:
    """(where it comes from, where it is or goes): ``"A -> B"`` is (A, B), ``"A"`` (None, A)."""
    if place is None:
        return None, None
    before, sep, after = place.partition(ON_THE_WAY)
    return (before, after) if sep else (None, before)


async def robot_views(session: AsyncSession, now: datetime | None = None) -> list[RobotView]:
    """Every registered robot, in the order they were added. With ``now``, a robot silent
    past ``OfflineAfterS`` is offline before the offline monitor's next pass says so."""
    cfg = await load_settings(session)
    rows = (await session.execute(
        select(Robot, Request, Customer.room_id)
        .outerjoin(Request, Request.id == Robot.current_request_id)
        .outerjoin(Customer, Customer.id == Request.customer_id)
        .order_by(Robot.id))).all()
    rooms = {rid: name for rid, name in await session.execute(select(Room.id, Room.name))}
    base = (await session.execute(
        select(Room.name).join(Beacon, Beacon.room_id == Room.id)
        .where(Beacon.is_base.is_(True)).order_by(Beacon.id).limit(1))).scalar()
    offline_after = timedelta(seconds=cfg.offline_after_s)
    views = []
    for robot, request, room_id in rows:
        online = not robot.is_offline and robot.last_ping_at is not None and (
            now is None or now - robot.last_ping_at <= offline_after)
        views.append(RobotView(
            name=robot.name, profile=PROFILE, state=robot.state,
            estop=bool(robot.emergency_stop or robot.estop_active),
            fault_code=robot.fault_code,
            fault_message=robot.fault_message if robot.fault_code is not None else None,
            battery_pct=robot.battery_pct, x_m=None, y_m=None, theta_rad=None, map_name=None,
            place=_place(robot, request, rooms.get(room_id) if room_id else None, base),
            job=(f"request {request.id}: {request.status}" if request is not None else None),
            online=online, last_seen=robot.last_ping_at))
    return views


def _place(robot: Robot, request: Request | None, room: str | None,
           base: str | None) -> str | None:
    """Where the server knows the robot to be, from what it serves and the base queue."""
    if base is None:
        return room
    if request is None:
        return base if robot.base_place is not None else f"{UNKNOWN}{ON_THE_WAY}{base}"
    status = Status(request.status)
    if room is None:
        return base
    if status in _AT_ROOM:
        return room
    if status in _TO_ROOM:
        return f"{base}{ON_THE_WAY}{room}"
    if status in _TO_BASE:
        return f"{room}{ON_THE_WAY}{base}"
    return base  # Washing, Pending (assigned, not yet sent): at base
