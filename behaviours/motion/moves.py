"""The wheel moves docking is made of: turn by an angle, drive holding a heading, stop.

Angles and distances come from wheel odometry (the profile's ``Odometry``, kept up to date by
its ``OdometryTracker``); every loop runs at 20 Hz on the event loop's clock. While the motor
board link is down a command is dropped and the move carries on from where odometry says it
is once the link is back (the board's deadman has stopped the wheels meanwhile).
"""

from __future__ import annotations

import asyncio
import contextlib
import math
from collections.abc import Callable

from behaviours.motion.config import DriveTuning
from behaviours.motion.odometry import Odometry
from behaviours.motion.waypoint_drive import wheel_command
from hal.devices import LinkDown, Motors
from hal.looptime.timer_sleep import timer_sleep
from hal.readings import MotorCommand
from hal.settings import SettingsView

PERIOD_S = 0.05
TURN_TOLERANCE_RAD = math.radians(0.5)
HEADING_GAIN = 3.0  # rad/s of turn per rad of heading error while driving
MAX_TURN_S = 30.0


def wrap(angle_rad: float) -> float:
    return math.atan2(math.sin(angle_rad), math.cos(angle_rad))


class Mover:
    """Turns and straight drives on odometry.

    Args:
        motors: the wheels; odometry: the robot's pose from the encoders.
        settings: ``drive.*`` (PWM calibration, wheel base) and ``docking.turn_dps``.
    """

    def __init__(self, motors: Motors, odometry: Odometry, settings: SettingsView) -> None:
        self.motors = motors
        self.odometry = odometry
        self.settings = settings
        self.tuning = DriveTuning.from_settings(settings)
        self.half_base_m = odometry.wheel_base_m / 2
        self.commands = 0

    @property
    def heading_rad(self) -> float:
        return self.odometry.pose().theta_rad

    def position(self) -> tuple[float, float]:
        pose = self.odometry.pose()
        return pose.x_m, pose.y_m

    async def send(self, v_mps: float, omega_rps: float) -> None:
        """One wheel command: forward speed and turn rate (positive: left)."""
        half = omega_rps * self.half_base_m
        await self._send(wheel_command(v_mps - half, v_mps + half, self.tuning))

    async def stop(self) -> None:
        with contextlib.suppress(LinkDown):
            await self.motors.stop()

    async def turn_by(self, angle_rad: float) -> float:
        """Turn in place by ``angle_rad`` (positive: left); returns the angle left over."""
        target = self.heading_rad + angle_rad
        return await self.turn_to(target)

    async def turn_to(self, heading_rad: float) -> float:
        """Turn in place to an odometry heading; returns the error left."""
        max_rate = math.radians(float(self.settings.get("docking.turn_dps")))
        loop = asyncio.get_running_loop()
        end = loop.time() + MAX_TURN_S
        error = wrap(heading_rad - self.heading_rad)
        while abs(error) > TURN_TOLERANCE_RAD and loop.time() < end:
            rate = max(math.radians(6), min(max_rate, abs(error) * 2.5))
            await self.send(0.0, math.copysign(rate, error))
            await timer_sleep(PERIOD_S)
            error = wrap(heading_rad - self.heading_rad)
        await self.send(0.0, 0.0)
        return error

    async def straight(self, distance_m: float, v_mps: float, *,
                       until: Callable[[], bool] | None = None,
                       heading_rad: float | None = None,
                       steer: Callable[[], float | None] | None = None) -> float:
        """Drive ``distance_m`` (negative ``v_mps``: backwards) holding a heading, or until
        ``until()``; ``steer()`` may give a new heading to hold at each step. Returns the
        distance driven."""
        hold = self.heading_rad if heading_rad is None else heading_rad
        x0, y0 = self.position()
        driven = 0.0
        while driven < distance_m:
            if until is not None and until():
                break
            if steer is not None:
                wanted = steer()
                if wanted is not None:
                    hold = wanted
            error = wrap(hold - self.heading_rad)
            await self.send(v_mps, HEADING_GAIN * error)
            await timer_sleep(PERIOD_S)
            x, y = self.position()
            driven = math.hypot(x - x0, y - y0)
        await self.send(0.0, 0.0)
        return driven

    async def _send(self, command: MotorCommand) -> None:
        self.commands += 1
        with contextlib.suppress(LinkDown):
            await self.motors.drive(command)
