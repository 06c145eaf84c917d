"""Driving to waypoints on wheel odometry: turn in place, then drive with heading correction.

Wheel speeds become PWM through the motor board's calibration (``drive.max_speed_mps`` at PWM
255, ``drive.deadband_pwm`` below which the wheels do not turn). While the motor board link is
down the drive waits for it to return, then carries on from where odometry says it is.
"""

from __future__ import annotations

import asyncio
import contextlib
import math
from collections.abc import Callable

import structlog

from behaviours.motion.config import DriveTuning
from behaviours.motion.odometry import Odometry, OdometryPose
from hal.devices import Encoders, LinkDown, ListenableEncoders, Motors
from hal.looptime.timer_sleep import timer_sleep
from hal.readings import EncoderReading, MotorCommand
from hal.settings import SettingsView
from hal.telemetry import NULL_TELEMETRY, Telemetry

log = structlog.get_logger(__name__)

_PERIOD_S = 0.05
_HEADING_TOLERANCE_RAD = math.radians(2.0)
_RETURN_TO_TURN_RAD = math.radians(45)


# Commands are immutable and a drive repeats a few hundred of them: each is built once.
_COMMANDS: dict[tuple[int, int, bool, bool], MotorCommand] = {}
_COMMANDS_KEPT = 4096


def wheel_command(left_mps: float, right_mps: float, tuning: DriveTuning) -> MotorCommand:
    """Wheel speeds (m/s, signed) as PWM and direction, past the motors' deadband."""
    key = (_pwm(left_mps, tuning), _pwm(right_mps, tuning), left_mps >= 0, right_mps >= 0)
    command = _COMMANDS.get(key)
    if command is None:
        command = MotorCommand(*key)
        if len(_COMMANDS) < _COMMANDS_KEPT:
            _COMMANDS[key] = command
    return command


def _pwm(speed: float, tuning: DriveTuning) -> int:
    if abs(speed) < 1e-4:
        return 0
    span = 255 - tuning.deadband_pwm
    return min(255, round(tuning.deadband_pwm + abs(speed) / tuning.max_speed_mps * span))


class OdometryTracker:
    """Keeps an Odometry up to date from the encoders, as a task (and shows the live view
    each new odometry pose, in the ``odom`` frame, when it is on)."""

    def __init__(self, encoders: Encoders, odometry: Odometry, *,
                 telemetry: Telemetry = NULL_TELEMETRY) -> None:
        self.encoders = encoders
        self.odometry = odometry
        self.telemetry = telemetry

    def _update_and_show(self, reading: EncoderReading) -> None:
        p = self.odometry.update(reading)
        self.telemetry.pose("odom", (p.x_m, p.y_m, p.theta_rad), frame="odom")

    async def run(self) -> None:
        update = self._update_and_show if self.telemetry.enabled else self.odometry.update
        latest = self.encoders.latest()
        if latest is not None:
            update(latest)
        if isinstance(self.encoders, ListenableEncoders):
            # Updated where each reading arrives: no task wake-up per reading. Without the
            # link no readings come; the first one after it returns carries the motion.
            stop = self.encoders.listen(update)
            try:
                await asyncio.Event().wait()  # until cancelled
            finally:
                stop()
            return
        while True:
            try:
                reading = await self.encoders.next_reading()
            except LinkDown:
                # No readings while the board is away; its counters run on, so the first
                # reading after the link returns carries the motion made meanwhile.
                await asyncio.sleep(_PERIOD_S)
                continue
            update(reading)


PoseSource = Callable[[], OdometryPose]
"""Where the robot is, in the frame its waypoints are given in (x_m, y_m, theta_rad)."""


class WaypointDrive:
    """Drives the robot through waypoints given in the frame of its pose source.

    The pose source is wheel odometry unless one is given (the localised pose in the map
    frame, for the navigation stack's path follower).
    """

    def __init__(self, motors: Motors, odometry: Odometry, settings: SettingsView, *,
                 pose_source: PoseSource | None = None) -> None:
        self.motors = motors
        self.odometry = odometry
        self.settings = settings
        self.pose: PoseSource = pose_source if pose_source is not None else odometry.pose
        self.waits_for_link = 0
        self.speed_scale = 1.0  # 0.5 while the encoders have failed (the seed's error table)
        self._link_up = asyncio.Event()
        self._up = motors.connected  # what _link_up says, read without a call each step
        if self._up:
            self._link_up.set()
        motors.on_link_change(self._on_link)

    def _on_link(self, connected: bool) -> None:
        self._up = connected
        if connected:
            self._link_up.set()
        else:
            self._link_up.clear()

    async def _send(self, command: MotorCommand) -> None:
        while True:
            if not self._up:
                self.waits_for_link += 1
                log.warning("drive.waiting_for_link")
                await self._link_up.wait()
                log.info("drive.link_back")
            try:
                await self.motors.drive(command)
                return
            except LinkDown:
                self._up = False
                self._link_up.clear()

    async def stop(self) -> None:
        # Without the link the board's deadman stops the wheels by itself.
        with contextlib.suppress(LinkDown):
            await self.motors.stop()

    async def go_to(self, x_m: float, y_m: float) -> float:
        """Drive to a point; returns the remaining distance by odometry."""
        tuning = DriveTuning.from_settings(self.settings)
        await self._turn_towards(x_m, y_m, tuning)
        start = self.pose()
        seg_x, seg_y = x_m - start.x_m, y_m - start.y_m
        seg_len = math.hypot(seg_x, seg_y)
        while True:
            pose = self.pose()
            dx, dy = x_m - pose.x_m, y_m - pose.y_m
            remaining = math.hypot(dx, dy)
            along = (dx * seg_x + dy * seg_y) / seg_len if seg_len > 0 else 0.0
            if remaining <= tuning.tolerance_m or along <= 0:
                break
            error = _wrap(math.atan2(dy, dx) - pose.theta_rad)
            if abs(error) > _RETURN_TO_TURN_RAD:
                await self._turn_towards(x_m, y_m, tuning)
                continue
            speed = max(tuning.min_mps, min(tuning.cruise_mps * self.speed_scale, 1.2 * along))
            omega = tuning.heading_gain * error
            half = omega * self.odometry.wheel_base_m / 2
            await self._send(wheel_command(speed - half, speed + half, tuning))
            await timer_sleep(_PERIOD_S)
        await self._send(MotorCommand.stopped())
        await asyncio.sleep(0.3)  # let the wheels come to rest before the next leg
        pose = self.pose()
        remaining = math.hypot(x_m - pose.x_m, y_m - pose.y_m)
        log.info("drive.waypoint_reached", x_m=round(x_m, 3), y_m=round(y_m, 3),
                 remaining_m=round(remaining, 4))
        return remaining

    async def _turn_towards(self, x_m: float, y_m: float, tuning: DriveTuning) -> None:
        while True:
            pose = self.pose()
            error = _wrap(math.atan2(y_m - pose.y_m, x_m - pose.x_m) - pose.theta_rad)
            if abs(error) < _HEADING_TOLERANCE_RAD:
                break
            speed = max(tuning.min_mps, min(tuning.turn_mps * self.speed_scale, abs(error) * 0.25))
            sign = 1 if error > 0 else -1
            await self._send(wheel_command(-sign * speed, sign * speed, tuning))
            await timer_sleep(_PERIOD_S)
        await self._send(MotorCommand.stopped())
        await asyncio.sleep(0.2)


def _wrap(angle_rad: float) -> float:
    return math.atan2(math.sin(angle_rad), math.cos(angle_rad))
