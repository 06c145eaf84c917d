"""The simulated world's walls as the robot's map file: a ``map_server`` PGM + YAML.

``map.file = "walls"`` in a simulated robot's config means "the map a survey of this world
would give": the world's walls rasterised at ``map.resolution_m`` (boxes marked
``mapped = false`` left out: furniture moved in since the map was made). The rig writes it
to a temporary directory and points ``map.file`` there, so the robot reads its map exactly
as it would on the real robot, through ``behaviours.nav.map_file``.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from behaviours.nav.grid import Grid
from sim.world.floor_plan import World

FREE = 254
OCCUPIED = 0


def write_walls_map(world: World, directory: Path, resolution_m: float,
                    name: str = "walls") -> Path:
    """Writes ``name.pgm`` and ``name.yaml`` for the world's mapped walls; returns the YAML."""
    grid = Grid.from_segments(world.mapped_walls().tolist(), resolution_m)
    return write_grid_map(grid, directory, name)


def write_grid_map(grid: Grid, directory: Path, name: str) -> Path:
    """A ``Grid`` as map_saver writes a trinary map (row 0 of the image is the top)."""
    pixels = np.where(grid.occupied, OCCUPIED, FREE).astype(np.uint8)[::-1]
    rows, cols = pixels.shape
    pgm = directory / f"{name}.pgm"
    pgm.write_bytes(f"P5\n{cols} {rows}\n255\n".encode("ascii") + pixels.tobytes())
    yaml = directory / f"{name}.yaml"
    yaml.write_text(
        f"image: {pgm.name}\nmode: trinary\nresolution: {grid.resolution_m}\n"
        f"origin: [{grid.origin_x_m}, {grid.origin_y_m}, 0.0]\nnegate: 0\n"
        "occupied_thresh: 0.65\nfree_thresh: 0.25\n", encoding="ascii")
    return yaml
