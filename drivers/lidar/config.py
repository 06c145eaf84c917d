"""The LiDAR driver's settings: the ``lidar`` config section, declared by ``LidarConfig``."""

from __future__ import annotations

import math
from dataclasses import dataclass

from drivers.lidar.packet import LINE_BAUD, Model
from hal.options import Order, load, section_of, setting
from hal.settings import SettingsView


@dataclass(frozen=True, slots=True)
class LidarConfig:
    """Port, model, mount and timings."""

    port: str = setting("/dev/ttyUSB0", "Serial device of the LiDAR's USB adapter.")
    baud: int = setting(LINE_BAUD, "Baud rate (the LD19 sends at 230400).",
                        min=1200, max=2000000)
    model: Model = setting(Model.LD19, "ld19: 4500 points/s; stl19p (D500 kit): 5000.")
    mount_yaw_deg: float = setting(
        0.0, "Where the sensor's 0 deg points, counter-clockwise from the robot's forward.",
        min=-360, max=360)
    mount_x_m: float = setting(0.0, "Sensor position ahead of the robot's centre.",
                               min=-5, max=5)
    mount_y_m: float = setting(0.0, "Sensor position left of the robot's centre.",
                               min=-5, max=5)
    min_range_m: float = setting(0.02, "Closer returns are invalid (LD19: 0.02 m).",
                                 min=0, max=100)
    max_range_m: float = setting(12.0, "Farther returns are invalid (LD19: 12 m).",
                                 min=0.1, max=100)
    stale_s: float = setting(0.5, "No scan for this long: the LiDAR is stale.",
                             min=0.05, max=60)
    reconnect_min_s: float = 0.1
    reconnect_max_s: float = setting(5.0, "Reconnect backoff cap (seed: retry every 5 s).",
                                     min=0.1, max=300)

    @property
    def mount_yaw_rad(self) -> float:
        return math.radians(self.mount_yaw_deg)

    @classmethod
    def from_settings(cls, settings: SettingsView) -> LidarConfig:
        return load(cls, settings.section(LIDAR.name))


LIDAR = section_of(LidarConfig, "lidar",
                   "The LD19 / STL-19P LiDAR on a serial port (drivers.lidar).")
"""The one place the LiDAR's settings and their defaults live."""

LIDAR_ORDERS = (Order(("lidar.min_range_m", "lidar.max_range_m")),)
