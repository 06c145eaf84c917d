"""The Arduino link's settings: the ``serial`` config section, read once into a LinkConfig."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from drivers.arduino.framing import Framing
from hal.options import Option, Section
from hal.settings import SettingsView

SERIAL = Section("serial", "The Arduino motor board link.", (
    Option("port", "str", "/dev/ttyACM0", "Serial device."),
    Option("baud", "int", 115200, "Baud rate.", min=1200, max=2000000),
    Option("framing", "str", "crc", "crc: #SEQ and CRC-8; plain: the seed's bare lines.",
           choices=("crc", "plain")),
    Option("ack_timeout_s", "float", 0.5, "Resend a command not acknowledged in this time.",
           min=0.01, max=10),
    Option("max_resends", "int", 3, "Resends before a command counts as lost.", min=0, max=20),
    Option("heartbeat_s", "float", 0.2, "Heartbeat period (MCU stops after 0.5 s silence).",
           min=0.05, max=0.45),
    Option("queue_limit", "int", 10, "Non-critical commands queued before dropping.",
           min=1, max=1000),
    Option("reconnect_min_s", "float", 0.1, "First reconnect delay (doubles up to the cap).",
           min=0.01, max=300),
    Option("reconnect_max_s", "float", 5.0, "Reconnect backoff cap.", min=0.1, max=300),
    Option("min_firmware_protocol", "int", 1, "Lowest protocol version accepted in HELLO.",
           min=0, max=255),
    Option("handshake_timeout_s", "float", 3.0,
           "Time the board gets to answer HELLO after the port opens (resets take ~2 s).",
           min=0.1, max=60),
))
"""The one place the link's settings and their defaults (DESIGN.md's serial contract) live."""


def _default(key: str) -> Any:
    return SERIAL.by_key[key].default


@dataclass(frozen=True, slots=True)
class LinkConfig:
    """How the driver talks to the motor board (defaults: the ``serial`` section's)."""

    port: str = _default("port")
    baud: int = _default("baud")
    framing: Framing = Framing.CRC  # the serial section's default, "crc"
    ack_timeout_s: float = _default("ack_timeout_s")
    max_resends: int = _default("max_resends")
    heartbeat_s: float = _default("heartbeat_s")
    queue_limit: int = _default("queue_limit")
    reconnect_min_s: float = _default("reconnect_min_s")
    reconnect_max_s: float = _default("reconnect_max_s")
    min_firmware_protocol: int = _default("min_firmware_protocol")
    handshake_timeout_s: float = _default("handshake_timeout_s")

    @property
    def give_up_s(self) -> float:
        """A command not acknowledged this long after its first transmission is lost."""
        return (self.max_resends + 1) * self.ack_timeout_s

    @property
    def silence_s(self) -> float:
        """No intact line from the MCU for this long (crc framing): the link is dead."""
        return max(self.give_up_s, 4 * self.heartbeat_s)

    @classmethod
    def from_settings(cls, settings: SettingsView) -> LinkConfig:
        s = settings.section("serial")
        return cls(
            port=s["port"], baud=s["baud"], framing=Framing(s["framing"]),
            ack_timeout_s=s["ack_timeout_s"], max_resends=s["max_resends"],
            heartbeat_s=s["heartbeat_s"], queue_limit=s["queue_limit"],
            reconnect_min_s=s["reconnect_min_s"], reconnect_max_s=s["reconnect_max_s"],
            min_firmware_protocol=s["min_firmware_protocol"],
            handshake_timeout_s=s["handshake_timeout_s"],
        )
