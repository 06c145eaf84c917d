"""The cabinet robot's site: walls, doors, rooms and cabinets, as read from its JSON map.

Coordinates are metres in the map frame; ``zero`` (the map's own coordinates of the robot's
map origin, the seed's "set zero coordinates") is subtracted from every point on reading, so
everything here is already in the robot's frame. A door is a stretch of a wall that the robot
can pass: rasterising leaves it open (the simulator closes it by script).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np
import numpy.typing as npt

from behaviours.nav.grid import Grid

if TYPE_CHECKING:
    from behaviours.profiles.cabinet.made_map import MadeMap

Point = tuple[float, float]
Segment = tuple[float, float, float, float]
FloatArray = npt.NDArray[np.float64]

FRONTS: dict[str, float] = {"east": 0.0, "north": math.pi / 2, "west": math.pi,
                            "south": -math.pi / 2}
"""Named sides a cabinet's front may face (north is +y); a number is a heading in degrees."""

ON_WALL_TOLERANCE_M = 0.01


@dataclass(frozen=True, slots=True)
class Door:
    name: str
    segment: Segment

    @property
    def middle(self) -> Point:
        x1, y1, x2, y2 = self.segment
        return ((x1 + x2) / 2, (y1 + y2) / 2)

    @property
    def width_m(self) -> float:
        x1, y1, x2, y2 = self.segment
        return math.hypot(x2 - x1, y2 - y1)

    def normal(self) -> Point:
        """A unit vector across the door (to one side; its negative points to the other)."""
        x1, y1, x2, y2 = self.segment
        length = math.hypot(x2 - x1, y2 - y1)
        return (-(y2 - y1) / length, (x2 - x1) / length)


@dataclass(frozen=True, slots=True)
class Room:
    name: str
    polygon: tuple[Point, ...]

    def contains(self, x_m: float, y_m: float) -> bool:
        """Even-odd rule; a point on the boundary may go either way."""
        inside = False
        pts = self.polygon
        for (x1, y1), (x2, y2) in zip(pts, pts[1:] + pts[:1], strict=True):
            if (y1 > y_m) != (y2 > y_m):
                x_cross = x1 + (y_m - y1) * (x2 - x1) / (y2 - y1)
                if x_m < x_cross:
                    inside = not inside
        return inside

    def centroid(self) -> Point:
        """The polygon's area centroid (its vertex mean when degenerate)."""
        pts = np.asarray(self.polygon, dtype=np.float64)
        x, y = pts[:, 0], pts[:, 1]
        xn, yn = np.roll(x, -1), np.roll(y, -1)
        cross = x * yn - xn * y
        area = float(cross.sum()) / 2
        if abs(area) < 1e-12:
            return (float(x.mean()), float(y.mean()))
        return (float(((x + xn) * cross).sum()) / (6 * area),
                float(((y + yn) * cross).sum()) / (6 * area))


@dataclass(frozen=True, slots=True)
class Cabinet:
    name: str
    room: str
    position: Point
    front_rad: float
    """The heading the cabinet's front faces: the robot stands in front, facing the other way."""

    def front_point(self, standoff_m: float) -> Point:
        x, y = self.position
        return (x + standoff_m * math.cos(self.front_rad),
                y + standoff_m * math.sin(self.front_rad))

    @property
    def facing_rad(self) -> float:
        """The robot's heading when it faces this cabinet's front."""
        return math.atan2(-math.sin(self.front_rad), -math.cos(self.front_rad))


@dataclass(frozen=True, slots=True)
class SiteMap:
    """A site as its JSON map describes it (see ``docs/cabinet.md`` for the format); on a
    made map (``made``) the walls are the outlines of the map's occupied cells."""

    walls: tuple[Segment, ...]
    doors: tuple[Door, ...]
    rooms: tuple[Room, ...]
    cabinets: tuple[Cabinet, ...]
    resolution_m: float = 0.05
    made: MadeMap | None = field(default=None, compare=False)

    def cabinet(self, name: str) -> Cabinet:
        for cabinet in self.cabinets:
            if cabinet.name == name:
                return cabinet
        msg = f"unknown cabinet {name!r}"
        raise KeyError(msg)

    def room_at(self, x_m: float, y_m: float) -> Room | None:
        for room in self.rooms:
            if room.contains(x_m, y_m):
                return room
        return None

    def solid_walls(self) -> tuple[Segment, ...]:
        """The walls with every door's stretch cut out: what the robot can see and not cross."""
        out: list[Segment] = []
        for wall in self.walls:
            pieces = [wall]
            for door in self.doors:
                pieces = [p for piece in pieces for p in cut_segment(piece, door.segment)]
            out.extend(pieces)
        return tuple(out)

    def grid(self, resolution_m: float | None = None) -> Grid:
        """The nav grid (``behaviours.nav.grid``): solid walls rasterised (a made map's own
        cells, unknown ones blocked), doors open."""
        if self.made is not None:
            return self.made.with_doors_open([door.segment for door in self.doors])
        return Grid.from_segments(self.solid_walls(), resolution_m or self.resolution_m)

    def wall_array(self) -> FloatArray:
        """Solid walls as an (N, 4) array (the scan fit's ICP lines)."""
        return np.asarray(self.solid_walls(), dtype=np.float64).reshape(-1, 4)


def door_on_wall(door: Segment, wall: Segment) -> bool:
    """Whether a door's segment lies along a wall (collinear, within its ends)."""
    return _interval_on(door, wall) is not None


def _interval_on(part: Segment, wall: Segment) -> tuple[float, float] | None:
    x1, y1, x2, y2 = wall
    length = math.hypot(x2 - x1, y2 - y1)
    if length < 1e-9:
        return None
    ux, uy = (x2 - x1) / length, (y2 - y1) / length
    ts = []
    for px, py in ((part[0], part[1]), (part[2], part[3])):
        dx, dy = px - x1, py - y1
        if abs(dx * uy - dy * ux) > ON_WALL_TOLERANCE_M:
            return None
        ts.append(dx * ux + dy * uy)
    lo, hi = min(ts), max(ts)
    if lo < -ON_WALL_TOLERANCE_M or hi > length + ON_WALL_TOLERANCE_M:
        return None
    return (lo / length, hi / length)


def cut_segment(wall: Segment, door: Segment) -> list[Segment]:
    """The parts of ``wall`` outside ``door`` (the wall itself when the door is not on it)."""
    interval = _interval_on(door, wall)
    if interval is None:
        return [wall]
    lo, hi = interval
    x1, y1, x2, y2 = wall
    out = []
    for a, b in ((0.0, lo), (hi, 1.0)):
        if b - a > 1e-9:
            out.append((x1 + a * (x2 - x1), y1 + a * (y2 - y1),
                        x1 + b * (x2 - x1), y1 + b * (y2 - y1)))
    return out


def segments_cross(a: Segment, b: Segment) -> bool:
    """Whether two segments properly intersect (touching ends do not count)."""
    def orient(px: float, py: float, qx: float, qy: float, rx: float, ry: float) -> float:
        return (qx - px) * (ry - py) - (qy - py) * (rx - px)

    d1 = orient(b[0], b[1], b[2], b[3], a[0], a[1])
    d2 = orient(b[0], b[1], b[2], b[3], a[2], a[3])
    d3 = orient(a[0], a[1], a[2], a[3], b[0], b[1])
    d4 = orient(a[0], a[1], a[2], a[3], b[2], b[3])
    return (d1 * d2 < 0) and (d3 * d4 < 0)


def polygon_of_rect(rect: Sequence[float]) -> tuple[Point, ...]:
    x0, y0, x1, y1 = rect
    return ((x0, y0), (x1, y0), (x1, y1), (x0, y1))
