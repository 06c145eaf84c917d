"""A map written as map_saver writes it reads back cell for cell."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from behaviours.nav.mapping.map_save import write_map
from hal.occupancy_map import FREE, OCCUPIED, UNKNOWN, OccupancyMap, read_map_yaml


class TestWriteMap:
    def test_reads_back_the_same_cells_unknown_included(self, tmp_path: Path) -> None:
        """Occupied, free and unknown survive the PGM and the YAML's thresholds."""
        cells = np.array([[OCCUPIED, FREE, UNKNOWN], [FREE, FREE, OCCUPIED]], dtype=np.int8)
        yaml = write_map(OccupancyMap(cells, 0.05, -1.5, 2.0), tmp_path / "site" / "made")
        back = read_map_yaml(yaml)
        assert back.cells.tolist() == cells.tolist()
        assert (back.resolution_m, back.origin_x_m, back.origin_y_m) == (0.05, -1.5, 2.0)
        assert (tmp_path / "site" / "made.pgm").read_bytes().startswith(b"P5\n")
