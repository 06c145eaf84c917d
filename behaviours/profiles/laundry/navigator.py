"""Turns directives (from the fleet server or a local route) into the robot's mission states.

The robot follows the line while told to, toward the room of the navigation-target beacons.
It stops by itself the moment a target beacon's RSSI crosses its threshold (``IsInTarget``),
rather than waiting up to a period for the server to say so, and then waits at the room until
it is sent on. The server's emergency stop and maintenance mode map to the root states; the
robot leaves them again only when the server lifts what the server put on.
"""

from __future__ import annotations

import asyncio
from typing import Any

import structlog

from behaviours.beacons.arrival import Arrival
from behaviours.beacons.tracker import BeaconTracker
from behaviours.context import RobotContext
from behaviours.machine_tables import CoreTrigger, RootState
from behaviours.profiles.laundry.directive import Directive
from behaviours.profiles.laundry.memory import LaundryMemory
from behaviours.profiles.laundry.states import FOLLOWING, LaundryState, LaundryTrigger

log = structlog.get_logger(__name__)

S, T = LaundryState, LaundryTrigger
MAX_LINE_RETRIES = 2
LINE_RETRY_PAUSE_S = 5.0


class Navigator:
    def __init__(self, ctx: RobotContext, tracker: BeaconTracker, arrival: Arrival,
                 set_follow_colour: Any, memory: LaundryMemory | None = None) -> None:
        self.ctx = ctx
        self.tracker = tracker
        self.arrival = arrival
        self._set_follow_colour = set_follow_colour
        self.directive = Directive.stand_still()
        self.target_room: str | None = None
        self.arrived_room: str | None = None
        self._arrival_fired = False
        self._leg: str | None = None  # the leg last asked of the machine (to_room, to_base)
        self.line_losses = 0  # in a row, since the last arrival
        self._last_loss_s = 0.0
        self.memory = memory
        # An e-stop the server put on, latched before a restart, is the server's to lift.
        self._server_estop = ctx.estop_latch.only_from("fleet")
        self._server_maintenance = False
        self.problems: list[str] = []
        arrival.on_change(self._on_arrival_change)

    @property
    def base_room(self) -> str:
        return str(self.ctx.settings.get("laundry.base_room"))

    async def apply(self, directive: Directive) -> None:
        """Take a new directive: beacons, colour, estop, maintenance, where to go."""
        self.directive = directive
        self.problems = self.tracker.apply_active_beacons(directive.active_beacons)
        self._set_follow_colour(directive.follow_color)
        self.arrival.update()
        state = self.ctx.state
        if directive.emergency_stop:
            if state != RootState.ESTOP:
                self._server_estop = True
                log.warning("laundry.server_estop")
                await self.ctx.trigger(CoreTrigger.ESTOP, source="fleet",
                                       reason="the fleet server's EmergencyStop")
            return
        if state == RootState.ESTOP:
            if self._server_estop:
                self._server_estop = False
                await self.ctx.trigger(CoreTrigger.RESUME, source="fleet")
            return
        if directive.maintenance:
            if state != RootState.MAINTENANCE:
                self._server_maintenance = await self.ctx.trigger(CoreTrigger.MAINTENANCE)
            return
        if state == RootState.MAINTENANCE:
            if self._server_maintenance:
                self._server_maintenance = False
                await self.ctx.trigger(CoreTrigger.END_MAINTENANCE)
            return
        await self._navigate(directive, self.ctx.state)

    async def _navigate(self, directive: Directive, state: str) -> None:
        rooms = directive.target_rooms()
        room = rooms[0] if rooms else None
        if directive.line_following:
            if state == RootState.RECOVERY:
                if not self._may_retry():
                    return
                await self.ctx.trigger(CoreTrigger.RECOVERED)
                state = self.ctx.state
            if room is not None and room == self.arrived_room and state in (S.AT_ROOM, S.AT_BASE):
                return  # already there; the server has not caught up yet
            to_base = room is not None and room == self.base_room
            want = S.TO_BASE if to_base else S.TO_ROOM
            self.target_room = room
            if self.memory is not None:
                self.memory.heading(room)
            if state != want and not (want == S.TO_BASE and state == S.QUEUED):
                self.arrived_room = None
                self._arrival_fired = False
                self._leg = want
                self.ctx.emit("laundry.go", room=room, follow_color=directive.follow_color)
                await self.ctx.trigger(T.GO_BASE if to_base else T.GO_ROOM)
                if self.arrival.is_in_target:
                    # Already at the new target (sent back to base while still beside it):
                    # no change of the arrival will come, so take it now.
                    self._on_arrival_change(True)
            return
        if state in FOLLOWING:
            if self.arrived_room is not None:
                # Arrived a moment ago; its trigger may still be on its way.
                await self._fire_arrival(_leg(state))
            else:
                await self.ctx.trigger(CoreTrigger.MISSION_DONE)
        elif state == S.AT_BASE or (state == S.AT_ROOM and room is None
                                  and self.arrived_room is None):
            await self.ctx.trigger(CoreTrigger.MISSION_DONE)

    async def _fire_arrival(self, leg: str) -> None:
        # The beacon and the server's directive may both report one arrival in the same
        # moment: the machine takes it once. An arrival seen on one leg (to_room) means
        # nothing once the server has sent the robot on another (to_base), even while that
        # order still waits in the machine's queue.
        if (_leg(self.ctx.state) == leg and self._leg in (None, leg)
                and not self._arrival_fired):
            self._arrival_fired = True
            await self.ctx.trigger(T.ARRIVED_BASE if leg == S.TO_BASE else T.ARRIVED_ROOM)

    def line_lost(self) -> None:
        """The line follower gave up; the robot is stopped in ``recovery``."""
        self.line_losses += 1
        self._last_loss_s = self.ctx.loop_time_s()

    def _may_retry(self) -> bool:
        """Try again a few seconds later, a few times; then stay stopped for a person to see."""
        if self.line_losses > MAX_LINE_RETRIES:
            return False
        return self.ctx.loop_time_s() - self._last_loss_s >= LINE_RETRY_PAUSE_S

    def _on_arrival_change(self, in_target: bool) -> None:
        if not in_target:
            return
        state = self.ctx.state
        if state not in FOLLOWING:
            return
        rooms = {c.room_name for c in self.tracker.configs() if c.is_navigation_target}
        reached = {b.config.room_name for b in self.tracker.tracked()
                   if b.mac in self.arrival.reached and b.config is not None}
        room = next(iter(sorted(reached & rooms)), self.target_room)
        self.arrived_room = room
        if self.memory is not None:
            self.memory.arrived(room)
        self.line_losses = 0
        self.ctx.emit("arrival", room=room, beacons=self.arrival.reached)
        log.info("laundry.arrived", room=room)
        self._schedule(_leg(state))

    def _schedule(self, leg: str) -> None:
        task = asyncio.get_running_loop().create_task(self._fire_arrival(leg))
        task.add_done_callback(lambda t: t.exception() if not t.cancelled() else None)

    def status(self) -> dict[str, Any]:
        return {"target_room": self.target_room, "arrived_room": self.arrived_room,
                "line_losses": self.line_losses,
                "line_following": self.directive.line_following,
                "follow_color": self.directive.follow_color, "problems": self.problems}


def _leg(state: str) -> str:
    """The leg a following state is on: queued at base is still the way to base."""
    return S.TO_BASE if state == S.QUEUED else state
