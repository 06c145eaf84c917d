"""Interpretation of the MCU's unsolicited telemetry lines into readings.

``ENCODER:<left>,<right>`` cumulative signed ticks; ``IR:<distance cm>``;
``BAT:<mV>,<percent>,<on dock 0|1>``; ``BOOT:<firmware>,<protocol>`` (the MCU has just started,
optional: firmware that does not send it is detected by nothing worse than a slower resync).
The docking lines (``IRS``, ``DOCK``, ``BUMP``, ``WALL``, ``BIN``) are in ``dock_telemetry``.
"""

from __future__ import annotations

from dataclasses import dataclass

from drivers.arduino.dock_telemetry import DockReading, DockTelemetryError, interpret_dock
from drivers.arduino.framing import Telemetry
from hal.readings import BatteryReading, EncoderReading, RangeReading


@dataclass(frozen=True, slots=True)
class Boot:
    firmware: str
    protocol: int
    t_s: float


Reading = EncoderReading | RangeReading | BatteryReading | Boot | DockReading


class TelemetryError(ValueError):
    """A telemetry line of a known kind whose fields do not fit; says which and why."""


def _ints(line: Telemetry, count: int) -> list[int]:
    if len(line.fields) != count:
        msg = f"{line.name}: expected {count} fields, got {len(line.fields)}"
        raise TelemetryError(msg)
    try:
        return [int(f) for f in line.fields]
    except ValueError:
        msg = f"{line.name}: fields must be integers, got {','.join(line.fields)!r}"
        raise TelemetryError(msg) from None


def interpret(line: Telemetry, t_s: float) -> Reading | None:
    """The reading a telemetry line carries; None for kinds this driver does not know."""
    if line.name == "ENCODER":
        fields = line.fields
        if len(fields) == 2:  # twenty a second: the usual line without _ints' list
            try:
                return EncoderReading(int(fields[0]), int(fields[1]), t_s)
            except ValueError:
                pass
        left, right = _ints(line, 2)  # says what is wrong
        return EncoderReading(left, right, t_s)
    if line.name == "IR":
        (distance_cm,) = _ints(line, 1)
        if distance_cm < 0:
            msg = f"IR: distance must be >= 0 cm, got {distance_cm}"
            raise TelemetryError(msg)
        return RangeReading(float(distance_cm), t_s)
    if line.name == "BAT":
        millivolts, percent, dock = _ints(line, 3)
        if millivolts < 0 or not 0 <= percent <= 100 or dock not in (0, 1):
            msg = f"BAT: out of range: {','.join(line.fields)} (mV >= 0, 0-100 %, dock 0|1)"
            raise TelemetryError(msg)
        on_dock = dock == 1
        return BatteryReading(millivolts / 1000.0, float(percent), on_dock and percent < 100,
                              on_dock, t_s)
    if line.name == "BOOT":
        if len(line.fields) != 2 or not line.fields[1].isdigit():
            msg = f"BOOT: expected <firmware>,<protocol>, got {','.join(line.fields)!r}"
            raise TelemetryError(msg)
        return Boot(line.fields[0], int(line.fields[1]), t_s)
    try:
        return interpret_dock(line, t_s)
    except DockTelemetryError as exc:
        raise TelemetryError(str(exc)) from None
