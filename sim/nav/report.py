"""The navigation layers of ``trajectory.png``: the robot's map, estimated path, particles.

Drawn when the run has ``nav.pose`` events (a navigating robot): the robot's map as grey
cells under everything (the world's mapped walls rasterised as ``map.file = "walls"`` does,
or the world's ``map`` YAML), the estimated path (dashed) beside the true one, and the
particle clouds of the ``nav.particles`` events (a sample of the filter's particles at the
start, every so often, and when the filter diverged), each labelled with its time.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from behaviours.nav.grid import Grid
from hal.occupancy_map import MapFileError, read_map_yaml
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
