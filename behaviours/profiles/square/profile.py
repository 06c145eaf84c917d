"""The ``square`` profile: drive a 1 m square on wheel odometry and come back to the start.

The smallest whole mission: it exercises the motor board link, the encoders, odometry and
the state machine, and is the simulator's first scenario. The side length is tunable.
"""

from __future__ import annotations

import asyncio
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

import structlog

from behaviours.motion.odometry import Odometry
from behaviours.motion.waypoint_drive import OdometryTracker, WaypointDrive
from behaviours.profile import BaseProfile, StateTask

if TYPE_CHECKING:
    from behaviours.context import RobotContext
    from robotd.supervisor import Service

log = structlog.get_logger(__name__)


def make_odometry(ctx: RobotContext) -> Odometry:
    drive = ctx.settings.section("drive")
    return Odometry(drive["wheel_base_m"], drive["wheel_radius_m"], drive["ticks_per_rev"])


class _OdometryService:
    """Keeps the profile's odometry current from the encoders for as long as the robot runs."""

    critical = True
    depends_on: tuple[str, ...] = ()

    def __init__(self, ctx: RobotContext, odometry: Odometry) -> None:
        self.name = "odometry"
        self._ctx = ctx
        self._odometry = odometry

    async def run(self, ready: Callable[[], None]) -> None:
        encoders = self._ctx.devices.encoders
        if encoders is None:
            msg = "the square profile needs encoders"
            raise RuntimeError(msg)
        ready()
        await OdometryTracker(encoders, self._odometry).run()


class _AutoStart:
    """Starts the mission once, as soon as the robot is idle after boot."""

    critical = False
    depends_on: tuple[str, ...] = ("odometry",)

    def __init__(self, ctx: RobotContext) -> None:
        self.name = "square.autostart"
        self._ctx = ctx

    async def run(self, ready: Callable[[], None]) -> None:
        ready()
        if self._ctx.store.get("square.done", False):
            log.info("square.already_done")
        else:
            await self._ctx.trigger("start_mission")
        await _forever()


async def _forever() -> None:
    await asyncio.Event().wait()


class SquareProfile(BaseProfile):
    name = "square"
    devices = ("motors", "encoders")

    def __init__(self) -> None:
        self._odometry: Odometry | None = None

    def mission_states(self) -> list[str | dict[str, Any]]:
        return ["square"]

    def services(self, ctx: RobotContext) -> list[Service]:
        self._odometry = make_odometry(ctx)
        return [_OdometryService(ctx, self._odometry), _AutoStart(ctx)]

    def state_tasks(self) -> dict[str, StateTask]:
        return {"mission.square": self._drive_square}

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
        ctx.store.put("square.done", True)
        ctx.emit("square.done", link_waits=drive.waits_for_link)
        await ctx.trigger("mission_done")
