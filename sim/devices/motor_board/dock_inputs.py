"""The motor board's docking inputs and its EVAC output, on the fake MCU, fed by the world.

Each input is None (the robot has no such sensor: no line is sent, so a robot or world without
a dock gets the very bytes it got before these lines existed), a value, or a zero-argument
callable read when its line is due. Lines go out with the board's telemetry ticks (the
ENCODER period, 50 ms):

    fake.dock_signal = (fl, fr)   IRS:<fl>,<fr>   20 Hz, 10-bit strength counts
    fake.contact_mv = 16_800      DOCK:<mV>       5 Hz
    fake.bumpers = (False, True)  BUMP:<l>,<r>    on change (seen within 50 ms) and every 1 s
    fake.wall_cm = 12.0           WALL:<cm>       10 Hz
    fake.bin_pct = 40.0           BIN:<pct>       1 Hz

Values go out as given, out of range too, so a bench can check how the driver takes them.
``EVAC:<0|1>`` sets ``evac``, appends ``(t_s, on)`` to ``evac_log`` and calls each of
``evac_listeners`` with the new state (the station's suction); a reset turns it off.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TypeAlias, TypeVar

from sim.devices.motor_board.mcu_frames import crc8_fast

T = TypeVar("T")
Source: TypeAlias = T | Callable[[], T] | None

PERIODS_S = {"IRS": 0.05, "DOCK": 0.2, "BUMP": 1.0, "WALL": 0.1, "BIN": 1.0}
_SLACK = 0.25


def read_source(source: Source[T]) -> T | None:
    """A source's value now: itself, or what its callable returns."""
    return source() if callable(source) else source


class DockInputs:
    """Mixin for ``FakeMcu``: the docking sensors' sources and the EVAC output's record."""

    dock_signal: Source[tuple[int, int]]
    contact_mv: Source[int]
    bumpers: Source[tuple[bool, bool]]
    wall_cm: Source[float]
    bin_pct: Source[float]

    def __init__(self) -> None:
        """Standalone: a bench's set of sources (``FakeMcu`` calls ``_init_dock_inputs``)."""
        self._init_dock_inputs()

    def _init_dock_inputs(self) -> None:
        self.dock_signal = self.contact_mv = self.bumpers = self.wall_cm = self.bin_pct = None
        self.evac = False
        self.evac_log: list[tuple[float, bool]] = []
        self.evac_listeners: list[Callable[[bool], None]] = []
        self._dock_due: dict[str, float] = {}
        self._bumpers_sent: tuple[bool, bool] | None = None

    def record_evac(self, on: bool, t_s: float) -> None:
        """The EVAC output is now ``on`` (by command here; the simavr bridge reads the pin)."""
        if on == self.evac:
            return
        self.evac = on
        self.evac_log.append((t_s, on))
        for listener in list(self.evac_listeners):
            listener(on)

    def _dock_fields(self) -> dict[str, bytes]:
        """The fields of each docking line whose sensor the robot has, read now."""
        fields: dict[str, bytes] = {}
        if (signal := read_source(self.dock_signal)) is not None:
            fields["IRS"] = b"%d,%d" % (round(signal[0]), round(signal[1]))
        if (contact_mv := read_source(self.contact_mv)) is not None:
            fields["DOCK"] = b"%d" % round(contact_mv)
        if (bumpers := read_source(self.bumpers)) is not None:
            pressed = (bool(bumpers[0]), bool(bumpers[1]))
            fields["BUMP"] = b"%d,%d" % pressed
            if pressed != self._bumpers_sent:
                self._bumpers_sent = pressed
                self._dock_due["BUMP"] = 0.0  # a change goes out at once
        if (wall_cm := read_source(self.wall_cm)) is not None:
            fields["WALL"] = b"%d" % round(wall_cm)
        if (bin_pct := read_source(self.bin_pct)) is not None:
            fields["BIN"] = b"%d" % round(bin_pct)
        return fields

    def _dock_lines(self, now_s: float, crc: bool) -> bytes:
        """The docking lines due at ``now_s``, framed (b"" for a robot without them)."""
        if (self.dock_signal is None and self.contact_mv is None and self.bumpers is None
                and self.wall_cm is None and self.bin_pct is None):
            return b""
        out = []
        for name, value in self._dock_fields().items():
            due_s, period_s = self._dock_due.get(name, 0.0), PERIODS_S[name]
            # The ticks come late by the loop's jitter (a pty, real time): a line is due at a
            # tick within a quarter period of its time, and keeps its cadence; one that is
            # late by more (just fed, or a bumper change) starts a new cadence from now.
            if now_s < due_s - _SLACK * period_s:
                continue
            next_s = due_s + period_s
            self._dock_due[name] = next_s if next_s > now_s else now_s + period_s
            body = b"%s:%s" % (name.encode(), value)
            out.append(b"%s*%02X\n" % (body, crc8_fast(body)) if crc else body + b"\n")
        return b"".join(out)
