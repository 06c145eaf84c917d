"""Lines of the Arduino serial link: host commands out, MCU replies and telemetry in.

Framing ``crc``: ``BODY*CC\\n`` with CC the CRC-8 of BODY in two uppercase hex digits; a host
command's BODY is ``#SEQ PAYLOAD``. Framing ``plain``: the seed's bare lines. A line is at most
64 bytes including its ``\\n`` (DESIGN.md, "Serial link to the Arduino").
"""

from __future__ import annotations

import functools
import re
from collections.abc import Callable
from dataclasses import dataclass
from enum import StrEnum
from typing import NamedTuple

from drivers.arduino.crc8 import crc8, crc8_joined

MAX_LINE_BYTES = 64
SEQ_MODULO = 256
NAK_REASONS = ("CRC", "PARSE", "RANGE")


class Framing(StrEnum):
    CRC = "crc"
    PLAIN = "plain"


@dataclass(frozen=True, slots=True)
class Ack:
    """``#SEQ ACK`` (``seq`` None: the plain framing's bare ``ACK``)."""

    seq: int | None


@dataclass(frozen=True, slots=True)
class Nak:
    """``#SEQ NAK:<CRC|PARSE|RANGE>`` (``seq`` None in plain framing)."""

    seq: int | None
    reason: str


@dataclass(frozen=True, slots=True)
class Hello:
    """``#SEQ HELLO:<firmware>,<protocol version>``."""

    seq: int | None
    firmware: str
    protocol: int


class Telemetry(NamedTuple):
    """An unsolicited ``NAME:field,field`` line (no SEQ), fields not yet interpreted."""

    name: str
    fields: tuple[str, ...]


@dataclass(frozen=True, slots=True)
class Garbled:
    """A line damaged on the wire: CRC mismatch, missing CRC, bytes that are not ASCII."""

    reason: str
    raw: bytes


@dataclass(frozen=True, slots=True)
class Unparsed:
    """An intact line (CRC good) that is no reply or telemetry this driver knows the shape of."""

    reason: str
    raw: bytes


Line = Ack | Nak | Hello | Telemetry | Garbled | Unparsed

_FORBIDDEN = re.compile(r"[\n\r*#]")
_TELEMETRY_NAME = re.compile(r"[A-Z][A-Z0-9_]*")
_NAMES_KEPT = 64
_names_seen: set[str] = set()  # telemetry names found well-formed (ENCODER, IR, BAT, ...)
# Telemetry(name, fields) without the generated __new__'s Python frame (forty lines a second).
_new_telemetry: Callable[[tuple[str, tuple[str, ...]]], Telemetry] = functools.partial(
    tuple.__new__, Telemetry)
# "00".."FF" -> 0..255: the CRC characters of a received line.
_HEX_PAIRS = {f"{value:02X}": value for value in range(256)}


def check_payload(payload: str, framing: Framing) -> None:
    """ValueError when ``payload`` cannot be framed (as ``encode_command`` would say)."""
    if not payload or not payload.isascii() or _FORBIDDEN.search(payload) is not None:
        msg = f"bad command payload {payload!r}: printable ASCII without '*', '#' or newlines"
        raise ValueError(msg)
    # The shortest framing: "#0 " before, "*CC\n" after (crc); "\n" after (plain).
    framed = len(payload) + (1 if framing is Framing.PLAIN else 7)
    if framed > MAX_LINE_BYTES:
        msg = f"command {payload!r} is {framed} bytes framed, the link allows {MAX_LINE_BYTES}"
        raise ValueError(msg)


# The framing of payloads and SEQ prefixes seen so far: their bytes and CRC-8 (a drive sends a
# few dozen distinct payloads over and over; cleared when full).
_ENCODED: dict[str, tuple[bytes, int]] = {}
_ENCODED_KEPT = 1024
_SEQ_PREFIXES = [(b"#%d " % seq, crc8(b"#%d " % seq)) for seq in range(SEQ_MODULO)]


def encode_command(payload: str, seq: int | None, framing: Framing) -> bytes:
    """The bytes of one host command; ValueError when it would break the line rules."""
    encoded = _ENCODED.get(payload)
    if encoded is None:
        if not payload or not payload.isascii() or _FORBIDDEN.search(payload) is not None:
            msg = f"bad command payload {payload!r}: printable ASCII without '*', '#' or newlines"
            raise ValueError(msg)
        data = payload.encode("ascii")
        encoded = (data, crc8(data))
        if len(_ENCODED) >= _ENCODED_KEPT:
            _ENCODED.clear()
        _ENCODED[payload] = encoded
    data, data_crc = encoded
    if framing is Framing.PLAIN:
        framed = len(data) + 1
    else:
        if seq is None or not 0 <= seq < SEQ_MODULO:
            msg = f"SEQ must be 0-255 in crc framing, got {seq}"
            raise ValueError(msg)
        prefix, prefix_crc = _SEQ_PREFIXES[seq]
        framed = len(prefix) + len(data) + 4  # "*CC\n"
    if framed > MAX_LINE_BYTES:
        msg = f"command {payload!r} is {framed} bytes framed, the link allows {MAX_LINE_BYTES}"
        raise ValueError(msg)
    if framing is Framing.PLAIN:
        return data + b"\n"
    return b"%s%s*%02X\n" % (prefix, data, crc8_joined(prefix_crc, data_crc, len(data)))


_WORDS = frozenset({"LED_IDLE", "LED_WAITING", "LED_MOVING", "SUCCESS_SCAN", "FAILURE_SCAN",
                    "STOP", "HB", "HELLO"})
_MOTOR = re.compile(r"MOTOR:(\d{1,3}),(\d{1,3}),([01]),([01])")
_SERVO = re.compile(r"SERVO:(\d{1,3})")
_EVAC = re.compile(r"EVAC:[01]")


def well_formed(payload: str) -> bool:
    """Whether ``payload`` is a command of the contract with values in range.

    The MCU refusing such a command means the frame was damaged in a way its CRC missed.
    """
    if payload in _WORDS:
        return True
    if (motor := _MOTOR.fullmatch(payload)) is not None:
        return int(motor.group(1)) <= 255 and int(motor.group(2)) <= 255
    if (servo := _SERVO.fullmatch(payload)) is not None:
        return int(servo.group(1)) <= 180
    return _EVAC.fullmatch(payload) is not None


def parse_line(raw: bytes, framing: Framing) -> Line:
    """Interpret one received line (without its ``\n``); never raises."""
    raw = raw.rstrip(b"\r")
    try:
        text = raw.decode("ascii")
    except UnicodeDecodeError:
        return Garbled("not ASCII", raw)
    if not text.isprintable():
        return Garbled("control characters", raw)
    if framing is Framing.CRC:
        # The usual line ends in "*CC" (uppercase, as sent): its value from a table, without
        # rpartition's three strings; anything else goes the long way, with int()'s rules.
        expected = _HEX_PAIRS.get(text[-2:], -1) if text[-3:-2] == "*" else -1
        if expected >= 0:
            body = text[:-3]
        else:
            body, star, check = text.rpartition("*")
            if not star or len(check) != 2:
                return Garbled("no CRC", raw)
            try:
                expected = int(check, 16)
            except ValueError:
                return Garbled("CRC is not hex", raw)
        if crc8(raw[:len(body)]) != expected:  # ASCII: the body's bytes are raw's first ones
            return Garbled("CRC mismatch", raw)
        text = body
    else:
        # Until it hears a plain command, a dual-framing board still sends ``*CC``: drop it.
        body, star, check = text.rpartition("*")
        if star and len(check) == 2 and check == f"{crc8(body.encode('ascii')):02X}":
            text = body
    return _parse_body(text, raw)


def _parse_body(text: str, raw: bytes) -> Line:
    if text[:1] != "#":
        # Telemetry of a kind seen before, most lines: straight to it. No reply word is
        # ever in _names_seen (ACK has no colon; NAK: and HELLO: lines are replies below).
        name, colon, rest = text.partition(":")
        if colon and name in _names_seen:
            return _new_telemetry((name, tuple(rest.split(",")) if rest else ()))
    seq: int | None = None
    if text.startswith("#"):
        # ``#SEQ REST``: 1-3 digits, then one space.
        space = text.find(" ")
        digits = text[1:space]
        if 0 < space <= 4 and digits.isdigit():
            seq = int(digits)
            if seq >= SEQ_MODULO:
                return Unparsed(f"SEQ {seq} out of range", raw)
            text = text[space + 1:]
    if text == "ACK":
        return Ack(seq)
    if text.startswith("NAK:"):
        reason = text[4:]
        if reason in NAK_REASONS:
            return Nak(seq, reason)
        return Unparsed(f"unknown NAK reason {reason!r}", raw)
    if text.startswith("HELLO:"):
        firmware, comma, version = text[6:].rpartition(",")
        if not comma or not version.isdigit():
            return Unparsed("HELLO needs <firmware>,<protocol version>", raw)
        return Hello(seq, firmware, int(version))
    if seq is not None:
        return Unparsed(f"unknown reply {text!r}", raw)
    name, colon, rest = text.partition(":")
    if name not in _names_seen:
        if not colon or _TELEMETRY_NAME.fullmatch(name) is None:
            return Unparsed(f"not a reply or telemetry: {text!r}", raw)
        if len(_names_seen) < _NAMES_KEPT:
            _names_seen.add(name)
    elif not colon:
        return Unparsed(f"not a reply or telemetry: {text!r}", raw)
    return Telemetry(name, tuple(rest.split(",")) if rest else ())
