"""The pictures of ``bench_mapping.py --images DIR``: the map made, and its error image.

``mapping-depot.png``: the map made (grey unknown, white free, black occupied) with the true,
mapped and odometry trajectories of the key scans. ``mapping-depot-error.png``: the map made
against the depot's true cells, cell by cell: occupied within one cell of a true wall (green),
occupied away from any (red), free where the truth is a wall (orange), true walls not seen
(light grey).
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import cv2
import matplotlib
import matplotlib.pyplot as plt
import numpy as np

from hal.occupancy_map import FREE, OCCUPIED, OccupancyMap

matplotlib.use("Agg")

Pose = tuple[float, float, float]


def _extent(m: OccupancyMap) -> tuple[float, float, float, float]:
    return (m.origin_x_m, m.origin_x_m + m.width * m.resolution_m,
            m.origin_y_m, m.origin_y_m + m.height * m.resolution_m)


def _on_truth(made: OccupancyMap, true: OccupancyMap) -> np.ndarray:
    """The made map's cells resampled onto the true map's grid (-1 where it says nothing)."""
    out = np.full(true.cells.shape, -1, dtype=np.int16)
    rows, cols = np.indices(true.cells.shape)
    x = true.origin_x_m + (cols + 0.5) * true.resolution_m
    y = true.origin_y_m + (rows + 0.5) * true.resolution_m
    c = np.floor((x - made.origin_x_m) / made.resolution_m).astype(int)
    r = np.floor((y - made.origin_y_m) / made.resolution_m).astype(int)
    inside = (r >= 0) & (r < made.height) & (c >= 0) & (c < made.width)
    out[inside] = made.cells[r[inside], c[inside]]
    return out


def write_images(folder: str, made: OccupancyMap, true: OccupancyMap, truth: Sequence[Pose],
                 mapped: Sequence[Pose], odometry: Sequence[Pose],
                 figures: dict[str, Any], prefix: str = "mapping-depot",
                 drive: str = "drive") -> list[Path]:
    """``PREFIX.png`` (the map with the paths) and ``PREFIX-error.png`` (against the truth);
    ``drive`` names what made it in the title."""
    out = Path(folder)
    out.mkdir(parents=True, exist_ok=True)
    shade = np.full(made.cells.shape, 0.6)
    shade[made.cells == FREE] = 1.0
    shade[made.cells >= OCCUPIED] = 0.0
    fig, ax = plt.subplots(figsize=(12, 6.5))
    ax.imshow(shade, cmap="gray", origin="lower", extent=_extent(made), vmin=0, vmax=1)
    for poses, style, label in ((truth, "g-", "true path"), (mapped, "b--", "mapped"),
                                (odometry, "r:", "odometry alone")):
        ax.plot([p[0] for p in poses], [p[1] for p in poses], style, lw=1.2, label=label)
    mapping, odo = figures["mapping_all"], figures["odometry_all"]
    ax.set_title(f"The depot mapped from a {figures['distance_m']} m {drive}: relation error "
                 f"{mapping['cm']} cm / {mapping['deg']} deg (odometry alone {odo['cm']} cm), "
                 f"{figures['loops_closed']} loops closed")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.legend(loc="lower right", fontsize=8)
    fig.tight_layout()
    first = out / f"{prefix}.png"
    fig.savefig(first, dpi=110)
    plt.close(fig)

    seen = _on_truth(made, true)
    wall = (true.cells == OCCUPIED).astype(np.uint8)
    near = cv2.dilate(wall, np.ones((3, 3), np.uint8)).astype(bool)
    rgb = np.ones((*true.cells.shape, 3))
    rgb[wall.astype(bool)] = (0.85, 0.85, 0.85)
    occupied = seen >= OCCUPIED
    rgb[occupied & near] = (0.1, 0.6, 0.1)
    rgb[occupied & ~near] = (0.85, 0.1, 0.1)
    rgb[(seen == FREE) & wall.astype(bool)] = (1.0, 0.6, 0.0)
    quality = figures["mapping_map"]
    fig, ax = plt.subplots(figsize=(12, 6.5))
    ax.imshow(rgb, origin="lower", extent=_extent(true))
    ax.set_title(f"Map made vs the depot's true cells: {quality['occupied_near_wall_pct']} % "
                 f"of occupied cells within one cell of a wall (green; red: not), "
                 f"{quality['free_truly_free_pct']} % of free cells truly free "
                 f"(orange: free on a wall)", fontsize=9)
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    fig.tight_layout()
    second = out / f"{prefix}-error.png"
    fig.savefig(second, dpi=110)
    plt.close(fig)
    return [first, second]
