"""The cabinet robot's drive controller (the seed's fourth init block): PID controllers on the
heading and the distance to go, turning in place and driving straight to a point.

The pose source is switchable: wheel odometry while the robot does not know where it is
(fitting: turns and the drive to the room's middle are relative moves), the navigation
stack's localised map pose once the scan is fitted. ``drive_to`` watches two things a caller
gives: ``blocked()`` (the scan says the corridor ahead is blocked, the localisation is lost)
and progress: no ``progress_m`` closer for ``stall_s`` ends the drive as ``stalled``.
"""

from __future__ import annotations

import asyncio
import contextlib
import math
from collections.abc import Callable
from dataclasses import dataclass

from behaviours.motion.config import DriveTuning
from behaviours.motion.odometry import OdometryPose
from behaviours.motion.waypoint_drive import wheel_command
from hal.devices import LinkDown, Motors
from hal.looptime.timer_sleep import timer_sleep
from hal.readings import MotorCommand
from hal.settings import SettingsView

PERIOD_S = 0.05
HEADING_TOLERANCE_RAD = math.radians(1.5)
RETURN_TO_TURN_RAD = math.radians(40)
PROGRESS_M = 0.05

PoseSource = Callable[[], OdometryPose]


def wrap(angle_rad: float) -> float:
    return math.atan2(math.sin(angle_rad), math.cos(angle_rad))


@dataclass(slots=True)
class Pid:
    """A PID controller on an error (the integral clamped against wind-up)."""

    kp: float
    ki: float
    kd: float
    limit: float
    integral: float = 0.0
    last_error: float | None = None

    def reset(self) -> None:
        self.integral, self.last_error = 0.0, None

    def step(self, error: float, dt_s: float) -> float:
        self.integral = max(-self.limit, min(self.limit, self.integral + error * dt_s))
        rate = 0.0 if self.last_error is None else (error - self.last_error) / dt_s
        self.last_error = error
        out = self.kp * error + self.ki * self.integral + self.kd * rate
        return max(-self.limit, min(self.limit, out))


@dataclass(frozen=True, slots=True)
class DriveResult:
    """``reached``, ``stalled`` (no progress for the stall time) or what ``blocked`` said."""

    reason: str
    remaining_m: float

    @property
    def reached(self) -> bool:
        return self.reason == "reached"


class DriveController:
    """Turns and straight drives on a pose source, through ``motors`` (the obstacle guard)."""

    def __init__(self, motors: Motors, settings: SettingsView, wheel_base_m: float,
                 pose: PoseSource) -> None:
        self.motors = motors
        self.settings = settings
        self.wheel_base_m = wheel_base_m
        self.pose = pose
        c = settings.section("cabinet")
        self.heading = Pid(c["heading_kp"], c["heading_ki"], c["heading_kd"], limit=2.0)
        self.distance_kp = float(c["distance_kp"])

    async def _send(self, left_mps: float, right_mps: float, tuning: DriveTuning) -> None:
        with contextlib.suppress(LinkDown):  # the board's deadman stops it without the link
            await self.motors.drive(wheel_command(left_mps, right_mps, tuning))

    async def stop(self) -> None:
        with contextlib.suppress(LinkDown):
            await self.motors.drive(MotorCommand.stopped())

    async def turn_to(self, heading_rad: float, timeout_s: float = 30.0) -> float:
        """Turn in place to a heading of the pose source; returns the error left (rad)."""
        tuning = DriveTuning.from_settings(self.settings)
        loop = asyncio.get_running_loop()
        until = loop.time() + timeout_s
        self.heading.reset()
        error = wrap(heading_rad - self.pose().theta_rad)
        while abs(error) >= HEADING_TOLERANCE_RAD and loop.time() < until:
            omega = self.heading.step(error, PERIOD_S)
            speed = omega * self.wheel_base_m / 2
            limit = tuning.turn_mps
            speed = math.copysign(max(tuning.min_mps, min(limit, abs(speed))), speed)
            await self._send(-speed, speed, tuning)
            await timer_sleep(PERIOD_S)
            error = wrap(heading_rad - self.pose().theta_rad)
        await self.stop()
        await asyncio.sleep(0.2)
        return wrap(heading_rad - self.pose().theta_rad)

    async def drive_to(self, x_m: float, y_m: float, *, stall_s: float,
                       blocked: Callable[[], str | None] | None = None,
                       tolerance_m: float = 0.05) -> DriveResult:
        """Turn towards (x, y), then drive to it with heading PID; stops on the way out."""
        tuning = DriveTuning.from_settings(self.settings)
        loop = asyncio.get_running_loop()
        pose = self.pose()
        if math.hypot(x_m - pose.x_m, y_m - pose.y_m) <= tolerance_m:
            return DriveResult("reached", math.hypot(x_m - pose.x_m, y_m - pose.y_m))
        await self.turn_to(math.atan2(y_m - pose.y_m, x_m - pose.x_m))
        best_m = math.inf
        best_s = loop.time()
        self.heading.reset()
        try:
            while True:
                pose = self.pose()
                dx, dy = x_m - pose.x_m, y_m - pose.y_m
                remaining = math.hypot(dx, dy)
                if remaining <= tolerance_m:
                    return DriveResult("reached", remaining)
                now = loop.time()
                if remaining < best_m - PROGRESS_M:
                    best_m, best_s = remaining, now
                elif now - best_s >= stall_s:
                    return DriveResult(f"stalled: no progress for {stall_s:g} s", remaining)
                why = blocked() if blocked is not None else None
                if why is not None:
                    return DriveResult(why, remaining)
                error = wrap(math.atan2(dy, dx) - pose.theta_rad)
                if abs(error) > RETURN_TO_TURN_RAD:
                    await self.turn_to(math.atan2(dy, dx))
                    continue
                speed = max(tuning.min_mps, min(tuning.cruise_mps, self.distance_kp * remaining))
                half = self.heading.step(error, PERIOD_S) * self.wheel_base_m / 2
                await self._send(speed - half, speed + half, tuning)
                await timer_sleep(PERIOD_S)
        finally:
            await self.stop()
            await asyncio.sleep(0.2)

    async def drive_straight(self, gap_m: Callable[[], float | None], *, timeout_s: float,
                             tolerance_m: float = 0.01) -> float | None:
        """Forward or back along the heading until ``gap_m()`` (what is left to go, signed:
        positive ahead) is within the tolerance; returns the last gap (None: never measured)."""
        tuning = DriveTuning.from_settings(self.settings)
        loop = asyncio.get_running_loop()
        until = loop.time() + timeout_s
        gap = gap_m()
        try:
            while gap is not None and abs(gap) > tolerance_m and loop.time() < until:
                speed = max(tuning.min_mps, min(tuning.cruise_mps / 2,
                                                self.distance_kp * abs(gap)))
                speed = math.copysign(speed, gap)
                await self._send(speed, speed, tuning)
                await timer_sleep(PERIOD_S)
                gap = gap_m()
        finally:
            await self.stop()
            await asyncio.sleep(0.3)
        return gap_m()
