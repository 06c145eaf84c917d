"""The staff's orders a fleet server sends in its answer: e-stop, and maintenance.

Both are levels the server holds (``EmergencyStop``, ``MaintenanceMode``): the robot acts
when one is set and it is not there yet, and undoes only what the server did when it is
cleared. An e-stop latched by anything else (``robotctl estop``, a failing service, a bumper)
is a person's to lift on the robot: the server's resume lifts only its own (the latch's
source is ``fleet`` alone, also across a restart). Resumed, a robot the server stopped at
work (in its mission, or docking) starts its mission again: the staff's resume means "go on",
where a person's ``robotctl resume`` leaves it idle for them to start.
"""

from __future__ import annotations

from collections.abc import Awaitable, Callable

import structlog

from behaviours.context import RobotContext
from behaviours.machine_tables import CoreTrigger, RootState

log = structlog.get_logger(__name__)

SOURCE = "fleet"
"""The e-stop latch's source for the server's orders."""

_AT_WORK = (RootState.MISSION, RootState.DOCKING)
"""Stopped by the server in these, the robot starts its mission again once resumed (a
robot stopped idle stays idle)."""

EngageEstop = Callable[[str, str], Awaitable[object]]
"""``engage(reason, source)``: the robot's e-stop (the daemon's, as ``robotctl estop``)."""


class StaffOrders:
    """Applies the server's e-stop and maintenance levels to the machine.

    Args:
        ctx: the robot's context (its state, triggers and e-stop latch).
        engage_estop: the e-stop path to take; None fires the machine's ``estop`` trigger.
    """

    def __init__(self, ctx: RobotContext, engage_estop: EngageEstop | None = None) -> None:
        self.ctx = ctx
        self._engage = engage_estop
        # An e-stop the server put on, latched before a restart, is the server's to lift.
        self._server_estop = ctx.estop_latch.only_from(SOURCE)
        self._server_maintenance = False
        self._back_to_work = False

    async def apply(self, emergency_stop: bool, maintenance: bool) -> bool:
        """Act on the orders; True while one of them holds the robot (the caller then gives
        it no other work)."""
        ctx = self.ctx
        state = ctx.state
        if emergency_stop:
            if state != RootState.ESTOP:
                self._server_estop = True
                self._back_to_work = state.split(".")[0] in _AT_WORK
                reason = "the fleet server's EmergencyStop"
                log.warning("site.server_estop", state=state)
                if self._engage is not None:
                    await self._engage(reason, SOURCE)
                else:
                    await ctx.trigger(CoreTrigger.ESTOP, source=SOURCE, reason=reason)
            return True
        if state == RootState.ESTOP:
            if self._server_estop and ctx.estop_latch.only_from(SOURCE):
                self._server_estop = False
                log.info("site.server_resume", back_to_work=self._back_to_work)
                if await ctx.trigger(CoreTrigger.RESUME, source=SOURCE) and self._back_to_work:
                    await ctx.trigger(CoreTrigger.START_MISSION)
            return True
        if maintenance:
            if state != RootState.MAINTENANCE:
                self._server_maintenance = await ctx.trigger(CoreTrigger.MAINTENANCE)
                if not self._server_maintenance:
                    log.warning("site.maintenance_refused", state=state)
            return True
        if state == RootState.MAINTENANCE:
            if self._server_maintenance:
                self._server_maintenance = False
                await ctx.trigger(CoreTrigger.END_MAINTENANCE)
            return True
        return False
