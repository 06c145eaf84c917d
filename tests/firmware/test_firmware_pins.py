"""What the firmware does on its pins, measured in the emulator's own time (real loop)."""

from __future__ import annotations

import asyncio

from firmware_client import PtyLink

from sim.devices.motor_board.simavr_bridge import SimavrBridge
from sim.devices.motor_board.simavr_mcu import SimavrMcu
from sim.world.plant import RecordingPlant


class TestMotors:
    async def test_motor_command_sets_duty_and_direction(
            self, mcu: SimavrMcu, link: PtyLink) -> None:
        """MOTOR drives ENA/ENB with the duties and IN1/IN2 with the directions (1 = forward)."""
        assert await link.command(1, "MOTOR:100,200,1,0") == "#1 ACK"
        pins = await mcu.wait_for(lambda p: p.pwm_l == 100 and p.pwm_r == 200)
        assert (pins.in_l, pins.in_r) == ("10", "01")
        assert pins.drive == (100, 200, True, False)

    async def test_stop_cuts_both_motors_at_once(self, mcu: SimavrMcu, link: PtyLink) -> None:
        """STOP sets both duties to 0 and lets the motors coast."""
        await link.command(1, "MOTOR:255,255,1,1")
        await mcu.wait_for(lambda p: p.pwm_l == 255 and p.pwm_r == 255)
        await link.command(2, "STOP")
        pins = await mcu.wait_for(lambda p: p.pwm_l == 0 and p.pwm_r == 0)
        assert pins.drive[:2] == (0, 0)


class TestDeadman:
    async def test_motors_stop_500_to_600_ms_after_the_last_motor_command(
            self, mcu: SimavrMcu, link: PtyLink) -> None:
        """Measured on the emulated pins: PWM on, then PWM 0 within 500-600 ms (MCU time)."""
        await link.command(1, "MOTOR:150,150,1,1")
        await mcu.wait_for(lambda p: p.pwm_l == 150)
        await mcu.wait_for(lambda p: p.pwm_l == 0 and p.pwm_r == 0, timeout_s=10.0)
        on = next(e for e in mcu.events if e.pwm_l == 150)  # the first sample with PWM on
        off = next(e for e in mcu.events if e.t_us > on.t_us and e.pwm_l == 0)
        assert 500_000 <= off.t_us - on.t_us <= 600_000

    async def test_heartbeats_keep_the_motors_running(
            self, mcu: SimavrMcu, link: PtyLink) -> None:
        """HB every 200 ms keeps the last MOTOR command alive past the deadman period."""
        await link.command(1, "MOTOR:90,90,0,0")
        on = await mcu.wait_for(lambda p: p.pwm_l == 90)
        seq = 1
        while (await mcu.time_us()) - on.t_us < 800_000:  # MCU time: the emulator may lag
            await asyncio.sleep(0.2)
            seq += 1
            assert await link.command(seq, "HB") == f"#{seq} ACK"
        last_hb_us = await mcu.time_us()
        assert (await mcu.state()).pwm_l == 90
        off = await mcu.wait_for(lambda p: p.pwm_l == 0, timeout_s=10.0)
        assert off.t_us - last_hb_us <= 600_000


class TestServo:
    async def test_servo_pulse_width_follows_the_angle(
            self, mcu: SimavrMcu, link: PtyLink) -> None:
        """0/90/180 degrees give 544/1472/2400 us pulses every 20 ms on D9."""
        assert (await mcu.state()).servo_us == 0  # limp until the first SERVO
        for seq, (angle, pulse_us) in enumerate([(0, 544), (90, 1472), (180, 2400)]):
            assert await link.command(seq, f"SERVO:{angle}") == f"#{seq} ACK"
            pins = await mcu.wait_for(lambda p, us=pulse_us: p.servo_us == us)
            assert pins.servo_period_us == 20_000
            assert pins.servo_deg == angle


class TestEncoders:
    async def test_injected_quadrature_edges_are_counted_with_sign(
            self, mcu: SimavrMcu, link: PtyLink) -> None:
        """Edges fed on D2/D4 and D3/D7 come back as cumulative signed ENCODER ticks."""
        await mcu.inject_encoder(250, -75)
        await asyncio.sleep(0.1)
        await mcu.inject_encoder(-50, 10)
        async with asyncio.timeout(10.0):
            while await link.telemetry_matching("ENCODER:") != "ENCODER:200,-65":
                pass


class TestSensors:
    async def test_ir_range_is_reported_in_cm(self, mcu: SimavrMcu, link: PtyLink) -> None:
        """The Sharp sensor's voltage on A0 is converted back to the distance, within 2 cm."""
        await mcu.set_range_cm(50)
        await asyncio.sleep(0.25)
        cm = int((await link.telemetry_matching("IR:")).split(":")[1])
        assert abs(cm - 50) <= 2

    async def test_battery_and_dock_are_reported(self, mcu: SimavrMcu, link: PtyLink) -> None:
        """BAT:<mV>,<pct>,<dock> from the divider on A1 and the contacts on A2."""
        await mcu.set_battery_v(11.1)
        await mcu.set_dock(True)
        await asyncio.sleep(0.25)
        mv, pct, dock = (await link.telemetry_matching("BAT:")).split(":")[1].split(",")
        assert abs(int(mv) - 11100) <= 30
        assert abs(int(pct) - 50) <= 1
        assert dock == "1"


class TestLeds:
    async def test_waiting_animation_alternates_the_eyes(
            self, mcu: SimavrMcu, link: PtyLink) -> None:
        """LED_WAITING lights the left eye, then the right one."""
        await link.command(1, "LED_WAITING")
        await mcu.wait_for(lambda p: p.leds & 0x3 == 0x1)
        await mcu.wait_for(lambda p: p.leds & 0x3 == 0x2)

    async def test_scan_effects_light_the_status_leds_then_return(
            self, mcu: SimavrMcu, link: PtyLink) -> None:
        """SUCCESS_SCAN lights green, FAILURE_SCAN red; both end after 1.5 s."""
        await link.command(1, "SUCCESS_SCAN")
        await mcu.wait_for(lambda p: bool(p.leds & 0x4))
        await link.command(2, "FAILURE_SCAN")
        red = await mcu.wait_for(lambda p: bool(p.leds & 0x8) and not p.leds & 0x4)
        back = await mcu.wait_for(lambda p: not p.leds & 0xC, timeout_s=10.0)
        assert 1_400_000 <= back.t_us - red.t_us <= 1_600_000


class TestBridge:
    async def test_bridge_applies_pwm_and_feeds_back_wheel_ticks(
            self, mcu: SimavrMcu, link: PtyLink) -> None:
        """The plant gets the emulated PWM and servo; its ticks come back as ENCODER."""
        plant = RecordingPlant(range_cm=80.0)
        bridge = SimavrBridge(mcu, plant, period_s=0.01)
        task = asyncio.create_task(bridge.run())
        try:
            await link.command(1, "MOTOR:80,60,1,0")
            await link.command(2, "SERVO:90")
            plant.ticks = (123, -45)
            async with asyncio.timeout(10.0):
                while await link.telemetry_matching("ENCODER:") != "ENCODER:123,-45":
                    pass
            assert (80, 60, True, False) in plant.pwm
            assert plant.servo_angles[-1] == 90
            cm = int((await link.telemetry_matching("IR:")).split(":")[1])
            assert abs(cm - 80) <= 3
        finally:
            task.cancel()
