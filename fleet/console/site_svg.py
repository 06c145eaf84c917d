"""The site map as SVG: a laundry site's schematic (its rooms as labelled boxes along the
line's loop, the base first) or a site's map picture, with every robot drawn on it.

Schematic: the loop is a rectangle run clockwise from its lower-left corner; the rooms sit
evenly along its lower side (the base first) and back along its upper side; each room is at a
fraction ``t`` of the loop (``data-t``). A robot in a room stands at the room's point (several
one behind the other); one on its way from A to B halfway along the loop from A to B. The
page's script (``console.js``) places markers by the same rule when a ``robots`` event comes.

Map: the picture (``/console/site/map.png``) in map pixels, a robot with a pose on it at its
pixel with a stroke for its heading (``map_image.SiteMap.pixel``): a pose on the site map's
own map (its YAML's stem), or on map ``odom`` for a robot whose odometry frame the site file
places (``odom_on_map``, ``on_site_map``); other robots are listed beside it. The script
places pushed poses by the same rule (``data-map``, ``data-placements``).
"""

from __future__ import annotations

import json
import math
from collections.abc import Mapping, Sequence

from fleet.console.html import esc
from fleet.console.map_image import SiteMap
from fleet.console.robot_views import RobotView, place_rooms

WIDTH, HEIGHT = 960, 380
LOOP = (110.0, 120.0, 850.0, 260.0)
"""The loop's rectangle (x0, y0, x1, y1) in the drawing's units."""
BOX_W, BOX_H = 130.0, 46.0
ODOM = "odom"
"""The map name of a pose in the robot's own odometry frame (the vacuum's)."""
Placements = Mapping[str, tuple[float, float, float]]
"""Robot name -> its odometry frame on the site map (x_m, y_m, theta_rad)."""
QUEUE_STEP = 0.025
"""How far apart (a fraction of the loop) robots at one place stand."""


def loop_point(t: float) -> tuple[float, float]:
    """The point at fraction ``t`` of the loop, clockwise from its lower-left corner."""
    x0, y0, x1, y1 = LOOP
    w, h = x1 - x0, y1 - y0
    d = (t % 1.0) * 2 * (w + h)
    if d < w:
        return x0 + d, y1
    if d < w + h:
        return x1, y1 - (d - w)
    if d < 2 * w + h:
        return x1 - (d - w - h), y0
    return x0, y0 + (d - 2 * w - h)


def room_places(rooms: Sequence[str]) -> dict[str, float]:
    """Each room's fraction of the loop: the first half along the lower side, left to right,
    the rest along the upper side, right to left."""
    x0, y0, x1, y1 = LOOP
    w, h = x1 - x0, y1 - y0
    perimeter = 2 * (w + h)
    lower = math.ceil(len(rooms) / 2)
    upper = len(rooms) - lower
    places = {}
    for i, room in enumerate(rooms[:lower]):
        places[room] = (i + 0.5) * w / lower / perimeter
    for j, room in enumerate(rooms[lower:]):
        places[room] = (w + h + (j + 0.5) * w / upper) / perimeter
    return places


def robot_t(view: RobotView, places: dict[str, float], queue_index: int) -> float | None:
    """Where on the loop the robot is drawn (None: its place is not on the drawing)."""
    origin, target = place_rooms(view.place)
    if target not in places:
        return None
    end = places[target]
    if origin is None:
        return end - queue_index * QUEUE_STEP
    start = places.get(origin, end - 4 * QUEUE_STEP)
    return start + ((end - start) % 1.0) / 2


def _room(name: str, t: float, base: bool) -> str:
    x, y = loop_point(t)
    below = y >= LOOP[3]
    box_y = y + 22 if below else y - 22 - BOX_H
    css = "room base" if base else "room"
    label = f"{name} (base)" if base else name
    return (f'<g class="{css}" data-room="{esc(name)}" data-t="{t:.5f}">'
            f'<line x1="{x:.1f}" y1="{y:.1f}" x2="{x:.1f}" '
            f'y2="{box_y + (0 if below else BOX_H):.1f}"/>'
            f'<rect x="{x - BOX_W / 2:.1f}" y="{box_y:.1f}" width="{BOX_W}" height="{BOX_H}" '
            f'rx="6"/><text x="{x:.1f}" y="{box_y + BOX_H / 2 + 5:.1f}">{esc(label)}</text>'
            "</g>")


def glyph_scale(site_map: SiteMap) -> float:
    """A marker on a map picture is drawn at this scale: as large beside the picture as on
    the schematic, whatever the map's size in pixels."""
    return max(site_map.width_px, site_map.height_px) / WIDTH


def marker(view: RobotView, x: float, y: float, heading_rad: float | None = None,
           scale: float = 1.0) -> str:
    """A robot's marker: a dot in its condition's colour, its name, battery and fault; on a
    map picture (``heading_rad`` given) it carries the pose it is drawn for, as reported
    (``data-x``, ``data-y``, ``data-theta``, ``data-map``), as the script's markers do."""
    battery = "" if view.battery_pct is None else f" {view.battery_pct:.0f}%"
    fault = f" {view.fault_code}" if view.fault_code else ""
    heading = pose = ""
    if heading_rad is not None:
        pose = (f'data-x="{view.x_m}" data-y="{view.y_m}" data-theta="{view.theta_rad or 0.0}" '
                f'data-map="{esc(view.map_name or "")}" ')
        heading = (f'<line class="heading" x1="0" y1="0" x2="{22 * math.cos(heading_rad):.1f}" '
                   f'y2="{-22 * math.sin(heading_rad):.1f}"/>')
    return (f'<g class="robot c-{view.condition}" id="marker-{esc(view.name)}" '
            f'data-robot="{esc(view.name)}" data-condition="{view.condition}" '
            f'data-place="{esc(view.place or "")}" {pose}transform="translate({x:.1f},{y:.1f})">'
            f'<g class="glyph" transform="scale({scale:.4g})">'
            f'{heading}<circle r="11"/><text class="name" y="-16">{esc(view.name)}</text>'
            f'<text class="about" x="16" y="5">{esc((battery + fault).strip())}</text></g>'
            f"<title>{esc(view.name)}: {esc(view.state or '?')} ({view.condition})</title></g>")


def schematic(rooms: Sequence[str], base: str | None, views: Sequence[RobotView]) -> str:
    """The laundry site drawn as its loop of rooms with the robots on it."""
    order = ([base] if base is not None and base in rooms else []) + [
        r for r in rooms if r != base]
    places = room_places(order)
    x0, y0, x1, y1 = LOOP
    drawn = [f'<rect class="loop" x="{x0}" y="{y0}" width="{x1 - x0}" height="{y1 - y0}" '
             'rx="18"/>']
    drawn += [_room(name, t, name == base) for name, t in places.items()]
    at: dict[str, int] = {}
    for view in views:
        key = view.place or ""
        t = robot_t(view, places, at.get(key, 0))
        at[key] = at.get(key, 0) + 1
        if t is None:
            continue
        x, y = loop_point(t)
        drawn.append(marker(view, x, y))
    return (f'<svg id="site-map" class="schematic" viewBox="0 0 {WIDTH} {HEIGHT}" '
            f'data-loop="{",".join(str(v) for v in LOOP)}" role="img" '
            f'aria-label="the site: rooms along the line and the robots">{"".join(drawn)}'
            "</svg>")


def on_site_map(view: RobotView, site_map: SiteMap, placements: Placements
                ) -> tuple[float, float, float] | None:
    """The robot's pose on the site map (x_m, y_m, theta_rad), or None: no pose, or one on a
    map that is neither the site's nor its placed odometry frame."""
    if view.x_m is None or view.y_m is None:
        return None
    theta = view.theta_rad or 0.0
    if view.map_name == site_map.name:
        return view.x_m, view.y_m, theta
    placed = placements.get(view.name)
    if view.map_name != ODOM or placed is None:
        return None
    px, py, pt = placed
    c, s = math.cos(pt), math.sin(pt)
    return px + c * view.x_m - s * view.y_m, py + s * view.x_m + c * view.y_m, pt + theta


def picture(site_map: SiteMap, views: Sequence[RobotView], placements: Placements) -> str:
    """The site's map picture with every robot that has a pose on it drawn there."""
    drawn = [f'<image href="/console/site/map.png" x="0" y="0" width="{site_map.width_px}" '
             f'height="{site_map.height_px}"/>']
    for view in views:
        pose = on_site_map(view, site_map, placements)
        if pose is None:
            continue
        col, row = site_map.pixel(pose[0], pose[1])
        drawn.append(marker(view, col, row, pose[2], glyph_scale(site_map)))
    placed = json.dumps({name: list(p) for name, p in placements.items()})
    return (f'<svg id="site-map" class="picture" '
            f'viewBox="0 0 {site_map.width_px} {site_map.height_px}" '
            f'data-origin="{site_map.origin_x_m},{site_map.origin_y_m}" '
            f'data-resolution="{site_map.resolution_m}" data-height="{site_map.height_px}" '
            f'data-map="{esc(site_map.name)}" data-placements="{esc(placed)}" '
            f'data-glyph-scale="{glyph_scale(site_map):.4g}" '
            f'role="img" aria-label="the site map {esc(site_map.name)} and the robots">'
            f'{"".join(drawn)}</svg>')
