"""ArduinoLink against the FakeMcu over the in-memory byte pipe, in virtual time."""

from __future__ import annotations

import asyncio
import itertools
from collections.abc import Awaitable, Callable
from dataclasses import replace

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from drivers.arduino import ArduinoLink, CommandNotDelivered, Framing, LinkConfig, Outcome
from drivers.arduino.framing import frame_body
from hal.devices import Battery, DeviceUnavailable, Encoders, LinkDown, Motors, RangeSensor
from hal.ports import StreamPair
from hal.readings import LedMode, MotorCommand
from hal.sim.fake_mcu import FakeMcu
from hal.sim.plant import RecordingPlant
from hal.sim.sim_serial import SimSerialPorts
from robotd import vclock

PORT = "/dev/ttyACM0"


class Bench:
    """A fake board on a sim port, the bytes the host wrote, and a link to it."""

    def __init__(self, **config: object) -> None:
        self.plant = RecordingPlant()
        self.mcu = FakeMcu(self.plant, seed=11)
        self.ports = SimSerialPorts()
        self.ports.attach(PORT, self.mcu)
        self.wire: list[bytes] = []
        self.attempts: list[float] = []
        self.link = ArduinoLink(self.tap, replace(LinkConfig(port=PORT), **config))  # type: ignore[arg-type]

    async def tap(self, port: str, baud: int) -> StreamPair:
        self.attempts.append(asyncio.get_running_loop().time())
        reader, writer = await self.ports(port, baud)
        original = writer.write

        def write(data: bytes | bytearray | memoryview) -> None:
            self.wire.append(bytes(data))
            original(data)

        writer.write = write  # type: ignore[method-assign]
        return reader, writer

    def mcu_writes(self, data: bytes) -> None:
        """Bytes from the board's side of the line, as if the firmware sent them."""
        assert self.ports.pipe is not None
        self.ports.pipe.b[1].write(data)

    def seqs_on_wire(self) -> list[int]:
        return [int(frame[1:frame.index(b" ")]) for frame in self.wire if frame.startswith(b"#")]


def on_bench(scenario: Callable[[Bench], Awaitable[None]], **config: object) -> None:
    async def main() -> None:
        bench = Bench(**config)
        await bench.link.start()
        try:
            await scenario(bench)
        finally:
            await bench.link.close()
            await bench.mcu.close()

    vclock.run(main())


class TestStartAndHandshake:
    def test_the_link_is_motors_and_its_facets_are_sensors(self) -> None:
        """One object fills the Motors slot; encoders, range and battery are its facets."""

        async def scenario(bench: Bench) -> None:
            assert isinstance(bench.link, Motors)
            assert isinstance(bench.link.encoders, Encoders)
            assert isinstance(bench.link.front_range, RangeSensor)
            assert isinstance(bench.link.battery, Battery)
            assert bench.link.firmware == "fake-mcu-1.0" and bench.link.protocol == 1

        on_bench(scenario)

    def test_start_without_the_port_raises_device_unavailable_naming_it(self) -> None:
        """No board at the port: DeviceUnavailable that says which port and why."""

        async def main() -> None:
            link = ArduinoLink(SimSerialPorts(), LinkConfig(port="/dev/ttyUSB9"))
            with pytest.raises(DeviceUnavailable, match=r"/dev/ttyUSB9.*cannot open"):
                await link.start()

        vclock.run(main())

    def test_firmware_with_an_old_protocol_is_refused(self) -> None:
        """HELLO protocol below serial.min_firmware_protocol: DeviceUnavailable, link down."""

        async def main() -> None:
            mcu = FakeMcu(RecordingPlant(), protocol=1)
            ports = SimSerialPorts()
            ports.attach(PORT, mcu)
            link = ArduinoLink(ports, LinkConfig(port=PORT, min_firmware_protocol=2))
            with pytest.raises(DeviceUnavailable, match="min_firmware_protocol"):
                await link.start()
            assert not link.connected
            await mcu.close()

        vclock.run(main())

    def test_a_restarted_driver_whose_hello_seq_looks_like_a_resend_still_connects(
            self) -> None:
        """The board executed ``#0 HELLO`` last; a new driver's ``#0 HELLO`` is taken as a
        resend, and the handshake still completes."""

        async def main() -> None:
            mcu = FakeMcu(RecordingPlant())
            ports = SimSerialPorts()
            ports.attach(PORT, mcu)
            _, writer = await ports(PORT, 115200)
            writer.write(frame_body(b"#0 HELLO"))
            await asyncio.sleep(0.1)
            link = ArduinoLink(ports, LinkConfig(port=PORT))
            await link.start()
            assert link.connected and mcu.duplicates == 1
            await link.close()
            await mcu.close()

        vclock.run(main())


    def test_a_board_that_resets_when_the_port_opens_is_waited_for(self) -> None:
        """Like an Uno (DTR reset, 1.5 s bootloader that swallows the first HELLOs): the
        handshake keeps asking and completes once the sketch runs."""

        async def main() -> None:
            mcu = FakeMcu(RecordingPlant(), reset_on_open=True, boot_s=1.5)
            ports = SimSerialPorts()
            ports.attach(PORT, mcu)
            link = ArduinoLink(ports, LinkConfig(port=PORT))
            loop = asyncio.get_running_loop()
            start_s = loop.time()
            await link.start()
            assert 1.5 <= loop.time() - start_s < 2.5
            assert link.firmware == "fake-mcu-1.0" and mcu.boots == 1
            await link.close()
            await mcu.close()

        vclock.run(main())


class TestCommands:
    def test_stop_goes_out_at_once_while_another_command_waits_for_its_ack(self) -> None:
        """Replies 300 ms late, a SERVO in flight: STOP is sent and executed without waiting
        for it, the SERVO ends SUPERSEDED, and its SEQ is never sent again after STOP's."""

        async def scenario(bench: Bench) -> None:
            loop = asyncio.get_running_loop()
            bench.mcu.delay(0.3)
            await asyncio.sleep(0.3)
            servo = bench.link.submit("SERVO:40")
            await asyncio.sleep(0.01)
            asked_s = loop.time()
            await bench.link.stop()
            stop_exec = next(e for e in bench.mcu.executed if e.payload == "STOP")
            assert stop_exec.t_s - asked_s < 0.05
            assert (await servo).outcome is Outcome.SUPERSEDED
            await asyncio.sleep(2.0)
            seqs = bench.seqs_on_wire()
            servo_seq = (await servo).seq
            stop_seq = seqs[max(i for i, s in enumerate(seqs) if s == servo_seq) + 1]
            assert servo_seq not in seqs[seqs.index(stop_seq):]

        on_bench(scenario, heartbeat_s=30.0)  # no HB in flight when the SERVO is sent

    def test_newer_motor_commands_replace_older_queued_ones(self) -> None:
        """While one MOTOR waits for a slow ACK, five more arrive: the board gets the first
        and the newest only; none is refused."""

        async def scenario(bench: Bench) -> None:
            bench.mcu.delay(0.2)
            await asyncio.sleep(0.3)
            await bench.link.drive(MotorCommand(10, 10))
            await asyncio.sleep(0.01)  # in flight now
            for value in range(11, 16):
                await bench.link.drive(MotorCommand(value, value))
            await asyncio.sleep(1.0)
            motors = [e.payload for e in bench.mcu.executed if e.payload.startswith("MOTOR")]
            assert motors == ["MOTOR:10,10,1,1", "MOTOR:15,15,1,1"]
            assert bench.link.status()["superseded"] == 4

        on_bench(scenario, heartbeat_s=30.0)

    def test_cosmetic_commands_past_the_queue_limit_are_dropped_and_counted(self) -> None:
        """15 LED effects while replies are slow: 10 wait, the oldest beyond are dropped."""

        async def scenario(bench: Bench) -> None:
            bench.mcu.delay(0.2)
            await asyncio.sleep(0.3)
            bench.link.submit("SERVO:1")  # in flight
            await asyncio.sleep(0.01)
            for i in range(15):
                await bench.link.show(list(LedMode)[i % 5])
            assert bench.link.link_stats().dropped == 5
            await asyncio.sleep(5.0)
            assert len(bench.mcu.leds) == 10

        on_bench(scenario, heartbeat_s=30.0)

    def test_bad_input_is_refused_and_an_undelivered_servo_move_raises(self) -> None:
        """Angles outside 0-180 and unframeable payloads are ValueErrors before sending; the
        board's NAK ends a command NAK; a servo move cut off by unplugging raises
        CommandNotDelivered (a LinkDown)."""

        async def scenario(bench: Bench) -> None:
            with pytest.raises(ValueError, match="0-180"):
                await bench.link.set_angle(200)
            with pytest.raises(ValueError, match="payload"):
                bench.link.submit("MOTOR:1*2")
            delivery = await bench.link.command("SERVO:999")
            assert (delivery.outcome, delivery.detail) == (Outcome.NAK, "NAK:RANGE")
            bench.mcu.delay(0.3)
            move = asyncio.ensure_future(bench.link.set_angle(10))
            await asyncio.sleep(0.1)
            bench.mcu.unplug()
            with pytest.raises(CommandNotDelivered, match="link_down"):
                await move

        on_bench(scenario)

    def test_a_valid_command_refused_by_the_board_is_sent_again(self) -> None:
        """A NAK:PARSE for a well-formed command means damage the CRC missed: the driver
        resends it (same SEQ) instead of giving up, and it runs once."""

        async def scenario(bench: Bench) -> None:
            bench.mcu.delay(0.2)
            await asyncio.sleep(0.3)
            servo = bench.link.submit("SERVO:66")
            await asyncio.sleep(0.01)
            seq = bench.seqs_on_wire()[-1]
            bench.mcu_writes(frame_body(f"#{seq} NAK:PARSE".encode()))
            delivery = await servo
            assert delivery.ok and delivery.resends >= 1
            assert bench.plant.servo_angles == [66]

        on_bench(scenario, heartbeat_s=30.0)

    def test_heartbeats_keep_the_wheels_turning_while_nothing_else_is_sent(self) -> None:
        """A MOTOR then 3 s of silence from the robot: HBs feed the deadman, no stop."""

        async def scenario(bench: Bench) -> None:
            await bench.link.drive(MotorCommand(90, 90))
            await asyncio.sleep(3.0)
            assert bench.plant.last_pwm == (90, 90, True, True)
            assert not bench.mcu.deadman_stops
            assert sum(e.payload == "HB" for e in bench.mcu.executed) >= 10

        on_bench(scenario)


class TestFaultsAndRecovery:
    def test_without_the_driver_the_board_stops_the_wheels_500_ms_after_the_last_command(
            self) -> None:
        """Unplugged mid-drive: the deadman stop lands exactly 0.5 s after the last MOTOR/HB
        the board received; the link is down meanwhile and drive() raises LinkDown."""

        async def scenario(bench: Bench) -> None:
            await bench.link.drive(MotorCommand(100, 100))
            await asyncio.sleep(0.35)
            bench.mcu.unplug()
            await asyncio.sleep(1.0)
            assert bench.mcu.last_drive_s is not None
            assert bench.mcu.deadman_stops == [pytest.approx(bench.mcu.last_drive_s + 0.5)]
            assert bench.plant.last_pwm == (0, 0, True, True)
            with pytest.raises(LinkDown, match="link is down"):
                await bench.link.drive(MotorCommand(1, 1))
            await bench.link.stop()  # never raises
            await bench.link.show(LedMode.IDLE)  # skipped, cosmetic

        on_bench(scenario)

    def test_reconnect_backs_off_exponentially_up_to_the_cap(self) -> None:
        """While the port is gone the driver retries after 0.1, 0.2, 0.4 ... s, capped at
        serial.reconnect_max_s, and connects when it returns."""

        async def scenario(bench: Bench) -> None:
            loop = asyncio.get_running_loop()
            gone_s = loop.time()
            bench.mcu.unplug()
            await asyncio.sleep(5.0)
            bench.mcu.replug()
            assert await bench.link.wait_connected(2.0)
            tries = [t - gone_s for t in bench.attempts if t >= gone_s]
            gaps = [round(b - a, 3) for a, b in itertools.pairwise(tries)]
            assert tries[0] == pytest.approx(0.1, abs=0.01)
            assert gaps[:5] == [0.2, 0.4, 0.8, 1.0, 1.0]
            assert bench.link.link_stats().reconnects == 1

        on_bench(scenario, reconnect_max_s=1.0)

    def test_a_silent_board_is_taken_for_gone_and_reconnected(self) -> None:
        """Every byte garbled for 3 s: no intact line for 2 s means the link is down; the
        driver reopens the port and is up again once the line is clean."""

        async def scenario(bench: Bench) -> None:
            changes: list[bool] = []
            bench.link.on_link_change(changes.append)
            bench.mcu.corrupt(100)
            await asyncio.sleep(3.0)
            assert changes[:1] == [False]
            bench.mcu.corrupt(0)
            assert await bench.link.wait_connected(10.0)
            assert changes == [False, True]
            assert (await bench.link.command("LED_IDLE")).ok

        on_bench(scenario)

    def test_waiting_readers_are_told_when_the_link_goes_down(self) -> None:
        """next_reading() waiters get LinkDown instead of hanging."""

        async def scenario(bench: Bench) -> None:
            waiter = asyncio.ensure_future(bench.link.front_range.next_reading())
            await asyncio.sleep(0)
            bench.mcu.unplug()
            with pytest.raises(LinkDown):
                await waiter

        on_bench(scenario)

    def test_garbage_overlong_and_unknown_lines_are_counted_and_ignored(self) -> None:
        """Non-ASCII bytes, a 200-byte line, a bad CRC, unknown and malformed telemetry: the
        link counts them, stays up and keeps acknowledging commands."""

        async def scenario(bench: Bench) -> None:
            bench.mcu_writes(b"\xff\xfe\x00garbage\n" + b"A" * 200 + b"\n"
                             + b"IR:10*00\n" + frame_body(b"TEMP:25")
                             + frame_body(b"ENCODER:x,y") + frame_body(b"#3 BOGUS"))
            await asyncio.sleep(0.2)
            status = bench.link.status()
            assert status["crc_errors"] >= 2 and status["overlong"] == 1
            assert status["unknown_telemetry"] == 1 and status["bad_telemetry"] == 1
            assert status["unparsed"] == 1
            assert bench.link.connected
            assert (await bench.link.command("LED_IDLE")).ok

        on_bench(scenario)

    def test_a_board_reset_keeps_encoder_counts_continuous(self) -> None:
        """The board restarts (BOOT) and counts from zero; the driver's ticks continue."""

        async def scenario(bench: Bench) -> None:
            bench.plant.ticks = (500, 400)
            await asyncio.sleep(0.2)
            bench.mcu.reset()
            bench.plant.ticks = (530, 410)
            await asyncio.sleep(0.2)
            reading = bench.link.encoders.latest()
            assert reading is not None
            assert (reading.left_ticks, reading.right_ticks) == (530, 410)
            assert bench.link.status()["mcu_resets"] == 1
            assert (await bench.link.command("HB")).ok

        on_bench(scenario)


class TestPlainFraming:
    def test_plain_framing_talks_to_an_old_sketch_without_seq_or_heartbeat(self) -> None:
        """framing = plain: bare lines, bare ACKs, no HELLO and no HB on the wire."""

        async def scenario(bench: Bench) -> None:
            await bench.link.drive(MotorCommand(30, 40, False, True))
            assert (await bench.link.command("LED_WAITING")).ok
            await asyncio.sleep(0.2)
            assert bench.plant.last_pwm == (30, 40, False, True)
            assert all(not frame.startswith((b"#", b"HB", b"HELLO")) for frame in bench.wire)
            assert bench.link.link_stats().acked == 2

        on_bench(scenario, framing=Framing.PLAIN)


PAYLOADS = st.one_of(
    st.builds("MOTOR:{},{},{},{}".format, st.integers(0, 255), st.integers(0, 255),
              st.integers(0, 1), st.integers(0, 1)),
    st.builds("SERVO:{}".format, st.integers(0, 180)),
    st.sampled_from([m.value for m in LedMode]),
)


class TestReliabilityProperty:
    @settings(max_examples=15, deadline=None)
    @given(st.lists(PAYLOADS, min_size=1, max_size=60), st.integers(0, 2**16),
           st.sampled_from([0.0, 1.0, 3.0]))
    def test_any_command_sequence_arrives_complete_once_and_in_order(
            self, payloads: list[str], seed: int, corrupt_pct: float) -> None:
        """Seed property 18: whatever commands are sent one after another, over a line that
        corrupts up to 3 % of bytes, each is acknowledged and the board executes each exactly
        once, in the order sent."""

        async def main() -> None:
            plant = RecordingPlant()
            mcu = FakeMcu(plant, seed=seed)
            ports = SimSerialPorts(seed=seed)
            ports.attach(PORT, mcu)
            link = ArduinoLink(ports, LinkConfig(port=PORT))
            await link.start()
            mcu.corrupt(corrupt_pct)
            sent = []
            for payload in payloads:
                delivery = await link.command(payload)
                assert delivery.ok, delivery
                sent.append((delivery.seq, payload))
            executed = [(e.seq, e.payload) for e in mcu.executed if e.payload != "HB"]
            assert executed[1:] == sent  # after the handshake's HELLO
            await link.close()
            await mcu.close()

        vclock.run(main())
