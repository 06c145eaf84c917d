"""Lines of the Arduino link: encoding host commands, parsing what the MCU sends."""

from __future__ import annotations

import pytest
from hypothesis import given
from hypothesis import strategies as st
from serial_frames import frame_body

from drivers.arduino.framing import (
    Ack,
    Framing,
    Garbled,
    Hello,
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


class TestWellFormed:
    def test_contract_commands_with_values_in_range_are_well_formed(self) -> None:
        """MOTOR 0-255 and 0|1, SERVO 0-180 and the bare words; nothing else."""
        for good in ("MOTOR:0,255,1,0", "SERVO:180", "LED_IDLE", "STOP", "HB", "HELLO"):
            assert well_formed(good), good
        for bad in ("MOTOR:256,0,1,0", "MOTOR:1,2,2,0", "SERVO:181", "SERVO:-1", "DANCE",
                    "MOTOR:1,2,1"):
            assert not well_formed(bad), bad
