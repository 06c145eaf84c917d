"""The Arduino link's settings, read once from the ``serial`` config section."""

from __future__ import annotations

from dataclasses import dataclass

from drivers.arduino.framing import Framing
from robotd.config.settings import Settings


@dataclass(frozen=True, slots=True)
class LinkConfig:
    """How the driver talks to the motor board (defaults: DESIGN.md's serial contract)."""

    port: str = "/dev/ttyACM0"
    baud: int = 115200
    framing: Framing = Framing.CRC
    ack_timeout_s: float = 0.5
    max_resends: int = 3
    heartbeat_s: float = 0.2
    queue_limit: int = 10
    reconnect_min_s: float = 0.1
    reconnect_max_s: float = 5.0
    min_firmware_protocol: int = 1
    handshake_timeout_s: float = 3.0

    @property
    def give_up_s(self) -> float:
        """A command not acknowledged this long after its first transmission is lost."""
        return (self.max_resends + 1) * self.ack_timeout_s

    @property
    def silence_s(self) -> float:
        """No intact line from the MCU for this long (crc framing): the link is dead."""
        return max(self.give_up_s, 4 * self.heartbeat_s)

    @classmethod
    def from_settings(cls, settings: Settings) -> LinkConfig:
        s = settings.section("serial")
        return cls(
            port=s["port"], baud=s["baud"], framing=Framing(s["framing"]),
            ack_timeout_s=s["ack_timeout_s"], max_resends=s["max_resends"],
            heartbeat_s=s["heartbeat_s"], queue_limit=s["queue_limit"],
            reconnect_max_s=s["reconnect_max_s"],
            min_firmware_protocol=s["min_firmware_protocol"],
            handshake_timeout_s=s["handshake_timeout_s"],
        )
