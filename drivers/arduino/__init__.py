"""The Arduino motor board link (DESIGN.md "Serial link to the Arduino")."""

from __future__ import annotations

from drivers.arduino.config import LinkConfig
from drivers.arduino.framing import Framing
from drivers.arduino.link import ArduinoLink, CommandNotDelivered, Feed, FirmwareRejected
from drivers.arduino.outbox import Delivery, Outcome
from hal.settings import SettingsView

__all__ = [
    "ArduinoLink",
    "CommandNotDelivered",
    "Delivery",
    "Feed",
    "FirmwareRejected",
    "Framing",
    "LinkConfig",
    "Outcome",
    "from_settings",
]


def from_settings(settings: SettingsView) -> ArduinoLink:
    """The real link on ``serial.port`` (``robotd.hardware``'s factory)."""
    from drivers.serial_port import open_serial

    return ArduinoLink.from_settings(open_serial, settings)
