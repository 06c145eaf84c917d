"""The LD19 / STL-19P LiDAR driver: LDROBOT's 47-byte packets on a one-way serial line.

``crc`` (LDROBOT's CRC-8), ``packet`` (the packet's fields), ``parser`` (bytes -> packets),
``scan_assembler`` (packets -> scans in the robot's frame), ``stats`` (counters), ``config``
(the ``lidar`` section) and ``link`` (the device: port, reconnects, staleness).
"""

from __future__ import annotations

from drivers.lidar.config import LidarConfig
from drivers.lidar.link import Ld19Lidar
from drivers.lidar.packet import Model, Packet
from drivers.lidar.parser import PacketParser
from drivers.lidar.scan_assembler import ScanAssembler
from hal.settings import SettingsView

__all__ = [
    "Ld19Lidar",
    "LidarConfig",
    "Model",
    "Packet",
    "PacketParser",
    "ScanAssembler",
    "from_settings",
]


def from_settings(settings: SettingsView) -> Ld19Lidar:
    """The real LiDAR on ``lidar.port`` (``robotd.hardware``'s factory)."""
    from drivers.serial_port import open_serial

    return Ld19Lidar(open_serial, LidarConfig.from_settings(settings))
