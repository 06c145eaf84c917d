"""The LiDAR driver's settings, read once from the ``lidar`` config section."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Protocol

from drivers.lidar.packet import LINE_BAUD, Model


class SectionSource(Protocol):
    """What the driver needs of the settings: one section's values (``Settings`` has it)."""

    def section(self, name: str) -> dict[str, Any]: ...


@dataclass(frozen=True, slots=True)
class LidarConfig:
    """Port, model, mount and timings (defaults: the ``lidar`` section's)."""

    port: str = "/dev/ttyUSB0"
    baud: int = LINE_BAUD
    model: Model = Model.LD19
    mount_yaw_deg: float = 0.0
    mount_x_m: float = 0.0
    mount_y_m: float = 0.0
    min_range_m: float = 0.02
    max_range_m: float = 12.0
    stale_s: float = 0.5
    reconnect_min_s: float = 0.1
    reconnect_max_s: float = 5.0

    @property
    def mount_yaw_rad(self) -> float:
        return math.radians(self.mount_yaw_deg)

    @classmethod
    def from_settings(cls, settings: SectionSource) -> LidarConfig:
        s = settings.section("lidar")
        return cls(
            port=s["port"], baud=s["baud"], model=Model(s["model"]),
            mount_yaw_deg=s["mount_yaw_deg"], mount_x_m=s["mount_x_m"],
            mount_y_m=s["mount_y_m"], min_range_m=s["min_range_m"],
            max_range_m=s["max_range_m"], stale_s=s["stale_s"],
            reconnect_max_s=s["reconnect_max_s"],
        )
