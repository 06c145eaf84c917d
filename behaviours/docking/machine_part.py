"""The ``docking`` root state as a machine part: the seed's phases (``behaviours.docking
.tables``) and section 4's counting of failed attempts (``behaviours.docking.attempts``), for
the profiles that dock (``Docking.machine_part``)."""

from __future__ import annotations

import asyncio
from typing import Any, Final

import structlog

from behaviours.context import RobotContext
from behaviours.docking.attempts import DockAttempts
from behaviours.docking.tables import DOCKING_TRANSITIONS, DockTrigger, docking_states
from behaviours.machine_part import MachinePart

log = structlog.get_logger(__name__)

DOCK_FAILED_FAULT: Final = "dock_failed"
"""The fault code once section 4's fallbacks are spent."""
DOCK_IR_LOST_FAULT: Final = "dock_ir_lost"


class AttemptCallbacks:
    """The guards and actions the docking tables name: section 4's retries and fallbacks."""

    def __init__(self, ctx: RobotContext) -> None:
        self._ctx = ctx
        self._attempts: DockAttempts | None = None

    @property
    def dock_attempts(self) -> DockAttempts:
        if self._attempts is None:
            self._attempts = DockAttempts(self._ctx.emit, self._ctx.store)
        return self._attempts

    def start_docking(self, _event: Any) -> None:
        attempts = self.dock_attempts
        settings = self._ctx.settings
        attempts.max_retries = int(settings.get("docking.max_retries"))
        attempts.max_fallbacks = int(settings.get("docking.max_fallbacks"))
        attempts.start(asyncio.get_running_loop().time())

    def count_dock_failure(self, event: Any) -> None:
        self.dock_attempts.failed(event.event.name, self._ctx.state,
                                  asyncio.get_running_loop().time(),
                                  str(event.kwargs.get("reason", "")))

    def may_retry_docking(self, _event: Any) -> bool:
        return self.dock_attempts.may_retry()

    def may_fall_back(self, _event: Any) -> bool:
        return self.dock_attempts.may_fall_back()

    def fell_back(self, _event: Any) -> None:
        self.dock_attempts.fell_back()

    def gave_up_docking(self, event: Any) -> None:
        """The seed's fallback spent (or the dock IR lost): a fault, not a silent recovery
        (``robotctl status`` shows it while the robot is in recovery; a robot that reports
        to a fleet server sends it there)."""
        why = self.dock_attempts.gave_up(str(event.kwargs.get("reason", "")))
        code = DOCK_IR_LOST_FAULT if event.event.name == DockTrigger.DOCK_IR_LOST \
            else DOCK_FAILED_FAULT
        log.error("dock.gave_up", code=code, reason=why)
        self._ctx.note_fault(code, why)

    def dock_succeeded(self, _event: Any) -> None:
        self.dock_attempts.succeeded(asyncio.get_running_loop().time())


def docking_part(ctx: RobotContext) -> MachinePart:
    """``docking`` filled with the seed's phases, its transitions, and their callbacks."""
    return MachinePart(
        "docking", "docking",
        {"initial": "search", "children": docking_states(), "on_enter": "start_docking"},
        tuple(DOCKING_TRANSITIONS), AttemptCallbacks(ctx))
