"""The ``robots`` event on ``GET /api/events``: the robots whose view changed, for staff.

A poller of the event hub (``EventHub.add_poller``): each pass while staff listen, it reads
every robot's view (``robot_views``, one query, the same as the pages) and sends the robots
whose state, place, fault, e-stop, online, battery (whole percent) or pose differ from the
last pass. Every server process reads the database, so a change made by any process (a
robot's report, a staff's order) reaches every listener; nothing is sent while nothing
changes.
"""

from __future__ import annotations

import json

import structlog

from fleet.clock import Clock
from fleet.console.robot_views import RobotView, robot_views
from fleet.db import Database
from fleet.push import StaffEvent

log = structlog.get_logger(__name__)

EVENT = "robots"


def _key(view: RobotView) -> tuple[object, ...]:
    battery = None if view.battery_pct is None else round(view.battery_pct)
    pose = tuple(None if v is None else round(v, 2)
                 for v in (view.x_m, view.y_m, view.theta_rad))
    return (view.state, view.place, view.fault_code, view.fault_message, view.estop,
            view.online, battery, pose, view.map_name, view.job)


class RobotChanges:
    """Args:
        db: the fleet database.
        clock: the wall clock (a silent robot turns offline on time).
    """

    def __init__(self, db: Database, clock: Clock) -> None:
        self._db = db
        self._clock = clock
        self._last: dict[str, tuple[object, ...]] = {}

    async def __call__(self) -> list[StaffEvent]:
        async with self._db.read() as session:
            views = await robot_views(session, self._clock())
        changed = [v for v in views if self._last.get(v.name) != _key(v)]
        self._last = {v.name: _key(v) for v in views}
        if not changed:
            return []
        log.debug("fleet.console.robots_changed", robots=len(changed))
        return [StaffEvent(EVENT, json.dumps({"Robots": [v.public() for v in changed]}))]
