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


# _ZEROS[n][crc]: the running value ``crc`` continued over n zero bytes.
_ZEROS = [bytes(range(256))]
for _ in range(64):
    _ZEROS.append(_ZEROS[-1].translate(bytes(_TABLE)))


def crc8_joined(crc_head: int, crc_tail: int, tail_bytes: int) -> int:
    """CRC-8 of ``head + tail`` from the CRCs of the two parts (tail at most 64 bytes).

    The CRC is linear (init 0, no final xor): crc(head + tail) = crc(head + zeros) ^
    crc(zeros + tail), and leading zero bytes leave it at 0, so a frame's CRC comes from its
    SEQ prefix's and its payload's without running over the payload again.
    """
    return _ZEROS[tail_bytes][crc_head] ^ crc_tail
