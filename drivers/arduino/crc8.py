"""CRC-8 of the serial link: polynomial 0x07, init 0x00, not reflected, no final xor."""

from __future__ import annotations

POLY = 0x07


def _table() -> tuple[int, ...]:
    table = []
    for byte in range(256):
        crc = byte
        for _ in range(8):
            crc = ((crc << 1) ^ POLY) & 0xFF if crc & 0x80 else (crc << 1) & 0xFF
        table.append(crc)
    return tuple(table)


_TABLE = _table()


def crc8(data: bytes, crc: int = 0) -> int:
    """CRC-8 of ``data`` (``crc8(b"123456789") == 0xF4``); ``crc`` continues a running value."""
    for byte in data:
        crc = _TABLE[crc ^ byte]
    return crc
