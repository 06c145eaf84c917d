"""A map as ``map_saver`` writes it: a trinary PGM (0 occupied, 254 free, 205 unknown) and YAML.

The YAML's thresholds are ROS 1 ``map_saver``'s, 0.65 and 0.196: with Nav2's 0.25 a pixel of
205 (occ = 50 / 255 = 0.196) would read back as free, and the unknown space around a map that
was made by driving would be planned through. Read back by ``hal.occupancy_map`` (as Nav2's
``map_server`` reads it), every cell is what was written.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from hal.occupancy_map import FREE, OCCUPIED, OccupancyMap

PIXEL_OCCUPIED = 0
PIXEL_FREE = 254
PIXEL_UNKNOWN = 205
OCCUPIED_THRESH = 0.65
FREE_THRESH = 0.196


def write_map(occupancy: OccupancyMap, out: str | Path) -> Path:
    """Writes ``OUT.pgm`` and ``OUT.yaml`` (``out`` without a suffix, or with ``.yaml``);
    returns the YAML's path."""
    base = Path(out)
    if base.suffix in (".yaml", ".pgm"):
        base = base.with_suffix("")
    base.parent.mkdir(parents=True, exist_ok=True)
    rows, cols = occupancy.height, occupancy.width
    pixels = np.full((rows, cols), PIXEL_UNKNOWN, dtype=np.uint8)
    pixels[occupancy.cells == FREE] = PIXEL_FREE
    pixels[occupancy.cells == OCCUPIED] = PIXEL_OCCUPIED
    pixels = pixels[::-1]  # image row 0 is the map's top
    pgm = base.with_name(base.name + ".pgm")
    pgm.write_bytes(f"P5\n# CREATOR: robotd map {occupancy.resolution_m:.3f} m/pix\n"
                    f"{cols} {rows}\n255\n".encode("ascii") + pixels.tobytes())
    yaml = base.with_name(base.name + ".yaml")
    yaml.write_text(
        f"image: {pgm.name}\nmode: trinary\nresolution: {occupancy.resolution_m}\n"
        f"origin: [{occupancy.origin_x_m}, {occupancy.origin_y_m}, 0]\nnegate: 0\n"
        f"occupied_thresh: {OCCUPIED_THRESH}\nfree_thresh: {FREE_THRESH}\n", encoding="ascii")
    return yaml
