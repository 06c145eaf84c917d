"""Painted lines that several rooms share (issue 27).

Robots on one painted line cannot pass each other, so at most one robot travels a shared line
at a time: a robot is *on* the line of its current request's room from dispatch until it
reports being back at base (standing at the room included, bringing a cancelled request back,
and lying dead on it: an offline robot is where it was last heard of). A robot away from base
with no request (its request resolved by the staff while it was away, or just restarted) is on
every line until it is back, since the server cannot know which it is on; staff who carry a
robot off the line deactivate it. A request for a room on a line another robot is on waits
Pending. A site that declares no lines keeps the behaviour before them; the seed's "any robot
busy -> Pending" (flowchart 1) is the site whose rooms are all on one line.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import structlog
from sqlalchemy import delete, func, select
from sqlalchemy.ext.asyncio import AsyncSession

from fleet.models import Beacon, Customer, LineRoom, Request, Robot, Room

log = structlog.get_logger(__name__)


@dataclass(frozen=True)
class LineMap:
    """Which lines each room is on, and each customer's room (the room of the customer's
    beacon, the robot's target, else the customer's own room)."""

    room_lines: dict[int, frozenset[str]]
    customer_rooms: dict[int, int | None]

    def lines_of(self, customer_id: int) -> frozenset[str]:
        room = self.customer_rooms.get(customer_id)
        return self.room_lines.get(room, frozenset()) if room is not None else frozenset()


async def line_map(session: AsyncSession) -> LineMap | None:
    """The site's lines, or None when it declares none (the usual case: one cheap query)."""
    rows = (await session.execute(select(LineRoom.line, LineRoom.room_id))).all()
    if not rows:
        return None
    room_lines: dict[int, set[str]] = {}
    for line, room_id in rows:
        room_lines.setdefault(room_id, set()).add(line)
    customers = (await session.execute(
        select(Customer.id, func.coalesce(Beacon.room_id, Customer.room_id))
        .outerjoin(Beacon, Beacon.id == Customer.beacon_id))).all()
    return LineMap({room: frozenset(lines) for room, lines in room_lines.items()},
                   {cid: room for cid, room in customers})


async def occupied(session: AsyncSession, lines: LineMap) -> dict[str, str]:
    """Each line some robot is on, with that robot's name."""
    rows = (await session.execute(
        select(Robot.name, Request.customer_id)
        .outerjoin(Request, Request.id == Robot.current_request_id)
        .where(Robot.is_active.is_(True),
               Robot.base_place.is_(None) | Robot.current_request_id.is_not(None))
        .order_by(Robot.id))).all()
    every_line = sorted({line for room in lines.room_lines.values() for line in room})
    found: dict[str, str] = {}
    for name, customer_id in rows:
        on = lines.lines_of(customer_id) if customer_id is not None else every_line
        for line in on:
            found.setdefault(line, name)
    return found


def blocking(lines: LineMap, on_line: dict[str, str], customer_id: int,
             robot_name: str | None = None) -> str | None:
    """The first line of the customer's room that another robot than ``robot_name`` is on."""
    for line in sorted(lines.lines_of(customer_id)):
        other = on_line.get(line)
        if other is not None and other != robot_name:
            return line
    return None


async def all_lines(session: AsyncSession) -> dict[str, list[str]]:
    """Every line with its rooms' names."""
    rows = (await session.execute(
        select(LineRoom.line, Room.name).join(Room, Room.id == LineRoom.room_id)
        .order_by(LineRoom.line, Room.id))).all()
    found: dict[str, list[str]] = {}
    for line, room in rows:
        found.setdefault(line, []).append(room)
    return found


async def put_line(session: AsyncSession, name: str, room_ids: Sequence[int]) -> None:
    """Create the line or replace its rooms (no rooms: the line is removed)."""
    await session.execute(delete(LineRoom).where(LineRoom.line == name))
    for room_id in dict.fromkeys(room_ids):
        session.add(LineRoom(line=name, room_id=room_id))
    await session.flush()
    log.info("fleet.line.put", line=name, rooms=len(set(room_ids)))
