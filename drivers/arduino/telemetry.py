"""Interpretation of the MCU's unsolicited telemetry lines into readings.

``ENCODER:<left>,<right>`` cumulative signed ticks; ``IR:<distance cm>``;
``BAT:<mV>,<percent>,<on dock 0|1>``; ``BOOT:<firmware>,<protocol>`` (the MCU has just started,
optional: firmware that does not send it is detected by nothing worse than a slower resync).
Docking (issue 15): ``IRS:<front_left>,<front_right>`` the front dock receivers' beam strength
(10-bit ADC counts, 0-1023); ``DOCK:<contact mV>`` the charging contacts' voltage (0 to the
divider's 30 V full scale); ``BUMP:<left 0|1>,<right 0|1>``; ``WALL:<cm>`` the right-side wall
sensor; ``BIN:<pct>`` the dust bin's fill level. A line out of these ranges is bad telemetry
(the link counts it); the board reports, the docking behaviour judges (a contact voltage
within limits). ``Feed`` is a sensor facet of the link; ``DockFacets`` holds the docking ones.
"""

from __future__ import annotations

from collections.abc import Callable, Coroutine
from dataclasses import dataclass
from typing import Any, Generic, TypeVar

from drivers.arduino.framing import Telemetry
from hal.latest import LatestValue
from hal.readings import (
    BatteryReading,
    BinLevel,
    Bumpers,
    DockContacts,
    DockSignal,
    EncoderReading,
    RangeReading,
    WallDistance,
)

T = TypeVar("T")
IRS_MAX = 1023  # 10-bit ADC
DOCK_MAX_MV = 30_000  # the contact divider's full scale (docs/firmware.md)
WALL_MAX_CM = 500


@dataclass(frozen=True, slots=True)
class Boot:
    firmware: str
    protocol: int
    t_s: float


DockReading = DockSignal | DockContacts | Bumpers | WallDistance | BinLevel
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
    return interpret_dock(line, t_s)


def _bounded(line: Telemetry, count: int, lo: int, hi: int, what: str) -> list[int]:
    fields = line.fields
    if len(fields) != count:
        msg = f"{line.name}: expected {count} fields ({what}), got {len(fields)}"
        raise TelemetryError(msg)
    try:
        values = [int(f) for f in fields]
    except ValueError:
        msg = f"{line.name}: fields must be integers, got {','.join(fields)!r}"
        raise TelemetryError(msg) from None
    if not all(lo <= v <= hi for v in values):
        msg = f"{line.name}: out of range: {','.join(fields)} ({what}: {lo}-{hi})"
        raise TelemetryError(msg)
    return values


def interpret_dock(line: Telemetry, t_s: float) -> DockReading | None:
    """The reading a docking line carries; None for other kinds; TelemetryError if bad."""
    name = line.name
    if name == "IRS":
        left, right = _bounded(line, 2, 0, IRS_MAX, "ADC counts")
        return DockSignal(left, right, t_s)
    if name == "DOCK":
        (mv,) = _bounded(line, 1, 0, DOCK_MAX_MV, "mV")
        return DockContacts(mv, t_s)
    if name == "BUMP":
        left, right = _bounded(line, 2, 0, 1, "pressed")
        return Bumpers(left == 1, right == 1, t_s)
    if name == "WALL":
        (cm,) = _bounded(line, 1, 0, WALL_MAX_CM, "cm")
        return WallDistance(float(cm), t_s)
    if name == "BIN":
        (pct,) = _bounded(line, 1, 0, 100, "%")
        return BinLevel(float(pct), t_s)
    return None


class Feed(Generic[T]):
    """A sensor facet of the link: newest reading and the next one (fails on link down)."""

    def __init__(self) -> None:
        self._latest: LatestValue[T] = LatestValue()
        self.publish: Callable[[T], None] = self._latest.publish  # no frame of our own

    def latest(self) -> T | None:
        return self._latest.latest()

    def listen(self, callback: Callable[[T], object]) -> Callable[[], None]:
        """Call ``callback(reading)`` as each reading arrives; returns the unsubscriber."""
        return self._latest.listen(callback)

    def next_reading(self) -> Coroutine[Any, Any, T]:
        """Awaitable: the next reading (LinkDown when the link goes down first)."""
        return self._latest.next()  # its coroutine itself: one frame less per reading

    def fail(self, exc: BaseException) -> None:
        self._latest.fail(exc)


class DockFacets:
    """The link's docking sensor facets: ``signal``, ``contacts``, ``bumpers``, ``wall``, ``bin``.

    Each is a ``Feed`` (``latest()``, ``next_reading()``, ``listen()``); a board that does not
    send a kind leaves its feed empty (``latest()`` None).
    """

    def __init__(self) -> None:
        self.signal: Feed[DockSignal] = Feed()
        self.contacts: Feed[DockContacts] = Feed()
        self.bumpers: Feed[Bumpers] = Feed()
        self.wall: Feed[WallDistance] = Feed()
        self.bin: Feed[BinLevel] = Feed()

    def publish(self, reading: DockReading) -> None:
        if isinstance(reading, DockSignal):
            self.signal.publish(reading)
        elif isinstance(reading, DockContacts):
            self.contacts.publish(reading)
        elif isinstance(reading, Bumpers):
            self.bumpers.publish(reading)
        elif isinstance(reading, WallDistance):
            self.wall.publish(reading)
        else:
            self.bin.publish(reading)

    def fail(self, exc: BaseException) -> None:
        for feed in (self.signal, self.contacts, self.bumpers, self.wall, self.bin):
            feed.fail(exc)

    def status(self) -> dict[str, object]:
        """``{"dock": newest values}`` for ``robotctl sensors``; empty until the board sent one
        (a robot without docking sensors shows nothing new)."""
        signal, contacts = self.signal.latest(), self.contacts.latest()
        bumpers, wall, bin_ = self.bumpers.latest(), self.wall.latest(), self.bin.latest()
        if signal is None and contacts is None and bumpers is None and wall is None \
                and bin_ is None:
            return {}
        return {"dock": {
            "irs": None if signal is None else [signal.front_left, signal.front_right],
            "contact_mv": None if contacts is None else contacts.mv,
            "bumpers": None if bumpers is None else [bumpers.left, bumpers.right],
            "wall_cm": None if wall is None else wall.distance_cm,
            "bin_pct": None if bin_ is None else bin_.percent,
        }}
