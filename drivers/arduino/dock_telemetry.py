"""The motor board's docking telemetry lines into readings, and the facets that carry them.

``IRS:<front_left>,<front_right>`` the front dock receivers' beam strength (10-bit ADC
counts, 0-1023); ``DOCK:<contact mV>`` the charging contacts' voltage (0 to the divider's
30 V full scale); ``BUMP:<left 0|1>,<right 0|1>``; ``WALL:<cm>`` the right-side wall sensor;
``BIN:<pct>`` the dust bin's fill level. A line out of these ranges is bad telemetry (the link
counts it); the board reports, the docking behaviour judges (a contact voltage within limits).
"""

from __future__ import annotations

from drivers.arduino.feed import Feed
from drivers.arduino.framing import Telemetry
from hal.readings import BinLevel, Bumpers, DockContacts, DockSignal, WallDistance

IRS_MAX = 1023  # 10-bit ADC
DOCK_MAX_MV = 30_000  # the contact divider's full scale (docs/firmware.md)
WALL_MAX_CM = 500

DockReading = DockSignal | DockContacts | Bumpers | WallDistance | BinLevel
NAMES = frozenset({"IRS", "DOCK", "BUMP", "WALL", "BIN"})


class DockTelemetryError(ValueError):
    """A docking line whose fields do not fit; says which line and why."""


def _ints(line: Telemetry, count: int, lo: int, hi: int, what: str) -> list[int]:
    fields = line.fields
    if len(fields) != count:
        msg = f"{line.name}: expected {count} fields ({what}), got {len(fields)}"
        raise DockTelemetryError(msg)
    try:
        values = [int(f) for f in fields]
    except ValueError:
        msg = f"{line.name}: fields must be integers, got {','.join(fields)!r}"
        raise DockTelemetryError(msg) from None
    if not all(lo <= v <= hi for v in values):
        msg = f"{line.name}: out of range: {','.join(fields)} ({what}: {lo}-{hi})"
        raise DockTelemetryError(msg)
    return values


def interpret_dock(line: Telemetry, t_s: float) -> DockReading | None:
    """The reading a docking line carries; None for other kinds; DockTelemetryError if bad."""
    name = line.name
    if name == "IRS":
        left, right = _ints(line, 2, 0, IRS_MAX, "ADC counts")
        return DockSignal(left, right, t_s)
    if name == "DOCK":
        (mv,) = _ints(line, 1, 0, DOCK_MAX_MV, "mV")
        return DockContacts(mv, t_s)
    if name == "BUMP":
        left, right = _ints(line, 2, 0, 1, "pressed")
        return Bumpers(left == 1, right == 1, t_s)
    if name == "WALL":
        (cm,) = _ints(line, 1, 0, WALL_MAX_CM, "cm")
        return WallDistance(float(cm), t_s)
    if name == "BIN":
        (pct,) = _ints(line, 1, 0, 100, "%")
        return BinLevel(float(pct), t_s)
    return None


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
