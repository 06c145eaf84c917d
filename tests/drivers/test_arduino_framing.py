"""Lines of the Arduino link: encoding host commands, parsing what the MCU sends."""

from __future__ import annotations

import pytest
from hypothesis import given
from hypothesis import strategies as st
from serial_frames import frame_body

from drivers.arduino import framing as framing_module
from drivers.arduino.crc8 import crc8
from drivers.arduino.framing import (
    Ack,
    Framing,
    Garbled,
    Hello,
    Line,
    Nak,
    Telemetry,
    Unparsed,
    encode_command,
    parse_line,
    well_formed,
)


class TestEncodeCommand:
    def test_crc_framing_is_hash_seq_payload_star_crc(self) -> None:
        """``#SEQ PAYLOAD*CC\\n`` with CC the CRC-8 of the body in uppercase hex."""
        line = encode_command("MOTOR:10,20,1,0", 7, Framing.CRC)
        assert line == frame_body(b"#7 MOTOR:10,20,1,0")
        assert line.startswith(b"#7 MOTOR:10,20,1,0*") and line.endswith(b"\n")
        assert line[-3:-1].decode() == line[-3:-1].decode().upper()

    def test_plain_framing_is_the_bare_seed_line(self) -> None:
        """Plain framing sends the seed's line as is."""
        assert encode_command("LED_IDLE", None, Framing.PLAIN) == b"LED_IDLE\n"

    def test_a_line_longer_than_64_bytes_is_refused(self) -> None:
        """Nothing longer than the contract's 64 bytes (with ``\\n``) goes on the wire."""
        with pytest.raises(ValueError, match="64"):
            encode_command("LED_" + "X" * 60, 255, Framing.CRC)

    @pytest.mark.parametrize("payload", ["", "A*B", "A\nB", "#1 HB", "MOTOR:é"])
    def test_payloads_that_would_break_framing_are_refused(self, payload: str) -> None:
        """Empty, non-ASCII, or with ``*``, ``#`` or newlines: ValueError naming it."""
        with pytest.raises(ValueError, match="payload"):
            encode_command(payload, 1, Framing.CRC)

    def test_seq_must_be_0_to_255(self) -> None:
        """SEQ is a byte."""
        with pytest.raises(ValueError, match="SEQ"):
            encode_command("HB", 256, Framing.CRC)


class TestParseLine:
    def test_replies_in_crc_framing(self) -> None:
        """ACK, NAK with reason and HELLO with firmware and protocol, each with its SEQ."""
        assert parse_line(frame_body(b"#4 ACK")[:-1], Framing.CRC) == Ack(4)
        assert parse_line(frame_body(b"#5 NAK:RANGE")[:-1], Framing.CRC) == Nak(5, "RANGE")
        hello = parse_line(frame_body(b"#0 HELLO:robotd-mcu-1.0.0,1")[:-1], Framing.CRC)
        assert hello == Hello(0, "robotd-mcu-1.0.0", 1)

    def test_telemetry_has_no_seq(self) -> None:
        """``ENCODER:12,-3*CC`` is telemetry with its fields."""
        line = parse_line(frame_body(b"ENCODER:12,-3")[:-1], Framing.CRC)
        assert line == Telemetry("ENCODER", ("12", "-3"))

    def test_crc_mismatch_and_missing_crc_are_garbled(self) -> None:
        """A damaged line is Garbled, with why."""
        good = frame_body(b"#4 ACK")[:-1]
        damaged = good.replace(b"4", b"5", 1)
        assert isinstance(parse_line(damaged, Framing.CRC), Garbled)
        assert parse_line(b"#4 ACK", Framing.CRC) == Garbled("no CRC", b"#4 ACK")

    def test_intact_lines_of_unknown_shape_are_unparsed(self) -> None:
        """Good CRC but no known reply: Unparsed, not a crash."""
        assert isinstance(parse_line(frame_body(b"#4 WHAT")[:-1], Framing.CRC), Unparsed)
        assert isinstance(parse_line(frame_body(b"hello world")[:-1], Framing.CRC), Unparsed)

    def test_plain_framing_takes_bare_ack_and_telemetry(self) -> None:
        """The seed's ``ACK`` and ``IR:35`` without SEQ or CRC."""
        assert parse_line(b"ACK", Framing.PLAIN) == Ack(None)
        assert parse_line(b"IR:35\r", Framing.PLAIN) == Telemetry("IR", ("35",))
        crc_framed = frame_body(b"IR:35")[:-1]
        assert parse_line(crc_framed, Framing.PLAIN) == Telemetry("IR", ("35",))

    @given(st.binary(max_size=100), st.sampled_from(list(Framing)))
    def test_garbage_never_raises(self, raw: bytes, framing: Framing) -> None:
        """Any bytes at all give a Line, never an exception."""
        parse_line(raw, framing)


def parse_line_long_way(raw: bytes, framing: Framing) -> Line:
    """``parse_line`` without its shortcuts (the CRC characters' table, telemetry of a known
    name first): the rules as written before them, to hold the shortcuts to."""
    raw = raw.rstrip(b"\r")
    try:
        text = raw.decode("ascii")
    except UnicodeDecodeError:
        return Garbled("not ASCII", raw)
    if not text.isprintable():
        return Garbled("control characters", raw)
    if framing is Framing.CRC:
        body, star, check = text.rpartition("*")
        if not star or len(check) != 2:
            return Garbled("no CRC", raw)
        try:
            expected = int(check, 16)
        except ValueError:
            return Garbled("CRC is not hex", raw)
        if crc8(raw[:len(body)]) != expected:
            return Garbled("CRC mismatch", raw)
        text = body
    else:
        body, star, check = text.rpartition("*")
        if star and len(check) == 2 and check == f"{crc8(body.encode('ascii')):02X}":
            text = body
    seq: int | None = None
    if text.startswith("#"):
        space = text.find(" ")
        digits = text[1:space]
        if 0 < space <= 4 and digits.isdigit():
            seq = int(digits)
            if seq >= 256:
                return Unparsed(f"SEQ {seq} out of range", raw)
            text = text[space + 1:]
    if text == "ACK":
        return Ack(seq)
    if text.startswith("NAK:"):
        reason = text[4:]
        if reason in ("CRC", "PARSE", "RANGE"):
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
    if not colon or framing_module._TELEMETRY_NAME.fullmatch(name) is None:
        return Unparsed(f"not a reply or telemetry: {text!r}", raw)
    return Telemetry(name, tuple(rest.split(",")) if rest else ())


_WORDS = st.sampled_from(["ENCODER", "IR", "BAT", "ACK", "NAK", "HELLO", "X1", "a", ""])
_FIELDS = st.none() | st.lists(st.sampled_from(["0", "-3", "12", "", " 7", "x", "CRC"]),
                               max_size=3)
# Mostly telemetry-shaped (no SEQ), a word, and fields after a colon or none at all.
_BODIES = st.builds(
    lambda seq, word, fields: (seq + word + ("" if fields is None else ":" + ",".join(fields))
                               ).encode("ascii"),
    st.sampled_from(["", "", "", "#0 ", "#17 ", "#255 ", "#256 ", "#x ", "#"]), _WORDS, _FIELDS)


def _checks(body: bytes) -> st.SearchStrategy[bytes]:
    """The right CRC characters half the time, else damaged, lowercase or not hex at all."""
    good = b"*%02X" % crc8(body)
    return st.just(good) | st.sampled_from([
        b"*%02x" % crc8(body), b"*%02X" % (crc8(body) ^ 1), b"*+F", b"* F", b"*G0", b"**A",
        b"*", b"", b"*ABC", good + b"\r", good[:1] + b"*" + good[1:]])


class TestParseLineShortcuts:
    @given(st.lists(_BODIES.flatmap(lambda body: _checks(body).map(lambda tail: body + tail)),
                    max_size=30), st.sampled_from(list(Framing)))
    def test_every_line_parses_as_the_long_way_does(self, lines: list[bytes],
                                                    framing: Framing) -> None:
        """Replies, telemetry of names seen or new, odd SEQs, CRC characters in either case,
        damaged or not hex: each line parses to what the rules without shortcuts say."""
        for raw in lines:
            assert parse_line(raw, framing) == parse_line_long_way(raw, framing), raw

    def test_every_crc_value_is_read_in_either_case(self) -> None:
        """Each of the 256 CRC values, in uppercase (as sent) or lowercase hex digits."""
        seen = set()
        for n in range(3000):
            body = b"IR:%d" % n
            seen.add(crc8(body))
            for check in (b"%02X" % crc8(body), b"%02x" % crc8(body)):
                line = parse_line(body + b"*" + check, Framing.CRC)
                assert line == Telemetry("IR", (str(n),)), (body, check)
        assert len(seen) == 256

    @given(st.binary(max_size=70), st.sampled_from(list(Framing)))
    def test_any_bytes_parse_as_the_long_way_does(self, raw: bytes, framing: Framing) -> None:
        """Whatever the line noise, the shortcuts change no result."""
        assert parse_line(raw, framing) == parse_line_long_way(raw, framing)


class TestWellFormed:
    def test_contract_commands_with_values_in_range_are_well_formed(self) -> None:
        """MOTOR 0-255 and 0|1, SERVO 0-180 and the bare words; nothing else."""
        for good in ("MOTOR:0,255,1,0", "SERVO:180", "LED_IDLE", "STOP", "HB", "HELLO"):
            assert well_formed(good), good
        for bad in ("MOTOR:256,0,1,0", "MOTOR:1,2,2,0", "SERVO:181", "SERVO:-1", "DANCE",
                    "MOTOR:1,2,1"):
            assert not well_formed(bad), bad
