"""ArduinoLink against the FakeMcu over the in-memory byte pipe, in virtual time."""

from __future__ import annotations

import asyncio

import pytest
from arduino_bench import PORT, Bench, on_bench
from serial_frames import frame_body

from drivers.arduino import ArduinoLink, CommandNotDelivered, LinkConfig, Outcome
from hal.devices import Battery, DeviceUnavailable, Encoders, Motors, RangeSensor
from hal.readings import LedMode, MotorCommand
from sim import vclock
from sim.devices.motor_board.fake_mcu import FakeMcu
from sim.devices.sim_serial import SimSerialPorts
from sim.world.plant import RecordingPlant


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
