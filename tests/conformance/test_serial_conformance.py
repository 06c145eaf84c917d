"""The serial link contract (DESIGN.md), checked against every MCU endpoint with the real driver."""

from __future__ import annotations

import asyncio
import itertools
from collections.abc import Callable
from functools import partial

import pytest
from endpoints import ENDPOINTS, McuEndpoint, Scenario, run_scenario
from serial_frames import frame_body

from drivers.arduino import Framing, Outcome
from hal.devices import LinkDown
from hal.ports import StreamPair
from hal.readings import MotorCommand

Runner = Callable[[Scenario], None]


@pytest.fixture(params=sorted(ENDPOINTS))
def run(request: pytest.FixtureRequest) -> Runner:
    return partial(run_scenario, ENDPOINTS[request.param])


def needs(endpoint: McuEndpoint, fault: str) -> None:
    if fault not in endpoint.faults:
        pytest.skip(f"{endpoint.name} cannot inject {fault}")


def last_pwm(endpoint: McuEndpoint) -> tuple[int, int, bool, bool] | None:
    log = endpoint.pwm_log()
    return log[-1][1:] if log else None


async def settle(seconds: float = 0.2) -> None:
    await asyncio.sleep(seconds)


async def read_reply(streams: StreamPair, timeout_s: float = 2.0) -> bytes | None:
    """The next line that is a reply (starts with ``#`` or is a bare ACK/NAK), or None."""
    reader = streams[0]
    loop = asyncio.get_running_loop()
    deadline = loop.time() + timeout_s
    while (remaining := deadline - loop.time()) > 0:
        try:
            line = await asyncio.wait_for(reader.readline(), remaining)
        except TimeoutError:
            return None
        body = line.rstrip(b"\r\n")
        if body.startswith((b"#", b"ACK", b"NAK")):
            return body
    return None


class TestHandshakeAndCommands:
    def test_hello_reports_firmware_and_protocol(self, run: Runner) -> None:
        """The driver connects, and HELLO tells the firmware name and protocol >= 1."""

        async def scenario(ep: McuEndpoint) -> None:
            link = ep.link()
            await link.start()
            try:
                assert link.connected
                assert link.firmware
                assert link.protocol is not None and link.protocol >= 1
            finally:
                await link.close()

        run(scenario)

    def test_motor_command_reaches_the_wheels_and_stop_stops_them(self, run: Runner) -> None:
        """drive() sets each wheel's PWM and direction; stop() sets both to zero."""

        async def scenario(ep: McuEndpoint) -> None:
            link = ep.link()
            await link.start()
            try:
                await link.drive(MotorCommand(120, 80, True, False))
                await settle()
                assert last_pwm(ep) == (120, 80, True, False)
                await link.stop()
                assert last_pwm(ep)[:2] == (0, 0)  # type: ignore[index]
            finally:
                await link.close()

        run(scenario)

    def test_servo_angle_reaches_the_servo(self, run: Runner) -> None:
        """set_angle() returns once the board acknowledged it; the servo got the angle."""

        async def scenario(ep: McuEndpoint) -> None:
            link = ep.link()
            await link.start()
            try:
                await link.set_angle(90)
                await link.set_angle(0)
                assert ep.servo_log()[-2:] == [90, 0]
            finally:
                await link.close()

        run(scenario)

    def test_bad_commands_are_refused_with_their_reason(self, run: Runner) -> None:
        """Out-of-range values get NAK:RANGE, malformed or unknown commands NAK:PARSE."""

        async def scenario(ep: McuEndpoint) -> None:
            link = ep.link()
            await link.start()
            try:
                cases = {"SERVO:181": "NAK:RANGE", "MOTOR:1,2,0,2": "NAK:RANGE",
                         "MOTOR:1,2": "NAK:PARSE", "DANCE": "NAK:PARSE", "SERVO:x": "NAK:PARSE"}
                for payload, reason in cases.items():
                    delivery = await link.command(payload)
                    assert (delivery.outcome, delivery.detail) == (Outcome.NAK, reason), payload
                assert (await link.command("LED_MOVING")).ok
            finally:
                await link.close()

        run(scenario)

    def test_telemetry_reports_encoders_range_and_battery(self, run: Runner) -> None:
        """ENCODER, IR and BAT telemetry become readings of the link's sensor facets."""

        async def scenario(ep: McuEndpoint) -> None:
            ep.set_sensors(ticks=(1234, -56), range_cm=42.0, battery=(11.9, 64.0, True))
            link = ep.link()
            await link.start()
            try:
                await settle(0.5)
                ticks = await asyncio.wait_for(link.encoders.next_reading(), 1.0)
                assert (ticks.left_ticks, ticks.right_ticks) == (1234, -56)
                distance = await asyncio.wait_for(link.front_range.next_reading(), 1.0)
                assert distance.distance_cm == pytest.approx(42.0, abs=1.0)
                battery = await asyncio.wait_for(link.battery.next_reading(), 1.0)
                assert battery.voltage_v == pytest.approx(11.9, abs=0.05)
                assert battery.on_dock_contacts
            finally:
                await link.close()

        run(scenario)


class TestPlainFraming:
    def test_the_driver_in_plain_framing_drives_the_board(self, run: Runner) -> None:
        """serial.framing = plain: no HELLO, bare lines and ACKs; wheels and servo move and
        telemetry still arrives."""

        async def scenario(ep: McuEndpoint) -> None:
            link = ep.link(framing=Framing.PLAIN)
            await link.start()
            try:
                assert (await link.command("SERVO:21")).ok
                await link.drive(MotorCommand(40, 41, True, False))
                await settle()
                assert last_pwm(ep) == (40, 41, True, False)
                assert ep.servo_log()[-1] == 21
                ticks = await asyncio.wait_for(link.encoders.next_reading(), 1.0)
                assert ticks is not None
                assert link.status()["bad_telemetry"] == 0
            finally:
                await link.close()

        run(scenario)


class TestRawFrames:
    """Byte-level rules, sent without the driver."""

    def test_frames_are_answered_by_seq_and_checked_by_crc(self, run: Runner) -> None:
        """Good frame: ACK; bad CRC with readable SEQ: NAK:CRC; resend of the last SEQ: ACK
        without a second execution; unreadable SEQ: no answer; overlong: NAK:PARSE."""

        async def scenario(ep: McuEndpoint) -> None:
            streams = await ep.opener(ep.port, 115200)
            writer = streams[1]
            try:
                good = frame_body(b"#7 SERVO:33")
                writer.write(good)
                assert await read_reply(streams) == frame_body(b"#7 ACK")[:-1]
                writer.write(good)  # a resend: acknowledged, not executed again
                assert (await read_reply(streams) or b"").startswith(b"#7 ACK*")
                assert ep.servo_log().count(33) == 1
                writer.write(b"#8 SERVO:34*00\n")
                assert (await read_reply(streams) or b"").startswith(b"#8 NAK:CRC*")
                writer.write(b"#x SERVO:35*00\n" + frame_body(b"#9 SERVO:36"))
                assert (await read_reply(streams) or b"").startswith(b"#9 ACK*")
                writer.write(b"#10 LED_IDLE" + b"!" * 80 + b"*00\n" + frame_body(b"#11 HB"))
                assert (await read_reply(streams) or b"").startswith(b"#10 NAK:PARSE*")
                assert (await read_reply(streams) or b"").startswith(b"#11 ACK*")
                assert 35 not in ep.servo_log() and 36 in ep.servo_log()
            finally:
                writer.close()

        run(scenario)

    def test_plain_lines_get_a_bare_ack(self, run: Runner) -> None:
        """The seed's plain lines work without SEQ or CRC: ``SERVO:45`` -> ``ACK``."""

        async def scenario(ep: McuEndpoint) -> None:
            streams = await ep.opener(ep.port, 115200)
            try:
                streams[1].write(b"SERVO:45\n")
                assert await read_reply(streams) == b"ACK"
                assert ep.servo_log()[-1] == 45
            finally:
                streams[1].close()

        run(scenario)


class TestFaults:
    def test_with_2pct_corruption_at_100_per_s_no_command_is_lost_or_run_twice(
            self, run: Runner) -> None:
        """2 % of bytes corrupted both ways, MOTOR commands offered at 100/s: every one is
        acknowledged, and the plant executed each exactly once, in order."""

        async def scenario(ep: McuEndpoint) -> None:
            needs(ep, "corrupt")
            count = 600 if ep.virtual_time else 150
            link = ep.link()
            await link.start()
            try:
                ep.corrupt(2.0)
                loop = asyncio.get_running_loop()
                start_s = loop.time()
                sent: list[tuple[int | None, str]] = []
                for i in range(count):
                    if (wait_s := start_s + i * 0.01 - loop.time()) > 0:
                        await asyncio.sleep(wait_s)
                    payload = f"MOTOR:{1 + i % 250},{255 - i % 250},{i % 2},1"
                    delivery = await link.command(payload)
                    assert delivery.ok, delivery
                    sent.append((delivery.seq, payload))
                ep.corrupt(0.0)
                stats = link.link_stats()
                assert stats.lost == 0 and stats.resent > 0 and stats.crc_errors > 0
                wheels = [p[1:] for p in ep.pwm_log() if p[1:3] != (0, 0)]
                assert wheels == [(1 + i % 250, 255 - i % 250, i % 2 == 1, True)
                                  for i in range(count)]
                executed = ep.executed()
                if executed is not None:
                    assert [e for e in executed if e[1].startswith("MOTOR")] == sent
                    seqs = [seq for seq, _ in executed]
                    assert all(a != b for a, b in itertools.pairwise(seqs))
            finally:
                await link.close()

        run(scenario)

    def test_unplug_stops_the_motors_by_deadman_and_the_link_comes_back(
            self, run: Runner) -> None:
        """Unplugged while driving: the wheels stop within 500 ms of the last command, the
        driver reports the link down and refuses drive(); replugged, commands flow again."""

        async def scenario(ep: McuEndpoint) -> None:
            needs(ep, "unplug")
            link = ep.link()
            changes: list[bool] = []
            link.on_link_change(changes.append)
            await link.start()
            try:
                await link.drive(MotorCommand(100, 100))
                await settle(0.3)
                assert last_pwm(ep) == (100, 100, True, True)
                loop = asyncio.get_running_loop()
                unplugged_s = loop.time()
                ep.unplug()
                await settle(1.0)
                stops = [p for p in ep.pwm_log() if p[0] >= unplugged_s and p[1:3] == (0, 0)]
                assert stops, "the deadman did not stop the wheels"
                assert stops[0][0] - unplugged_s <= 0.5 + ep.timing_slack_s
                assert not link.connected
                with pytest.raises(LinkDown):
                    await link.drive(MotorCommand(50, 50))
                ep.replug()
                assert await link.wait_connected(10.0)
                await link.drive(MotorCommand(60, 61))
                await settle(0.3)
                assert last_pwm(ep) == (60, 61, True, True)
                assert changes == [True, False, True]
                assert link.link_stats().reconnects == 1
            finally:
                await link.close()

        run(scenario)

    def test_after_a_board_reset_commands_execute_again(self, run: Runner) -> None:
        """A reset clears the board's SEQ memory and stops the wheels; the next commands are
        executed (not taken for duplicates) without the driver restarting."""

        async def scenario(ep: McuEndpoint) -> None:
            needs(ep, "reset")
            link = ep.link()
            await link.start()
            try:
                await link.drive(MotorCommand(100, 100))
                await settle(0.3)
                ep.reset()
                await settle(0.3)
                assert last_pwm(ep)[:2] == (0, 0)  # type: ignore[index]
                for value in (70, 71, 72):
                    await link.drive(MotorCommand(value, value))
                    await settle(0.1)
                    assert last_pwm(ep) == (value, value, True, True)
                await link.set_angle(12)
                assert ep.servo_log()[-1] == 12
            finally:
                await link.close()

        run(scenario)

    def test_slow_replies_are_waited_for_and_not_executed_twice(self, run: Runner) -> None:
        """Replies 200 ms late: every command is acknowledged and executed once."""

        async def scenario(ep: McuEndpoint) -> None:
            needs(ep, "delay")
            link = ep.link()
            await link.start()
            try:
                ep.delay(0.2)
                for angle in range(10, 20):
                    delivery = await link.command(f"SERVO:{angle}")
                    assert delivery.ok
                ep.delay(0.0)
                assert ep.servo_log()[-10:] == list(range(10, 20))
                assert link.link_stats().lost == 0
            finally:
                await link.close()

        run(scenario)
