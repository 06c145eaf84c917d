"""The firmware's side of the serial link, spoken over the emulated UART (real loop, wall time)."""

from __future__ import annotations

import asyncio
import random

from firmware_client import PtyLink, crc8, frame, unframe

from sim.devices.motor_board.simavr_mcu import SimavrMcu


class TestFramingHelper:
    def test_crc_matches_the_contract_check_value(self) -> None:
        """The test's own CRC-8 gives F4 for "123456789", as DESIGN.md requires."""
        assert crc8(b"123456789") == 0xF4


class TestCrcFraming:
    async def test_hello_reports_firmware_and_protocol_version(self, link: PtyLink) -> None:
        """HELLO is answered `#SEQ HELLO:<firmware>,1` under a valid CRC."""
        body = await link.command(7, "HELLO")
        assert body.startswith("#7 HELLO:robotd-mcu-")
        assert body.endswith(",1")

    async def test_good_commands_are_acknowledged_with_their_seq(self, link: PtyLink) -> None:
        """Every payload of the contract gets `#SEQ ACK`."""
        payloads = ["MOTOR:0,0,1,1", "SERVO:90", "LED_IDLE", "LED_WAITING", "LED_MOVING",
                    "SUCCESS_SCAN", "FAILURE_SCAN", "STOP", "HB"]
        for seq, payload in enumerate(payloads, start=250):
            assert await link.command(seq % 256, payload) == f"#{seq % 256} ACK"

    async def test_bad_crc_is_nakked(self, link: PtyLink) -> None:
        """A frame whose CRC does not match its body gets NAK:CRC and is not executed."""
        good = frame("#3 MOTOR:200,200,1,1")
        bad = good.replace(b"200,200", b"200,201")
        link.send(bad)
        assert unframe(await link.reply()) == "#3 NAK:CRC"
        link.send(b"#4 STOP\n")
        assert unframe(await link.reply()) == "#4 NAK:CRC"

    async def test_unreadable_seq_is_dropped(self, link: PtyLink) -> None:
        """A frame whose SEQ cannot be read gets no answer at all."""
        link.send(frame("#x HB"))
        link.send(frame("#300 HB"))
        link.send(frame("#12HB"))
        assert await link.no_reply()

    async def test_parse_and_range_errors_are_told_apart(self, link: PtyLink) -> None:
        """Unknown or malformed payloads get NAK:PARSE; numbers out of range NAK:RANGE."""
        assert await link.command(1, "JUMP") == "#1 NAK:PARSE"
        assert await link.command(2, "MOTOR:1,2,3") == "#2 NAK:PARSE"
        assert await link.command(3, "MOTOR:1,2,1,x") == "#3 NAK:PARSE"
        assert await link.command(4, "MOTOR:256,0,1,1") == "#4 NAK:RANGE"
        assert await link.command(5, "MOTOR:0,0,2,1") == "#5 NAK:RANGE"
        assert await link.command(6, "SERVO:181") == "#6 NAK:RANGE"
        assert await link.command(7, "SERVO:-1") == "#7 NAK:RANGE"
        assert await link.command(8, "SERVO:1234567") == "#8 NAK:RANGE"

    async def test_control_bytes_in_a_payload_are_a_parse_error(self, link: PtyLink) -> None:
        """A well-framed payload with a NUL or control byte is refused, not half-read."""
        assert await link.command(15, "HB\x00junk") == "#15 NAK:PARSE"
        assert await link.command(16, "STOP\x07") == "#16 NAK:PARSE"

    async def test_overlong_line_with_readable_seq_is_nakked(self, link: PtyLink) -> None:
        """A line over 64 bytes gets NAK:PARSE when its SEQ is readable; the link goes on."""
        body = "#9 MOTOR:" + "1" * 80
        link.send(frame(body))
        assert unframe(await link.reply()) == "#9 NAK:PARSE"
        assert await link.command(10, "HB") == "#10 ACK"

    async def test_overlong_line_without_seq_is_dropped(self, link: PtyLink) -> None:
        """A line over 64 bytes with no readable SEQ is dropped silently."""
        link.send(b"X" * 200 + b"\n")
        assert await link.no_reply()
        assert await link.command(11, "HB") == "#11 ACK"

    async def test_the_64_byte_limit_counts_the_newline(self, link: PtyLink) -> None:
        """A 64-byte line is checked normally (here: NAK:CRC); 65 bytes is overlong (PARSE)."""
        fits = b"#13 " + b"X" * 56 + b"*00\n"
        assert len(fits) == 64
        link.send(fits)
        assert unframe(await link.reply()) == "#13 NAK:CRC"
        link.send(b"#14 " + b"X" * 57 + b"*00\n")
        assert unframe(await link.reply()) == "#14 NAK:PARSE"

    async def test_duplicate_seq_is_acked_without_executing_again(
            self, mcu: SimavrMcu, link: PtyLink) -> None:
        """A resend of the last executed frame is acknowledged but does not run the motors."""
        assert await link.command(20, "MOTOR:120,120,1,1") == "#20 ACK"
        await mcu.wait_for(lambda p: p.pwm_l == 120)
        await mcu.wait_for(lambda p: p.pwm_l == 0, timeout_s=2.0)  # deadman
        assert await link.command(20, "MOTOR:120,120,1,1") == "#20 ACK"
        await asyncio.sleep(0.1)
        assert (await mcu.state()).pwm_l == 0

    async def test_same_seq_with_another_payload_is_executed(
            self, mcu: SimavrMcu, link: PtyLink) -> None:
        """Only an identical frame is a duplicate: a restarted host reusing SEQ is obeyed."""
        assert await link.command(0, "SERVO:0") == "#0 ACK"
        assert await link.command(0, "SERVO:180") == "#0 ACK"
        pins = await mcu.wait_for(lambda p: p.servo_us == 2400)
        assert pins.servo_deg == 180

    async def test_telemetry_lines_carry_valid_crcs(self, link: PtyLink) -> None:
        """Encoder, IR and battery telemetry arrive without SEQ, each under a valid CRC."""
        for prefix in ("ENCODER:", "IR:", "BAT:"):
            assert (await link.telemetry_matching(prefix)).startswith(prefix)
        assert all(unframe(line) is not None for line in link.telemetry)


class TestPlainFraming:
    async def test_plain_lines_get_bare_acks(self, link: PtyLink) -> None:
        """The seed's lines, without SEQ or CRC, are obeyed and answered with a bare ACK."""
        link.send(b"LED_MOVING\n")
        assert await link.reply() == "ACK"
        link.send(b"HELLO\n")
        assert (await link.reply()).startswith("HELLO:robotd-mcu-")
        link.send(b"SERVO:200\n")
        assert await link.reply() == "NAK:RANGE"

    async def test_telemetry_follows_the_framing_of_the_last_good_command(
            self, link: PtyLink) -> None:
        """After a plain command telemetry is plain; after a CRC frame it is framed again."""
        link.send(b"HB\n")
        assert await link.reply() == "ACK"
        await asyncio.sleep(0.1)
        plain = await link.telemetry_matching("ENCODER:")
        assert "*" not in plain
        assert await link.command(1, "HB") == "#1 ACK"
        await asyncio.sleep(0.1)
        start = len(link.telemetry)
        await link.telemetry_matching("ENCODER:")
        assert all(unframe(line) is not None for line in link.telemetry[start:])


class TestRobustness:
    async def test_random_garbage_never_wedges_the_link(
            self, mcu: SimavrMcu, link: PtyLink) -> None:
        """300 lines of random bytes (some frame-like) leave the board answering and idle."""
        rng = random.Random(6)
        alphabet = b"#0123456789 *:,ABCDEFHLMNOPRSTVW_\x00\xff\r"
        for _ in range(300):
            size = rng.randint(0, 90)
            link.send(bytes(rng.choice(alphabet) for _ in range(size)) + b"\n")
        link.send(frame("#42 HELLO"))
        async with asyncio.timeout(10.0):
            while True:  # the garbage is answered first (bare NAKs, NAK:CRC ...)
                line = await link.reply()
                if line.startswith("#"):
                    assert unframe(line) is not None, line
                if line.startswith("#42 "):
                    break
        assert unframe(line) == "#42 HELLO:robotd-mcu-1.1.0,1"
        pins = await mcu.state()
        assert pins.drive[:2] == (0, 0)
