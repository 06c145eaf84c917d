"""One script step as an action sees it."""

from __future__ import annotations

from collections.abc import Awaitable, Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from sim.crash import DaemonKeeper
    from sim.rig import SimRig
    from sim.scenario import Scenario


@dataclass(frozen=True, slots=True)
class Step:
    """The step's robot, its arguments, and how to schedule the end of a timed fault."""

    scenario: Scenario
    robot: str
    rig: SimRig
    args: dict[str, Any]
    later: Callable[[float, Callable[[], None], str], None]
    """``later(delay_s, fn, name)``: run ``fn`` then, recorded as the script action ``name``."""
    daemons: DaemonKeeper | None = None
    """The robots' daemons, to kill and restart one (None where nothing can be killed)."""

    def duration_s(self) -> float | None:
        value = self.args.get("duration_s")
        return None if value is None else float(value)


Action = Callable[[Step], Awaitable[None] | None]
"""Does the step; an action that must wait (a daemon going down) returns an awaitable."""
