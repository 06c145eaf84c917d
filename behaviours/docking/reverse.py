"""Backing up with the rear receiver watching: the seed's reverse guard.

The seed gives the rear directional receiver two jobs (section 3: "Virtual Wall / 후진 충돌
방지", reverse collision prevention). Every move backwards of the docking behaviour (undocking,
backing off before a retry, backing away from the dock after a fallback, homing backwards on
the rear receiver) goes through ``back_up``: it stops as soon as the rear receiver sees a
virtual wall (the wall lies right behind the robot) or a bumper closes on the way (the robot
is being pushed, or pivoted into something; one pressed at the start is why it backs off),
and says so (``dock.reverse_guard``). The bumpers cover
the front half only and the robot has no range sensor behind: a wall behind the robot that
emits nothing is not seen (the hardware's limit, not a choice).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING

from behaviours.docking.senses import DockSenses

if TYPE_CHECKING:
    from behaviours.context import RobotContext

VIRTUAL_WALL = "virtual_wall"
"""The beam name of the OI virtual wall (code 162 in ``docking.ir_codes``)."""
REAR = "rear"


def behind(senses: DockSenses, *, bumped_before: bool = False) -> str | None:
    """Why the robot must not back up any further (None: nothing seen behind it)."""
    beams = senses.view().reading.beams
    if VIRTUAL_WALL in beams.get(REAR, frozenset()):
        return "virtual wall behind"
    if senses.bumped() and not bumped_before:
        return "bumper pressed"
    return None


async def back_up(ctx: RobotContext, senses: DockSenses, distance_m: float, speed_mps: float,
                  *, why: str, until: Callable[[], bool] | None = None) -> float:
    """Back up ``distance_m`` at ``speed_mps`` (a positive speed), stopping early when
    ``behind`` says so (event ``dock.reverse_guard``) or ``until()`` holds; the distance
    driven."""
    stopped: list[str] = []
    bumped_before = senses.bumped()

    def done() -> bool:
        nonlocal bumped_before
        reason = behind(senses, bumped_before=bumped_before)
        bumped_before = bumped_before and senses.bumped()  # released: guard again
        if reason is not None:
            stopped.append(reason)
            return True
        return until is not None and until()

    driven = await senses.mover.straight(distance_m, -abs(speed_mps), until=done)
    if stopped:
        ctx.emit("dock.reverse_guard", reason=stopped[0], during=why,
                 backed_m=round(driven, 3), wanted_m=round(distance_m, 3))
    return driven
