"""``robotd probe DEVICE``: a technician's check of one real device through its real driver.

Each probe module provides ``add_arguments(parser)`` and ``async def run(args) -> int``; the
CLI builds one sub-command per entry here and imports the module only when it is used.
"""

from __future__ import annotations

PROBES: dict[str, tuple[str, str]] = {
    "serial": ("robotd.probes.serial", "the Arduino motor board link: handshake, commands, RTT"),
    "lidar": ("robotd.probes.lidar", "the LD19 LiDAR: packets, scan rate, CRC errors"),
    "ble": ("robotd.probes.ble", "BLE iBeacons in range: MAC, UUID, major/minor, RSSI"),
    "camera": ("robotd.probes.camera", "the camera: frame rate and size, line detection"),
    "hx711": ("robotd.probes.hx711", "the HX711 load cell: raw counts, kg, noise"),
}
"""Device name -> (module path, one-line description)."""
