"""The ``request`` event on ``GET /api/events?requests=true``: a customer's request whose
status changed, pushed to that customer's page.

Not every status change notifies the customer (a request reaching the laundry room notifies
the staff only), yet the phone page shows each one as it comes. A poller of the event hub
(``EventHub.add_poller``): each pass while a customer page listens it reads the active
requests and those finished in the last ``RECENT_S`` (one query, bounded by what is in
progress) and sends each whose status changed since the last pass to its customer.
"""

from __future__ import annotations

import json
from datetime import timedelta

from sqlalchemy import or_, select

from fleet.clock import Clock
from fleet.db import Database
from fleet.models import Request
from fleet.push import StaffEvent
from fleet.status import ACTIVE

EVENT = "request"
RECENT_S = 600.0


class RequestChanges:
    """Args:
        db: the fleet database.
        clock: the wall clock (which finished requests are recent).
    """

    def __init__(self, db: Database, clock: Clock) -> None:
        self._db = db
        self._clock = clock
        self._last: dict[int, tuple[str, bool, bool]] = {}

    async def __call__(self) -> list[StaffEvent]:
        since = self._clock() - timedelta(seconds=RECENT_S)
        async with self._db.read() as session:
            rows = (await session.execute(
                select(Request.id, Request.customer_id, Request.status, Request.is_paid,
                       Request.is_approved)
                .where(or_(Request.status.in_([str(s) for s in ACTIVE]),
                           Request.finished_at >= since)))).all()
        events = []
        seen: dict[int, tuple[str, bool, bool]] = {}
        for request_id, customer_id, status, paid, approved in rows:
            key = (str(status), bool(paid), bool(approved))
            seen[request_id] = key
            if self._last.get(request_id) != key:
                events.append(StaffEvent(EVENT, json.dumps({"Id": request_id,
                                                            "Status": key[0]}),
                                         customer_id=customer_id))
        self._last = seen
        return events
