"""Every robot as the console shows it: one ``RobotView`` a robot, made in one place.

The board's robot table, the site map, the robot page and the pushed ``robots`` events all
read ``robot_views(session)``; what a robot reports of itself reaches every page through it
(more profiles and fields: this function is the one to extend). A laundry robot of the data
exchange shows its state path, e-stop latch, fault and battery as it sends them; its place is
what the server knows of it (at base, at the customer's room, or on the way between the two,
from the request it serves); a line robot has no pose (``x_m`` and the like stay None). A
robot that reports its site status (``POST /api/Robot/{name}/status``, any profile) shows
what ``robot_statuses`` makes of it: profile, state, e-stop, fault, battery, pose and its
map, place, job, online by its reports.

``place`` is a room's name (the robot is there) or ``"FROM -> TO"`` (on its way);
``place_rooms`` reads it back.
"""

from __future__ import annotations

from dataclasses import dataclass, fields
from datetime import datetime, timedelta
from typing import Literal

from sqlalchemy import select
from sqlalchemy.ext.asyncio import AsyncSession

from fleet.models import Beacon, Customer, Request, Robot, Room
from fleet.services.robot_status import RobotStatus, robot_statuses
from fleet.settings import load_settings
from fleet.status import Status

Condition = Literal["offline", "estop", "fault", "moving", "idle"]
ON_THE_WAY = " -> "
UNKNOWN = "the line"
"""Where a robot sent back to base with no request comes from (the server does not know)."""
PROFILE = "laundry"
"""Every robot of the data exchange is a laundry robot (seed 000, section 8); one never heard
from has no profile yet."""

_TO_ROOM = frozenset(str(s) for s in (Status.ACCEPTED, Status.GOING_TO_ROOM))
_AT_ROOM = frozenset(str(s) for s in (Status.ARRIVED_AT_ROOM, Status.ARRIVED_FOR_DELIVERY))
_TO_BASE = frozenset(str(s) for s in (Status.LAUNDRY_LOADED, Status.GOING_TO_BASE,
                                      Status.CANCELLED, Status.COMPLETED))


@dataclass(frozen=True)
class RobotView(RobotStatus):
    """One robot on the console (None: not known): a robot status (its fields are
    ``RobotStatus``'s), with what the pages make of it."""

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


_ROWS = (
    select(Robot.name, Robot.state, Robot.emergency_stop, Robot.estop_active, Robot.fault_code,
           Robot.fault_message, Robot.battery_pct, Robot.is_offline, Robot.last_ping_at,
           Robot.base_place, Request.id, Request.status, Customer.room_id, Robot.status_at)
    .outerjoin(Request, Request.id == Robot.current_request_id)
    .outerjoin(Customer, Customer.id == Request.customer_id)
    .order_by(Robot.id))
"""One row a robot, plain columns (no ORM objects: a pass over 2000 robots stays cheap)."""
_BASE = (select(Room.name).join(Beacon, Beacon.room_id == Room.id)
         .where(Beacon.is_base.is_(True)).order_by(Beacon.id).limit(1))


async def robot_views(session: AsyncSession, now: datetime | None = None) -> list[RobotView]:
    """Every registered robot, in the order they were added. With ``now``, a robot silent
    past ``OfflineAfterS`` is offline before the offline monitor's next pass says so."""
    cfg = await load_settings(session)
    rooms = {rid: name for rid, name in await session.execute(select(Room.id, Room.name))}
    base = (await session.execute(_BASE)).scalar()
    offline_after = timedelta(seconds=cfg.offline_after_s)
    views = []
    rows = (await session.execute(_ROWS)).all()
    reported = ({s.name: s for s in await robot_statuses(session, now, reporting_only=True)}
                if any(row[-1] is not None for row in rows) else {})
    for (name, state, ordered_stop, latched, fault_code, fault_message, battery, offline,
         ping, base_place, request_id, status, room_id, status_at) in rows:
        if status_at is not None and name in reported:
            views.append(_reported(reported[name]))
            continue
        online = not offline and ping is not None and (
            now is None or now - ping <= offline_after)
        room = rooms.get(room_id) if room_id is not None else None
        views.append(RobotView(
            name=name, profile=PROFILE if ping is not None else None, state=state,
            estop=bool(ordered_stop or latched),
            fault_code=fault_code,
            fault_message=fault_message if fault_code is not None else None,
            battery_pct=battery, x_m=None, y_m=None, theta_rad=None, map_name=None,
            place=_place(base_place is not None, status, room, base),
            job=f"request {request_id}: {status}" if request_id is not None else None,
            online=online, last_seen=ping))
    return views


def _reported(status: RobotStatus) -> RobotView:
    """A robot that reports its site status, as the server's status of it says."""
    return RobotView(**{f.name: getattr(status, f.name) for f in fields(RobotView)})


def _place(at_base: bool, status: str | None, room: str | None,
           base: str | None) -> str | None:
    """Where the server knows the robot to be, from what it serves and the base queue."""
    if base is None:
        return room
    if status is None:
        return base if at_base else f"{UNKNOWN}{ON_THE_WAY}{base}"
    if room is None:
        return base
    if status in _AT_ROOM:
        return room
    if status in _TO_ROOM:
        return f"{base}{ON_THE_WAY}{room}"
    if status in _TO_BASE:
        return f"{room}{ON_THE_WAY}{base}"
    return base  # Washing, Pending (assigned, not yet sent): at base
