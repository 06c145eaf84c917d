"""A simulated world built from a cabinet robot's JSON map (``[world] site_map = "..."``).

The world's walls are the map's walls with the doors' stretches cut out (the map's doors are
open), its rooms the map's rooms (their bounding boxes); the scenario adds what the map does
not know (``boxes`` with ``mapped = false``: furniture, ``people``). A door is closed and
opened by script (``door.close``, ``door.open``: ``sim.robots.cabinet.actions``): its segment
is added to the walls as something the robot's map lacks, and taken out again.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from behaviours.profiles.cabinet.map_reader import SiteFileError, parse_site_map, read_json
from behaviours.profiles.cabinet.site_map import Segment, SiteMap
from sim.world.floor_plan import World, WorldError

KEY = "site_map"


def site_map_of(name: str, base_dir: Path | None) -> SiteMap:
    """The JSON map a scenario names (relative to the scenario), or WorldError."""
    path = Path(name).expanduser()
    if not path.is_absolute() and base_dir is not None:
        path = base_dir / path
    try:
        return parse_site_map(read_json(path, name), name, path.parent)
    except SiteFileError as exc:
        msg = f"world.{KEY}: {'; '.join(exc.problems)}"
        raise WorldError(msg) from None


def expand_site_map(table: dict[str, Any], base_dir: Path | None) -> dict[str, Any]:
    """``table`` with ``site_map`` replaced by the map's walls and rooms (as is without it)."""
    if KEY not in table:
        return table
    name = table[KEY]
    if not isinstance(name, str):
        msg = f"world.{KEY}: expected a file name, got {name!r}"
        raise WorldError(msg)
    site = site_map_of(name, base_dir)
    out = {k: v for k, v in table.items() if k != KEY}
    walls = site.solid_walls()
    xs = [v for w in site.walls for v in (w[0], w[2])]
    ys = [v for w in site.walls for v in (w[1], w[3])]
    out.setdefault("width_m", max(xs))
    out.setdefault("height_m", max(ys))
    out["boundary"] = False
    out["walls"] = [*out.get("walls", []),
                    *({"x1": x1, "y1": y1, "x2": x2, "y2": y2} for x1, y1, x2, y2 in walls)]
    if "rooms" not in out:
        out["rooms"] = [_room(room.name, room.polygon) for room in site.rooms]
    return out


def _room(name: str, polygon: tuple[tuple[float, float], ...]) -> dict[str, Any]:
    xs, ys = [p[0] for p in polygon], [p[1] for p in polygon]
    return {"name": name, "x_min_m": min(xs), "y_min_m": min(ys), "x_max_m": max(xs),
            "y_max_m": max(ys)}


def door_segment(site: SiteMap, name: str) -> Segment:
    for door in site.doors:
        if door.name == name:
            return door.segment
    known = ", ".join(d.name for d in site.doors) or "none"
    msg = f"no door named {name!r} in the map (known: {known})"
    raise WorldError(msg)


def close_door(world: World, segment: Segment) -> bool:
    """The door's segment added to the walls (unmapped); False if it is closed already."""
    if _row(world, segment) is not None:
        return False
    world.walls = np.concatenate([world.walls, np.asarray([segment], dtype=np.float64)])
    world.unmapped_walls += 1
    return True


def open_door(world: World, segment: Segment) -> bool:
    """The door's segment taken out of the walls; False if it was not closed."""
    row = _row(world, segment)
    if row is None:
        return False
    world.walls = np.delete(world.walls, row, axis=0)
    world.unmapped_walls -= 1
    return True


def _row(world: World, segment: Segment) -> int | None:
    mapped = world.walls.shape[0] - world.unmapped_walls
    target = np.asarray(segment, dtype=np.float64)
    for i in range(mapped, world.walls.shape[0]):
        if np.allclose(world.walls[i], target, atol=1e-9):
            return i
    return None
