"""The MCU side of the serial protocol's frames: CRC, SEQ and payload parsing.

Written apart from the driver's code on purpose (the fake checks the driver, not itself): the
CRC is computed bit by bit as the firmware does, then tabulated once for speed.
"""

from __future__ import annotations

import re
from typing import NamedTuple

_WORDS = frozenset({"LED_IDLE", "LED_WAITING", "LED_MOVING", "SUCCESS_SCAN", "FAILURE_SCAN",
                    "STOP", "HB", "HELLO"})
_LIMITS = {"MOTOR:": ((0, 255), (0, 255), (0, 1), (0, 1)), "SERVO:": ((0, 180),),
           "EVAC:": ((0, 1),)}
# The firmware's atoi-with-checks: each field an optional minus and ASCII digits.
_FIELDS = {prefix: re.compile(",".join([r"(-?[0-9]+)"] * len(limits)))
           for prefix, limits in _LIMITS.items()}
# A line's two CRC characters -> their value; anything else is not hex.
HEX_BYTE = {b"%c%c" % (hi, lo): int(b"%c%c" % (hi, lo), 16)
            for hi in b"0123456789ABCDEFabcdef" for lo in b"0123456789ABCDEFabcdef"}


def crc8_bitwise(data: bytes) -> int:
    """CRC-8 poly 0x07 computed bit by bit, as the firmware does."""
    crc = 0
    for byte in data:
        crc ^= byte
        for _ in range(8):
            crc = ((crc << 1) ^ 0x07) & 0xFF if crc & 0x80 else (crc << 1) & 0xFF
    return crc


# The bitwise algorithm tabulated once: the fake runs thousands of lines per simulated minute.
_CRC_TABLE = tuple(crc8_bitwise(bytes([b])) for b in range(256))


def crc8_fast(data: bytes, crc: int = 0) -> int:
    """CRC-8 of ``data``; ``crc`` continues a running value (the CRC of what came before)."""
    for byte in data:
        crc = _CRC_TABLE[crc ^ byte]
    return crc


# _ZEROS[n][crc]: a running CRC continued over n zero bytes.
_ZEROS = [bytes(range(256))]
for _ in range(64):
    _ZEROS.append(_ZEROS[-1].translate(bytes(_CRC_TABLE)))


def crc8_join(crc_head: int, crc_tail: int, tail_bytes: int) -> int:
    """CRC-8 of ``head + tail`` from the parts' CRCs (the CRC is linear; tail <= 64 bytes)."""
    return _ZEROS[tail_bytes][crc_head] ^ crc_tail


class Executed(NamedTuple):
    """One command the MCU carried out (``seq`` None in plain framing)."""

    t_s: float
    seq: int | None
    payload: str


class ParseError(Exception):
    def __init__(self, reason: str) -> None:
        super().__init__(reason)
        self.reason = reason


def parse_payload(payload: str) -> tuple[str, tuple[int, ...]]:
    """(command word, integer arguments); ParseError("PARSE" | "RANGE") when bad."""
    if payload in _WORDS:
        return payload, ()
    prefix = payload[:payload.find(":") + 1]
    limits = _LIMITS.get(prefix)
    if limits is None:
        raise ParseError("PARSE")
    fields = _FIELDS[prefix].fullmatch(payload, len(prefix))
    if fields is None:
        raise ParseError("PARSE")
    values = tuple(map(int, fields.groups()))
    for value, (lo, hi) in zip(values, limits, strict=True):
        if not lo <= value <= hi:
            raise ParseError("RANGE")
    return prefix[:-1], values


def read_seq(line: bytes) -> int | None:
    """``#SEQ `` at the start: 1-3 digits, 0-255, then one space; None when unreadable."""
    space = line.find(b" ", 2, 5)
    if space < 0 or line[:1] != b"#":
        return None
    digits = line[1:space]
    if not digits.isdigit():
        return None
    seq = int(digits)
    return seq if seq <= 255 else None


_TELEMETRY_HEADS = {name: (b"%s:" % name.encode(), crc8_fast(b"%s:" % name.encode()))
                    for name in ("ENCODER", "IR", "BAT")}


def telemetry_line(name: str, fields: bytes, crc: bool) -> bytes:
    """``NAME:fields`` as a line, CRC-framed or plain; the CRC is continued from the name's
    (worked out once) over the fields."""
    head, head_crc = _TELEMETRY_HEADS[name]
    if not crc:
        return b"%s%s\n" % (head, fields)
    return b"%s%s*%02X\n" % (head, fields, crc8_fast(fields, head_crc))
