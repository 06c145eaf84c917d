"""The LiDAR driver's settings, read once from the ``lidar`` config section."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

from drivers.lidar.packet import LINE_BAUD, Model
from hal.options import Option, Order, Section
from hal.settings import SettingsView

LIDAR = Section("lidar", "The LD19 / STL-19P LiDAR on a serial port (drivers.lidar).", (
    Option("port", "str", "/dev/ttyUSB0", "Serial device of the LiDAR's USB adapter."),
    Option("baud", "int", LINE_BAUD, "Baud rate (the LD19 sends at 230400).",
           min=1200, max=2000000),
    Option("model", "str", "ld19", "ld19: 4500 points/s; stl19p (D500 kit): 5000.",
           choices=("ld19", "stl19p")),
    Option("mount_yaw_deg", "float", 0.0,
           "Where the sensor's 0 deg points, counter-clockwise from the robot's forward.",
           min=-360, max=360),
    Option("mount_x_m", "float", 0.0, "Sensor position ahead of the robot's centre.",
           min=-5, max=5),
    Option("mount_y_m", "float", 0.0, "Sensor position left of the robot's centre.",
           min=-5, max=5),
    Option("min_range_m", "float", 0.02, "Closer returns are invalid (LD19: 0.02 m).",
           min=0, max=100),
    Option("max_range_m", "float", 12.0, "Farther returns are invalid (LD19: 12 m).",
           min=0.1, max=100),
    Option("stale_s", "float", 0.5, "No scan for this long: the LiDAR is stale.",
           min=0.05, max=60),
    Option("reconnect_max_s", "float", 5.0,
           "Reconnect backoff cap (seed: retry every 5 s).", min=0.1, max=300),
))
"""The one place the LiDAR's settings and their defaults live."""

LIDAR_ORDERS = (Order(("lidar.min_range_m", "lidar.max_range_m")),)


def _default(key: str) -> Any:
    return LIDAR.by_key[key].default


@dataclass(frozen=True, slots=True)
class LidarConfig:
    """Port, model, mount and timings (defaults: the ``lidar`` section's)."""

    port: str = _default("port")
    baud: int = _default("baud")
    model: Model = Model.LD19  # the lidar section's default, "ld19"
    mount_yaw_deg: float = _default("mount_yaw_deg")
    mount_x_m: float = _default("mount_x_m")
    mount_y_m: float = _default("mount_y_m")
    min_range_m: float = _default("min_range_m")
    max_range_m: float = _default("max_range_m")
    stale_s: float = _default("stale_s")
    reconnect_min_s: float = 0.1
    reconnect_max_s: float = _default("reconnect_max_s")

    @property
    def mount_yaw_rad(self) -> float:
        return math.radians(self.mount_yaw_deg)

    @classmethod
    def from_settings(cls, settings: SettingsView) -> LidarConfig:
        s = settings.section("lidar")
        return cls(
            port=s["port"], baud=s["baud"], model=Model(s["model"]),
            mount_yaw_deg=s["mount_yaw_deg"], mount_x_m=s["mount_x_m"],
            mount_y_m=s["mount_y_m"], min_range_m=s["min_range_m"],
            max_range_m=s["max_range_m"], stale_s=s["stale_s"],
            reconnect_max_s=s["reconnect_max_s"],
        )
