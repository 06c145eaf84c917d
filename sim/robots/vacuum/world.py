"""A virtual wall in the vacuum's world: ``[world] virtual_wall = { x_m, y_m, heading_deg,
range_m, half_angle_deg }``, the OI's battery-powered beam (code 162) that a robot vacuum must
not cross.

The simulator sends it as one more beam of the dock (``sim.world.dock``): the receivers,
occlusion and decoding are the dock's. It goes in the first of the dock's emission slots
whose beams it nowhere crosses, so a receiver never reads its code OR'd with a dock beam's
and the dock's cycle stays 144 ms; only when it crosses a beam of every slot does it get a
slot of its own (a 180 ms cycle, still within the driver's 0.2 s window, though a tighter fit
for the centre beam's sweep). A real virtual wall is not in step with the dock: where its
beam and a dock beam meet, frames would now and then overlap and the decoder count a
collision; here they never do. A world with a virtual wall must have a dock; one virtual wall
per world (each code once).
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

from sim.world.dock import DEFAULT_BEAMS, Beam
from sim.world.floor_plan import WorldError
from sim.world.geometry import Pose

VIRTUAL_WALL_CODE = 162
KEYS = ("x_m", "y_m", "heading_deg", "range_m", "half_angle_deg")
OWN_SLOT = 4
"""After the dock's four slots (0-3), when it crosses a beam of each."""
SAMPLE_M = 0.05


def expand_virtual_wall(table: dict[str, Any], _base_dir: Path | None) -> dict[str, Any]:
    """``[world] virtual_wall`` as a beam of ``[world.dock]`` (its apex and direction in the
    dock's frame); a world without one is returned unchanged."""
    wall = table.get("virtual_wall")
    if wall is None:
        return table
    where = "world.virtual_wall"
    if not isinstance(wall, dict):
        msg = f"{where}: expected a table {{ x_m, y_m, heading_deg, range_m, half_angle_deg }}"
        raise WorldError(msg)
    unknown = sorted(set(wall) - set(KEYS))
    if unknown:
        msg = f"{where}: unknown key(s) {', '.join(unknown)} (known: {', '.join(KEYS)})"
        raise WorldError(msg)
    dock = table.get("dock")
    if not isinstance(dock, dict):
        msg = f"{where}: a virtual wall needs [world.dock] (it is sent in the dock's cycle)"
        raise WorldError(msg)

    def num(key: str, default: float | None = None) -> float:
        value = wall.get(key, default)
        if isinstance(value, bool) or not isinstance(value, int | float) \
                or not math.isfinite(value):
            msg = f"{where}.{key}: expected a number, got {value!r}"
            raise WorldError(msg)
        return float(value)

    x, y, heading = num("x_m"), num("y_m"), num("heading_deg")
    dx, dy = float(dock["x_m"]), float(dock["y_m"])
    dock_heading = math.radians(float(dock.get("heading_deg", 0.0)))
    c, s = math.cos(dock_heading), math.sin(dock_heading)
    wall_beam = Beam(
        "virtual_wall", VIRTUAL_WALL_CODE,
        centre_deg=math.degrees(math.remainder(math.radians(heading) - dock_heading, math.tau)),
        half_angle_deg=num("half_angle_deg", 5.0), range_m=num("range_m", 2.0),
        apex_forward_m=(x - dx) * c + (y - dy) * s, apex_left_m=-(x - dx) * s + (y - dy) * c)
    slot = _free_slot(wall_beam, _dock_beams(dock), Pose(dx, dy, dock_heading))
    beam = {"name": wall_beam.name, "code": wall_beam.code, "centre_deg": wall_beam.centre_deg,
            "half_angle_deg": wall_beam.half_angle_deg, "range_m": wall_beam.range_m,
            "apex_forward_m": wall_beam.apex_forward_m, "apex_left_m": wall_beam.apex_left_m,
            "slot": slot}
    out = {k: v for k, v in table.items() if k != "virtual_wall"}
    out["dock"] = {**dock, "beams": [*dock.get("beams", []), beam]}
    return out


def _dock_beams(dock: dict[str, Any]) -> list[Beam]:
    """The dock's beams as the scenario leaves them (a changed default keeps its slot)."""
    beams = {b.name: b for b in DEFAULT_BEAMS}
    for entry in dock.get("beams", []):
        name = str(entry.get("name"))
        base = beams.get(name)
        if base is not None:
            beams[name] = Beam(name, int(entry.get("code", base.code)),
                               float(entry.get("centre_deg", base.centre_deg)),
                               float(entry.get("half_angle_deg", base.half_angle_deg)),
                               float(entry.get("range_m", base.range_m)),
                               float(entry.get("apex_forward_m", base.apex_forward_m)),
                               float(entry.get("apex_left_m", base.apex_left_m)),
                               int(entry.get("slot", base.slot)))
        elif {"code", "centre_deg", "half_angle_deg", "range_m", "slot"} <= set(entry):
            beams[name] = Beam(name, int(entry["code"]), float(entry["centre_deg"]),
                               float(entry["half_angle_deg"]), float(entry["range_m"]),
                               float(entry.get("apex_forward_m", 0.0)),
                               float(entry.get("apex_left_m", 0.0)), int(entry["slot"]))
    return list(beams.values())


def _free_slot(wall: Beam, beams: list[Beam], dock: Pose) -> int:
    """The first dock slot none of whose beams covers any point of the wall's sector."""
    points = _sector_points(wall, dock)
    for slot in sorted({b.slot for b in beams}):
        if not any(b.covers(dock, x, y) for b in beams if b.slot == slot for x, y in points):
            return slot
    return max(OWN_SLOT, 1 + max(b.slot for b in beams))


def _sector_points(beam: Beam, dock: Pose) -> list[tuple[float, float]]:
    """Points filling a beam's sector (its middle and both edges, every ``SAMPLE_M``)."""
    ax, ay = beam.apex(dock)
    out = []
    for edge in (-1.0, 0.0, 1.0):
        angle = dock.heading_rad + math.radians(beam.centre_deg + edge * beam.half_angle_deg)
        steps = int(beam.range_m / SAMPLE_M)
        out += [(ax + math.cos(angle) * i * SAMPLE_M, ay + math.sin(angle) * i * SAMPLE_M)
                for i in range(1, steps + 1)]
    return out
