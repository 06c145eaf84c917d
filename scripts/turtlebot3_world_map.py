"""Write sim/maps/turtlebot3_world.pgm, as map_saver would have saved it.

The YAML beside it is ROBOTIS' own (turtlebot3_navigation2/map/map.yaml, Apache-2.0): 384 x 384
cells of 0.05 m, origin (-10, -10). The PGM bytes of their map.pgm were not available to us, so
this draws the same world (turtlebot3_gazebo/models/turtlebot3_world/model.sdf): the nine
pillars exactly (radius 0.15 m at -1.1, 0, 1.1 on both axes); the outer wall, a mesh whose
shape the SDF does not spell out, as a regular hexagon (two sides facing +-x), 2.25 m from
the centre to each side, 0.10 m thick. Shades as map_saver writes them: 254 free, 0 occupied,
205 unknown.

Run: .venv/bin/python scripts/turtlebot3_world_map.py
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

SIZE = 384
RESOLUTION_M = 0.05
ORIGIN_M = -10.0
PILLARS = [(x, y) for x in (-1.1, 0.0, 1.1) for y in (-1.1, 0.0, 1.1)]
PILLAR_RADIUS_M = 0.15
INRADIUS_M = 2.25
WALL_M = 0.10


def hexagon_distance(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Largest projection on the side normals of a flat-topped hexagon (sides at +-x, 60 deg)."""
    normals = [(math.cos(a), math.sin(a)) for a in np.radians([0, 60, 120])]
    return np.max([np.abs(x * nx + y * ny) for nx, ny in normals], axis=0)


def main() -> None:
    centres = ORIGIN_M + (np.arange(SIZE) + 0.5) * RESOLUTION_M
    x, y = np.meshgrid(centres, centres[::-1])  # image row 0 is the top (highest y)
    d = hexagon_distance(x, y)
    image = np.full((SIZE, SIZE), 205, dtype=np.uint8)
    image[d < INRADIUS_M] = 254
    image[(d >= INRADIUS_M) & (d < INRADIUS_M + WALL_M)] = 0
    for px, py in PILLARS:
        image[np.hypot(x - px, y - py) <= PILLAR_RADIUS_M] = 0
    out = Path(__file__).resolve().parents[1] / "sim/maps/turtlebot3_world.pgm"
    header = f"P5\n# CREATOR: map_saver.cpp {RESOLUTION_M:.3f} m/pix\n{SIZE} {SIZE}\n255\n"
    out.write_bytes(header.encode() + image.tobytes())
    print(out)


if __name__ == "__main__":
    main()
