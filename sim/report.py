"""The simulator's report: ``events.jsonl`` and ``trajectory.png`` (map, paths, events)."""

from __future__ import annotations

import io
import itertools
import json
import math
from collections.abc import Iterable
from pathlib import Path
from typing import Any

import numpy as np

from hal.files import write_new
from sim.nav.report import draw_navigation
from sim.registry import distinct, slice_of
from sim.tracks import TrackPoint
from sim.world.dock import Dock
from sim.world.floor_plan import World
from sim.world.geometry import FloatArray, raycast

_EVENT_MARKERS = {
    "collision": ("x", "red"),
    "script": ("v", "black"),
    "estop": ("X", "crimson"),
    "link": ("s", "darkorange"),
    "deadman": ("P", "firebrick"),
    "arrival": ("*", "gold"),
}


def event_line(event: dict[str, Any]) -> str:
    """One event as a JSON line: ``t`` and ``kind`` first, other fields sorted, floats rounded."""
    head = {"t": round(float(event["t"]), 6), "kind": event["kind"]}
    rest = {k: _round(v) for k, v in sorted(event.items()) if k not in ("t", "kind")}
    return json.dumps(head | rest, separators=(",", ":"), default=str)


def write_events(path: Path, events: Iterable[dict[str, Any]]) -> None:
    """One JSON line an event, never written through a link placed at ``path``."""
    text = "".join(event_line(event) + "\n" for event in events)
    write_new(path, text.encode("utf-8"))


def _round(value: Any) -> Any:
    if isinstance(value, float):
        return round(value, 6) if math.isfinite(value) else str(value)
    if isinstance(value, dict):
        return {k: _round(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_round(v) for v in value]
    return value


_BEAM_COLOURS = {"force_field": "#9b59b6", "front_left": "#e74c3c", "front_right": "#27ae60",
                 "far_left": "#f5b7b1", "far_right": "#abebc6", "centre": "#f1c40f"}


def _draw_dock(ax: Any, dock: Dock, walls: FloatArray) -> None:
    """The dock's beams as translucent sectors cut off by the walls (widest underneath),
    its body and its pads."""
    from matplotlib.patches import Polygon

    for beam in sorted(dock.beams, key=lambda b: -b.range_m * b.half_angle_deg):
        x, y = beam.apex(dock.pose)
        colour = _BEAM_COLOURS.get(beam.name, "#95a5a6")
        middle = dock.heading_rad + math.radians(beam.centre_deg)
        half = math.radians(min(beam.half_angle_deg, 180.0))
        angles = np.linspace(middle - half, middle + half, 121)
        reach = raycast(walls, x, y, angles, beam.range_m)
        outline = [(x, y), *zip((x + reach * np.cos(angles)).tolist(),
                                (y + reach * np.sin(angles)).tolist(), strict=True)]
        ax.add_patch(Polygon(outline, closed=True, facecolor=colour, edgecolor=colour,
                             alpha=0.22, lw=0.8, zorder=0.5,
                             label=f"beam {beam.name} ({beam.code})"))
    pose = dock.pose
    half = dock.width_m / 2
    corners = [pose.to_world(0.0, -half), pose.to_world(-dock.depth_m, -half),
               pose.to_world(-dock.depth_m, half), pose.to_world(0.0, half)]
    ax.add_patch(Polygon(corners, closed=True, facecolor="#2e7d32", edgecolor="black",
                         lw=1.0, zorder=3, label="dock"))
    pads = dock.pads()[0]
    ax.plot([pads[0], pads[2]], [pads[1], pads[3]], color="gold", lw=3, zorder=3.5)


def draw_trajectory(
    path: Path,
    world: World,
    tracks: dict[str, list[TrackPoint]],
    events: list[dict[str, Any]],
    title: str,
    profiles: tuple[str, ...] = (),
) -> None:
    """Draw the floor plan, each robot's path coloured by state, and the marked events;
    the report layers of the robots' ``profiles`` (their simulator slices) on top."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.patches import Rectangle

    fig, ax = plt.subplots(figsize=(11.5, 9 * world.height_m / max(world.width_m, 1e-6) + 0.6))
    for room in world.rooms:
        ax.add_patch(Rectangle((room.x_min_m, room.y_min_m), room.x_max_m - room.x_min_m,
                               room.y_max_m - room.y_min_m, facecolor="#f2f2ec",
                               edgecolor="#c8c8c0", lw=0.8, zorder=0))
        ax.text(room.x_min_m + 0.05, room.y_max_m - 0.05, room.name, va="top", fontsize=8,
                color="#777")
    for name, zone in world.zones.items():
        ax.add_patch(Rectangle((zone.x_min_m, zone.y_min_m), zone.x_max_m - zone.x_min_m,
                               zone.y_max_m - zone.y_min_m, facecolor="#e4f0ff",
                               edgecolor="#88a", lw=0.8, ls="--", zorder=0))
        ax.text(zone.x_min_m + 0.05, zone.y_min_m + 0.05, name, fontsize=8, color="#557")
    mapped = world.walls.shape[0] - world.unmapped_walls
    for i, (x1, y1, x2, y2) in enumerate(world.walls):
        # Walls the robot's map lacks (furniture, a door shut by the script) in brown.
        ax.plot([x1, x2], [y1, y2], color="#333" if i < mapped else "#8e5b2a", lw=2.5,
                solid_capstyle="round", zorder=2,
                label="not on the robot's map (furniture, shut doors)" if i == mapped else None)
    for line in world.lines:
        b, g, r = line.bgr
        xs = [p[0] for p in line.points] + ([line.points[0][0]] if line.closed else [])
        ys = [p[1] for p in line.points] + ([line.points[0][1]] if line.closed else [])
        ax.plot(xs, ys, color=(r / 255, g / 255, b / 255), lw=max(1.5, line.width_m * 120),
                alpha=0.55, zorder=1, label=f"line {line.name} ({line.colour})")
    for beacon in world.beacons:
        ax.plot(beacon.x_m, beacon.y_m, marker="^", color="tab:blue", ms=8, zorder=3)
        ax.annotate(beacon.room or beacon.mac[-5:], (beacon.x_m, beacon.y_m), fontsize=7,
                    xytext=(4, 4), textcoords="offset points", color="tab:blue")
    if world.dock is not None:
        _draw_dock(ax, world.dock, world.walls)
    draw_navigation(ax, world, events)
    for layer in distinct(layer for p in profiles for layer in slice_of(p).layers):
        layer(ax, world, events)
    for person in world.people:
        ax.plot(person.x_m, person.y_m, marker="o", color="purple", ms=9, zorder=3)

    states = sorted({p.state for points in tracks.values() for p in points})
    # Up to 10 states in tab10's strong colours; more (the vacuum has 21) in tab20's 20.
    cmap, hues = (plt.get_cmap("tab10"), 10) if len(states) <= 10 else (plt.get_cmap("tab20"), 20)
    colour = {s: cmap(i % hues) for i, s in enumerate(states)}
    dashed = {s for i, s in enumerate(states) if i >= hues}  # past the colours: dashed too
    styles = ["-", "--", ":", "-."]
    labelled: set[str] = set()
    halo = plt.get_cmap("Set2")
    for index, (robot, points) in enumerate(tracks.items()):
        style = styles[index % len(styles)]
        if len(tracks) > 1 and points:
            # Each robot's own band under its state colours, each next one narrower and on top:
            # two robots on one loop show as a stripe within a stripe where both drove.
            ax.plot([p.x_m for p in points], [p.y_m for p in points], color=halo(index % 8),
                    lw=9 - 3 * (index % 3), alpha=0.6, zorder=3.5 + 0.1 * index,
                    solid_capstyle="round", label=f"band of {robot}")
        for state in states:
            px: list[float] = []
            py: list[float] = []
            for a, b2 in itertools.pairwise(points):
                if a.state == state:
                    px += [a.x_m, b2.x_m, math.nan]
                    py += [a.y_m, b2.y_m, math.nan]
            if px:
                label = None if state in labelled else (state or "-")
                labelled.add(state)
                ax.plot(px, py, color=colour[state], lw=1.8, zorder=4, label=label,
                        ls="--" if state in dashed and len(tracks) == 1 else style)
        if points:
            ax.plot(points[0].x_m, points[0].y_m, marker="o", mfc="white", mec="black", ms=7,
                    zorder=5)
            ax.plot(points[-1].x_m, points[-1].y_m, marker="o", color="black", ms=5, zorder=5)
            if len(tracks) > 1:
                ax.plot([], [], color="black", ls=style, label=f"path of {robot}")
                ax.annotate(robot, (points[-1].x_m, points[-1].y_m), fontsize=7,
                            xytext=(4, 6 + 8 * index), textcoords="offset points")

    seen: set[str] = set()
    notes_at: dict[tuple[float, float], int] = {}
    for event in events:
        kind = str(event.get("kind"))
        if kind not in _EVENT_MARKERS or "x_m" not in event or "y_m" not in event:
            continue
        marker, col = _EVENT_MARKERS[kind]
        # An arrival is where a script acts too (the load comes in): its star is drawn large,
        # outlined and underneath, so both show.
        big = kind == "arrival"
        # Link markers are hollow and underneath: a script step or a deadman stop at the same
        # spot (unplugging the board is both) shows through them.
        hollow = kind == "link"
        ax.plot(event["x_m"], event["y_m"], marker=marker, color=col, ms=20 if big else 10,
                mec="black" if big else col, mew=0.8 if big else 1.5 if hollow else 1.0,
                mfc="none" if hollow else col,
                zorder=5.5 if big else 5.8 if hollow else 7,
                label=None if kind in seen else kind, ls="none")
        seen.add(kind)
        note = event.get("action") or event.get("state") or ""
        if note:
            spot = (round(float(event["x_m"]), 1), round(float(event["y_m"]), 1))
            stacked = notes_at.get(spot, 0)
            notes_at[spot] = stacked + 1
            ax.annotate(str(note), (event["x_m"], event["y_m"]), fontsize=7,
                        xytext=(6, -10 - 9 * stacked), textcoords="offset points", color=col)

    ax.set_xlim(world.x_min_m - 0.1, world.x_min_m + world.width_m + 0.1)
    ax.set_ylim(world.y_min_m - 0.1, world.y_min_m + world.height_m + 0.1)
    ax.set_aspect("equal")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.set_title(title, fontsize=10)
    ax.grid(True, color="#eee", lw=0.5)
    handles, _labels = ax.get_legend_handles_labels()
    ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=7, framealpha=0.85,
              ncol=2 if len(handles) > 28 else 1)
    fig.tight_layout()
    png = io.BytesIO()
    fig.savefig(png, format="png", dpi=110, bbox_inches="tight")  # a long legend kept whole
    plt.close(fig)
    write_new(path, png.getvalue())
