"""The ``square`` profile: drive a 1 m square on wheel odometry and come back to the start.

The smallest whole mission: it exercises the motor board link, the encoders, odometry and
the state machine, and is the simulator's first scenario. The side length is tunable.
"""

from __future__ import annotations

import asyncio
from typing import TYPE_CHECKING, Any, Final

import structlog

from behaviours.machine_tables import CoreTrigger, mission_children
from behaviours.motion.odometry import Odometry
from behaviours.motion.waypoint_drive import OdometryTracker, WaypointDrive
from behaviours.persistence import MissionRecord
from behaviours.profile import BaseProfile, StateTask
from behaviours.service import Service, TaskService

if TYPE_CHECKING:
    from behaviours.context import RobotContext

log = structlog.get_logger(__name__)


SQUARE: Final = "mission.square"
"""The mission's one state."""
SQUARE_MISSION = MissionRecord("square.mission", 1, {"done": False})
"""The square is driven once per state directory."""
LEGACY_DONE_KEY = "square.done"
"""Where robots that ran before the mission-state facility kept the same fact."""


async def _forever() -> None:
    await asyncio.Event().wait()


class SquareProfile(BaseProfile):
    name = "square"
    devices = ("motors", "encoders")

    def __init__(self) -> None:
        self._odometry: Odometry | None = None

    def mission_states(self) -> list[str | dict[str, Any]]:
        return mission_children(SQUARE)

    def mission_records(self) -> tuple[MissionRecord, ...]:
        return (SQUARE_MISSION,)

    def services(self, ctx: RobotContext) -> list[Service]:
        encoders = ctx.devices.encoders
        if encoders is None:
            msg = "the square profile needs encoders"
            raise RuntimeError(msg)
        odometry = self._odometry = Odometry.from_settings(ctx.settings)

        async def autostart() -> None:
            """Starts the mission once, as soon as the robot is idle after boot."""
            if ctx.persisted(SQUARE_MISSION)["done"] or ctx.store.get(LEGACY_DONE_KEY, False):
                log.info("square.already_done")
            else:
                await ctx.trigger(CoreTrigger.START_MISSION)
            await _forever()

        return [TaskService("odometry", OdometryTracker(encoders, odometry,
                                                        telemetry=ctx.telemetry).run,
                            critical=True),
                TaskService("square.autostart", autostart, depends_on=("odometry",))]

    def state_tasks(self) -> dict[str, StateTask]:
        return {SQUARE: self._drive_square}

    async def _drive_square(self, ctx: RobotContext) -> None:
        motors = ctx.devices.motors
        if motors is None or self._odometry is None:
            msg = "the square profile needs motors and odometry"
            raise RuntimeError(msg)
        side_m = 1.0
        start = self._odometry.pose()
        corners = [(side_m, 0.0), (side_m, side_m), (0.0, side_m), (0.0, 0.0)]
        drive = WaypointDrive(motors, self._odometry, ctx.settings)
        ctx.emit("square.start", odom_x_m=start.x_m, odom_y_m=start.y_m)
        for i, (dx, dy) in enumerate(corners):
            remaining = await drive.go_to(start.x_m + dx, start.y_m + dy)
            ctx.emit("square.corner", corner=i + 1, remaining_m=remaining)
        await drive.stop()
        ctx.persisted(SQUARE_MISSION).set(done=True)
        ctx.emit("square.done", link_waits=drive.waits_for_link)
        await ctx.trigger(CoreTrigger.MISSION_DONE)
