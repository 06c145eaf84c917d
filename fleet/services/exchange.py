"""The server side of the robot's 1 s data exchange (seed section 8): record the report,
handle arrival and weight, answer with beacons, targets and orders.

Most reports change nothing: the robot is idle or on its way. Those are answered from a
cached read, and their pings are written in one batch a second, so hundreds of robots cost
few writes and no report waits for one. A report that may change a request (arrival, weight
at the room, a robot back from offline) runs in a serialized write transaction.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from datetime import datetime, timedelta
from typing import Any, cast

from sqlalchemy import Connection, Table, bindparam, case, or_, select, update

from fleet.cache import Cached, SiteCache, SiteView
from fleet.clock import Clock
from fleet.db import Database
from fleet.errors import NotFound
from fleet.models import Request, Robot
from fleet.services import unload, weight
from fleet.services.arrival import Sighting, base_heard, handle_arrival
from fleet.services.assignment import process_queue
from fleet.services.common import current_request, robot_by_name, waiting_for
from fleet.services.condition import apply_condition
from fleet.services.navigation import Navigation, navigation
from fleet.services.reconnect import Reconnects
from fleet.settings import FleetSettings
from fleet.status import Status


@dataclass(frozen=True)
class Report:
    """What the robot sends."""

    robot_name: str
    sightings: Sequence[Sighting]
    is_in_target: bool
    weight_kg: float | None
    ultrasonic_distance: float | None
    # What the robot knows of itself (issue 27); None: not reported.
    state: str | None = None
    estop_active: bool | None = None
    fault_code: str | None = None
    fault_message: str | None = None
    battery_pct: float | None = None
    queued: bool = False
    """Queued at base behind the robot ahead, pulling up to the base beacon as it can: it keeps
    the base beacons as its targets (``laundry.base_queue``)."""
    # What the site status carries for every robot (issue 29); None: not reported.
    profile: str | None = None
    place: str | None = None
    job: str | None = None


@dataclass(frozen=True)
class Reply:
    navigation: Navigation
    emergency_stop: bool
    maintenance_mode: bool
    request_id: int | None = None
    """The request the robot serves (so it can remember it across a restart), or None."""
    request_status: str | None = None
    waiting_for: str | None = None
    """Why a free robot is not sent out: "unload" (its load must come off first), or None."""


@dataclass(frozen=True)
class _Light:
    """The one-statement read of a report that changes nothing."""

    robot_id: int
    is_offline: bool
    stopped: bool
    emergency_stop: bool
    maintenance_mode: bool
    request_id: int | None
    status: str
    customer_id: int
    robot_returned: bool
    last_ping_at: datetime | None
    estop_active: bool | None
    fault_code: str | None
    unload_pending: bool
    unload_clear_since: datetime | None
    waiting_for_line: str | None
    has_left_base: bool
    away: bool
    """Not known to stand at base (None ``base_place``)."""

    @property
    def waiting_for(self) -> str | None:
        return waiting_for(self.unload_pending, self.waiting_for_line)


_LIGHT_QUERY = (
    select(Robot.name, Robot.id, Robot.is_offline, Robot.emergency_stop, Robot.maintenance_mode,
           Request.id, Request.status, Request.customer_id, Request.robot_returned,
           Robot.last_ping_at, Robot.estop_active, Robot.fault_code, Robot.unload_pending,
           Robot.unload_clear_since, Robot.waiting_for_line, Robot.has_left_base,
           Robot.base_place)
    .select_from(Robot)
    .outerjoin(Request, Request.id == Robot.current_request_id)
)


def _read_lights(conn: Connection) -> dict[str, _Light]:
    return {str(row[0]): _light(row[1:]) for row in conn.execute(_LIGHT_QUERY)}


def _light(row: Any) -> _Light:
    (rid, offline, estop, maintenance, req_id, status, customer, returned, ping, estop_active,
     fault_code, unload_pending, unload_clear_since, line, left, base_place) = row
    return _Light(rid, offline, estop or maintenance, estop, maintenance,
                  req_id, status or "", customer or 0, bool(returned), ping, estop_active,
                  fault_code, bool(unload_pending), unload_clear_since, line, bool(left),
                  base_place is None)


class RobotViews:
    """What quiet reports need of every robot, read for all robots in one query and kept
    until this process commits a serialized write or for ``ttl_s`` of loop time (changes made
    by other server processes); and the pings of quiet reports, written in one batch by
    ``flush_pings`` (about once a second)."""

    def __init__(self, db: Database, clock: Clock, ttl_s: float = 1.0) -> None:
        self._db = db
        self.reconnects: Reconnects[Report] = Reconnects(db, clock, _apply_report)
        self._snapshot = Cached(self._load, ttl_s)
        self._generation = db.generation
        self._pings: dict[int, dict[str, Any]] = {}

    async def _load(self) -> dict[str, _Light]:
        return await self._db.run_read(_read_lights)

    async def get(self, name: str) -> _Light:
        if self._generation != self._db.generation:
            self._generation = self._db.generation
            self._snapshot.invalidate()
        light = (await self._snapshot.get()).get(name)
        if light is None:  # perhaps added by another server process since the snapshot
            self._snapshot.invalidate()
            light = (await self._snapshot.get()).get(name)
        if light is None:
            msg = f"robot {name!r} is not registered"
            raise NotFound(msg)
        return light

    def note_ping(self, robot_id: int, now: datetime, report: Report) -> None:
        self._pings[robot_id] = {
            "rid": robot_id, "ping": now, "weight": report.weight_kg,
            "distance": report.ultrasonic_distance, "in_target": report.is_in_target,
            "state": report.state, "battery": report.battery_pct,
            "fault_message": report.fault_message, "profile": report.profile,
            "place": report.place, "job": report.job}

    def drop_ping(self, robot_id: int) -> None:
        """Forget the robot's pending ping: a newer report of it is being written."""
        self._pings.pop(robot_id, None)

    async def flush_pings(self) -> int:
        """Write the pings noted since the last flush; returns how many robots.

        In robot id order: behind a load balancer every server process flushes pings of
        the same robots each second, and rows locked in one order by all cannot deadlock.
        A ping older than the one stored (written by another process meanwhile) changes
        nothing. If the write fails the pings are kept for the next flush."""
        if not self._pings:
            return 0
        pending, self._pings = self._pings, {}
        pings = [pending[rid] for rid in sorted(pending)]

        def write(conn: Connection) -> None:
            for start in range(0, len(pings), _PING_CHUNK):
                conn.execute(_PING_UPDATE, pings[start:start + _PING_CHUNK])

        try:
            await self._db.run_write(write, serial=False)
        except Exception:
            self._pings = pending | self._pings  # newer reports noted meanwhile win
            raise
        return len(pings)


_robots = cast(Table, Robot.__table__)
# A plain executemany: an ORM bulk update of hundreds of rows would hold the event loop. A
# quiet report's state path, battery and fault text ride along (they change nothing else; the
# fault's code and the e-stop latch do, and are written by the report's own transaction).
_PING_UPDATE = (
    update(_robots).where(_robots.c.id == bindparam("rid"), or_(
        _robots.c.last_ping_at.is_(None), _robots.c.last_ping_at <= bindparam("ping"))).values(
        last_ping_at=bindparam("ping"), weight_kg=bindparam("weight"),
        ultrasonic_distance=bindparam("distance"), is_in_target=bindparam("in_target"),
        state=bindparam("state"), battery_pct=bindparam("battery"),
        profile=bindparam("profile"), place=bindparam("place"), job=bindparam("job"),
        fault_message=case((_robots.c.fault_code.is_(None), None),
                           else_=bindparam("fault_message")))
)
_PING_CHUNK = 200


def _stale(light: _Light, now: datetime, cfg: FleetSettings) -> bool:
    """Silent past the offline limit, though the monitor has not marked it offline yet: not
    assignable until this report is written (then it serves the queue)."""
    return light.last_ping_at is None or (
        now - light.last_ping_at > timedelta(seconds=cfg.offline_after_s))


def _may_change(light: _Light, report: Report, now: datetime, cfg: FleetSettings,
                site: SiteView, stale: bool = False) -> bool:
    if light.is_offline or stale:
        return True
    if light.request_id is not None and not light.has_left_base \
            and _out_of_base(site, report, cfg):
        return True
    if light.fault_code != report.fault_code or light.estop_active != report.estop_active:
        return True
    if unload.step(light.unload_pending, light.unload_clear_since, report.weight_kg, now,
                   cfg) is not None:
        return True
    if light.request_id is None:
        return light.away and report.is_in_target  # sent back to base, and there
    return report.is_in_target or light.status in (
        Status.ARRIVED_AT_ROOM, Status.ARRIVED_FOR_DELIVERY)


async def exchange(
    db: Database, clock: Clock, cache: SiteCache, views: RobotViews, report: Report
) -> Reply:
    """One data exchange. Raises NotFound for an unknown robot."""
    light = await views.get(report.robot_name)
    cfg = await cache.settings()
    site = await cache.site()
    now = clock()
    stale = not light.is_offline and _stale(light, now, cfg)
    if not _may_change(light, report, now, cfg, site, stale):
        views.note_ping(light.robot_id, now, report)
        return _light_reply(light, site, cfg, report.queued)
    if light.is_offline:
        # Back online: restored in a batch with the others coming back now (a reconnect
        # storm), then this report is handled as any other.
        await views.reconnects.restore(report.robot_name, report)
        light = await views.get(report.robot_name)
        if not _may_change(light, report, clock(), cfg, site):
            return _light_reply(light, site, cfg, report.queued)
    async with db.write() as session:
        now = clock()
        robot = await robot_by_name(session, report.robot_name)
        if robot is None:
            msg = f"robot {report.robot_name!r} is not registered"
            raise NotFound(msg)
        views.drop_ping(robot.id)
        _apply_report(robot, now, report)
        if robot.current_request_id is not None and not robot.has_left_base \
                and _out_of_base(site, report, cfg):
            robot.has_left_base = True
        await apply_condition(session, now, robot, report.estop_active, report.fault_code,
                              report.fault_message)
        if stale:
            await process_queue(session, now, cfg)
        if report.is_in_target:
            await handle_arrival(session, now, robot, report.sightings, site, cfg)
        await unload.apply(session, now, cfg, robot)
        current = await current_request(session, robot)
        if current is not None:
            weight.evaluate(session, now, cfg, current, report.weight_kg)
        nav = navigation(site, cfg, current,
                         stopped=robot.emergency_stop or robot.maintenance_mode,
                         away=robot.base_place is None or (
                             current is None and report.queued))
        return Reply(nav, robot.emergency_stop, robot.maintenance_mode,
                     current.id if current is not None else None,
                     str(current.status) if current is not None else None,
                     waiting_for(robot.unload_pending, robot.waiting_for_line))


def _out_of_base(site: SiteView, report: Report, cfg: FleetSettings) -> bool:
    """The report places the robot out of the base (its queue included): no base beacon
    heard within BaseQueueMarginDb of its threshold, or no beacon named at all."""
    return not base_heard(site, report.sightings, cfg.base_queue_margin_db)


def _light_reply(light: _Light, site: SiteView, cfg: FleetSettings,
                 queued: bool = False) -> Reply:
    request = light if light.request_id is not None else None
    away = light.away or (request is None and queued)
    nav = navigation(site, cfg, request, stopped=light.stopped, away=away)
    return Reply(nav, light.emergency_stop, light.maintenance_mode,
                 light.request_id, light.status or None, light.waiting_for)


def _apply_report(robot: Robot, now: datetime, report: Report) -> None:
    robot.last_ping_at = now
    if robot.weight_kg != report.weight_kg:
        robot.weight_kg = report.weight_kg
    if robot.ultrasonic_distance != report.ultrasonic_distance:
        robot.ultrasonic_distance = report.ultrasonic_distance
    if robot.is_in_target != report.is_in_target:
        robot.is_in_target = report.is_in_target
    if robot.state != report.state:
        robot.state = report.state
    if robot.battery_pct != report.battery_pct:
        robot.battery_pct = report.battery_pct
    if (robot.profile, robot.place, robot.job) != (report.profile, report.place, report.job):
        robot.profile, robot.place, robot.job = report.profile, report.place, report.job
    if robot.fault_code is not None and robot.fault_code == report.fault_code \
            and robot.fault_message != report.fault_message:
        robot.fault_message = report.fault_message
