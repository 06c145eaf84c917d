"""A snag: something holds the robot where it is (a cable caught under a wheel, the edge of
a rug, a wheel in a floor grate). The wheels still turn and their encoders count, the body
does not move; turning in place still works. Unlike a wall, nothing of it shows in the LiDAR
scan or the front range sensor, so the planner keeps its path and only the lack of progress
tells: the seed's "stuck" (RelayBot's goal unreachable, the cabinet robot's drive controller
that cannot reach its node).

``Snag.hold()`` pins the body's position every ``HOLD_S`` of loop time until ``release()``;
the script's ``body.snag`` (``duration_s``: then ``body.released``), in the simulator slices
of the robots whose scenarios use it.
"""

from __future__ import annotations

import asyncio
import contextlib
from typing import TYPE_CHECKING, Any

from sim.world.floor_plan import WorldError
from sim.world.geometry import Pose

if TYPE_CHECKING:
    from sim.world.body import DiffDriveBody

HOLD_S = 0.01
"""As often as the body's physics steps: it never gets more than a step away."""


class Snag:
    """Holds one body in place while it lasts."""

    def __init__(self, body: DiffDriveBody) -> None:
        self.body = body
        self.at: tuple[float, float] | None = None
        self._task: asyncio.Task[None] | None = None

    @property
    def holding(self) -> bool:
        return self._task is not None and not self._task.done()

    def hold(self) -> None:
        """Catch the body where it stands now."""
        if self.holding:
            return
        pose = self.body.pose
        self.at = (pose.x_m, pose.y_m)
        self._task = asyncio.get_running_loop().create_task(self._pin(), name="snag")

    def release(self) -> None:
        if self._task is not None:
            self._task.cancel()
        self._task = None
        self.at = None

    async def _pin(self) -> None:
        with contextlib.suppress(asyncio.CancelledError):
            while self.at is not None:
                pose = self.body.pose
                if (pose.x_m, pose.y_m) != self.at:
                    self.body.pose = Pose(self.at[0], self.at[1], pose.heading_rad)
                await asyncio.sleep(HOLD_S)


def snag_action(step: Any) -> None:
    """``body.snag``: the robot caught where it stands for ``duration_s`` (required), then
    ``body.released``. ``step`` is a ``sim.actions.Step`` (not imported: the actions stand on
    the world, not the other way round)."""
    duration = step.duration_s()
    if duration is None:
        msg = "body.snag.duration_s: expected how long the robot stays caught (seconds)"
        raise WorldError(msg)
    held = Snag(step.rig.body)
    held.hold()
    step.later(duration, held.release, "body.released")
