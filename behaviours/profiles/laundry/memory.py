"""What the laundry robot remembers across a crash: its request, what it holds, where it was.

Kept through the framework's ``MissionRecord`` (``laundry.mission``), written at each change.
The fleet server is the source of truth for a request's status (seed section 2); the robot
keeps the last it was told, and what that means it carries: dirty laundry from
``LaundryLoaded`` until the base takes it, clean laundry from ``FinishedWashingGoingToRoom``
until the customer takes it out. Back online after a restart it reports what it holds in every
data exchange (``Holding``) and reconciles with the server's first answer (seed section 13):
the same request goes on where it was; a request the server has let go while the robot still
holds laundry away from the base is an alert for a person, and the laundry is not forgotten.
"""

from __future__ import annotations

from typing import Any

import structlog

from behaviours.context import RobotContext
from behaviours.persistence import MissionRecord, Persisted
from behaviours.profiles.laundry.directive import Directive

log = structlog.get_logger(__name__)

LAUNDRY_MISSION = MissionRecord("laundry.mission", 1, {
    "request_id": None,         # the request the robot serves (the server's RequestId)
    "request_status": None,     # its status as last told
    "holding": "none",          # "none", "dirty" or "clean"
    "holding_request_id": None,  # whose laundry it holds
    "last_room": None,          # the last room whose beacon it arrived at
    "target_room": None,        # where it was going
})

HOLDS_DIRTY = frozenset({"LaundryLoaded"})
HOLDS_CLEAN = frozenset({"FinishedWashingGoingToRoom", "FinishedWashingArrivedAtRoom"})
HOLDS_NOTHING = frozenset({"Pending", "Accepted", "ArrivedAtRoom", "FinishedWashingGoingToBase"})
"""Other statuses (Cancelled, Washing ...) leave what it holds as it was."""


class LaundryMemory:
    """The robot's side of the request, kept in ``laundry.mission``.

    Args:
        ctx: the robot's context (its store, its events).
        base_room: ``laundry.base_room``: laundry left there counts as handed over.
    """

    def __init__(self, ctx: RobotContext, base_room: str) -> None:
        self.ctx = ctx
        self.base_room = base_room
        self.kept: Persisted = ctx.persisted(LAUNDRY_MISSION)
        held = self.kept.values()
        self._to_reconcile = self.kept.restored and (
            held["request_id"] is not None or held["holding"] != "none")
        self._unclaimed_told = False
        if self._to_reconcile:
            log.warning("laundry.restored", **held)
            ctx.emit("laundry.restored", **held)

    @property
    def holding(self) -> str:
        return str(self.kept["holding"])

    def report(self) -> dict[str, Any] | None:
        """The data exchange's ``Holding`` extension: what it carries and whose, or None."""
        if self.kept["holding"] == "none":
            return None
        return {"Laundry": self.kept["holding"], "RequestId": self.kept["holding_request_id"]}

    @property
    def last_room(self) -> str | None:
        """The last room whose beacon it arrived at (None: none yet)."""
        room = self.kept["last_room"]
        return None if room is None else str(room)

    def arrived(self, room: str | None) -> None:
        """It arrived at ``room``'s beacon (written at once; not awaited: a position)."""
        self.kept.set(last_room=room)

    def heading(self, room: str | None) -> None:
        """It set off towards ``room``."""
        self.kept.set(target_room=room)

    async def observe(self, directive: Directive) -> None:
        """Take the server's answer: the request and what that means the robot holds;
        durable before the robot acts on the answer."""
        rid, status = directive.request_id, directive.request_status
        before = self.kept.values()
        changes: dict[str, Any] = {"request_id": rid, "request_status": status}
        if rid is not None:
            if status in HOLDS_DIRTY:
                changes.update(holding="dirty", holding_request_id=rid)
            elif status in HOLDS_CLEAN:
                changes.update(holding="clean", holding_request_id=rid)
            elif status in HOLDS_NOTHING:
                changes.update(holding="none", holding_request_id=None)
        elif before["holding"] != "none":
            if before["last_room"] == self.base_room:
                # Let go at the base (Washing, or a cancelled request back home): handed over.
                changes.update(holding="none", holding_request_id=None)
            else:
                self._unclaimed(before)
        changed = await self.kept.update(**changes)
        if self._to_reconcile:
            self._to_reconcile = False
            self._reconcile(before, rid, status)
        if changed:
            after = self.kept.values()
            if after["holding"] != before["holding"] or \
                    after["holding_request_id"] != before["holding_request_id"]:
                self.ctx.emit("laundry.holding", holding=after["holding"],
                              request_id=after["holding_request_id"], status=status)

    def _reconcile(self, held: dict[str, Any], rid: int | None, status: str | None) -> None:
        """Told once, after the first answer since the restart has been taken: what the robot
        remembered, what the server says, and what the robot now holds."""
        now = self.kept.values()
        fields = {"request_id": held["request_id"], "restored_holding": held["holding"],
                  "server_request_id": rid, "server_status": status,
                  "agrees": rid == held["request_id"], "holding": now["holding"],
                  "holding_request_id": now["holding_request_id"]}
        log.info("laundry.reconciled", **fields)
        self.ctx.emit("laundry.reconciled", **fields)

    def _unclaimed(self, held: dict[str, Any]) -> None:
        if self._unclaimed_told:
            return
        self._unclaimed_told = True
        log.error("laundry.unclaimed", holding=held["holding"],
                  request_id=held["holding_request_id"], last_room=held["last_room"],
                  note="the server has no request for laundry the robot holds: a person must "
                       "take it")
        self.ctx.emit("laundry.unclaimed", holding=held["holding"],
                      request_id=held["holding_request_id"], last_room=held["last_room"])

    def status(self) -> dict[str, Any]:
        return self.kept.values()
