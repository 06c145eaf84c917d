"""Wheel odometry: the robot's pose from cumulative encoder ticks (seed 002, section 4)."""

from __future__ import annotations

import math
from dataclasses import dataclass

from behaviours.motion.config import WheelConfig
from hal.readings import EncoderReading
from hal.settings import SettingsView


@dataclass(frozen=True, slots=True)
class OdometryPose:
    x_m: float
    y_m: float
    theta_rad: float


class Odometry:
    """Integrates encoder tick deltas into a pose (x, y, theta) in the odometry frame.

    Ticks are cumulative and signed, as the motor board reports them; the first reading after
    ``reset`` only sets the reference. A jump larger than ``max_step_ticks`` is
    taken as a board reset (counters back to zero) and rebases instead of moving the robot.
    """

    def __init__(
        self,
        wheel_base_m: float,
        wheel_radius_m: float,
        ticks_per_rev: int,
        *,
        max_step_ticks: int = 2000,
    ) -> None:
        if wheel_base_m <= 0 or wheel_radius_m <= 0 or ticks_per_rev <= 0:
            msg = "wheel_base_m, wheel_radius_m and ticks_per_rev must be > 0"
            raise ValueError(msg)
        self.wheel_base_m = wheel_base_m
        self.m_per_tick = 2 * math.pi * wheel_radius_m / ticks_per_rev
        self.max_step_ticks = max_step_ticks
        self._x = self._y = self._theta = 0.0
        self._pose: OdometryPose | None = None  # built when read, until the robot moves
        self._last: tuple[int, int] | None = None
        self.distance_m = 0.0
        self.rebases = 0
        self.last_t_s: float | None = None

    @classmethod
    def from_settings(cls, settings: SettingsView) -> Odometry:
        """The robot's wheels as the ``drive`` section describes them."""
        wheels = WheelConfig.from_settings(settings)
        return cls(wheels.wheel_base_m, wheels.wheel_radius_m, wheels.ticks_per_rev)

    def reset(self, x_m: float = 0.0, y_m: float = 0.0, theta_rad: float = 0.0) -> None:
        self._x, self._y, self._theta = x_m, y_m, theta_rad
        self._pose = None
        self._last = None

    def update(self, reading: EncoderReading) -> OdometryPose:
        ticks = (reading.left_ticks, reading.right_ticks)
        self.last_t_s = reading.t_s
        if self._last is None:
            self._last = ticks
            return self.pose()
        dl_ticks = ticks[0] - self._last[0]
        dr_ticks = ticks[1] - self._last[1]
        self._last = ticks
        if abs(dl_ticks) > self.max_step_ticks or abs(dr_ticks) > self.max_step_ticks:
            self.rebases += 1
            return self.pose()
        self.integrate(dl_ticks * self.m_per_tick, dr_ticks * self.m_per_tick)
        return self.pose()

    def integrate(self, left_m: float, right_m: float) -> None:
        """Advance by wheel travel (midpoint rule: exact for constant curvature over the step)."""
        d = (left_m + right_m) / 2
        dtheta = (right_m - left_m) / self.wheel_base_m
        mid = self._theta + dtheta / 2
        self._x += d * math.cos(mid)
        self._y += d * math.sin(mid)
        self._theta = math.atan2(math.sin(self._theta + dtheta), math.cos(self._theta + dtheta))
        self.distance_m += abs(d)
        self._pose = None

    def pose(self) -> OdometryPose:
        pose = self._pose
        if pose is None:
            pose = self._pose = OdometryPose(self._x, self._y, self._theta)
        return pose
