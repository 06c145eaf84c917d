"""The ``drive`` config section: the wheels odometry integrates, then the drive's tuning."""

from __future__ import annotations

from dataclasses import dataclass

from hal.options import Order, load, section_of, setting
from hal.settings import SettingsView


@dataclass(frozen=True, slots=True)
class WheelConfig:
    """The wheels and encoders (``Odometry.from_settings``)."""

    wheel_base_m: float = setting(0.30, "Distance between the wheels.", min=0.05, max=2)
    wheel_radius_m: float = setting(0.035, "Wheel radius.", min=0.005, max=0.5)
    ticks_per_rev: int = setting(360, "Encoder ticks per wheel turn.", min=1, max=100000)

    @classmethod
    def from_settings(cls, settings: SettingsView) -> WheelConfig:
        return load(cls, settings.section(DRIVE.name))


@dataclass(frozen=True, slots=True)
class DriveTuning:
    """The motor board's calibration and the waypoint drive's speeds and gains."""

    max_speed_mps: float = setting(0.6, "Wheel speed at PWM 255.", min=0.01, max=5)
    deadband_pwm: int = setting(20, "PWM below which the wheels do not turn.", min=0, max=254)
    cruise_mps: float = setting(0.2, "Speed between waypoints.", min=0.01, max=5, tunable=True)
    min_mps: float = setting(0.03, "Slowest commanded speed.", min=0.001, max=1, tunable=True)
    turn_mps: float = setting(0.08, "Wheel speed when turning in place.", min=0.01, max=2,
                              tunable=True)
    heading_gain: float = setting(2.0, "Heading correction (rad/s per rad).", min=0, max=50,
                                  tunable=True)
    tolerance_m: float = setting(0.01, "A waypoint is reached this close.", min=0.001, max=1,
                                 tunable=True)

    @classmethod
    def from_settings(cls, settings: SettingsView) -> DriveTuning:
        return load(cls, settings.section(DRIVE.name))


DRIVE = section_of((WheelConfig, DriveTuning), "drive", "Wheels, odometry and waypoint driving.")

DRIVE_ORDERS = (Order(("drive.min_mps", "drive.cruise_mps"), strict=False),)
