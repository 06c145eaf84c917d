"""The Arduino link's settings: the ``serial`` config section, declared by ``LinkConfig``."""

from __future__ import annotations

from dataclasses import dataclass

from drivers.arduino.framing import Framing
from hal.options import load, section_of, setting
from hal.settings import SettingsView


@dataclass(frozen=True, slots=True)
class LinkConfig:
    """How the driver talks to the motor board (DESIGN.md's serial contract)."""

    port: str = setting("/dev/ttyACM0", "Serial device.")
    baud: int = setting(115200, "Baud rate.", min=1200, max=2000000)
    framing: Framing = setting(Framing.CRC, "crc: #SEQ and CRC-8; plain: the seed's bare lines.")
    ack_timeout_s: float = setting(0.5, "Resend a command not acknowledged in this time.",
                                   min=0.01, max=10)
    max_resends: int = setting(3, "Resends before a command counts as lost.", min=0, max=20)
    heartbeat_s: float = setting(0.2, "Heartbeat period (MCU stops after 0.5 s silence).",
                                 min=0.05, max=0.45)
    queue_limit: int = setting(10, "Non-critical commands queued before dropping.",
                               min=1, max=1000)
    reconnect_min_s: float = setting(0.1, "First reconnect delay (doubles up to the cap).",
                                     min=0.01, max=300)
    reconnect_max_s: float = setting(5.0, "Reconnect backoff cap.", min=0.1, max=300)
    min_firmware_protocol: int = setting(1, "Lowest protocol version accepted in HELLO.",
                                         min=0, max=255)
    handshake_timeout_s: float = setting(
        3.0, "Time the board gets to answer HELLO after the port opens (resets take ~2 s).",
        min=0.1, max=60)

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
        return load(cls, settings.section(SERIAL.name))


SERIAL = section_of(LinkConfig, "serial", "The Arduino motor board link.")
"""The one place the link's settings and their defaults live."""
