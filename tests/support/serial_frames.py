"""Test helper: frames as the motor board sends them, with the driver's CRC."""

from __future__ import annotations

from drivers.arduino.crc8 import crc8


def frame_body(body: bytes) -> bytes:
    """``BODY*CC\\n`` for any body (what the MCU side sends in crc framing)."""
    return body + f"*{crc8(body):02X}\n".encode("ascii")
