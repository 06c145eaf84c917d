"""The pure parts of the simavr wrapper: pin samples and sensor conversions (no emulator)."""

from __future__ import annotations

import pytest

from sim.devices.motor_board.simavr_mcu import (
    ADC_REF_MV,
    IR_ADC_OFFSET,
    IR_K,
    SERVO_MAX_US,
    SERVO_MIN_US,
    McuPins,
    ir_millivolts,
)

EV = ("EV t_us=1500 pwm_l=120 pwm_r=80 in_l=10 in_r=01 servo_us=1472 servo_period_us=20000 "
      "leds=3")


class TestMcuPins:
    def test_parses_a_harness_event_line(self) -> None:
        """Every field of an EV line lands in the sample."""
        pins = McuPins.parse(EV)
        assert (pins.t_us, pins.pwm_l, pins.pwm_r, pins.in_l, pins.in_r) == (
            1500, 120, 80, "10", "01")
        assert (pins.servo_us, pins.servo_period_us, pins.leds) == (1472, 20000, 3)

    def test_drive_follows_the_h_bridge_inputs(self) -> None:
        """IN1/IN2 = 10 is forward, 01 reverse; equal inputs drive nothing whatever the duty."""
        assert McuPins.parse(EV).drive == (120, 80, True, False)
        coasting = McuPins.parse(EV.replace("in_l=10", "in_l=00").replace("in_r=01", "in_r=11"))
        assert coasting.drive[:2] == (0, 0)

    def test_servo_angle_round_trips_through_the_firmware_pulse(self) -> None:
        """The firmware's integer pulse for each angle 0-180 reads back as that angle."""
        for angle in range(181):
            pulse_us = SERVO_MIN_US + angle * (SERVO_MAX_US - SERVO_MIN_US) // 180
            pins = McuPins.parse(EV.replace("servo_us=1472", f"servo_us={pulse_us}"))
            assert pins.servo_deg == angle, pulse_us

    def test_no_pulse_means_no_angle(self) -> None:
        """A limp servo (no pulse yet) has no angle."""
        assert McuPins.parse(EV.replace("servo_us=1472", "servo_us=0")).servo_deg is None


class TestIrMillivolts:
    @pytest.mark.parametrize("range_cm", [20, 35, 50, 80, 120, 150])
    def test_firmware_conversion_reads_the_range_back(self, range_cm: int) -> None:
        """The voltage for a range, read by a 10-bit ADC and the firmware's fit, is +-2 cm."""
        adc = ir_millivolts(range_cm) * 1023 // ADC_REF_MV
        assert abs(IR_K // (adc - IR_ADC_OFFSET) - range_cm) <= 2

    def test_out_of_span_ranges_are_clamped(self) -> None:
        """Closer than 20 cm reads as 20 cm; farther than 150 cm as 150 cm."""
        assert ir_millivolts(5) == ir_millivolts(20)
        assert ir_millivolts(400) == ir_millivolts(150)
