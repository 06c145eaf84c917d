"""The simulated floor plan: walls, rooms, painted lines, beacons, dock, people and zones.

Loaded from a scenario's ``[world]`` table. Everything is in metres on one flat floor, x to
the east, y to the north. Sensors models (camera, BLE, LiDAR, IR) read from here.
"""

from __future__ import annotations

import difflib
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from hal.occupancy_map import MapFileError, read_map_yaml
from sim.world.dock import CONTACT_MV, DEFAULT_BEAMS, FAULT_MV, SLOT_S, Beam, Dock
from sim.world.geometry import (
    FloatArray,
    NearestSegments,
    SegmentSet,
    distance_to_segments,
    polyline_segments,
    segments_array,
)
from sim.world.occupancy_walls import known_bounds, map_walls
from sim.world.walkers import LEG_RADIUS_M, Walk, leg_centres

# Colours a painted line can have, as a camera sees them under white light (BGR).
LINE_COLOURS_BGR: dict[str, tuple[int, int, int]] = {
    "black": (30, 30, 30),
    "red": (40, 40, 200),
    "green": (60, 160, 50),
    "blue": (170, 80, 30),
    "yellow": (40, 200, 220),
    "white": (245, 245, 245),
}


class WorldError(ValueError):
    """A scenario's world table is wrong; the message names the key."""


@dataclass(frozen=True, slots=True)
class Room:
    name: str
    x_min_m: float
    y_min_m: float
    x_max_m: float
    y_max_m: float

    def contains(self, x_m: float, y_m: float) -> bool:
        return self.x_min_m <= x_m <= self.x_max_m and self.y_min_m <= y_m <= self.y_max_m


@dataclass(frozen=True, slots=True)
class PaintedLine:
    """A painted line on the floor: a polyline with a colour and a width."""

    name: str
    points: tuple[tuple[float, float], ...]
    colour: str
    width_m: float
    closed: bool = False

    @property
    def bgr(self) -> tuple[int, int, int]:
        return LINE_COLOURS_BGR[self.colour]

    def segments(self) -> FloatArray:
        return polyline_segments(list(self.points), self.closed)


@dataclass(frozen=True, slots=True)
class SimBeacon:
    """An iBeacon on a wall: identity, position and its advertised power at 1 m."""

    mac: str
    uuid: str
    major: int
    minor: int
    x_m: float
    y_m: float
    tx_power_dbm: int = -59
    room: str = ""
    interval_s: float = 0.1


@dataclass
class Person:
    """A person on the floor: a body circle (``radius_m``) for bumpers and the front sensor;
    the LiDAR, at shin height, sees two legs (``legs``) or the circle. ``walk``: a path
    walked over time (``sim.world.walkers``), applied by ``update(t_s)``."""

    name: str
    x_m: float
    y_m: float
    present: bool = True
    radius_m: float = 0.2
    legs: bool = True
    heading_rad: float = 0.0
    qr_payload: str | None = None
    """The text of the QR code this person holds up to a forward camera (a customer's order)."""
    walk: Walk | None = None

    def update(self, t_s: float) -> None:
        """Move to where the walk puts the person at ``t_s`` (no walk: stay)."""
        if self.walk is not None:
            self.x_m, self.y_m, self.heading_rad, _ = self.walk.at(t_s)

    def leg_circles(self, t_s: float) -> list[tuple[float, float, float]]:
        """(x, y, radius) of what a LiDAR beam at shin height meets."""
        if not self.legs:
            return [(self.x_m, self.y_m, self.radius_m)]
        walked = 0.0
        if self.walk is not None:
            walked = max(0.0, t_s - self.walk.start_s) * self.walk.speed_mps
            if not self.walk.at(t_s)[3]:
                walked = 0.0  # standing: legs together
        return [(x, y, LEG_RADIUS_M)
                for x, y in leg_centres(self.x_m, self.y_m, self.heading_rad, walked)]


@dataclass
class World:
    width_m: float
    height_m: float
    walls: FloatArray
    rooms: list[Room] = field(default_factory=list)
    lines: list[PaintedLine] = field(default_factory=list)
    beacons: list[SimBeacon] = field(default_factory=list)
    dock: Dock | None = None
    people: list[Person] = field(default_factory=list)
    zones: dict[str, Room] = field(default_factory=dict)
    floor_bgr: tuple[int, int, int] = (200, 205, 210)
    robots_see_each_other: bool = True
    x_min_m: float = 0.0  # the floor's lower-left corner (a map's origin can be negative)
    y_min_m: float = 0.0
    map_source: str = ""  # the map_server YAML the walls came from, if any
    unmapped_walls: int = 0  # the last this many walls are furniture the robots' maps lack
    _segments_cache: tuple[tuple[PaintedLine, ...], FloatArray, NearestSegments] | None = field(
        default=None, init=False, repr=False, compare=False)

    def mapped_walls(self) -> FloatArray:
        """The walls a robot's map has (``map.file = "walls"``): all but unmapped boxes."""
        return self.walls[:self.walls.shape[0] - self.unmapped_walls]

    def room_at(self, x_m: float, y_m: float) -> str | None:
        for room in self.rooms:
            if room.contains(x_m, y_m):
                return room.name
        return None

    def clearance_m(self, x_m: float, y_m: float) -> float:
        """Distance from a point to the nearest wall."""
        return distance_to_segments(self.walls, x_m, y_m)

    def line_segments(self) -> FloatArray:
        """All painted lines' segments (read-only; rebuilt when ``lines`` changes)."""
        key = tuple(self.lines)
        cached = self._segments_cache
        if cached is None or cached[0] != key:  # the same line objects compare by identity
            parts = [line.segments() for line in self.lines]
            segments = np.concatenate(parts) if parts else segments_array([])
            segments.flags.writeable = False
            cached = self._segments_cache = (key, segments, NearestSegments(SegmentSet(segments)))
        return cached[1]

    def cross_track_m(self, x_m: float, y_m: float) -> float:
        """Distance from a point to the nearest painted line's centre."""
        self.line_segments()
        assert self._segments_cache is not None
        # as distance_to_segments, to the bit, from the few segments near the point
        return self._segments_cache[2].min_distance(x_m, y_m)

    def beacon(self, mac: str) -> SimBeacon:
        for b in self.beacons:
            if b.mac == mac:
                return b
        msg = f"no beacon {mac}"
        raise KeyError(msg)

    @classmethod
    def from_table(cls, table: dict[str, Any], where: str = "world", *,
                   base_dir: Path | None = None) -> World:
        """Build from a scenario's ``[world]`` table; WorldError names the bad key.

        ``map``: a map_server YAML (relative to ``base_dir``) whose occupied cells are walls;
        the floor then spans the cells the map knows unless ``width_m``/``height_m`` say otherwise.
        """
        r = _Reader(table, where)
        r.known("width_m", "height_m", "boundary", "walls", "rooms", "lines", "beacons", "dock",
                "people", "zones", "floor_bgr", "robots_see_each_other", "map", "boxes",
                "x_min_m", "y_min_m")
        # The floor's lower-left corner: a site whose origin (home) is inside the floor.
        x_min, y_min = r.num("x_min_m", 0.0), r.num("y_min_m", 0.0)
        map_walls_: FloatArray | None = None
        source = ""
        if "map" in table:
            source, map_walls_, (x_min, y_min, x_max, y_max) = _read_map(
                r.text("map"), base_dir, where)
            width = r.num("width_m", x_max - x_min)
            height = r.num("height_m", y_max - y_min)
        else:
            width, height = r.num("width_m"), r.num("height_m")
        walls: list[tuple[float, float, float, float]] = []
        if r.get("boundary", map_walls_ is None):
            x0, y0, x1, y1 = x_min, y_min, x_min + width, y_min + height
            walls += [(x0, y0, x1, y0), (x1, y0, x1, y1), (x1, y1, x0, y1), (x0, y1, x0, y0)]
        for i, w in enumerate(r.tables("walls")):
            wr = _Reader(w, f"{where}.walls[{i}]")
            wr.known("x1", "y1", "x2", "y2")
            walls.append((wr.num("x1"), wr.num("y1"), wr.num("x2"), wr.num("y2")))
        rooms = [_room(_Reader(t, f"{where}.rooms[{i}]")) for i, t in enumerate(r.tables("rooms"))]
        lines = []
        for i, t in enumerate(r.tables("lines")):
            lr = _Reader(t, f"{where}.lines[{i}]")
            lr.known("name", "points", "colour", "width_m", "closed")
            colour = lr.text("colour", "black")
            if colour not in LINE_COLOURS_BGR:
                msg = f"{lr.where}.colour: expected one of {sorted(LINE_COLOURS_BGR)}"
                raise WorldError(msg)
            points = tuple((float(p[0]), float(p[1])) for p in lr.points("points"))
            lines.append(PaintedLine(lr.text("name", f"line{i}"), points, colour,
                                     lr.num("width_m", 0.025), bool(lr.get("closed", False))))
        beacons = []
        for i, t in enumerate(r.tables("beacons")):
            br = _Reader(t, f"{where}.beacons[{i}]")
            br.known("mac", "uuid", "major", "minor", "x_m", "y_m", "tx_power_dbm", "room",
                     "interval_s")
            beacons.append(SimBeacon(
                br.text("mac"), br.text("uuid"), int(br.num("major")), int(br.num("minor")),
                br.num("x_m"), br.num("y_m"), int(br.num("tx_power_dbm", -59)),
                br.text("room", ""), br.num("interval_s", 0.1)))
        dock = _dock(_Reader(r.get("dock"), f"{where}.dock")) if "dock" in table else None
        people = [Person(pr.text("name", f"person{i}"), pr.num("x_m"), pr.num("y_m"),
                         bool(pr.get("present", True)), legs=bool(pr.get("legs", True)),
                         qr_payload=pr.text("qr_payload") if "qr_payload" in pr.table else None)
                  for i, pr in ((i, _Reader(t, f"{where}.people[{i}]"))
                                for i, t in enumerate(r.tables("people")))]
        mapped_boxes: list[tuple[float, float, float, float]] = []
        unmapped_boxes: list[tuple[float, float, float, float]] = []
        for i, t in enumerate(r.tables("boxes")):
            xr = _Reader(t, f"{where}.boxes[{i}]")
            xr.known("x_min_m", "y_min_m", "x_max_m", "y_max_m", "mapped")
            x0, y0 = xr.num("x_min_m"), xr.num("y_min_m")
            x1, y1 = xr.num("x_max_m"), xr.num("y_max_m")
            sides = [(x0, y0, x1, y0), (x1, y0, x1, y1), (x1, y1, x0, y1), (x0, y1, x0, y0)]
            (mapped_boxes if xr.get("mapped", True) else unmapped_boxes).extend(sides)
        walls += mapped_boxes
        zones = {name: _room(_Reader(t, f"{where}.zones.{name}"), name)
                 for name, t in r.get("zones", {}).items()}
        floor = tuple(int(v) for v in r.get("floor_bgr", (200, 205, 210)))
        all_walls = segments_array(walls)
        if map_walls_ is not None:
            all_walls = np.concatenate([all_walls, map_walls_])
        if unmapped_boxes:  # last, so that mapped_walls() is a prefix
            all_walls = np.concatenate([all_walls, segments_array(unmapped_boxes)])
        return cls(width, height, all_walls, rooms, lines, beacons, dock, people,
                   zones, (floor[0], floor[1], floor[2]),
                   bool(r.get("robots_see_each_other", True)), x_min, y_min, source,
                   len(unmapped_boxes))


def _read_map(name: str, base_dir: Path | None, where: str
              ) -> tuple[str, FloatArray, tuple[float, float, float, float]]:
    path = Path(name).expanduser()
    if not path.is_absolute() and base_dir is not None:
        path = base_dir / path
    try:
        occupancy = read_map_yaml(path)
    except MapFileError as exc:
        msg = f"{where}.map: {exc}"
        raise WorldError(msg) from exc
    return str(path), map_walls(occupancy), known_bounds(occupancy)


_DOCK_KEYS = ("x_m", "y_m", "heading_deg", "slot_s", "width_m", "depth_m", "contact_mv",
              "fault_mv", "beams")
_BEAM_KEYS = ("name", "code", "centre_deg", "half_angle_deg", "range_m", "apex_forward_m",
              "apex_left_m", "slot")


def _dock(r: _Reader) -> Dock:
    """``[world.dock]``: its face's middle and the way it looks, and optional beam changes.

    Each ``[[world.dock.beams]]`` entry names a beam: a default beam's fields it gives are
    changed, a new name is a new beam (every field but the apex then required)."""
    r.known(*_DOCK_KEYS)
    beams = {b.name: b for b in DEFAULT_BEAMS}
    for i, t in enumerate(r.tables("beams")):
        br = _Reader(t, f"{r.where}.beams[{i}]")
        br.known(*_BEAM_KEYS)
        name = br.text("name")
        base = beams.get(name)

        def field(key: str, default: float | None = None, br: _Reader = br,
                  base: Beam | None = base) -> float:
            return br.num(key, float(getattr(base, key)) if base is not None else default)

        beam = Beam(name, int(field("code")), field("centre_deg"), field("half_angle_deg"),
                    field("range_m"), field("apex_forward_m", 0.0),
                    field("apex_left_m", 0.0), int(field("slot")))
        problem = _beam_problem(beam, [b for n, b in beams.items() if n != name])
        if problem:
            msg = f"{br.where}.{problem}"
            raise WorldError(msg)
        beams[name] = beam
    slot_s = r.num("slot_s", SLOT_S)
    if not SLOT_S <= slot_s <= 0.2:
        msg = (f"{r.where}.slot_s: {slot_s} s cannot carry an OI frame (32 ms) and its gap; "
               "expected 0.036-0.2")
        raise WorldError(msg)
    return Dock(r.num("x_m"), r.num("y_m"), math.radians(r.num("heading_deg", 0)),
                beams=tuple(beams.values()), slot_s=slot_s,
                width_m=r.num("width_m", 0.34), depth_m=r.num("depth_m", 0.14),
                contact_mv=int(r.num("contact_mv", CONTACT_MV)),
                fault_mv=int(r.num("fault_mv", FAULT_MV)))


def _beam_problem(beam: Beam, others: list[Beam]) -> str | None:
    """What is wrong with a beam (as ``key: message``), or None."""
    if not 0 <= beam.code <= 255:
        return f"code: expected 0-255, got {beam.code}"
    same = next((b.name for b in others if b.code == beam.code), None)
    if same is not None:
        return f"code: {beam.code} is already the {same} beam's"
    if not 0 < beam.half_angle_deg <= 180:
        return f"half_angle_deg: expected 0-180, got {beam.half_angle_deg}"
    if beam.range_m <= 0:
        return f"range_m: expected a positive range, got {beam.range_m}"
    if not 0 <= beam.slot <= 7:
        return f"slot: expected 0-7, got {beam.slot}"
    return None


def _room(r: _Reader, name: str | None = None) -> Room:
    return Room(name or r.text("name"), r.num("x_min_m"), r.num("y_min_m"),
                r.num("x_max_m"), r.num("y_max_m"))


class _Reader:
    """Typed access to one TOML table; errors name the dotted key."""

    def __init__(self, table: Any, where: str) -> None:
        if not isinstance(table, dict):
            msg = f"{where}: expected a table"
            raise WorldError(msg)
        self.table = table
        self.where = where

    def get(self, key: str, default: Any = None) -> Any:
        return self.table.get(key, default)

    def known(self, *keys: str) -> None:
        for key in self.table:
            if key not in keys:
                close = difflib.get_close_matches(key, keys, n=1)
                hint = f"did you mean {close[0]!r}?" if close else f"known: {', '.join(keys)}"
                msg = f"{self.where}.{key}: unknown key ({hint})"
                raise WorldError(msg)

    def num(self, key: str, default: float | None = None) -> float:
        value = self.table.get(key, default)
        if value is None:
            msg = f"{self.where}.{key}: required number is missing"
            raise WorldError(msg)
        if isinstance(value, bool) or not isinstance(value, int | float):
            msg = f"{self.where}.{key}: expected a number, got {value!r}"
            raise WorldError(msg)
        return float(value)

    def text(self, key: str, default: str | None = None) -> str:
        value = self.table.get(key, default)
        if not isinstance(value, str):
            msg = f"{self.where}.{key}: expected a string, got {value!r}"
            raise WorldError(msg)
        return value

    def tables(self, key: str) -> list[Any]:
        value = self.table.get(key, [])
        if not isinstance(value, list):
            msg = f"{self.where}.{key}: expected an array of tables"
            raise WorldError(msg)
        return value

    def points(self, key: str) -> list[tuple[float, float]]:
        value = self.table.get(key)
        ok = isinstance(value, list) and len(value) >= 2 and all(
            isinstance(p, list) and len(p) == 2
            and all(isinstance(c, int | float) and not isinstance(c, bool) for c in p)
            for p in value)
        if not ok:
            msg = f"{self.where}.{key}: expected at least two [x, y] points"
            raise WorldError(msg)
        return [(float(p[0]), float(p[1])) for p in value]  # type: ignore[union-attr]
