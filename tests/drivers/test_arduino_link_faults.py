"""The Arduino link under faults (unplug, corruption, resets), in plain framing, and its
reliability property."""

from __future__ import annotations

import asyncio
import itertools

import pytest
from arduino_bench import PORT, Bench, on_bench
from hypothesis import given, settings
from hypothesis import strategies as st
from serial_frames import frame_body

from drivers.arduino import ArduinoLink, Framing, LinkConfig
from hal.devices import LinkDown
from hal.readings import LedMode, MotorCommand
from sim import vclock
from sim.devices.motor_board.fake_mcu import FakeMcu
from sim.devices.sim_serial import SimSerialPorts
from sim.world.plant import RecordingPlant


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
