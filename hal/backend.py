"""The set of devices a robot has, whichever backend (real drivers or the simulator) made them."""

from __future__ import annotations

from dataclasses import dataclass, fields
from enum import Enum
from typing import Any

import httpx

from hal.devices import (
    Audio,
    Battery,
    BeaconScanner,
    BinSensor,
    BumperSensor,
    Camera,
    ContactSensor,
    DockIr,
    DockSignalSensor,
    DockStation,
    Encoders,
    Leds,
    Lidar,
    LoadCell,
    Motors,
    QrReader,
    RangeSensor,
    ServoBox,
    WallSensor,
)


class Backend(Enum):
    REAL = "real"
    SIM = "sim"


@dataclass
class Devices:
    """The robot's devices; a profile uses the ones it needs (None: the robot has none).

    One driver may fill several slots: the Arduino link is motors, encoders, range sensor,
    battery, servo box and LEDs at once.
    """

    motors: Motors | None = None
    encoders: Encoders | None = None
    front_range: RangeSensor | None = None
    battery: Battery | None = None
    servo: ServoBox | None = None
    leds: Leds | None = None
    camera: Camera | None = None
    beacons: BeaconScanner | None = None
    load_cell: LoadCell | None = None
    dock_ir: DockIr | None = None
    dock_signal: DockSignalSensor | None = None
    dock_contacts: ContactSensor | None = None
    bumpers: BumperSensor | None = None
    wall: WallSensor | None = None
    bin: BinSensor | None = None
    station: DockStation | None = None
    """The docking robot's motor-board senses (front IR strength, contacts, bumpers, right
    wall sensor, dust bin) and the auto-empty station it signals through the contacts."""
    lidar: Lidar | None = None
    audio: Audio | None = None
    qr: QrReader | None = None
    network: httpx.AsyncBaseTransport | None = None
    """How the robot reaches the fleet server: None is the operating system's network; the
    simulator gives a transport to its in-process server (and can cut it)."""

    def distinct(self) -> list[Any]:
        """Each device to start and close, once, in slot order.

        A driver filling several slots counts once; a slot filled by a facet of a driver (the
        Arduino link's encoder feed) has no ``start``/``close`` of its own and is left out.
        """
        seen: list[Any] = []
        for f in fields(self):
            device = getattr(self, f.name)
            if device is None or any(device is s for s in seen):
                continue
            if callable(getattr(device, "start", None)) and callable(getattr(device, "close",
                                                                             None)):
                seen.append(device)
        return seen

    def present(self) -> list[str]:
        return [f.name for f in fields(self) if getattr(self, f.name) is not None]
