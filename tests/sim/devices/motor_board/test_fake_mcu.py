"""The fake motor board, driven with raw frames over the in-memory byte pipe."""

from __future__ import annotations

import asyncio
from collections.abc import Awaitable, Callable

import pytest
from serial_frames import frame_body

from drivers.arduino.crc8 import crc8
from hal.ports import StreamPair
from sim import vclock
from sim.devices.byte_pipe import BytePipe
from sim.devices.motor_board.fake_mcu import FakeMcu
from sim.devices.motor_board.mcu_frames import ParseError, parse_payload, read_seq
from sim.devices.sim_serial import SimSerialPorts
from sim.world.plant import RecordingPlant

PORT = "/dev/ttyACM0"


async def lines_until(streams: StreamPair, count: int, timeout_s: float = 1.0) -> list[bytes]:
    """Up to ``count`` lines (without ``\\n``) received within ``timeout_s``."""
    got: list[bytes] = []
    loop = asyncio.get_running_loop()
    deadline = loop.time() + timeout_s
    while len(got) < count and (remaining := deadline - loop.time()) > 0:
        try:
            got.append((await asyncio.wait_for(streams[0].readline(), remaining))[:-1])
        except TimeoutError:
            break
    return got


def replies(lines: list[bytes]) -> list[bytes]:
    return [line for line in lines if line.startswith((b"#", b"ACK", b"NAK"))]


def with_mcu(scenario: Callable[[FakeMcu, RecordingPlant, StreamPair], Awaitable[None]],
             **options: object) -> None:
    async def main() -> None:
        plant = RecordingPlant()
        mcu = FakeMcu(plant, **options)  # type: ignore[arg-type]
        ports = SimSerialPorts()
        ports.attach(PORT, mcu)
        streams = await ports(PORT, 115200)
        try:
            await scenario(mcu, plant, streams)
        finally:
            await mcu.close()

    vclock.run(main())


class TestFrameRules:
    def test_read_seq_accepts_one_to_three_digits_then_a_space(self) -> None:
        """``#0 ``..``#255 `` are SEQs; anything else is unreadable (None)."""
        assert [read_seq(b"#0 HB"), read_seq(b"#255 HB")] == [0, 255]
        for bad in (b"#256 HB", b"#1234 HB", b"# HB", b"#12HB", b"12 HB", b"#"):
            assert read_seq(bad) is None, bad

    def test_payload_ranges_give_range_and_shapes_give_parse(self) -> None:
        """MOTOR duty 0-255 and dir 0|1, SERVO 0-180: RANGE; wrong shape: PARSE."""
        assert parse_payload("MOTOR:255,0,1,0") == ("MOTOR", (255, 0, 1, 0))
        for payload, reason in (("MOTOR:256,0,1,0", "RANGE"), ("SERVO:181", "RANGE"),
                                ("MOTOR:1,2,3", "PARSE"), ("SERVO:", "PARSE"),
                                ("LED_OFF", "PARSE"), ("SERVO:1,2", "PARSE")):
            with pytest.raises(ParseError) as err:
                parse_payload(payload)
            assert err.value.reason == reason, payload


class TestFakeMcu:
    def test_good_frames_are_executed_once_and_resends_only_acknowledged(self) -> None:
        """``#3 MOTOR`` runs the wheels and is ACKed; the same frame again is ACKed without
        running it again; a new SEQ runs again."""

        async def scenario(mcu: FakeMcu, plant: RecordingPlant, streams: StreamPair) -> None:
            frame = frame_body(b"#3 MOTOR:10,20,1,0")
            streams[1].write(frame + frame + frame_body(b"#4 MOTOR:10,20,1,0"))
            got = replies(await lines_until(streams, 20, 0.2))
            assert [g.split(b"*")[0] for g in got] == [b"#3 ACK", b"#3 ACK", b"#4 ACK"]
            assert plant.pwm == [(10, 20, True, False)] * 2
            assert mcu.duplicates == 1
            assert [(e.seq, e.payload) for e in mcu.executed] == [
                (3, "MOTOR:10,20,1,0"), (4, "MOTOR:10,20,1,0")]

        with_mcu(scenario)

    def test_the_deadman_stops_the_wheels_500_ms_after_the_last_motor_or_hb(self) -> None:
        """MOTOR at t, HB at t+0.3: the wheels stop at exactly t+0.8."""

        async def scenario(mcu: FakeMcu, plant: RecordingPlant, streams: StreamPair) -> None:
            streams[1].write(frame_body(b"#1 MOTOR:100,100,1,1"))
            await asyncio.sleep(0.3)
            streams[1].write(frame_body(b"#2 HB"))
            await asyncio.sleep(1.0)
            assert mcu.last_drive_s is not None
            assert mcu.deadman_stops == [pytest.approx(mcu.last_drive_s + 0.5)]
            assert plant.last_pwm == (0, 0, True, True)

        with_mcu(scenario)

    def test_telemetry_comes_at_its_rates(self) -> None:
        """In one second: 20 ENCODER, 5 IR and 5 BAT lines, CRC-framed."""

        async def scenario(mcu: FakeMcu, plant: RecordingPlant, streams: StreamPair) -> None:
            lines = await lines_until(streams, 1000, 1.01)  # + the last line's wire time
            names = [line.split(b":")[0] for line in lines]
            assert (names.count(b"ENCODER"), names.count(b"IR"), names.count(b"BAT")) == (
                20, 5, 5)
            assert all(b"*" in line for line in lines)
            assert b"BAT:12300,80,0" in [line.split(b"*")[0] for line in lines]

        with_mcu(scenario)

    def test_the_board_is_silent_while_its_bootloader_has_the_port(self) -> None:
        """After reset() with boot_s 0.3 s nothing comes for 0.3 s; then BOOT, and telemetry
        on its own cadence (ENCODER every 50 ms from 0.3 s, IR and BAT every 200 ms)."""

        async def scenario(mcu: FakeMcu, plant: RecordingPlant, streams: StreamPair) -> None:
            loop = asyncio.get_running_loop()
            start_s = loop.time()
            mcu.reset()
            heard: list[tuple[float, bytes]] = []
            while (remaining := start_s + 0.51 - loop.time()) > 0:
                try:
                    line = await asyncio.wait_for(streams[0].readline(), remaining)
                except TimeoutError:
                    break
                heard.append((loop.time() - start_s, line.split(b"*")[0]))
            assert heard[0][0] >= 0.3 and heard[0][1] == b"BOOT:fake-mcu-1.0,1"
            names = [line.split(b":")[0] for _, line in heard[1:]]
            assert (names.count(b"ENCODER"), names.count(b"IR"), names.count(b"BAT")) == (
                5, 1, 1)

        with_mcu(scenario, boot_s=0.3)

    def test_reset_forgets_the_last_seq_stops_motors_and_announces_boot(self) -> None:
        """After reset() the same SEQ is executed again, encoders count from zero, and a
        ``BOOT:<fw>,<protocol>`` line goes out."""

        async def scenario(mcu: FakeMcu, plant: RecordingPlant, streams: StreamPair) -> None:
            frame = frame_body(b"#9 SERVO:20")
            streams[1].write(frame)
            await asyncio.sleep(0.01)
            plant.ticks = (40, 50)
            mcu.reset()
            streams[1].write(frame)
            lines = await lines_until(streams, 100, 0.2)
            assert frame_body(b"BOOT:fake-mcu-1.0,1")[:-1] in lines
            assert plant.servo_angles == [20, 20]
            encoder = [line for line in lines if line.startswith(b"ENCODER")][-1]
            assert encoder.split(b"*")[0] == b"ENCODER:0,0"

        with_mcu(scenario)

    def test_unplug_breaks_the_port_and_opening_fails_until_replugged(self) -> None:
        """unplug(): the host's read fails with OSError and the port cannot be opened;
        replug(): it opens again."""

        async def main() -> None:
            mcu = FakeMcu(RecordingPlant())
            ports = SimSerialPorts()
            ports.attach(PORT, mcu)
            reader, _ = await ports(PORT, 115200)
            mcu.unplug()
            with pytest.raises(OSError):
                await reader.read(100)
            with pytest.raises(FileNotFoundError):
                await ports(PORT, 115200)
            mcu.replug()
            reader, _ = await ports(PORT, 115200)
            assert await asyncio.wait_for(reader.readline(), 1.0)
            await mcu.close()

        vclock.run(main())

    def test_corruption_is_repeatable_for_a_seed(self) -> None:
        """The same seed corrupts the same bytes: two runs see identical lines."""

        def run_once() -> list[bytes]:
            seen: list[bytes] = []

            async def scenario(mcu: FakeMcu, plant: RecordingPlant, st: StreamPair) -> None:
                mcu.corrupt(10)
                seen.extend(await lines_until(st, 1000, 1.0))

            with_mcu(scenario, seed=5)
            return seen

        first = run_once()
        assert first == run_once()
        assert any(b"*" not in line or not line.isascii() for line in first) or len(
            set(first)) > 1

    def test_delay_holds_replies_back(self) -> None:
        """delay(0.25): the ACK arrives 0.25 s (plus wire time) after the frame."""

        async def scenario(mcu: FakeMcu, plant: RecordingPlant, streams: StreamPair) -> None:
            mcu.delay(0.25)
            loop = asyncio.get_running_loop()
            sent_s = loop.time()
            streams[1].write(frame_body(b"#1 HB"))
            while not (await streams[0].readline()).startswith(b"#1 ACK"):
                pass
            assert 0.25 <= loop.time() - sent_s < 0.26

        with_mcu(scenario)

    def test_plain_lines_are_answered_plainly_and_switch_telemetry_to_plain(self) -> None:
        """``LED_IDLE`` gets ``ACK``; ``NOPE`` gets ``NAK:PARSE``; telemetry drops its CRC."""

        async def scenario(mcu: FakeMcu, plant: RecordingPlant, streams: StreamPair) -> None:
            streams[1].write(b"LED_IDLE\nNOPE\n")
            lines = await lines_until(streams, 100, 0.3)
            assert replies(lines) == [b"ACK", b"NAK:PARSE"]
            assert mcu.leds == ["LED_IDLE"]
            assert any(line.startswith(b"ENCODER:") and b"*" not in line for line in lines)

        with_mcu(scenario)

    def test_a_reader_task_and_a_direct_pipe_hear_the_same_lines(self) -> None:
        """Split lines, CRs and an overlong line get the same replies either way of serving."""
        writes = [frame_body(b"#1 MOTOR:10,20,1,0")[:7], frame_body(b"#1 MOTOR:10,20,1,0")[7:],
                  b"\r" + frame_body(b"#2 HB").replace(b"*", b"\r*"),
                  b"#3 " + b"X" * 80 + b"\n", frame_body(b"#4 SERVO:200"), b"LED_IDLE\r\n"]

        async def serve(direct: bool) -> tuple[list[bytes], list[tuple[int | None, str]]]:
            mcu = FakeMcu(RecordingPlant(), encoder_period_s=100.0, ir_period_s=100.0,
                          battery_period_s=100.0)
            pipe = BytePipe(baud=115200)
            if direct:
                mcu.connect_pipe(pipe)
            else:
                mcu.connect(pipe.b, hangup=pipe.break_)
            for data in writes:
                pipe.a[1].write(data)
                await asyncio.sleep(0.01)
            got = await lines_until(pipe.a, 5, 0.5)
            await mcu.close()
            return got, [(e.seq, e.payload) for e in mcu.executed]

        async def main() -> None:
            by_task, by_pipe = await serve(direct=False), await serve(direct=True)
            assert by_task == by_pipe
            assert by_pipe[0][:3] == [b"#1 ACK*" + b"%02X" % crc8(b"#1 ACK"),
                                      b"#2 ACK*" + b"%02X" % crc8(b"#2 ACK"),
                                      b"#3 NAK:PARSE*" + b"%02X" % crc8(b"#3 NAK:PARSE")]

        vclock.run(main())
