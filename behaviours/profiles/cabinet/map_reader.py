"""Reading the cabinet robot's JSON files (the site map, the task list) with every problem
named as ``map.json: cabinets[2].front: message``.

A reader never raises on bad content: it collects problems (all of them, not only the first),
and ``SiteFileError`` carries them to ``check-config`` and to the daemon's start.
"""

from __future__ import annotations

import json
import math
from collections.abc import Callable
from pathlib import Path
from typing import Any

from behaviours.profiles.cabinet.made_map import DOOR_JAMB_TOLERANCE_M, MadeMap, read_made_map
from behaviours.profiles.cabinet.made_map import KEY as OCCUPANCY
from behaviours.profiles.cabinet.site_map import (
    FRONTS,
    Cabinet,
    Door,
    Point,
    Room,
    Segment,
    SiteMap,
    door_on_wall,
    polygon_of_rect,
)
from hal.files import FileRefused, read_bounded_text


class SiteFileError(Exception):
    """A map or task file that cannot be used; ``problems`` are ``FILE: where: what``."""

    def __init__(self, problems: list[str]) -> None:
        super().__init__("\n".join(problems))
        self.problems = problems


class Problems:
    """Problems of one file, each prefixed with the file's name and the JSON path."""

    def __init__(self, file: str) -> None:
        self.file = file
        self.items: list[str] = []

    def add(self, where: str, message: str) -> None:
        self.items.append(f"{self.file}: {where}: {message}")

    def raise_any(self) -> None:
        if self.items:
            raise SiteFileError(self.items)


MAX_SITE_FILE_BYTES = 16 * 1024 * 1024
"""A site map or task list of thousands of nodes is a few megabytes of JSON."""


def read_json(path: Path, shown: str) -> Any:
    """The parsed document; a file that cannot be read or is not JSON is a SiteFileError."""
    try:
        text = read_bounded_text(path, MAX_SITE_FILE_BYTES, "site file")
    except FileRefused as exc:
        raise SiteFileError([f"{shown}: file: cannot read: {exc.path}: {exc.why}"]) from None
    try:
        doc = json.loads(text, parse_constant=_Constant)
    except json.JSONDecodeError as exc:
        raise SiteFileError([f"{shown}: line {exc.lineno}: not JSON: {exc.msg}"]) from None
    except RecursionError:
        raise SiteFileError([f"{shown}: file: nested too deeply to read"]) from None
    constants = [f"{shown}: {where or 'file'}: {value.name} is not a number (JSON has no NaN "
                 "or Infinity)" for where, value in _constants(doc, "")]
    if constants:
        raise SiteFileError(constants)
    return doc


class _Constant:
    """Where the decoder met ``NaN``/``Infinity``: a marker, reported at its JSON path."""

    def __init__(self, name: str) -> None:
        self.name = name


def _constants(value: Any, where: str) -> list[tuple[str, _Constant]]:
    """(JSON path, marker) of every NaN/Infinity in a parsed document (iterative: the
    decoder has already bounded the depth)."""
    found: list[tuple[str, _Constant]] = []
    stack: list[tuple[str, Any]] = [(where, value)]
    while stack:
        at, item = stack.pop()
        if isinstance(item, _Constant):
            found.append((at, item))
        elif isinstance(item, dict):
            stack += [(f"{at}.{k}" if at else str(k), v) for k, v in reversed(item.items())]
        elif isinstance(item, list):
            stack += [(f"{at}[{i}]", v) for i, v in reversed(list(enumerate(item)))]
    return found


def number(value: Any, where: str, problems: Problems) -> float | None:
    if isinstance(value, bool) or not isinstance(value, int | float):
        problems.add(where, f"expected a number, got {show(value)}")
        return None
    if not math.isfinite(value):
        problems.add(where, f"expected a finite number, got {value}")
        return None
    return float(value)


def numbers(value: Any, count: int, where: str, problems: Problems) -> list[float] | None:
    if not isinstance(value, list) or len(value) != count:
        problems.add(where, f"expected a list of {count} numbers, got {show(value)}")
        return None
    out = [number(v, f"{where}[{i}]", problems) for i, v in enumerate(value)]
    return None if any(v is None for v in out) else [float(v) for v in out if v is not None]


def name_of(item: dict[str, Any], where: str, seen: set[str], problems: Problems) -> str | None:
    name = item.get("name")
    if not isinstance(name, str) or not name:
        problems.add(f"{where}.name", f"expected a non-empty string, got {show(name)}")
        return None
    if name in seen:
        problems.add(f"{where}.name", f"duplicate name {name!r}")
        return None
    seen.add(name)
    return name


def items(doc: dict[str, Any], key: str, problems: Problems, *, required: bool
          ) -> list[tuple[str, dict[str, Any]]]:
    """(json path, object) of each entry of a list of objects; wrong shapes reported."""
    value = doc.get(key)
    if value is None:
        if required:
            problems.add(key, "missing (expected a list)")
        return []
    if not isinstance(value, list):
        problems.add(key, f"expected a list, got {show(value)}")
        return []
    out = []
    for i, item in enumerate(value):
        if not isinstance(item, dict):
            problems.add(f"{key}[{i}]", f"expected an object, got {show(item)}")
            continue
        out.append((f"{key}[{i}]", item))
    return out


def unknown_keys(item: dict[str, Any], where: str, known: tuple[str, ...],
                 problems: Problems) -> None:
    for key in item:
        if key not in known:
            problems.add(f"{where}.{key}" if where else key,
                         f"unknown key (known: {', '.join(known)})")


MAP_KEYS = ("resolution_m", "zero", "walls", "occupancy", "doors", "rooms", "cabinets")


def parse_site_map(doc: Any, shown: str, base_dir: Path | None = None) -> SiteMap:
    """A SiteMap from a parsed JSON document, or SiteFileError naming every problem;
    ``base_dir``: where a made map's ``occupancy`` file is looked for (the site file's
    folder)."""
    problems = Problems(shown)
    if not isinstance(doc, dict):
        problems.add("file", f"expected a JSON object, got {show(doc)}")
        problems.raise_any()
    unknown_keys(doc, "", MAP_KEYS, problems)
    resolution_m = 0.05
    if "resolution_m" in doc:
        value = number(doc["resolution_m"], "resolution_m", problems)
        if value is not None and not 0.005 <= value <= 0.5:
            problems.add("resolution_m", f"must be within 0.005..0.5, got {value}")
        elif value is not None:
            resolution_m = value
    zero = numbers(doc.get("zero", [0, 0]), 2, "zero", problems) or [0.0, 0.0]
    shift: Callable[[float, float], Point] = lambda x, y: (x - zero[0], y - zero[1])  # noqa: E731

    made = None
    if OCCUPANCY in doc:
        if "walls" in doc:
            problems.add("walls", f"give walls or {OCCUPANCY}, not both")
        made, problem = read_made_map(doc[OCCUPANCY], base_dir, (zero[0], zero[1]))
        if problem is not None:
            problems.add(OCCUPANCY, problem)
        walls = made.walls() if made is not None else []
        resolution_m = made.occupied.resolution_m if made is not None else resolution_m
    else:
        walls = _walls(doc, problems, shift)
    doors = _doors(doc, problems, shift, walls, made)
    rooms = _rooms(doc, problems, shift)
    cabinets = _cabinets(doc, problems, shift, rooms)
    problems.raise_any()
    return SiteMap(tuple(walls), tuple(doors), tuple(rooms), tuple(cabinets), resolution_m,
                   made)


def _segment(value: Any, where: str, problems: Problems,
             shift: Callable[[float, float], Point]) -> Segment | None:
    nums = numbers(value, 4, where, problems)
    if nums is None:
        return None
    (x1, y1), (x2, y2) = shift(nums[0], nums[1]), shift(nums[2], nums[3])
    if math.hypot(x2 - x1, y2 - y1) < 1e-6:
        problems.add(where, "a segment needs two different end points")
        return None
    return (x1, y1, x2, y2)


def _walls(doc: dict[str, Any], problems: Problems,
           shift: Callable[[float, float], Point]) -> list[Segment]:
    value = doc.get("walls")
    if not isinstance(value, list) or not value:
        problems.add("walls", f"expected a non-empty list of [x1, y1, x2, y2], got {show(value)}")
        return []
    out = []
    for i, item in enumerate(value):
        seg = _segment(item, f"walls[{i}]", problems, shift)
        if seg is not None:
            out.append(seg)
    return out


def _doors(doc: dict[str, Any], problems: Problems, shift: Callable[[float, float], Point],
           walls: list[Segment], made: MadeMap | None) -> list[Door]:
    seen: set[str] = set()
    out = []
    for where, item in items(doc, "doors", problems, required=False):
        unknown_keys(item, where, ("name", "segment"), problems)
        name = name_of(item, where, seen, problems)
        seg = _segment(item.get("segment"), f"{where}.segment", problems, shift)
        if name is None or seg is None:
            continue
        if made is not None:
            gaps_m = [made.jamb_gap_m(seg[0], seg[1]), made.jamb_gap_m(seg[2], seg[3])]
            if max(gaps_m) > DOOR_JAMB_TOLERANCE_M:
                problems.add(f"{where}.segment",
                             f"an end is {max(gaps_m):.2f} m from the map's nearest wall cell "
                             f"(a door stands in a wall: within {DOOR_JAMB_TOLERANCE_M} m)")
                continue
        elif walls and not any(door_on_wall(seg, wall) for wall in walls):
            problems.add(f"{where}.segment", "not along any wall (a door is a stretch of a wall)")
            continue
        out.append(Door(name, seg))
    return out


def _rooms(doc: dict[str, Any], problems: Problems,
           shift: Callable[[float, float], Point]) -> list[Room]:
    seen: set[str] = set()
    out = []
    for where, item in items(doc, "rooms", problems, required=True):
        unknown_keys(item, where, ("name", "rect", "polygon"), problems)
        name = name_of(item, where, seen, problems)
        polygon: list[Point] | None = None
        if ("rect" in item) == ("polygon" in item):
            problems.add(where, "expected exactly one of rect [x0, y0, x1, y1] or polygon")
        elif "rect" in item:
            rect = numbers(item["rect"], 4, f"{where}.rect", problems)
            if rect is not None:
                if rect[2] <= rect[0] or rect[3] <= rect[1]:
                    problems.add(f"{where}.rect", "expected x1 > x0 and y1 > y0")
                else:
                    polygon = [shift(x, y) for x, y in polygon_of_rect(rect)]
        else:
            raw = item["polygon"]
            if not isinstance(raw, list) or len(raw) < 3:
                problems.add(f"{where}.polygon", f"expected 3 or more [x, y], got {show(raw)}")
            else:
                pts = [numbers(p, 2, f"{where}.polygon[{i}]", problems) for i, p in enumerate(raw)]
                if all(p is not None for p in pts):
                    polygon = [shift(p[0], p[1]) for p in pts if p is not None]
        if name is not None and polygon is not None:
            out.append(Room(name, tuple(polygon)))
    if not out and not problems.items:
        problems.add("rooms", "expected at least one room")
    return out


def _cabinets(doc: dict[str, Any], problems: Problems, shift: Callable[[float, float], Point],
              rooms: list[Room]) -> list[Cabinet]:
    seen: set[str] = set()
    by_name = {room.name: room for room in rooms}
    out = []
    for where, item in items(doc, "cabinets", problems, required=True):
        unknown_keys(item, where, ("name", "room", "position", "front"), problems)
        name = name_of(item, where, seen, problems)
        pos = numbers(item.get("position"), 2, f"{where}.position", problems)
        front = _front(item.get("front"), f"{where}.front", problems)
        room_name = item.get("room")
        room = by_name.get(room_name) if isinstance(room_name, str) else None
        if not isinstance(room_name, str):
            problems.add(f"{where}.room", f"expected a room's name, got {show(room_name)}")
        elif room is None:
            known = ", ".join(sorted(by_name)) or "none"
            problems.add(f"{where}.room", f"unknown room {room_name!r} (known: {known})")
        if name is None or pos is None or front is None or room is None:
            continue
        x, y = shift(pos[0], pos[1])
        if not room.contains(x, y):
            problems.add(f"{where}.position",
                         f"({pos[0]:g}, {pos[1]:g}) is not inside room {room.name!r}")
            continue
        out.append(Cabinet(name, room.name, (x, y), front))
    return out


def _front(value: Any, where: str, problems: Problems) -> float | None:
    if isinstance(value, str):
        if value in FRONTS:
            return FRONTS[value]
        problems.add(where, f"expected one of {', '.join(FRONTS)} or a heading in degrees, "
                            f"got {value!r}")
        return None
    degrees = number(value, where, problems)
    return None if degrees is None else math.radians(degrees)


def show(value: Any) -> str:
    kinds = {bool: "a boolean", int: "an integer", float: "a number", str: "a string",
             list: "a list", dict: "an object", type(None): "null"}
    text = repr(value)
    if len(text) > 40:
        text = text[:37] + "..."
    return f"{kinds.get(type(value), type(value).__name__)} ({text})"
