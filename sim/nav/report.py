"""The navigation layers of ``trajectory.png``: the robot's map, zones, estimated path, particles.

Drawn when the run has ``nav.pose`` events (a navigating robot): the robot's map as grey
cells under everything (the world's mapped walls rasterised as ``map.file = "walls"`` does,
or the world's ``map`` YAML), the zones it was given (``nav.zones``: keep-out cells hatched
red, speed zones tinted by their limit), the estimated path (dashed) beside the true one, the
particle clouds of the ``nav.particles`` events (a sample of the filter's particles at the
start, every so often, and when the filter diverged), each labelled with its time, and where
the filter was relocalised over the whole map.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import numpy.typing as npt

from behaviours.nav.grid import Grid
from behaviours.nav.zones import SpeedRule
from hal.occupancy_map import MapFileError, OccupancyMap, read_map_yaml
from sim.nav.checks import zones_of
from sim.world.floor_plan import World

_CLOUD_COLOURS = ("#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd", "#8c564b")


def robot_map(world: World, resolution_m: float = 0.05) -> Grid | None:
    """The grid a navigating robot in this world has as its map (None if it cannot)."""
    if world.map_source:
        try:
            return Grid.from_map(read_map_yaml(world.map_source))
        except MapFileError:
            return None
    if world.walls.shape[0] == 0:
        return None
    return Grid.from_segments(world.mapped_walls().tolist(), resolution_m)


def draw_navigation(ax: Any, world: World, events: list[dict[str, Any]]) -> None:
    """The map grid, the estimated path and the particle clouds onto ``ax``."""
    poses = [e for e in events if e.get("kind") == "nav.pose"]
    if not poses:
        return
    start = next((e for e in events if e.get("kind") == "nav.start"), {})
    grid = robot_map(world, float(start.get("map_resolution_m", 0.05)))
    if grid is not None:
        x0, y0 = grid.origin_x_m, grid.origin_y_m
        extent = (x0, x0 + grid.cols * grid.resolution_m, y0, y0 + grid.rows * grid.resolution_m)
        shade = np.where(grid.occupied, 0.55, np.nan)
        ax.imshow(shade, origin="lower", extent=extent, cmap="Greys", vmin=0, vmax=1,
                  alpha=0.7, zorder=1.5, interpolation="nearest")
        ax.plot([], [], marker="s", color="#8c8c8c", ls="none", label="robot's map (cells)")
    draw_zones(ax, events)
    for robot in sorted({str(e.get("robot", "")) for e in poses}):
        mine = [e for e in poses if str(e.get("robot", "")) == robot]
        ax.plot([e["est_x_m"] for e in mine], [e["est_y_m"] for e in mine], color="black",
                lw=1.0, ls=(0, (3, 2)), zorder=4.5,
                label=f"estimated path{' of ' + robot if robot else ''}")
    clouds = [e for e in events if e.get("kind") == "nav.particles"]
    for i, cloud in enumerate(clouds):
        pts = np.asarray(cloud.get("xy", []), dtype=np.float64).reshape(-1, 2)
        if pts.shape[0] == 0:
            continue
        colour = _CLOUD_COLOURS[i % len(_CLOUD_COLOURS)]
        ax.scatter(pts[:, 0], pts[:, 1], s=3, color=colour, alpha=0.6, zorder=4.8,
                   label=f"particles t={float(cloud['t']):.0f} s ({cloud.get('why', '')})")
    for e in events:
        if e.get("kind") in ("nav.relocalise", "nav.relocalised") and "x_m" in e:
            done = e["kind"] == "nav.relocalised"
            ax.plot(e["x_m"], e["y_m"], marker="D" if done else "o", ms=7, mfc="none",
                    mec="#2ca02c" if done else "#d62728", mew=1.6, ls="none", zorder=5.5,
                    label=("relocalised" if done else "lost: global search")
                    + f" t={float(e['t']):.0f} s")


def _extent(mask: OccupancyMap) -> tuple[float, float, float, float]:
    x0, y0 = mask.origin_x_m, mask.origin_y_m
    return (x0, x0 + mask.width * mask.resolution_m, y0, y0 + mask.height * mask.resolution_m)


def draw_zones(ax: Any, events: list[dict[str, Any]]) -> None:
    """The keep-out cells (red) and the speed zones (a blue tint, darker the slower, with
    each zone's limit written once) of the ``nav.zones`` event."""
    zones = zones_of(events)
    if zones is None:
        return
    for key in ("keepout_file", "speed_file"):
        path = zones.get(key)
        if not path:
            continue
        try:
            mask = read_map_yaml(str(path))
        except MapFileError:
            continue
        if key == "keepout_file":
            shade = np.where(mask.cells >= 100, 1.0, np.nan)
            ax.imshow(shade, origin="lower", extent=_extent(mask), cmap="Reds", vmin=0,
                      vmax=1.6, alpha=0.45, zorder=1.4, interpolation="nearest")
            ax.plot([], [], marker="s", color="#f4a29a", ls="none", label="keep-out zone")
            continue
        rule = SpeedRule(zones.get("speed_type") == "percent", float(zones["speed_base"]),
                         float(zones["speed_multiplier"]))
        limits = rule.limits(mask.cells.astype(np.int16))
        top = float(zones.get("speed_top_mps", 1.0))
        mps = top * limits / 100.0 if rule.percent else limits
        slow = np.where(np.isnan(limits), np.nan, 1.0 - np.clip(mps / top, 0.0, 1.0))
        ax.imshow(slow, origin="lower", extent=_extent(mask), cmap="Blues", vmin=-0.2,
                  vmax=1.0, alpha=0.35, zorder=1.3, interpolation="nearest")
        _label_speed_zones(ax, mask, limits, rule, top)


def _label_speed_zones(ax: Any, mask: OccupancyMap, limits: npt.NDArray[np.float64],
                       rule: SpeedRule, top: float) -> None:
    """Each speed limit's largest patch labelled at its middle ("50 %: 0.10 m/s")."""
    import cv2

    for value in np.unique(limits[~np.isnan(limits)]):
        region = (limits == value).astype(np.uint8)
        count, _labels, stats, centres = cv2.connectedComponentsWithStats(
            region, connectivity=4)
        if count < 2:
            continue
        big = 1 + int(np.argmax(stats[1:, cv2.CC_STAT_AREA]))
        if stats[big, cv2.CC_STAT_AREA] < 400:
            continue  # a wall's outline, not a zone
        cx, cy = centres[big]
        x = mask.origin_x_m + (cx + 0.5) * mask.resolution_m
        y = mask.origin_y_m + (cy + 0.5) * mask.resolution_m
        unit = "%" if rule.percent else " m/s"
        text = f"limit {value:g}{unit}"
        if rule.percent:
            text += f" = {rule.mps(float(value), top):.2f} m/s"
        ax.text(x, y, text, fontsize=7, color="#08306b", ha="center", va="center",
                zorder=6, bbox={"boxstyle": "round", "fc": "white", "alpha": 0.6, "lw": 0})
