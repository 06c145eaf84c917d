"""Telemetry lines into readings."""

from __future__ import annotations

import pytest

from drivers.arduino.framing import Telemetry
from drivers.arduino.telemetry import Boot, TelemetryError, interpret
from hal.readings import BatteryReading, EncoderReading, RangeReading


class TestInterpret:
    def test_known_kinds_become_readings(self) -> None:
        """ENCODER, IR, BAT and BOOT give their readings stamped with the given time."""
        assert interpret(Telemetry("ENCODER", ("5", "-7")), 1.0) == EncoderReading(5, -7, 1.0)
        assert interpret(Telemetry("IR", ("35",)), 1.0) == RangeReading(35.0, 1.0)
        assert interpret(Telemetry("BAT", ("12150", "80", "1")), 1.0) == BatteryReading(
            12.15, 80.0, True, True, 1.0)
        assert interpret(Telemetry("BOOT", ("fw", "1")), 2.0) == Boot("fw", 1, 2.0)

    def test_a_full_battery_on_the_dock_is_not_charging(self) -> None:
        """At 100 % on the contacts the charger is done."""
        reading = interpret(Telemetry("BAT", ("12600", "100", "1")), 0.0)
        assert isinstance(reading, BatteryReading) and not reading.charging

    def test_unknown_kinds_give_none(self) -> None:
        """A kind this driver does not know is no error: None (counted by the link)."""
        assert interpret(Telemetry("TEMP", ("25",)), 0.0) is None

    @pytest.mark.parametrize("line", [
        Telemetry("ENCODER", ("1",)), Telemetry("ENCODER", ("a", "b")),
        Telemetry("IR", ("-1",)), Telemetry("BAT", ("12000", "101", "0")),
        Telemetry("BAT", ("12000", "50", "2")), Telemetry("BOOT", ("fw",)),
    ])
    def test_bad_fields_raise_telemetry_error_naming_the_kind(self, line: Telemetry) -> None:
        """Wrong field count, non-integers or out-of-range values: TelemetryError."""
        with pytest.raises(TelemetryError, match=line.name):
            interpret(line, 0.0)
